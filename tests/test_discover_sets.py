"""Discrepancy workflow, effects found together (docs/model.md §9.1, "Sets of effects" and
"Resolved"): the joint refinement of a set's fit, the 95 % intervals that must exclude the
baseline, and two effects hidden together named together."""

from __future__ import annotations

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


def test_joint_refinement_reaches_the_least_squares_minimum():
    """Gauss–Newton steps confirmed by 'runs' reach the minimum of the nonlinear least squares
    (checked against scipy's least_squares, an independent solver) from the point a coordinate pass
    leaves, and the covariance is (JᵀJ)⁻¹ of the model at the minimum."""
    from scipy.optimize import least_squares

    A, y, model = _alike_model()
    done = {}

    def evaluate(us):
        for u in us:
            done[tuple(np.round(u, 12))] = model(np.asarray(u))

    def residuals(u):
        return done[tuple(np.round(u, 12))] - y

    def chi2(u):
        r = residuals(u)
        return float(r @ r)

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
    done = {}

    def evaluate(us):
        for u in us:
            done[tuple(np.round(u, 12))] = model(np.asarray(u))

    def residuals(u):
        return done[tuple(np.round(u, 12))] - y

    def chi2(u):
        r = residuals(u)
        return float(r @ r)

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
