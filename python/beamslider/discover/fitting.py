"""Fitting the candidate effects: weighted least-squares fits of a candidate or a set (beam level)
and the profile fit of the free-slider runs (slider level) with its profile-likelihood intervals
(docs/model.md §9.1, "One effect", "Sets of effects"); the statistics are :mod:`.stats`, the search
:mod:`.search`."""

from __future__ import annotations

import math
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from .. import _core
from ..params import Parameters
from .chain import Model, as_model, realise_model
from .effects import Effect, apply_effects
from .features import Feature
from .models import Ensemble, data_modes
from .result import CandidateFit
from .spread import chi2_roughness, pooled_spread
from .options import DEFAULT, DiscoverOptions
from .stats import chi2_quantile, chi2_terms, interval_z, mode_terms, right_fit_bound


def fit_candidate(effects: Sequence[Effect], baseline: Parameters, meas: Dict[str, Feature],
                   model_fn: Callable[[Parameters], Dict[str, float]], *, diff_step: Optional[float],
                   max_nfev: int, options: DiscoverOptions = DEFAULT) -> CandidateFit:
    """Beam level: the weighted least-squares fit of ``effects`` on the surrogate ``model_fn``
    (docs/model.md §9), from the baseline and from a tenth of the bounds; adequate at
    ``options.significance``."""
    from scipy.optimize import least_squares

    names = [k for k in meas]
    sig = np.array([meas[k].stderr for k in names])
    y = np.array([meas[k].value for k in names])
    penalty = 1e3

    def resid(u: np.ndarray) -> np.ndarray:
        try:
            m = model_fn(apply_effects(baseline, effects, u))
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
    values = {e.name: e.value(u, baseline) for e, u in zip(effects, best.x)}
    stderrs = {e.name: _stderr_of(e, u, su, baseline) for e, u, su in zip(effects, best.x, se_u)}
    dof = n - k
    return CandidateFit(tuple(e.name for e in effects), values, stderrs, chi2, dof,
                        chi2 <= chi2_quantile(dof, options.significance), chi2 + k * math.log(max(n, 2)))


ModelMany = Callable[[List[Any]], List[Optional[Dict[str, float]]]]
"""Model features of several parameter sets or :class:`.chain.Model` at once (None for a failed
model): one batch of runs."""


def _one_at_a_time(model_fn: Callable[[Parameters], Dict[str, float]]) -> ModelMany:
    def many(ps: List[Any]) -> List[Optional[Dict[str, float]]]:
        out: List[Optional[Dict[str, float]]] = []
        for p in ps:
            try:
                out.append(model_fn(as_model(p).params))
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


EnsembleMany = Callable[[List[Any], List[Optional[Dict[str, float]]]], List[Optional[Ensemble]]]
"""Ensembles (:func:`.models.ensemble_slider_features`) of several parameter sets whose unshifted
runs' features are given: one batch of the remaining runs."""


def _interval(xs: np.ndarray, fs: np.ndarray, rough: float = 0.0, delta: float = 1.0) -> Tuple[float, float, float]:
    """Minimum of a scanned profile χ²(x) and its Δχ² = ``delta`` interval (1: one standard
    error; :func:`interval_z` squared: the interval that names, docs/model.md §9.1): the outermost
    scan points with χ² ≤ χ²_min + delta, extended to where the profile crosses it by
    interpolation in sqrt(χ² − χ²_min) (the scan's ends if it does not cross). For a rough profile
    (single-run χ² scattering by ``rough`` about a smooth one, :func:`chi2_roughness`) the threshold is
    χ²_min + delta + 2·rough: the scan points that the scatter cannot tell from the minimum."""
    order = np.argsort(xs)
    xs, fs = xs[order], fs[order]
    ok = np.isfinite(fs)
    if not ok.any():
        return math.nan, -math.inf, math.inf
    j = int(np.nanargmin(np.where(ok, fs, np.inf)))
    delta = float(delta) + 2.0 * max(float(rough), 0.0)
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


def _poor_single(ens: Optional[Ensemble], spread: Dict[str, float], ensemble_chi2: Callable[..., float], n: int,
                 options: DiscoverOptions) -> bool:
    """Whether a single effect's coordinate pass ended where its ensemble fits worse than right models
    usually do (χ² above their (1 − ``options.poor_single_alpha``) quantile, docs/model.md §9.1
    "Goodness of fit"): single runs scatter, and their refinement can settle beside the valley that
    the ensembles' means show."""
    if ens is None or not math.isfinite(options.gof_scale) or options.poor_single_alpha <= 0:
        return False
    sp = dict(spread)
    sp.update(ens.spread)
    return ensemble_chi2(ens, sp) > right_fit_bound(n, 1, options, options.poor_single_alpha)


