"""Discrepancy workflow, what the data resolve (docs/model.md §9.1): the measurement chain and the
contact spacing as candidates, a candidate named only when its interval excludes the baseline,
candidates that fit equally reported as a confounded group, and the advice."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import beamslider as bs
from beamslider import discover as dc
from beamslider.discover.chain import Model, chain_map, realise_model
from beamslider.discover.effects import CHAIN_EFFECTS, EFFECTS
from beamslider.discover.options import DiscoverOptions
from beamslider.discover.result import CandidateFit
from beamslider.discover.stats import lrt_threshold
from beamslider.discover.models import PATH_POINTS, batch_slider_features, measured_slider_features, slider_paths
from beamslider.discover.rule import (Reason, Why, kinds, negligible_fits, relevant_resolved, unnamed_verdict,
                                      unresolved_reasons)
from beamslider.discover.confounding import confounded_group, outside_fits_better
from beamslider.discover.stats import interval_of

S0_OFFSET = 0.0015
"""The truth runs start off the s0 their files name (no "inverse crime", as tests/test_discover.py)."""

CHAIN = dict(velocity_gain=1.07, position_offset=0.012, position_scale=1.03, time_base=1.004)


def test_chain_candidates_are_declared_with_thresholds():
    """The measurement chain and the contact spacing are slider-level candidates with a relevance
    threshold and its reason (docs/model.md §9.1); the chain leaves the physical parameters alone."""
    assert set(CHAIN_EFFECTS) == {"excitation_gain", "velocity_gain", "position_offset", "position_scale", "time_base"}
    p = bs.Parameters()
    for n in CHAIN_EFFECTS + ("contact_spacing",):
        e = EFFECTS[n]
        assert e.level == "slider" and e.relevance > 0 and "§9.1" in e.relevance_reason, n
        lo, hi = e.search
        assert e.lower <= lo < e.variable(e.baseline_value(p), p) < hi <= e.upper, n
    m = realise_model(p, {"excitation_gain": 0.95, "contact_spacing": 0.0115, "position_offset": 0.01})
    assert m.params == bs.Parameters(contact_spacing_m=0.0115)
    assert m.value("excitation_gain") == 0.95 and m.value("position_offset") == 0.01 and m.value("time_base") == 1.0
    assert dc.realise_effects(p, {"velocity_gain": 1.1}) == p
    assert EFFECTS["position_offset"].relevant(0.004, p)[0] is False
    assert EFFECTS["excitation_gain"].relevant(0.95, p)[0] is True


def test_chain_map_matches_the_signal_level_errors(tmp_path):
    """Noise-free runs written through a miscalibrated chain (velocity gain, camera offset and scale,
    time base applied to the signals by the synthesiser) give the features that the chain's map
    predicts from the model's (an independent route: signals against features)."""
    p = bs.Parameters()
    pts = [(124, 6, 0.3)]
    kw = dict(operating_points=pts, duration_s=6, noise_s=0.0, noise_velocity_m_s=0.0, seed=1)
    ideal = dc.synthesize_slider_runs(p, out_dir=tmp_path / "ideal", **kw)
    skewed = dc.synthesize_slider_runs(p, out_dir=tmp_path / "skewed", chain=CHAIN, **kw)
    f0, _, ops = measured_slider_features([bs.read_measurement(q) for q in ideal])
    f1, _, _ = measured_slider_features([bs.read_measurement(q) for q in skewed])
    m = Model(p, tuple(sorted(CHAIN.items())))
    assert set(f1) == set(f0) and len(f0) >= 4
    for k, f in f0.items():
        expect = chain_map(k, f.value, m)
        tol = 3e-3 * abs(expect)  # measured: within 1e-3 (the feature windows are not rescaled by tau)
        if k.startswith("f_recorded@"):
            tol = 1e-5 * abs(expect)  # a spectral peak: the stamps' scale exactly
        assert f1[k].value == pytest.approx(expect, abs=tol), k
        assert abs(f1[k].value - f.value) > 5 * tol, k  # the errors do show (2.5-7.5 %)
    # The model side: the runner's features of the model seen through the chain, the same map.
    plain, through = batch_slider_features([p, m], ops)
    for k, f in plain[0].items():
        assert through[0][k].value == pytest.approx(chain_map(k, f.value, m), rel=1e-12), k
    with pytest.raises(ValueError, match="measurement-chain"):
        dc.synthesize_slider_runs(p, out_dir=tmp_path / "bad", chain=dict(gain=1.0), **kw)


def test_the_recorded_frequency_is_the_spectral_peak_against_the_stamps():
    """recorded_frequency: a sine of known frequency (closed form) sampled at 1e-4 s, amplitude
    modulated as a slider run's envelope is, with noise: the peak within 1e-5 of the truth, and f/τ
    from stamps τ t; the segments' scatter as its error. The model records f_ex (chain: f_ex/τ)."""
    from beamslider.discover.features import recorded_frequency

    rng = np.random.default_rng(4)
    t = np.arange(0, 20, 1e-4)
    f = 123.4567
    v = (0.2 + 0.15 * np.tanh(t - 8)) * np.sin(2 * np.pi * f * t + 0.3) + 0.002 * rng.standard_normal(len(t))
    got, se = recorded_frequency(t, v, 124.0)
    assert got == pytest.approx(f, rel=1e-5) and 0 < se < 1e-3 * f
    got, _ = recorded_frequency(1.004 * t, v, 124.0)
    assert got == pytest.approx(f / 1.004, rel=1e-5)
    p = bs.Parameters()
    ops = [dc.OperatingPoint(124, 6, 0.3, 1.0)]
    plain, through = batch_slider_features([p, Model(p, (("time_base", 1.004),))], ops)
    assert plain[0]["f_recorded@124Hz_6ms2_s00.3"].value == 124.0
    assert through[0]["f_recorded@124Hz_6ms2_s00.3"].value == pytest.approx(124.0 / 1.004, rel=1e-12)


def test_the_advice_separates_the_camera_offset_from_its_scale_from_another_start():
    """A camera offset o and a scale k with o = (k - 1)·0.32 report the same positions where the
    slider stays near s = 0.3: the runs from s0 = 0.3 hardly tell them apart (the fitted models of
    the discover table, 10-s runs: distance 0.5 at (124, 14) and (104, 14)), a run from s0 = 0.15
    does (3.4 at (124, 14)), and the default advice grid offers it (DiscoverOptions.advice_grid)."""
    from beamslider.discover.advice import advise
    from beamslider.discover.options import DEFAULT

    ADVICE_GRID = DEFAULT.advice_grid

    p = bs.Parameters()
    fit = {"position_scale": 1.0361, "position_offset": 0.011667}
    ops = [dc.OperatingPoint(124, 14, 0.3, 10.0), dc.OperatingPoint(104, 14, 0.3, 10.0)]
    a = advise(list(fit), p, ops, ADVICE_GRID, fitted=fit)
    assert a["recommended"]["s0"] == 0.15 and a["recommended"]["score"] > 3 * a["at_measured_points"] > 0, a
    only_03 = advise(list(fit), p, ops, [g for g in ADVICE_GRID if g[2] == 0.3], fitted=fit)
    assert only_03["recommended"]["score"] < a["recommended"]["score"] / 2, only_03
    # 60 s from s0 = 0.15 at (124, 14) the slider ends at the clamping (s = 0.038, its contact point
    # 0.3 mm from it): never advised; at (116, 10) it ends at s = 0.065.
    from beamslider.discover.advice import fitted_differences

    CLAMP_CLEARANCE = DEFAULT.clamp_clearance

    at = lambda f, a: [dc.OperatingPoint(f, a, 0.15, 60.0)]  # noqa: E731
    assert fitted_differences(fit, p, at(124, 14), clearance=CLAMP_CLEARANCE) is None
    assert fitted_differences(fit, p, at(116, 10), clearance=CLAMP_CLEARANCE) is not None


