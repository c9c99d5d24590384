"""Naming the missing effect: :func:`discover`, in three parts (docs/model.md §9): the problem built
once (:mod:`.problem`), a search strategy's fits (:mod:`.search`) and the rule's verdict
(:mod:`.rule`), with the tuning values in one type (:mod:`.options`); :func:`outcome` puts them
together as a :class:`.result.Discovery`."""

from __future__ import annotations

import time
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

from ..enma import EnmaData
from ..measurement import Measurement
from ..params import Parameters
from .chain import Model, realise_model
from .cluster import on_cluster
from .effects import EFFECTS
from .options import DiscoverOptions
from .problem import Problem
from .provisional import Provisional
from .reasons import kinds
from .result import CandidateFit, Discovery, Verdict
from .rule import criterion, decide
from .search import run, strategy_of
from .stats import excess, gap_of, interval_of, sigma


def discover(*, enma_data: Optional[EnmaData] = None, measured: Optional[Sequence[Measurement]] = None,
             baseline: Optional[Parameters] = None, effects: Optional[Sequence[str]] = None,
             max_effects: int = 2, progress: bool = False, gap_ratio: Optional[float] = None,
             threads: Optional[int] = None, advice_grid: Optional[Sequence[Tuple[float, float, float]]] = None,
             fast: bool = False, search: str = "tiered", runs_file: Optional[Any] = None,
             options: Any = None, on_provisional: Optional[Callable[[Dict[str, Any]], None]] = None,
             scheduler: Any = None, scheduler_file: Optional[str] = None) -> Discovery:
    """Find the effects the ``baseline`` model misses, from beam-level ENMA data (``enma_data``),
    slider-level free-slider runs (``measured``, files of the published format) or both (one joint
    fit over both feature sets: beam-level effects from both, slider-level ones from the runs),
    name them, add them and measure the gap before and after (docs/model.md §9).
    ``options``: a :class:`.options.DiscoverOptions` or a mapping of some of its fields (an unknown
    key is refused); ``gap_ratio`` and ``advice_grid``, when given, replace its fields of those
    names (a named set leaves at most ``gap_ratio`` of the gap beyond the noise; the operating
    points (f_ex, a_ex, s0) where the advice looks for a run, empty: none). ``effects``: the
    candidates (None: the level's library). ``progress``: a bar of fits done / to do (None: a bar
    on a terminal, a line now and then in a log). ``threads``: workers of the core's runner (None:
    one per core). ``search`` (slider level): ``"tiered"`` (the default), ``"full"`` or ``"fast"``
    (also ``fast=True``), :mod:`.search` (docs/model.md §9.1, "Cost"). ``runs_file``: a JSON-lines
    file of the free-slider runs, or a :class:`.runstore.RunStore`: the runs it holds from the same
    code are reused, every run made is appended (None: none kept). ``on_provisional``: called with
    the leading candidate as soon as the tiered search has one, and as the lead improves (a dict,
    :mod:`.provisional`; raising :class:`.provisional.StopAtProvisional` ends the search there).
    ``scheduler`` (an address or a ``distributed.Client``) or ``scheduler_file``: the free-slider
    runs are made as tasks of that Dask cluster, with the local run's answer (:mod:`.cluster`,
    docs/cluster.md); the scheduler is reached before anything is written."""
    t0 = time.perf_counter()
    strategy = strategy_of(search, fast)
    opts = DiscoverOptions.of(options, gap_ratio=gap_ratio, advice_grid=advice_grid)
    with on_cluster(scheduler, scheduler_file):
        problem = Problem.build(enma_data=enma_data, measured=measured, baseline=baseline, effects=effects,
                                max_effects=max_effects, threads=threads, runs_file=runs_file, progress=progress,
                                options=opts)
        problem.provisional = Provisional(on_provisional, problem, t0) if on_provisional is not None else None
        fits = [] if problem.baseline_fits else run(problem, strategy)
        verdict = decide(problem, fits)
        return outcome(problem, fits, verdict, time.perf_counter() - t0)


