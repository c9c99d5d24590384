"""The documentation site builds with warnings as errors (without running the gallery's examples,
which the full build runs), its page list is complete, the API reference lists every public
name, and the README stays short with every link resolving."""

from __future__ import annotations

import importlib
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
PACKAGES = ["beamslider", "beamslider.superslow", "beamslider.maps", "beamslider.study", "beamslider.design",
            "beamslider.enma", "beamslider.discover", "beamslider.cli"]
PAGES = ["index", "getting-started", "guide/simulation", "guide/superslow", "guide/maps", "guide/predictor",
         "guide/study", "guide/design", "guide/enma", "guide/discrepancy", "cluster", "model", "classify",
         "validation/index", "api/index", "cli", "development"]


def test_readme_is_short_and_its_links_resolve():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 250
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+:", target) or target.startswith("#"):
            continue
        assert (ROOT / target.split("#")[0]).exists(), f"README.md links to a missing file: {target}"


def test_every_page_of_the_site_exists():
    for page in PAGES:
        assert (DOCS / f"{page}.md").exists(), page


@pytest.mark.docs
def test_site_builds_without_warnings(tmp_path):
    pytest.importorskip("myst_parser")
    pytest.importorskip("furo")
    pytest.importorskip("sphinxarg")
    pytest.importorskip("sphinx_gallery")
    sphinx = pytest.importorskip("sphinx")
    if int(sphinx.__version__.split(".")[0]) < 8:
        pytest.skip("the site is built with Sphinx >= 8 (Python >= 3.11)")
    out = tmp_path / "html"
    r = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", "-D", "plot_gallery=0",
                        "-d", str(tmp_path / "doctrees"), str(DOCS), str(out)],
                       capture_output=True, text=True, timeout=900, env={**__import__("os").environ, "MPLBACKEND": "Agg"})
    assert r.returncode == 0, r.stderr[-5000:]
    # Every name of every public __all__ is in the API reference (listed on its module's page).
    from sphinx.util.inventory import InventoryFile

    with open(out / "objects.inv", "rb") as f:
        inv = InventoryFile.load(f, "", lambda base, uri: uri)
    names = {name for entries in inv.data.values() if hasattr(inv, "data") for name in entries} if hasattr(inv, "data") \
        else {name for entries in inv.values() for name in entries}
    missing = []
    for pkg in PACKAGES:
        mod = importlib.import_module(pkg)
        for name in mod.__all__:
            if f"{pkg}.{name}" in names:
                continue
            obj = getattr(mod, name)
            # classes shown on the top-level page without their members are indexed where defined
            canonical = f"{getattr(obj, '__module__', '')}.{getattr(obj, '__qualname__', name)}"
            if canonical not in names and not any(n.endswith(f".{name}") for n in names):
                missing.append(f"{pkg}.{name}")
    assert not missing, missing
    for page in PAGES:
        assert (out / f"{page}.html").exists(), page


@pytest.mark.docs
def test_every_gallery_example_shows_its_figure(tmp_path):
    """The gallery run as the full build runs it (its examples executed): each example's page
    has its figure, also where the package draws a ``matplotlib.figure.Figure`` without pyplot."""
    pytest.importorskip("sphinx_gallery")
    sphinx = pytest.importorskip("sphinx")
    if int(sphinx.__version__.split(".")[0]) < 8:
        pytest.skip("the site is built with Sphinx >= 8 (Python >= 3.11)")
    import runpy

    src = tmp_path / "src"
    src.mkdir()
    gallery_conf = runpy.run_path(str(DOCS / "conf.py"))["sphinx_gallery_conf"]
    (src / "conf.py").write_text(
        "import sys\n"
        f"sys.path.insert(0, {str(DOCS)!r})\n"
        "extensions = ['sphinx_gallery.gen_gallery']\n"
        f"sphinx_gallery_conf = {gallery_conf!r}\n", encoding="utf-8")
    (src / "index.rst").write_text("Gallery\n=======\n\n.. toctree::\n\n   gallery/index\n", encoding="utf-8")
    out = tmp_path / "html"
    r = subprocess.run([sys.executable, "-m", "sphinx", "-W", "-q", "-b", "html", str(src), str(out)],
                       capture_output=True, text=True, timeout=900, env={**__import__("os").environ, "MPLBACKEND": "Agg"})
    assert r.returncode == 0, r.stderr[-5000:]
    examples = sorted(p.stem for p in (ROOT / "examples" / "gallery").glob("plot_*.py"))
    assert len(examples) >= 5
    for name in examples:
        page = (out / "gallery" / f"{name}.html").read_text(encoding="utf-8")
        assert re.search(rf'<img [^>]*src="[^"]*sphx_glr_{name}_\d+\.png"', page), f"{name}: no figure on its gallery page"