def test_advice_says_when_no_run_of_its_grid_separates_a_group(monkeypatch):
    """A confounded group whose fitted models differ by less than options.weak_separation at every grid point:
    the advice says so instead of recommending the run; where a point separates them, it is
    recommended as before; a point where a run ends at the clamping (options.clamp_clearance) is never."""
    from beamslider.discover import advice

    dist = {(124.0, 6.0): 0.9, (110.0, 10.0): 1.5, (104.0, 10.0): 9.0}

    def fake(values, base, ops, threads=None, clearance=None, cache=None, options=None):
        if clearance is not None and ops[0].f_ex == 104.0:
            return None  # a run ends at the clamping: the point is skipped
        d = dist.get((ops[0].f_ex, ops[0].a_ex), 0.5) if len(ops) == 1 else 3.0
        return {"a": {"x": 0.0}, "b": {"x": d}}

    monkeypatch.setattr(advice, "fitted_differences", fake)
    ops = [dc.OperatingPoint(104, 14, 0.3, 10.0)]
    grid = [(124, 6, 0.3), (110, 10, 0.3), (104, 10, 0.3)]
    a = advice.advise(["a", "b"], bs.Parameters(), ops, grid, fitted={"a": 1.0, "b": 2.0})
    assert a["weak"] and a["text"].startswith("no run of the grid separates them by 2 uncertainties"), a
    assert (a["recommended"]["f_ex"], a["recommended"]["score"]) == (110, 1.5)
    dist[(124.0, 6.0)] = 4.0
    a = advice.advise(["a", "b"], bs.Parameters(), ops, grid, fitted={"a": 1.0, "b": 2.0})
    assert not a["weak"] and a["text"].startswith("add a run at f_ex = 124 Hz"), a
    a = advice.advise(["a", "b"], bs.Parameters(), ops, [(104, 10, 0.3)], fitted={"a": 1.0, "b": 2.0})
    assert a["recommended"] is None and "clamping" in a["note"], a


def test_identical_runs_are_made_once():
    """The chain's feature-level candidates re-read the baseline's runs: a cache of runs makes each
    run once (results identical to fresh runs)."""
    p = bs.Parameters()
    ops = [dc.OperatingPoint(110, 10, 0.3, 1.0)]
    cache: dict = {}
    a = batch_slider_features([p, Model(p, (("velocity_gain", 1.1),)), p], ops, cache=cache)
    assert len(cache) == 1
    b = batch_slider_features([Model(p, (("excitation_gain", 0.9),))], ops, cache=cache)
    assert len(cache) == 2
    fresh = batch_slider_features([p], ops)[0][0]
    assert {k: f.value for k, f in a[0][0].items()} == {k: f.value for k, f in fresh.items()}
    assert a[2][0]["amplitude_final_h@110Hz_10ms2_s00.3"].value == fresh["amplitude_final_h@110Hz_10ms2_s00.3"].value
    assert a[1][0]["amplitude_final_h@110Hz_10ms2_s00.3"].value == pytest.approx(
        1.1 * fresh["amplitude_final_h@110Hz_10ms2_s00.3"].value, rel=1e-12)
    assert b[0][0]["amplitude_final_h@110Hz_10ms2_s00.3"].value != fresh["amplitude_final_h@110Hz_10ms2_s00.3"].value


def test_the_reports_slider_paths_are_those_the_chain_records():
    """The report's figure draws the updated model as its measurement chain would record it: the
    camera's o + k s, the stamps τ t, the shaker at gain × a_ex (docs/model.md §9.1); an ideal chain
    draws the simulator's own path (the same s as ``simulate`` at those times)."""
    p = bs.Parameters()
    ops = [dc.OperatingPoint(124, 14, 0.3, 1.0)]
    chain = Model(p, (("position_offset", 0.01), ("position_scale", 1.02), ("time_base", 1.004)))
    ideal, seen, shaken = slider_paths([p, chain, Model(p, (("excitation_gain", 0.9),))], ops)
    (t, s), (tc, sc), (tg, sg) = ideal[0], seen[0], shaken[0]
    assert len(t) == 2001 < PATH_POINTS  # a run of fewer samples keeps them all
    assert np.array_equal(tc, 1.004 * t) and np.array_equal(sc, 0.01 + 1.02 * s)
    run = bs.simulate(p, f_ex=124, a_ex=14, s0=0.3, t_end=1.0, record_every=5)
    i = np.searchsorted(run.t, t[-1] - 1e-6)
    assert run.t[i] == pytest.approx(t[-1], rel=1e-6) and run.s[i] == pytest.approx(s[-1], rel=1e-6, abs=0)
    low = bs.simulate(p, f_ex=124, a_ex=0.9 * 14, s0=0.3, t_end=1.0, record_every=5)
    assert np.array_equal(tg, t) and low.s[i] == pytest.approx(sg[-1], rel=1e-6, abs=0)
    assert abs(low.s[i] - run.s[i]) > 1e-4


def _fit(name, value, interval, chi2=10.0, predicted=None):
    return CandidateFit((name,), {name: value}, {name: (interval[1] - interval[0]) / 2}, chi2, 9, True, chi2,
                        predicted=dict(predicted or {}), intervals={name: interval})


def test_an_interval_containing_the_baseline_is_not_resolved():
    """The issue's tilt of 2.2 ± 4.5 mrad: relevant by its point value, but its interval contains 0."""
    p = bs.Parameters()
    assert unresolved_reasons(_fit("tilt", 0.0022, (-0.0023, 0.0067)), p)[0].startswith("not resolved")
    assert unresolved_reasons(_fit("tilt", 0.008, (0.007, 0.009)), p) == []
    assert interval_of(_fit("tilt", 0.008, (0.007, 0.009)), "tilt") == (0.007, 0.009)
    beam = CandidateFit(("axial_preload",), {"axial_preload": 3.0}, {"axial_preload": 4.0}, 5.0, 5, True, 5.0)
    assert interval_of(beam, "axial_preload") == pytest.approx((3.0 - 1.96 * 4.0, 3.0 + 1.96 * 4.0), abs=1e-3)  # 95 %
    assert unresolved_reasons(beam, p)


def test_confounded_group_of_singles_within_the_threshold():
    """Single fits in full within the selection's threshold of the best form a group with the
    combination they resolve, however they move the features (the cosines are reported); one that
    fits clearly worse, one only screened or one fitted at a negligible change does not
    (docs/model.md §9.1, "Confounded")."""
    p = bs.Parameters()
    before = {"a": 0.0, "b": 0.0, "c": 0.0}
    sig = {"a": 1.0, "b": 1.0, "c": 1.0}
    j0 = p.slider_inertia_kg_m2
    fits = [_fit("slider_inertia", 0.82 * j0, (0.8 * j0, 0.84 * j0), 12.0, dict(a=3.0, b=-2.0, c=1.0)),
            _fit("contact_spacing", 0.0115, (0.0113, 0.0117), 12.8, dict(a=2.9, b=-2.1, c=0.9)),
            _fit("friction_coefficient", 0.25, (0.24, 0.26), 13.5, dict(a=-1.0, b=3.0, c=2.0)),
            _fit("com_offset", 0.005, (0.0048, 0.0052), 16.0, dict(a=3.0, b=-2.0, c=1.0))]
    reasons = {f.effects: [] for f in fits}
    g = confounded_group(fits[0], fits, reasons, before, sig, p, 1.0)
    assert g is not None and g["group"] == ["slider_inertia", "contact_spacing"]
    assert g["cos"]["contact_spacing"] > 0.95 and "contact_spacing_m" in g["combination"]
    g = confounded_group(fits[0], fits, reasons, before, sig, p, 2.0)   # moving the features otherwise
    assert g["group"] == ["slider_inertia", "contact_spacing", "friction_coefficient"]
    assert g["cos"]["friction_coefficient"] < 0.5
    assert confounded_group(fits[0], fits, reasons, before, sig, p, 5.0)["group"] == [
        "slider_inertia", "contact_spacing", "friction_coefficient", "com_offset"]
    reasons[("contact_spacing",)] = [Reason(Why.NEGLIGIBLE, "negligible change", "contact_spacing")]
    assert confounded_group(fits[0], fits, reasons, before, sig, p, 1.0) is None
    screened = dataclasses.replace(fits[1], screened=True)
    assert confounded_group(fits[0], [fits[0], screened], {f.effects: [] for f in fits}, before, sig, p, 1.0) is None


