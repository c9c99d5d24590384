"""Naming the missing effect: fits of every candidate and pair, the χ² criterion and forward
selection by likelihood-ratio tests (see the package docstring); the fits are :mod:`.fitting`."""

from __future__ import annotations

import math
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

from .. import _core
from ..enma import EnmaData
from ..measurement import Measurement
from ..params import Parameters, resolve
from .chain import Model, realise_model
from .effects import EFFECTS, Effect, realise_effects
from .features import Feature, enma_features
from .fitting import (MODE_CONDITIONING, CandidateFit, Discovery, EnsembleMany, ModelMany, baseline_test,
                      chi2_quantile, excess, z_bound,
                      fit_candidate, gap_of, lrt_threshold, missing_z, profile_fit, select, sigma)
from .models import (ENSEMBLE_S0_SHIFTS, RUN_PROGRESS, Ensemble, Modes, RunCache, batch_slider_features, beam_surrogate,
                     data_modes, ensemble_slider_features, levels_for, measured_slider_features,
                     simulated_enma_features, slider_paths, unreached_mode_features)
from .fast import TIER_SHARED, best_single, no_pair_gains, predict_singles, predicted_singles, tiered_singles
from .joint import fit_sets_joint
from .refine import sets_to_refine, step_chi2
from .report import fmt_value
from .runstore import RunStore
from .separability import slider_changes, slider_sensitivities
from .verdicts import (ADVICE_GRID, CONFIRM_SINGLES, GUIDED_PAIRS, Reason, Reasons, Why, advise,
                       beaten_by_negligible, confounded_group, confounded_sets, pairs_to_fit, interval_of, kinds,
                       negligible_fits, outside_fits_better, rank_pairs, unnamed_verdict, unresolved_reasons)


def _progress_bar(enabled: Optional[bool], total: int, desc: str):
    """tqdm bar of fits done / to do (a no-op object when disabled; ``None``: the bar on a
    terminal, else a line now and then, :class:`beamslider._util.LogProgress`)."""
    from tqdm.auto import tqdm

    from .._util import LogProgress, stderr_is_terminal

    if enabled is None:
        if not stderr_is_terminal():
            return LogProgress(total, desc, "fit")
        enabled = True

    return tqdm(total=total, desc=desc, unit="fit", disable=not enabled, leave=False)


class _FitProgress:
    """What the fits' progress shows beside the count of fits (on a terminal the bar's postfix, in
    a log a line at most every ``LOG_INTERVAL_S``, :class:`beamslider._util.LogProgress`): the runs
    made so far (the core's per-run callback, :data:`.models.RUN_PROGRESS`), so that a long fit
    still shows progress, and the lowest χ² fitted so far with its values (not a verdict: the
    naming rule and the other candidates come after)."""

    def __init__(self, bar: Any) -> None:
        self.bar, self.runs, self.best = bar, 0, None

    def __call__(self, n: int) -> None:
        self.runs += n
        self._show()

    def saw(self, f: CandidateFit) -> None:
        if math.isfinite(f.chi2) and (self.best is None or f.chi2 < self.best.chi2):
            self.best = f
            self._show()

    def _show(self) -> None:
        text = f"{self.runs} runs made"
        if self.best is not None:
            vals = ", ".join(f"{e} {fmt_value(self.best.values[e])}" for e in self.best.effects)
            text += f", lowest chi2 so far {self.best.chi2:.3g} ({vals})"
        self.bar.set_postfix_str(text, refresh=True)


