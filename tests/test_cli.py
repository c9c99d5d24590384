"""The ``beamslider`` command in a subprocess: real CSV/JSON/PNG files, one-line user errors."""

import json
import os

import numpy as np
import pytest

import beamslider
from beamslider.cli import manifold_file_stem
from beamslider.measurement import write_measurement
from conftest import is_png, run_cli

FAST_MANIFOLD = ["--manifold-s", "0.2,0.3", "--manifold-periods", "4", "--manifold-record", "2"]
FAST_MANIFOLD_STEM = manifold_file_stem(124, 14, 4, 2, [0.2, 0.3])  # manifold_124Hz_14ms2_4periods_avg2_s<hash>


def _ok(p):
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr
    return p


def _user_error(p, *words):
    assert p.returncode != 0
    assert "Traceback" not in p.stderr, p.stderr
    lines = [ln for ln in p.stderr.splitlines() if ln.strip()]
    assert len(lines) >= 1
    msg = lines[-1]
    assert "error" in msg
    for w in words:
        assert w in msg, msg
    return msg


def test_help_lists_subcommands(tmp_path):
    p = _ok(run_cli("--help", cwd=tmp_path))
    for cmd in ("simulate", "manifold", "compare", "plot"):
        assert cmd in p.stdout


def test_simulate_writes_csv_json_png(tmp_path):
    p = _ok(run_cli("simulate", "--t-end", "0.3", *FAST_MANIFOLD, "--no-progress", cwd=tmp_path))
    out = tmp_path / "beamslider-out"  # the default folder
    stem = "fs_124Hz_14ms2_s0_0p3"
    assert is_png(out / f"{stem}.png")
    meta = json.loads((out / f"{stem}.json").read_text())
    assert meta["status"] == "completed" and meta["f_ex_hz"] == 124 and meta["counters"]["steps"] == 15000
    with np.load(out / f"{stem}.npz") as z:  # the default trajectory format (--format csv for CSV)
        assert sorted(z.files) == sorted(["t_s", "w_4L7_m", "s", "xC_m", "zC_m", "beta_rad"])
        assert all(z[k].shape == (1501,) for k in z.files)
    assert meta["complete"] is True and meta["data"] == f"{stem}.npz"
    assert (out / f"{FAST_MANIFOLD_STEM}.csv").read_text().startswith("branch,s,amplitude_m")
    assert "wrote" in p.stdout


def test_simulate_options_and_progress(tmp_path):
    p = _ok(run_cli("simulate", "--f-ex", "104", "--a-ex", "6", "--s0", "0.25", "--t-end", "0.2", "--model", "pcs",
                    "--no-manifold", "--solver", "reference", "--out", "o", "--progress", cwd=tmp_path))
    assert is_png(tmp_path / "o" / "pcs_104Hz_6ms2_s_0p25.png")
    assert "100%" in p.stderr  # progress bar (asked for: stderr is not a terminal here)


def test_simulate_without_figure_then_plot_draws_it(tmp_path):
    p = _ok(run_cli("simulate", "--t-end", "0.2", "--no-manifold", "--no-figure", "--out", "o", "--no-progress",
                    cwd=tmp_path))
    stem = tmp_path / "o" / "fs_124Hz_14ms2_s0_0p3"
    assert sorted(x.name for x in (tmp_path / "o").iterdir()) == [stem.name + ".json", stem.name + ".npz"]
    assert ".png" not in p.stdout and json.loads(stem.with_suffix(".json").read_text())["complete"] is True
    _ok(run_cli("plot", str(stem.with_suffix(".json")), "--out", "o", cwd=tmp_path))
    assert is_png(stem.with_suffix(".png"))


def test_manifold_and_plot_round_trip(tmp_path):
    _ok(run_cli("manifold", *FAST_MANIFOLD, "--out", "m", "--no-progress", cwd=tmp_path))
    m = tmp_path / "m"
    assert FAST_MANIFOLD_STEM.startswith("manifold_124Hz_14ms2_4periods_avg2_s")
    assert is_png(m / f"{FAST_MANIFOLD_STEM}.png")
    meta = json.loads((m / f"{FAST_MANIFOLD_STEM}.json").read_text())
    assert meta["up"]["s"] == [0.2, 0.3] and meta["down"]["s"] == [0.3, 0.2]
    _ok(run_cli("plot", str(m / f"{FAST_MANIFOLD_STEM}.json"), "--out", "p", cwd=tmp_path))
    assert is_png(tmp_path / "p" / f"{FAST_MANIFOLD_STEM}.png")


