"""Joint refinement of a fit of several effects (docs/model.md §9.1, "Sets of effects"): damped
Gauss–Newton steps on the model linearised by central differences of full runs, each step
confirmed by full runs, and the Wald covariance of the converged fit.

A coordinate pass (one effect after the other, each scanned with the others held) stops short of
the minimum when the effects move the features alike (friction and the natural frequencies both
shift the slider's speeds): the first effect is fitted with the second at its baseline value and
takes up part of the second's share. The linearised model solves for all of them at once."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Sequence

import numpy as np

from .effects import EFFECTS
from .models import as_modes, is_mode_feature, tag_of, unreached_mode_features
from .options import DEFAULT, DiscoverOptions
from .separability import bumped


@dataclass
class Refined:
    """Outcome of :func:`gauss_newton`."""

    u: np.ndarray
    chi2: float
    cov: Optional[np.ndarray]
    """Covariance of u from the Jacobian at ``u``: (JᵀJ)⁻¹ (residuals in units of their
    uncertainty), widened per effect where χ² rises less than the linearised model says
    (:func:`curvature_widening`); None if J is rank-deficient."""
    history: List[float] = field(default_factory=list)
    """χ² at the start and after each accepted step."""


def _clip(u: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    return np.minimum(np.maximum(u, lower), upper)


def gauss_newton(u0: Sequence[float], lower: Sequence[float], upper: Sequence[float], h: Sequence[float],
                 evaluate: Callable[[List[np.ndarray]], None], residuals: Callable[[np.ndarray], np.ndarray],
                 chi2: Callable[[np.ndarray], float], *, max_steps: int = DEFAULT.gauss_newton_steps,
                 min_gain: float = DEFAULT.min_gain) -> Refined:
    """Refine ``u0`` jointly. ``evaluate(us)``: make the runs of the points ``us`` (one batch;
    cached by the caller); ``residuals(u)``: (model − measured)/σ per feature of an evaluated
    point (NaN where the model lacks the feature or it is charged as a mode term); ``chi2(u)``: the
    fit's χ² of an evaluated point. Per step: the Jacobian by central differences (±``h``,
    clipped to the bounds), the Gauss–Newton step δ = −J⁺r and the Levenberg–Marquardt step
    (JᵀJ + diag JᵀJ)⁻¹(−Jᵀr), trials u + δ, u + δ/2 and the damped step as one batch; the best is
    taken if it lowers χ² by more than ``min_gain``; so is the best of the Jacobian's own points
    u ± h (runs already made) where it lowers χ² more than those trials do."""
    u = np.asarray(u0, dtype=float).copy()
    lo, hi, hs = (np.asarray(v, dtype=float) for v in (lower, upper, h))
    k = len(u)
    evaluate([u])
    f = chi2(u)
    history = [f]
    points: List[List[np.ndarray]] = [[], []]

    def jacobian(at: np.ndarray):
        plus = [_clip(at + hs[i] * np.eye(k)[i], lo, hi) for i in range(k)]
        minus = [_clip(at - hs[i] * np.eye(k)[i], lo, hi) for i in range(k)]
        points[0], points[1] = plus, minus
        evaluate(plus + minus)
        r0 = residuals(at)
        cols = []
        for i in range(k):
            span = plus[i][i] - minus[i][i]
            cols.append((residuals(plus[i]) - residuals(minus[i])) / span if span > 0 else np.full_like(r0, np.nan))
        J = np.column_stack(cols)
        ok = np.isfinite(r0) & np.all(np.isfinite(J), axis=1)
        return r0[ok], J[ok]

    r, J = jacobian(u)
    for _ in range(max_steps):
        if len(r) <= k:
            break
        delta = np.linalg.lstsq(J, -r, rcond=None)[0]
        A, g = J.T @ J, J.T @ r
        try:
            damped = np.linalg.solve(A + np.diag(np.diag(A)), -g)
        except np.linalg.LinAlgError:
            damped = 0.5 * delta
        trials = [_clip(u + delta, lo, hi), _clip(u + 0.5 * delta, lo, hi), _clip(u + damped, lo, hi)]
        evaluate(trials)
        # The Jacobian's own points u ± h are runs already made: where the linearised step fails
        # (a mode boundary bends the model), the best of them is a step too (pattern search).
        trials += points[0] + points[1]
        scores = [chi2(t) for t in trials]
        j = int(np.argmin(scores))
        if not scores[j] < f - min_gain:
            break
        u, f = trials[j], scores[j]
        history.append(f)
        r, J = jacobian(u)
    cov: Optional[np.ndarray] = None
    if len(r) > k:
        A = J.T @ J
        if np.linalg.matrix_rank(A) == k:
            rho = curvature_widening(A, u, points[0], points[1], f, chi2)
            cov = np.linalg.inv(A) * np.sqrt(np.outer(rho, rho))
    return Refined(u, f, cov, history)


def curvature_widening(A: np.ndarray, u: np.ndarray, plus: Sequence[np.ndarray], minus: Sequence[np.ndarray],
                       f0: float, chi2: Callable[[np.ndarray], float]) -> np.ndarray:
    """Per effect i, the factor ρᵢ ≥ 1 on the variance: the curvature of χ² along i that the
    linearised model claims, 2 (JᵀJ)ᵢᵢ, over the one measured at the Jacobian's own points u ± hᵢ.
    Measured one side at a time, 2 (χ²(u ± hᵢ) − χ²(u))/hᵢ², and the smaller side taken: a cliff on
    one side (a mode boundary, the end state of a run) makes the symmetric second difference steep
    while χ² stays flat on the other side, where the error is set. A side where χ² does not rise by
    1 over its step counts as rising by 1 there (the conditional error is then the step, a lower
    bound). Where the features jump between u − h and u + h the central difference inflates J and
    (JᵀJ)⁻¹ understates the error; χ² itself shows how sharply the data pin the effect
    (docs/model.md §9.1, "Resolved")."""
    rho = np.ones(len(u))
    for i in range(len(u)):
        hp, hm = float(plus[i][i] - u[i]), float(u[i] - minus[i][i])
        if hp <= 0 or hm <= 0:
            continue  # clipped at a bound: no second difference
        fp, fm = chi2(plus[i]), chi2(minus[i])
        if not (math.isfinite(fp) and math.isfinite(fm) and math.isfinite(f0)):
            continue
        measured = min(2 * max(fp - f0, 1.0) / hp ** 2, 2 * max(fm - f0, 1.0) / hm ** 2)
        rho[i] = max(1.0, 2 * float(A[i, i]) / measured)
    return rho


def residual_vector(model: Optional[Dict[str, float]], names: Sequence[str], y: np.ndarray, sig: np.ndarray,
                    skip: Callable[[str], bool]) -> np.ndarray:
    """(model − measured)/σ per feature of ``names``; NaN where the model lacks the feature or
    ``skip(name)`` (a mode feature of an operating point whose run is not in the data's mode: its
    χ² term is its expectation, not a residual)."""
    out = np.full(len(names), math.nan)
    if model is None:
        return out
    for i, (k, yk, sk) in enumerate(zip(names, y, sig)):
        v = model.get(k)
        if v is not None and math.isfinite(v) and not skip(k):
            out[i] = (v - yk) / sk
    return out


def refine_jointly(effects: Sequence, u: np.ndarray, evaluate: Callable[[List[np.ndarray]], None],
                   residuals: Callable[[np.ndarray], np.ndarray], chi2: Callable[[np.ndarray], float],
                   options: DiscoverOptions = DEFAULT) -> Refined:
    """:func:`gauss_newton` for a profile fit's point ``u`` of the ``effects``: bounds each
    effect's search range widened by a quarter of its width on both sides (within its bounds),
    difference steps a third of a grid step of the search range (9 points); at most
    ``options.gauss_newton_steps`` steps, each lowering χ² by more than ``options.min_gain``."""
    lower, upper, h = [], [], []
    for e in effects:
        lo, hi = e.search if math.isfinite(e.search[0]) else (e.lower, e.upper)
        lower.append(max(e.lower, lo - (hi - lo) / 4))
        upper.append(min(e.upper, hi + (hi - lo) / 4))
        h.append((hi - lo) / 24)
    return gauss_newton(u, lower, upper, h, evaluate, residuals, chi2, max_steps=options.gauss_newton_steps,
                        min_gain=options.min_gain)


class EnsembleObjective:
    """The joint refinement's objective on ensembles of runs (a model's runs from s0 + the
    ensemble's shifts, :func:`.models.ensemble_slider_features`): the mean features are smooth
    where single runs scatter by Δχ² of tens between neighbouring parameter values (friction and
    detuning together at (110 Hz, 10 m/s²)). Residuals and χ² with the uncertainties fixed at the
    start (σ² = σ_meas² + (1 + 1/R)·spread²), so that trial points are compared alike; the mode
    terms as in the fit's χ² (:func:`.stats.chi2_terms`)."""

    def __init__(self, evaluate, central, params_of, ensemble_many, key_of, names, y, se, spread, runs,
                 chi2_of, unpredicted) -> None:
        self._evaluate, self._central, self._params_of = evaluate, central, params_of
        self._many, self._key = ensemble_many, key_of
        self.names, self.y = list(names), y
        self.sig = np.sqrt(np.asarray(se) ** 2 + (1 + 1 / max(runs, 1)) *
                           np.array([spread.get(k, 0.0) for k in self.names]) ** 2)
        self._chi2_of, self._unpredicted = chi2_of, unpredicted
        self.cache: Dict = {}

    def evaluate(self, us: List[np.ndarray]) -> None:
        self._evaluate(us)
        todo, seen = [], set()
        for u in us:
            k = self._key(u)
            if k not in self.cache and k not in seen and self._central(u) is not None:
                todo.append(u)
                seen.add(k)
        for k in {self._key(u) for u in us} - seen:
            self.cache.setdefault(k, None)
        if todo:
            for u, e in zip(todo, self._many([self._params_of(u) for u in todo], [self._central(u) for u in todo])):
                self.cache[self._key(u)] = e

    def residuals(self, u: np.ndarray) -> np.ndarray:
        e = self.cache.get(self._key(u))
        if e is None:
            return np.full(len(self.names), math.nan)
        miss = self._unpredicted(e.mean, e.mode_counts, e.runs)
        return residual_vector(e.mean, self.names, self.y, self.sig, lambda k: tag_of(k) in miss and is_mode_feature(k))

    def chi2(self, u: np.ndarray) -> float:
        e = self.cache.get(self._key(u))
        return math.inf if e is None else self._chi2_of(e.mean, e.mode_counts, e.runs, self.sig)