def test_the_goodness_of_fit_bound():
    """c·χ²₁₋α(share·(n − k)) (docs/model.md §9.1, "Goodness of fit"): a closed form, smaller with
    each fitted parameter, infinite where the test is off; the independent implementation's stand-in
    (gap 1.30 over 17 features) lies beyond it, a right model's usual χ² (about 7) within."""
    from scipy.stats import chi2
    from beamslider.discover.stats import gof_bound
    o = dc.DiscoverOptions()
    b = gof_bound(17, 1, o.gof_scale, o.gof_dof_share, 0.01)
    assert b == pytest.approx(o.gof_scale * chi2.ppf(0.99, o.gof_dof_share * 16))
    assert gof_bound(17, 2, o.gof_scale, o.gof_dof_share, 0.01) < b < gof_bound(17, 0, o.gof_scale, o.gof_dof_share)
    assert 7.0 < b < 1.30 ** 2 * 17
    assert gof_bound(17, 1, math.inf, 0.3) == math.inf


def _runs(tmp_path, truth, *, chain=None, points=((110, 10, 0.3), (124, 6, 0.3)), duration_s=15, seed=3, sub="data"):
    paths = dc.synthesize_slider_runs(truth, operating_points=list(points), duration_s=duration_s,
                                      out_dir=tmp_path / sub, seed=seed, s0_offset=S0_OFFSET, chain=chain)
    return [bs.read_measurement(q) for q in paths]


def test_a_truth_names_effects_of_the_library_as_discover_realises_them():
    """The synthesiser's truth holds parameters and effects by name: the detuning (no parameter of
    its own) scales the natural frequencies by its factor, an effect sets its parameter in the units
    discover reports, and the measurement chain's effects become the model's chain."""
    from beamslider.discover.synthesize import truth_from_toml_text

    m = truth_from_toml_text("natural_frequency_detuning = 1.03\ncontact_spacing = 0.0115\n"
                             "excitation_gain = 0.95\nfriction_coefficient = 0.3\n")
    base = bs.Parameters(friction_coefficient=0.3)
    assert m.params == dc.realise_effects(base, {"natural_frequency_detuning": 1.03, "contact_spacing": 0.0115})
    assert m.params.contact_spacing_m == 0.0115 and m.params.friction_coefficient == 0.3
    f = m.params.natural_frequencies_hz()
    f0 = bs.Parameters(contact_spacing_m=0.0115).natural_frequencies_hz()
    assert all(abs(a / b - 1.03) < 1e-12 for a, b in zip(f, f0))
    assert m.chain == (("excitation_gain", 0.95),)
    assert truth_from_toml_text("").params == bs.Parameters() and truth_from_toml_text("").chain == ()


@pytest.mark.parametrize("text, msg", [
    ("detuning = 1.03\n", "neither a parameter"),
    ("slider_mass = 0.05\nslider_mass_kg = 0.05\n", "twice"),
    ("tilt = 'x'\n", "finite number"),
    ("clearance = nan\n", "finite number"),
    ("slider_mass = -1\n", "slider_mass_kg"),
    ("natural_frequency_detuning = 0\n", "> 0"),
    ("x = [\n", "invalid TOML"),
])
def test_a_bad_truth_is_one_line_from_the_command(text, msg, tmp_path):
    from conftest import run_cli

    (tmp_path / "t.toml").write_text(text, encoding="utf-8")
    r = run_cli("synthesize", "slider", "--truth", "t.toml", "--out", str(tmp_path / "o"), cwd=tmp_path, timeout=60)
    assert r.returncode != 0 and msg in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "t.toml" in r.stderr, r.stderr
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_the_command_takes_the_truths_effects_and_refuses_a_chain_set_twice(tmp_path):
    from conftest import run_cli

    (tmp_path / "t.toml").write_text("natural_frequency_detuning = 1.03\nexcitation_gain = 0.95\n", encoding="utf-8")
    r = run_cli("synthesize", "slider", "--truth", "t.toml", "--points", "124,14,0.3", "--duration", "0.5",
                "--seed", "4", "--out", "cli", "--no-progress", cwd=tmp_path, timeout=120)
    assert r.returncode == 0, r.stderr
    lib = dc.synthesize_slider_runs(dc.realise_effects(bs.Parameters(), {"natural_frequency_detuning": 1.03}),
                                    operating_points=[(124, 14, 0.3)], duration_s=0.5, out_dir=tmp_path / "lib",
                                    seed=4, chain={"excitation_gain": 0.95})
    (cli,) = sorted((tmp_path / "cli").glob("*.txt"))
    assert cli.name == lib[0].name and cli.read_bytes() == lib[0].read_bytes()
    for args, msg in ((["slider", "--chain", "excitation_gain=0.9"], "set twice"), (["enma"], "slider runs only")):
        r = run_cli("synthesize", *args, "--truth", "t.toml", "--out", str(tmp_path / "o"), cwd=tmp_path, timeout=60)
        assert r.returncode != 0 and msg in r.stderr and "Traceback" not in r.stderr, r.stderr
        assert len(r.stderr.strip().splitlines()) == 1, r.stderr


@pytest.mark.parametrize("args, msg", [
    (["synthesize", "slider", "--chain", "gain=0.9"], "measurement-chain"),
    (["synthesize", "slider", "--chain", "excitation_gain=x"], "--chain"),
    (["discover", "--measured", "nothing.txt", "--advice-grid", "1,2"], "--advice-grid"),
])
def test_cli_rejects_a_bad_chain_or_advice_grid(args, msg, tmp_path):
    from conftest import run_cli

    r = run_cli(*args, "--out", str(tmp_path / "o"), cwd=tmp_path, timeout=60)
    assert r.returncode != 0 and msg in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr


EXCITATION = dict(excitation_gain=0.95)
"""A calibration error of the shaker's control: it ran 5 % below the level the files name."""


@pytest.mark.heavy
def test_the_only_candidate_is_named_where_the_baseline_ensemble_fits_clearly_worse(tmp_path):
    """A 5 % excitation-level error in one 10-s run at (124 Hz, 6 m/s²) with restitution as the only
    candidate. Restitution's single runs are rough and flat over the search range, so the scan's
    interval reaches the baseline 0.5; the baseline's own ensemble fits worse than the fit's by far
    more than z², so the interval stops short of 0.5 at the parabolic crossing (docs/model.md §9.1,
    "One effect"), and the one candidate offered, which fits as right models do, is named. Discover
    names among the candidates it is given: here a stand-in (with the excitation gain among them,
    the next test)."""
    runs = _runs(tmp_path, bs.Parameters(), chain=EXCITATION, points=[(124, 6, 0.3)], duration_s=10)
    d = dc.discover(measured=runs, effects=["restitution"], advice_grid=[(124, 14, 0.3), (110, 10, 0.3)])
    assert d.verdict == "named" and d.named_effects == ["restitution"], dc.verdict_line(d)
    fit = [c for c in d.candidates if c.effects == ("restitution",)][0]
    lo, hi = interval_of(fit, "restitution")
    v = fit.values["restitution"]
    assert lo <= v <= hi and not lo <= 0.5 <= hi, (lo, v, hi)
    delta = d.gap_before ** 2 * len(d.features) - fit.chi2
    assert delta > 1.96 ** 2, delta
    assert lo >= v + (0.5 - v) * 1.96 / math.sqrt(delta) - 1e-9, (lo, delta)   # no wider than the crossing
    assert "named restitution" in dc.verdict_line(d)


@pytest.mark.heavy
@pytest.mark.xfail(reason="this version answers 'none' (a negligible friction change closes the gap) where the "
                          "excitation gain was the best candidate not resolved: a miss of the goodness-of-fit rule's "
                          "version, open in docs/validation/discover.md", strict=False)