def profile_fit(effects: Sequence[Effect], baseline: Parameters, meas: Dict[str, Feature],
                model_fn: Optional[Callable[[Parameters], Dict[str, float]]] = None, *,
                grid_n: Optional[int] = None, refine: Optional[int] = None, model_many: Optional[ModelMany] = None,
                ensemble_many: Optional[EnsembleMany] = None, spread0: Optional[Dict[str, float]] = None,
                fixed: Optional[Dict[str, float]] = None, joint: Optional[bool] = None,
                options: DiscoverOptions = DEFAULT) -> CandidateFit:
    """Fit for expensive, rough objectives (slider level). Per effect (one coordinate pass): a grid
    scan of χ² over its search range (``grid_n`` points, None: ``options.grid_points``; one batch of
    runs), then ``refine`` (None: ``options.refine_levels``)
    levels of 7 points spanning ± one step around the best so far (each one batch; the step
    shrinks 3× per level). The model's sensitivity to what the data cannot resolve enters every
    χ² as a spread of the features (σ² = σ_meas² + 2·spread² for one run against one measured
    draw): ``spread0`` (the baseline's) at first, then that of an ensemble of runs
    (``ensemble_many``) at the best coarse point, and at the end that of the ensemble at the
    fitted point, whose mean gives the fit's χ² (σ² = σ_meas² + (1 + 1/R)·spread²); one effect:
    where the ensemble at the best coarse point fits better than that at the end by more than
    :func:`interval_z` squared (single runs switching end states near a mode boundary), that point
    is the fit. Standard
    error: half the Δχ² = 1 interval of the rescored profile scan (:func:`_interval`), widened
    by the scatter of the last refinement level's χ² about a parabola (:func:`chi2_roughness`)
    where the objective is rough; one effect whose fit is the baseline value while its last level
    is rough (``options.rough_rescan``): its grid rescored on ensembles and the best point refined on
    their means (:func:`.refine.gauss_newton`), taken with the ensembles' profile interval where its
    ensemble fits better by more than z² and its change is relevant. Several effects, or one whose
    coordinate pass ends where its ensemble does not fit as right models do (:func:`_poor_single`;
    its grid rescored on ensembles first, and the best point taken): the coordinate pass's point
    refined jointly on ensemble means (:func:`.refine.gauss_newton`, ``options.joint_refinement``),
    standard errors from its covariance.
    Intervals at ``options.interval_level`` (:func:`.stats.interval_of`), holding the fitted value.
    ``joint``: refine a set jointly (None: ``options.joint_refinement``).
    ``fixed``: values of further effects held (the joint fit's beam-level part)."""
    many = model_many if model_many is not None else _one_at_a_time(model_fn)  # type: ignore[arg-type]
    names = list(meas)
    se = np.array([meas[k].stderr for k in names])
    y = np.array([meas[k].value for k in names])
    cache: Dict[Tuple[float, ...], Optional[Dict[str, float]]] = {}
    fixed = dict(fixed or {})
    spread = dict(spread0 or {})
    modes = data_modes(meas, options.high_final_h) if options.mode_conditioning else None
    joint_on = options.joint_refinement if joint is None else bool(joint)
    grid_n = options.grid_points if grid_n is None else grid_n
    refine = options.refine_levels if refine is None else refine

    def sig_single() -> np.ndarray:
        return np.sqrt(se ** 2 + 2 * np.array([spread.get(k, 0.0) for k in names]) ** 2)

    def chi2_from(m: Optional[Dict[str, float]], sig: np.ndarray, counts: Optional[Dict[str, int]] = None,
                  runs: int = 1) -> float:
        return chi2_terms(m, names, y, sig, modes, counts, runs)

    def key_of(u: np.ndarray) -> Tuple[float, ...]:
        return tuple(round(float(v), 12) for v in u)

    def params_of(u: np.ndarray) -> Model:
        vals = dict(fixed)
        vals.update({e.name: e.value(float(x), baseline) for e, x in zip(effects, u)})
        return realise_model(baseline, vals)

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

    def ensemble_chi2(ens: Ensemble, sp: Dict[str, float]) -> float:
        # The ensemble mean against the data, σ² = σ_meas² + (1 + 1/R)·spread².
        sig_e = np.sqrt(se ** 2 + (1 + 1 / ens.runs) * np.array([sp.get(kk, 0.0) for kk in names]) ** 2)
        return chi2_from(ens.mean, sig_e, ens.mode_counts, ens.runs)

    def ensemble_objective(sp: Dict[str, float], runs: int):
        # Ensemble means as the joint refinement's objective, uncertainties fixed by ``sp``.
        from .refine import EnsembleObjective

        return EnsembleObjective(evaluate, lambda p: cache[key_of(p)], params_of, ensemble_many, key_of, names, y, se,
                                 sp, runs, lambda m, c, r, sg: chi2_from(m, sg, c, r),
                                 lambda m, c, r: mode_terms(m, modes, c, r)[0])

    def ensemble_at(u: np.ndarray) -> Optional[Ensemble]:
        if ensemble_many is None or cache.get(key_of(u)) is None:
            return None
        return ensemble_many([params_of(u)], [cache[key_of(u)]])[0]

    u = np.array([np.clip(e.variable(e.baseline_value(baseline), baseline), e.lower, e.upper) for e in effects])
    u_base = u.copy()
    grids: List[List[float]] = []
    first: Optional[Tuple[np.ndarray, Ensemble]] = None  # the ensemble at the first scan's best point
    samples: List[List[np.ndarray]] = [[] for _ in effects]
    last: List[List[np.ndarray]] = [[] for _ in effects]
    for i, e in enumerate(effects):
        lo, hi = e.search if math.isfinite(e.search[0]) else (e.lower, e.upper)
        at = lambda x: np.where(np.arange(len(u)) == i, x, u)  # noqa: E731
        grid = list(np.linspace(lo, hi, grid_n))
        grids.append(grid)
        evaluate([at(g) for g in grid])
        xs = list(grid)
        step = (hi - lo) / max(grid_n - 1, 1)
        x_best = min(xs, key=lambda x: chi2(at(x)))
        if i == 0:
            ens = ensemble_at(at(x_best))
            if ens is not None:
                first = (at(x_best), ens)
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
    # The single runs' roughness about the fit before the spread pools it (options.rough_rescan).
    rough_pass = (chi2_roughness(np.array([p[0] for p in last[0]]), np.array([chi2(p) for p in last[0]]))
                  if len(effects) == 1 else 0.0)
    refined = None
    u0, spread0_pass = u.copy(), dict(spread)
    # A scan that picked the baseline is the rough rescan's (below); one that moved is refined where
    # poor, in a fit in full (a coarse screening scan is only ranked).
    poor = (len(effects) == 1 and joint_on and refine >= options.refine_levels and key_of(u) != key_of(u_base)
            and _poor_single(ensemble_at(u), spread, ensemble_chi2, len(names), options))
    if (len(effects) >= 2 or poor) and joint_on:
        from .refine import refine_jointly, single_run_residuals

        evaluate([u])
        ens = ensemble_at(u)
        if ens is not None:
            spread.update(ens.spread)
        if ensemble_many is not None:
            # Ensemble means: single runs are too rough to linearise (docs/model.md §9.1).
            obj = ensemble_objective(spread, ens.runs if ens is not None else 5)
            start = u
            if poor:  # the scan's grid rescored on ensemble means: its single runs may have passed the valley by
                pts = [u] + [np.array([g]) for g in grids[0]]
                obj.evaluate(pts)
                start = min(pts, key=obj.chi2)
            refined = refine_jointly(effects, start, obj.evaluate, obj.residuals, obj.chi2, options)
        else:
            resid = single_run_residuals(lambda p: cache[key_of(p)], names, y, sig_single,
                                         lambda m: mode_terms(m, modes, None, 1)[0])
            refined = refine_jointly(effects, u, evaluate, resid, chi2, options)
        u = refined.u
        if poor and np.array_equal(u, u0):  # the ensembles found no better point: the single's fit stands
            refined = None
            spread.clear()
            spread.update(spread0_pass)
    ens = ensemble_at(u)
    n, k = len(names), len(effects) + len(fixed)
    predicted: Dict[str, float] = {}
    if ens is not None:
        # A calibration of the measurement chain's features moves no run: its last level is one run
        # seen through seven calibrations, whose scatter about the trend is nil and says nothing of the
        # model's spread (docs/model.md §9.1, "One effect").
        levels = [[cache[key_of(p)] for p in pts] for e, pts in zip(effects, last) if e.chain != "features"]
        spread.update(pooled_spread(ens, levels, names, modes, options.mode_min_dof))
        predicted = dict(ens.mean)
        best_chi2 = ensemble_chi2(ens, spread)
        if first is not None and refined is None and len(effects) == 1 and key_of(first[0]) != key_of(u):
            # The fit's χ² is that of an ensemble; where the single runs' search left a point whose
            # ensemble fits better by more than the intervals' z² (a rough, mode-switching
            # objective), that point is the fit; within z² the two are alike and the refined one stands.
            sp_first = dict(spread0 or {})
            sp_first.update(pooled_spread(first[1], [], names, modes, options.mode_min_dof))
            c_first = ensemble_chi2(first[1], sp_first)
            if c_first < best_chi2 - interval_z(options.interval_level) ** 2:
                u, ens, best_chi2 = first[0], first[1], c_first
                spread.clear()
                spread.update(sp_first)
                predicted = dict(ens.mean)
    else:
        best_chi2 = chi2(u)
        predicted = dict(cache[key_of(u)] or {})
    rescanned: Optional[Tuple[np.ndarray, np.ndarray]] = None  # the ensembles' profile, where rescanned
    if (ens is not None and refined is None and len(effects) == 1 and key_of(u) == key_of(u_base)
            and rough_pass > options.rough_rescan):
        # Rough single runs found nothing but the baseline: the grid rescored on ensembles (each with
        # its own spread, as the first pick's), the best refined on their means; taken where its
        # ensemble fits better by more than z², as the first pick is, and its change is relevant.
        from .refine import refine_jointly

        sp_obj = dict(spread0 or {})
        sp_obj.update(pooled_spread(ens, [], names, modes, options.mode_min_dof))
        obj = ensemble_objective(sp_obj, ens.runs)
        pts = [u] + [np.array([g]) for g in grids[0]]
        obj.evaluate(pts)
        refine_jointly(effects, min(pts, key=obj.chi2), obj.evaluate, obj.residuals, obj.chi2, options)
        # Every ensemble made, scored as a fit is: its mean against the data with its own spread.
        own: Dict[Tuple[float, ...], Tuple[float, Dict[str, float], Ensemble]] = {}
        for k_, e_ in obj.cache.items():
            if e_ is not None:
                sp_k = dict(spread0 or {})
                sp_k.update(pooled_spread(e_, [], names, modes, options.mode_min_dof))
                own[k_] = (ensemble_chi2(e_, sp_k), sp_k, e_)
        k_best = min(own, key=lambda k_: own[k_][0], default=None)
        if (k_best is not None and key_of(u) in own
                and own[k_best][0] < own[key_of(u)][0] - interval_z(options.interval_level) ** 2
                and effects[0].relevant(effects[0].value(k_best[0], baseline), baseline)[0]):
            best_chi2, sp_r, ens = own[k_best]
            u, predicted = np.array(k_best), dict(ens.mean)
            spread.clear()
            spread.update(sp_r)
            rescanned = (np.array([k_[0] for k_ in own]), np.array([c_ for c_, _, _ in own.values()]))
    values, stderrs, intervals = dict(fixed), {}, {}
    roughness: Dict[str, float] = {}
    z = interval_z(options.interval_level)
    for i, e in enumerate(effects):
        xs = np.array([p[i] for p in samples[i]])
        fs = np.array([chi2(p) for p in samples[i]])
        # Rescanned: the interval is the ensembles' profile's, not widened by the single runs.
        smooth = rescanned is not None or (poor and refined is not None)
        rough = 0.0 if smooth else chi2_roughness(np.array([p[i] for p in last[i]]), np.array([chi2(p) for p in last[i]]))
        roughness[e.name] = rough
        values[e.name] = e.value(u[i], baseline)
        if refined is not None:
            # Several effects: the Wald interval of the joint fit (marginal over the others). Not
            # widened by the single runs' roughness where it ran on ensemble means: their
            # uncertainties hold the runs' spread, which that roughness measures.
            var = float(refined.cov[i, i]) if refined.cov is not None else math.inf
            widen = 1.0 if ensemble_many is not None else 1 + 2 * rough
            su = math.sqrt(var * widen) if math.isfinite(var) and var >= 0 else math.inf
            lo_u, hi_u = u[i] - z * su, u[i] + z * su
        else:
            if rescanned is not None:  # one effect rescanned: the profile of its ensembles
                xs, fs = rescanned
            _, lo1, hi1 = _interval(xs, fs, rough)
            su = (hi1 - lo1) / 2 if math.isfinite(lo1) and math.isfinite(hi1) else math.inf
            _, lo_u, hi_u = _interval(xs, fs, rough, delta=z * z)
            # The interval holds the fitted value (the profile rescored with the fitted point's
            # spread may have its minimum elsewhere).
            lo_u, hi_u = min(lo_u, u[i]), max(hi_u, u[i])
        stderrs[e.name] = _stderr_of(e, u[i], su, baseline)
        ok = math.isfinite(su) and math.isfinite(lo_u) and math.isfinite(hi_u)
        ends = sorted((e.value(lo_u, baseline), e.value(hi_u, baseline))) if ok else [-math.inf, math.inf]
        intervals[e.name] = (ends[0], ends[1])
    names_all = tuple(list(fixed) + [e.name for e in effects])
    return CandidateFit(names_all, values, stderrs, best_chi2, n - k, best_chi2 <= chi2_quantile(n - k, options.significance),
                        best_chi2 + k * math.log(max(n, 2)), predicted,
                        {kk: spread.get(kk, 0.0) for kk in names}, intervals, roughness)
