"""Naming the missing effect: weighted least-squares fits of every candidate and pair, χ² criterion
and forward selection by likelihood-ratio tests (see the package docstring)."""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from .. import _core
from .._json import json_safe as _json_safe
from ..enma import EnmaData
from ..measurement import Measurement
from ..params import Parameters, resolve
from .effects import EFFECTS, Effect, _apply, _realise
from .features import Feature, enma_features
from .models import (ENSEMBLE_S0_SHIFTS, MODE_MIN_DOF, Ensemble, Modes, _levels_for, data_modes, is_mode_feature,
                     mode_penalty, run_mode, tag_of, batch_slider_features, ensemble_slider_features, beam_surrogate, measured_slider_features, simulated_enma_features)


SIGNIFICANCE = 0.01

MODE_CONDITIONING = True
"""Slider level: compare the features that depend on the state a run ends in
(:data:`.models.MODE_FEATURES`) only with model runs in the data's mode, and charge the mode's
rarity as a likelihood term (:func:`_chi2_terms`). False: one Gaussian over all runs."""


# --- features -------------------------------------------------------------------------------------

@dataclass
class CandidateFit:
    """One candidate set fitted to the measured features."""

    effects: Tuple[str, ...]
    values: Dict[str, float]
    stderrs: Dict[str, float]
    chi2: float
    dof: int
    adequate: bool
    bic: float
    predicted: Dict[str, float] = field(default_factory=dict)
    """Slider level: the features of the fitted model, mean of its ensemble of runs."""
    model_spread: Dict[str, float] = field(default_factory=dict)
    """Slider level: their spread over the ensemble (:data:`.models.ENSEMBLE_S0_SHIFTS`)."""
    intervals: Dict[str, Tuple[float, float]] = field(default_factory=dict)
    """Slider level: the Δχ² = 1 interval of each parameter from its profile scan."""
    roughness: Dict[str, float] = field(default_factory=dict)
    """Slider level: scatter of the single-run χ² about a parabola near the minimum
    (:func:`_roughness`); the interval's threshold is χ²_min + 1 + 2·roughness."""


@dataclass
class Discovery:
    """Outcome of :func:`discover` (see :func:`write_report`)."""

    level: str
    named_effects: List[str]
    parameters: Dict[str, Dict[str, Any]]
    features: Dict[str, Dict[str, Any]]
    gap_before: float
    gap_after: float
    chi2_before: float
    candidates: List[CandidateFit]
    criterion: str
    baseline: Parameters
    updated: Parameters
    behaviours: Dict[str, Dict[str, str]] = field(default_factory=dict)
    alternatives: List[Tuple[str, ...]] = field(default_factory=list)
    data: Any = None
    runtime_s: float = 0.0
    verdict: str = "none"
    """``named`` (an effect set passed the naming rule), ``unexplained`` (the baseline does not fit
    and no candidate set passes), ``none`` (the baseline fits the data)."""
    rejected: List[Dict[str, Any]] = field(default_factory=list)
    """Fitted candidate sets not named, each with the reasons."""
    features_off: List[Dict[str, Any]] = field(default_factory=list)
    """Features still off after the update (|z| > 2), largest first."""
    gap_ratio: float = 0.3
    gap_excess_before: float = 0.0
    """Gap beyond the noise before: sqrt(max(χ²₀ − n, 0)/n) (:data:`GAP_EXCESS_MEASURE`)."""
    gap_excess_after: float = 0.0
    """The same after the update: sqrt(max(χ² − (n − k), 0)/n)."""
    modes: Dict[str, Dict[str, Any]] = field(default_factory=dict)
    """Slider level, per operating point: the data's mode (:func:`.models.run_mode`: ends high,
    has a turning point) and how many of the baseline's and the updated model's ensemble runs end
    in it (:data:`MODE_CONDITIONING`)."""

    def to_json(self) -> Dict[str, Any]:
        return _json_safe(dict(
            verdict=self.verdict, level=self.level, named_effects=self.named_effects, parameters=self.parameters,
            rejected=self.rejected, features_off=self.features_off, gap_ratio=self.gap_ratio,
            gap_before=self.gap_before, gap_after=self.gap_after, gap_measure=GAP_MEASURE,
            gap_excess_before=self.gap_excess_before, gap_excess_after=self.gap_excess_after,
            gap_excess_measure=GAP_EXCESS_MEASURE,
            chi2_before=self.chi2_before, criterion=self.criterion, features=self.features,
            behaviours=self.behaviours, alternatives=[list(a) for a in self.alternatives],
            candidates=[dict(effects=list(c.effects), values=c.values, stderrs=c.stderrs, chi2=c.chi2, dof=c.dof,
                             adequate=c.adequate, bic=c.bic, intervals=c.intervals, chi2_roughness=c.roughness)
                        for c in self.candidates],
            modes=self.modes, baseline=self.baseline.to_dict(), updated=self.updated.to_dict(), runtime_s=self.runtime_s))


GAP_MEASURE = ("RMS over the features of (model - measured) / uncertainty (measurement and, slider level, "
               "the model's spread over its ensemble of runs), sqrt(chi2 / n); slider level, chi2 includes the "
               "mode terms (end-state features compared within the data's mode)")
GAP_EXCESS_MEASURE = ("gap beyond the noise: sqrt(max(chi2 - E[chi2], 0) / n), E[chi2] = n for the baseline "
                      "and n - k for a model with k fitted parameters; the naming rule compares these")


def _excess(chi2: float, dof: int, n: int) -> float:
    """Gap beyond the noise: sqrt(max(χ² − dof, 0)/n) (:data:`GAP_EXCESS_MEASURE`)."""
    return math.sqrt(max(chi2 - dof, 0.0) / max(n, 1))


def _chi2_quantile(dof: int) -> float:
    from scipy.stats import chi2

    return float(chi2.ppf(1 - SIGNIFICANCE, max(dof, 1)))


def _sigma(f: Feature, spread: float, runs: int) -> float:
    """Uncertainty of (model − measured) for a model feature that is the mean of ``runs`` runs whose
    spread is ``spread`` (runs = 0: no model spread): the measured value is one draw of the truth's
    spread, the model's mean has spread²/runs."""
    return math.sqrt(f.stderr ** 2 + (spread ** 2 * (1 + 1 / runs) if runs > 0 else 0.0))