def test_excitation_level_error_in_two_short_runs_is_the_best_candidate_not_resolved(tmp_path):
    """The same 5 % error in 10-s runs at (124, 6) and (116, 10), the excitation gain among the
    candidates with tilt and friction (the issue's case named a tilt): the excitation gain is the
    best candidate, its fit contains the truth, but its 95 % interval (docs/model.md §9.1) still
    contains 1 with two short runs, so the verdict is 'unexplained … not resolved' and the model
    is not changed; tilt is not named either."""
    runs = _runs(tmp_path, bs.Parameters(), chain=EXCITATION, points=[(124, 6, 0.3), (116, 10, 0.3)], duration_s=10)
    d = dc.discover(measured=runs, effects=["excitation_gain", "tilt", "friction_coefficient"], advice_grid=())
    line = dc.verdict_line(d)
    assert d.verdict == "unexplained" and "best candidate excitation_gain" in line and "not resolved" in line, line
    fit = [c for c in d.candidates if c.effects == ("excitation_gain",)][0]
    lo, hi = interval_of(fit, "excitation_gain")
    assert lo < 0.95 < hi and lo <= 1.0 <= hi, (lo, hi)
    assert d.named_effects == [] and d.updated == d.baseline


@pytest.mark.heavy
def test_confounded_contact_spacing_and_inertia_and_the_advice_that_separates_them(tmp_path):
    """The contact spacing 15 % wider than the baseline's, one 10-s run at (124, 6): the slider's
    inertia fits as well as the spacing (both enter its rocking through J/(m B²); the issue's case
    named the inertia), so the verdict is 'confounded' with both, the combination the data resolve
    and the run that separates them: at (110, 10) the two fitted models' features differ by 5.5
    uncertainties, at (120, 6) by 4.4 (their run-to-run spread is large there), at (124, 6) by 0.9
    (measured with 10-s runs). Advice that works: with the recommended run added, the contact
    spacing alone is named, within two standard errors of the truth, and the inertia no longer fits."""
    truth = bs.Parameters(contact_spacing_m=0.0115)
    runs = _runs(tmp_path, truth, points=[(124, 6, 0.3)], duration_s=10)
    d = dc.discover(measured=runs, effects=["slider_inertia", "contact_spacing"],
                    advice_grid=[(110, 10, 0.3), (120, 6, 0.3)])
    assert d.verdict == "confounded" and d.named_effects == [] and d.updated == d.baseline, dc.verdict_line(d)
    c = d.confounded
    assert sorted(c["group"]) == ["contact_spacing", "slider_inertia"], c
    assert "slider_inertia_kg_m2" in c["combination"] and "contact_spacing_m" in c["combination"]
    assert c["values"]["contact_spacing"] > 0.0102 and c["values"]["slider_inertia"] < 0.95 * 3.15e-6, c
    rec = c["advice"]["recommended"]
    assert (rec["f_ex"], rec["a_ex"]) == (110, 10), c["advice"]
    assert rec["score"] > 2 * c["advice"]["at_measured_points"], c["advice"]
    assert "confounded" in dc.verdict_line(d)
    dc.write_report(d, tmp_path / "rep")
    md = (tmp_path / "rep" / "report.md").read_text()
    assert "Confounded" in md and "Advice" in md and " in [" in md
    # The recommended run, added.
    extra = _runs(tmp_path, truth, points=[(rec["f_ex"], rec["a_ex"], rec["s0"])], duration_s=rec["duration_s"],
                  sub="extra")
    d2 = dc.discover(measured=runs + extra, effects=["slider_inertia", "contact_spacing"], advice_grid=())
    assert d2.verdict == "named" and d2.named_effects == ["contact_spacing"], dc.verdict_line(d2)
    q = d2.parameters["contact_spacing"]
    assert abs(q["value"] - 0.0115) <= 2 * q["stderr"], q
    assert any(r["effects"] == ["slider_inertia"] and r["reasons"][0].startswith("not adequate") for r in d2.rejected)


def test_linearised_pair_ranking_finds_two_effects_that_fit_badly_alone():
    """Data that are the sum of two candidates' signatures: that pair is predicted to fit exactly
    (χ² 0) although neither fits alone; a pair with a candidate that moves other features does not."""
    from beamslider.discover.separability import rank_pairs

    sens = {"friction_coefficient": {"a": 1.0, "b": 2.0, "c": 0.0, "d": 1.0},
            "natural_frequency_detuning": {"a": -1.0, "b": 1.0, "c": 3.0, "d": 0.0},
            "tilt": {"a": 0.0, "b": 0.0, "c": 0.0, "d": 5.0},
            "com_offset": {"a": 1.0, "b": 0.0, "c": 0.0}}
    r = {k: 2.5 * sens["friction_coefficient"][k] - 1.5 * sens["natural_frequency_detuning"][k] for k in "abcd"}
    r["e"] = 0.5  # moved by none of them: counts r² in every prediction
    ranked = rank_pairs(sens, r)
    assert ranked[0][0] == ("friction_coefficient", "natural_frequency_detuning")
    assert ranked[0][1] == pytest.approx(0.25, abs=1e-9) and ranked[1][1] > 5.0
    assert len(ranked) == 6 and [c for _, c in ranked] == sorted(c for _, c in ranked)


@pytest.mark.parametrize("grid", [[(110, 10)], [(110, 10, "x")], [(110, math.nan, 0.3)], 5])
def test_a_bad_advice_grid_is_a_one_line_error(grid, tmp_path):
    runs = _runs(tmp_path, bs.Parameters(), points=[(110, 10, 0.3)], duration_s=1)
    with pytest.raises(ValueError, match="advice_grid"):
        dc.discover(measured=runs, effects=["friction_coefficient"], advice_grid=grid)


def _spacing_and_restitution(spacing, rest, dof):
    """A contact spacing moved by a negligible 0.6 % and restitution 0.5 -> 0.3, each fitted alone:
    (χ², standard error, 95 % interval) of each, and their degrees of freedom."""
    (c_s, se_s, iv_s), (c_r, se_r, iv_r) = spacing, rest
    return (CandidateFit(("contact_spacing",), {"contact_spacing": 0.010062}, {"contact_spacing": se_s}, c_s, dof,
                         True, c_s, intervals={"contact_spacing": iv_s}),
            CandidateFit(("restitution",), {"restitution": 0.3}, {"restitution": se_r}, c_r, dof, True, c_r,
                         intervals={"restitution": iv_r}))


def test_a_negligible_change_that_fits_is_none_only_if_no_relevant_change_is_resolved():
    """Restitution 0.5 -> 0.3 fits adequately and its 95 % interval excludes 0.5, and a contact
    spacing moved by a negligible 0.6 % fits too: the data resolve a relevant change, so the
    negligible one does not make the baseline adequate (not "none"). With restitution's interval
    reaching 0.5 (not resolved) the negligible change stands: the baseline is adequate."""
    from beamslider.discover.rule import judge

    base = bs.Parameters()
    spacing, rest = _spacing_and_restitution((10.0, 1e-4, (0.0098, 0.0103)), (9.0, 0.07, (0.12, 0.45)), dof=11)
    fits = [spacing, rest]
    reasons = judge(fits, base, 12, 5.0, 0.3)
    assert reasons[("restitution",)] == [] and reasons[("contact_spacing",)][0].startswith("negligible change")
    assert negligible_fits(fits, reasons) == [spacing]
    assert relevant_resolved(fits, reasons) == [rest]
    rest.intervals["restitution"] = (0.12, 0.55)
    reasons = judge(fits, base, 12, 5.0, 0.3)
    assert reasons[("restitution",)][0].startswith("not resolved")
    assert relevant_resolved(fits, reasons) == [] and negligible_fits(fits, reasons) == [spacing]
    # An inadequate relevant fit does not count: the negligible change fits better.
    rest.intervals["restitution"] = (0.12, 0.45)
    rest.adequate = False
    assert relevant_resolved(fits, judge(fits, base, 12, 5.0, 0.3)) == []