def _fit_sets(cand_effects: Sequence[Effect], max_effects: int, level: str, base: Parameters,
              meas: Dict[str, Feature], model_fn: Callable[[Parameters], Dict[str, float]],
              diff_step: Optional[float], max_nfev: int, *, model_many: Optional[ModelMany] = None,
              ensemble_many: Optional[EnsembleMany] = None, spread0: Optional[Dict[str, float]] = None,
              progress: bool = False,
              guide: Optional[Callable[[], List[Tuple[Tuple[str, str], float]]]] = None,
              done: Optional[Callable[[List[CandidateFit]], bool]] = None,
              predict: Optional[Callable[[], Dict[str, Tuple[float, float]]]] = None,
              step: Optional[Callable[[CandidateFit], float]] = None,
              record: Optional[List[Dict[str, Any]]] = None, tier: bool = False,
              named: Optional[Callable[[List[CandidateFit]], Optional[CandidateFit]]] = None,
              known: Optional[Callable[[str], bool]] = None) -> List[CandidateFit]:
    """Fit every single candidate and the sets of up to ``max_effects`` (:func:`.verdicts.pairs_to_fit`,
    with the pairs ranked by ``guide``, slider level: :func:`.verdicts.rank_pairs`); no sets if
    ``done(singles)`` (no set can be selected over them, :func:`_no_set_can_win`). ``predict``: the
    fast path (:mod:`.fast`): singles screened by the linearised model, and the pair it predicts best
    only if predicted to beat the best single fitted by the selection's threshold. ``step``: a set's
    χ² predicted after a Gauss–Newton step from its coordinate pass (:func:`.refine.step_chi2`),
    which chooses the sets refined jointly (:func:`.refine.sets_to_refine`); ``record``: one entry
    per set so staged (pass and predicted χ², refined or not). ``tier`` (with ``predict``): the
    screening tier first (:func:`.fast.tiered_singles`), the full search only where it does not
    settle: settled if no set can win (``done``) or, for the single ``named(singles)`` would name,
    no pair containing it is predicted to gain the selection's least threshold (:func:`.fast.no_pair_gains`;
    ``known(name)``: whether ``step`` has the effect's column). ``tier`` without ``predict`` (slider
    level, few candidates, each fitted in full): no sets where that gate holds."""
    def fit(combo: Sequence[Effect], refine: int = 2, joint: Optional[bool] = None) -> CandidateFit:
        if level == "beam":
            f = fit_candidate(combo, base, meas, model_fn, diff_step=diff_step, max_nfev=max_nfev)
        else:
            f = profile_fit(combo, base, meas, model_fn, model_many=model_many, ensemble_many=ensemble_many,
                            spread0=spread0, refine=refine, joint=joint)
        shown.saw(f)
        return f

    def pairs_gated(singles: List[CandidateFit]) -> bool:
        # The tier's gate for the pairs: none with the single the selection would name is
        # predicted to gain the least threshold (:func:`.fast.no_pair_gains`).
        return (step is not None and named is not None
                and no_pair_gains(singles, named(singles), step, base, known or (lambda e: True)))

    bar = _progress_bar(progress, len(cand_effects), f"discover ({level}): fits")
    shown = _FitProgress(bar)
    token = RUN_PROGRESS.set(shown)
    try:
        fits: List[CandidateFit] = []
        settled = False  # by the tier: no sets fitted
        tier_full: Dict[str, CandidateFit] = {}  # the tier's fits in full, kept by the full search
        if predict is not None and tier:
            # The screening tier: settled if its fits leave no set to fit (a named single below the
            # threshold) and no candidate it left unfitted is predicted near; else the full search, whose
            # runs the tier's full fits share (cached).
            pred = predict()
            fits, complete = tiered_singles(cand_effects, pred, lambda e: fit((e,)), len(meas))
            if complete and (max_effects < 2 or (done is not None and done(fits)) or pairs_gated(fits)):
                settled = True
                bar.update(len(cand_effects))
            else:
                # The full search keeps the tier's first TIER_SHARED fits by prediction; a later one, made
                # to settle the answer, enters as its coarse scan does (from the fit's cached runs), so the
                # full search's verdict is that of a tier of TIER_SHARED fits.
                first = sorted((f for f in fits if not f.screened), key=lambda f: pred[f.effects[0]][0])[:TIER_SHARED]
                tier_full = {f.effects[0]: f for f in first}
                fits, predict = [], None
        elif predict is not None:
            fits = predicted_singles(cand_effects, predict(), lambda e: fit((e,)), len(meas))
            bar.update(len(cand_effects))
        if not fits and level == "slider" and len(cand_effects) > SCREEN_FROM:
            # Coarse scans of every candidate first (grid and one ensemble, SCREEN_REFINE levels: runs
            # the full fits reuse), full fits only of those whose coarse χ² is within SCREEN_MARGIN of the best
            # and of those the tier fitted in full (a coarse scan's single runs may miss what that fit found).
            coarse = []
            for e in cand_effects:
                coarse.append(fit((e,), refine=SCREEN_REFINE))
                bar.update(0.5)
            best = sorted(c.chi2 for c in coarse)
            cut = max(best[0] + SCREEN_MARGIN, best[min(SCREEN_KEEP, len(best)) - 1])
            for e, c in zip(cand_effects, coarse):
                if e.name in tier_full:
                    fits.append(tier_full[e.name])
                elif c.chi2 <= cut:
                    fits.append(fit((e,)))
                else:
                    c.screened = True
                    fits.append(c)
                bar.update(0.5)
        elif not fits:
            for e in cand_effects:
                fits.append(fit((e,)))
                bar.update(1)
            if tier and max_effects >= 2 and level == "slider" and pairs_gated(fits):
                # Few candidates, every single fitted in full: the tier's gate for the pairs, as where the
                # tier settles (no pair with the single the selection names is predicted to gain).
                settled = True
        if max_effects >= 2 and not settled and not (done is not None and done(fits)):
            ranked = guide() if guide is not None else None
            combos = pairs_to_fit(cand_effects, fits, max_effects, level, ranked)
            if predict is not None and ranked:  # the best predicted pair, if predicted to beat the best single
                win = ranked[0][1] < min(f.chi2 for f in fits if not f.screened) - lrt_threshold(1, len(cand_effects))
                combos = [c for c in combos if win and frozenset(e.name for e in c) == frozenset(ranked[0][0])]
            bar.total = len(cand_effects) + len(combos)
            bar.refresh()
            staged = level == "slider" and len(combos) > JOINT_SETS
            sets = []
            for combo in combos:
                # Many sets: the coordinate pass of each first, the joint refinement of the best below.
                sets.append(fit(combo, joint=False if staged else None))
                bar.update(1)
            if staged:
                names = [frozenset(e.name for e in c) for c in combos]
                top = [frozenset(p) for p, _ in (ranked or [])[:1]]
                passes = [s.chi2 for s in sets]
                steps = [step(s) for s in sets] if step is not None else None
                order = sets_to_refine(passes, steps, next((i for i in range(len(sets)) if names[i] in top), None),
                                       JOINT_SETS, lrt_threshold(1, len(cand_effects)))
                bar.total += len(order)
                for i in order:
                    sets[i] = fit(combos[i])  # the coordinate pass's runs are cached
                    bar.update(1)
                if record is not None:
                    record.extend(dict(effects=sorted(names[i]), pass_chi2=passes[i], step_chi2=None if steps is None
                                       else steps[i], refined=i in order, chi2=sets[i].chi2) for i in range(len(sets)))
            fits += sets
    finally:
        RUN_PROGRESS.reset(token)
        bar.close()
    return fits