def _mode_terms(model: Dict[str, float], modes: Optional[Modes], counts: Optional[Dict[str, int]],
                runs: int) -> Tuple[set, float]:
    """The operating points (tags) whose mode features the model cannot predict (none of its runs
    ends in the data's mode, :func:`.models.run_mode`), and the sum of the mode penalties
    (:func:`.models.mode_penalty`). ``counts``: per tag, how many of the model's ``runs`` runs are
    in the data's mode (an ensemble); None: ``model`` is one run, whose own mode decides."""
    unpredicted, pen = set(), 0.0
    for tag, md in (modes or {}).items():
        if md is None:
            continue
        if counts is not None and tag in counts:
            k, r = counts[tag], max(runs, 1)
        else:
            k, r = (1 if run_mode(model, tag) == md else 0), 1
        if k == 0:
            unpredicted.add(tag)
        pen += mode_penalty(k, r)
    return unpredicted, pen


def _chi2_terms(model: Optional[Dict[str, float]], names: Sequence[str], y: np.ndarray, sig: np.ndarray,
                modes: Optional[Modes] = None, counts: Optional[Dict[str, int]] = None, runs: int = 1) -> float:
    """χ² of the measured features ``names`` (values ``y``, uncertainties ``sig``) against
    ``model``: Σ z² (a feature the model lacks counts as 5σ), where a mode feature of an
    operating point the model cannot predict in the data's mode counts as its expectation, 1,
    plus the mode penalties (:func:`_mode_terms`): the likelihood of bimodal features is that of
    the data's mode times that of the features within it."""
    if model is None:
        return math.inf
    unpredicted, pen = _mode_terms(model, modes, counts, runs)
    total = pen
    for k, yk, sk in zip(names, y, sig):
        if tag_of(k) in unpredicted and is_mode_feature(k):
            total += 1.0
        elif k in model and math.isfinite(model[k]):
            total += ((model[k] - yk) / sk) ** 2
        else:
            total += 25.0
    return float(total)


def _missing_z(name: str, counts: Optional[Dict[str, int]]) -> float:
    """z of a feature an ensemble lacks: 1 (its expectation) for a mode feature of an operating
    point where none of its runs is in the data's mode, 5 otherwise (:func:`_chi2_terms`)."""
    tag = tag_of(name)
    return 1.0 if counts and tag in counts and counts[tag] == 0 and is_mode_feature(name) else 5.0


def _gap(model: Dict[str, float], meas: Dict[str, Feature], spread: Optional[Dict[str, float]] = None,
         runs: int = 0, modes: Optional[Modes] = None, counts: Optional[Dict[str, int]] = None) -> Tuple[float, float]:
    """(RMS gap sqrt(χ²/n), χ²) of ``model`` against the measured features (:func:`_chi2_terms`;
    ``spread``/``runs``: the model's ensemble, :func:`_sigma`; ``modes``/``counts``: the data's
    modes and the ensemble's runs in them)."""
    sp = spread or {}
    names = list(meas)
    if not names:
        return 0.0, 0.0
    y = np.array([meas[k].value for k in names])
    sig = np.array([_sigma(meas[k], sp.get(k, 0.0), runs) for k in names])
    chi2 = _chi2_terms(model, names, y, sig, modes, counts, max(runs, 1))
    return float(math.sqrt(chi2 / len(names))), chi2


def _fit_candidate(effects: Sequence[Effect], baseline: Parameters, meas: Dict[str, Feature],
                   model_fn: Callable[[Parameters], Dict[str, float]], *, diff_step: Optional[float],
                   max_nfev: int) -> CandidateFit:
    from scipy.optimize import least_squares

    names = [k for k in meas]
    sig = np.array([meas[k].stderr for k in names])
    y = np.array([meas[k].value for k in names])
    penalty = 1e3

    def resid(u: np.ndarray) -> np.ndarray:
        try:
            m = model_fn(_apply(baseline, effects, u))
        except (ValueError, _core.SimulationError):
            return np.full(len(names), penalty)
        r = np.array([(m.get(k, math.nan) - yk) / sk for k, yk, sk in zip(names, y, sig)])
        return np.where(np.isfinite(r), r, penalty)

    lo = np.array([e.lower for e in effects])
    hi = np.array([e.upper for e in effects])
    starts = [np.clip([e.variable(e.baseline_value(baseline), baseline) for e in effects], lo, hi)]
    starts.append(lo + 0.1 * (hi - lo))
    best = None
    for x0 in starts:
        kw = dict(bounds=(lo, hi), x_scale=np.maximum(hi - lo, 1e-12) * 0.05, max_nfev=max_nfev)
        if diff_step is not None:
            kw["diff_step"] = diff_step
        r = least_squares(resid, x0, **kw)
        if best is None or r.cost < best.cost:
            best = r
    assert best is not None
    chi2 = float(2 * best.cost)
    n, k = len(names), len(effects)
    J = best.jac
    try:
        cov_u = np.linalg.pinv(J.T @ J)
        se_u = np.sqrt(np.maximum(np.diag(cov_u), 0.0))
    except np.linalg.LinAlgError:
        se_u = np.full(k, math.inf)
    values, stderrs = {}, {}
    for e, u, su in zip(effects, best.x, se_u):
        v = e.value(u, baseline)
        values[e.name] = v
        if e.kind == "compliance":
            stderrs[e.name] = abs(e.scale(baseline) / u ** 2) * su if u > 0 else math.inf
        else:
            stderrs[e.name] = abs(e.scale(baseline)) * su
    dof = n - k
    return CandidateFit(tuple(e.name for e in effects), values, stderrs, chi2, dof,
                        chi2 <= _chi2_quantile(dof), chi2 + k * math.log(max(n, 2)))


ModelMany = Callable[[List[Parameters]], List[Optional[Dict[str, float]]]]
"""Model features of several parameter sets at once (None for a failed model): one batch of runs."""


def _one_at_a_time(model_fn: Callable[[Parameters], Dict[str, float]]) -> ModelMany:
    def many(ps: List[Parameters]) -> List[Optional[Dict[str, float]]]:
        out: List[Optional[Dict[str, float]]] = []
        for p in ps:
            try:
                out.append(model_fn(p))
            except (ValueError, _core.SimulationError):
                out.append(None)
        return out
    return many


def _stderr_of(e: Effect, u: float, su: float, baseline: Parameters) -> float:
    """Standard error of the parameter value from that of its fit variable u (delta method)."""
    if not math.isfinite(su):
        return math.inf
    if e.kind == "compliance":
        return abs(e.scale(baseline) / u ** 2) * su if u > 0 else math.inf
    return abs(e.scale(baseline)) * su