def test_a_relevant_change_that_a_negligible_one_fits_better_is_not_named():
    """The χ² values of restitution 0.5 -> 0.7 hidden in the three reference 60-s runs with
    restitution not a candidate (docs/results/discover/table.md): a tilt of 5.6 mrad fits (χ² 16.7)
    and its interval [1.6, 9.1] mrad excludes 0, but an excitation gain of 1.0125, below its 2 %
    threshold, fits better (χ² 10.4): the tilt is not named; being resolved it still makes the
    verdict "unexplained", not "none". Restitution itself, a candidate, fits at χ² 4.1 and is named.
    A pair is charged its second parameter: it must beat a negligible single by the threshold."""
    from beamslider.discover.rule import judge
    from beamslider.discover.rule import select

    base = bs.Parameters()
    thr, eb = lrt_threshold(1, 13), 2.89

    def one(name, value, chi2, iv):
        return CandidateFit((name,), {name: value}, {name: 1e-3}, chi2, 16, True, chi2, intervals={name: iv})

    tilt = one("tilt", 0.0055556, 16.73, (0.0016, 0.0091))
    gain = one("excitation_gain", 1.0125, 10.39, (1.004, 1.02))
    fits = [tilt, gain]
    plain = judge(fits, base, 17, eb, 0.3)
    assert plain[("tilt",)] == [] and negligible_fits(fits, plain) == [gain]
    assert select([f for f in fits if not plain[f.effects]], 158.6, 17, False)[0] is tilt  # named without the rule
    reasons = judge(fits, base, 17, eb, 0.3, thr)
    assert [r.kind for r in reasons[("tilt",)]] == [Why.NEGLIGIBLE_FITS_BETTER], reasons
    assert "excitation_gain 1.012" in reasons[("tilt",)][0] and "16.7" in reasons[("tilt",)][0]
    assert select([f for f in fits if not reasons[f.effects]], 158.6, 17, False)[0] is None
    assert relevant_resolved(fits, reasons) == [tilt]
    assert unnamed_verdict(fits, reasons, thr) == ("unexplained", None, None)
    # Better than the negligible change: named as before (restitution 0.675 at χ² 4.06).
    rest = one("restitution", 0.675, 4.06, (0.622, 0.713))
    assert judge([rest, gain], base, 17, eb, 0.3, thr)[("restitution",)] == []
    tilt.chi2 = 10.38
    assert judge(fits, base, 17, eb, 0.3, thr)[("tilt",)] == []
    # A pair pays for its second parameter.
    pair = CandidateFit(("tilt", "restitution"), {"tilt": 0.004, "restitution": 0.6}, {"tilt": 1e-3, "restitution": 0.02},
                        10.39 - thr + 0.01, 15, True, 0.0, intervals={"tilt": (0.002, 0.006), "restitution": (0.56, 0.64)})
    assert [r.kind for r in judge([pair, gain], base, 17, eb, 0.3, thr)[pair.effects]] == [Why.NEGLIGIBLE_FITS_BETTER]
    pair.chi2 -= 0.02
    assert judge([pair, gain], base, 17, eb, 0.3, thr)[pair.effects] == []


def test_a_set_that_a_left_out_effect_fits_clearly_better_is_not_named():
    """The χ² values of f0 × 0.98 hidden in the three reference 60-s runs with the detuning not a
    candidate (docs/results/discover/table.md): the candidates' best set, an excitation gain of
    0.929 with a velocity gain of 1.058, passes the naming rule at χ² 17.2, while the detuning
    alone, left out, fits at 4.4: better by more than the selection's threshold with each set
    charged it per parameter (χ²_X + t < χ²_best + 2t − t). Only the best predicted left-out
    effects are fitted, and only one that passes the naming rule alone counts."""
    from beamslider.discover.rule import judge

    base = bs.Parameters()
    thr = lrt_threshold(1, 13)
    pair = CandidateFit(("excitation_gain", "velocity_gain"), {"excitation_gain": 0.929, "velocity_gain": 1.058},
                        {"excitation_gain": 0.026, "velocity_gain": 0.016}, 17.2, 15, True, 0.0,
                        intervals={"excitation_gain": (0.877, 0.981), "velocity_gain": (1.028, 1.089)})
    assert judge([pair], base, 17, 1.57, 0.3, thr)[pair.effects] == []

    def confirm(chi2, iv=(0.9737, 0.9853)):
        calls = []

        def fit(name):
            calls.append(name)
            v, c2, i = (0.9778, chi2, iv) if name == "natural_frequency_detuning" else (0.004, 60.0, (0.002, 0.006))
            f = CandidateFit((name,), {name: v}, {name: 0.0047}, c2, 16, c2 < 32.0, 0.0, intervals={name: i})
            return f, judge([f], base, 17, 1.57, 0.3)[f.effects]
        return fit, calls

    pred = {"natural_frequency_detuning": (9.0, 0.978), "slider_mass": (80.0, 0.05), "tilt": (60.0, 0.004)}
    fit, calls = confirm(4.4)
    why = outside_fits_better(pair, pred, fit, thr)
    assert why is not None and why.kind is Why.OUTSIDE_FITS_BETTER, why
    assert "natural_frequency_detuning" in why and "4.4 against 17.2" in why
    assert calls == ["natural_frequency_detuning", "tilt"]  # the two best predicted, fitted in full
    # Better, but not by the threshold: 17.2 + 2t − (χ² + t) must exceed t.
    assert outside_fits_better(pair, pred, confirm(17.19)[0], thr) is not None
    assert outside_fits_better(pair, pred, confirm(17.21)[0], thr) is None
    # A single set must be beaten by the threshold itself.
    single = CandidateFit(("excitation_gain",), {"excitation_gain": 0.95}, {"excitation_gain": 0.01}, 20.0, 16, True,
                          0.0, intervals={"excitation_gain": (0.93, 0.97)})
    assert outside_fits_better(single, pred, confirm(20.0 - thr - 0.01)[0], thr) is not None
    assert outside_fits_better(single, pred, confirm(20.0 - thr + 0.01)[0], thr) is None
    # A left-out effect that does not pass the naming rule alone (its interval holds the baseline) does not count.
    assert outside_fits_better(pair, pred, confirm(4.4, (0.97, 1.01))[0], thr) is None
    assert outside_fits_better(pair, {}, confirm(4.4)[0], thr) is None


def test_a_relevant_unresolved_fit_far_better_than_a_negligible_one_is_unexplained():
    """The χ² values of restitution 0.3 hidden in the three 60-s runs (the slow test below): a
    negligible contact-spacing change fits (χ² 18.5), restitution 0.3 fits far better (χ² 2.9) but
    its interval [0.2, 0.543] reaches the baseline 0.5. The difference, 15.6, exceeds the
    selection's likelihood-ratio threshold for one effect of 14 (11.45): "unexplained" with
    restitution as the unresolved best candidate, not "none". Within the threshold the negligible
    change stands: "none" — if it closes the gap as a named set must (at most 0.3 of the gap beyond
    the noise left); one that leaves more explains no more than the baseline: "unexplained". A negligible pair pays the threshold for its second parameter. A
    resolved relevant change leaves no best unresolved candidate."""
    from beamslider.discover.rule import judge

    base = bs.Parameters()
    eb = 5.0  # the gap beyond the noise before: the negligible change closes it as a named set must
    thr = lrt_threshold(1, 14)
    assert thr == pytest.approx(11.45, abs=0.01)
    spacing, rest = _spacing_and_restitution((18.49, 4e-4, (0.009291, 0.01102)), (2.92, 0.09, (0.2, 0.5431)), dof=12)
    fits = [spacing, rest]
    reasons = judge(fits, base, 13, eb, 0.3)
    assert [r.kind for r in reasons[("restitution",)]] == [Why.NOT_RESOLVED]
    assert kinds(reasons[("contact_spacing",)]) == {Why.NEGLIGIBLE, Why.NOT_RESOLVED}
    assert negligible_fits(fits, reasons) == [spacing]
    assert unnamed_verdict(fits, reasons, thr) == ("unexplained", None, rest)
    rest.chi2 = spacing.chi2 - thr + 0.01
    assert unnamed_verdict(fits, judge(fits, base, 13, eb, 0.3), thr) == ("none", spacing, None)
    # Before the gap was 1.25 beyond the noise: the negligible change leaves 0.71 of it (> 0.3 x).
    small = judge(fits, base, 13, 1.25, 0.3)
    assert Why.SMALL_SHARE in kinds(small[("contact_spacing",)]) and negligible_fits(fits, small) == []
    assert unnamed_verdict(fits, small, thr) == ("unexplained", None, rest)
    # A negligible pair is charged its second parameter (the selection's price of adding one): it
    # gives "none" only if it fits at least as well as restitution alone.
    rest.chi2 = 2.92
    pair = CandidateFit(("com_offset", "tilt"), {"com_offset": 0.0040625, "tilt": 1e-4},
                        {"com_offset": 5e-5, "tilt": 1e-3}, 4.0, 11, True, 4.0,
                        intervals={"com_offset": (0.0039, 0.0042), "tilt": (-0.002, 0.002)})
    fits3 = [spacing, rest, pair]
    reasons = judge(fits3, base, 13, eb, 0.3)
    assert negligible_fits(fits3, reasons) == [spacing, pair]
    assert unnamed_verdict(fits3, reasons, thr) == ("unexplained", None, rest)
    pair.chi2 = 2.5
    assert unnamed_verdict(fits3, judge(fits3, base, 13, eb, 0.3), thr) == ("none", pair, None)
    rest.intervals["restitution"] = (0.2, 0.45)
    assert unnamed_verdict(fits, judge(fits, base, 13, eb, 0.3), thr) == ("unexplained", None, None)
    # The reasons keep their kind and effect through pickling (a report's reasons are their text).
    import pickle

    r = pickle.loads(pickle.dumps(reasons[("contact_spacing",)][0]))
    assert isinstance(r, Reason) and r.kind is Why.NEGLIGIBLE and r.effect == "contact_spacing"
    assert r.startswith("negligible change of contact_spacing_m")


