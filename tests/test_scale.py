"""Bounded memory and streamed outputs, one writer per results file, maps on Dask, bad inputs."""

from __future__ import annotations

import gzip
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import beamslider
from beamslider import _core
from beamslider.maps import RESULTS_FILE, read_map
from beamslider.plotting import decimate_minmax

CLI = [sys.executable, "-m", "beamslider"]
ENV = {**os.environ, "PYTHONUNBUFFERED": "1"}


def _run_py(code: str, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          timeout=timeout, env=ENV)


# --- 1. bounded memory ------------------------------------------------------------------------

LIMIT = """
import resource
resource.setrlimit(resource.RLIMIT_AS, (int(2.5e9), int(2.5e9)))
import beamslider
"""


def test_too_large_run_is_refused_before_it_starts_under_an_address_space_limit():
    r = _run_py(LIMIT + """
import time
t0 = time.perf_counter()
try:
    beamslider.simulate(f_ex=124, a_ex=14, t_end=1e5, record_every=1)
except ValueError as e:
    print("ValueError:", e)
    print("seconds:", time.perf_counter() - t0)
""")
    assert r.returncode == 0, r.stderr
    msg = r.stdout
    assert "ValueError:" in msg
    for word in ("t_end", "record_every", "channels", "GB", "out="):
        assert word in msg, msg
    # 5e9 rows of 6 float64: 240 GB
    assert "240 GB" in msg, msg
    assert "memory allocation" not in r.stderr  # refused by the estimate, not by a failed allocation


def test_streamed_run_keeps_memory_bounded_under_an_address_space_limit(tmp_path):
    out = tmp_path / "run.npz"
    r = _run_py(LIMIT + f"""
import resource
beamslider.simulate(f_ex=124, a_ex=14, t_end=0.05, record_every=1, out={str(tmp_path / 'warm.npz')!r})
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
res = beamslider.simulate(f_ex=124, a_ex=14, t_end=40.0, record_every=1, out={str(out)!r}, max_memory=1e6)
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({{"before_kib": before, "after_kib": after, "rows": len(res.t), "t_last": float(res.t[-1]),
                   "memmap": type(res.t).__name__}}))
""".replace("import resource\nbeamslider", "import resource, json\nbeamslider"))
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout.strip().splitlines()[-1])
    rows = 1 + round(40.0 / 2e-5)
    assert d["rows"] == rows and d["t_last"] == pytest.approx(40.0)
    assert d["memmap"] == "memmap"
    data_mb = rows * 6 * 8 / 1e6  # 96 MB of recorded arrays
    growth_mb = (d["after_kib"] - d["before_kib"]) / 1024
    print(f"streamed 40 s at record_every=1: {data_mb:.0f} MB written, peak RSS grew by {growth_mb:.1f} MB")
    assert growth_mb < data_mb / 4, (growth_mb, data_mb)
    assert out.stat().st_size > rows * 6 * 8


def test_streamed_files_equal_the_in_memory_run_bitwise(tmp_path):
    args = dict(f_ex=124, a_ex=14, s0=0.3, t_end=0.2, record_every=3)
    mem = beamslider.simulate(**args)
    for name in ("a.npz", "a.csv", "a.parquet"):
        res = beamslider.simulate(**args, out=tmp_path / name)
        assert res.path == tmp_path / name
        for f in ("t", "w", "s", "x_c", "z_c", "beta"):
            np.testing.assert_array_equal(getattr(res, f), getattr(mem, f), err_msg=f"{name} {f}")
        assert res.status == mem.status and res.counters == mem.counters
    # np.load reads the .npz too (one array per channel)
    with np.load(tmp_path / "a.npz") as z:
        np.testing.assert_array_equal(z["w_4L7_m"], mem.w)
    with pytest.raises(ValueError, match="`out`.*exists"):
        beamslider.simulate(**args, out=tmp_path / "a.npz")
    with pytest.raises(ValueError, match="`out`.*npz, .csv or .parquet"):
        beamslider.simulate(**args, out=tmp_path / "a.h5")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv", "a.npz", "a.parquet"]  # no temporary files left
    import pyarrow.parquet as pq

    table = pq.read_table(tmp_path / "a.parquet")  # an ordinary Parquet file: any reader takes it
    from beamslider.trajectory import COLUMNS

    assert table.column_names == list(COLUMNS)
    np.testing.assert_array_equal(table.column("w_4L7_m").to_numpy(), mem.w)


