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
from conftest import cli_command, is_png, run_cli, wait_for_lines

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
    wait_for_lines(results, 4)
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
    f, a, s = beamslider._core.MapConfig(text).axes
    assert f == [100.0, 102.0] and a == [4.0] and s == [0.3]
    default = beamslider.maps.default_map_config()
    f, a, s = beamslider._core.MapConfig(default).axes
    assert f == list(np.arange(100.0, 131.0, 2.0)) and a == [4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0] and s == [0.3]



def test_config_from_its_parts_is_the_config_from_toml():
    """``MapConfig.of`` (no TOML, the predicted map's path) builds the configuration that the TOML
    text of :func:`map_config_toml` gives, and refuses what that refuses, naming the field."""
    from beamslider.params import native

    p = beamslider.Parameters(friction_coefficient=0.27, slider_mass_kg=0.0123456789)
    f, a = [100.0, 101.5, 130.0], [4.0, 14.0]
    text = beamslider._core.MapConfig(map_config_toml(p, f_ex=f, a_ex=a, s0=0.3, t_end=20.0)).toml()
    parts = beamslider._core.MapConfig.of(native(p), f_ex_hz=f, a_ex_m_s2=a, s0=[0.3], duration_s=20.0)
    assert parts.toml() == text and parts.axes == (f, a, [0.3])
    with pytest.raises(ValueError, match="grid.f_ex_hz"):
        beamslider._core.MapConfig.of(native(p), f_ex_hz=[], a_ex_m_s2=a, s0=[0.3], duration_s=20.0)
    with pytest.raises(ValueError, match="duration_s"):
        beamslider._core.MapConfig.of(native(p), f_ex_hz=f, a_ex_m_s2=a, s0=[0.3], duration_s=0.0)

@pytest.mark.slow
def test_representative_operating_points():
    """MODEL.md §8: the four representative points, 120 s from s0 = 0.3."""
    expected = {(124.0, 14.0): "signature_move", (104.0, 14.0): "trivial_adaption",
                (126.0, 10.0): "relaxation_oscillation", (124.0, 6.0): "self_damping"}
    for (f, a), want in expected.items():
        t = beamslider.operating_map(f_ex=f, a_ex=a, s0=0.3, t_end=120.0)
        assert t["behaviour"][0] == want, (f, a, t["reason"][0])


def _same_rows(a, b, idx):
    """Rows `idx` of two tables equal in every field but the wall time."""
    assert set(a) == set(b)
    for k in a:
        if k == "wall_time_s":
            continue
        if a[k].dtype == object:
            assert [list(a[k][i]) for i in idx] == [list(b[k][i]) for i in idx], k
        else:
            np.testing.assert_array_equal(a[k][idx], b[k][idx], err_msg=k)


def test_extend_to_continues_only_not_settled_points_bitwise(tmp_path, capsys):
    """Extending a map in time (docs/classify.md): a 3-s map extended to 6 s re-runs only its not-settled points, from their saved
    end states, and each re-run row is the row of the 6-s map (but the wall time)."""
    # Windows of 1 s: with the default ones (15 s, drift over 30 s) no 3-s run is settled.
    grid = dict(f_ex=[100.0, 120.0, 124.0], a_ex=[4.0, 14.0], s0=[0.3, 0.7],
                criteria={"steady_window_s": 1.0, "steady_drift_window_s": 1.0})
    long = beamslider.operating_map(**grid, t_end=6.0, threads=2)
    short = beamslider.operating_map(**grid, t_end=3.0, threads=2, out=tmp_path / "m")
    # Continued: settled = false (not_settled, or a behaviour still creeping) and undetermined.
    open_ = ~short["settled"] | np.isin(short["behaviour"], ["not_settled", "undetermined"])
    unsettled = np.flatnonzero(open_)
    settled = np.flatnonzero(~open_)
    assert len(unsettled) and len(settled), short["behaviour"]
    assert short["has_end_state"].all()
    capsys.readouterr()
    ext = beamslider.operating_map(**grid, t_end=3.0, threads=2, out=tmp_path / "m", extend_to=6.0)
    printed = capsys.readouterr().out
    assert f"re-ran {len(unsettled)} of 12 points (settled = false, or undetermined)" in printed, printed
    _same_rows(ext, long, unsettled)
    _same_rows(ext, short, settled)
    assert (ext["t_end_s"][unsettled] == 6.0).all() and (ext["t_end_s"][settled] == 3.0).all()
    # The results file reads back to the same table; the text table says how long the runs were.
    _same(read_map(tmp_path / "m"), ext)
    assert "t_end = 6 s (settled points kept from 3 s)" in text_table(ext)
    # Repeating the call (e.g. after a Ctrl-C) re-runs nothing more.
    again = beamslider.operating_map(**grid, t_end=3.0, threads=2, out=tmp_path / "m", extend_to=6.0)
    assert "re-ran 0 of 12 points" in capsys.readouterr().out
    _same(again, ext)