def test_delta_chi2_interval_of_a_scan():
    from beamslider.discover.fitting import _interval

    x = np.linspace(0.0, 2.0, 41)
    best, lo, hi = _interval(x, (x - 1.0) ** 2 / 0.1 ** 2 + 3.0)
    assert best == pytest.approx(1.0) and lo == pytest.approx(0.9) and hi == pytest.approx(1.1)
    # A coarse scan of the same parabola (step 0.25 = 2.5 sigma) still gives the interval exactly.
    xc = np.linspace(0.0, 2.0, 9)
    assert _interval(xc, (xc - 1.0) ** 2 / 0.1 ** 2)[1:] == pytest.approx((0.9, 1.1))
    # Not crossing chi2_min + 1 inside the scan: the scan's end; rough profiles: the outermost points.
    assert _interval(x, np.zeros_like(x))[1:] == (0.0, 2.0)
    f = np.full_like(x, 50.0)
    f[[10, 30]] = [1.0, 1.5]
    assert _interval(x, f)[1] < 0.5 < 1.5 < _interval(x, f)[2]


def test_rough_profile_widens_the_interval():
    """A χ² scan that scatters about a parabola (single runs of a chaotic objective) gets an interval
    widened by twice the scatter, which covers the parabola's minimum; a smooth one is unchanged."""
    from beamslider.discover.fitting import _interval
    from beamslider.discover.spread import chi2_roughness

    x = np.linspace(0.2, 0.4, 21)
    smooth = (x - 0.3) ** 2 / 0.01 ** 2
    assert chi2_roughness(x, smooth) == pytest.approx(0.0, abs=1e-9)
    assert _interval(x, smooth, chi2_roughness(x, smooth))[1:] == pytest.approx((0.29, 0.31), abs=1e-9)
    bumps = (x - 0.3) ** 2 / 0.02 ** 2 + np.where(np.arange(x.size) % 2 == 0, 0.0, 6.0)  # minimum 0.3, scatter ~3
    bumps[8] -= 1.5  # the luckiest run at 0.28
    best, lo, hi = _interval(x, bumps, chi2_roughness(x, bumps))
    assert best == pytest.approx(0.28) and 2.0 < chi2_roughness(x, bumps) < 4.0
    assert lo < 0.27 and hi > 0.33
    plain = _interval(x, bumps)
    assert 0.27 < plain[1] and plain[2] < 0.31  # the plain Δχ² = 1 interval: 0.28 (+0.025)


def test_a_fit_keeps_the_scanned_point_whose_ensemble_fits_better():
    """fitting.profile_fit on a rough objective (docs/model.md §9.1, "One effect"): the single runs'
    scan picks a point, the ensemble there widens the spread, and the scan picked again with it moves
    to a point whose ensemble fits far worse (an excitation gain 1.04 hidden: the ensemble at 1.0375
    fits at χ² 9.7, the point picked again, 1.0, at 149.6, and the candidate was screened out). The
    fit is the first pick where its ensemble fits better by more than z² (here by 9), and its
    interval holds its value."""
    from beamslider.discover.features import Feature
    from beamslider.discover.fitting import profile_fit
    from beamslider.discover.models import Ensemble

    e, base = EFFECTS["friction_coefficient"], bs.Parameters()
    grid = np.linspace(*e.search, 9)
    good = round(float(grid[6]), 9)    # 0.4

    def mu(m):
        return round(float(m.params.friction_coefficient), 9)

    def single(v):   # one run: the features a, b in units of their uncertainty 1, data at 0
        if v == good:
            return dict(a=0.5, b=0.5)
        return dict(a=3.0, b=0.0) if v < good else dict(a=10.0, b=1.0)   # below it the lure

    def ensemble(v):  # at `good` the runs split (a spreads by 10), below it they agree on a = 3
        mean = dict(a=0.2, b=0.2) if v == good else single(v)
        return Ensemble(mean, dict(a=10.0 if v == good else 0.0, b=0.0), 5, {})

    meas = {k: Feature(k, 0.0, 1.0) for k in ("a", "b")}
    many = lambda ps: [single(mu(m)) for m in ps]  # noqa: E731
    ens = lambda ps, central: [ensemble(mu(m)) for m in ps]  # noqa: E731
    for refine in (0, 2):
        f = profile_fit([e], base, meas, model_many=many, ensemble_many=ens, spread0=dict(a=0.0, b=0.0),
                        refine=refine)
        assert f.values[e.name] == pytest.approx(good)
        assert f.chi2 == pytest.approx(0.04 / 121 + 0.04)  # the ensemble at `good`, σ_a² = 1 + 1.2·100
        lo, hi = f.intervals[e.name]
        assert lo <= good <= hi
    # Where the first pick fits better by less than z² (3.84), the refined point stands.
    near = lambda ps, central: [Ensemble(dict(a=1.5, b=0.0), dict(a=0.0, b=0.0), 5, {}) if mu(m) < good  # noqa: E731
                                else ensemble(mu(m)) for m in ps]
    # (Without the grid's rescoring of a poor single, tested apart: on two features χ² 2.25 lies above
    # right models' 90 % quantile.)
    f = profile_fit([e], base, meas, model_many=many, ensemble_many=near, spread0=dict(a=0.0, b=0.0),
                    options=DiscoverOptions(poor_single_alpha=0.0))
    assert f.values[e.name] < good and f.chi2 == pytest.approx(2.25)
    # Without the ensemble at the first pick the point picked again would be the fit (χ² 9): check it is
    # the re-pick that moves, so that the test can fail.
    sp = dict(a=10.0, b=0.0)
    chi2_single = {v: sum((single(v)[k] / math.sqrt(1 + 2 * sp[k] ** 2)) ** 2 for k in "ab")
                   for v in (round(float(g), 9) for g in grid)}
    assert min(chi2_single, key=chi2_single.get) < good