def test_parquet_and_csv_results_read_each_column_on_first_use(tmp_path):
    args = dict(f_ex=124, a_ex=14, s0=0.3, t_end=0.2, record_every=3)
    for name in ("b.parquet", "b.csv"):
        res = beamslider.simulate(**args, out=tmp_path / name)
        assert "w" not in res.__dict__ and "t" not in res.__dict__  # nothing read yet
        assert len(res.w) == 1 + round(0.2 / 2e-5) // 3
        assert "w" in res.__dict__


def test_parquet_without_pyarrow_names_the_extra(tmp_path):
    hide = textwrap.dedent("""
        import sys
        class _NoArrow:
            def find_spec(self, name, path=None, target=None):
                if name == "pyarrow" or name.startswith("pyarrow."):
                    raise ImportError("No module named 'pyarrow' (hidden by the test)")
                return None
        sys.meta_path.insert(0, _NoArrow())
    """)
    code = hide + textwrap.dedent(f"""
        import beamslider
        try:
            beamslider.simulate(f_ex=124, a_ex=14, t_end=0.1, out={str(tmp_path / 'r.parquet')!r})
        except ImportError as e:
            print(e)
        from beamslider.cli import main
        sys.exit(main(["simulate", "--t-end", "0.1", "--format", "parquet", "--no-manifold", "--out",
                       {str(tmp_path / 'o')!r}]))
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=ENV, timeout=300)
    assert 'pip install "beamslider[parquet]"' in r.stdout, r.stdout + r.stderr
    assert r.returncode == 1 and 'beamslider[parquet]' in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert r.stderr.count("\n") == 1
    assert list(tmp_path.iterdir()) == []  # nothing written, not even the folder


def test_csv_result_is_read_at_bounded_memory(tmp_path):
    out = tmp_path / "run.csv"
    r = _run_py(f"""
import json, resource, beamslider
res = beamslider.simulate(f_ex=124, a_ex=14, t_end=20.0, record_every=1, out={str(out)!r})
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
n, t_last, w_first = len(res.t), float(res.t[-1]), float(res.w[1])  # every column parsed
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({{"before_kib": before, "after_kib": after, "rows": n, "t_last": t_last, "w1": w_first}}))
""")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout.strip().splitlines()[-1])
    rows = 1 + round(20.0 / 2e-5)
    assert d["rows"] == rows and d["t_last"] == pytest.approx(20.0)
    assert d["w1"] == beamslider.simulate(f_ex=124, a_ex=14, t_end=1e-4, record_every=1).w[1]
    data_mb = rows * 6 * 8 / 1e6  # 48 MB of columns, 1 M lines of text
    growth_mb = (d["after_kib"] - d["before_kib"]) / 1024
    print(f"CSV of 20 s at record_every=1 read: {data_mb:.0f} MB of columns, peak RSS grew by {growth_mb:.1f} MB")
    assert growth_mb < data_mb / 4, (growth_mb, data_mb)


def test_csv_numbers_round_trip(tmp_path):
    res = beamslider.simulate(f_ex=124, a_ex=14, t_end=0.01, record_every=1, out=tmp_path / "r.csv")
    mem = beamslider.simulate(f_ex=124, a_ex=14, t_end=0.01, record_every=1)
    lines = (tmp_path / "r.csv").read_text().splitlines()
    assert lines[0] == "t_s,w_4L7_m,s,xC_m,zC_m,beta_rad"
    w = np.array([float(ln.split(",")[1]) for ln in lines[1:]])
    np.testing.assert_array_equal(w, mem.w)
    assert len(res.t) == len(mem.t)


# --- 2. atomic output, interruption, plot refuses incomplete ----------------------------------


def test_sigint_during_streamed_write_leaves_no_file_under_the_final_name(tmp_path):
    out = tmp_path / "run.npz"
    p = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import beamslider
        print("start", flush=True)
        beamslider.simulate(f_ex=124, a_ex=14, t_end=600, record_every=1, out={str(out)!r})
        """)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    assert p.stdout.readline().strip() == "start"
    time.sleep(1.5)
    assert any(f.name.startswith(".run.npz.partial") for f in tmp_path.iterdir())  # it is writing
    p.send_signal(signal.SIGINT)
    _out, err = p.communicate(timeout=60)
    assert p.returncode != 0 and "KeyboardInterrupt" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("manifold", [False, True])