def single_run_residuals(model_of: Callable[[np.ndarray], Optional[Dict[str, float]]], names: Sequence[str],
                         y: np.ndarray, sig: Callable[[], np.ndarray], unpredicted: Callable[[Dict[str, float]], set]
                         ) -> Callable[[np.ndarray], np.ndarray]:
    """Residuals of single runs (no ensembles): ``unpredicted(model)`` the operating points whose
    mode the run misses (their mode features are not residuals)."""
    def residuals(p: np.ndarray) -> np.ndarray:
        m = model_of(p)
        miss = unpredicted(m) if m is not None else set()
        return residual_vector(m, names, y, sig(), lambda k: tag_of(k) in miss and is_mode_feature(k))
    return residuals


def step_chi2(fit, changes: Dict[str, Dict[str, float]], meas: Dict, sig: Dict[str, float], base,
              modes: Optional[Dict] = None, counts: Optional[Dict[str, int]] = None,
              moves: float = DEFAULT.linear_steps) -> float:
    """The χ² a joint refinement of a set's coordinate-pass point ``fit`` is predicted to reach: one
    Gauss–Newton step on the linearised model, min over δ of |r + S δ|² with r the residuals of the
    pass's fitted features (``fit.predicted``, in units of ``sig``) and S the feature changes of
    each effect moved by ``moves`` relevance thresholds (``options.linear_steps``) from the baseline (``changes``,
    raw, :func:`.separability.slider_changes`, also in units of ``sig``: the fit's own uncertainties),
    δ bounded to each effect's search range; the gain |r|² − min |r + S δ|² taken off the pass's χ²
    (its mode terms unchanged), at least 0. Mode features of an
    operating point whose data mode the fitted features miss (``modes``), or none of the baseline's
    runs reached (``counts``: per point, the baseline's runs in the data's mode; the changes there
    are those of a run in another mode), are left out.
    The pass point's χ² if the linearised model has no column for an effect (docs/model.md §9.1)."""
    from scipy.optimize import lsq_linear

    effects = [EFFECTS[e] for e in fit.effects]
    if not fit.predicted or any(not changes.get(e.name) for e in effects):
        return float(fit.chi2)
    unreached = unreached_mode_features(meas, counts)
    known = as_modes(modes)

    def missed(k: str) -> bool:
        t = tag_of(k)
        md = (known or {}).get(t) if t is not None else None
        return k in unreached or (is_mode_feature(k) and md is not None and known.mode_of(fit.predicted, t) != md)

    keys = [k for k in meas if k in sig and sig[k] > 0 and math.isfinite(fit.predicted.get(k, math.nan))
            and not missed(k) and all(math.isfinite(changes[e.name].get(k, math.nan)) for e in effects)]
    if len(keys) <= len(effects):
        return float(fit.chi2)
    r = np.array([(fit.predicted[k] - meas[k].value) / sig[k] for k in keys])
    S = np.column_stack([[changes[e.name][k] / sig[k] for k in keys] for e in effects])
    lo, hi = [], []
    for e in effects:
        d = bumped(e, base, moves) - e.baseline_value(base)
        a, b = e.search if math.isfinite(e.search[0]) else (e.lower, e.upper)
        ends = [(e.value(v, base) - fit.values[e.name]) / d for v in (a, b)] if d != 0 else [0.0, 0.0]
        lo.append(min(ends + [0.0]))
        hi.append(max(ends + [0.0]))
    lo_a, hi_a = np.array(lo), np.array(hi)
    hi_a = np.where(hi_a - lo_a > 0, hi_a, lo_a + 1e-12)  # a fixed effect: a vanishing interval
    x = lsq_linear(S, -r, bounds=(lo_a, hi_a)).x
    gain = float(r @ r - np.sum((r + S @ x) ** 2))
    return max(float(fit.chi2) - max(gain, 0.0), 0.0)