def _no_set_can_win(singles: List[CandidateFit], judge: Callable[[List[CandidateFit]], Reasons]) -> bool:
    """Whether fitting sets is pointless: a single candidate passes the naming rule with a χ²
    below the least likelihood-ratio threshold for adding an effect (:func:`.fitting.lrt_threshold`
    with m = 1, 6.63): the selection would name it, and no set (χ² ≥ 0) can beat it by the threshold."""
    reasons = judge(singles)
    ok = [f for f in singles if not reasons[f.effects]]
    return bool(ok) and min(f.chi2 for f in ok) <= lrt_threshold(1, 1)


SCREEN_FROM = 3
"""Slider level, more candidates than this: each is first scanned coarsely (:func:`_fit_sets`)."""

SCREEN_REFINE = 1
"""Refinement levels of the coarse scan (:func:`.fitting.profile_fit`): the grid, one level of 7 points
spanning ± one grid step about the grid's best point, and the ensembles at the two picks. The level
sees a valley narrower than the grid step beside that point, which the grid alone drops (friction 0.185
hidden: χ² 198 at the grid point 0.2, 1.8 at 0.1833; μ = 0.17 hidden: 381 at 0.2, 5.9 fitted in full at
0.1722; docs/model.md §9.1, "Cost")."""

SCREEN_MARGIN = 20.0
"""A coarsely scanned single candidate is fitted in full if its χ² is within this of the best
coarse χ²: the refinement lowered a grid's minimum by at most (grid step / 2σ)², about 13, for the
sharpest candidate of the table's runs (slider inertia). Not a bound: a valley narrower than the
screen's refinement step beside no grid point is still dropped (docs/model.md §9.1, "Cost")."""

SCREEN_KEEP = 3
"""At least this many single candidates (the best coarse ones) are fitted in full."""

JOINT_SETS = 3
"""Slider level, with more sets to fit than this: all get the coordinate pass, and at least this
many the joint refinement (:func:`.fitting.profile_fit`): the best by the pass's χ² and the pair the
linearised model predicts best, and beside them every set predicted by a Gauss–Newton step from its
pass point to come within the selection's threshold of the least so predicted
(:func:`.refine.sets_to_refine`; the refinement costs ensembles of runs at every point)."""