def test_cli_interrupted_simulate_leaves_an_incomplete_sidecar_that_plot_refuses(tmp_path, manifold):
    # With the manifold (the default) it runs in a background thread: Ctrl-C stops both.
    out = tmp_path / "o"
    p = subprocess.Popen(CLI + ["simulate", "--t-end", "600", "--record-every", "1", "--out", str(out)]
                         + ([] if manifold else ["--no-manifold"]),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    stem = "fs_124Hz_14ms2_s0_0p3"
    for _ in range(300):
        if (out / f"{stem}.json").exists():
            break
        time.sleep(0.05)
    time.sleep(1.0)
    p.send_signal(signal.SIGINT)
    _o, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert not (out / f"{stem}.npz").exists()
    assert not list(out.glob("manifold_*.csv")) or not manifold  # the manifold was stopped, not finished
    assert not [f for f in out.iterdir() if "partial" in f.name]
    meta = json.loads((out / f"{stem}.json").read_text())
    assert meta["complete"] is False
    r = subprocess.run(CLI + ["plot", str(out / f"{stem}.json"), "--out", str(tmp_path / "p")], capture_output=True,
                       text=True, env=ENV)
    assert r.returncode == 1 and "did not finish" in r.stderr and "Traceback" not in r.stderr


def test_cli_simulate_streams_npz_by_default_and_csv_or_parquet_on_request(tmp_path):
    stem = "fs_124Hz_14ms2_s0_0p3"
    mem = beamslider.simulate(f_ex=124, a_ex=14, s0=0.3, t_end=0.3)
    for fmt in ("npz", "csv", "parquet"):
        out = tmp_path / fmt
        r = subprocess.run(CLI + ["simulate", "--t-end", "0.3", "--no-manifold", "--out", str(out)]
                           + (["--format", fmt] if fmt != "npz" else []), capture_output=True, text=True, env=ENV)
        assert r.returncode == 0, r.stderr
        meta = json.loads((out / f"{stem}.json").read_text())
        assert meta["complete"] is True and meta["data"] == f"{stem}.{fmt}"
        cols = beamslider.read_trajectory(out / f"{stem}.{fmt}")
        np.testing.assert_array_equal(cols["w_4L7_m"], mem.w)
        r = subprocess.run(CLI + ["plot", str(out / f"{stem}.json"), "--out", str(out / "re")], capture_output=True,
                           text=True, env=ENV)
        assert r.returncode == 0, r.stderr


def test_simulate_command_imports_only_what_it_needs():
    r = _run_py("""
import sys
from beamslider.cli import COMMANDS, build_parser
build_parser("simulate")
heavy = ("scipy", "matplotlib", "dask", "distributed", "pyarrow", "beamslider.discover", "beamslider.maps",
         "beamslider.enma", "beamslider.superslow", "beamslider.study")
print(sorted(m for m in sys.modules if m.split(".")[0] in heavy or m.startswith(heavy)))
full = build_parser()
names = set(next(a for a in full._subparsers._group_actions).choices)
assert names == set(COMMANDS), (names ^ set(COMMANDS))
for c in COMMANDS:  # each command's module registers it
    assert c in next(a for a in build_parser(c)._subparsers._group_actions).choices, c
""")
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]", r.stdout


