"""Sphinx configuration of the beamslider documentation site.

Build (from the repository root, with the extra ``docs`` installed)::

    python -m sphinx -W --keep-going -b html docs docs/_build/html

``-D plot_gallery=0`` skips running the gallery's examples (the test suite builds the site so).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "docs"))  # _ext

project = "beamslider"
author = "the beamslider authors"
copyright = "the beamslider authors (MIT licence)"
try:
    from importlib.metadata import version as _version

    release = _version("beamslider")
except Exception:  # pragma: no cover - the package is not installed
    release = "0.1.0"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "sphinxarg.ext",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = [
    "_build",
    "api/_data",
    "Thumbs.db",
    ".DS_Store",
    "gallery/*.ipynb",
    "gallery/*.py",
    "gallery/*.zip",
    "gallery/*.md5",
    "gallery/*.json",
]

myst_enable_extensions = ["dollarmath", "deflist", "colon_fence"]
myst_heading_anchors = 3
# Links to repository files outside docs/ (scripts, examples) point at the files themselves.
suppress_warnings = ["myst.xref_missing"] if os.environ.get("BEAMSLIDER_DOCS_LAX") else []

# API reference: every name of each module's __all__, with its signature; the type hints fill a
# Parameters / Returns field list for every function whose docstring has none.
autodoc_default_options = {"members": True, "undoc-members": True, "show-inheritance": True}
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_typehints_description_target = "all"
autodoc_preserve_defaults = True
autodoc_mock_imports: list = []
napoleon_numpy_docstring = True
napoleon_google_docstring = True
napoleon_use_rtype = False
napoleon_use_ivar = True
nitpicky = False

html_theme = "furo"
html_title = "beamslider"
html_static_path: list = []

sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples" / "gallery"),
    "gallery_dirs": "gallery",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    # The package's Figure objects (it makes them without pyplot), then pyplot's figures.
    "image_scrapers": ("_ext.gallery_figures.scrape", "matplotlib"),
    "matplotlib_animations": False,
    "show_memory": False,
    "abort_on_example_error": True,
}

os.environ.setdefault("MPLBACKEND", "Agg")


# The API pages document each module's functions and classes with automodule (which follows
# __all__); the constants of __all__ autodoc does not pick up by itself, so each page includes a
# list of them generated here from __all__ at every build (docs/api/_data/, not committed).
API_MODULES = {"beamslider": "beamslider", "superslow": "beamslider.superslow", "maps": "beamslider.maps",
               "study": "beamslider.study", "design": "beamslider.design", "enma": "beamslider.enma",
               "discover": "beamslider.discover", "cli": "beamslider.cli", "plotting": "beamslider.plotting"}


def _write_constant_lists() -> None:
    import importlib
    import inspect

    out = Path(__file__).resolve().parent / "api" / "_data"
    out.mkdir(exist_ok=True)
    for page, modname in API_MODULES.items():
        mod = importlib.import_module(modname)
        names = [n for n in getattr(mod, "__all__", [])
                 if not any(f(getattr(mod, n)) for f in (inspect.isclass, inspect.isroutine, inspect.ismodule))]
        text = ""
        if names:
            text = "Constants\n---------\n\n" + "".join(f".. autodata:: {modname}.{n}\n   :no-value:\n\n" for n in names)
        path = out / f"{page}.rst"
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")


_write_constant_lists()


def _escape_bars(app, what, name, obj, options, lines):
    """Docstrings write |x| for absolute values and norms; in reStructuredText a pair of bars is a
    substitution reference. Escape them (no docstring of the package uses substitutions)."""
    for i, line in enumerate(lines):
        if "|" in line:
            lines[i] = line.replace("\\|", "|").replace("|", "\\|")


def _describe_constants(app, what, name, obj, options, lines):
    """A constant without a doc comment would show its type's docstring (dict, tuple, ...): show
    its type and, when short, its value instead."""
    own = (getattr(obj, "__doc__", None) or "").strip().splitlines()
    first = next((ln.strip() for ln in lines if ln.strip()), None)
    if what in ("data", "attribute") and own and first == own[0].strip():
        text = repr(obj)
        lines[:] = [f"``{type(obj).__name__}``" + (f": ``{text}``" if len(text) <= 100 and "`" not in text else "")]


def setup(app):
    app.connect("autodoc-process-docstring", _describe_constants, priority=300)
    app.connect("autodoc-process-docstring", _escape_bars, priority=400)