EnsembleMany = Callable[[List[Parameters], List[Optional[Dict[str, float]]]], List[Optional[Ensemble]]]
"""Ensembles (:func:`.models.ensemble_slider_features`) of several parameter sets whose unshifted
runs' features are given: one batch of the remaining runs."""


def _roughness(xs: np.ndarray, fs: np.ndarray) -> float:
    """Scatter of single-run χ² values about a quadratic in x: the residual RMS of a least-squares
    parabola through the points (at least 5 distinct x, 4 residual degrees of freedom
    with 7), 0 with fewer. Where the locomotion is chaotic in the parameter (restitution), runs at
    neighbouring values differ by Δχ² of several units although the data cannot tell them apart."""
    xs, fs = np.asarray(xs, dtype=float), np.asarray(fs, dtype=float)
    ok = np.isfinite(fs)
    xs, fs = xs[ok], fs[ok]
    if np.unique(np.round(xs, 12)).size < 5:
        return 0.0
    ss, dof = _parabola_scatter(xs, fs)
    return math.sqrt(ss / dof)


def _parabola_scatter(x: np.ndarray, v: np.ndarray) -> Tuple[float, int]:
    """Sum of squared residuals of v about a least-squares parabola in x, and their degrees of
    freedom (len − 3): what a quadratic trend leaves unexplained (the roughness)."""
    t = (x - x.mean()) / max(float(np.ptp(x)), 1e-300)
    r = v - np.polyval(np.polyfit(t, v, 2), t)
    return float(r @ r), len(x) - 3


def _interval(xs: np.ndarray, fs: np.ndarray, rough: float = 0.0) -> Tuple[float, float, float]:
    """Minimum of a scanned profile χ²(x) and its Δχ² = 1 interval: the outermost scan points with
    χ² ≤ χ²_min + 1, extended to where the profile crosses χ²_min + 1 by interpolation in
    sqrt(χ² − χ²_min) (the scan's ends if it does not cross). For a rough profile (single-run χ²
    scattering by ``rough`` about a smooth one, :func:`_roughness`) the threshold is
    χ²_min + 1 + 2·rough: the scan points that the scatter cannot tell from the minimum."""
    order = np.argsort(xs)
    xs, fs = xs[order], fs[order]
    ok = np.isfinite(fs)
    if not ok.any():
        return math.nan, -math.inf, math.inf
    j = int(np.nanargmin(np.where(ok, fs, np.inf)))
    delta = 1.0 + 2.0 * max(float(rough), 0.0)
    level = fs[j] + delta
    inside = np.flatnonzero(ok & (fs <= level))
    lo_i, hi_i = int(inside[0]), int(inside[-1])

    def cross(i_in: int, i_out: int) -> float:
        # Interpolated in sqrt(χ² − χ²_min), linear in x for a parabolic profile: exact for a
        # parabola however coarse the scan (linear in χ² would shrink the interval by the
        # ratio of the scan step to the interval).
        if not np.isfinite(fs[i_out]):
            return float(xs[i_out])
        r_in, r_out = math.sqrt(max(fs[i_in] - fs[j], 0.0)), math.sqrt(max(fs[i_out] - fs[j], 0.0))
        w = (math.sqrt(delta) - r_in) / (r_out - r_in)
        return float(xs[i_in] + w * (xs[i_out] - xs[i_in]))

    lo = cross(lo_i, lo_i - 1) if lo_i > 0 else float(xs[0])
    hi = cross(hi_i, hi_i + 1) if hi_i < len(xs) - 1 else float(xs[-1])
    return float(xs[j]), lo, hi


def _pooled_spread(ens: Ensemble, levels: Sequence[Sequence[Optional[Dict[str, float]]]],
                   names: Sequence[str], modes: Optional[Modes] = None) -> Dict[str, float]:
    """The model's spread of each feature at the fitted point, pooled from two measurements of the
    same thing — its sensitivity to what the data cannot resolve: the variance over the ensemble
    of runs (R − 1 degrees of freedom) and the scatter about a quadratic trend of the single runs
    of the last refinement level of each profile scan (7 points, 4 degrees of freedom; the trend is
    what the data resolve, the scatter the roughness). Five runs alone give an unstable estimate
    (4 degrees of freedom: at μ = 0.26, 60 s, the final amplitude at 126 Hz spreads by 0.002 over
    the ensemble, by 0.007 over nine perturbations). ``modes``: the data's modes; a mode feature's
    spread comes from the runs in the data's mode only, or, with fewer than
    :data:`.models.MODE_MIN_DOF` degrees of freedom, is the ensemble's spread over all runs."""
    out: Dict[str, float] = {}
    for k in names:
        ss, dof = 0.0, 0
        tag = tag_of(k)
        md = (modes or {}).get(tag) if tag is not None and is_mode_feature(k) else None
        if md is not None and tag in ens.mode_counts:
            runs = ens.mode_counts[tag]
            if k in ens.mode_spread and runs > 1:
                ss += ens.mode_spread[k] ** 2 * (runs - 1)
                dof += runs - 1
        elif k in ens.spread and ens.runs > 1:
            ss += ens.spread[k] ** 2 * (ens.runs - 1)
            dof += ens.runs - 1
        for pts in levels:
            xs = np.array([j for j, m in enumerate(pts) if m is not None and k in m and math.isfinite(m[k])
                           and (md is None or run_mode(m, tag) == md)], dtype=float)
            if len(xs) >= 5:
                v = np.array([pts[int(j)][k] for j in xs])  # type: ignore[index]
                ss_k, dof_k = _parabola_scatter(xs, v)
                ss += ss_k
                dof += dof_k
        if md is not None and tag in ens.mode_counts and dof < MODE_MIN_DOF:
            out[k] = ens.spread.get(k, 0.0)  # too few runs in the data's mode: the spread over all runs
        else:
            out[k] = math.sqrt(ss / dof) if dof > 0 else 0.0
    return out