def test_minmax_decimation_keeps_every_columns_extremes():
    rng = np.random.default_rng(1)
    n = 1_000_003
    t = np.arange(n) * 1e-4
    y = np.cumsum(rng.standard_normal(n))
    y[123_457] = 1e3  # a single spike must survive
    td, yd = decimate_minmax(t, y, columns=1000)
    assert len(td) <= 2 * 1000 + 2
    assert np.all(np.diff(td) >= 0)
    assert yd.max() == 1e3 and yd.min() == y.min()
    per = n // 1000
    for c in (0, 500, 999):
        seg = y[c * per:(c + 1) * per]
        assert seg.min() in yd and seg.max() in yd
    # every drawn point is a sample of the trace
    idx = np.searchsorted(t, td)
    np.testing.assert_array_equal(y[idx], yd)
    # the band drawn in panel (a): per column, the first time, the minimum and the maximum
    from beamslider.plotting import minmax_band

    tb, lo, hi = minmax_band(t, y, columns=1000)
    assert len(tb) == len(lo) == len(hi) == 1000
    cols = y[:1000 * per].reshape(1000, per)
    np.testing.assert_array_equal(lo, cols.min(axis=1))
    np.testing.assert_array_equal(hi, cols.max(axis=1))
    first = np.arange(1000) * per + np.minimum(cols.argmin(axis=1), cols.argmax(axis=1))
    np.testing.assert_array_equal(tb, t[first])  # the earlier extreme's time
    assert minmax_band(t[:3999], y[:3999], columns=1000) is None  # short traces are drawn as they are


@pytest.mark.parametrize("every", [1, 5, 7])
def test_streamed_overview_equals_numpy_decimation_and_the_maps_super_slow_signals(tmp_path, every):
    """The core's overview of a streamed run (figure and summary data, computed as it streams) is
    numpy's min/max per pixel column of the in-memory run, and its super-slow signals are those an
    operating map computes from samples every 20 steps (envelope_stream)."""
    args = dict(f_ex=124, a_ex=14, s0=0.3, t_end=3.0, record_every=every)
    mem = beamslider.simulate(**args)
    res = beamslider.simulate(**args, out=tmp_path / f"r{every}.npz")
    ov = res.overview
    assert ov is not None and ov.columns == 2000 and ov.window == 1.0
    if len(mem.t) >= 4 * 2000:
        for got, y in ((ov.w_minmax, mem.w), (ov.s_minmax, mem.s)):
            want = decimate_minmax(mem.t, y, columns=2000)
            np.testing.assert_array_equal(got[0], want[0])
            np.testing.assert_array_equal(got[1], want[1])
    else:
        assert ov.w_minmax is None and ov.s_minmax is None  # short traces are drawn as they are
    stride = max(1, round(20 / every))
    p = beamslider.Parameters()
    t0, dt, s, a = _core.super_slow_signals(np.ascontiguousarray(mem.w[::stride]), np.ascontiguousarray(mem.s[::stride]),
                                            p.dt_s * every * stride, p.thickness_m, 1.0)
    assert len(a) == 3.0 / 0.2 - 1  # the last bin waits for samples past the end
    np.testing.assert_array_equal(ov.amplitude_h, a)
    np.testing.assert_array_equal(ov.s, s)
    np.testing.assert_allclose(ov.t, t0 + dt * np.arange(len(a)))
    # the classic envelope (FFT Hilbert, per sample) agrees where both are defined
    env = mem.envelope(1.0) / p.thickness_m
    mid = np.interp(ov.t[3:-3], mem.t, env)
    np.testing.assert_allclose(ov.amplitude_h[3:-3], mid, rtol=2e-2)


def test_cli_summary_and_figure_use_the_streamed_overview(tmp_path, monkeypatch):
    """``beamslider simulate`` takes the final amplitude from the core's super-slow signals (the
    operating maps' definition) and draws without reading the trajectory back."""
    from beamslider import plotting
    from beamslider.cli import main

    calls = []
    real = plotting.decimate_minmax

    def spy(t, y, columns=2000):
        calls.append(len(t))
        return real(t, y, columns)

    monkeypatch.setattr(plotting, "decimate_minmax", spy)
    monkeypatch.setattr(beamslider.SimulationResult, "display_envelope",
                        lambda self, window=1.0: pytest.fail("the envelope was recomputed from the file"))
    out = tmp_path / "o"
    assert main(["simulate", "--t-end", "2", "--record-every", "1", "--no-manifold", "--out", str(out)]) == 0
    stem = "fs_124Hz_14ms2_s0_0p3"
    meta = json.loads((out / f"{stem}.json").read_text())
    assert (out / f"{stem}.png").exists() and calls == []
    cols = beamslider.read_trajectory(out / f"{stem}.npz")
    p = beamslider.Parameters()
    _, _, _, a = _core.super_slow_signals(np.ascontiguousarray(cols["w_4L7_m"][::20]),
                                          np.ascontiguousarray(cols["s"][::20]), p.dt_s * 20, p.thickness_m, 1.0)
    assert meta["final_amplitude_over_h"] == a[-1]
    assert meta["final_amplitude_m"] == a[-1] * p.thickness_m


