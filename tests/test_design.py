"""Design optimisation (beamslider.design): the bandwidth measure on synthetic classified grids,
configuration errors, the robust objective, resume after a killed run, and the Dask path on a
LocalCluster. Runs are a fraction of a second of model time (the numbers are not physics)."""

import json

import numpy as np
import pytest

from beamslider import Parameters
from beamslider.cli import main as cli_main
from beamslider.design import (DesignConfig, adaption_bandwidth, adapted_intervals, harvestable_level, optimise,
                               pareto_front, read_design_file, robust_value)
from beamslider.design import optimise as optimise_module
from beamslider.design.results import DesignWriter
from beamslider.study import Uncertain

T, S, R, I = "trivial_adaption", "signature_move", "relaxation_oscillation", "inactivity"
F = [100.0, 102.0, 104.0, 106.0, 108.0]


# --- the bandwidth measure --------------------------------------------------------------------

def test_whole_band_is_its_width():
    assert adaption_bandwidth(F, [T, T, S, S, S], [1.0] * 5) == pytest.approx(8.0, abs=0)


def test_empty_band_is_zero():
    assert adaption_bandwidth(F, [R, I, R, I, R], [1.0] * 5) == 0.0
    # adaptive behaviours below a_min do not count either
    assert adaption_bandwidth(F, [T] * 5, [0.1] * 5, a_min_h=0.3) == 0.0


def test_behaviour_edge_at_the_midpoint():
    # adapted at 100..104, relaxation oscillation from 106: edge at 105 Hz
    assert adapted_intervals(F, [T, T, S, R, R], [1.0] * 5) == [(100.0, 105.0)]
    assert adaption_bandwidth(F, [T, T, S, R, R], [1.0] * 5) == pytest.approx(5.0)
    # an isolated adapted point: half of each neighbouring interval
    assert adaption_bandwidth(F, [R, R, S, R, R], [1.0] * 5) == pytest.approx(2.0)
    # at the band's end: half an interval
    assert adaption_bandwidth(F, [R, R, R, R, S], [1.0] * 5) == pytest.approx(1.0)


def test_amplitude_edge_linearly_interpolated():
    # both signature moves; A falls from 0.5 to 0.1 between 104 and 106: crossing of 0.3 at 105
    amp = [0.8, 0.7, 0.5, 0.1, 0.1]
    assert adapted_intervals(F, [S] * 5, amp, a_min_h=0.3) == [(100.0, pytest.approx(105.0))]
    # crossing at a quarter of the interval: A from 0.4 to 0.0, a_min 0.3 -> 104.5
    amp = [0.8, 0.7, 0.4, 0.0, 0.0]
    assert adaption_bandwidth(F, [S] * 5, amp, a_min_h=0.3) == pytest.approx(4.5)
    # rising edge too: 0.2 -> 0.6 between 100 and 102, a_min 0.3 -> edge at 100.5
    amp = [0.2, 0.6, 0.7, 0.7, 0.7]
    assert adaption_bandwidth(F, [T] * 5, amp, a_min_h=0.3) == pytest.approx(7.5)


def test_two_bands_and_unsorted_input_rejected():
    beh = [T, R, R, R, S]
    assert adapted_intervals(F, beh, [1.0] * 5) == [(100.0, 101.0), (107.0, 108.0)]
    with pytest.raises(ValueError, match="increasing"):
        adaption_bandwidth(F[::-1], beh, [1.0] * 5)
    with pytest.raises(ValueError, match="length"):
        adaption_bandwidth([100.0], [T], [1.0])


def test_harvestable_level_trapezoid():
    assert harvestable_level(F, [1.0] * 5) == pytest.approx(1.0)
    # (A/h)^2 = 0, 0, 4, 0, 0: trapezoid integral 2*4 = 8 over 8 Hz -> 1.0; NaN counts as 0
    assert harvestable_level(F, [0.0, np.nan, 2.0, 0.0, 0.0]) == pytest.approx(1.0)


def test_pareto_front():
    recs = [dict(feasible=True, slider_mass_kg=m, bandwidth_hz=b) for m, b in
            [(0.02, 5.0), (0.03, 4.0), (0.04, 10.0), (0.05, 10.0), (0.06, 12.0)]]
    recs.append(dict(feasible=False, slider_mass_kg=0.01, bandwidth_hz=50.0))
    front = pareto_front(recs)
    assert [(r["slider_mass_kg"], r["bandwidth_hz"]) for r in front] == [(0.02, 5.0), (0.04, 10.0), (0.06, 12.0)]


# --- configuration -------------------------------------------------------------------------------

