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
    "image_scrapers": ("matplotlib",),
    "matplotlib_animations": False,
    "show_memory": False,
    "abort_on_example_error": True,
}

os.environ.setdefault("MPLBACKEND", "Agg")


def _escape_bars(app, what, name, obj, options, lines):
    """Docstrings write |x| for absolute values and norms; in reStructuredText a pair of bars is a
    substitution reference. Escape them (no docstring of the package uses substitutions)."""
    for i, line in enumerate(lines):
        if "|" in line:
            lines[i] = line.replace("\\|", "|").replace("|", "\\|")


def setup(app):
    app.connect("autodoc-process-docstring", _escape_bars, priority=400)