def _map_file(path, rows, version=3, duration=120.0):
    """A results file with the paper's settings and the given rows (dicts without end states)."""
    header = beamslider._core.read_results_file(Path(__file__).parent.parent / "docs" / "results" / "operating_map.jsonl")[0]
    settings = json.loads(header)["settings"]
    settings["duration_s"] = duration
    path.write_text("\n".join([json.dumps({"beamslider_map": version, "settings": settings})]
                              + [json.dumps(r) for r in rows]) + "\n", encoding="utf-8")
    return path


def _rows(grid, version=3):
    """Rows of a small map without end states: behaviour by position, one of them not settled."""
    out = []
    for i, (f, a, s0) in enumerate(grid):
        b = beamslider.maps.BEHAVIOURS[i % 5]
        r = {"index": i, "f_ex_hz": f, "a_ex_m_s2": a, "s0": s0, "t_end_s": 120.0, "status": "completed",
             "behaviour": b, "reason": f"r{i}", "s_final": 0.3 + 0.001 * i, "amplitude_final_h": 0.5,
             "amplitude_initial_h": 0.1, "amplitude_max_h": 0.9, "s_min": 0.2, "s_max": 0.4, "net_travel": 0.01,
             "travel_to_centre": 0.01, "turn_s": None, "turn_t_s": None, "jump_up_t_s": [1.0 * i], "jump_down_t_s": [],
             "steady": i != 1, "phase": "steady_high",
             "counters": {"steps": i, "contact_steps": 0, "closed_histogram": [i, 0, 0, 0, 0], "solver_iterations": 0,
                          "max_iterations": 0, "cap_hits": 0, "first_guess_hits": 0, "linear_solves": 0,
                          "enumerations": 0, "fallbacks": 0}, "wall_time_s": 0.5}
        if version >= 3:
            r.update(settled=i != 1, drift_s=0.001 * i, drift_a_h=-0.002 * i)
        out.append(r)
    return out


GRID3 = [(f, a, 0.3) for a in (12.0, 14.0) for f in (122.0, 124.0, 126.0)]


def test_map_as_pandas_and_xarray_round_trip(tmp_path):
    """A map reads as a DataFrame that round-trips the file's rows and as an xarray Dataset over
    (f_ex_hz, a_ex_m_s2, s0) with the behaviour as a categorical variable (docs/model.md §8)."""
    pd = pytest.importorskip("pandas")
    xr = pytest.importorskip("xarray")
    rows = _rows(GRID3)
    t = read_map(_map_file(tmp_path / "map.jsonl", rows))
    df = t.to_pandas()
    assert isinstance(df, pd.DataFrame) and len(df) == len(rows)
    assert list(df["behaviour"].cat.categories) == list(beamslider.maps.BEHAVIOURS)
    for r, (_, d) in zip(rows, df.iterrows()):
        for k, v in r.items():
            if k == "counters":
                assert d["counters_steps"] == v["steps"] and list(d["counters_closed_histogram"]) == v["closed_histogram"]
            elif k in ("turn_s", "turn_t_s"):
                assert np.isnan(d[k]) and v is None
            elif k in ("jump_up_t_s", "jump_down_t_s"):
                assert list(d[k]) == v
            else:
                assert d[k] == v, k
    ds = t.to_xarray()
    assert isinstance(ds, xr.Dataset)
    assert ds["behaviour"].dims == ("f_ex_hz", "a_ex_m_s2", "s0")
    assert ds.behaviour.sel(f_ex_hz=124, a_ex_m_s2=14).item() == rows[4]["behaviour"]
    assert ds.behaviour_code.sel(f_ex_hz=124, a_ex_m_s2=14, s0=0.3).item() == beamslider.maps.BEHAVIOURS.index(rows[4]["behaviour"])
    assert ds["behaviour"].attrs["categories"].split() == list(beamslider.maps.BEHAVIOURS)
    assert not bool(ds.settled.sel(f_ex_hz=124, a_ex_m_s2=12).item())
    assert float(ds.drift_s.sel(f_ex_hz=126, a_ex_m_s2=14).item()) == rows[5]["drift_s"]
    # NetCDF in one call (scipy's writer), and back.
    ds.drop_vars([k for k in ds.data_vars if ds[k].dtype == object]).to_netcdf(tmp_path / "map.nc")
    back = xr.open_dataset(tmp_path / "map.nc")
    np.testing.assert_array_equal(back.behaviour_code.values, ds.behaviour_code.values)
    back.close()
    # A partial grid: the missing point is NaN / empty / code -1.
    part = read_map(_map_file(tmp_path / "part.jsonl", rows[:5])).to_xarray()
    assert part.behaviour_code.sel(f_ex_hz=126, a_ex_m_s2=14).item() == -1
    assert np.isnan(part.s_final.sel(f_ex_hz=126, a_ex_m_s2=14).item())