def outcome(problem: Problem, fits: List[CandidateFit], v: Verdict, runtime_s: float) -> Discovery:
    """The :class:`.result.Discovery` of ``problem``'s fits and verdict: the named parameters, the
    features before and after (the full simulation of the named set), the rejected sets, the
    modes and the slider's paths."""
    p, o, meas, best = problem, problem.options, problem.meas, v.named
    a = v.after
    after_f = p.filled(a.features if a else p.before, a.spread if a else p.spread_base,
                       a.counts if a else p.counts_base)
    spread_after, counts_after = (a.spread, a.counts) if a else (dict(p.spread_base), dict(p.counts_base))
    behaviours = dict(p.behaviours)
    if p.measured is not None:
        behaviours["updated"] = a.behaviours if a else p.behaviours.get("baseline", {})
    named = list(best.effects) if best is not None else []
    gap_after, chi2_after = gap_of(after_f, meas, spread_after, p.runs_base, p.modes, counts_after)

    def sig(k: str, sp: Dict[str, float]) -> float:
        return sigma(meas[k], sp.get(k, 0.0), p.runs_base)

    features = {k: dict(measured=f.value, uncertainty=f.stderr, baseline=p.before[k], updated=after_f[k],
                        model_spread_baseline=p.spread_base.get(k, 0.0), model_spread_updated=spread_after.get(k, 0.0),
                        unit=f.unit, description=f.description,
                        z_before=(p.before[k] - f.value) / sig(k, p.spread_base),
                        z_after=(after_f[k] - f.value) / sig(k, spread_after),
                        exceeds_uncertainty=bool(abs(p.before[k] - f.value) > 2 * sig(k, p.spread_base)))
                for k, f in meas.items()}
    off = sorted(((k, f["z_after"]) for k, f in features.items() if abs(f["z_after"]) > 2), key=lambda x: -abs(x[1]))
    upd_model = realise_model(p.base, {e: best.values[e] for e in named}) if best is not None else Model(p.base)
    return Discovery(p.level, named, _parameters(p, best), features, p.gap_before, gap_after, p.chi2_0, fits,
                     criterion(p), p.base, upd_model.params if best is not None else p.base, behaviours,
                     v.alternatives, p.data, runtime_s, verdict=v.kind, rejected=_rejected(fits, v),
                     features_off=[dict(feature=k, z=z) for k, z in off], gap_ratio=o.gap_ratio,
                     gap_excess_before=p.excess_before,
                     gap_excess_after=excess(chi2_after, p.n - len(named) if best is not None else p.n, p.n),
                     confounded=_with_advice(v.group, v), unresolved=_unresolved(p, v),
                     guided_pairs=p.record.guided, joint_refinement=p.record.refined,
                     modes={t: dict(ends_high=md[0], turning_point=md[1], runs=p.runs_base,
                                    baseline_runs_in_mode=p.counts_base.get(t), updated_runs_in_mode=counts_after.get(t))
                            for t, md in (p.modes or {}).items() if md is not None},
                     paths=p.paths(upd_model), judgment=v, options=o)


def _parameters(p: Problem, best: Optional[CandidateFit]) -> Dict[str, Dict[str, Any]]:
    # The named set's parameters with their standard errors, intervals and relevance.
    if best is None:
        return {}
    level = p.options.interval_level
    return {e: dict(field=EFFECTS[e].field, value=best.values[e], stderr=best.stderrs[e], unit=EFFECTS[e].unit,
                    baseline=EFFECTS[e].baseline_value(p.base), relevance=EFFECTS[e].relevant(best.values[e], p.base)[1],
                    interval=list(interval_of(best, e, level)),
                    **({"chi2_roughness": best.roughness[e]} if e in best.roughness else {})) for e in best.effects}


def _rejected(fits: List[CandidateFit], v: Verdict) -> List[Dict[str, Any]]:
    # The fitted sets not named, best first, each with its reasons and their kinds.
    negl = v.negligible
    return [dict(effects=list(f.effects), values=f.values, stderrs=f.stderrs, chi2=f.chi2, dof=f.dof,
                 reasons=v.why_not(f), kinds=sorted(k.name for k in kinds(v.reasons[f.effects])),
                 negligible=any(f is g for g in negl))
            for f in sorted(fits, key=lambda f: f.chi2) if v.named is None or f.effects != v.named.effects]


def _with_advice(d: Dict[str, Any], v: Verdict) -> Dict[str, Any]:
    # The confounded group (or, nothing confounded, the unresolved candidate) carries the advice.
    return {**d, "advice": v.advice} if d and v.advice else d


def _unresolved(p: Problem, v: Verdict) -> Dict[str, Any]:
    # "unexplained — best candidate X, not resolved by these runs" (docs/model.md §9.1, "Resolved").
    u = v.unresolved
    if u is None:
        return {}
    out = dict(effects=list(u.effects), values=u.values, stderrs=u.stderrs, chi2=u.chi2,
               intervals={e: list(interval_of(u, e, p.options.interval_level)) for e in u.effects},
               reasons=v.reasons[u.effects], kinds=[r.kind.name for r in v.reasons[u.effects]])
    if v.advice and not v.group:
        out["advice"] = v.advice
    return out