def tiny(**kw):
    """A search of very short runs (two frequencies, one level)."""
    base = dict(variables=[dict(name="gap_ratio", low=1.02, high=1.2), dict(name="slider_mass_kg", low=0.03, high=0.06)],
                f_lo_hz=120.0, f_hi_hz=124.0, f_step_hz=4.0, a_ex_m_s2=[14.0], t_end_s=1.5, a_min_h=0.05,
                popsize=2, maxiter=1, seed=4)
    base.update(kw)
    return DesignConfig(**base)


def test_variable_errors():
    with pytest.raises(ValueError, match="not_a_field"):
        tiny(variables=[dict(name="not_a_field", low=0.0, high=1.0)])
    with pytest.raises(ValueError, match="gap_ratio"):
        tiny(variables=[dict(name="gap_ratio", low=1.2, high=1.1)])  # low >= high
    with pytest.raises(ValueError, match="gap_ratio"):
        tiny(variables=[dict(name="gap_ratio", low=0.9, high=1.1)])  # R/h must exceed 1
    with pytest.raises(ValueError, match="contact_solver"):
        tiny(variables=[dict(name="contact_solver", low=0.0, high=1.0)])
    cfg = tiny()
    with pytest.raises(ValueError, match="slider_mass_kg.*outside its bounds"):
        cfg.design_params([1.05, 0.1])
    with pytest.raises(ValueError, match="unknown key 'nonsense'"):
        DesignConfig.from_toml_text("[design]\ngap_ratio = [1.02, 1.2]\n[band]\nnonsense = 1\n")
    with pytest.raises(ValueError, match="youngs_modulus"):
        DesignConfig.from_toml_text("[design]\nyoungs = [1.0, 2.0]\n")


def test_toml_round_trip_and_inertia_scaling():
    cfg = tiny()
    again = DesignConfig.from_toml_text(cfg.to_toml_text())
    assert again.to_dict() == cfg.to_dict()
    p0 = Parameters()
    p = cfg.design_params([1.1, 2 * p0.slider_mass_kg if 2 * p0.slider_mass_kg <= 0.06 else 0.06])
    assert p.gap_ratio == 1.1
    assert p.slider_inertia_kg_m2 == pytest.approx(p0.slider_inertia_kg_m2 * p.slider_mass_kg / p0.slider_mass_kg)
    assert tiny(scale_inertia=False).design_params([1.1, 0.05]).slider_inertia_kg_m2 == p0.slider_inertia_kg_m2


def test_robust_with_one_point_distribution_equals_plain(tmp_path):
    plain = tiny(maxiter=0, popsize=1, include_prototype=True)
    one = tiny(maxiter=0, popsize=1, include_prototype=True, robust="mean",
               uncertain=[Uncertain("friction_coefficient", "uniform", low=0.1, high=0.3, levels=[0.2])],
               sampling_method="grid")
    assert one.samples_values() == [{"friction_coefficient": 0.2}]
    a = optimise(plain, checks=False)
    b = optimise(one, checks=False)
    assert len(a.search) == len(b.search) == 5  # scipy's smallest population
    for ra, rb in zip(a.search, b.search):
        assert ra["x"] == rb["x"]
        assert rb["bandwidth_hz"] == ra["bandwidth_hz"] and rb["harvest"] == ra["harvest"]
        assert rb["score"] == ra["score"]
    assert robust_value([3.0], "quantile", 0.1) == robust_value([3.0], "none") == 3.0


# --- the search, its file and resume ---------------------------------------------------------------

def strip(records):
    return [{k: v for k, v in r.items() if k != "wall_time_s"} for r in records]


def test_search_writes_one_line_per_design_and_refuses_overwrite(tmp_path):
    cfg = tiny(max_slider_mass_kg=0.05)
    res = optimise(cfg, out=tmp_path, check_t_end_s=1.5)
    header, records, _ = read_design_file(tmp_path)
    assert header["config"]["band"]["f_lo_hz"] == 120.0
    keys = [r["key"] for r in records]
    assert len(keys) == len(set(keys)) == len(res.records)
    assert res.prototype is not None and res.prototype["x"] == [1.05, Parameters().slider_mass_kg]
    infeasible = [r for r in res.search if not r["feasible"]]
    assert all("max_slider_mass_kg" in r["violation"] and r["runs"] == 0 for r in infeasible)
    assert all(r["runs"] == 2 for r in res.search if r["feasible"])
    assert res.best["feasible"] and res.best["score"] == max(r["score"] for r in res.search)
    assert "prototype_nominal" in res.checks and "best_nominal" in res.checks
    with pytest.raises(FileExistsError, match="resume"):
        optimise(cfg, out=tmp_path)
    with pytest.raises(ValueError, match="another configuration"):
        optimise(tiny(seed=5), out=tmp_path, resume=True)


