"""The gallery's image scraper for the package's figures.

``beamslider.plotting`` (and the study and design plots) build ``matplotlib.figure.Figure``
objects directly, without pyplot, so that they never change a global backend or keep figures
alive. sphinx-gallery's own scraper collects pyplot's figures only; this one collects, after each
code block, every ``Figure`` the example holds in a variable (``fig = plot_operating_point(...)``)
that no scraper has saved yet. docs/conf.py lists it before the matplotlib scraper (which closes pyplot's figures).
"""

from __future__ import annotations

from typing import Any

_SAVED = "_sphinx_gallery_saved"


def scrape(block: Any, block_vars: dict, gallery_conf: dict, **kwargs: Any) -> str:
    """Save the example's unsaved ``Figure`` objects as the block's images (reST)."""
    from matplotlib.figure import Figure
    from sphinx_gallery.scrapers import figure_rst

    figures = []
    for value in block_vars["example_globals"].values():
        if not isinstance(value, Figure) or getattr(value, _SAVED, False) or value in figures:
            continue
        if getattr(value.canvas, "manager", None) is not None:
            setattr(value, _SAVED, True)  # pyplot's: the matplotlib scraper, next, saves and closes it
            continue
        figures.append(value)
    paths = []
    for fig, path in zip(figures, block_vars["image_path_iterator"]):
        fig.savefig(path, **kwargs)
        setattr(fig, _SAVED, True)
        paths.append(path)
    return figure_rst(paths, gallery_conf["src_dir"]) if paths else ""
