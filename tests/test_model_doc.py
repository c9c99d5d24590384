"""docs/model.md, the project's model specification, against the code: every field of
``beamslider.Parameters`` with the code's default, the generated table up to date, the stated
allowed ranges enforced by the core, and no reference left to the old, unshipped MODEL.md."""

from __future__ import annotations

import dataclasses
import importlib.util
import math
import re
from pathlib import Path

import pytest

import beamslider
from beamslider import _core
from beamslider.params import ALLOWED, SYMBOLS

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "model.md"


def _doc() -> str:
    return DOC.read_text(encoding="utf-8")


def _table_rows() -> dict:
    rows = {}
    for line in _doc().splitlines():
        m = re.match(r"^\| `([a-z0-9_]+)` \| (.*)$", line)
        if m:
            rows[m.group(1)] = [c.strip() for c in m.group(2).rstrip("|").split("|")]
    return rows


def test_every_parameter_appears_with_the_code_default():
    rows = _table_rows()
    defaults = beamslider.Parameters()
    for f in dataclasses.fields(beamslider.Parameters):
        assert f.name in rows, f"{f.name} missing from docs/model.md §1"
        cells = rows[f.name]
        shown = cells[3].strip("`")
        value = getattr(defaults, f.name)
        if isinstance(value, str):
            assert shown == f'"{value}"', (f.name, shown, value)
        else:
            assert float(shown) == value, (f.name, shown, value)
        assert cells[0] == SYMBOLS[f.name]
        assert cells[4] == ALLOWED[f.name]


def test_python_defaults_equal_the_rust_defaults():
    """The table is generated from the Python dataclass; the core's own defaults must agree."""
    rust = _core.Params.from_toml_text("").to_dict()
    py = beamslider.Parameters().to_dict()
    assert set(rust) == set(py)
    for k, v in py.items():
        assert rust[k] == v, k


def test_generated_table_is_up_to_date():
    spec = importlib.util.spec_from_file_location("gen_model_params", ROOT / "scripts" / "tooling" / "gen_model_params.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    text = _doc()
    assert gen.render(text) == text, "run python3 scripts/tooling/gen_model_params.py"


def _accepts(name: str, value) -> bool:
    try:
        beamslider.Parameters(**{name: value})
        return True
    except ValueError:
        return False


@pytest.mark.parametrize("name", [f.name for f in dataclasses.fields(beamslider.Parameters)])
def test_allowed_ranges_are_what_the_core_enforces(name):
    """Probe the core at the bounds the table states."""
    text = ALLOWED[name]
    default = getattr(beamslider.Parameters(), name)
    assert _accepts(name, default)
    if isinstance(default, str):
        assert not _accepts(name, "magic")
        return
    if "integer" in text:
        lo, hi = (1, 20) if "1..20" in text else (1, None)
        assert _accepts(name, lo) and not _accepts(name, lo - 1)
        if hi is not None:
            assert _accepts(name, hi) and not _accepts(name, hi + 1)
        return
    assert not _accepts(name, math.nan)
    if "finite" in text:
        assert not _accepts(name, math.inf)
    if "`inf` allowed" in text:
        assert _accepts(name, math.inf)
    if "> 0" in text:
        assert not _accepts(name, 0.0) and not _accepts(name, -default)
    if "≥ 0" in text:
        assert _accepts(name, 0.0) and not _accepts(name, -1e-3)
    if "> 1" in text:
        assert not _accepts(name, 1.0) and _accepts(name, 1.001)
    if "in [0, 1]" in text:
        assert _accepts(name, 0.0) and _accepts(name, 1.0) and not _accepts(name, 1.001) and not _accepts(name, -0.001)
    if "< `length_m`" in text:
        assert not _accepts(name, beamslider.Parameters().length_m)


def test_sections_cited_by_the_code_exist():
    headings = set(re.findall(r"^## (\d+)\.", _doc(), re.M))
    assert headings >= {str(i) for i in range(1, 10)}


def test_no_reference_to_the_unshipped_specification():
    """The README and --help texts cite docs/model.md, not a MODEL.md that a clone does not have."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    old = re.compile(r"(?<![/\w])MODEL\.md")
    assert not old.search(readme)
    from beamslider.cli import build_parser

    ap = build_parser()
    texts = [ap.format_help()]
    for action in ap._subparsers._group_actions:  # every subcommand's --help
        for sub in action.choices.values():
            texts.append(sub.format_help())
    assert not any(old.search(t) for t in texts)