def test_resume_after_a_killed_run(tmp_path, monkeypatch):
    cfg = tiny(maxiter=2)
    ref = optimise(cfg, out=tmp_path / "ref", checks=False)
    n = len(ref.records)
    assert n >= 6
    added = []
    real_add = DesignWriter.add

    def dying_add(self, record):
        if len(added) == 4:
            raise KeyboardInterrupt  # killed after four designs
        added.append(record["key"])
        return real_add(self, record)

    monkeypatch.setattr(DesignWriter, "add", dying_add)
    with pytest.raises(KeyboardInterrupt):
        optimise(cfg, out=tmp_path / "run", checks=False)
    monkeypatch.setattr(DesignWriter, "add", real_add)
    _h, partial, _ = read_design_file(tmp_path / "run")
    assert len(partial) == 4
    evaluated = []

    def counting_add(self, record):
        evaluated.append(record["key"])
        return real_add(self, record)

    monkeypatch.setattr(DesignWriter, "add", counting_add)
    res = optimise(cfg, out=tmp_path / "run", resume=True, checks=False)
    assert not set(evaluated) & {r["key"] for r in partial}  # no design twice
    assert res.evaluated_now == n - 4
    _h, records, _ = read_design_file(tmp_path / "run")
    assert len(records) == n and len({r["key"] for r in records}) == n
    assert strip(res.search) == strip(ref.search)
    assert res.best["x"] == ref.best["x"] and res.best["score"] == ref.best["score"]
    assert res.optimiser["nfev"] == ref.optimiser["nfev"]


