"""Uncertainty studies (beamslider.study): configuration, sampling, Sobol' estimators, the
natural-frequency detuning, the resumable results file, and the Dask executor on a small
LocalCluster — bitwise the rows of the local executor, and no point lost when a worker is killed."""

import json
import math
import os
import signal

import numpy as np
import pytest

from beamslider import Parameters, _core
from beamslider.cli import main as cli_main
from beamslider.study import (RESULTS_FILE, StudyConfig, Uncertain, aggregate, detune, read_results, read_study,
                              run_study, sample, sobol_indices, plot_behaviour_probability, plot_sensitivity)
from beamslider.study.config import _saltelli_matrices

MU = Uncertain("friction_coefficient", "uniform", low=0.22, high=0.31)
FREQ = Uncertain("natural_frequency_factor", "uniform", low=0.95, high=1.05)


def tiny(**kw):
    """A study of short runs (milliseconds each)."""
    base = dict(uncertain=[MU, FREQ], method="lhs", samples=6, seed=3, duration_s=0.3, chunk_size=2,
                f_ex_hz=[120.0, 124.0], a_ex_m_s2=[14.0])
    base.update(kw)
    return StudyConfig(**base)


def rows_of(path):
    """Rows of a results file without the wall time (the only field allowed to differ)."""
    _h, rows, _good, truncated = read_results(path)
    assert not truncated
    return sorted(({k: v for k, v in r.items() if k != "wall_time_s"} for r in rows), key=lambda r: r["index"])


# --- configuration and sampling -----------------------------------------------------------------


def test_config_toml_roundtrip_and_core_readable_map_config():
    c = tiny(method="saltelli", samples=4, criteria={"high_h": 0.25}, dt_s=2e-5)
    again = StudyConfig.from_toml_text(c.to_toml_text())
    assert again == c
    f, a, s = c.map_config().axes
    assert f == [120.0, 124.0] and a == [14.0] and s == [0.3]


@pytest.mark.parametrize("text, match", [
    ("[uncertain.nope]\nlow = 0\nhigh = 1\n", "invalid uncertain parameter 'nope'"),
    ("[uncertain.friction_coefficient]\ndistribution = 'beta'\n", "invalid distribution"),
    ("[uncertain.friction_coefficient]\nlow = 0.3\nhigh = 0.2\n", "need low < high"),
    ("[uncertain.friction_coefficient]\nlow = 0.1\n", "needs a finite number `high`"),
    ("[study]\nmethod = 'mc'\n[uncertain.friction_coefficient]\nlow = 0.1\nhigh = 0.2\n", "study.method"),
    ("[study]\nsampels = 3\n[uncertain.friction_coefficient]\nlow = 0.1\nhigh = 0.2\n", "unknown key 'sampels'"),
    ("duration_s = -1\n[uncertain.friction_coefficient]\nlow = 0.1\nhigh = 0.2\n", "duration_s"),
    ("[params]\nfriction_coefficient = -1\n[uncertain.damping_ratio]\nlow = 0.1\nhigh = 0.2\n", "friction_coefficient"),
    ("", "at least one"),
])
def test_bad_configuration_is_a_value_error_naming_the_field(text, match):
    with pytest.raises(ValueError, match=match):
        StudyConfig.from_toml_text(text)


def test_samples_follow_the_distributions_and_the_seed():
    lhs = sample([MU, FREQ], "lhs", 20, seed=1)
    assert lhs.shape == (20, 2)
    assert np.array_equal(lhs, sample([MU, FREQ], "lhs", 20, seed=1))
    # Latin hypercube: one sample in each of the 20 strata of every input.
    strata = np.floor((lhs[:, 0] - 0.22) / 0.09 * 20).astype(int)
    assert sorted(strata.tolist()) == list(range(20))
    assert ((lhs[:, 1] >= 0.95) & (lhs[:, 1] <= 1.05)).all()
    sal = sample([MU, FREQ], "saltelli", 8, seed=1)
    assert sal.shape == (8 * 4, 2)
    a, b, ab1, ab2 = sal[:8], sal[8:16], sal[16:24], sal[24:]
    assert np.array_equal(ab1[:, 0], b[:, 0]) and np.array_equal(ab1[:, 1], a[:, 1])
    assert np.array_equal(ab2[:, 1], b[:, 1]) and np.array_equal(ab2[:, 0], a[:, 0])
    grid = sample([Uncertain("friction_coefficient", low=0.2, high=0.3, levels=[0.2, 0.3]), FREQ], "grid", 1)
    assert grid.shape == (6, 2) and set(grid[:, 1]) == {0.95, 1.0, 1.05}
    normal = sample([Uncertain("damping_ratio", "truncnormal", mean=1e-3, std=2e-4, low=5e-4, high=2e-3)], "sobol", 64)
    assert normal.min() >= 5e-4 and normal.max() <= 2e-3 and abs(np.mean(normal) - 1e-3) < 1e-4