def _profile_fit(effects: Sequence[Effect], baseline: Parameters, meas: Dict[str, Feature],
                 model_fn: Optional[Callable[[Parameters], Dict[str, float]]] = None, *, grid_n: int = 9,
                 refine: int = 2, model_many: Optional[ModelMany] = None,
                 ensemble_many: Optional[EnsembleMany] = None, spread0: Optional[Dict[str, float]] = None,
                 fixed: Optional[Dict[str, float]] = None) -> CandidateFit:
    """Fit for expensive, rough objectives (slider level). Per effect (one coordinate pass): a grid
    scan of χ² over its search range (``grid_n`` points, one batch of runs), then ``refine``
    levels of 7 points spanning ± one step around the best so far (each one batch; the step
    shrinks 3× per level). The model's sensitivity to what the data cannot resolve enters every
    χ² as a spread of the features (σ² = σ_meas² + 2·spread² for one run against one measured
    draw): ``spread0`` (the baseline's) at first, then that of an ensemble of runs
    (``ensemble_many``) at the best coarse point, and at the end that of the ensemble at the
    fitted point, whose mean gives the fit's χ² (σ² = σ_meas² + (1 + 1/R)·spread²). Standard
    error: half the Δχ² = 1 interval of the rescored profile scan (:func:`_interval`), widened
    by the scatter of the last refinement level's χ² about a parabola (:func:`_roughness`)
    where the objective is rough.
    ``fixed``: values of further effects held (the joint fit's beam-level part)."""
    many = model_many if model_many is not None else _one_at_a_time(model_fn)  # type: ignore[arg-type]
    names = list(meas)
    se = np.array([meas[k].stderr for k in names])
    y = np.array([meas[k].value for k in names])
    cache: Dict[Tuple[float, ...], Optional[Dict[str, float]]] = {}
    fixed = dict(fixed or {})
    spread = dict(spread0 or {})
    modes = data_modes(meas) if MODE_CONDITIONING else None

    def sig_single() -> np.ndarray:
        return np.sqrt(se ** 2 + 2 * np.array([spread.get(k, 0.0) for k in names]) ** 2)

    def chi2_from(m: Optional[Dict[str, float]], sig: np.ndarray, counts: Optional[Dict[str, int]] = None,
                  runs: int = 1) -> float:
        return _chi2_terms(m, names, y, sig, modes, counts, runs)

    def key_of(u: np.ndarray) -> Tuple[float, ...]:
        return tuple(round(float(v), 12) for v in u)

    def params_of(u: np.ndarray) -> Parameters:
        vals = dict(fixed)
        vals.update({e.name: e.value(float(x), baseline) for e, x in zip(effects, u)})
        return _realise(baseline, vals)

    def evaluate(us: List[np.ndarray]) -> None:
        todo: Dict[Tuple[float, ...], Parameters] = {}
        for u in us:
            key = key_of(u)
            if key not in cache and key not in todo:
                try:
                    todo[key] = params_of(u)
                except ValueError:
                    cache[key] = None
        if todo:
            for key, m in zip(todo, many(list(todo.values()))):
                cache[key] = m

    def chi2(u: np.ndarray) -> float:
        return chi2_from(cache[key_of(u)], sig_single())

    def ensemble_at(u: np.ndarray) -> Optional[Ensemble]:
        if ensemble_many is None or cache.get(key_of(u)) is None:
            return None
        return ensemble_many([params_of(u)], [cache[key_of(u)]])[0]

    u = np.array([np.clip(e.variable(e.baseline_value(baseline), baseline), e.lower, e.upper) for e in effects])
    samples: List[List[np.ndarray]] = [[] for _ in effects]
    last: List[List[np.ndarray]] = [[] for _ in effects]
    for i, e in enumerate(effects):
        lo, hi = e.search if math.isfinite(e.search[0]) else (e.lower, e.upper)
        at = lambda x: np.where(np.arange(len(u)) == i, x, u)  # noqa: E731
        grid = list(np.linspace(lo, hi, grid_n))
        evaluate([at(g) for g in grid])
        xs = list(grid)
        step = (hi - lo) / max(grid_n - 1, 1)
        x_best = min(xs, key=lambda x: chi2(at(x)))
        if i == 0:
            ens = ensemble_at(at(x_best))
            if ens is not None:
                spread.update(ens.spread)
                x_best = min(xs, key=lambda x: chi2(at(x)))
        fine = []
        for _ in range(refine):
            fine = [x for x in np.linspace(x_best - step, x_best + step, 7) if lo <= x <= hi]
            evaluate([at(x) for x in fine])
            xs += fine
            x_best = min(xs, key=lambda x: chi2(at(x)))
            step /= 3
        u[i] = x_best
        samples[i] = [at(x) for x in xs]
        last[i] = [at(x) for x in fine]
    ens = ensemble_at(u)
    n, k = len(names), len(effects) + len(fixed)
    predicted: Dict[str, float] = {}
    if ens is not None:
        spread.update(_pooled_spread(ens, [[cache[key_of(p)] for p in pts] for pts in last], names, modes))
        predicted = dict(ens.mean)
        sig_e = np.sqrt(se ** 2 + (1 + 1 / ens.runs) * np.array([spread.get(kk, 0.0) for kk in names]) ** 2)
        best_chi2 = chi2_from(ens.mean, sig_e, ens.mode_counts, ens.runs)
    else:
        best_chi2 = chi2(u)
        predicted = dict(cache[key_of(u)] or {})
    values, stderrs, intervals = dict(fixed), {}, {}
    roughness: Dict[str, float] = {}
    for i, e in enumerate(effects):
        xs = np.array([p[i] for p in samples[i]])
        fs = np.array([chi2(p) for p in samples[i]])
        rough = _roughness(np.array([p[i] for p in last[i]]), np.array([chi2(p) for p in last[i]]))
        _, lo_u, hi_u = _interval(xs, fs, rough)
        roughness[e.name] = rough
        su = (hi_u - lo_u) / 2 if math.isfinite(lo_u) and math.isfinite(hi_u) else math.inf
        values[e.name] = e.value(u[i], baseline)
        stderrs[e.name] = _stderr_of(e, u[i], su, baseline)
        ends = sorted((e.value(lo_u, baseline), e.value(hi_u, baseline))) if math.isfinite(su) else [-math.inf, math.inf]
        intervals[e.name] = (ends[0], ends[1])
    names_all = tuple(list(fixed) + [e.name for e in effects])
    return CandidateFit(names_all, values, stderrs, best_chi2, n - k, best_chi2 <= _chi2_quantile(n - k),
                        best_chi2 + k * math.log(max(n, 2)), predicted,
                        {kk: spread.get(kk, 0.0) for kk in names}, intervals, roughness)