# --- 3. one writer per results file -----------------------------------------------------------


def _map_cmd(out: Path, resume: bool = True, t_end: str = "6"):
    return CLI + ["map", "--f-ex", "118:124:2", "--a-ex", "6,10", "--t-end", t_end, "--threads", "1", "--out", str(out)] \
        + (["--resume"] if resume else [])


def test_two_map_resume_processes_one_refuses_and_the_file_stays_whole(tmp_path):
    out = tmp_path / "m"
    # The second starts once the first holds the results file, and the map is long enough (20-s runs)
    # that the first still holds it then, however loaded the machine: the two always overlap.
    first = subprocess.Popen(_map_cmd(out, t_end="20"), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             env=ENV)
    deadline = time.monotonic() + 120
    while not (out / (RESULTS_FILE + ".lock")).exists() and first.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    procs = [first, subprocess.Popen(_map_cmd(out, t_end="20"), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True, env=ENV)]
    res = [(p.wait(timeout=600), p.stdout.read(), p.stderr.read()) for p in procs]
    codes = sorted(r[0] for r in res)
    assert codes == [0, 1], res
    refused = next(r for r in res if r[0] == 1)
    winner = next(p for p, r in zip(procs, res) if r[0] == 0)
    assert str(out) in refused[2] and f"PID {winner.pid}" in refused[2] and "Traceback" not in refused[2]
    lines = (out / RESULTS_FILE).read_text().splitlines()
    assert len(lines) == 1 + 8  # header + 8 rows, none fused
    for ln in lines:
        json.loads(ln)
    # a final resume computes nothing and equals an uninterrupted map (but the wall time)
    r = subprocess.run(_map_cmd(out, t_end="20"), capture_output=True, text=True, env=ENV)
    assert r.returncode == 0, r.stderr
    r = subprocess.run(_map_cmd(tmp_path / "ref", resume=False, t_end="20"), capture_output=True, text=True, env=ENV)
    assert r.returncode == 0, r.stderr
    a, b = read_map(out), read_map(tmp_path / "ref")
    for k in a:
        if k != "wall_time_s":
            np.testing.assert_array_equal(a[k], b[k], err_msg=k)


def test_second_writer_of_a_results_file_fails_at_once_naming_folder_and_pid(tmp_path):
    path = tmp_path / "study.jsonl"
    first = _core.ResultsLock(path)
    t0 = time.perf_counter()
    with pytest.raises(BlockingIOError) as e:
        _core.ResultsLock(path)
    assert time.perf_counter() - t0 < 2.0
    assert str(tmp_path) in str(e.value) and f"PID {os.getpid()}" in str(e.value)
    first.release()
    with _core.ResultsLock(path):
        pass


def test_lock_file_is_removed_on_release_and_one_left_by_a_killed_holder_does_not_block(tmp_path):
    path = tmp_path / "map.jsonl"
    lock = tmp_path / "map.jsonl.lock"
    with _core.ResultsLock(path):
        assert lock.exists()
    assert not lock.exists()
    holder = subprocess.Popen([sys.executable, "-c", "import sys, time; from beamslider import _core; "
                               "l = _core.ResultsLock(sys.argv[1]); print('held', flush=True); time.sleep(120)",
                               str(path)], stdout=subprocess.PIPE, text=True, env=ENV)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(BlockingIOError, match=f"PID {holder.pid}"):
            _core.ResultsLock(path)
    finally:
        holder.kill()
        holder.wait()
    assert lock.exists()  # SIGKILL: no clean-up ran
    with _core.ResultsLock(path):  # its lock died with it
        pass
    assert not lock.exists()
    beamslider.operating_map(f_ex=[120.0], a_ex=10.0, t_end=0.5, out=tmp_path / "m")
    assert not [f for f in (tmp_path / "m").iterdir() if f.name.endswith(".lock")]


