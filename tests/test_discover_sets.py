"""Discrepancy workflow, effects found together (docs/model.md §9.1, "Sets of effects" and
"Resolved"): the joint refinement of a set's fit, the 95 % intervals that must exclude the
baseline, and two effects hidden together named together."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest

import beamslider as bs
from beamslider import discover as dc
from beamslider.discover.result import CandidateFit
from beamslider.discover.fitting import _interval
from beamslider.discover.stats import interval_z
from beamslider.discover.refine import gauss_newton
from beamslider.discover.stats import interval_of
from beamslider.discover.rule import unresolved_reasons
from beamslider.discover.options import DEFAULT

S0_OFFSET = 0.0015
"""The truth runs start off the s0 their files name (no "inverse crime", as tests/test_discover.py)."""



LEADER_ALONE = dataclasses.replace(DEFAULT, tier_least=1)
"""The tier as the strategy cases below were written: the leader alone where no rival is predicted near."""


class FakeProblem:
    """A stand-in for :class:`beamslider.discover.problem.Problem` as a search strategy sees it: each
    fit by ``fit(effects, refine=..., joint=...)`` (refine None: the options' refine_levels), the
    linearised model's predictions, the ranked pairs and the steps as given, the rule's gates
    (``done``: no set can win; ``named``: the single the selection would name) as given."""

    def __init__(self, fit, cands, *, max_effects=2, pred=None, guide=None, done=lambda s: False,
                 named=lambda s: None, step=lambda f: f.chi2, known=lambda name: True, n=11, options=None):
        from beamslider.discover.options import DEFAULT
        from beamslider.discover.problem import SearchRecord
        from beamslider.discover.stats import lrt_threshold

        self._fit, self.pred, self._guide, self.done, self.named = fit, pred, guide, done, named
        self.step, self.known = step, known
        self.level, self.max_effects, self.progress, self.base = "slider", max_effects, False, bs.Parameters()
        self.meas = {f"f{i}": None for i in range(n)}
        self.options = options or DEFAULT
        self.record = SearchRecord()
        self.thr_m = lrt_threshold(1, len(cands))

    def fit(self, combo, refine=None, joint=None):
        return self._fit(combo, refine=self.options.refine_levels if refine is None else refine, joint=joint)

    def predict(self, cands):
        return self.pred

    def guide(self):
        return self._guide() if self._guide is not None else []

    def no_set_can_win(self, singles):
        return self.done(singles)

    def best_single(self, singles):
        return self.named(singles)

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


def test_the_joint_covariance_is_widened_where_chi2_rises_less_than_the_linearised_model_says():
    """curvature_widening: a χ² that rises along each effect as (JᵀJ) says leaves the covariance as
    it is; features that flip between u − h and u + h (a mode boundary) while χ² stays put inflate
    J, and the variance is widened to the step's (conditional error h); a point clipped at a bound
    is left alone. Through gauss_newton: the flipping feature's effect gets error h, not (JᵀJ)⁻¹'s."""
    from beamslider.discover.refine import curvature_widening

    h = 0.01
    A = np.diag([1e4, 1e6])
    u = np.zeros(2)
    plus, minus = [np.array([h, 0.0]), np.array([0.0, h])], [np.array([-h, 0.0]), np.array([0.0, -h])]
    quad = lambda p: 3.0 + A[0, 0] * p[0] ** 2 + A[1, 1] * p[1] ** 2  # noqa: E731
    assert curvature_widening(A, u, plus, minus, quad(u), quad) == pytest.approx([1.0, 1.0])
    flat0 = lambda p: 3.0 + A[1, 1] * p[1] ** 2  # noqa: E731
    rho = curvature_widening(A, u, plus, minus, flat0(u), flat0)
    assert rho == pytest.approx([A[0, 0] * h * h, 1.0])  # conditional variance (1/A00)·rho = h²
    clipped = [np.array([0.0, 0.0]), np.array([0.0, h])]
    assert curvature_widening(A, u, clipped, minus, flat0(u), flat0)[0] == 1.0

    # Feature 0 flips sign between u0 - h and u0 + h with |r| unchanged (chi2 flat in u0).
    c = 5.0

    def resid(p):
        return np.array([c * math.copysign(1.0, math.sin(math.pi * p[0] / (2 * h) + math.pi / 4)),
                         (p[1] - 0.3) / 0.01, 0.0, 0.0])

    out = gauss_newton([0.0, 0.3], [-1, -1], [1, 1], [h, 1e-4], lambda us: None, resid,
                       lambda p: float(resid(p) @ resid(p)))
    assert out.u == pytest.approx([0.0, 0.3])
    assert math.sqrt(out.cov[0, 0]) == pytest.approx(h, rel=1e-6)  # (JᵀJ)⁻¹ alone: h / c
    assert math.sqrt(out.cov[1, 1]) == pytest.approx(0.01, rel=1e-3)


def test_a_one_sided_cliff_widens_the_error_to_the_flat_side():
    """curvature_widening measures each side: χ² flat below u (it rises by 0.2 over the step) and a
    cliff above (a mode boundary, +5,000) give a symmetric second difference steeper than the
    linearised model's curvature, which would leave (JᵀJ)⁻¹ as it is; the flat side sets the
    conditional error to the step h. An asymmetric but rising χ² takes the shallower side's curvature."""
    from beamslider.discover.refine import curvature_widening

    h = 0.01
    A = np.diag([1e5])
    u = np.zeros(1)
    plus, minus = [np.array([h])], [np.array([-h])]
    cliff = lambda p: 3.0 + (5000.0 if p[0] > h / 2 else 0.0) + 2e3 * p[0] ** 2  # noqa: E731
    rho = curvature_widening(A, u, plus, minus, cliff(u), cliff)
    assert rho[0] == pytest.approx(A[0, 0] * h * h)  # conditional variance (1/A00)·rho = h²
    symmetric = 2 * ((cliff(plus[0]) - cliff(u)) + (cliff(minus[0]) - cliff(u))) / (2 * h * h)
    assert symmetric > 2 * A[0, 0]  # the symmetric rule would not widen
    slopes = lambda p: 3.0 + (4e4 if p[0] < 0 else 4e5) * p[0] ** 2  # noqa: E731
    assert curvature_widening(A, u, plus, minus, slopes(u), slopes)[0] == pytest.approx(A[0, 0] / 4e4)


def test_joint_refinement_steps_to_a_jacobian_point_where_the_linearised_step_fails():
    """A cliff at u0 + h (a mode boundary) inflates J: the Gauss–Newton step is too short to gain
    min_gain, while the Jacobian's own point u0 - h, a run already made, fits better; it is taken."""
    h = 0.01

    def resid(p):
        r0 = 10.0 if p[0] > 0.5 * h else (p[0] + h) / 0.01
        return np.array([r0, (p[1] - 0.3) / 0.01, 0.0, 0.0])

    chi2 = lambda p: float(resid(p) @ resid(p))  # noqa: E731
    out = gauss_newton([0.0, 0.3], [-1, -1], [1, 1], [h, 1e-4], lambda us: None, resid, chi2)
    assert out.u == pytest.approx([-h, 0.3]) and out.history == pytest.approx([1.0, 0.0], abs=1e-9)


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
    from beamslider.discover.stats import lrt_threshold
    from beamslider.discover.rule import no_set_can_win

    assert lrt_threshold(1, 1) == pytest.approx(6.635, abs=1e-3)
    fits = [_single("friction_coefficient", 5.0, 0.26), _single("tilt", 30.0, 0.004)]
    passes = lambda fs: {f.effects: [] for f in fs}  # noqa: E731
    assert no_set_can_win(fits, passes)
    fits[0].chi2 = 7.0
    assert not no_set_can_win(fits, passes)
    fits[0].chi2 = 5.0
    assert not no_set_can_win(fits, lambda fs: {f.effects: (["not resolved"] if f.chi2 < 6 else []) for f in fs})


def test_pairs_chosen_by_the_linearised_ranking():
    """With a ranking, the pairs fitted are the three best-predicted that extend each of the two
    best singles and the three best-predicted overall; without one, every pair that extends them."""
    from beamslider.discover.effects import EFFECTS
    from beamslider.discover.search.pairs import pairs_to_fit as _pairs_to_fit

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
    best = CandidateFit(("friction_coefficient", "slider_inertia"),
                        {"friction_coefficient": 0.13, "slider_inertia": 3.44e-6}, {}, 12.0, 10, True, 12.0,
                        predicted=dict(a=20.0, b=20.0, c=0.0, d=0.0))
    raw = dict(friction_coefficient=dict(a=1.0, b=0.0, c=0.0, d=0.0), slider_inertia=dict(a=0.0, b=1.0, c=0.0, d=0.0),
               com_offset=dict(zip("abcd", com_signature)), tilt=dict(a=0.0, b=0.0, c=0.0, d=1.0))
    asked = []

    def changes(names):
        asked.append(list(names))
        return {n: raw[n] for n in names}

    return best, changes, asked


def test_a_pair_that_moves_the_features_as_another_effect_does_is_confounded():
    """The set check of docs/model.md §9.1 ("Confounded"): a single effect outside the candidates
    whose linearised change reproduces the pair's within the selection's threshold (least squares:
    residual 800 - 40²/2.0025 = 1.0 against the pair's own 0) is fitted in full; if that fit passes
    the naming rule within the threshold of the pair's χ², the pair is a confounded group with it.
    An effect that the linearised model puts farther off, or whose full fit is worse, does not
    make one; a fitted set is judged by its own fit; a single named effect is left to the single
    candidates' check. Where only effects outside the candidates mimic the pair, the verdict is
    "unexplained" and says which (docs/model.md §9.1, "Confounded")."""
    from beamslider.discover.confounding import confounded_sets

    p = bs.Parameters()
    lib = ["friction_coefficient", "slider_inertia", "com_offset", "tilt"]
    before, sig = dict(a=0.0, b=0.0, c=0.0, d=0.0), dict(a=1.0, b=1.0, c=1.0, d=1.0)
    thr = 11.45
    tried = []

    def confirm(chi2, why=()):
        def fit(name):
            tried.append(name)
            return CandidateFit((name,), {name: 0.0058}, {}, chi2, 11, True, chi2,
                                predicted=dict(a=19.8, b=20.1, c=0.1, d=0.0)), list(why)
        return fit

    best, changes, asked = _pair_and_changes((1.0, 1.0, 0.05, 0.0))
    g = confounded_sets(best, [best], {best.effects: []}, before, sig, p, thr, lib, changes, confirm(15.0),
                        candidates=["friction_coefficient", "slider_inertia", "tilt"])
    assert tried == ["com_offset"], tried  # tilt is 800 off: not tried
    assert g is not None and g["sets"] == [["friction_coefficient", "slider_inertia"], ["com_offset"]], g
    assert g["group"] == ["friction_coefficient", "slider_inertia", "com_offset"]
    assert g["not_candidates"] == ["com_offset"] and g["models"][1] == {"com_offset": 0.0058}
    assert "com_offset_m" in g["combination"] and "not among the candidates" in g["explanation"]
    assert g["among_candidates"] is False  # only an effect the user did not suspect mimics it: "unexplained"
    from types import SimpleNamespace

    from beamslider.discover.report import verdict_line
    from beamslider.discover.result import Because, Kind, Verdict

    line = verdict_line(SimpleNamespace(judgment=Verdict(Kind.UNEXPLAINED, Because.OUTSIDE_CANDIDATES, group=g),
                                        gap_before=21.9))
    assert line.startswith("unexplained discrepancy (gap 21.9) - the best set friction_coefficient + "
                           "slider_inertia fits as well as com_offset, not among the candidates"), line
    assert sorted(asked[0]) == sorted(lib)
    # Its full fit worse by more than the threshold, or failing the naming rule: named.
    assert confounded_sets(best, [best], {best.effects: []}, before, sig, p, thr, lib, changes,
                           confirm(12.0 + thr + 0.1)) is None
    assert confounded_sets(best, [best], {best.effects: []}, before, sig, p, thr, lib, changes,
                           confirm(13.0, ["not adequate"])) is None
    # Half as much on b: alone it leaves 800 - 30²/1.25 = 80 (more than the threshold): not even fitted.
    best, changes, _ = _pair_and_changes((1.0, 0.5, 0.0, 0.0))
    tried.clear()
    assert confounded_sets(best, [best], {best.effects: []}, before, sig, p, thr, lib, changes, confirm(12.0)) is None
    assert tried == []
    # A fitted set is judged by its fit: within the threshold and alike -> confounded; else not.
    other = CandidateFit(("com_offset", "tilt"), {"com_offset": 0.006, "tilt": 0.001}, {}, 15.0, 10, True, 15.0,
                         predicted=dict(a=19.5, b=20.5, c=0.5, d=0.0))
    g = confounded_sets(best, [best, other], {best.effects: [], other.effects: []}, before, sig, p, thr, lib, changes,
                        confirm(99.0))
    assert g is not None and g["sets"][1:] == [["com_offset", "tilt"]], g
    assert g["among_candidates"] is True  # every effect a candidate (none given): "confounded"
    other.chi2 = 12.0 + thr + 0.1
    assert confounded_sets(best, [best, other], {best.effects: [], other.effects: []}, before, sig, p, thr, lib,
                           changes, confirm(99.0)) is None
    other.chi2, other.predicted = 15.0, dict(a=20.0, b=-20.0, c=0.0, d=0.0)  # fits as well, moves them otherwise
    assert confounded_sets(best, [best, other], {best.effects: [], other.effects: []}, before, sig, p, thr, lib,
                           changes, confirm(99.0)) is None
    one = CandidateFit(("friction_coefficient",), {"friction_coefficient": 0.13}, {}, 12.0, 11, True, 12.0,
                       predicted=dict(a=20.0, b=0.0, c=0.0, d=0.0))
    assert confounded_sets(one, [one], {one.effects: []}, before, sig, p, thr, lib, changes, confirm(1.0)) is None


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


def test_the_fast_path_predicts_each_single_from_moves_of_five_thresholds():
    """discover(fast=True) (docs/model.md §9.1, "Cost"): a quadratic per feature through the moves by
    ± 5 relevance thresholds predicts a candidate's best χ² and value — for data made by that very
    quadratic at 0.6 of the move, χ² ≈ 0 at the baseline + 0.6 × 5 thresholds; a candidate that
    moves nothing is predicted at |r|²; only the best predicted are fitted in full, the others kept
    as screened with their predicted χ² (and the naming rule says so)."""
    from beamslider.discover.effects import EFFECTS
    from beamslider.discover.options import DEFAULT
    from beamslider.discover.search.common import predicted_singles
    from beamslider.discover.separability import predict_singles
    from beamslider.discover.rule import judge

    p = bs.Parameters()
    up = dict(friction_coefficient=dict(a=2.0, b=1.0), tilt=dict(a=0.0, b=0.0))
    down = dict(friction_coefficient=dict(a=-2.0, b=0.2), tilt=dict(a=0.0, b=0.0))
    x = 0.6
    resid = dict(a=2.0 * x, b=0.4 * x + 0.6 * x * x)  # a x + c x² with a = (up - down)/2, c = (up + down)/2
    cands = [EFFECTS["friction_coefficient"], EFFECTS["tilt"]]
    pred = predict_singles(cands, p, resid, dict(a=1.0, b=1.0), lambda names, st: up if st > 0 else down)
    chi2, v = pred["friction_coefficient"]
    assert chi2 == pytest.approx(0.0, abs=0.01) and v == pytest.approx(0.2 + x * 5 * 0.01, abs=0.001)
    assert pred["tilt"][0] == pytest.approx(resid["a"] ** 2 + resid["b"] ** 2)
    names = ["friction_coefficient", "tilt", "clearance", "slider_mass"]
    pred = {n: (c, EFFECTS[n].baseline_value(p)) for n, c in zip(names, [3.0, 40.0, 9.0, 20.0])}
    fitted = []
    fits = predicted_singles([EFFECTS[n] for n in names], pred, lambda e: fitted.append(e.name) or CandidateFit(
        (e.name,), {e.name: 0.25}, {e.name: 0.01}, 2.0, 9, True, 2.0), 10)
    assert DEFAULT.fast_keep == 3 and fitted == ["friction_coefficient", "clearance", "slider_mass"]
    tilt = fits[1]
    assert tilt.screened and tilt.linearised and tilt.chi2 == 40.0 and not tilt.adequate
    assert "linearised model predicts chi2 = 40" in judge(fits, p, 10, 5.0, 0.3)[("tilt",)][0]


def test_the_fast_path_fits_the_best_predicted_pair_only_if_it_could_be_selected(monkeypatch):
    """discover(fast=True): the pair the linearised model predicts best is fitted only if its
    predicted χ² beats the best single fitted in full by the selection's threshold (for one effect
    picked from the candidates: lrt_threshold(1, 4) here); the other pairs are never fitted."""
    from beamslider.discover.effects import EFFECTS
    from beamslider.discover.options import DEFAULT
    from beamslider.discover.search import fast
    from beamslider.discover.stats import lrt_threshold

    names = ["friction_coefficient", "natural_frequency_detuning", "tilt", "clearance"]
    cands = [EFFECTS[n] for n in names]
    fitted = []

    def fake_fit(effects, *a, **kw):
        fitted.append(tuple(e.name for e in effects))
        c2 = 30.0 if len(effects) == 1 else 2.0
        return CandidateFit(tuple(e.name for e in effects), {e.name: 0.0 for e in effects}, {}, c2, 10, True, c2)

    pred = {n: (c, 0.0) for n, c in zip(names, [40.0, 50.0, 60.0, 70.0])}
    thr = lrt_threshold(1, len(names))
    for best_pair, want in [(30.0 - thr - 0.1, True), (30.0 - thr + 0.1, False)]:
        fitted.clear()
        ranked = [(("friction_coefficient", "tilt"), best_pair), (("clearance", "tilt"), best_pair + 1)]
        fits = fast.search(FakeProblem(fake_fit, cands, guide=lambda: ranked, pred=pred), cands, DEFAULT)
        pairs = [f for f in fitted if len(f) == 2]
        assert pairs == ([("friction_coefficient", "tilt")] if want else []), (best_pair, fitted)
        assert [f for f in fitted if len(f) == 1] == [(n,) for n in names[:3]]  # the three best predicted
        assert len(fits) == 4 + len(pairs)


def test_the_tier_fits_the_best_predicted_and_falls_back_to_the_full_search(monkeypatch):
    """discover(search="tiered") (docs/model.md §9.1, "Cost"): the best predicted single is fitted in
    full, the next ones while predicted within TIER_MARGIN of the best fitted χ²; if that settles the
    answer (a named single below the threshold, every unfitted candidate predicted beyond the margin,
    no fitted χ² more than TIER_MARGIN above its prediction; the predictions scaled down where a
    fitted χ² lies far below its own)
    the others stay screened and no coarse scan is made; else the full search runs: coarse scans of
    every candidate (refine=options.screen_refine), as search="full" does."""
    from beamslider.discover.effects import EFFECTS
    from beamslider.discover.options import DEFAULT
    from beamslider.discover.search import tiered
    from beamslider.discover.search.tiered import tiered_singles

    TIER_MARGIN = DEFAULT.tier_margin

    names = ["friction_coefficient", "natural_frequency_detuning", "tilt", "clearance"]
    cands = [EFFECTS[n] for n in names]
    chi2_fit = dict(friction_coefficient=4.0, natural_frequency_detuning=30.0, tilt=12.0, clearance=50.0)

    def fake(name):
        return CandidateFit((name,), {name: 0.0}, {name: 0.01}, chi2_fit[name], 10, True, chi2_fit[name])

    fitted = []
    for pred_tilt, want, complete in [(4.0 + TIER_MARGIN + 1, ["friction_coefficient"], True),
                                      (4.0 + TIER_MARGIN - 1, ["friction_coefficient", "tilt"], True)]:
        fitted.clear()
        pred = dict(friction_coefficient=(9.0, 0.0), natural_frequency_detuning=(60.0, 0.0), tilt=(pred_tilt, 0.0),
                    clearance=(80.0, 0.0))
        fits, ok = tiered_singles(cands, pred, lambda e: fitted.append(e.name) or fake(e.name), 10)
        assert fitted == want and ok is complete
        assert [f.effects[0] for f in fits] == names
        assert all(f.linearised == (f.effects[0] not in want) for f in fits)
    # A fitted χ² far above its prediction (a valley the fit missed): not complete.
    pred = dict(friction_coefficient=(4.0 - TIER_MARGIN - 0.5, 0.0), natural_frequency_detuning=(90.0, 0.0),
                tilt=(90.0, 0.0), clearance=(90.0, 0.0))
    assert tiered_singles(cands, pred, lambda e: fake(e.name), 10)[1] is False
    pred["friction_coefficient"] = (4.0 - TIER_MARGIN + 0.5, 0.0)
    assert tiered_singles(cands, pred, lambda e: fake(e.name), 10)[1] is True
    # A fitted χ² far below its prediction (a change beyond the quadratic's reach): the others'
    # predictions scaled by that fit's ratio to its prediction (4/64 here), the tier complete only
    # where they, so scaled, lie beyond the margin.
    pred = dict(friction_coefficient=(64.0, 0.0), natural_frequency_detuning=(1000.0, 0.0), tilt=(1200.0, 0.0),
                clearance=(16.0 * (4.0 + TIER_MARGIN + 1.0), 0.0))
    fitted.clear()
    fits, ok = tiered_singles(cands, pred, lambda e: fitted.append(e.name) or fake(e.name), 10)
    assert fitted == ["friction_coefficient"] and ok is True
    pred["clearance"] = (16.0 * (4.0 + TIER_MARGIN - 1.0), 0.0)
    fitted.clear()
    fits, ok = tiered_singles(cands, pred, lambda e: fitted.append(e.name) or fake(e.name), 10)
    assert fitted == ["friction_coefficient", "clearance"] and ok is True
    pred["tilt"] = (16.0 * (4.0 + TIER_MARGIN - 1.0), 0.0)
    fitted.clear()
    assert tiered_singles(cands, pred, lambda e: fitted.append(e.name) or fake(e.name), 10, keep=2)[1] is False
    # No candidate fitted so far adequate: the next best predicted is fitted whatever its prediction.
    def inadequate_friction(name):
        f = fake(name)
        f.adequate = name != "friction_coefficient"
        return f

    pred = dict(friction_coefficient=(9.0, 0.0), natural_frequency_detuning=(60.0, 0.0), tilt=(200.0, 0.0),
                clearance=(300.0, 0.0))
    fitted.clear()
    fits, ok = tiered_singles(cands, pred, lambda e: fitted.append(e.name) or inadequate_friction(e.name), 10)
    assert fitted == ["friction_coefficient", "natural_frequency_detuning"] and ok is True
    # At least ``least`` fitted in full, the leader's nearest predicted rival among them; and one
    # that is adequate but does not fit as right models do (``good``) does not stop the tier.
    fitted.clear()
    fits, ok = tiered_singles(cands, pred, lambda e: fitted.append(e.name) or fake(e.name), 10, least=2)
    assert fitted == ["friction_coefficient", "natural_frequency_detuning"] and ok is True
    fitted.clear()
    fits, ok = tiered_singles(cands, pred, lambda e: fitted.append(e.name) or fake(e.name), 10,
                              good=lambda f: f.chi2 <= 3.0)
    assert fitted == names[:2] + ["tilt", "clearance"] and ok is True
    # More candidates predicted near than may be fitted in full: not complete.
    pred = {n: (5.0 + i, 0.0) for i, n in enumerate(names)}
    fitted.clear()
    fits, ok = tiered_singles(cands, pred, lambda e: fitted.append(e.name) or fake(e.name), 10, keep=2)
    assert not ok and fitted == names[:2]   # the fits made in full are returned, for the full search to keep
    assert [f.effects[0] for f in fits if not f.linearised] == names[:2]

    # Through the strategy: settled -> no coarse scan; not settled -> every candidate scanned coarsely.
    calls = []

    def fake_fit(effects, *a, refine=2, **kw):
        calls.append((tuple(e.name for e in effects), refine))
        return fake(effects[0].name)

    pred = dict(friction_coefficient=(9.0, 0.0), natural_frequency_detuning=(60.0, 0.0), tilt=(60.0, 0.0),
                clearance=(80.0, 0.0))
    for settled in (True, False):
        calls.clear()
        fits = tiered.search(FakeProblem(fake_fit, cands, done=lambda s: settled, pred=pred, guide=lambda: []),
                             cands, LEADER_ALONE)
        coarse = [c for c in calls if c[1] == DEFAULT.screen_refine]
        assert calls[0] == (("friction_coefficient",), 2)
        assert (coarse == []) if settled else (len(coarse) == len(names))
        assert len([f for f in fits if f.linearised]) == (len(names) - 1 if settled else 0)
    # At most single effects (max_effects 1): a complete tier settles, no set could be fitted.
    calls.clear()
    tiered.search(FakeProblem(fake_fit, cands, max_effects=1, pred=pred), cands, LEADER_ALONE)
    assert not any(r == 0 for _, r in calls)


def _coarse_or_full(coarse, full, calls):
    """A stand-in for the problem's fits: each single candidate's χ² from ``coarse`` for the full
    search's coarse scan (refine=options.screen_refine), else from ``full``; each call logged in ``calls``."""
    from beamslider.discover.options import DEFAULT

    def fit(effects, *a, refine=2, **kw):
        n = effects[0].name
        calls.append((n, refine))
        c2 = coarse[n] if refine == DEFAULT.screen_refine else full[n]
        return CandidateFit((n,), {n: 0.0}, {n: 0.01}, c2, 10, True, c2)

    return fit


def test_the_full_search_keeps_a_fit_the_tier_made_in_full(monkeypatch):
    """search.tiered (docs/model.md §9.1, "Cost"): where the tier does not settle, the full search's
    coarse scans screen each candidate, but one the tier fitted in full keeps that fit though its
    coarse χ² is beyond the margin (single runs on the grid missing a valley between its points, as a
    tilt of 8 mrad at another slider start: coarse χ² 59, the baseline's, predicted 10.6, ensembles
    near the truth 6–16). The others are fitted in full only within the margin."""
    from beamslider.discover.effects import EFFECTS
    from beamslider.discover.options import DEFAULT
    from beamslider.discover.search import tiered

    names = ["friction_coefficient", "natural_frequency_detuning", "tilt", "clearance", "restitution"]
    cands = [EFFECTS[n] for n in names]
    coarse = dict(friction_coefficient=200.0, natural_frequency_detuning=30.0, tilt=35.0, clearance=40.0,
                  restitution=90.0)
    full = dict(friction_coefficient=4.0, natural_frequency_detuning=25.0, tilt=33.0, clearance=38.0, restitution=80.0)
    calls = []
    fit = _coarse_or_full(coarse, full, calls)
    cut = max(sorted(coarse.values())[0] + DEFAULT.screen_margin, sorted(coarse.values())[DEFAULT.screen_keep - 1])
    assert coarse["friction_coefficient"] > cut   # the coarse scan alone would screen it out
    # The tier not complete: friction predicted best but 26 above its fit, the others' predictions
    # so scaled (4/30) within the margin; or more candidates predicted near than the tier may fit in
    # full (options.fast_keep, 3).
    for pred in (dict(friction_coefficient=(30.0, 0.0), natural_frequency_detuning=(60.0, 0.0), tilt=(60.0, 0.0),
                      clearance=(80.0, 0.0), restitution=(90.0, 0.0)),
                 dict(friction_coefficient=(4.5, 0.0), natural_frequency_detuning=(5.0, 0.0), tilt=(6.0, 0.0),
                      clearance=(7.0, 0.0), restitution=(90.0, 0.0))):
        calls.clear()
        fits = tiered.search(FakeProblem(fit, cands, done=lambda s: True, pred=pred), cands, LEADER_ALONE)
        by = {f.effects[0]: f for f in fits}
        assert ("clearance", DEFAULT.screen_refine) in calls  # the full search's coarse scans ran
        assert not by["friction_coefficient"].screened and by["friction_coefficient"].chi2 == 4.0
        assert calls.count(("friction_coefficient", 2)) == 1   # the tier's fit, not made again
        assert all(by[n].screened == (coarse[n] > cut) for n in names if n != "friction_coefficient")
        assert by["restitution"].screened and by["restitution"].chi2 == 90.0


def test_a_fourth_tier_fit_leaves_the_full_search_as_a_tier_of_three_would(monkeypatch):
    """search.tiered with options.tier_keep = 4 and tier_shared = 3 (docs/model.md §9.1, "Cost"): a
    tier that fits four candidates and does not settle hands the full search its first three fits by
    prediction; the fourth enters as its coarse scan (here beyond the margin, so screened out, though
    its full fit was the best), and the full search's fits are those after a tier of three fits."""
    import dataclasses

    from beamslider.discover.effects import EFFECTS
    from beamslider.discover.options import DEFAULT
    from beamslider.discover.search import tiered

    assert DEFAULT.tier_keep == 4 and DEFAULT.tier_shared == 3
    names = ["friction_coefficient", "natural_frequency_detuning", "tilt", "clearance", "restitution"]
    cands = [EFFECTS[n] for n in names]
    coarse = dict(friction_coefficient=10.0, natural_frequency_detuning=30.0, tilt=35.0, clearance=200.0,
                  restitution=90.0)
    full = dict(friction_coefficient=4.0, natural_frequency_detuning=25.0, tilt=33.0, clearance=3.0, restitution=80.0)
    # Four predicted near, the fifth beyond the margin; the tilt's fit 27 above its prediction: not trusted.
    pred = dict(friction_coefficient=(4.5, 0.0), natural_frequency_detuning=(5.0, 0.0), tilt=(6.0, 0.0),
                clearance=(7.0, 0.0), restitution=(90.0, 0.0))
    calls = []
    fit = _coarse_or_full(coarse, full, calls)

    def run(options=LEADER_ALONE):
        calls.clear()
        fits = tiered.search(FakeProblem(fit, cands, max_effects=1, done=lambda s: True, pred=pred, options=options),
                             cands, options)
        return [(f.effects, f.chi2, f.screened) for f in fits], list(calls)

    fits4, calls4 = run()
    assert [c for c in calls4 if c[1] == 2][:4] == [(n, 2) for n in names[:4]]   # the tier fitted four
    by = {f[0][0]: f for f in fits4}
    assert by["clearance"][1:] == (200.0, True)   # its coarse scan, not the tier's fit (3.0)
    assert all(by[n][1:] == (full[n], False) for n in names[:3])
    fits3, calls3 = run(dataclasses.replace(LEADER_ALONE, tier_keep=3))
    assert fits3 == fits4 and ("clearance", 2) not in calls3


def test_the_tier_settles_a_named_single_only_if_no_pair_with_it_is_predicted_to_gain():
    """tiered.no_pair_gains: the pairs that could change a named single's verdict contain it (the
    forward selection extends the named single); each is predicted by a Gauss–Newton step from the
    single's fitted point with the other effect at its baseline. A predicted gain of the least
    threshold (6.63) or more sends the search on; smaller gains everywhere settle it. Through
    the strategy: settled without coarse scans or pairs."""
    import dataclasses

    from beamslider.discover.effects import EFFECTS
    from beamslider.discover.options import DEFAULT
    from beamslider.discover.search import tiered
    from beamslider.discover.search.common import no_pair_gains

    p = bs.Parameters()
    names = ["friction_coefficient", "natural_frequency_detuning", "tilt"]
    best = CandidateFit(("friction_coefficient",), {"friction_coefficient": 0.25}, {}, 20.0, 12, True, 20.0,
                        predicted=dict(a=1.0))
    singles = [best] + [CandidateFit((n,), {n: 0.0}, {}, 90.0, 12, True, 90.0) for n in names[1:]]
    asked = []

    def step(gain_of):
        def f(pair):
            asked.append((pair.effects, dict(pair.values)))
            return pair.chi2 - gain_of.get(pair.effects[1], 0.0)
        return f

    assert no_pair_gains(singles, best, step(dict(tilt=6.5)), p)
    assert [a[0] for a in asked] == [("friction_coefficient", "natural_frequency_detuning"),
                                     ("friction_coefficient", "tilt")]
    assert asked[1][1] == {"friction_coefficient": 0.25, "tilt": EFFECTS["tilt"].baseline_value(p)}
    assert not no_pair_gains(singles, best, step(dict(tilt=6.7)), p)
    assert not no_pair_gains(singles, None, step({}), p)
    # A moved run failed: no column for the tilt, nothing predicted for its pair -> not settled.
    assert not no_pair_gains(singles, best, step({}), p, known=lambda name: name != "tilt")

    calls = []

    def fake_fit(effects, *a, refine=2, **kw):
        calls.append((tuple(e.name for e in effects), refine))
        names_ = tuple(e.name for e in effects)
        return next((f for f in singles if f.effects == names_),
                    CandidateFit(names_, {e: 0.0 for e in names_}, {}, 50.0, 11, True, 50.0))

    pred = dict(friction_coefficient=(15.0, 0.25), natural_frequency_detuning=(80.0, 1.0), tilt=(80.0, 0.0))
    cands = [EFFECTS[n] for n in names]
    for gain, settled in ((1.0, True), (9.0, False)):
        calls.clear()
        problem = FakeProblem(fake_fit, cands, n=13, pred=pred, named=lambda s: best, step=step(dict(tilt=gain)),
                              guide=lambda: [(("friction_coefficient", "tilt"), 0.0)])  # a pair predicted to win
        tiered.search(problem, cands, dataclasses.replace(LEADER_ALONE, screen_from=2, gof_scale=math.inf))
        assert (calls == [(("friction_coefficient",), 2)]) == settled, calls  # else the full search


def test_a_gauss_newton_step_from_the_pass_point_predicts_the_refined_chi2():
    """refine.step_chi2: with features exactly linear in two effects, the χ² predicted after one
    step from a pass point that stopped short is the least-squares minimum (here the noise floor,
    the pass's mode terms kept)."""
    from beamslider.discover.effects import EFFECTS
    from beamslider.discover.features import Feature
    from beamslider.discover.options import DEFAULT
    from beamslider.discover.refine import step_chi2
    from beamslider.discover.separability import bumped

    base = bs.Parameters()
    names = ["friction_coefficient", "natural_frequency_detuning"]
    keys = [f"f{i}" for i in range(5)]
    cols = {"friction_coefficient": [10.0, 8.0, 12.0, 5.0, 10.0], "natural_frequency_detuning": [9.0, 10.0, 10.0, 6.0, -11.0]}
    noise = np.array([0.3, -0.2, 0.1, 0.0, -0.1])
    d = {n: bumped(EFFECTS[n], base, DEFAULT.linear_steps) - EFFECTS[n].baseline_value(base) for n in names}
    truth = {n: EFFECTS[n].baseline_value(base) + x * d[n] for n, x in zip(names, (0.4, -0.3))}

    def features(vals):
        return {k: sum(cols[n][i] * (vals[n] - EFFECTS[n].baseline_value(base)) / d[n] for n in names)
                for i, k in enumerate(keys)}

    meas = {k: Feature(k, v + e, 1.0) for (k, v), e in zip(features(truth).items(), noise)}
    sig = {k: 1.0 for k in keys}
    # The coordinate pass stopped short: friction took up part of the detuning's share.
    at = {"friction_coefficient": truth["friction_coefficient"] - 0.2 * d["friction_coefficient"],
          "natural_frequency_detuning": EFFECTS["natural_frequency_detuning"].baseline_value(base)}
    pred = features(at)
    r = np.array([(pred[k] - meas[k].value) for k in keys])
    fit = CandidateFit(tuple(names), at, {}, float(r @ r) + 2.0, 3, False, 0.0, predicted=pred)
    changes = {n: {k: cols[n][i] for i, k in enumerate(keys)} for n in names}
    A = np.column_stack([cols[n] for n in names])
    floor = float(np.sum((noise - A @ np.linalg.lstsq(A, noise, rcond=None)[0]) ** 2))
    got = step_chi2(fit, changes, meas, sig, base)
    assert got == pytest.approx(floor + 2.0, abs=1e-6)
    assert got < fit.chi2 - 5
    # Without a column for one of the effects, no prediction: the pass's χ².
    assert step_chi2(fit, {names[0]: changes[names[0]]}, meas, sig, base) == fit.chi2


def test_the_joint_refinement_goes_to_every_set_predicted_to_come_near_the_best():
    """refine.sets_to_refine: the two best by the pass's χ² and the pair predicted best from the
    baseline, and beside them each set whose χ² predicted after a Gauss–Newton step is within the
    margin of the best pass's χ² (a set whose pass stopped far short is refined too)."""
    from beamslider.discover.refine import sets_to_refine

    passes = [25.6, 35.0, 38.6, 47.2, 52.6, 73.6, 160.3, 666.5]
    steps = [22.0, 33.0, 30.0, 45.0, 28.9, 70.0, 150.0, 600.0]
    got = sets_to_refine(passes, steps, 2, 3, 11.45)
    assert got == [0, 1, 2, 4]  # 25.6 + 11.45 = 37.05: 28.9 in, 45 and 70 out
    assert sets_to_refine(passes, None, 2, 3, 11.45) == [0, 1, 2]  # no prediction: the fixed three
    assert sets_to_refine(passes, steps[:4] + [37.0] + steps[5:], 6, 3, 11.45) == [0, 1, 6, 2, 4]
    assert sets_to_refine(passes, steps[:4] + [37.1] + steps[5:], 6, 3, 11.45) == [0, 1, 6, 2]


def test_staged_sets_are_refined_by_the_predicted_step(monkeypatch):
    """search.full with more sets than options.joint_sets: every set gets the coordinate pass; the joint
    refinement goes to the fixed ones and to the set whose predicted step brings it near the best,
    and the report's record says which."""
    import dataclasses

    from beamslider.discover.effects import EFFECTS
    from beamslider.discover.options import DEFAULT
    from beamslider.discover.search import full

    names = ["friction_coefficient", "natural_frequency_detuning", "tilt", "clearance", "slider_mass"]
    cands = [EFFECTS[n] for n in names]
    calls = []
    pass_of = {frozenset(p): 40.0 + 5 * i for i, p in enumerate(itertools.combinations(names, 2))}
    hidden = frozenset(["natural_frequency_detuning", "slider_mass"])
    pass_of[hidden] = 90.0

    def fake_fit(effects, *a, joint=None, refine=2, **kw):
        key = frozenset(e.name for e in effects)
        calls.append((key, joint))
        c2 = 100.0 if len(effects) == 1 else (pass_of[key] if joint is False else
                                               (10.0 if key == hidden else pass_of[key] - 1))
        return CandidateFit(tuple(e.name for e in effects), {e.name: 0.0 for e in effects}, {}, c2, 10, False, c2)

    options = dataclasses.replace(DEFAULT, screen_from=10)   # every single fitted in full
    first = [("friction_coefficient", "tilt"), ("friction_coefficient", "clearance"),
             ("friction_coefficient", "natural_frequency_detuning"), ("natural_frequency_detuning", "slider_mass")]
    ranked = [(p, 50.0) for p in first + [p for p in itertools.combinations(names, 2) if p not in first]]
    problem = FakeProblem(fake_fit, cands, n=14, guide=lambda: ranked, options=options,
                          step=lambda f: 45.0 if frozenset(f.effects) == hidden else f.chi2 + 20)
    fits = full.search(problem, cands, options)
    record = problem.record.refined
    refined = {k for k, j in calls if j is None and len(k) == 2}
    assert hidden in refined and len(refined) == DEFAULT.joint_sets + 1
    assert min(f.chi2 for f in fits if len(f.effects) == 2) == 10.0
    assert {frozenset(r["effects"]) for r in record if r["refined"]} == refined
    assert [r["chi2"] for r in record if frozenset(r["effects"]) == hidden] == [10.0]


def test_the_fast_path_leaves_out_mode_features_where_the_baseline_misses_the_data_mode():
    """linearised.predict_singles: at an operating point where none of the baseline's runs ends in the
    data's mode, the end-state features' changes from the baseline's run are those of a run in
    another mode (a mode switch: hundreds of uncertainties), no signature of the candidate; they
    count as they are, and the candidate is predicted from the other features (here: exactly)."""
    from beamslider.discover.effects import EFFECTS
    from beamslider.discover.separability import predict_singles

    p = bs.Parameters()
    tag = "126Hz_10ms2_s00.3"
    keys = [f"speed_early@{tag}", f"amplitude_final_h@{tag}", f"s_final@{tag}"]
    up = {"tilt": {keys[0]: 7.5, keys[1]: -1180.0, keys[2]: 30.0}}
    down = {"tilt": {keys[0]: -3.7, keys[1]: 515.0, keys[2]: 17.5}}
    x = 0.8
    resid = {keys[0]: (7.5 + 3.7) / 2 * x + (7.5 - 3.7) / 2 * x * x, keys[1]: -1.0, keys[2]: -1.0}
    sig = {k: 1.0 for k in keys}
    cands = [EFFECTS["tilt"]]
    changes = lambda names, st: up if st > 0 else down  # noqa: E731
    chi2, v = predict_singles(cands, p, resid, sig, changes, {tag: 0})["tilt"]
    assert chi2 == pytest.approx(2.0, abs=0.01) and v == pytest.approx(x * 5 * 0.002, abs=2e-4)
    # With the baseline in the data's mode there, the mode features are its signature too.
    assert predict_singles(cands, p, resid, sig, changes, {tag: 3})["tilt"][0] > 30  # the best is near no tilt


def test_the_pair_ranking_leaves_out_mode_features_the_baseline_misses():
    """separability.rank_pairs with ``frozen``: a mode feature whose signature is a mode switch (huge)
    makes the true pair look bad; counted as it is, the true pair ranks first."""
    from beamslider.discover.separability import rank_pairs

    sens = {"a": {"x": 1.0, "y": 0.0, "m": -900.0}, "b": {"x": 0.0, "y": 1.0, "m": 400.0},
            "c": {"x": 0.5, "y": 0.5, "m": 0.0}}
    resid = {"x": 3.0, "y": -2.0, "m": -1.0}
    assert rank_pairs(sens, resid)[0][0] != ("a", "b")
    best, chi2 = rank_pairs(sens, resid, ["m"])[0]
    assert best == ("a", "b") and chi2 == pytest.approx(1.0)