def _judge(fits: Sequence[CandidateFit], base: Parameters, n: int, excess_before: float,
           gap_ratio: float, threshold: Optional[float] = None) -> Reasons:
    """The naming rule per fitted set: the reasons it may not be named (empty: it may). Not
    adequate (χ² > χ²₀.₉₉(n − k)); a parameter moved by less than its relevance threshold; a
    small share of the gap beyond the noise (:func:`excess`: sqrt(max(χ² − (n − k), 0)/n) >
    gap_ratio × the baseline's sqrt(max(χ²₀ − n, 0)/n)); a parameter whose interval contains its
    baseline value (not resolved, :func:`.verdicts.unresolved_reasons`); with ``threshold`` (the
    selection's price of a parameter), a negligible change that fits as well
    (:func:`.verdicts.beaten_by_negligible`)."""
    out: Reasons = {}
    for f in fits:
        reasons: List[Reason] = []
        if f.screened:
            reasons.append(Reason(Why.SCREENED, f"screened out: its coarse scan's chi2 = {f.chi2:.3g} is more than "
                                                f"{SCREEN_MARGIN:g} above the best coarse chi2 (not fitted in full)"
                                  if not f.linearised else f"screened out: the linearised model predicts chi2 = "
                                                           f"{f.chi2:.3g}, not among those fitted in full"))
        elif not f.adequate:
            reasons.append(Reason(Why.NOT_ADEQUATE, f"not adequate: chi2 = {f.chi2:.3g} > chi2_0.99({f.dof}) = "
                                                    f"{chi2_quantile(f.dof):.3g}"))
        for e in f.effects:
            ok, how = EFFECTS[e].relevant(f.values[e], base)
            if not ok:
                reasons.append(Reason(Why.NEGLIGIBLE, f"negligible change of {EFFECTS[e].field}: {how}", e))
        g = excess(f.chi2, f.dof, n)
        if g > gap_ratio * excess_before:
            reasons.append(Reason(Why.SMALL_SHARE, f"small share of the gap beyond the noise: {excess_before:.3g} -> "
                                                   f"{g:.3g} (more than {gap_ratio:g} x)"))
        reasons += unresolved_reasons(f, base)
        out[f.effects] = reasons
    return out if threshold is None else beaten_by_negligible(fits, out, threshold)


