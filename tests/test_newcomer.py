"""What a newcomer on a fresh clone meets: the predictor's pages say one thing about other designs,
the drift law's out-of-range warning names the value outside, the classifier's reasons and the
discover report's figure titles print numbers as a person writes them, the folders the README's
commands create are ignored by git, and getting-started shows the labelled tables."""

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import beamslider

ROOT = Path(__file__).resolve().parent.parent


def test_the_predictor_pages_agree_on_other_designs():
    """The built-in law is a design law: a slider inside its box needs no new training, a changed
    beam (or a design outside the box) is predicted with a warning and fits a law of its own."""
    from beamslider.superslow import default_law

    inside = beamslider.Parameters(gap_ratio=1.1, slider_mass_kg=0.04)
    _law, note = default_law().law_for(inside)
    assert note is None or note == "", note
    _law, note = default_law().law_for(beamslider.Parameters(length_m=0.15))
    assert note, "a changed beam is outside what the built-in law covers"
    predictor = (ROOT / "docs" / "guide" / "predictor.md").read_text(encoding="utf-8")
    design = (ROOT / "docs" / "guide" / "design_law.md").read_text(encoding="utf-8")
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "another beam or slider (a `--params` TOML) needs its own" not in predictor
    for text in (predictor, design):
        assert "needs no new training" in text and "fit-law" in text
    assert "no new training" in readme


def test_the_out_of_range_warning_names_the_value_outside():
    from beamslider.superslow import predict

    r = predict(beamslider.Parameters(gap_ratio=1.3), f_ex=124, a_ex=14, s0=0.3)
    range_warnings = [w for w in r.warnings if "training range" in w]
    assert range_warnings, r.warnings
    assert re.search(r"(amp_rel|s|f_ex|a_ex) = [-0-9.e]+.*trained from", range_warnings[0]), range_warnings[0]


def test_a_classifier_reason_prints_the_drift_window_as_written():
    dt = 0.2
    t = np.arange(0, 40.0 + dt / 2, dt)
    s = 0.3 + 0.002 * t        # still creeping at the end
    a = np.full_like(t, 0.2)   # on a low level
    c = beamslider.classify(t, s, a)
    assert "in the last" in c.reason, c.reason
    assert not re.search(r"\d\.\d{6,}", c.reason), c.reason


def test_the_discover_slider_figure_is_titled_with_the_operating_point(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    import matplotlib.axes

    import beamslider.discover as dc
    from beamslider.discover.models import OperatingPoint
    from beamslider.discover.result import Because, Kind, Verdict

    titles = []
    real = matplotlib.axes.Axes.set_title
    monkeypatch.setattr(matplotlib.axes.Axes, "set_title", lambda ax, text, *a, **k: (titles.append(text), real(ax, text, *a, **k))[1])
    r = beamslider.simulate(f_ex=124, a_ex=14, s0=0.3, t_end=1.0)
    path = tmp_path / "Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt"
    beamslider.measurement.write_measurement(path, r.t, np.gradient(r.w, r.t), r.s)
    meas = beamslider.read_measurement(path)
    op = OperatingPoint(meas.f_ex, meas.a_ex, meas.s0, float(meas.t[-1]))

    class Stand:  # what write_report reads of a slider-level discover
        level = "slider"
        data = [meas]
        baseline = updated = beamslider.Parameters()
        parameters = {}
        features = {"s_final": {"z_before": 1.0, "z_after": 0.5}}
        paths = {"baseline": {op.tag: (r.t, r.s)}, "updated": {op.tag: (r.t, r.s)}}
        gap_before, gap_after, named_effects = 1.0, 0.5, []
        judgment = Verdict(Kind.NONE, Because.BASELINE_FITS)

        def to_json(self):
            return {}

    try:
        dc.write_report(Stand(), tmp_path / "rep")
    except (AttributeError, KeyError, TypeError):
        pass  # the stand-in lacks what later figures read; the slider figure is drawn by then
    assert "f_ex = 124 Hz, a_ex = 14 m/s², s₀ = 0.3" in titles, titles
    assert not any("124Hz" in t for t in titles), titles


def _out_folders(text: str):
    for block in re.findall(r"```sh\n(.*?)```", text, re.S):
        for line in block.splitlines():
            if not line.strip().startswith("beamslider ") or line.strip().startswith("beamslider --"):
                continue
            m = re.search(r"--out\s+(\S+)", line)
            yield (m.group(1) if m else "beamslider-out").split("/")[0]


def test_the_folders_the_readme_commands_create_are_ignored_by_git():
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    folders = set()
    for page in (ROOT / "README.md", ROOT / "docs" / "getting-started.md"):
        folders |= set(_out_folders(page.read_text(encoding="utf-8")))
    assert {"taste", "beamslider-out"} <= folders, folders
    for folder in sorted(folders):
        r = subprocess.run(["git", "check-ignore", "-q", f"{folder}/x.json"], cwd=ROOT)
        assert r.returncode == 0, f"{folder}/ (made by the README's commands) is not ignored by git"


def test_getting_started_shows_the_labelled_tables():
    text = (ROOT / "docs" / "getting-started.md").read_text(encoding="utf-8")
    assert ".to_pandas()" in text and ".to_xarray()" in text


def test_the_readme_timing_is_the_generated_one():
    """The README's test timing is what scripts/tooling/time_test_command.sh wrote into
    docs/results/timing/test_command.txt (not typed), with pytest's whole count (skipped too)."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"<!-- timing:begin[^\n]*-->\n(.*?)\n<!-- timing:end -->", readme, re.S).group(1)
    lines = (ROOT / "docs" / "results" / "timing" / "test_command.txt").read_text(encoding="utf-8").splitlines()
    line, reb = lines[1], lines[2] if lines[2].startswith("rebuild") else ""
    expected = f"From a clean clone: **{line}**" + (f"; {reb}" if reb else "") + \
        " ([docs/results/timing/test_command.txt](docs/results/timing/test_command.txt))."
    assert block == expected
    script = (ROOT / "scripts" / "tooling" / "time_test_command.sh").read_text(encoding="utf-8")
    pattern = re.search(r'PASSED=\$\(grep -Eo "([^"]+)"', script).group(1)
    summary = "==== 628 passed, 1 skipped, 4 deselected in 251.20s (0:04:11) ===="
    assert re.search(pattern, summary).group(0) == "628 passed, 1 skipped"  # ERE and Python's alike here