def test_sobol_estimators_on_the_ishigami_function():
    # Ishigami (a = 7, b = 0.1): S1 = (0.3139, 0.4424, 0), ST = (0.5576, 0.4424, 0.2437).
    n, d = 4096, 3
    a, b = _saltelli_matrices(d, n, seed=5)
    u = np.vstack([a, b] + [np.where(np.arange(d) == i, b, a) for i in range(d)])
    x = -np.pi + 2 * np.pi * u
    y = np.sin(x[:, 0]) + 7 * np.sin(x[:, 1]) ** 2 + 0.1 * x[:, 2] ** 4 * np.sin(x[:, 0])
    ind = sobol_indices(y, n, d, bootstrap=50)
    assert np.allclose(ind["S1"], [0.3139, 0.4424, 0.0], atol=0.04)
    assert np.allclose(ind["ST"], [0.5576, 0.4424, 0.2437], atol=0.04)
    assert (ind["S1_conf"] > 0).all() and (ind["ST_conf"] < 0.1).all()
    salib = pytest.importorskip("SALib.analyze.sobol")
    # SALib orders the rows per base sample: A_j, AB_1j, ..., AB_Dj, B_j.
    y_salib = np.column_stack([y[:n]] + [y[(2 + i) * n:(3 + i) * n] for i in range(d)] + [y[n:2 * n]]).ravel()
    problem = {"num_vars": d, "names": ["x1", "x2", "x3"], "bounds": [[-np.pi, np.pi]] * d}
    ref = salib.analyze(problem, y_salib, calc_second_order=False, num_resamples=10, seed=1)
    assert np.allclose(ind["S1"], ref["S1"], rtol=1e-12, atol=1e-12)
    assert np.allclose(ind["ST"], ref["ST"], rtol=1e-12, atol=1e-12)


def test_natural_frequency_factor_scales_every_frequency_and_holds_b_star():
    p = Parameters()
    f0 = np.array(p.natural_frequencies_hz())
    for c in (0.95, 1.05):
        q = Parameters.from_dict({**p.to_dict(), **detune(p, c)})
        assert np.allclose(np.array(q.natural_frequencies_hz()) / f0, c, rtol=1e-9, atol=0)
        area = p.beam_mass_kg / (p.density_kg_m3 * p.length_m)
        k_ax = lambda r: 1 / (r.length_m / (r.youngs_modulus_pa * area) + 1 / r.k_t_n_per_m)  # noqa: E731
        assert math.isclose(k_ax(q), k_ax(p), rel_tol=1e-12)  # b = (k_ax/2) K11², K unchanged
        assert math.isclose(q.k_r_nm_per_rad / q.youngs_modulus_pa, p.k_r_nm_per_rad / p.youngs_modulus_pa, rel_tol=1e-12)
    ideal = Parameters(k_t_n_per_m=math.inf)
    assert math.isinf(detune(ideal, 1.05).get("k_t_n_per_m", math.inf))
    with pytest.raises(ValueError, match="natural_frequency_factor"):
        detune(p, 0.5)


# --- local execution, results file, aggregation -------------------------------------------------


def test_local_study_rows_are_map_rows_and_resume_after_a_truncated_write(tmp_path):
    cfg = tiny()
    full = run_study(cfg, out=tmp_path / "full", threads=2)
    assert len(full.table["index"]) == 12 and list(full.table["index"]) == list(range(12))
    path = tmp_path / "full" / RESULTS_FILE
    header, core_rows, _good, truncated = _core.read_results_file(path)  # the map reader reads a study file
    assert len(core_rows) == 12 and not truncated and json.loads(header)["settings"]["duration_s"] == 0.3
    # The same point as a one-point map gives the same row.
    one = [r for r in rows_of(path) if r["index"] == 5][0]
    p = Parameters.from_dict({**Parameters().to_dict(),
                              "friction_coefficient": one["params"]["friction_coefficient"],
                              **detune(Parameters(), one["params"]["natural_frequency_factor"])})
    from beamslider.maps import map_config_toml
    run = _core.MapRun(_core.MapConfig(map_config_toml(p, f_ex=one["f_ex_hz"], a_ex=14.0, t_end=0.3)))
    run.run_local()
    mrow = json.loads(run.finish()[0][0])
    # (a study row keeps no end state: it is not extended in time)
    assert all(mrow[k] == one[k] for k in mrow if k not in ("index", "wall_time_s", "end"))

    # Kill simulation: keep the header and 5 rows, then half a line.
    lines = path.read_bytes().split(b"\n")
    part = tmp_path / "part"
    part.mkdir()
    (part / RESULTS_FILE).write_bytes(b"\n".join(lines[:6]) + b"\n" + lines[6][:40])
    with pytest.raises(ValueError, match="exists"):
        run_study(cfg, out=part)
    resumed = run_study(cfg, out=part, resume=True, threads=1)
    assert rows_of(part / RESULTS_FILE) == rows_of(path)
    assert np.array_equal(resumed.table["s_final"], full.table["s_final"], equal_nan=True)  # 0.3 s: too short to classify (NaN)
    with pytest.raises(ValueError, match="another study configuration"):
        run_study(tiny(seed=4), out=part, resume=True)
    again = read_study(part)
    assert again.points[1].probabilities == full.points[1].probabilities