def sets_to_refine(pass_chi2: Sequence[float], predicted: Optional[Sequence[float]], guided: Optional[int],
                   keep: int, margin: float) -> List[int]:
    """Which sets (indices) get the joint refinement after every set's coordinate pass: the
    ``keep`` − 1 best by the pass's χ² and ``guided`` (the pair the linearised model predicts best
    from the baseline), filled up to ``keep`` by the pass's χ²; and every set whose χ² after a
    Gauss–Newton step from its pass point (``predicted``, :func:`step_chi2`) is within ``margin``
    of the best pass's χ², in the order of that prediction (docs/model.md §9.1, "Cost"). The
    linearised model overestimates the gain of large moves: compared with one another, the
    predictions would favour the sets it overestimates most; compared with a χ² a set reached,
    an overestimate costs a refinement, not a set."""
    n = len(pass_chi2)
    by_pass = sorted(range(n), key=lambda i: pass_chi2[i])
    order = by_pass[:max(keep - 1, 0)]
    if guided is not None and 0 <= guided < n and guided not in order:
        order.append(guided)
    order += [i for i in by_pass if i not in order][:max(keep - len(order), 0)]
    if predicted is not None and len(predicted) == n and n:
        best = min(pass_chi2)
        order += [i for i in sorted(range(n), key=lambda i: predicted[i])
                  if predicted[i] <= best + margin and i not in order]
    return order
