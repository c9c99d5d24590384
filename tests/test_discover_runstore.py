"""Discover's kept runs (beamslider.discover.runstore, docs/model.md §9.1 "Cost"): a run read back
is the run that was made, a discover run again on its runs makes none of them and gives the same
answer as a discover without kept runs, and a damaged or shared file loses nothing it held."""

from __future__ import annotations

import json

import pytest

import beamslider as bs
from beamslider import _core
from beamslider import discover as dc
from beamslider.discover.chain import Model
from beamslider.discover.models import batch_slider_features
from beamslider.discover.runstore import RunStore, code_fingerprint

from conftest import run_cli

OPS = [dc.OperatingPoint(124, 6, 0.3, 1.0)]


def _values(res):
    return [None if r is None else ({k: (f.value, f.stderr, f.unit, f.description) for k, f in r[0].items()}, r[1])
            for r in res]


def test_a_kept_run_is_read_back_as_it_was(tmp_path):
    """Features and behaviour of runs read from the file equal those of the runs made (bitwise),
    and nothing is run again; a failed run (None) is kept as failed."""
    p = bs.Parameters()
    models_ = [p, Model(p, (("excitation_gain", 0.9),)), bs.Parameters(friction_coefficient=0.3)]
    store = RunStore(tmp_path / "runs.jsonl")
    made = batch_slider_features(models_, OPS, cache=store)
    assert store.added == 3 and store.loaded == 0
    again = RunStore(tmp_path / "runs.jsonl")
    assert again.loaded == 3 and set(again) == set(store)
    calls = []
    real = _core.run_free_slider_batch

    def counting(jobs, **kw):
        calls.append(len(jobs))
        return real(jobs, **kw)

    mp_ = pytest.MonkeyPatch()
    mp_.setattr(_core, "run_free_slider_batch", counting)
    try:
        read = batch_slider_features(models_, OPS, cache=again)
    finally:
        mp_.undo()
    assert calls == [] and _values(read) == _values(made)
    fresh = batch_slider_features(models_, OPS)
    assert _values(read) == _values(fresh)
    again[("failed",)] = None
    assert RunStore(tmp_path / "runs.jsonl")[("failed",)] is None