def test_a_poor_single_is_refined_from_its_grid_rescored_on_ensembles():
    """fitting.profile_fit, one effect (docs/model.md §9.1, "Sets of effects"): the truth's grid point
    drew an unlucky single run, so the scan settles on a lure whose ensemble fits worse than right
    models do; the grid rescored on ensemble means finds the truth's point (a contact spacing of
    9.11 mm scanned to 9.94 mm at χ² 193, where the truth's ensemble fits at 5.7). Without the
    poor single's refinement (``poor_single_alpha`` 0) the lure stands, so that the test can fail."""
    from beamslider.discover.features import Feature
    from beamslider.discover.fitting import profile_fit
    from beamslider.discover.models import Ensemble

    e, base = EFFECTS["friction_coefficient"], bs.Parameters()
    grid = np.linspace(*e.search, 9)
    good = round(float(grid[6]), 9)

    def mu(m):
        return round(float(m.params.friction_coefficient), 9)

    def single(v):  # one run: the truth's point drew a run in the other end state
        return dict(a=10.0, b=1.0) if v >= good else dict(a=3.0, b=0.0)

    def ensemble(v):  # the means: only the truth's point fits
        mean = dict(a=0.2, b=0.2) if v == good else (dict(a=3.0, b=0.0) if v < good else dict(a=10.0, b=1.0))
        return Ensemble(mean, dict(a=0.0, b=0.0), 5, {})

    meas = {k: Feature(k, 0.0, 1.0) for k in ("a", "b")}
    many = lambda ps: [single(mu(m)) for m in ps]  # noqa: E731
    ens = lambda ps, central: [ensemble(mu(m)) for m in ps]  # noqa: E731
    f = profile_fit([e], base, meas, model_many=many, ensemble_many=ens, spread0=dict(a=0.0, b=0.0))
    assert f.values[e.name] == pytest.approx(good)
    assert f.chi2 < 1.0
    lo, hi = f.intervals[e.name]
    assert lo <= good <= hi
    f0 = profile_fit([e], base, meas, model_many=many, ensemble_many=ens, spread0=dict(a=0.0, b=0.0),
                     options=DiscoverOptions(poor_single_alpha=0.0))
    assert f0.values[e.name] < good and f0.chi2 > 8.0


def test_a_rough_scan_that_picks_the_baseline_is_rescored_on_ensembles(monkeypatch):
    """fitting.profile_fit, one effect (docs/model.md §9.1, "One effect"): single runs that switch end
    states from one scan point to the next (Δχ² of hundreds) leave the baseline's own run the best,
    so the scan finds nothing; the ensembles' means are smooth and have their minimum off the grid.
    The grid rescored on ensembles and refined by Gauss–Newton on their means finds the minimum (the
    closed form: the means are linear in μ, so one step lands on it); its interval, that of the
    ensembles' profile, is here the closed form's ±1.96/sqrt(JᵀJ) and excludes the baseline. Without
    the rescan (threshold infinite) the fit stays at the baseline, so that the test can fail; a
    valley within the relevance threshold is not taken."""
    import dataclasses

    from beamslider.discover.features import Feature
    from beamslider.discover.fitting import profile_fit
    from beamslider.discover.models import Ensemble
    from beamslider.discover.options import DEFAULT

    e, base = EFFECTS["friction_coefficient"], bs.Parameters()
    truth, b0 = 0.33, 0.2   # off the grid 0.1, 0.15, ..., 0.5; the baseline on it

    def mu(m):
        return round(float(m.params.friction_coefficient), 9)

    slope = 1.0

    def mean(v):
        return dict(a=100.0 * slope * (v - truth), b=50.0 * slope * (v - truth))

    def single(v):   # the baseline's own run fits (χ² 9); elsewhere a run ends in another state
        if v == b0:
            return dict(a=3.0, b=0.0)
        m = mean(v)
        return dict(a=m["a"] + (40.0 if round(v * 3e4) % 2 else -40.0), b=m["b"])

    meas = {k: Feature(k, 0.0, 1.0) for k in ("a", "b")}
    many = lambda ps: [single(mu(m)) for m in ps]  # noqa: E731
    ens = lambda ps, central: [Ensemble(mean(mu(m)), dict(a=0.0, b=0.0), 5, {}) for m in ps]  # noqa: E731
    f = profile_fit([e], base, meas, model_many=many, ensemble_many=ens, spread0=dict(a=0.0, b=0.0))
    assert f.values[e.name] == pytest.approx(truth, abs=1e-6)
    assert f.chi2 == pytest.approx(0.0, abs=1e-6)
    se = 1 / math.sqrt(100.0 ** 2 + 50.0 ** 2)   # (JᵀJ)^-1/2 of the linear means
    assert f.stderrs[e.name] == pytest.approx(se, rel=1e-3)
    lo, hi = f.intervals[e.name]
    assert lo == pytest.approx(truth - 1.96 * se, rel=1e-3) and hi == pytest.approx(truth + 1.96 * se, rel=1e-3)
    assert lo > b0
    assert f.roughness[e.name] == 0.0   # the interval is the ensembles' profile's, not widened
    f = profile_fit([e], base, meas, model_many=many, ensemble_many=ens, spread0=dict(a=0.0, b=0.0),
                    options=dataclasses.replace(DEFAULT, rough_rescan=math.inf))
    assert f.values[e.name] == pytest.approx(b0)
    # A sharp valley within friction's relevance threshold (0.01) of the baseline (the baseline's
    # ensemble at χ² 80): nothing to name, not taken; 0.012 from it, taken.
    slope = 10.0
    for truth, taken in ((0.208, False), (0.212, True)):
        f = profile_fit([e], base, meas, model_many=many, ensemble_many=ens, spread0=dict(a=0.0, b=0.0))
        assert f.values[e.name] == pytest.approx(truth if taken else b0, abs=1e-6)


def test_a_single_scanned_beside_its_valley_is_refined_on_ensembles():
    """fitting.profile_fit, one effect (docs/model.md §9.1, "Sets of effects"): single runs with a
    spurious dip settle the scan at 0.4, where the ensembles' mean does not fit as right models do
    (χ² 61 above the goodness-of-fit bound); Gauss–Newton on the ensembles' means (linear in μ here)
    lands on their minimum, 0.33, with the closed form's interval and no roughness widening. With
    the goodness-of-fit test off (``gof_scale`` inf) the scan's point stands, so the test can fail."""
    import dataclasses

    from beamslider.discover.features import Feature
    from beamslider.discover.fitting import profile_fit
    from beamslider.discover.models import Ensemble
    from beamslider.discover.options import DEFAULT

    e, base = EFFECTS["friction_coefficient"], bs.Parameters()
    truth = 0.33

    def mu(m):
        return round(float(m.params.friction_coefficient), 9)

    def mean(v):
        return dict(a=100.0 * (v - truth), b=50.0 * (v - truth))

    def single(v):   # a spurious dip at 0.4; elsewhere far off
        return dict(a=0.5, b=0.0) if abs(v - 0.4) < 1e-9 else dict(a=200.0 + 10 * v, b=0.0)

    meas = {k: Feature(k, 0.0, 1.0) for k in ("a", "b")}
    many = lambda ps: [single(mu(m)) for m in ps]  # noqa: E731
    ens = lambda ps, central: [Ensemble(mean(mu(m)), dict(a=0.0, b=0.0), 5, {}) for m in ps]  # noqa: E731
    f = profile_fit([e], base, meas, model_many=many, ensemble_many=ens, spread0=dict(a=0.0, b=0.0))
    assert f.values[e.name] == pytest.approx(truth, abs=1e-6) and f.chi2 == pytest.approx(0.0, abs=1e-6)
    se = 1 / math.sqrt(100.0 ** 2 + 50.0 ** 2)
    lo, hi = f.intervals[e.name]
    assert lo == pytest.approx(truth - 1.96 * se, rel=1e-3) and hi == pytest.approx(truth + 1.96 * se, rel=1e-3)
    assert f.roughness[e.name] == 0.0
    f = profile_fit([e], base, meas, model_many=many, ensemble_many=ens, spread0=dict(a=0.0, b=0.0),
                    options=dataclasses.replace(DEFAULT, gof_scale=math.inf))
    assert f.values[e.name] == pytest.approx(0.4) and f.chi2 > 10


