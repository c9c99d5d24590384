"""Discrepancy workflow, effects found together (docs/model.md §9.1, "Sets of effects" and
"Resolved"): the joint refinement of a set's fit, the 95 % intervals that must exclude the
baseline, and two effects hidden together named together."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import beamslider as bs
from beamslider import discover as dc
from beamslider.discover.fitting import CandidateFit, _interval, interval_z
from beamslider.discover.refine import gauss_newton
from beamslider.discover.verdicts import interval_of, unresolved_reasons

S0_OFFSET = 0.0015
"""The truth runs start off the s0 their files name (no "inverse crime", as tests/test_discover.py)."""


def _alike_model():
    """Residuals of two parameters that move the features alike (columns at 0.98 correlation) with
    a mild nonlinearity: the coordinate pass (one parameter, then the other) stops short."""
    A = np.array([[1.0, 0.9], [0.8, 1.0], [1.2, 1.0], [0.5, 0.6], [1.0, 1.1]])
    truth = np.array([0.4, -0.3])
    y = A @ truth + 0.05 * np.array([1, -1, 0.5, 0, -0.5]) + 0.03 * (truth[0] ** 2)

    def model(u):
        return A @ u + 0.03 * u[0] ** 2

    return A, y, model


def _confirmed_runs(model, y):
    """evaluate / residuals / χ² as :func:`.refine.gauss_newton` takes them: ``evaluate`` 'runs'
    the model at the points asked (stored by rounded point), the others read what was run."""
    done = {}

    def evaluate(us):
        for u in us:
            done[tuple(np.round(u, 12))] = model(np.asarray(u))

    def residuals(u):
        return done[tuple(np.round(u, 12))] - y

    def chi2(u):
        r = residuals(u)
        return float(r @ r)

    return evaluate, residuals, chi2


def test_joint_refinement_reaches_the_least_squares_minimum():
    """Gauss–Newton steps confirmed by 'runs' reach the minimum of the nonlinear least squares
    (checked against scipy's least_squares, an independent solver) from the point a coordinate pass
    leaves, and the covariance is (JᵀJ)⁻¹ of the model at the minimum."""
    from scipy.optimize import least_squares

    A, y, model = _alike_model()
    evaluate, residuals, chi2 = _confirmed_runs(model, y)

    # The coordinate pass: the first parameter with the second at 0, then the second.
    u1 = least_squares(lambda a: model(np.array([a[0], 0.0])) - y, [0.0]).x[0]
    u2 = least_squares(lambda b: model(np.array([u1, b[0]])) - y, [0.0]).x[0]
    start = np.array([u1, u2])
    ref = least_squares(lambda u: model(u) - y, start, xtol=1e-14, ftol=1e-14)
    evaluate([start])
    assert chi2(start) > 2 * 2 * ref.cost + 1e-3  # the coordinate pass stops short
    out = gauss_newton(start, [-5, -5], [5, 5], [1e-4, 1e-4], evaluate, residuals, chi2, min_gain=1e-9,
                       max_steps=10)
    assert out.u == pytest.approx(ref.x, abs=1e-4)  # a flat valley: chi2 agrees to 1e-6
    assert out.chi2 == pytest.approx(2 * ref.cost, rel=1e-6, abs=1e-9)
    J = A + np.array([[0.06 * out.u[0], 0.0]] * len(y))
    assert out.cov == pytest.approx(np.linalg.inv(J.T @ J), rel=1e-4)
    assert out.history[0] > out.history[-1]


def test_joint_refinement_stops_where_no_step_lowers_chi2():
    """At the minimum already no step is taken (the history has the start only) and the bounds hold."""
    A, y, model = _alike_model()
    evaluate, residuals, chi2 = _confirmed_runs(model, y)

    out = gauss_newton([0.0, 0.0], [0.0, 0.0], [0.1, 0.1], [0.01, 0.01], evaluate, residuals, chi2)
    assert np.all(out.u >= 0) and np.all(out.u <= 0.1)
    fixed = gauss_newton(out.u, [0.0, 0.0], [0.1, 0.1], [0.01, 0.01], evaluate, residuals, chi2)
    assert fixed.history == [fixed.chi2] and np.array_equal(fixed.u, out.u)


def test_the_interval_that_names_is_the_95_percent_one():
    """A parabolic profile χ² = ((x − 2)/0.1)²: the Δχ² = 1 interval is ± 0.1, the one that must
    exclude the baseline ± 1.96 · 0.1 (however coarse the scan); a rough profile widens it by 2·roughness."""
    z = interval_z()
    assert z == pytest.approx(1.959964, abs=1e-6)
    xs = np.linspace(1.0, 3.0, 9)
    fs = ((xs - 2.0) / 0.1) ** 2
    assert _interval(xs, fs)[1:] == pytest.approx((1.9, 2.1), abs=1e-12)
    assert _interval(xs, fs, delta=z * z)[1:] == pytest.approx((2 - 0.1 * z, 2 + 0.1 * z), abs=1e-12)
    lo, hi = _interval(xs, fs, rough=1.0, delta=z * z)[1:]
    assert hi - 2 == pytest.approx(0.1 * math.sqrt(z * z + 2), abs=1e-12)
    # Beam level: value ± z standard errors; a change 1.5 se from the baseline is not resolved at 95 %.
    p = bs.Parameters()
    beam = CandidateFit(("axial_preload",), {"axial_preload": 3.0}, {"axial_preload": 2.0}, 5.0, 5, True, 5.0)
    assert interval_of(beam, "axial_preload") == pytest.approx((3 - 2 * z, 3 + 2 * z))
    assert unresolved_reasons(beam, p)
    beam.stderrs["axial_preload"] = 1.4
    assert not unresolved_reasons(beam, p)


def _runs(tmp_path, truth, points, duration_s, seed=3, chain=None):
    paths = dc.synthesize_slider_runs(truth, operating_points=list(points), duration_s=duration_s,
                                      out_dir=tmp_path / "data", seed=seed, s0_offset=S0_OFFSET, chain=chain)
    return [bs.read_measurement(q) for q in paths]


def _single(name, chi2, value):
    return CandidateFit((name,), {name: value}, {name: 0.001}, chi2, 7, True, chi2,
                        intervals={name: (value - 0.002, value + 0.002)})


def test_sets_are_not_fitted_when_no_set_could_be_selected():
    """A single candidate that passes the naming rule with χ² below the least likelihood-ratio
    threshold (6.63) cannot be beaten by any set; one with a larger χ², or one that fails the rule,
    leaves the sets to fit."""
    from beamslider.discover.fitting import lrt_threshold
    from beamslider.discover.naming import _no_set_can_win

    assert lrt_threshold(1, 1) == pytest.approx(6.635, abs=1e-3)
    fits = [_single("friction_coefficient", 5.0, 0.26), _single("tilt", 30.0, 0.004)]
    passes = lambda fs: {f.effects: [] for f in fs}  # noqa: E731
    assert _no_set_can_win(fits, passes)
    fits[0].chi2 = 7.0
    assert not _no_set_can_win(fits, passes)
    fits[0].chi2 = 5.0
    assert not _no_set_can_win(fits, lambda fs: {f.effects: (["not resolved"] if f.chi2 < 6 else []) for f in fs})


def test_pairs_chosen_by_the_linearised_ranking():
    """With a ranking, the pairs fitted are the three best-predicted that extend each of the two
    best singles and the three best-predicted overall; without one, every pair that extends them."""
    from beamslider.discover.effects import EFFECTS
    from beamslider.discover.naming import _pairs_to_fit

    names = ["friction_coefficient", "natural_frequency_detuning", "tilt", "com_offset", "clearance", "restitution"]
    cands = [EFFECTS[n] for n in names]
    singles = [_single(n, c, 0.0) for n, c in zip(names, [50, 60, 10, 12, 70, 80])]
    pairs = [tuple(sorted(p)) for p in itertools.combinations(names, 2)]
    ranked = [(p, float(i)) for i, p in enumerate(sorted(pairs, key=lambda p: ("clearance" in p, "restitution" in p, p)))]
    got = {frozenset(e.name for e in c) for c in _pairs_to_fit(cands, singles, 2, "slider", ranked)}
    want = {frozenset(p) for p, _ in ranked[:3]}
    for t in ("tilt", "com_offset"):  # the two best singles
        want |= {frozenset(q) for q in [q for q, _ in ranked if t in q][:3]}
    assert got == want and len(got) < len(pairs)
    every = {frozenset(e.name for e in c) for c in _pairs_to_fit(cands, singles, 2, "slider", None)}
    assert every == {frozenset(p) for p in pairs if "tilt" in p or "com_offset" in p}


def _pair_and_changes(com_signature):
    """A named pair (friction, slider inertia) whose fitted change is (20, 20, 0, 0) in units of the
    uncertainties, and the linearised model's feature changes of four effects (5 relevance thresholds)."""
    from beamslider.discover.separability import _bumped
    from beamslider.discover.effects import EFFECTS

    p = bs.Parameters()
    best = CandidateFit(("friction_coefficient", "slider_inertia"),
                        {"friction_coefficient": 0.13, "slider_inertia": 3.44e-6}, {}, 12.0, 10, True, 12.0,
                        predicted=dict(a=20.0, b=20.0, c=0.0, d=0.0))
    raw = dict(friction_coefficient=dict(a=1.0, b=0.0, c=0.0, d=0.0), slider_inertia=dict(a=0.0, b=1.0, c=0.0, d=0.0),
               com_offset=dict(zip("abcd", com_signature)), tilt=dict(a=0.0, b=0.0, c=0.0, d=1.0))
    asked = []

    def changes(names):
        asked.append(list(names))
        return {n: raw[n] for n in names}, {n: _bumped(EFFECTS[n], p, 5.0) for n in names}

    return p, best, changes, asked


def test_a_pair_that_moves_the_features_as_another_effect_does_is_confounded():
    """The set check of docs/model.md §9.1 ("Confounded"), against an independent least-squares
    reading of the linearised model: a single effect outside the candidates whose change reproduces
    the pair's within the selection's threshold (residual 1.0 < 11.45) makes the pair a confounded
    group; one that needs friction beside it (another set) too; an effect that moves a feature the
    pair leaves alone does not; a fitted set is judged by its own fit."""
    from beamslider.discover.verdicts import confounded_sets

    lib = ["friction_coefficient", "slider_inertia", "com_offset", "tilt"]
    before, sig = dict(a=0.0, b=0.0, c=0.0, d=0.0), dict(a=1.0, b=1.0, c=1.0, d=1.0)
    thr = 11.45
    # com offset moves a and b alike: alone it reproduces (20, 20) to 800 - 40²/2.0025 = 1.0.
    p, best, changes, asked = _pair_and_changes((1.0, 1.0, 0.05, 0.0))
    g = confounded_sets(best, [best], {best.effects: []}, before, sig, p, thr, lib, changes,
                        candidates=["friction_coefficient", "slider_inertia", "tilt"])
    assert g is not None and g["sets"] == [["friction_coefficient", "slider_inertia"], ["com_offset"]], g
    assert g["group"] == ["friction_coefficient", "slider_inertia", "com_offset"]
    assert g["not_candidates"] == ["com_offset"]
    v0 = p.com_offset_m
    moved = changes(["com_offset"])[1]["com_offset"]
    x = 40.0 / 2.0025  # the least-squares multiple of the 5-threshold change
    assert g["models"][1]["com_offset"] == pytest.approx(v0 + x * (moved - v0), rel=1e-9)
    assert "com_offset_m" in g["combination"] and "not among the candidates" in g["explanation"]
    assert sorted(asked[0]) == sorted(lib)
    # Half as much on b: alone it leaves 800 - 30²/1.25 = 80; with friction or inertia beside it, nothing.
    p, best, changes, _ = _pair_and_changes((1.0, 0.5, 0.0, 0.0))
    g = confounded_sets(best, [best], {best.effects: []}, before, sig, p, thr, lib, changes)
    assert g is not None and g["sets"][1:] == [["com_offset", "friction_coefficient"], ["com_offset", "slider_inertia"]]
    # A change of c that the pair does not make: no set reproduces it.
    p, best, changes, _ = _pair_and_changes((1.0, 0.5, 3.0, 0.0))
    assert confounded_sets(best, [best], {best.effects: []}, before, sig, p, thr, lib, changes) is None
    # A fitted set is judged by its fit: within the threshold and alike -> confounded; else not.
    other = CandidateFit(("com_offset", "tilt"), {"com_offset": 0.006, "tilt": 0.001}, {}, 15.0, 10, True, 15.0,
                         predicted=dict(a=19.5, b=20.5, c=0.5, d=0.0))
    g = confounded_sets(best, [best, other], {best.effects: [], other.effects: []}, before, sig, p, thr, lib, changes)
    assert g is not None and g["sets"][1:] == [["com_offset", "tilt"]] and "fitted" in g["how"]["com_offset+tilt"]
    other.chi2 = 12.0 + thr + 0.1
    assert confounded_sets(best, [best, other], {best.effects: [], other.effects: []}, before, sig, p, thr, lib,
                           changes) is None
    # A single named effect is left to the single candidates' check (confounded_group).
    one = CandidateFit(("friction_coefficient",), {"friction_coefficient": 0.13}, {}, 12.0, 11, True, 12.0,
                       predicted=dict(a=20.0, b=0.0, c=0.0, d=0.0))
    assert confounded_sets(one, [one], {one.effects: []}, before, sig, p, thr, lib, changes) is None


POINTS = [(110, 10, 0.3), (124, 6, 0.3), (116, 10, 0.3)]
"""Three 15-s runs: two effects at once need the third point (with two, friction 0.24 and the
natural frequencies x 0.985 fit at chi2 0.7 but the detuning's 95 % interval reaches 1.004)."""


@pytest.mark.heavy
@pytest.mark.parametrize("truth", [dict(friction_coefficient=0.24, natural_frequency_detuning=0.985),
                                   dict(slider_mass=0.0499, tilt=0.007)], ids=["mu-f0", "mass-tilt"])
def test_two_effects_hidden_together_are_named_together(truth, tmp_path):
    """Two effects hidden together, values off the scan grids, the two as candidates (which pairs
    are fitted among more: test_pairs_chosen_by_the_linearised_ranking): both are named, each
    within two standard errors of its truth, each 95 % interval excluding the baseline (the
    coordinate pass alone stopped at chi2 15-27 for friction with the natural frequencies,
    docs/model.md §9.1)."""
    from beamslider.discover.chain import realise_model

    p = bs.Parameters()
    runs = _runs(tmp_path, realise_model(p, truth).params, POINTS, 15)
    d = dc.discover(measured=runs, effects=sorted(truth), advice_grid=())
    assert d.verdict == "named" and sorted(d.named_effects) == sorted(truth), dc.verdict_line(d)
    for e, v in truth.items():
        q = d.parameters[e]
        assert abs(q["value"] - v) <= 2 * q["stderr"], (e, q)
        assert not (q["interval"][0] <= q["baseline"] <= q["interval"][1]), (e, q)