def test_study_results_file_takes_the_lock(tmp_path):
    from beamslider.study import StudyConfig, Uncertain
    from beamslider.study.results import open_results
    from beamslider.study.sampling import study_points

    cfg = StudyConfig(uncertain=[Uncertain("friction_coefficient", "uniform", low=0.22, high=0.31)],
                      f_ex_hz=[120.0], a_ex_m_s2=[10.0], method="lhs", samples=2, seed=1, duration_s=1.0)
    pts = study_points(cfg)
    w = open_results(cfg, pts, tmp_path / "study.jsonl", False)
    with pytest.raises(BlockingIOError, match=f"PID {os.getpid()}"):
        open_results(cfg, pts, tmp_path / "study.jsonl", True)
    w.close()
    open_results(cfg, pts, tmp_path / "study.jsonl", True).close()


def test_reader_ignores_a_torn_last_row(tmp_path):
    beamslider.operating_map(f_ex=[120.0, 122.0], a_ex=10.0, t_end=2.0, out=tmp_path)
    path = tmp_path / RESULTS_FILE
    text = path.read_text()
    path.write_text(text + text.splitlines()[1][:40])  # a writer killed mid-row
    assert len(read_map(tmp_path)["index"]) == 2


# --- 4. bad inputs ----------------------------------------------------------------------------


def test_envelope_with_a_nan_names_the_argument():
    t = np.arange(1000) * 1e-3
    w = np.sin(2 * np.pi * 50 * t)
    w[500] = np.nan
    with pytest.raises(ValueError, match=r"`w`.*NaN.*index 500"):
        beamslider.envelope(t, w)


def test_classify_rejects_non_uniform_time():
    t = np.linspace(0, 10, 51)
    t[10] += 0.05
    with pytest.raises(ValueError, match="`t`.*uniformly"):
        beamslider.classify(t, np.full(51, 0.3), np.full(51, 0.1))


def test_classify_rejects_two_samples():
    with pytest.raises(ValueError, match="`t`.*at least three"):
        beamslider.classify([0.0, 0.2], [0.3, 0.3], [0.1, 0.1])


def test_record_every_larger_than_the_steps_is_an_error():
    with pytest.raises(ValueError, match="`record_every` = 1000: larger than the run's 500 time steps"):
        beamslider.simulate(f_ex=124, a_ex=14, t_end=0.01, record_every=1000)


def test_zero_duration_is_an_error():
    with pytest.raises(ValueError, match="`t_end` = 0"):
        beamslider.simulate(f_ex=124, a_ex=14, t_end=0)


def test_huge_integers_name_the_argument():
    with pytest.raises(ValueError, match="`record_every`"):
        beamslider.simulate(f_ex=124, a_ex=14, t_end=0.01, record_every=2**64)
    with pytest.raises(ValueError, match="`threads`"):
        beamslider.operating_map(f_ex=120.0, a_ex=10.0, t_end=1.0, threads=2**64)
    for argv in (["simulate", "--record-every", str(2**64)], ["map", "--threads", str(2**64)]):
        r = subprocess.run(CLI + argv, capture_output=True, text=True, env=ENV)
        assert r.returncode == 2 and "too large" in r.stderr and "Traceback" not in r.stderr, r.stderr


def test_measured_slider_position_outside_the_beam_is_rejected(tmp_path):
    path = tmp_path / "Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt"
    t = np.arange(200) * 1e-3
    s = np.full(200, 0.3)
    s[50] = 5.0
    np.savetxt(path, np.column_stack([t, np.sin(t), s]))
    with pytest.raises(beamslider.MeasurementFormatError, match=r"s = 5 outside \[0, 1\]") as e:
        beamslider.read_measurement(path)
    assert path.name in str(e.value)


@pytest.mark.parametrize("cmd", [["map"], ["study", "--config", "x.toml"]])
def test_map_and_study_reject_window(cmd):
    r = subprocess.run(CLI + cmd + ["--window", "2"], capture_output=True, text=True, env=ENV)
    assert r.returncode == 2 and "--window" in r.stderr and "Traceback" not in r.stderr