def test_compare_and_plot_with_measurement(tmp_path):
    # A "measurement": the model's own run written in the published format.
    r = beamslider.simulate(f_ex=124, a_ex=14, s0=0.3, t_end=0.3, record_every=5)
    v = np.gradient(r.w, r.t)
    meas = tmp_path / "Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt"
    write_measurement(meas, r.t, v, r.s)
    p = _ok(run_cli("compare", str(meas), *FAST_MANIFOLD, "--no-progress", "--out", "c", "--window", "0.05",
                    cwd=tmp_path))
    stem = "compare_" + meas.stem
    assert is_png(tmp_path / "c" / f"{stem}.png")
    meta = json.loads((tmp_path / "c" / f"{stem}.json").read_text())
    assert meta["kind"] == "compare" and meta["f_ex_hz"] == 124 and meta["t_end_s"] == pytest.approx(0.3, abs=1e-3)
    assert "measured" in p.stdout
    # Re-plot: a simulation result with the measurement overlaid, and a measurement alone.
    _ok(run_cli("plot", str(tmp_path / "c" / f"{stem}.json"), "--out", "p", "--window", "0.05", cwd=tmp_path))
    assert is_png(tmp_path / "p" / f"{stem}.png")
    _ok(run_cli("plot", "--measurement", str(meas), "--out", "p2", "--window", "0.05", cwd=tmp_path))
    assert is_png(tmp_path / "p2" / f"{meas.stem}.png")


def test_user_errors_are_one_line_without_traceback(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("restitution = 2.0\n")
    _user_error(run_cli("simulate", "--params", str(bad), "--t-end", "0.1", cwd=tmp_path), "restitution")
    garbled = tmp_path / "garbled.toml"
    garbled.write_text('length_m = "long"\n')
    _user_error(run_cli("simulate", "--params", str(garbled), cwd=tmp_path), "length_m")
    _user_error(run_cli("simulate", "--params", str(tmp_path / "none.toml"), cwd=tmp_path), "none.toml")
    _user_error(run_cli("simulate", "--s0", "0.99", "--t-end", "0.1", cwd=tmp_path), "s0")
    _user_error(run_cli("simulate", "--t-end", "abc", cwd=tmp_path), "--t-end")
    _user_error(run_cli("simulate", "--dt", "1e-3", "--t-end", "0.1", cwd=tmp_path), "dt_s")
    _user_error(run_cli("compare", str(tmp_path / "missing.txt"), cwd=tmp_path), "missing.txt")
    malformed = tmp_path / "fex124_ExcLevel14_RelSliderPosStart03.txt"
    malformed.write_text("0 1 0.3\n0.0001 1 0.3\n0.0002 x 0.3\n")
    _user_error(run_cli("compare", str(malformed), cwd=tmp_path), f"{malformed}:3")
    unnamed = tmp_path / "run.txt"
    unnamed.write_text("0 1 0.3\n0.0001 1 0.3\n")
    _user_error(run_cli("compare", str(unnamed), cwd=tmp_path), "--f-ex")
    _user_error(run_cli("manifold", "--manifold-s", "a:b", cwd=tmp_path), "--manifold-s")
    _user_error(run_cli("plot", cwd=tmp_path), "nothing to plot")
    assert not (tmp_path / "beamslider-out" / "fs_124Hz_14ms2_s0_0p3.png").exists()


def test_closed_pipe_exits_quietly(tmp_path):
    """`beamslider predict ... | head` where the reader has gone before the line is written: no
    "error: Broken pipe" on stderr, the status of a tool killed by SIGPIPE (141), and the files are
    written all the same."""
    import subprocess

    from conftest import cli_command

    env = dict(os.environ, MPLBACKEND="Agg")
    p = subprocess.Popen([*cli_command(), "predict", "--f-ex", "124", "--a-ex", "14", "--out", "o"], cwd=tmp_path,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    p.stdout.close()  # the reader is gone before anything is written
    err = p.stderr.read().decode()
    assert p.wait(timeout=120) == 141, err
    assert "Broken pipe" not in err and "Traceback" not in err, err
    assert (tmp_path / "o" / "predict_124Hz_14ms2_s0_0p3.json").exists()


def test_discover_fast_is_for_the_slider_level_only(tmp_path):
    """``discover --fast`` screens slider-level candidates (docs/model.md §9.1); without measured
    runs, or with ENMA data, it is an error before anything runs."""
    r = run_cli("discover", "--fast", cwd=tmp_path)
    assert r.returncode == 1 and "--fast: only for the slider level" in r.stderr
    r = run_cli("discover", "--search", "fast", cwd=tmp_path)
    assert r.returncode == 1 and "--search fast: only for the slider level" in r.stderr
    assert not (tmp_path / "beamslider-out").exists()