def _lrt_threshold(df: int, m: int) -> float:
    """Likelihood-ratio threshold for adding ``df`` effects chosen as the best of ``m`` candidate
    sets: the (1 − α/m) quantile of χ²(df) (Bonferroni for picking the best of m)."""
    from scipy.stats import chi2

    return float(chi2.isf(SIGNIFICANCE / max(m, 1), max(df, 1)))


def _select(fits: List[CandidateFit], chi2_0: float, n: int) -> Tuple[Optional[CandidateFit], List[Tuple[str, ...]]]:
    """Nothing if the baseline is adequate; else forward selection by likelihood-ratio tests: the
    best single effect must beat the baseline, and the best larger set containing the current
    choice must beat it, by more than :func:`_lrt_threshold` (99 %, corrected for the number of
    sets the best was picked from)."""
    if chi2_0 <= _chi2_quantile(n) or not fits:
        return None, []
    by_size: Dict[int, List[CandidateFit]] = {}
    for f in fits:
        by_size.setdefault(len(f.effects), []).append(f)
    best: Optional[CandidateFit] = None
    best_chi2, best_k = chi2_0, 0
    for k in sorted(by_size):
        pool = [c for c in by_size[k] if best is None or set(best.effects) <= set(c.effects)]
        if not pool:
            continue
        top = min(pool, key=lambda c: c.chi2)
        if best_chi2 - top.chi2 > _lrt_threshold(k - best_k, len(pool)):
            best, best_chi2, best_k = top, top.chi2, k
        else:
            break
    if best is None:
        return None, []
    alts = [c.effects for c in by_size[len(best.effects)] if c.effects != best.effects and c.chi2 - best.chi2 < 2.0]
    return best, alts


def _progress_bar(enabled: bool, total: int, desc: str):
    """tqdm bar of fits done / to do (a no-op object when disabled)."""
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, unit="fit", disable=not enabled, leave=False)


def _pairs_to_fit(cand_effects: Sequence[Effect], singles: List[CandidateFit], max_effects: int, level: str
                  ) -> List[Tuple[Effect, ...]]:
    """The sets of 2..max_effects effects to fit: all at the beam level (cheap surrogate); at the
    slider and joint levels those that extend one of the two best singles, and (joint) every set
    of beam-level effects only (their slider part is one evaluation)."""
    top = {f.effects[0] for f in sorted(singles, key=lambda f: f.chi2)[:2]}
    out = []
    for k in range(2, max_effects + 1):
        for combo in itertools.combinations(cand_effects, k):
            names = {e.name for e in combo}
            if level == "beam" or top & names or (level == "joint" and all(e.level == "beam" for e in combo)):
                out.append(combo)
    return out


def _fit_sets(cand_effects: Sequence[Effect], max_effects: int, level: str, base: Parameters,
              meas: Dict[str, Feature], model_fn: Callable[[Parameters], Dict[str, float]],
              diff_step: Optional[float], max_nfev: int, *, model_many: Optional[ModelMany] = None,
              ensemble_many: Optional[EnsembleMany] = None, spread0: Optional[Dict[str, float]] = None,
              progress: bool = False) -> List[CandidateFit]:
    """Fit every single candidate and the sets of up to ``max_effects`` (:func:`_pairs_to_fit`)."""
    def fit(combo: Sequence[Effect]) -> CandidateFit:
        if level == "beam":
            return _fit_candidate(combo, base, meas, model_fn, diff_step=diff_step, max_nfev=max_nfev)
        return _profile_fit(combo, base, meas, model_fn, model_many=model_many, ensemble_many=ensemble_many,
                            spread0=spread0)

    bar = _progress_bar(progress, len(cand_effects), f"discover ({level}): fits")
    fits = []
    for e in cand_effects:
        fits.append(fit((e,)))
        bar.update(1)
    if max_effects >= 2:
        combos = _pairs_to_fit(cand_effects, fits, max_effects, level)
        bar.total = len(cand_effects) + len(combos)
        bar.refresh()
        for combo in combos:
            fits.append(fit(combo))
            bar.update(1)
    bar.close()
    return fits