def test_table_conversions_without_pandas_or_xarray_name_the_extra(tmp_path, monkeypatch):
    from beamslider.design import DesignRecords

    t = read_map(_map_file(tmp_path / "map.jsonl", _rows(GRID3)))
    monkeypatch.setitem(sys.modules, "pandas", None)
    monkeypatch.setitem(sys.modules, "xarray", None)
    with pytest.raises(ImportError, match=r"beamslider\[pandas\]"):
        t.to_pandas()
    with pytest.raises(ImportError, match=r"beamslider\[xarray\]"):
        t.to_xarray()
    with pytest.raises(ImportError, match=r"beamslider\[pandas\]"):
        DesignRecords([{"x": [1.0]}]).to_pandas()
    # The dict of arrays needs neither.
    assert t["behaviour"][0] == "inactivity"


def test_unsettled_rows_are_marked_and_version_2_rows_derive_the_flag(tmp_path):
    """A behaviour reached but not settled is marked `*` in the text table and hollow in the
    figure; a version-2 file (no flag) reads with settled = steady (docs/model.md §8)."""
    t = read_map(_map_file(tmp_path / "v3.jsonl", _rows(GRID3)))
    assert t["settled"].tolist() == [True, False, True, True, True, True]
    txt = text_table(t)
    assert "T*" in txt and txt.count("*") == 2, txt  # the cell and the legend
    assert "* reached, not yet settled" in txt
    np.testing.assert_array_equal(beamslider.maps.marked_unsettled(t), [False, True, False, False, False, False])
    v2 = read_map(_map_file(tmp_path / "v2.jsonl", _rows(GRID3, version=2), version=2))
    np.testing.assert_array_equal(v2["settled"], t["settled"])
    assert np.isnan(v2["drift_s"]).all()
    pytest.importorskip("matplotlib")
    fig = plot_operating_map(t)
    ax = fig.axes[0]
    frames = [p for p in ax.patches if p.get_facecolor()[3] == 0 and p.get_linewidth() == 2.5]
    assert len(frames) == 1  # one hollow cell


def test_extend_to_bad_input_is_a_value_error(tmp_path):
    grid = dict(f_ex=[120.0], a_ex=[14.0], s0=0.3)
    with pytest.raises(ValueError, match="extend_to"):
        beamslider.operating_map(**grid, t_end=1.0, out=tmp_path / "none", extend_to=2.0)
    beamslider.operating_map(**grid, t_end=0.5, out=tmp_path / "m")
    for bad in (0.5, 0.2, float("nan"), "x"):
        with pytest.raises(ValueError, match="extend_to"):
            beamslider.operating_map(**grid, t_end=0.5, out=tmp_path / "m", extend_to=bad)
    with pytest.raises(ValueError, match="extend_to"):
        beamslider.operating_map(**grid, t_end=0.5, extend_to=1.0)
    with pytest.raises(ValueError, match="t_end"):
        beamslider.operating_map(**grid, t_end=0.4, out=tmp_path / "m", extend_to=1.0)
    # A map written without end states (rows stripped, as an old version wrote them).
    lines = (tmp_path / "m" / RESULTS_FILE).read_text().splitlines()
    rows = [json.loads(l) for l in lines[1:]]
    for r in rows:
        r.pop("end")
        r["behaviour"] = "not_settled"
    (tmp_path / "m" / RESULTS_FILE).write_text("\n".join([lines[0]] + [json.dumps(r) for r in rows]) + "\n")
    with pytest.raises(ValueError, match="extend_to.*end state"):
        beamslider.operating_map(**grid, t_end=0.5, out=tmp_path / "m", extend_to=1.0)


