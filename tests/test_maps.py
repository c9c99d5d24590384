"""Operating maps and behaviour classification (beamslider.maps; MODEL.md §8)."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import beamslider
from beamslider.maps import RESULTS_FILE, map_config_toml, plot_operating_map, read_map, text_table
from conftest import cli_command, is_png, run_cli

GRID = dict(f_ex=[118.0, 120.0, 122.0, 124.0], a_ex=[6.0, 14.0], s0=0.3, t_end=2.0)


def _same(a, b):
    """Tables equal in every field but the wall time."""
    assert set(a) == set(b)
    for k in a:
        if k == "wall_time_s":
            continue
        if a[k].dtype == object:
            assert [list(x) for x in a[k]] == [list(x) for x in b[k]], k
        else:
            np.testing.assert_array_equal(a[k], b[k], err_msg=k)


def _signals(s, a, t_end=120.0, dt=0.05):
    t = np.arange(0.0, t_end + dt / 2, dt)
    return t, s(t), a(t)


def test_classify_synthetic_signature_and_self_damping():
    build = lambda t, a: a * (1 - np.exp(-t))
    s = lambda t: np.where(t < 8, 0.3 - 0.042 * t / 8, 0.258 + np.clip((t - 8) / 22, 0, 1) * 0.073)
    a = lambda t: np.where(t < 8, build(t, 0.08), np.clip(0.08 + (t - 8) * 0.72, 0.08, 0.8) + np.clip((t - 9) / 21, 0, 1) * 0.39)
    c = beamslider.classify(*_signals(s, a))
    assert c.behaviour == "signature_move", c.reason
    assert abs(c.features["turn_s"] - 0.258) < 1e-3 and len(c.features["jump_up_t_s"]) == 1
    c = beamslider.classify(*_signals(lambda t: 0.3 - 0.2 * np.clip(t / 45, 0, 1), lambda t: build(t, 0.03) - 0.02 * np.clip(t / 45, 0, 1)))
    assert c.behaviour == "self_damping", c.reason
    c = beamslider.classify(*_signals(lambda t: 0.3 + 0 * t, lambda t: 0.1 + 0 * t))
    assert c.behaviour == "inactivity"
    # thresholds can be changed
    c = beamslider.classify(*_signals(lambda t: 0.3 + 0.005 * t / 120, lambda t: 0.1 + 0 * t), criteria={"still_s": 0.001})
    assert c.behaviour == "undetermined" and c.reason
    with pytest.raises(ValueError):
        beamslider.classify([0, 1], [0.3], [0.1, 0.1])
    with pytest.raises(ValueError):
        beamslider.classify(*_signals(lambda t: 0.3 + 0 * t, lambda t: 0.1 + 0 * t), criteria={"bogus": 1})


def test_operating_map_table_and_thread_independence(tmp_path):
    one = beamslider.operating_map(**GRID, threads=1, out=tmp_path / "one")
    two = beamslider.operating_map(**GRID, threads=2)
    _same(one, two)
    assert len(one["index"]) == 8
    np.testing.assert_array_equal(one["index"], np.arange(8))
    np.testing.assert_array_equal(one["f_ex_hz"], [118, 120, 122, 124] * 2)
    np.testing.assert_array_equal(one["a_ex_m_s2"], [6] * 4 + [14] * 4)
    assert set(one["behaviour"]) <= set(beamslider.maps.BEHAVIOURS)
    assert (one["counters_steps"] == 100000).all()
    assert (one["wall_time_s"] > 0).all()
    # The results file reads back to the same table.
    _same(read_map(tmp_path / "one"), one)
    assert (tmp_path / "one" / "map.toml").exists()
    txt = text_table(one)
    assert len(txt.splitlines()) == 4
    fig = plot_operating_map(one, path=tmp_path / "map.png")
    assert is_png(tmp_path / "map.png") and fig is not None


def test_operating_map_errors(tmp_path):
    with pytest.raises(ValueError, match="f_ex"):
        beamslider.operating_map(f_ex=[-1.0], a_ex=4.0, t_end=1.0)
    with pytest.raises(ValueError, match="threads"):
        beamslider.operating_map(f_ex=120.0, a_ex=4.0, t_end=1.0, threads=0)
    beamslider.operating_map(f_ex=120.0, a_ex=4.0, t_end=0.5, out=tmp_path)
    with pytest.raises(ValueError, match="exists"):
        beamslider.operating_map(f_ex=120.0, a_ex=4.0, t_end=0.5, out=tmp_path)
    with pytest.raises(ValueError, match="other settings"):
        beamslider.operating_map(f_ex=120.0, a_ex=4.0, t_end=0.6, out=tmp_path, resume=True)


def test_cli_map_killed_then_resumed_from_python(tmp_path):
    """Kill `beamslider map` mid-run, resume with operating_map: same rows as an uninterrupted
    run, none lost, none duplicated."""
    grid = dict(f_ex=list(np.arange(110.0, 131.0, 2.0)), a_ex=[6.0, 10.0, 14.0], s0=0.3, t_end=3.0)
    full = beamslider.operating_map(**grid, threads=2)
    out = tmp_path / "killed"
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.Popen([*cli_command(), "map", "--f-ex", "110:130:2", "--a-ex", "6,10,14", "--t-end", "3",
                             "-j", "1", "--no-progress", "--out", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    results = out / RESULTS_FILE
    t0 = time.time()
    while time.time() - t0 < 60:
        if results.exists() and len(results.read_text().splitlines()) >= 4:
            break
        time.sleep(0.005)
    proc.kill()
    proc.wait()
    before = [json.loads(l) for l in results.read_text().splitlines()[1:] if l.strip().endswith("}")]
    assert 0 < len(before) < 33
    with open(results, "a") as f:  # a kill in the middle of a write
        f.write('{"index":5,"f_ex_hz":1')
    resumed = beamslider.operating_map(**grid, threads=2, out=out, resume=True)
    _same(resumed, full)
    lines = results.read_text().splitlines()
    rows = [json.loads(l) for l in lines[1:]]
    assert len(rows) == 33
    assert sorted(r["index"] for r in rows) == list(range(33))


def test_cli_map_writes_table_and_figure(tmp_path):
    r = run_cli("map", "--f-ex", "120,124", "--a-ex", "6,14", "--t-end", "1", "--no-progress", "--out", str(tmp_path),
                cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert is_png(tmp_path / "map.png")
    assert (tmp_path / "map.txt").read_text().count("\n") == 4
    # Resume of a complete map computes nothing and gives the same table.
    r2 = run_cli("map", "--f-ex", "120,124", "--a-ex", "6,14", "--t-end", "1", "--no-progress", "--resume",
                 "--out", str(tmp_path), cwd=tmp_path)
    assert r2.returncode == 0, r2.stderr
    assert len((tmp_path / RESULTS_FILE).read_text().splitlines()) == 5
    r3 = run_cli("map", "--f-ex", "120:110:2", "--out", str(tmp_path / "x"), cwd=tmp_path)
    assert r3.returncode == 1 and "START:STOP:STEP" in r3.stderr
    r4 = run_cli("map", "--print-config", cwd=tmp_path)
    assert r4.returncode == 0 and "[grid]" in r4.stdout and "130.0" in r4.stdout


def test_config_is_shared_with_the_rust_tool():
    text = map_config_toml(f_ex=[100, 102], a_ex=4, t_end=120)
    canonical, f, a, s = beamslider._core.map_config(text)
    assert f == [100.0, 102.0] and a == [4.0] and s == [0.3]
    default = beamslider.maps.default_map_config()
    _, f, a, s = beamslider._core.map_config(default)
    assert f == list(np.arange(100.0, 131.0, 2.0)) and a == [4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0] and s == [0.3]


@pytest.mark.slow
def test_representative_operating_points():
    """MODEL.md §8: the four representative points, 120 s from s0 = 0.3."""
    expected = {(124.0, 14.0): "signature_move", (104.0, 14.0): "trivial_adaption",
                (126.0, 10.0): "relaxation_oscillation", (124.0, 6.0): "self_damping"}
    for (f, a), want in expected.items():
        t = beamslider.operating_map(f_ex=f, a_ex=a, s0=0.3, t_end=120.0)
        assert t["behaviour"][0] == want, (f, a, t["reason"][0])