def _fit_sets_joint(cand_effects: Sequence[Effect], max_effects: int, base: Parameters,
                    meas_b: Dict[str, Feature], model_b: Callable[[Parameters], Dict[str, float]],
                    meas_s: Dict[str, Feature], model_many: ModelMany, chi2_b0: float, chi2_s0: float,
                    *, ensemble_many: Optional[EnsembleMany] = None, spread0: Optional[Dict[str, float]] = None,
                    progress: bool = False) -> List[CandidateFit]:
    """Joint fit over beam (ENMA) and slider (run) features, χ² = χ²_beam + χ²_slider. The beam
    features do not depend on slider-level effects (the ENMA is of the beam alone), so a set's
    beam-level parameters are fitted to the beam features (weighted least squares on the
    surrogate; they are far more precise there than in the runs), and its slider-level parameters
    by the profile fit of the runs with those beam-level values held; a set of beam-level effects
    only costs one evaluation of the runs. Returns one fit per set, as :func:`_fit_sets`."""
    names_s = list(meas_s)
    modes = data_modes(meas_s) if MODE_CONDITIONING else None

    def chi2_s_of(ps: List[Parameters]) -> List[Tuple[float, Dict[str, float], Dict[str, float]]]:
        """χ² of the runs of each model (with its ensemble's mean and spread when given)."""
        singles = model_many(ps)
        ens = ensemble_many(ps, singles) if ensemble_many is not None else [None] * len(ps)
        out = []
        for m, e in zip(singles, ens):
            if m is None:
                out.append((math.inf, {}, {}))
                continue
            mean, sp, runs = (e.mean, e.spread, e.runs) if e is not None else (m, dict(spread0 or {}), 1)
            counts = e.mode_counts if e is not None else None
            f = {k: mean[k] for k in names_s if k in mean}
            out.append((_gap(f, meas_s, sp, runs, modes, counts)[1], mean, sp))
        return out

    n = len(meas_b) + len(meas_s)

    def fit_sets(combos: List[Tuple[Effect, ...]], bar) -> List[CandidateFit]:
        beam_fits: Dict[Tuple[str, ...], CandidateFit] = {}
        for combo in combos:
            eb = tuple(e for e in combo if e.level == "beam")
            if eb and tuple(e.name for e in eb) not in beam_fits:
                beam_fits[tuple(e.name for e in eb)] = _fit_candidate(eb, base, meas_b, model_b, diff_step=None, max_nfev=200)
        out: List[Optional[CandidateFit]] = [None] * len(combos)
        # Sets of beam-level effects only: their runs as one batch.
        only_b = [i for i, c in enumerate(combos) if all(e.level == "beam" for e in c)]
        if only_b:
            ps = [_realise(base, beam_fits[tuple(e.name for e in combos[i])].values) for i in only_b]
            for i, (c2, mean, sp) in zip(only_b, chi2_s_of(ps)):
                bf = beam_fits[tuple(e.name for e in combos[i])]
                chi2 = bf.chi2 + c2
                k = len(combos[i])
                out[i] = CandidateFit(bf.effects, dict(bf.values), dict(bf.stderrs), chi2, n - k,
                                      chi2 <= _chi2_quantile(n - k), chi2 + k * math.log(n), mean, sp)
                bar.update(1)
        for i, combo in enumerate(combos):
            if out[i] is not None:
                continue
            eb = tuple(e for e in combo if e.level == "beam")
            es = [e for e in combo if e.level != "beam"]
            bf = beam_fits.get(tuple(e.name for e in eb)) if eb else None
            sf = _profile_fit(es, base, meas_s, model_many=model_many, ensemble_many=ensemble_many, spread0=spread0,
                              fixed=bf.values if bf else None)
            chi2 = (bf.chi2 if bf else chi2_b0) + sf.chi2
            k = len(combo)
            values = {e.name: sf.values[e.name] for e in combo}
            stderrs = {**(bf.stderrs if bf else {}), **sf.stderrs}
            out[i] = CandidateFit(tuple(e.name for e in combo), values, stderrs, chi2, n - k,
                                  chi2 <= _chi2_quantile(n - k), chi2 + k * math.log(n), sf.predicted,
                                  sf.model_spread, sf.intervals, sf.roughness)
            bar.update(1)
        return [f for f in out if f is not None]

    bar = _progress_bar(progress, len(cand_effects), "discover (joint): fits")
    fits = fit_sets([(e,) for e in cand_effects], bar)
    if max_effects >= 2:
        combos = _pairs_to_fit(cand_effects, fits, max_effects, "joint")
        bar.total = len(cand_effects) + len(combos)
        bar.refresh()
        fits += fit_sets(combos, bar)
    bar.close()
    return fits


def _judge(fits: Sequence[CandidateFit], base: Parameters, n: int, excess_before: float,
           gap_ratio: float) -> Dict[Tuple[str, ...], List[str]]:
    """The naming rule per fitted set: the reasons it may not be named (empty: it may). Not
    adequate (χ² > χ²₀.₉₉(n − k)); a parameter moved by less than its relevance threshold; a
    small share of the gap beyond the noise (:func:`_excess`: sqrt(max(χ² − (n − k), 0)/n) >
    gap_ratio × the baseline's sqrt(max(χ²₀ − n, 0)/n))."""
    out: Dict[Tuple[str, ...], List[str]] = {}
    for f in fits:
        reasons = []
        if not f.adequate:
            reasons.append(f"not adequate: chi2 = {f.chi2:.3g} > chi2_0.99({f.dof}) = {_chi2_quantile(f.dof):.3g}")
        for e in f.effects:
            ok, how = EFFECTS[e].relevant(f.values[e], base)
            if not ok:
                reasons.append(f"negligible change of {EFFECTS[e].field}: {how}")
        g = _excess(f.chi2, f.dof, n)
        if g > gap_ratio * excess_before:
            reasons.append(f"small share of the gap beyond the noise: {excess_before:.3g} -> {g:.3g} "
                           f"(more than {gap_ratio:g} x)")
        out[f.effects] = reasons
    return out


