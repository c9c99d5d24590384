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


def test_the_first_answer_is_the_scan_before_a_poor_singles_refinement():
    """search.tiered.leading (docs/model.md §9.1, "Provisional answer"): the first answer is the
    candidate's coordinate pass, fitted with the poor single's refinement off; the fit in full that
    follows is handed on too where it leads, and is the tier's fit. Later candidates are fitted once."""
    import dataclasses
    from types import SimpleNamespace

    from beamslider.discover.effects import EFFECTS
    from beamslider.discover.options import DiscoverOptions
    from beamslider.discover.provisional import Provisional
    from beamslider.discover.result import CandidateFit
    from beamslider.discover.search.tiered import leading

    def fitted(name, chi2):
        return CandidateFit((name,), {name: 0.2}, {name: 0.01}, chi2, 16, True, chi2, intervals={name: (0.18, 0.22)})

    asked = []

    def problem_fit(combo, refine=None, joint=None, options=None):
        asked.append(options)
        return fitted(combo[0].name, 30.0)  # the scan alone

    problem = SimpleNamespace(level="slider", options=DiscoverOptions(), fit=problem_fit, chi2_0=100.0,
                              gap_before=2.0, n=17)
    seen = []
    lead = Provisional(seen.append, problem, 0.0)
    full_fits = iter([fitted("friction_coefficient", 12.0), fitted("com_offset", 20.0)])
    f = leading(problem, lambda combo: next(full_fits), lead, EFFECTS["friction_coefficient"])
    assert f.chi2 == 12.0
    assert len(asked) == 1 and asked[0] == dataclasses.replace(DiscoverOptions(), poor_single_alpha=0.0)
    assert [a["chi2"] for a in seen] == [30.0, 12.0]
    g = leading(problem, lambda combo: next(full_fits), lead, EFFECTS["com_offset"])
    assert g.chi2 == 20.0 and len(asked) == 1 and len(seen) == 2  # fitted once; it does not lead


@pytest.mark.heavy
def test_the_provisional_answer_leaves_the_verdict_bitwise():
    """Handing on the provisional answer (the first fit's coordinate pass made before its fit in full)
    changes no value of the result: Discovery.to_json() equal with and without it, but the run time."""
    import beamslider as bs
    from beamslider import discover as dc

    data = [bs.read_measurement(SAMPLE)]
    seen = []
    a = dc.discover(measured=data, effects=FOUR.split(","), progress=False, on_provisional=seen.append).to_json()
    b = dc.discover(measured=data, effects=FOUR.split(","), progress=False).to_json()
    assert seen and seen[0]["provisional"] is True
    for d in (a, b):
        d.pop("runtime_s", None)
    assert json.dumps(a, sort_keys=True, default=str) == json.dumps(b, sort_keys=True, default=str)