def discover(*, enma_data: Optional[EnmaData] = None, measured: Optional[Sequence[Measurement]] = None,
             baseline: Optional[Parameters] = None, effects: Optional[Sequence[str]] = None,
             max_effects: int = 2, progress: bool = False, gap_ratio: float = 0.3,
             threads: Optional[int] = None, advice_grid: Optional[Sequence[Tuple[float, float, float]]] = None,
             fast: bool = False, search: str = "tiered", runs_file: Optional[Any] = None) -> Discovery:
    """Find the effects the ``baseline`` model misses, from beam-level ENMA data (``enma_data``),
    slider-level free-slider runs (``measured``, files of the published format) or both (one joint
    fit over both feature sets: beam-level effects from both, slider-level ones from the runs),
    name them, add them and measure the gap before and after (module docs: criterion).
    ``gap_ratio``: a named set must leave at most this share of the gap beyond the noise,
    sqrt(max(χ² − E[χ²], 0)/n) (0.3); otherwise the verdict is "unexplained". Slider level: each
    model is an ensemble of runs from s0 + :data:`.models.ENSEMBLE_S0_SHIFTS` whose spread joins
    the feature uncertainties. ``progress``: a bar of fits done / to do. ``threads``: workers of
    the core's runner for the free-slider runs (None: one per core). ``advice_grid``: operating
    points (f_ex, a_ex, s0) among which the separability tool looks for the run that would resolve
    an unresolved best candidate or separate a confounded group (None:
    :data:`.verdicts.ADVICE_GRID`; empty: no advice runs). ``search`` (slider level, more than
    :data:`SCREEN_FROM` candidates; docs/model.md §9.1, "Cost"): ``"tiered"``, the linearised
    model's screening with full fits of the best predicted first (:func:`.fast.tiered_singles`), the
    full search only where that does not settle the answer; ``"full"``, coarse scans of every
    candidate; ``"fast"`` (also ``fast=True``), the screening alone and one pair (:mod:`.fast`).
    ``runs_file``: a JSON-lines file of the free-slider runs, or a :class:`.runstore.RunStore` of
    one: the runs it holds from the same code are reused, and every run made is appended (None:
    none kept)."""
    import time

    t0 = time.perf_counter()
    base = resolve(baseline)
    if search not in ("tiered", "full", "fast"):
        raise ValueError(f"invalid search = {search!r}: give 'tiered', 'full' or 'fast'")
    if fast:
        search = "fast"
    if not (isinstance(gap_ratio, (int, float)) and 0 < gap_ratio <= 1):
        raise ValueError(f"invalid gap_ratio = {gap_ratio!r}: must be in (0, 1]")
    if threads is not None and not (isinstance(threads, int) and threads >= 1):
        raise ValueError(f"invalid threads = {threads!r}: must be an integer >= 1")
    if advice_grid is not None:
        try:
            advice_grid = [tuple(float(v) for v in g) for g in advice_grid]
        except (TypeError, ValueError):
            raise ValueError(f"invalid advice_grid = {advice_grid!r}: give (f_ex, a_ex, s0) triples") from None
        if not all(len(g) == 3 and all(math.isfinite(v) for v in g) for g in advice_grid):
            raise ValueError(f"invalid advice_grid = {advice_grid!r}: give (f_ex, a_ex, s0) triples of finite numbers")
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
    run_cache: RunCache = {}
    if runs_file is not None and measured is not None:
        run_cache = runs_file if isinstance(runs_file, RunStore) else RunStore(runs_file)
    if enma_data is not None:
        meas_b = enma_features(enma_data)
        enma_levels = levels_for(enma_data, base)
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
        ens_base = ensemble_slider_features([base], ops, threads=threads, modes=modes, cache=run_cache)[0]
        if ens_base is None:
            raise _core.SimulationError("the baseline model's runs at the measured operating points failed")
        spread_base = {k: ens_base.spread.get(k, 0.0) for k in meas_s}
        behaviours = {"measured": beh_meas, "baseline": ens_base.behaviours}

        def model_many_fn(ps: List[Any]) -> List[Optional[Dict[str, float]]]:
            return [None if r is None else {k: f.value for k, f in r[0].items()}
                    for r in batch_slider_features(ps, ops, threads=threads, cache=run_cache)]

        def ensemble_many_fn(ps: List[Any], central: List[Optional[Dict[str, float]]]) -> List[Optional[Ensemble]]:
            cen = [None if c is None else ({k: Feature(k, v, 0.0) for k, v in c.items()}, {}) for c in central]
            return ensemble_slider_features(ps, ops, threads=threads, central=cen, modes=modes, cache=run_cache)

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
    test = baseline_test(before, meas, spread_base, runs_base, modes, counts_base)
    before, gap_before, chi2_0, n, z_worst, base_ok = test.before, test.gap, test.chi2, test.n, test.z_worst, test.fits
    excess_before = excess(chi2_0, n, n)
    thr_m = lrt_threshold(1, len(cand_effects))  # the selection's price of one parameter
    fits: List[CandidateFit] = []
    guided: List[Dict[str, Any]] = []
    refined_sets: List[Dict[str, Any]] = []

    def refit_beam_bias(fits_b: List[CandidateFit]) -> None:
        """Re-centre the surrogate's bias correction at the model the likelihood-ratio selection
        picks (the surrogate's own errors would otherwise count against adequacy)."""
        best_b, _ = select(fits_b, gap_of({k: before[k] for k in meas_b}, meas_b)[1], len(meas_b))
        if best_b is not None:
            chosen = realise_effects(base, {e: best_b.values[e] for e in best_b.effects})
            sim_c, _ = simulated_enma_features(chosen, enma_levels)
            sur_c = beam_surrogate(chosen)
            bias.clear()
            bias.update({k: sim_c[k].value - sur_c[k] for k in sim_c if k in sur_c})

    if not base_ok:
        if level == "beam":
            fits = _fit_sets(cand_effects, max_effects, level, base, meas, model_fn, diff_step, max_nfev,
                             progress=progress)
            best0, _ = select(fits, chi2_0, n, base_ok)
            if best0 is not None:
                refit_beam_bias(fits)
                fits = [fit_candidate([EFFECTS[e] for e in f.effects], base, meas, model_fn, diff_step=diff_step,
                                       max_nfev=max_nfev) for f in fits]
        elif level == "slider":
            def sig_of() -> Dict[str, float]:
                return {k: sigma(meas[k], spread_base.get(k, 0.0), runs_base) for k in meas}

            def resid_of() -> Dict[str, float]:
                return {k: (meas[k].value - before[k]) / s for k, s in sig_of().items() if k in before}

            def guide() -> List[Tuple[Tuple[str, str], float]]:
                # Every pair with the χ² the linearised model predicts (each may fit badly alone).
                sens = slider_sensitivities([e.name for e in cand_effects], base, ops, threads=threads, cache=run_cache)
                ranked = rank_pairs(sens, resid_of(), unreached_mode_features(meas, counts_base))
                guided.extend(dict(pair=list(p), predicted_chi2=c) for p, c in ranked[:GUIDED_PAIRS])
                return ranked

            changes: Dict[str, Dict[str, float]] = {}

            def step(f: CandidateFit) -> float:
                # The linearised model's columns: the runs the pair ranking made (cached).
                if not changes:
                    changes.update(slider_changes([e.name for e in cand_effects], base, ops, threads=threads,
                                                  cache=run_cache))
                # In the fit's own uncertainties (its spread), as its χ².
                sig_f = {k: sigma(meas[k], f.model_spread.get(k, spread_base.get(k, 0.0)), runs_base) for k in meas}
                return step_chi2(f, changes, meas, sig_f, base, modes, counts_base)

            fits = _fit_sets(cand_effects, max_effects, level, base, meas, model_fn, diff_step, max_nfev,
                             model_many=model_many, ensemble_many=ensemble_many, spread0=spread_base,
                             progress=progress, guide=guide if len(cand_effects) > 3 else None,
                             step=step, record=refined_sets,
                             predict=(lambda: predict_singles(
                                 cand_effects, base, resid_of(), sig_of(), lambda names, st: slider_changes(
                                     names, base, ops, steps=st, threads=threads, cache=run_cache), counts_base))
                             if search != "full" and len(cand_effects) > SCREEN_FROM else None,
                             tier=search == "tiered",
                             done=lambda singles: _no_set_can_win(
                                 singles, lambda fs: _judge(fs, base, n, excess_before, gap_ratio, thr_m)),
                             known=lambda name: bool(changes.get(name)),
                             named=lambda singles: best_single(
                                 singles, _judge(singles, base, n, excess_before, gap_ratio, thr_m), chi2_0, n))
        else:
            assert model_many is not None
            # Beam stage first (cheap): its selection re-centres the surrogate's bias.
            beam_cands = [e for e in cand_effects if e.level == "beam"]
            chi2_b0 = gap_of({k: before[k] for k in meas_b}, meas_b)[1]
            if beam_cands and chi2_b0 > chi2_quantile(len(meas_b)):
                fits_b = _fit_sets(beam_cands, max_effects, "beam", base, meas_b, model_b, None, 200)
                refit_beam_bias(fits_b)
            chi2_s0 = gap_of({k: before[k] for k in meas_s}, meas_s, spread_base, runs_base, modes, counts_base)[1]
            fits = fit_sets_joint(cand_effects, max_effects, base, meas_b, model_b, meas_s, model_many,
                                   chi2_b0, chi2_s0, ensemble_many=ensemble_many, spread0=spread_base,
                                   progress=progress)
    verdicts = _judge(fits, base, n, excess_before, gap_ratio, thr_m)
    best, alts = select([f for f in fits if not verdicts[f.effects]], chi2_0, n, base_ok)

    def after_of(p: Model) -> Tuple[Dict[str, float], Dict[str, str], Dict[str, float], Dict[str, int]]:
        # "After": full simulation of the updated model (not the surrogate): virtual ENMA and the
        # ensemble of runs (mean, behaviours of the unshifted run, spread, runs in the data's modes).
        out: Dict[str, float] = {}
        beh: Dict[str, str] = {}
        sp: Dict[str, float] = {}
        counts: Dict[str, int] = {}
        if enma_data is not None:
            out.update({k: f.value for k, f in simulated_enma_features(p.params, enma_levels)[0].items()})
        if measured is not None:
            e = ensemble_slider_features([p], ops, threads=threads, modes=modes, cache=run_cache)[0]
            if e is not None:
                out.update(e.mean)
                beh, sp, counts = e.behaviours, e.spread, e.mode_counts
        return out, beh, sp, counts

    def filled(f: Dict[str, float], sp: Dict[str, float], counts: Dict[str, int]) -> Dict[str, float]:
        f = dict(f)
        for k in meas:
            if k not in f:
                f[k] = meas[k].value + missing_z(k, counts) * sigma(meas[k], sp.get(k, 0.0), runs_base)
        return f

    after_f: Dict[str, float] = dict(before)
    spread_after: Dict[str, float] = dict(spread_base)
    counts_after: Dict[str, int] = dict(counts_base)
    beh_upd = behaviours.get("baseline", {})
    updated = base
    confounded: Dict[str, Any] = {}

    def confirm(name: str) -> Tuple[CandidateFit, List[Reason]]:
        # One effect fitted in full and judged alone by the naming rule.
        f = profile_fit((EFFECTS[name],), base, meas, model_fn, model_many=model_many,
                        ensemble_many=ensemble_many, spread0=spread_base)
        return f, _judge([f], base, n, excess_before, gap_ratio)[f.effects]

    # The features' uncertainties about the baseline (its spread), for the checks of a named set.
    sig_base = {k: sigma(meas[k], spread_base.get(k, 0.0), runs_base) for k in meas} if measured is not None else {}
    if best is not None and measured is not None:
        group = confounded_group(best, fits, verdicts, before, sig_base, base, thr_m) or (confounded_sets(
            best, fits, verdicts, before, sig_base, base, thr_m, [n for n, e in EFFECTS.items() if e.level == level],
            lambda names: slider_changes(names, base, ops, threads=threads, cache=run_cache), confirm,
            [e.name for e in cand_effects]) if level == "slider" else None)
        if group is not None:
            # The data resolve a combination of the group, not which of them: nothing is named.
            confounded = group
            best, alts = None, []
    outside = [x for x, e in EFFECTS.items() if e.level == level and x not in {c.name for c in cand_effects}]
    if best is not None and measured is not None and level == "slider" and outside:
        # An effect of the library left out of the candidates that fits clearly better: the
        # candidates do not establish their change (docs/model.md §9.1, "Outside the candidates").
        pred_o = predict_singles([EFFECTS[x] for x in outside], base,
                                 {k: (meas[k].value - before[k]) / s for k, s in sig_base.items() if k in before},
                                 sig_base, lambda names, st: slider_changes(names, base, ops, steps=st, threads=threads,
                                                                         cache=run_cache), counts_base)
        bar_o = _progress_bar(progress, min(CONFIRM_SINGLES, len(pred_o)),
                              "discover: effects not among the candidates (fits)")

        def confirm_o(name: str) -> Tuple[CandidateFit, List[Reason]]:
            out = confirm(name)
            bar_o.update(1)
            return out

        why_o = outside_fits_better(best, pred_o, confirm_o, thr_m)
        bar_o.close()
        if why_o is not None:
            verdicts[best.effects] = verdicts[best.effects] + [why_o]
            best, alts = None, []
    if best is not None:
        cand = realise_model(base, {e: best.values[e] for e in best.effects})
        f_c, b_c, sp_c, n_c = after_of(cand)
        # The fit's spread pools the ensemble with the roughness of its scan (pooled_spread).
        sp_c = {**sp_c, **{k: v for k, v in best.model_spread.items() if k in sp_c or k in f_c}}
        f_c = filled(f_c, sp_c, n_c)
        chi2_c = gap_of(f_c, meas, sp_c, runs_base, modes, n_c)[1]
        g_c = excess(chi2_c, n - len(best.effects), n)
        if g_c <= gap_ratio * excess_before:
            updated, after_f, beh_upd, spread_after, counts_after = cand.params, f_c, b_c, sp_c, n_c
        else:
            # The fit's gap was small enough, the full simulation's is not: not named.
            verdicts[best.effects] = verdicts[best.effects] + [Reason(
                Why.SMALL_SHARE, f"small share of the gap beyond the noise in the full simulation of the updated "
                                 f"model: {g_c:.3g} > {gap_ratio:g} x {excess_before:.3g}")]
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
                              interval=list(interval_of(best, e)),
                              **({"chi2_roughness": best.roughness[e]} if e in best.roughness else {})) for e in named}
    after_f = filled(after_f, spread_after, counts_after)
    gap_after, chi2_after = gap_of(after_f, meas, spread_after, runs_base, modes, counts_after)
    excess_after = excess(chi2_after, n - len(best.effects) if best is not None else n, n)

    def sig(k: str, sp: Dict[str, float]) -> float:
        return sigma(meas[k], sp.get(k, 0.0), runs_base)

    features = {k: dict(measured=f.value, uncertainty=f.stderr, baseline=before[k], updated=after_f[k],
                        model_spread_baseline=spread_base.get(k, 0.0), model_spread_updated=spread_after.get(k, 0.0),
                        unit=f.unit, description=f.description,
                        z_before=(before[k] - f.value) / sig(k, spread_base),
                        z_after=(after_f[k] - f.value) / sig(k, spread_after),
                        exceeds_uncertainty=bool(abs(before[k] - f.value) > 2 * sig(k, spread_base)))
                for k, f in meas.items()}
    # Nothing named or confounded: "none" where an adequate fit needs only a negligible change —
    # unless a relevant change is resolved, or fits clearly better unresolved (docs/model.md §9.1).
    unresolved: Dict[str, Any] = {}
    if base_ok:
        verdict = "none"
    elif best is not None:
        verdict = "named"
    elif confounded and confounded.get("among_candidates", True):
        verdict = "confounded"
    else:
        # Also a named set that only effects outside the candidates mimic: not established by them.
        verdict, _, u = unnamed_verdict(fits, verdicts, thr_m)
        if u is not None:
            unresolved = dict(effects=list(u.effects), values=u.values, stderrs=u.stderrs, chi2=u.chi2,
                              intervals={e: list(interval_of(u, e)) for e in u.effects},
                              reasons=verdicts[u.effects], kinds=[r.kind.name for r in verdicts[u.effects]])
    grid = ADVICE_GRID if advice_grid is None else tuple(advice_grid)
    to_advise = confounded.get("group") or unresolved.get("effects")
    if to_advise and measured is not None and grid:
        done_pts = {(op.f_ex, op.a_ex, op.s0) for op in ops}
        bar = _progress_bar(progress, 1 + sum(tuple(g) not in done_pts for g in grid),
                            f"discover: advice for {', '.join(to_advise)} (points)")
        (confounded or unresolved)["advice"] = advise(to_advise, base, ops, grid, threads=threads,
                                                     on_point=lambda: bar.update(1),
                                                     fitted=confounded.get("models", confounded.get("values")),
                                                     cache=run_cache)
        bar.close()
    negl = negligible_fits(fits, verdicts)
    rejected = [dict(effects=list(f.effects), values=f.values, stderrs=f.stderrs, chi2=f.chi2, dof=f.dof,
                     reasons=verdicts[f.effects] or ["passes the naming rule, but " + (
                         "is confounded (see confounded)" if confounded else "a simpler or better set was named")],
                     kinds=sorted(k.name for k in kinds(verdicts[f.effects])), negligible=any(f is g for g in negl))
                for f in sorted(fits, key=lambda f: f.chi2) if best is None or f.effects != best.effects]
    off = sorted(((k, v["z_after"]) for k, v in features.items() if abs(v["z_after"]) > 2), key=lambda x: -abs(x[1]))
    criterion = (f"an effect set is named only if (1) the baseline does not fit, chi2 = {chi2_0:.3g} > chi2_0.99(n={n}) = "
                 f"{chi2_quantile(n):.2f} or a feature's |z| = {z_worst:.3g} > {z_bound(n):.3g} (99 %, Bonferroni over "
                 f"the n features); (2) the updated model is adequate, chi2 <= chi2_0.99(n-k); (3) each "
                 f"parameter moved by at least its relevance threshold (EFFECTS[...].relevance); (4) the gap beyond "
                 f"the noise, sqrt(max(chi2 - E[chi2], 0)/n), after <= {gap_ratio:g} x before ({excess_before:.3g}; "
                 f"fit and full simulation); (5) it fits better than every set of negligible changes, each chi2 "
                 f"charged {thr_m:.3g} per parameter; (6) slider level: no single effect of the library left out of the candidates "
                 f"fits better by more than {thr_m:.3g}, each charged it per parameter; among the sets that pass, forward "
                 f"selection by likelihood-ratio tests at 99 %, Bonferroni-corrected for picking the best of m "
                 f"sets (m = {len(cand_effects)}: {thr_m:.2f}); otherwise the "
                 f"verdict is 'unexplained' and nothing is added")
    # The report's figure: the slider's paths of the baseline's and the updated model's runs from
    # s0 (made by the search and the full simulation of the updated model: from the run cache).
    paths: Dict[str, Any] = {}
    if measured is not None:
        upd_model = realise_model(base, {e: best.values[e] for e in named}) if best is not None else Model(base)
        both = slider_paths([base, upd_model], ops, threads=threads, cache=run_cache)
        paths = {name: {op.tag: x for op, x in zip(ops, row)} for name, row in zip(("baseline", "updated"), both)}
    return Discovery(level, named, params_out, features, gap_before, gap_after, chi2_0, fits, criterion, base,
                     updated, behaviours, alts, enma_data if level == "beam" else list(measured or []) if level == "slider"
                     else dict(enma=enma_data, measured=list(measured or [])),
                     time.perf_counter() - t0, verdict=verdict, rejected=rejected,
                     features_off=[dict(feature=k, z=z) for k, z in off], gap_ratio=gap_ratio,
                     gap_excess_before=excess_before, gap_excess_after=excess_after,
                     confounded=confounded, unresolved=unresolved, guided_pairs=guided, joint_refinement=refined_sets,
                     modes={t: dict(ends_high=md[0], turning_point=md[1], runs=runs_base,
                                    baseline_runs_in_mode=counts_base.get(t), updated_runs_in_mode=counts_after.get(t))
                            for t, md in (modes or {}).items() if md is not None}, paths=paths)