def test_cli_map_extend_to(tmp_path):
    r = run_cli("map", "--f-ex", "100,124", "--a-ex", "4,14", "--t-end", "2", "--no-progress", "--out", str(tmp_path),
                cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "t_end = 2 s" in (tmp_path / "map.txt").read_text()
    r = run_cli("map", "--extend-to", "3", "--no-progress", "--out", str(tmp_path), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "re-ran" in r.stdout and "settled = false" in r.stdout, r.stdout
    assert "t_end = 3 s" in (tmp_path / "map.txt").read_text()
    r = run_cli("map", "--extend-to", "3", "--no-progress", "--out", str(tmp_path), cwd=tmp_path)
    assert r.returncode == 1 and "extend-to" in r.stderr


def test_plot_shows_settings_and_one_panel_per_s0(tmp_path):
    t = beamslider.operating_map(f_ex=[118.0, 124.0], a_ex=[6.0, 14.0], s0=[0.3, 0.4], t_end=0.5)
    fig = plot_operating_map(t, path=tmp_path / "two.png", mark_changes=True)
    axes = [a for a in fig.axes if a.get_title()]
    assert len(axes) == 2
    assert "0.3" in axes[0].get_title() and "0.4" in axes[1].get_title() and "t_end = 0.5 s" in axes[0].get_title()
    assert is_png(tmp_path / "two.png")
    txt = text_table(t)
    assert txt.count("t_end = 0.5 s") == 2 and "s0 = 0.4" in txt
    with pytest.raises(ValueError, match="s0"):
        plot_operating_map(t, s0=0.5)


@pytest.mark.slow
def test_start_position_example_106hz_10ms2():
    """The paper's Fig. 12 (var_start_pos): 106 Hz, 10 m/s², 120 s: trivial adaption from
    s0 = 0.3, signature move from s0 = 0.4."""
    t = beamslider.operating_map(f_ex=106.0, a_ex=10.0, s0=[0.3, 0.4], t_end=120.0)
    assert list(t["behaviour"]) == ["trivial_adaption", "signature_move"], list(t["reason"])
    # The run from 0.4 ends nearer the clamping than it started: net travel is a feature only.
    assert t["net_travel"][1] < 0


def test_papers_map_at_120_s_as_xarray():
    """The committed paper's map (docs/results/operating_map.jsonl, s0 = 0.3, 120 s, format 3): the
    creeping trivial adaptions (100, 14) and (102, 6) are labelled with settled = false, the
    signature move at (124, 14) is settled (docs/results/operating_map_extension.txt)."""
    pytest.importorskip("xarray")
    ds = read_map(Path(__file__).parent.parent / "docs" / "results" / "operating_map.jsonl").to_xarray()
    assert ds.behaviour.sel(f_ex_hz=124, a_ex_m_s2=14).item() == "signature_move"
    assert bool(ds.settled.sel(f_ex_hz=124, a_ex_m_s2=14).item())
    for f, a in ((100, 14), (102, 6)):
        assert ds.behaviour.sel(f_ex_hz=f, a_ex_m_s2=a).item() == "trivial_adaption"
        assert not bool(ds.settled.sel(f_ex_hz=f, a_ex_m_s2=a).item())
        assert float(ds.drift_s.sel(f_ex_hz=f, a_ex_m_s2=a).item()) > 0.005


def test_a_design_law_map_with_the_hb_jump_down_is_its_blend_without_the_learnt_rule():
    """``s_dn='hb'`` with a design law (docs/model.md §6.4–6.5): the core blends the law for the
    map's parameters with ρ_c = 0 and predicts with the law rule; the same map from that blended
    law passed as a drift law must agree row for row."""
    import dataclasses

    from beamslider.superslow import predicted_map
    from beamslider.superslow import design_coordinates, design_params
    from beamslider.superslow.design_law import default_law

    x = design_coordinates(beamslider.Parameters())
    x.update(gap_ratio=1.08, slider_mass_kg=0.035, com_offset_m=0.002)
    p, law = design_params(x), default_law()
    blended, _note = law.law_for(p)
    assert blended.rho_c > 0  # else the two rules could not differ
    grid = dict(f_ex=[104.0, 116.0, 124.0], a_ex=[10.0, 14.0], s0=0.3, t_end=120.0)
    via_design = predicted_map(p, drift=law, s_dn="hb", **grid)
    via_blend = predicted_map(p, drift=dataclasses.replace(blended, rho_c=0.0), s_dn="law", **grid)
    keep = [k for k in via_design[0] if k != "wall_time_s"]
    assert [[r[k] for k in keep] for r in via_design] == [[r[k] for k in keep] for r in via_blend]
    learnt = predicted_map(p, drift=law, s_dn="law", **grid)  # the learnt rule changes this grid's rows
    assert [r["behaviour"] for r in learnt] != [r["behaviour"] for r in via_design]
