"""Hardening (docs/guide/reliability.md): input files validated with one-line errors naming the
file and the key, half-right files refused instead of read with a default, counts derived from
user numbers bounded before a run, map results checked against their grid, a resume that never
narrows map.toml, and a short run of the property fuzzer of the input readers
(scripts/tooling/fuzz_inputs.py)."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

import beamslider
from beamslider import _toml
from beamslider.maps import map_config_toml, read_map
from beamslider.superslow import default_drift_law, load_drift_law, load_law
from conftest import default_signals, run_cli

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_LAW = ROOT / "python" / "beamslider" / "data" / "default_law.json"


def _one_line_error(r, *words):
    assert r.returncode == 1, (r.returncode, r.stderr[-2000:])
    assert "Traceback" not in r.stderr, r.stderr[-2000:]
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("beamslider: error:"), r.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def _law(tmp_path, name="law.json", **change):
    d = json.loads(DEFAULT_LAW.read_text())
    for k, v in change.items():
        if v is None:
            d.pop(k)
        else:
            d[k] = v
    path = tmp_path / name
    path.write_text(json.dumps(d))
    return path


# --- input files: one-line errors naming the file and the key -------------------------------


@pytest.mark.parametrize("key", ["x", "v", "k", "mean", "std", "lo", "hi", "points", "rho_c"])
def test_law_file_without_a_key_is_one_line_on_every_path(tmp_path, key):
    law = _law(tmp_path, **{key: None})
    with pytest.raises(ValueError, match=f"law.json lacks `{key}`"):
        load_drift_law(law)
    with pytest.raises(ValueError, match=f"lacks `{key}`"):
        load_law(law)
    r = run_cli("predict", "--law", str(law), "--f-ex", "124", "--a-ex", "14", "--out", "p", cwd=tmp_path)
    _one_line_error(r, "law.json", key)
    r = run_cli("map", "--predictor", str(law), "--f-ex", "124", "--a-ex", "14", "--out", "m", cwd=tmp_path)
    _one_line_error(r, "law.json", key)
    assert not (tmp_path / "m").exists() and not (tmp_path / "p").exists()


@pytest.mark.parametrize("change, words", [
    (dict(version=99), ["version 99", "newer"]),
    (dict(version="1"), ["version"]),
    (dict(stray=1), ["unknown key `stray`"]),
    (dict(x=5), ["x = 5"]),
    (dict(points=[1, 2]), ["points"]),
    (dict(k=True), ["k = True"]),
    (dict(features=3), ["features"]),
])
def test_half_right_law_files_are_refused(tmp_path, change, words):
    law = _law(tmp_path, **change)
    with pytest.raises(ValueError) as e:
        load_drift_law(law)
    for w in words + ["law.json"]:
        assert w in str(e.value)


def test_shipped_laws_still_load():
    assert default_drift_law().rho_c > 0
    from beamslider.superslow.design_law import DEFAULT_DESIGN_LAW_PATH, load_design_law

    assert len(load_design_law(DEFAULT_DESIGN_LAW_PATH).laws) >= 2


STUDY = """duration_s = 0.05
[uncertain.friction_coefficient]
low = 0.1
high = 0.3
"""


@pytest.mark.parametrize("extra, words", [
    ("levels = 3\n", ["levels"]),
    ("std = 3\n", ["does not use `std`"]),
    ("distribution = [1]\n", ["distribution"]),
])
def test_study_file_errors_are_one_line(tmp_path, extra, words):
    (tmp_path / "s.toml").write_text(STUDY + extra)
    r = run_cli("study", "--config", "s.toml", "--out", "o", cwd=tmp_path)
    _one_line_error(r, "s.toml", *words)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("text", ["garbage", "{}", "[1]", '{"address": 5}', "\xff\xfe"])
def test_scheduler_file_that_is_not_one_is_a_one_line_error(tmp_path, text):
    pytest.importorskip("distributed")
    (tmp_path / "sched.json").write_bytes(text.encode("latin-1"))
    r = run_cli("map", "--f-ex", "124", "--a-ex", "14", "--t-end", "0.01", "--scheduler-file", "sched.json",
                "--out", "o", cwd=tmp_path, timeout=60)
    _one_line_error(r, "sched.json")
    assert not (tmp_path / "o").exists()


def test_binary_config_file_is_named(tmp_path):
    (tmp_path / "bin.toml").write_bytes(b"duration_s = 1\n\xd0\xff\x00\x01")
    for cmd in ("map", "study", "design"):
        r = run_cli(cmd, "--config", "bin.toml", "--out", "o", cwd=tmp_path)
        _one_line_error(r, "bin.toml")


# --- map results checked against their grid; a resume never narrows map.toml ---------------


@pytest.fixture(scope="module")
def small_map(tmp_path_factory):
    d = tmp_path_factory.mktemp("map")
    r = run_cli("map", "--f-ex", "120,124,128", "--a-ex", "14", "--t-end", "0.05", "-j", "2", "--out", "m", cwd=d)
    assert r.returncode == 0, r.stderr
    return d / "m"


def _copy(src: Path, dst: Path) -> Path:
    dst.mkdir()
    for f in src.iterdir():
        (dst / f.name).write_bytes(f.read_bytes())
    return dst


def _refused_extra_row(small_map, tmp_path, extra, message):
    """A copy of the small map with one more row (``extra(lines)``): read_map and a resumed
    ``beamslider map`` refuse it, naming line 5 (``message``: what read_map says)."""
    m = _copy(small_map, tmp_path / "m")
    lines = (m / "map.jsonl").read_text().splitlines(keepends=True)
    (m / "map.jsonl").write_text("".join(lines + [extra(lines)]))
    with pytest.raises(ValueError, match=message):
        read_map(m)
    r = run_cli("map", "--f-ex", "120,124,128", "--a-ex", "14", "--t-end", "0.05", "--resume", "--out", "m", cwd=tmp_path)
    _one_line_error(r, "map.jsonl:5")


def test_duplicated_map_row_is_refused_with_its_line(small_map, tmp_path):
    _refused_extra_row(small_map, tmp_path, lambda lines: lines[1], r"map.jsonl:5: a second row .*first on line 2")


def test_foreign_map_row_is_refused_with_its_line(small_map, tmp_path):
    def foreign(lines):
        row = json.loads(lines[1])
        row["f_ex_hz"] = 99.5
        return json.dumps(row) + "\n"

    _refused_extra_row(small_map, tmp_path, foreign, r"map.jsonl:5: a row of a point not on the map's grid .*f_ex = 99.5")


def test_resume_with_fewer_points_keeps_the_whole_grid_in_map_toml(small_map, tmp_path):
    m = _copy(small_map, tmp_path / "m")
    r = run_cli("map", "--f-ex", "120", "--a-ex", "14", "--t-end", "0.05", "--resume", "--out", "m", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    grid = _toml.loads((m / "map.toml").read_text())["grid"]
    assert grid["f_ex_hz"] == [120.0, 124.0, 128.0]
    assert len(read_map(m)["index"]) == 3


# --- counts derived from user numbers are bounded before the run ----------------------------


@pytest.mark.parametrize("kw, words", [
    (dict(t_end=1e300), ["t_end", "1e+300", "limit of 1e+11"]),
    (dict(t_end=1.0, params=dict(dt_s=1e-300)), ["t_end", "limit of 1e+11"]),
    (dict(f_ex=1e-200), ["f_ex_hz", "1e-200", ">= 0.001 Hz"]),
])
def test_absurd_durations_and_rates_are_refused_by_name(kw, words):
    kw = dict(kw)
    params = kw.pop("params", None)
    args = {**dict(f_ex=124.0, a_ex=14.0, t_end=0.01), **kw}
    if params:
        args["params"] = beamslider.Parameters(**params)
    with pytest.raises(ValueError) as e:
        beamslider.simulate(**args)
    for w in words:
        assert w in str(e.value), (w, str(e.value))


def test_absurd_values_are_printed_short(tmp_path):
    r = run_cli("simulate", "--f-ex", "1e300", "--a-ex", "14", "--t-end", "0.01", "--out", "o", cwd=tmp_path)
    line = _one_line_error(r, "f_ex_hz", "1e300")
    assert len(line) < 300 and "0000000000" not in line


def test_map_with_absurd_duration_or_record_every_is_refused_before_running(tmp_path):
    r = run_cli("map", "--t-end", "1e300", "--f-ex", "124", "--a-ex", "14", "--out", "o", cwd=tmp_path, timeout=60)
    _one_line_error(r, "duration_s", "1e300")
    text = map_config_toml(f_ex=[124.0], a_ex=[14.0], t_end=0.05).replace(
        "record_every = 20", "record_every = 100000000")
    (tmp_path / "re.toml").write_text(text)
    r = run_cli("map", "--config", "re.toml", "--out", "o2", cwd=tmp_path, timeout=60)
    _one_line_error(r, "record_every", "100000000", "record_every <= 5000")
    assert not (tmp_path / "o").exists() and not (tmp_path / "o2").exists()


# --- the property fuzzer, briefly (the full run: scripts/tooling/fuzz_inputs.py) -------------


@pytest.mark.parametrize("reader", ["law", "design_law", "map_config", "map_results", "study", "design"])
def test_input_readers_fuzzed_briefly(reader, tmp_path):
    pytest.importorskip("hypothesis")
    sys.path.insert(0, str(ROOT / "scripts" / "tooling"))
    try:
        import fuzz_inputs
    finally:
        sys.path.pop(0)
    assert fuzz_inputs.fuzz(reader, 150, seed=7, tmp=tmp_path, case_timeout=20.0) == 150


# --- one overwrite policy; signals leave no file under a final name -------------------------


def test_every_writer_refuses_to_replace_results_without_force(tmp_path):
    assert run_cli("synthesize", "enma", "--out", "syn", cwd=tmp_path).returncode == 0
    _one_line_error(run_cli("synthesize", "enma", "--out", "syn", cwd=tmp_path), "enma_data.csv", "--force")
    assert run_cli("synthesize", "enma", "--out", "syn", "--force", cwd=tmp_path).returncode == 0
    data = str(tmp_path / "syn" / "enma_data.csv")
    assert run_cli("enma", data, "--out", "e", cwd=tmp_path).returncode == 0
    _one_line_error(run_cli("enma", data, "--out", "e", cwd=tmp_path), "enma_updated.toml", "--force")
    assert run_cli("discover", "--enma", data, "--out", "d", cwd=tmp_path).returncode == 0
    _one_line_error(run_cli("discover", "--enma", data, "--out", "d", cwd=tmp_path), "updated.toml", "--force")
    assert run_cli("discover", "--enma", data, "--out", "d", "--force", cwd=tmp_path).returncode == 0


def test_refusal_says_the_earlier_run_did_not_finish(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    (out / "fs_124Hz_14ms2_s0_0p3.json").write_text(json.dumps({"kind": "simulation", "complete": False}))
    r = run_cli("simulate", "--f-ex", "124", "--a-ex", "14", "--t-end", "0.01", "--out", "o", cwd=tmp_path)
    _one_line_error(r, "did not finish", "--force")


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM", "SIGHUP"])
def test_signal_during_simulate_leaves_no_file_under_a_final_name(tmp_path, sig):
    import os
    import signal
    import subprocess
    import time

    from conftest import cli_command, default_signals

    env = dict(os.environ, MPLBACKEND="Agg")
    p = subprocess.Popen([*cli_command(), "simulate", "--f-ex", "124", "--a-ex", "14", "--t-end", "600", "--out", "o",
                          "--no-progress"], cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env, preexec_fn=default_signals)
    t0 = time.time()
    while time.time() - t0 < 60 and not any(f.name.startswith(".") for f in (tmp_path / "o").glob(".*partial*")):
        time.sleep(0.01)
    time.sleep(0.3)
    p.send_signal(getattr(signal, sig))
    err = p.communicate(timeout=60)[1]
    assert p.returncode == 128 + getattr(signal, sig), err
    assert "Traceback" not in err
    # no partial data, no manifold: only the summary that says the run did not finish
    assert sorted(f.name for f in (tmp_path / "o").iterdir()) == ["fs_124Hz_14ms2_s0_0p3.json"]
    assert json.loads((tmp_path / "o" / "fs_124Hz_14ms2_s0_0p3.json").read_text())["complete"] is False
    r = run_cli("simulate", "--f-ex", "124", "--a-ex", "14", "--t-end", "0.05", "--out", "o", cwd=tmp_path)
    _one_line_error(r, "did not finish", "--force")
    r = run_cli("simulate", "--f-ex", "124", "--a-ex", "14", "--t-end", "0.05", "--out", "o", "--force", cwd=tmp_path)
    assert r.returncode == 0, r.stderr


# --- progress in a log (standard error not a terminal) --------------------------------------


def test_long_commands_report_progress_in_a_log(tmp_path, monkeypatch, capsys):
    import os
    import subprocess

    from conftest import cli_command, default_signals

    env = dict(os.environ, MPLBACKEND="Agg", BEAMSLIDER_PROGRESS_INTERVAL_S="0")
    r = subprocess.run([*cli_command(), "map", "--f-ex", "120,124", "--a-ex", "14", "--t-end", "0.3", "-j", "1", "--out", "m"],
                       cwd=tmp_path, capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "beamslider: map 2/2 pts (100 %)" in r.stderr and "\r" not in r.stderr
    from beamslider.discover.progress import progress_bar

    monkeypatch.setenv("BEAMSLIDER_PROGRESS_INTERVAL_S", "0")
    bar = progress_bar(None, 4, "discover (slider): fits")  # what `discover --measured` gets in a job log
    bar.update(1)
    bar.close()
    assert "beamslider: discover (slider): fits 1/4 fit (25 %)" in capsys.readouterr().err


def test_a_discover_in_a_log_counts_its_runs_while_a_fit_is_made(tmp_path):
    """Between two fits done a discover's log still moves: its lines count the runs made so far, and
    once a fit is done they show the lowest χ² fitted so far with its value."""
    import os
    import re
    import subprocess

    import beamslider as bs
    import beamslider.discover as dc
    from conftest import cli_command

    dc.synthesize_slider_runs(bs.Parameters(friction_coefficient=0.25), operating_points=[(124, 6, 0.3)],
                              duration_s=4, out_dir=tmp_path / "data", seed=3, s0_offset=0.0015)
    data = [str(q) for q in sorted((tmp_path / "data").iterdir())]
    env = dict(os.environ, MPLBACKEND="Agg", BEAMSLIDER_PROGRESS_INTERVAL_S="0")
    r = subprocess.run([*cli_command(), "discover", "--measured", *data, "--effects", "friction_coefficient",
                        "--advice-grid", "none", "--runs", "none", "--out", "d"],
                       cwd=tmp_path, capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 0, r.stderr
    counts = [int(m) for m in re.findall(r"discover \(slider\): fits 0/1 fit \(0 %\), (\d+) runs made", r.stderr)]
    assert len(counts) >= 2 and counts == sorted(counts) and counts[-1] > counts[0], r.stderr
    best = re.findall(r"fits 1/1 fit \(100 %\), \d+ runs made, lowest chi2 so far ([0-9.e+-]+) "
                      r"\(friction_coefficient ([0-9.]+)\)", r.stderr)
    report = json.loads((tmp_path / "d" / "report.json").read_text())
    fitted = next(f for f in report["candidates"] if f["effects"] == ["friction_coefficient"])
    assert best and float(best[-1][1]) == pytest.approx(fitted["values"]["friction_coefficient"], rel=1e-4), r.stderr


def test_short_runs_stay_silent_in_a_log(tmp_path):
    r = run_cli("map", "--f-ex", "120", "--a-ex", "14", "--t-end", "0.3", "-j", "1", "--out", "m", cwd=tmp_path)
    assert r.returncode == 0 and "pts" not in r.stderr, r.stderr


# --- streamed outputs check the free space; a vanished output folder stops a map --------------


def test_streamed_run_larger_than_the_free_space_is_refused_before_writing(tmp_path, monkeypatch, capsys):
    import shutil
    from collections import namedtuple

    from beamslider.cli import main as cli_main

    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda _p: usage(10**9, 0, 10**6))
    assert cli_main(["simulate", "--f-ex", "124", "--a-ex", "14", "--t-end", "5", "--format", "csv",
                     "--out", str(tmp_path / "o")]) == 1
    err = capsys.readouterr().err
    assert "t_end" in err and "free" in err, err
    assert not (tmp_path / "o").exists()


def test_vanished_output_folder_stops_the_map_at_the_next_row(tmp_path):
    import os
    import shutil
    import subprocess
    import time

    from conftest import cli_command, default_signals

    env = dict(os.environ, MPLBACKEND="Agg")
    p = subprocess.Popen([*cli_command(), "map", "--f-ex", "100:130:2", "--a-ex", "14", "--t-end", "40", "-j", "1",
                          "--no-progress", "--out", "m"], cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                         text=True, env=env, preexec_fn=default_signals)
    results = tmp_path / "m" / "map.jsonl"
    t0 = time.time()
    while time.time() - t0 < 60 and not (results.exists() and len(results.read_text().splitlines()) >= 2):
        time.sleep(0.01)
    shutil.rmtree(tmp_path / "m")
    t1 = time.time()
    err = p.communicate(timeout=60)[1]
    assert p.returncode == 1 and "vanished" in err and "Traceback" not in err, err
    assert time.time() - t1 < 20  # at the next row, not at the end (16 points of about 1 s each)


# --- a cluster run survives its scheduler ------------------------------------------------------


def _rows(path):
    rows = [json.loads(ln) for ln in Path(path).read_text().splitlines()[1:] if ln.strip().endswith("}")]
    for r in rows:
        r.pop("wall_time_s")
    return sorted(rows, key=lambda r: (r.get("index", -1), r.get("key", "")))  # map and study rows by index, design rows by key


def _start_cluster(tmp_path, env):
    """A scheduler and one worker, each in a process of its own (the scheduler is then killed)."""
    import subprocess
    import time

    dask = Path(sys.executable).parent / "dask"
    sched_file = tmp_path / "sched.json"
    sched = subprocess.Popen([str(dask), "scheduler", "--scheduler-file", str(sched_file), "--port", "0",
                              "--dashboard-address", ":0"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    t0 = time.time()
    while not sched_file.exists() and time.time() - t0 < 60:
        time.sleep(0.1)
    worker = subprocess.Popen([str(dask), "worker", "--scheduler-file", str(sched_file), "--nthreads", "1"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    return sched, worker, sched_file


@pytest.mark.parametrize("victim", ["scheduler", "workers"])
def test_cluster_map_ends_when_the_cluster_is_lost_and_resumes_locally(tmp_path, victim):
    import os
    import subprocess
    import time

    pytest.importorskip("distributed")
    from conftest import cli_command, default_signals

    env = dict(os.environ, MPLBACKEND="Agg", BEAMSLIDER_CLUSTER_TIMEOUT_S="8")
    grid = ["--f-ex", "100:130:2", "--a-ex", "14", "--t-end", "6", "--no-progress"]
    sched, worker, sched_file = _start_cluster(tmp_path, env)
    try:
        p = subprocess.Popen([*cli_command(), "map", *grid, "--scheduler-file", str(sched_file), "--chunk-size", "2",
                              "--out", "m"], cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env, preexec_fn=default_signals)
        results = tmp_path / "m" / "map.jsonl"
        t0 = time.time()
        while time.time() - t0 < 120 and not (results.exists() and len(results.read_text().splitlines()) >= 3):
            time.sleep(0.05)
        (sched if victim == "scheduler" else worker).kill()
        t1 = time.time()
        try:
            err = p.communicate(timeout=120)[1]
        except subprocess.TimeoutExpired:
            p.kill()
            raise
        assert time.time() - t1 < 8 + 30  # the stated timeout, and the client's reconnect attempts (20 s)
    finally:
        for proc in (worker, sched):
            proc.kill()
            proc.wait()
    assert p.returncode == 1, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Dask cluster is lost" in lines[0] and "--resume" in lines[0], err
    kept = _rows(results)
    assert 0 < len(kept) < 16
    r = run_cli("map", *grid, "-j", "2", "--resume", "--out", "m", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    r = run_cli("map", *grid, "-j", "2", "--out", "full", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert _rows(results) == _rows(tmp_path / "full" / "map.jsonl")


def test_ctrl_c_on_a_cluster_map_whose_scheduler_died_exits_130_without_a_traceback(tmp_path):
    import os
    import signal
    import subprocess
    import time

    pytest.importorskip("distributed")
    from conftest import cli_command, default_signals

    # PYTHONFAULTHANDLER: a command that has not ended a minute after Ctrl-C is sent SIGABRT, which
    # prints every thread's stack into the failure message.
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONFAULTHANDLER="1")
    sched, worker, sched_file = _start_cluster(tmp_path, env)
    try:
        p = subprocess.Popen([*cli_command(), "map", "--f-ex", "100:130:2", "--a-ex", "14", "--t-end", "6", "--no-progress",
                              "--scheduler-file", str(sched_file), "--chunk-size", "2", "--out", "m"],
                             cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env, preexec_fn=default_signals)
        results = tmp_path / "m" / "map.jsonl"
        t0 = time.time()
        while time.time() - t0 < 120 and not (results.exists() and len(results.read_text().splitlines()) >= 3):
            time.sleep(0.05)
        sched.kill()  # the client now waits for it to come back
        time.sleep(2)
        p.send_signal(signal.SIGINT)
        try:
            err = p.communicate(timeout=60)[1]
        except subprocess.TimeoutExpired:
            p.send_signal(signal.SIGABRT)
            try:
                stacks = p.communicate(timeout=30)[1]
            except subprocess.TimeoutExpired:
                p.kill()
                stacks = p.communicate()[1]
            pytest.fail(f"still running 60 s after Ctrl-C; its threads:\n{stacks}")
    finally:
        for proc in (worker, sched):
            proc.kill()
            proc.wait()
    assert p.returncode == 130 and "Traceback" not in err, err


# --- kills of study and design runs: no partial file, the resume equals an uninterrupted run ----

KILL_STUDY = """duration_s = 3.0
[grid]
f_ex_hz = [120.0, 124.0]
a_ex_m_s2 = [14.0]
[study]
method = "lhs"
samples = 6
seed = 3
chunk_size = 2
[uncertain.friction_coefficient]
low = 0.2
high = 0.3
"""

KILL_DESIGN = """seed = 1
[design]
gap_ratio = [1.02, 1.3]
[band]
f_lo_hz = 120.0
f_hi_hz = 124.0
f_step_hz = 4.0
a_ex_m_s2 = [14.0]
s0 = [0.3]
t_end_s = 2.0
[optimiser]
popsize = 3
maxiter = 1
recheck = 0
"""


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    """The uninterrupted results of a command (``study`` or ``design``), each run once per test
    process and only if a test asks for it (with several pytest-xdist workers a worker may get the
    tests of one command only)."""
    d = tmp_path_factory.mktemp("full")
    done = set()

    def results(cmd: str) -> Path:
        if cmd not in done:
            (d / f"{cmd}.toml").write_text(KILL_STUDY if cmd == "study" else KILL_DESIGN)
            r = run_cli(cmd, "--config", f"{cmd}.toml", "--out", f"{cmd}-full", "--no-progress", cwd=d, timeout=600)
            assert r.returncode == 0, r.stderr
            done.add(cmd)
        return d / f"{cmd}-full" / f"{cmd}.jsonl"

    return results


@pytest.mark.parametrize("cmd", ["study", "design"])
@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM", "SIGKILL"])
def test_killed_study_or_design_resumes_to_the_uninterrupted_rows(tmp_path, uninterrupted, cmd, sig):
    import os
    import signal
    import subprocess
    import time

    from conftest import cli_command, default_signals

    (tmp_path / f"{cmd}.toml").write_text(KILL_STUDY if cmd == "study" else KILL_DESIGN)
    env = dict(os.environ, MPLBACKEND="Agg")
    args = [*cli_command(), cmd, "--config", f"{cmd}.toml", "--out", "o", "--no-progress"]
    p = subprocess.Popen(args, cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env,
                         preexec_fn=default_signals)
    results = tmp_path / "o" / f"{cmd}.jsonl"
    t0 = time.time()
    while time.time() - t0 < 120 and not (results.exists() and len(results.read_text().splitlines()) >= 3):
        time.sleep(0.01)
    p.send_signal(getattr(signal, sig))
    err = p.communicate(timeout=60)[1]
    assert p.returncode != 0 and "Traceback" not in err, err
    if sig != "SIGKILL":
        assert not [f.name for f in (tmp_path / "o").iterdir() if "partial" in f.name]
        assert p.returncode == (130 if sig == "SIGINT" else 128 + getattr(signal, sig)), err
    assert 0 < len(_rows(results)) < len(_rows(uninterrupted(cmd)))
    r = run_cli(cmd, "--config", f"{cmd}.toml", "--out", "o", "--resume", "--no-progress", cwd=tmp_path, timeout=600)
    assert r.returncode == 0, r.stderr
    assert not [f.name for f in (tmp_path / "o").iterdir() if "partial" in f.name]
    assert _rows(results) == _rows(uninterrupted(cmd))


@pytest.mark.parametrize("criteria, key", [
    ({"high_h": -1.0}, "high_h"), ({"steady_window_s": 0.0}, "steady_window_s"), ({"low_h": 0.5}, "low_h"),
    ({"jump_ratio": 0.5}, "jump_ratio"), ({"still_s": float("nan")}, "still_s"), ({"relax_min_cycles": 0}, "relax_min_cycles"),
])
def test_bad_classification_criteria_are_one_line_errors_naming_the_key(criteria, key):
    """Thresholds the classification cannot use (docs/classify.md) are refused before any run, by
    the map configuration (typed or TOML) and by classify itself."""
    from beamslider import _core
    from beamslider.maps.config import map_config

    with pytest.raises(ValueError, match=rf"`criteria\.{key}`"):
        map_config(beamslider.Parameters(), f_ex=[124.0], a_ex=[14.0], t_end=5.0, criteria=criteria)
    with pytest.raises(ValueError, match=rf"`criteria\.{key}`"):
        _core.MapConfig(map_config_toml(f_ex=[124.0], a_ex=[14.0], t_end=5.0, criteria=criteria))
    with pytest.raises(ValueError, match=rf"`criteria\.{key}`"):
        _core.classify(np.full(3, 0.3), np.full(3, 0.1), 0.2, criteria=criteria)


def test_a_drift_table_has_one_writer_and_damaged_lines_are_named(tmp_path):
    """Drift tables are results files (docs/model.md §6.3, §8): a second writer is refused at once
    while the first holds the file, and a damaged line in the middle is an error naming the line."""
    from beamslider import _core
    from beamslider.superslow import drift_table, read_drift_table

    short = dict(settle_periods=5, first_settle_periods=20, window_s=0.1, sub_windows=2)
    out = tmp_path / "d.jsonl"
    full = drift_table(f_ex=124, a_ex=14, s=[0.3, 0.32], out=out, **short)
    before = out.read_bytes()
    with _core.ResultsLock(str(out)):
        with pytest.raises(BlockingIOError, match="PID"):
            drift_table(f_ex=124, a_ex=14, s=[0.3, 0.32], out=out, resume=True, **short)
    assert out.read_bytes() == before
    again = drift_table(f_ex=124, a_ex=14, s=[0.3, 0.32], out=out, resume=True, **short)
    assert again.computed == 0 and out.read_bytes() == before
    np.testing.assert_array_equal(read_drift_table(out).v, full.v)
    lines = before.decode().splitlines()
    out.write_text("\n".join(lines[:1] + ["{not json"] + lines[1:]) + "\n")
    with pytest.raises(ValueError, match="d.jsonl:2"):
        read_drift_table(out)
    out.write_text(json.dumps({"format": "something else"}) + "\n")
    with pytest.raises(ValueError, match="not a beamslider results file of this kind"):
        read_drift_table(out)