def test_aggregate_probabilities_statistics_and_main_effects():
    cfg = StudyConfig(uncertain=[Uncertain("friction_coefficient", low=0.2, high=0.3, levels=[0.2, 0.25, 0.3])],
                      method="grid", duration_s=1.0)
    rows = []
    runs = [(0.2, "signature_move", 0.33), (0.25, "signature_move", 0.34), (0.3, "trivial_adaption", 0.37)]
    for i, (mu, beh, s) in enumerate(runs):
        rows.append({"index": i, "sample": i, "point": 0, "params": {"friction_coefficient": mu}, "f_ex_hz": 124.0,
                     "a_ex_m_s2": 14.0, "s0": 0.3, "t_end_s": 1.0, "status": "completed", "behaviour": beh,
                     "reason": "", "s_final": s, "amplitude_final_h": 0.5, "amplitude_initial_h": 0.1,
                     "amplitude_max_h": 0.6, "s_min": 0.29, "s_max": s, "net_travel": s - 0.3,
                     "travel_to_centre": s - 0.3, "turn_s": None, "turn_t_s": None, "jump_up_t_s": [],
                     "jump_down_t_s": [], "steady": True, "counters": {"steps": 1}, "wall_time_s": 0.1})
    res = aggregate(cfg, rows)
    p = res.points[0]
    assert math.isclose(p.probabilities["signature_move"], 2 / 3) and math.isclose(p.probabilities["trivial_adaption"], 1 / 3)
    assert p.most_probable == "signature_move"
    assert math.isclose(p.stats["s_final"]["mean"], (0.33 + 0.34 + 0.37) / 3) and p.stats["turn_s"]["n_finite"] == 0
    assert p.main_effects["s_final"]["friction_coefficient"] == [(0.2, 0.33), (0.25, 0.34), (0.3, 0.37)]
    assert math.isclose(p.sensitivity["s_final"]["friction_coefficient"]["rho"], 1.0)
    assert math.isnan(p.sensitivity["turn_s"]["friction_coefficient"]["rho"])
    json.dumps(res.summary_dict(), allow_nan=False)


def test_cli_study_writes_results_summary_and_figures(tmp_path, capsys):
    cfg_path = tmp_path / "study.toml"
    cfg_path.write_text(tiny(method="saltelli", samples=2, f_ex_hz=[124.0]).to_toml_text(), encoding="utf-8")
    out = tmp_path / "out"
    assert cli_main(["study", "--config", str(cfg_path), "--out", str(out), "--no-progress", "-j", "2"]) == 0
    for name in (RESULTS_FILE, "study.toml", "summary.json", "summary.txt", "behaviour_probability.png",
                 "sensitivity.png"):
        assert (out / name).stat().st_size > 0, name
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["points"][0]["sensitivity"]["s_final"]) == {"friction_coefficient", "natural_frequency_factor"}
    assert "S1" in summary["points"][0]["sensitivity"]["s_final"]["friction_coefficient"]
    assert cli_main(["study", "--config", str(tmp_path / "missing.toml"), "--out", str(out)]) == 1
    assert "no such file" in capsys.readouterr().err
    assert cli_main(["study", "--print-config"]) == 0
    assert StudyConfig.from_toml_text(capsys.readouterr().out).method == "lhs"


def test_figures_are_drawn(tmp_path):
    res = run_study(tiny(samples=3), threads=2)
    plot_behaviour_probability(res, path=tmp_path / "p.png")
    plot_sensitivity(res, path=tmp_path / "s.png")
    assert (tmp_path / "p.png").stat().st_size > 0 and (tmp_path / "s.png").stat().st_size > 0


# --- Dask ---------------------------------------------------------------------------------------


def test_dask_rows_are_bitwise_the_local_rows(tmp_path, cluster):
    cfg = tiny(samples=5)
    run_study(cfg, out=tmp_path / "local", threads=2)
    run_study(cfg, out=tmp_path / "dask", scheduler=cluster, chunk_size=3)
    run_study(cfg, out=tmp_path / "addr", scheduler=cluster.scheduler.address, chunk_size=1)
    local = rows_of(tmp_path / "local" / RESULTS_FILE)
    assert len(local) == 10
    assert rows_of(tmp_path / "dask" / RESULTS_FILE) == local
    assert rows_of(tmp_path / "addr" / RESULTS_FILE) == local


def test_killed_dask_worker_loses_no_points(tmp_path, cluster):
    cfg = tiny(samples=12, duration_s=1.0, chunk_size=2)  # 12 chunks of ~30 ms of simulation each
    pids = list(cluster.run(os.getpid).values())
    killed = []

    def kill_one(done, total):
        if not killed:
            os.kill(pids[0], signal.SIGKILL)
            killed.append((done, total))

    res = run_study(cfg, out=tmp_path / "dask", scheduler=cluster, on_chunk=kill_one)
    assert killed and killed[0][0] < killed[0][1]
    assert len(res.table["index"]) == 24
    run_study(cfg, out=tmp_path / "local", threads=2)
    assert rows_of(tmp_path / "dask" / RESULTS_FILE) == rows_of(tmp_path / "local" / RESULTS_FILE)
