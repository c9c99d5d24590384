"""Naming the missing effect: :func:`discover` (see the package docstring): the problem, the search
(:mod:`.search`) and the naming rule (:mod:`.rule`)."""

from __future__ import annotations

import math
from typing import Any, Dict, List, Optional, Sequence, Tuple

from .. import _core
from ..enma import EnmaData
from ..measurement import Measurement
from ..params import Parameters, resolve
from .advice import ADVICE_GRID, advise
from .chain import Model, realise_model
from .confounding import CONFIRM_SINGLES, confounded_group, confounded_sets, outside_fits_better
from .effects import EFFECTS, realise_effects
from .features import Feature, enma_features
from .fitting import EnsembleMany, ModelMany, fit_candidate, profile_fit
from .models import (ENSEMBLE_S0_SHIFTS, Ensemble, Modes, RunCache, batch_slider_features, beam_surrogate,
                     data_modes, ensemble_slider_features, levels_for, measured_slider_features,
                     simulated_enma_features, slider_paths, unreached_mode_features)
from .refine import step_chi2
from .result import CandidateFit, Discovery
from .rule import Reason, Why, best_single, judge, kinds, negligible_fits, no_set_can_win, select, unnamed_verdict
from .runstore import RunStore
from .search.joint import fit_sets_joint
from .search.linearised import predict_singles
from .search.pairs import GUIDED_PAIRS, rank_pairs
from .search.progress import progress_bar
from .search.sets import SCREEN_FROM, fit_sets
from .separability import slider_changes, slider_sensitivities
from .stats import (MODE_CONDITIONING, baseline_test, chi2_quantile, excess, gap_of, interval_of, lrt_threshold,
                    missing_z, sigma, z_bound)


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
    :data:`.advice.ADVICE_GRID`; empty: no advice runs). ``search`` (slider level, more than
    :data:`SCREEN_FROM` candidates; docs/model.md §9.1, "Cost"): ``"tiered"``, the linearised
    model's screening with full fits of the best predicted first (:func:`.search.tiered.tiered_singles`), the
    full search only where that does not settle the answer; ``"full"``, coarse scans of every
    candidate; ``"fast"`` (also ``fast=True``), the screening alone and one pair (:mod:`.search.linearised`).
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
            fits = fit_sets(cand_effects, max_effects, level, base, meas, model_fn, diff_step, max_nfev,
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

            fits = fit_sets(cand_effects, max_effects, level, base, meas, model_fn, diff_step, max_nfev,
                            model_many=model_many, ensemble_many=ensemble_many, spread0=spread_base,
                            progress=progress, guide=guide if len(cand_effects) > 3 else None,
                            step=step, record=refined_sets,
                            predict=(lambda: predict_singles(
                                 cand_effects, base, resid_of(), sig_of(), lambda names, st: slider_changes(
                                     names, base, ops, steps=st, threads=threads, cache=run_cache), counts_base))
                            if search != "full" and len(cand_effects) > SCREEN_FROM else None,
                            tier=search == "tiered",
                            done=lambda singles: no_set_can_win(
                                 singles, lambda fs: judge(fs, base, n, excess_before, gap_ratio, thr_m)),
                            known=lambda name: bool(changes.get(name)),
                            named=lambda singles: best_single(
                                 singles, judge(singles, base, n, excess_before, gap_ratio, thr_m), chi2_0, n))
        else:
            assert model_many is not None
            # Beam stage first (cheap): its selection re-centres the surrogate's bias.
            beam_cands = [e for e in cand_effects if e.level == "beam"]
            chi2_b0 = gap_of({k: before[k] for k in meas_b}, meas_b)[1]
            if beam_cands and chi2_b0 > chi2_quantile(len(meas_b)):
                fits_b = fit_sets(beam_cands, max_effects, "beam", base, meas_b, model_b, None, 200)
                refit_beam_bias(fits_b)
            chi2_s0 = gap_of({k: before[k] for k in meas_s}, meas_s, spread_base, runs_base, modes, counts_base)[1]
            fits = fit_sets_joint(cand_effects, max_effects, base, meas_b, model_b, meas_s, model_many,
                                   chi2_b0, chi2_s0, ensemble_many=ensemble_many, spread0=spread_base,
                                   progress=progress)
    verdicts = judge(fits, base, n, excess_before, gap_ratio, thr_m)
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
        return f, judge([f], base, n, excess_before, gap_ratio)[f.effects]

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
        bar_o = progress_bar(progress, min(CONFIRM_SINGLES, len(pred_o)),
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
        bar = progress_bar(progress, 1 + sum(tuple(g) not in done_pts for g in grid),
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