def test_a_line_cut_short_or_of_other_code_is_skipped(tmp_path):
    """A line cut short by a killed process, a line of another code version and a foreign line are
    skipped; the next run appended after a cut line is read back."""
    f = tmp_path / "runs.jsonl"
    store = RunStore(f)
    batch_slider_features([bs.Parameters()], OPS, cache=store)
    good = f.read_text()
    other = json.loads(good)
    other["code"] = "0" * 16
    f.write_text(good + json.dumps(other) + "\n" + "not json\n" + good[: len(good) // 2])
    store = RunStore(f)
    assert store.loaded == 1
    batch_slider_features([bs.Parameters(friction_coefficient=0.25)], OPS, cache=store)
    assert RunStore(f).loaded == 2 and len(RunStore(f)) == 2
    # killed during its first write: the cut line is skipped, the next run read back
    g = tmp_path / "cut.jsonl"
    g.write_text(good[:100])
    store = RunStore(g)
    store[("k",)] = None
    assert RunStore(g).loaded == 1
    assert len(code_fingerprint()) == 16


WRITER = """
import sys, time
from beamslider.discover import Feature, RunStore
store = RunStore(sys.argv[1])
while time.time() < float(sys.argv[3]):  # both writers start together
    pass
for i in range(int(sys.argv[2]), int(sys.argv[2]) + 3000):
    store[(("x", float(i)),)] = ({"a": Feature("a", float(i), 0.0, "m", "d" * 2000)}, "b", None)
"""


def test_two_writers_of_one_file_lose_no_line(tmp_path):
    """Two processes appending to the same file (two discovers sharing their runs): every line is whole."""
    import subprocess
    import sys
    import time

    f = tmp_path / "runs.jsonl"
    start = time.time() + 5
    ps = [subprocess.Popen([sys.executable, "-c", WRITER, str(f), str(k * 10000), str(start)]) for k in range(2)]
    assert [p.wait(timeout=120) for p in ps] == [0, 0]
    store = RunStore(f)
    assert store.loaded == 6000 and sorted(k[0][1] for k in store) == [float(i) for i in range(3000)] + [
        float(i) for i in range(10000, 13000)]
    assert all(len(r[0]["a"].description) == 2000 for r in store.values())
    # the writers' lines interleave (the test would not show anything otherwise)
    second = [json.loads(json.loads(line)["key"])[0][1] >= 10000 for line in f.read_text().splitlines()]
    assert sum(a != b for a, b in zip(second, second[1:])) > 1


def test_a_folder_a_foreign_file_or_an_unwritable_place_is_a_clear_error(tmp_path):
    """Refused before any run, and a file that is not a runs file is left as it was."""
    with pytest.raises(ValueError, match="is a folder"):
        RunStore(tmp_path)
    (tmp_path / "notes.md").write_text("# my notes\n\nnot runs\n")
    with pytest.raises(ValueError, match="not a file of runs"):
        RunStore(tmp_path / "notes.md")
    assert (tmp_path / "notes.md").read_text() == "# my notes\n\nnot runs\n"
    (tmp_path / "file").write_text("")
    with pytest.raises(ValueError, match="cannot (read|write) runs file"):
        RunStore(tmp_path / "file" / "runs.jsonl")


def test_a_discover_run_again_on_its_runs_makes_only_the_figures_runs_and_says_the_same(tmp_path, monkeypatch):
    """A slider-level discover with its runs kept, then again on the same file: the second makes no
    run but the few whose paths the report draws, and its answer (verdict, fits, values,
    intervals, advice) is that of a discover that keeps none."""
    paths = dc.synthesize_slider_runs(bs.Parameters(friction_coefficient=0.25), operating_points=[(124, 6, 0.3)],
                                      duration_s=4, out_dir=tmp_path / "data", seed=3, s0_offset=0.0015)
    runs = [bs.read_measurement(q) for q in paths]
    kw = dict(measured=runs, effects=["friction_coefficient", "restitution"], advice_grid=[(110, 10, 0.3)])
    plain = dc.discover(**kw).to_json()
    first = dc.discover(runs_file=tmp_path / "runs.jsonl", **kw).to_json()
    jobs = []
    real = _core.run_free_slider_batch

    def counting(j, **k):
        jobs.extend(j)
        return real(j, **k)

    monkeypatch.setattr(_core, "run_free_slider_batch", counting)
    store = RunStore(tmp_path / "runs.jsonl")
    second = dc.discover(runs_file=store, **kw).to_json()
    assert store.loaded > 20
    assert 0 < len(jobs) <= 2 and store.added == 0  # the paths of the baseline and the updated model, made again, not appended again
    for d in (first, second):
        d.pop("runtime_s")
    plain.pop("runtime_s")
    assert first == plain and second == plain


def test_the_command_keeps_its_runs_in_the_output_folder_unless_told(tmp_path):
    """``beamslider discover --measured`` keeps runs.jsonl in --out and says how many it reused;
    ``--runs none`` keeps none; ``--runs`` without runs to keep, or on a folder, is one line."""
    dc.synthesize_slider_runs(bs.Parameters(), operating_points=[(124, 6, 0.3)], duration_s=1,
                              out_dir=tmp_path / "data", seed=3)
    data = [str(q) for q in sorted((tmp_path / "data").iterdir())]
    base = ["discover", "--measured", *data, "--effects", "friction_coefficient", "--advice-grid", "none",
            "--no-progress"]
    r = run_cli(*base, "--out", "a", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "a" / "runs.jsonl").is_file() and "runs: 0 reused from" in r.stdout
    r = run_cli(*base, "--out", "a", "--force", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "runs: 0 reused" not in r.stdout and " reused from " in r.stdout
    r = run_cli(*base, "--out", "b", "--runs", "none", cwd=tmp_path)
    assert r.returncode == 0 and not (tmp_path / "b" / "runs.jsonl").exists(), r.stderr
    r = run_cli(*base, "--out", "c", "--runs", "data", cwd=tmp_path)
    assert r.returncode == 1 and "is a folder" in r.stderr and "Traceback" not in r.stderr, r.stderr
    r = run_cli("discover", "--runs", "x.jsonl", "--out", "d", cwd=tmp_path)
    assert r.returncode == 1 and "--runs" in r.stderr and "Traceback" not in r.stderr, r.stderr


def test_an_interrupted_discover_keeps_its_runs_and_the_next_goes_on_from_them(tmp_path):
    """Ctrl-C during a discover: exit 130 without a traceback, the runs made so far kept whole in
    runs.jsonl; the discover run again reuses every one of them."""
    import os
    import signal
    import subprocess
    import time

    from conftest import cli_command, default_signals

    dc.synthesize_slider_runs(bs.Parameters(friction_coefficient=0.25), operating_points=[(124, 6, 0.3)],
                              duration_s=10, out_dir=tmp_path / "data", seed=3, s0_offset=0.0015)
    data = [str(q) for q in sorted((tmp_path / "data").iterdir())]
    argv = ["discover", "--measured", *data, "--effects", "friction_coefficient,restitution", "--advice-grid", "none",
            "--no-progress", "--out", "o"]
    p = subprocess.Popen([*cli_command(), *argv], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=dict(os.environ, MPLBACKEND="Agg"), preexec_fn=default_signals)
    runs = tmp_path / "o" / "runs.jsonl"
    t0 = time.time()
    while time.time() - t0 < 120 and p.poll() is None and not (runs.exists() and len(runs.read_bytes().splitlines()) >= 5):
        time.sleep(0.02)
    p.send_signal(signal.SIGINT)
    try:
        _, err = p.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        p.kill()
        raise
    assert p.returncode == 130 and "Traceback" not in err, err
    kept = RunStore(runs).loaded
    assert "runs made are kept in" in err and "the same command again goes on from them" in err, err
    assert kept >= 5 and not (tmp_path / "o" / "report.json").exists()
    r = run_cli(*argv, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert f"runs: {kept} reused from" in r.stdout, r.stdout
    assert f"runs: {kept} kept runs read from" in r.stdout.splitlines()[0], r.stdout  # said before it goes on
    made = int(next(l for l in r.stdout.splitlines() if " reused from " in l).rsplit(", ", 1)[1].split()[0])
    assert RunStore(runs).loaded == kept + made  # nothing appended twice


def test_the_fingerprint_covers_the_run_making_sources_only():
    """Kept runs survive a change of the search or the rule (they do not make runs) and are
    refused after a change of the feature extractor (it does)."""
    from pathlib import Path

    from beamslider.discover import runstore

    root = Path(runstore.__file__).resolve().parent.parent
    assert all((root / rel).is_file() for rel in runstore.RUN_SOURCES)
    assert "discover/features.py" in runstore.RUN_SOURCES and "discover/models.py" in runstore.RUN_SOURCES
    assert not any(rel.endswith(("workflow.py", "rule.py", "report.py")) or "/search/" in rel for rel in runstore.RUN_SOURCES)


def test_a_run_made_again_for_its_path_is_not_appended_twice(tmp_path):
    """The report's figure makes again the runs read back without their slider path; the file keeps
    each run once (a discover run again on its kept runs appends nothing it holds)."""
    from beamslider.discover.models import slider_paths

    f = tmp_path / "runs.jsonl"
    batch_slider_features([bs.Parameters()], OPS, cache=RunStore(f))
    lines = f.read_text().count("\n")
    again = RunStore(f)
    slider_paths([bs.Parameters()], OPS, cache=again)  # remakes the path-less run
    assert again.added == 0 and f.read_text().count("\n") == lines


def test_runs_of_a_code_entered_in_the_lineage_are_taken_over(tmp_path, monkeypatch):
    """A run kept by an older code is reused only where the lineage enters this code as making the
    same runs (docs/model.md §9.1, "Kept runs"): an unlisted digest stays refused, and the chain is
    followed back."""
    from beamslider.discover import lineage

    f = tmp_path / "runs.jsonl"
    batch_slider_features([bs.Parameters()], OPS, cache=RunStore(f))
    line = json.loads(f.read_text())
    line["code"] = "a" * 16
    f.write_text(json.dumps(line) + "\n")
    assert RunStore(f).loaded == 0
    monkeypatch.setattr(lineage, "RUNS", {code_fingerprint(): ("b" * 16, "checked"), "b" * 16: ("a" * 16, "checked")})
    assert RunStore(f).loaded == 1
    assert lineage.accepted(code_fingerprint(), lineage.RUNS) == {code_fingerprint(), "a" * 16, "b" * 16}
    assert lineage.accepted("c" * 16, lineage.RUNS) == {"c" * 16}


def test_runs_read_with_other_options_are_kept_apart(tmp_path):
    """The features' reading (smoothing, segments, floors) is an option; a run read otherwise has a
    key of its own, so that neither reading is taken for the other; the defaults keep the keys the
    runs were kept under before."""
    from beamslider.discover.options import DiscoverOptions

    store = RunStore(tmp_path / "runs.jsonl")
    floors = tuple((n, k, v * 10) for n, k, v in DiscoverOptions().feature_floors)
    wide = DiscoverOptions(feature_floors=floors)
    (a,), (b,) = (batch_slider_features([bs.Parameters()], OPS, cache=store, options=o) for o in (DiscoverOptions(), wide))
    assert store.added == 2 and sum(len(k) == 6 for k in store) == 1
    name = next(k for k in a[0] if k.startswith("speed_late"))
    assert b[0][name].value == a[0][name].value and b[0][name].stderr >= 10 * 2e-4  # the floor × 10
    again = RunStore(tmp_path / "runs.jsonl")
    (c,) = batch_slider_features([bs.Parameters()], OPS, cache=again, options=wide)
    assert again.added == 0 and c[0][name].stderr == b[0][name].stderr