@pytest.mark.slow
def test_restitution_in_three_60_s_runs_is_named_where_the_baseline_ensemble_fits_clearly_worse(tmp_path):
    """Restitution 0.3 (baseline 0.5) hidden in the three reference 60-s runs, the truth runs started
    S0_OFFSET off the named s0, all slider-level candidates. Restitution fits best by far, but its χ²
    is rough in ε (runs at neighbouring values differ by Δχ² of several units), so the scan's interval
    reaches the baseline 0.5; the baseline's own ensemble fits worse by far more than z², so the
    interval stops short of it (docs/model.md §9.1, "One effect") and restitution is named, its
    interval holding the truth (about 5 minutes)."""
    slider = [n for n, e in EFFECTS.items() if e.level == "slider"]
    paths = dc.synthesize_slider_runs(bs.Parameters(restitution=0.3),
                                      operating_points=[(104, 14, 0.3), (126, 10, 0.3), (124, 14, 0.3)],
                                      duration_s=60, out_dir=tmp_path, seed=3, s0_offset=S0_OFFSET)
    d = dc.discover(measured=[bs.read_measurement(p) for p in paths], baseline=bs.Parameters(), effects=slider,
                    max_effects=1, advice_grid=[(110, 10, 0.3), (124, 6, 0.3)])
    assert d.verdict == "named" and d.named_effects == ["restitution"], dc.verdict_line(d)
    lo, hi = d.parameters["restitution"]["interval"]
    assert lo <= 0.3 <= hi and not lo <= 0.5 <= hi, (lo, hi)
    fit = [c for c in d.candidates if c.effects == ("restitution",)][0]
    assert d.gap_before ** 2 * len(d.features) - fit.chi2 > 1.96 ** 2


def test_the_baseline_fits_only_without_a_feature_beyond_the_bonferroni_bound():
    """fitting.baseline_fits (docs/model.md §9.1): the excitation level 5 % low in the three reference
    60-s runs gives χ² 28.07 over 16 features, below the 99 % limit 32.0, while one slider speed is
    off by z = −4.39; the two-sided 99 % bound over 16 features is 3.42 (independent reading:
    Φ⁻¹(1 − 0.01/32)), so the baseline does not fit. Without that feature (|z| 2.86, the velocity
    gain of 1.06 in the same runs) it fits; above the χ² limit it never does."""
    from scipy.stats import norm

    from beamslider.discover.stats import baseline_fits, chi2_quantile, z_bound

    from beamslider.discover.rule import select

    assert z_bound(16) == pytest.approx(norm.ppf(1 - 0.01 / 32)) and z_bound(16) == pytest.approx(3.42, abs=0.01)
    assert chi2_quantile(16) == pytest.approx(32.0, abs=0.01)
    assert not baseline_fits(28.07, 16, 4.39)
    assert baseline_fits(21.4, 16, 2.86) and not baseline_fits(32.1, 16, 0.0)
    f = CandidateFit(("excitation_gain",), {"excitation_gain": 0.95}, {}, 10.0, 15, True, 10.0)
    assert select([f], 28.07, 16)[0] is None  # the χ² test alone: the baseline is adequate
    assert select([f], 28.07, 16, baseline_fits(28.07, 16, 4.39))[0] is f


def test_the_baseline_test_counts_each_feature_in_its_uncertainty_and_a_missing_one_at_five():
    """fitting.baseline_test (docs/model.md §9.1): z of each feature in sqrt(σ_meas² + (1 + 1/R)·spread²)
    (here σ_meas 0.3, spread 0.4 over R = 4 runs: sqrt(0.09 + 1.25·0.16) = sqrt(0.29)); a feature the
    baseline lacks is filled 5 of those uncertainties off (χ² 25); adequacy by χ² and the |z| bound."""
    from beamslider.discover.features import Feature
    from beamslider.discover.stats import baseline_test, chi2_quantile, z_bound

    meas = {"a": Feature("a", 1.0, 0.3), "b": Feature("b", 2.0, 0.3), "c": Feature("c", 0.0, 0.3)}
    s = math.sqrt(0.09 + 1.25 * 0.16)
    t = baseline_test({"a": 1.0 + s, "b": 2.0 - 3 * s}, meas, {"a": 0.4, "b": 0.4, "c": 0.4}, 4)
    assert t.n == 3 and t.chi2 == pytest.approx(1 + 9 + 25) and t.z_worst == pytest.approx(5.0)
    assert t.before["c"] == pytest.approx(5 * s) and t.gap == pytest.approx(math.sqrt(35 / 3))
    assert not t.fits and t.chi2 > chi2_quantile(3)
    t = baseline_test({"a": 1.0 + s, "b": 2.0 - s, "c": 0.0}, meas, {"a": 0.4, "b": 0.4, "c": 0.4}, 4)
    assert t.chi2 == pytest.approx(2.0) and t.fits and t.z_worst < z_bound(3)


def test_a_set_with_negligible_members_lends_the_single_its_valley():
    """A pair whose second effect is negligible found the single's valley (the single's scan settled
    beside it): the single at the pair's value, simulated, takes the single's place where it fits
    better; the pair's interval goes with it (docs/model.md §9.1, "Sets of effects")."""
    from types import SimpleNamespace

    from beamslider.discover.features import Feature
    from beamslider.discover.options import DiscoverOptions
    from beamslider.discover.result import After, CandidateFit
    from beamslider.discover.search.common import adopt_set_valleys

    meas = {"a@x": Feature("a@x", 1.0, 0.1)}
    asked = []

    def simulate(model):
        asked.append(model)
        return After({"a@x": 1.0 + 0.1 * (model.params.slider_inertia_kg_m2 - 4.0e-6) / 1e-7}, {}, {}, {})

    problem = SimpleNamespace(base=bs.Parameters(), options=DiscoverOptions(), simulate=simulate, meas=meas,
                              runs_base=5, modes=None, n=1)
    single = CandidateFit(("slider_inertia",), {"slider_inertia": 4.134e-6}, {"slider_inertia": 1e-7}, 21.6, 16, False,
                          24.4, intervals={"slider_inertia": (4.0e-6, 4.3e-6)})
    pair = CandidateFit(("slider_inertia", "com_offset"), {"slider_inertia": 4.002e-6, "com_offset": 0.0041},
                        {"slider_inertia": 8e-8, "com_offset": 1e-4}, 4.3, 15, True, 9.9,
                        intervals={"slider_inertia": (3.85e-6, 4.15e-6), "com_offset": (0.0039, 0.0043)})
    out = adopt_set_valleys(problem, [single, pair])
    assert len(asked) == 1 and out[1] is pair
    s = out[0]
    assert s.effects == ("slider_inertia",) and s.values == {"slider_inertia": 4.002e-6}
    assert s.chi2 == pytest.approx(0.02 ** 2) and s.intervals == {"slider_inertia": (3.85e-6, 4.15e-6)}
    # a single that fits as well as the set (within z²), or a set with two relevant members: untouched
    close = CandidateFit(single.effects, single.values, single.stderrs, 6.0, 16, True, 8.8, intervals=single.intervals)
    assert adopt_set_valleys(problem, [close, pair])[0] is close
    both = CandidateFit(("slider_inertia", "tilt"), {"slider_inertia": 4.0e-6, "tilt": 0.01}, {}, 1.0, 15, True, 6.0)
    assert adopt_set_valleys(problem, [single, both])[0] is single and len(asked) == 1


def test_a_calibration_of_features_does_not_shrink_the_models_spread():
    """A camera offset moves no run: the last refinement level of its scan is one run seen through
    seven offsets, whose scatter about the trend is nil. The fit's spread is the ensemble's, not
    pooled with that nil scatter (docs/model.md §9.1, "One effect"), so a right calibration fits
    with the χ² its ensemble gives."""
    from beamslider.discover.features import Feature
    from beamslider.discover.fitting import profile_fit
    from beamslider.discover.models import Ensemble

    e, base = EFFECTS["position_offset"], bs.Parameters()
    assert e.chain == "features"
    names = ("s_final@t", "s_turning@t")

    def seen(m):
        o = m.value("position_offset")
        return {"s_final@t": 0.30 + o, "s_turning@t": 0.20 + o}

    meas = {"s_final@t": Feature("s_final@t", 0.304, 0.001), "s_turning@t": Feature("s_turning@t", 0.204, 0.001)}
    many = lambda ps: [seen(m) for m in ps]  # noqa: E731
    ens = lambda ps, central: [Ensemble(seen(m), {k: 0.01 for k in names}, 5, {}) for m in ps]  # noqa: E731
    f = profile_fit([e], base, meas, model_many=many, ensemble_many=ens, spread0={k: 0.0 for k in names})
    assert f.model_spread == pytest.approx({k: 0.01 for k in names})
    assert f.values[e.name] == pytest.approx(0.004, abs=0.002)