def discover(*, enma_data: Optional[EnmaData] = None, measured: Optional[Sequence[Measurement]] = None,
             baseline: Optional[Parameters] = None, effects: Optional[Sequence[str]] = None,
             max_effects: int = 2, progress: bool = False, gap_ratio: float = 0.3,
             threads: Optional[int] = None) -> Discovery:
    """Find the effects the ``baseline`` model misses, from beam-level ENMA data (``enma_data``),
    slider-level free-slider runs (``measured``, files of the published format) or both (one joint
    fit over both feature sets: beam-level effects from both, slider-level ones from the runs),
    name them, add them and measure the gap before and after (module docs: criterion).
    ``gap_ratio``: a named set must leave at most this share of the gap beyond the noise,
    sqrt(max(χ² − E[χ²], 0)/n) (0.3); otherwise the verdict is "unexplained". Slider level: each
    model is an ensemble of runs from s0 + :data:`.models.ENSEMBLE_S0_SHIFTS` whose spread joins
    the feature uncertainties. ``progress``: a bar of fits done / to do. ``threads``: workers of
    the core's runner for the free-slider runs (None: one per core)."""
    import time

    t0 = time.perf_counter()
    base = resolve(baseline)
    if not (isinstance(gap_ratio, (int, float)) and 0 < gap_ratio <= 1):
        raise ValueError(f"invalid gap_ratio = {gap_ratio!r}: must be in (0, 1]")
    if threads is not None and not (isinstance(threads, int) and threads >= 1):
        raise ValueError(f"invalid threads = {threads!r}: must be an integer >= 1")
    if enma_data is None and measured is None:
        raise ValueError("give enma_data (beam level), measured runs (slider level) or both (joint fit)")
    if measured is not None and len(measured) == 0:
        raise ValueError("invalid measured = []: give at least one run")
    level = "joint" if (enma_data is not None and measured is not None) else ("beam" if enma_data is not None else "slider")
    levels = {"beam", "slider"} if level == "joint" else {level}
    names = list(effects) if effects is not None else [n for n, e in EFFECTS.items() if e.level in levels]
    unknown = [n for n in names if n not in EFFECTS]
    if unknown:
        raise ValueError(f"unknown effect {unknown[0]!r}: known are {', '.join(EFFECTS)}")
    cand_effects = [EFFECTS[n] for n in names if EFFECTS[n].level in levels]
    if not cand_effects:
        raise ValueError(f"none of the effects {names} acts at the {level} level")
    behaviours: Dict[str, Dict[str, str]] = {}
    meas: Dict[str, Feature] = {}
    before: Dict[str, float] = {}
    model_many: Optional[ModelMany] = None
    ensemble_many: Optional[EnsembleMany] = None
    spread_base: Dict[str, float] = {}
    runs_base = len(ENSEMBLE_S0_SHIFTS) if measured is not None else 0
    modes: Optional[Modes] = None
    counts_base: Dict[str, int] = {}
    bias: Dict[str, float] = {}
    if enma_data is not None:
        meas_b = enma_features(enma_data)
        enma_levels = _levels_for(enma_data, base)
        sim_base, _ = simulated_enma_features(base, enma_levels)
        sur_base = beam_surrogate(base)
        bias.update({k: sim_base[k].value - sur_base[k] for k in sim_base if k in sur_base})

        def model_b(p: Parameters) -> Dict[str, float]:
            s_ = beam_surrogate(p)
            return {k: v + bias.get(k, 0.0) for k, v in s_.items()}

        meas.update(meas_b)
        before.update({k: f.value for k, f in sim_base.items()})
    if measured is not None:
        meas_s, beh_meas, ops = measured_slider_features(measured)
        modes = data_modes(meas_s) if MODE_CONDITIONING else None
        # Baseline: an ensemble of runs from s0 + ENSEMBLE_S0_SHIFTS (one batch): the mean is the
        # prediction, the spread the model's sensitivity to what the data cannot resolve; with
        # modes, the mode features' mean and spread over the runs in the data's mode.
        ens_base = ensemble_slider_features([base], ops, threads=threads, modes=modes)[0]
        if ens_base is None:
            raise _core.SimulationError("the baseline model's runs at the measured operating points failed")
        spread_base = {k: ens_base.spread.get(k, 0.0) for k in meas_s}
        behaviours = {"measured": beh_meas, "baseline": ens_base.behaviours}

        def model_many_fn(ps: List[Parameters]) -> List[Optional[Dict[str, float]]]:
            return [None if r is None else {k: f.value for k, f in r[0].items()}
                    for r in batch_slider_features(ps, ops, threads=threads)]

        def ensemble_many_fn(ps: List[Parameters], central: List[Optional[Dict[str, float]]]) -> List[Optional[Ensemble]]:
            cen = [None if c is None else ({k: Feature(k, v, 0.0) for k, v in c.items()}, {}) for c in central]
            return ensemble_slider_features(ps, ops, threads=threads, central=cen, modes=modes)

        ensemble_many = ensemble_many_fn
        model_many = model_many_fn
        meas.update(meas_s)
        before.update(ens_base.mean)
        counts_base = ens_base.mode_counts

    def model_fn(p: Parameters) -> Dict[str, float]:
        out: Dict[str, float] = {}
        if enma_data is not None:
            out.update(model_b(p))
        if model_many is not None:
            r = model_many([p])[0]
            if r is None:
                raise _core.SimulationError("a run of the model failed")
            out.update(r)
        return out

    diff_step, max_nfev = None, (200 if level == "beam" else 0)
    # Features the baseline cannot compute (e.g. no turning point) count as a disagreement of 5σ.
    for k in meas:
        if k not in before:
            before[k] = meas[k].value + _missing_z(k, counts_base) * _sigma(meas[k], spread_base.get(k, 0.0), runs_base)
    gap_before, chi2_0 = _gap(before, meas, spread_base, runs_base, modes, counts_base)
    n = len(meas)
    excess_before = _excess(chi2_0, n, n)
    fits: List[CandidateFit] = []

    def refit_beam_bias(fits_b: List[CandidateFit]) -> None:
        """Re-centre the surrogate's bias correction at the model the likelihood-ratio selection
        picks (the surrogate's own errors would otherwise count against adequacy)."""
        best_b, _ = _select(fits_b, _gap({k: before[k] for k in meas_b}, meas_b)[1], len(meas_b))
        if best_b is not None:
            chosen = _realise(base, {e: best_b.values[e] for e in best_b.effects})
            sim_c, _ = simulated_enma_features(chosen, enma_levels)
            sur_c = beam_surrogate(chosen)
            bias.clear()
            bias.update({k: sim_c[k].value - sur_c[k] for k in sim_c if k in sur_c})

    if chi2_0 > _chi2_quantile(n):
        if level == "beam":
            fits = _fit_sets(cand_effects, max_effects, level, base, meas, model_fn, diff_step, max_nfev,
                             progress=progress)
            best0, _ = _select(fits, chi2_0, n)
            if best0 is not None:
                refit_beam_bias(fits)
                fits = [_fit_candidate([EFFECTS[e] for e in f.effects], base, meas, model_fn, diff_step=diff_step,
                                       max_nfev=max_nfev) for f in fits]
        elif level == "slider":
            fits = _fit_sets(cand_effects, max_effects, level, base, meas, model_fn, diff_step, max_nfev,
                             model_many=model_many, ensemble_many=ensemble_many, spread0=spread_base,
                             progress=progress)
        else:
            assert model_many is not None
            # Beam stage first (cheap): its selection re-centres the surrogate's bias.
            beam_cands = [e for e in cand_effects if e.level == "beam"]
            chi2_b0 = _gap({k: before[k] for k in meas_b}, meas_b)[1]
            if beam_cands and chi2_b0 > _chi2_quantile(len(meas_b)):
                fits_b = _fit_sets(beam_cands, max_effects, "beam", base, meas_b, model_b, None, 200)
                refit_beam_bias(fits_b)
            chi2_s0 = _gap({k: before[k] for k in meas_s}, meas_s, spread_base, runs_base, modes, counts_base)[1]
            fits = _fit_sets_joint(cand_effects, max_effects, base, meas_b, model_b, meas_s, model_many,
                                   chi2_b0, chi2_s0, ensemble_many=ensemble_many, spread0=spread_base,
                                   progress=progress)
    verdicts = _judge(fits, base, n, excess_before, gap_ratio)
    best, alts = _select([f for f in fits if not verdicts[f.effects]], chi2_0, n)

    def after_of(p: Parameters) -> Tuple[Dict[str, float], Dict[str, str], Dict[str, float], Dict[str, int]]:
        # "After": full simulation of the updated model (not the surrogate): virtual ENMA and the
        # ensemble of runs (mean, behaviours of the unshifted run, spread, runs in the data's modes).
        out: Dict[str, float] = {}
        beh: Dict[str, str] = {}
        sp: Dict[str, float] = {}
        counts: Dict[str, int] = {}
        if enma_data is not None:
            out.update({k: f.value for k, f in simulated_enma_features(p, enma_levels)[0].items()})
        if measured is not None:
            e = ensemble_slider_features([p], ops, threads=threads, modes=modes)[0]
            if e is not None:
                out.update(e.mean)
                beh, sp, counts = e.behaviours, e.spread, e.mode_counts
        return out, beh, sp, counts

    def filled(f: Dict[str, float], sp: Dict[str, float], counts: Dict[str, int]) -> Dict[str, float]:
        f = dict(f)
        for k in meas:
            if k not in f:
                f[k] = meas[k].value + _missing_z(k, counts) * _sigma(meas[k], sp.get(k, 0.0), runs_base)
        return f

    after_f: Dict[str, float] = dict(before)
    spread_after: Dict[str, float] = dict(spread_base)
    counts_after: Dict[str, int] = dict(counts_base)
    beh_upd = behaviours.get("baseline", {})
    updated = base
    if best is not None:
        cand = _realise(base, {e: best.values[e] for e in best.effects})
        f_c, b_c, sp_c, n_c = after_of(cand)
        # The fit's spread pools the ensemble with the roughness of its scan (_pooled_spread).
        sp_c = {**sp_c, **{k: v for k, v in best.model_spread.items() if k in sp_c or k in f_c}}
        f_c = filled(f_c, sp_c, n_c)
        chi2_c = _gap(f_c, meas, sp_c, runs_base, modes, n_c)[1]
        g_c = _excess(chi2_c, n - len(best.effects), n)
        if g_c <= gap_ratio * excess_before:
            updated, after_f, beh_upd, spread_after, counts_after = cand, f_c, b_c, sp_c, n_c
        else:
            # The fit's gap was small enough, the full simulation's is not: not named.
            verdicts[best.effects] = verdicts[best.effects] + [
                f"small share of the gap beyond the noise in the full simulation of the updated model: "
                f"{g_c:.3g} > {gap_ratio:g} x {excess_before:.3g}"]
            best, alts = None, []
    if measured is not None:
        behaviours["updated"] = beh_upd
    if best is None:
        named: List[str] = []
        params_out: Dict[str, Dict[str, Any]] = {}
    else:
        named = list(best.effects)
        params_out = {e: dict(field=EFFECTS[e].field, value=best.values[e], stderr=best.stderrs[e],
                              unit=EFFECTS[e].unit, baseline=EFFECTS[e].baseline_value(base),
                              relevance=EFFECTS[e].relevant(best.values[e], base)[1],
                              **({"chi2_roughness": best.roughness[e]} if e in best.roughness else {})) for e in named}
    after_f = filled(after_f, spread_after, counts_after)
    gap_after, chi2_after = _gap(after_f, meas, spread_after, runs_base, modes, counts_after)
    excess_after = _excess(chi2_after, n - len(best.effects) if best is not None else n, n)

    def sig(k: str, sp: Dict[str, float]) -> float:
        return _sigma(meas[k], sp.get(k, 0.0), runs_base)

    features = {k: dict(measured=f.value, uncertainty=f.stderr, baseline=before[k], updated=after_f[k],
                        model_spread_baseline=spread_base.get(k, 0.0), model_spread_updated=spread_after.get(k, 0.0),
                        unit=f.unit, description=f.description,
                        z_before=(before[k] - f.value) / sig(k, spread_base),
                        z_after=(after_f[k] - f.value) / sig(k, spread_after),
                        exceeds_uncertainty=bool(abs(before[k] - f.value) > 2 * sig(k, spread_base)))
                for k, f in meas.items()}
    # "none" also when an adequate fit needs only a negligible change (and may fail the gap share):
    # the data are explained without a physically relevant change.
    negligible = [f for f in fits if verdicts[f.effects] and f.adequate
                  and any(r.startswith("negligible change") for r in verdicts[f.effects])
                  and all(r.startswith(("negligible change", "small share of the gap")) for r in verdicts[f.effects])]
    if chi2_0 <= _chi2_quantile(n):
        verdict = "none"
    elif best is not None:
        verdict = "named"
    elif negligible:
        # Adequate and closing the gap, but only by a physically negligible change: nothing to name.
        verdict = "none"
    else:
        verdict = "unexplained"
    rejected = [dict(effects=list(f.effects), values=f.values, stderrs=f.stderrs, chi2=f.chi2, dof=f.dof,
                     reasons=verdicts[f.effects] or ["passes the naming rule, but a simpler or better set was named"])
                for f in sorted(fits, key=lambda f: f.chi2) if best is None or f.effects != best.effects]
    off = sorted(((k, v["z_after"]) for k, v in features.items() if abs(v["z_after"]) > 2), key=lambda x: -abs(x[1]))
    criterion = (f"an effect set is named only if (1) the baseline does not fit, chi2 = {chi2_0:.3g} > chi2_0.99(n={n}) = "
                 f"{_chi2_quantile(n):.2f}; (2) the updated model is adequate, chi2 <= chi2_0.99(n-k); (3) each "
                 f"parameter moved by at least its relevance threshold (EFFECTS[...].relevance); (4) the gap beyond "
                 f"the noise, sqrt(max(chi2 - E[chi2], 0)/n), after <= {gap_ratio:g} x before ({excess_before:.3g}; "
                 f"fit and full simulation); among the sets that pass, forward "
                 f"selection by likelihood-ratio tests at 99 %, Bonferroni-corrected for picking the best of m "
                 f"sets (m = {len(cand_effects)}: {_lrt_threshold(1, len(cand_effects)):.2f}); otherwise the "
                 f"verdict is 'unexplained' and nothing is added")
    return Discovery(level, named, params_out, features, gap_before, gap_after, chi2_0, fits, criterion, base,
                     updated, behaviours, alts, enma_data if level == "beam" else list(measured or []) if level == "slider"
                     else dict(enma=enma_data, measured=list(measured or [])),
                     time.perf_counter() - t0, verdict=verdict, rejected=rejected,
                     features_off=[dict(feature=k, z=z) for k, z in off], gap_ratio=gap_ratio,
                     gap_excess_before=excess_before, gap_excess_after=excess_after,
                     modes={t: dict(ends_high=md[0], turning_point=md[1], runs=runs_base,
                                    baseline_runs_in_mode=counts_base.get(t), updated_runs_in_mode=counts_after.get(t))
                            for t, md in (modes or {}).items() if md is not None})


# --- synthesiser ----------------------------------------------------------------------------------