def test_plot_of_a_non_utf8_file_names_the_file(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_bytes(b"t_s,w_4L7_m\n\xff\xfe\x00garbage\n")
    r = subprocess.run(CLI + ["plot", str(bad), "--out", str(tmp_path / "o")], capture_output=True, text=True, env=ENV)
    assert r.returncode == 1 and str(bad) in r.stderr and "Traceback" not in r.stderr, r.stderr


def test_progress_bars_are_off_when_stderr_is_not_a_terminal(tmp_path):
    base = CLI + ["simulate", "--t-end", "0.2", "--no-manifold"]
    r = subprocess.run(base + ["--out", str(tmp_path / "a")], capture_output=True, env=ENV)
    assert r.returncode == 0 and b"\r" not in r.stderr and b"%|" not in r.stderr, r.stderr
    r = subprocess.run(base + ["--out", str(tmp_path / "b"), "--progress"], capture_output=True, env=ENV)
    assert r.returncode == 0 and b"\r" in r.stderr and b"100%|" in r.stderr, r.stderr


# --- 5. maps on Dask --------------------------------------------------------------------------


def test_map_on_a_local_cluster_equals_the_local_map_row_for_row(tmp_path):
    distributed = pytest.importorskip("distributed")
    grid = dict(f_ex=[118.0, 120.0, 122.0], a_ex=[6.0, 10.0], t_end=3.0)
    local = beamslider.operating_map(**grid, out=tmp_path / "local")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c, \
            distributed.Client(c) as client:
        remote = beamslider.operating_map(**grid, out=tmp_path / "dask", scheduler=client, chunk_size=2)
    rows = {}
    for name in ("local", "dask"):
        lines = (tmp_path / name / RESULTS_FILE).read_text().splitlines()
        assert json.loads(lines[0]) == json.loads((tmp_path / "local" / RESULTS_FILE).read_text().splitlines()[0])
        rows[name] = {}
        for ln in lines[1:]:
            r = json.loads(ln)
            r.pop("wall_time_s")
            rows[name][r["index"]] = r
    assert rows["local"] == rows["dask"]  # bitwise (JSON numbers round-trip), end states included
    for k in local:
        if k != "wall_time_s":
            np.testing.assert_array_equal(local[k], remote[k], err_msg=k)


def test_unreachable_scheduler_writes_nothing(tmp_path, monkeypatch):
    pytest.importorskip("distributed")
    import beamslider._dask

    monkeypatch.setattr(beamslider._dask, "CONNECT_TIMEOUT_S", 1.0)
    with pytest.raises(ValueError, match="cannot reach the scheduler at tcp://127.0.0.1:9"):
        beamslider.operating_map(f_ex=120.0, a_ex=10.0, t_end=1.0, out=tmp_path / "m", scheduler="tcp://127.0.0.1:9")
    assert not (tmp_path / "m").exists()
    from beamslider.study import StudyConfig, Uncertain, run_study

    cfg = StudyConfig(uncertain=[Uncertain("friction_coefficient", "uniform", low=0.22, high=0.31)],
                      f_ex_hz=[120.0], a_ex_m_s2=[10.0], method="lhs", samples=2, seed=1, duration_s=1.0)
    with pytest.raises(ValueError, match="cannot reach"):
        run_study(cfg, out=tmp_path / "s", scheduler="tcp://127.0.0.1:9")
    assert not (tmp_path / "s").exists()
    with pytest.raises(ValueError, match="scheduler_file"):
        run_study(cfg, out=tmp_path / "s", scheduler_file=str(tmp_path / "missing.json"))
    assert not (tmp_path / "s").exists()


def test_blocked_envelope_matches_the_whole_run_fft():
    from beamslider.simulate import blocked_envelope

    rng = np.random.default_rng(3)
    n = 2_500_001  # prime-ish length, 50 s at 2e-5 s
    t = np.arange(n) * 2e-5
    slow = 1 + 0.5 * np.sin(2 * np.pi * 0.05 * t) + 0.2 * np.tanh((t - 20) / 0.5)
    w = 1e-3 * slow * np.sin(2 * np.pi * 124 * t + 0.3 * np.sin(2 * np.pi * 0.1 * t)) \
        + 2e-5 * np.sin(2 * np.pi * 780 * t) + 1e-6 * rng.standard_normal(n)
    exact = beamslider.envelope(t, w, window=1.0)
    fast = blocked_envelope(t, w, window=1.0)
    rel = np.abs(fast - exact) / exact.max()
    print(f"blocked envelope: max deviation {rel.max():.2e} of the peak")
    assert rel.max() < 1e-3
