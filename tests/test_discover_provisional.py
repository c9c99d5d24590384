"""The provisional answer (docs/model.md §9.1, "Provisional answer"): the tiered search's leading
candidate written to report.json and printed as soon as it is known, replaced by the verdict;
``--quick`` stops there. Also: discover's measured files read before anything is written."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from conftest import run_cli

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = str(next((ROOT / "examples" / "data").glob("*.txt.gz")))
FOUR = "friction_coefficient,com_offset,slider_mass,tilt"  # more than the screen's three: the tier runs


def test_quick_stops_at_the_leading_candidate(tmp_path):
    r = run_cli("discover", "--measured", SAMPLE, "--effects", FOUR, "--quick", "--out", "q", cwd=tmp_path,
                timeout=600)
    assert r.returncode == 0, r.stderr
    rep = json.loads((tmp_path / "q" / "report.json").read_text())
    assert rep["provisional"] is True and len(rep["leading"]) == 1
    (lead,) = rep["leading"]
    lo, hi = rep["intervals"][lead]
    assert lead in FOUR.split(",") and lo <= rep["values"][lead] <= hi
    assert rep["chi2"] < rep["chi2_before"] and rep["elapsed_s"] > 0
    assert "--quick: stopped here" in r.stdout and not (tmp_path / "q" / "report.md").exists()


@pytest.mark.heavy
def test_the_verdict_replaces_the_provisional_answer(tmp_path):
    r = run_cli("discover", "--measured", SAMPLE, "--effects", FOUR, "--out", "full", cwd=tmp_path, timeout=900)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    first = next(i for i, l in enumerate(lines) if l.startswith("provisional ("))
    assert "the search goes on" in lines[first]
    assert first < next(i for i, l in enumerate(lines) if l.startswith("verdict: "))
    rep = json.loads((tmp_path / "full" / "report.json").read_text())
    assert "provisional" not in rep and rep["verdict"] in ("none", "named", "confounded", "unexplained")


def test_a_measured_file_twice_or_unreadable_is_refused_before_anything_is_written(tmp_path):
    twice = run_cli("discover", "--measured", SAMPLE, SAMPLE, "--out", "o1", cwd=tmp_path)
    assert twice.returncode != 0 and "given twice" in twice.stderr
    bad = tmp_path / "Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt"
    bad.write_text("not a measurement\n")
    r = run_cli("discover", "--measured", str(bad), "--out", "o2", cwd=tmp_path)
    assert r.returncode != 0
    assert not (tmp_path / "o1").exists() and not (tmp_path / "o2").exists()