def test_cli_design(tmp_path, capsys):
    cfg = tiny(maxiter=0, popsize=1)
    path = tmp_path / "design.toml"
    path.write_text(cfg.to_toml_text())
    assert cli_main(["design", "--config", str(path), "--out", str(tmp_path / "o"), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "design search" in out and "wrote" in out
    assert (tmp_path / "o" / "summary.json").exists()
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["evaluations_search"] == 5
    bad = tmp_path / "bad.toml"
    bad.write_text("[design]\nnot_a_field = [0.0, 1.0]\n")
    assert cli_main(["design", "--config", str(bad), "--out", str(tmp_path / "b")]) == 1
    assert "not_a_field" in capsys.readouterr().err
    assert not (tmp_path / "b").exists()


def test_print_config_is_valid(capsys):
    assert cli_main(["design", "--print-config"]) == 0
    cfg = DesignConfig.from_toml_text(capsys.readouterr().out)
    assert cfg.names == ["gap_ratio", "slider_mass_kg"]


# --- Dask -------------------------------------------------------------------------------------

def test_dask_search_equals_local(tmp_path, cluster):
    cfg = tiny(chunk_size=1)
    local = optimise(cfg, out=tmp_path / "local", checks=False, threads=2)
    dask = optimise(cfg, out=tmp_path / "dask", checks=False, scheduler=cluster)
    assert strip(dask.search) == strip(local.search)
    assert dask.best["x"] == local.best["x"]


def test_prototype_outside_the_bounds_is_not_rechecked():
    cfg = tiny(variables=[dict(name="gap_ratio", low=1.1, high=1.2)], include_prototype=False, maxiter=0)
    with pytest.raises(ValueError, match="include_prototype"):
        tiny(variables=[dict(name="gap_ratio", low=1.1, high=1.2)])
    res = optimise(cfg, check_t_end_s=1.5)
    assert res.prototype is None and "prototype_nominal" not in res.checks and res.checks["best_nominal"]["feasible"]


def test_predictor_run_records_the_law_content_and_refuses_a_changed_law(tmp_path):
    """A predictor search's file records the SHA-256 of the drift law file: resuming it after the
    law was refitted (same path, other content) is refused, with the same law it goes on."""
    import hashlib

    law = tmp_path / "law.json"
    law.write_text('{"kind": "beamslider drift law", "rho_c": 0.0119}', encoding="utf-8")
    cfg = tiny(evaluator="predictor", drift_law=str(law))
    path = tmp_path / "run" / "design.jsonl"
    DesignWriter(cfg, path, False).close()
    header, _, _ = read_design_file(path)
    assert header["drift_law_sha256"] == hashlib.sha256(law.read_bytes()).hexdigest()
    DesignWriter(cfg, path, True).close()  # same law: resumes
    law.write_text('{"kind": "beamslider drift law", "rho_c": 0.01497}', encoding="utf-8")
    with pytest.raises(ValueError, match="another content of the drift law"):
        DesignWriter(cfg, path, True)


def test_reference_designs_and_every_check_robust_over_the_same_sample():
    """Named reference designs are re-checked beside the search's best and its re-checks, every one
    robustly over the same fixed sample, and the FS-confirmed best is the re-checked search design
    with the highest FS robust bandwidth (an FS-only reference never wins that title)."""
    unc = [Uncertain("friction_coefficient", "uniform", low=0.15, high=0.3)]
    cfg = tiny(evaluator="predictor", drift_law="default", robust="mean", uncertain=unc, samples=2, recheck=2,
               maxiter=0, popsize=1, reference={"other": {"gap_ratio": 1.064}})
    assert np.allclose(cfg.reference_x(cfg.reference["other"]), [1.064, Parameters().slider_mass_kg])
    again = DesignConfig.from_toml_text(cfg.to_toml_text())
    assert again.reference == {"other": {"gap_ratio": 1.064}}
    res = optimise(cfg, check_t_end_s=1.5)
    names = {"prototype", "best", "recheck_0", "recheck_1", "ref_other"}
    assert {k[:-len("_robust")] for k in res.checks if k.endswith("_robust")} == names
    fs = {k: r for k, r in res.checks.items() if k.endswith("_robust")}
    assert all(r["evaluator"] == "fs" and len(r["samples"]) == 2 for r in fs.values())
    assert res.checks["ref_other_robust"]["variables"]["gap_ratio"] == 1.064
    name, rec = res.confirmed_best()
    assert name in ("best", "recheck_0", "recheck_1")
    assert rec["bandwidth_hz"] == max(fs[f"{n}_robust"]["bandwidth_hz"] for n in ("best", "recheck_0", "recheck_1"))
    assert res.summary()["confirmed_best"]["name"] == name and "FS-confirmed best" in res.text()


def test_reference_design_errors():
    with pytest.raises(ValueError, match=r"unknown key 'friction_coefficient' in \[reference.a\]"):
        tiny(reference={"a": {"friction_coefficient": 0.2}})
    with pytest.raises(ValueError, match="outside its bounds"):
        tiny(reference={"a": {"gap_ratio": 1.5}})
    with pytest.raises(ValueError, match="must be a table"):
        DesignConfig.from_toml_text("[design]\ngap_ratio = [1.02, 1.2]\n[reference]\na = 3\n")


def test_recheck_tolerance_spreads_the_rechecks_over_the_designs_the_predictor_cannot_tell_apart():
    """With ``recheck_tolerance_hz`` the re-checks are the best design and then, in turn, the one
    farthest (unit box of the bounds) from those chosen among the designs scoring within the
    tolerance of the best; infeasible and worse designs are never chosen. At 0 they are the best
    as ranked, and the option is absent from the file's header so older runs still resume."""
    from beamslider.design.optimise import recheck_choice

    cfg = tiny(variables=[dict(name="gap_ratio", low=1.01, high=1.21), dict(name="slider_mass_kg", low=0.02, high=0.06)],
               recheck=3, recheck_tolerance_hz=3.0)
    rows = [dict(key="a", x=[1.050, 0.040], score=30.0, feasible=True),
            dict(key="b", x=[1.051, 0.041], score=29.9, feasible=True),
            dict(key="c", x=[1.090, 0.040], score=29.0, feasible=True),   # 0.2 of the R/h range from a
            dict(key="d", x=[1.200, 0.060], score=99.0, feasible=False),  # infeasible: never
            dict(key="e", x=[1.051, 0.056], score=28.0, feasible=True),   # 0.4 of the mass range from a
            dict(key="f", x=[1.210, 0.020], score=26.0, feasible=True),   # 4 Hz below the best: never
            dict(key="a", x=[1.050, 0.040], score=30.0, feasible=True)]   # the same design again
    assert recheck_choice(rows, cfg) == ["a", "e", "c"]
    assert DesignConfig.from_toml_text(cfg.to_toml_text()).recheck_tolerance_hz == 3.0
    plain = tiny(variables=cfg.variables, recheck=3)
    assert recheck_choice(rows, plain) == ["a", "b", "c"]
    assert "recheck_tolerance_hz" not in plain.to_dict()["optimiser"]
    assert recheck_choice(rows[:1], cfg) == ["a"]
    with pytest.raises(ValueError, match="recheck_tolerance_hz"):
        tiny(recheck_tolerance_hz=-1.0)
