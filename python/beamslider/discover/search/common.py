"""What the strategies share (docs/model.md §9.1, "Sets of effects", "Cost"): the fits with their
progress, the single candidates fitted in full or scanned coarsely, the tier's gate for the pairs,
and the sets: which are fitted, their coordinate passes and which get the joint refinement."""

from __future__ import annotations

import math
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

from ...params import Parameters
from ..effects import EFFECTS, Effect
from ..models import RUN_PROGRESS
from ..options import DEFAULT, DiscoverOptions
from ..refine import sets_to_refine
from ..result import CandidateFit
from ..stats import chi2_quantile, lrt_threshold
from .pairs import pairs_to_fit
from ..progress import FitProgress, progress_bar


class Fitter:
    """Fits of sets of ``candidates`` (``fit_fn``, default the problem's :meth:`.problem.Problem.fit`)
    with a bar of fits done / to do that also counts the runs made and shows the lowest χ² fitted so
    far; a context: the core's per-run callback is set inside it."""

    def __init__(self, problem: Any, candidates: Sequence[Effect], level: Optional[str] = None,
                 fit_fn: Optional[Callable[..., CandidateFit]] = None, progress: Any = "problem") -> None:
        self.problem = problem
        self.fit_fn = fit_fn if fit_fn is not None else problem.fit
        enabled = problem.progress if progress == "problem" else progress
        self.bar = progress_bar(enabled, len(candidates), f"discover ({level or problem.level}): fits")
        self.shown = FitProgress(self.bar)

    def __enter__(self) -> "Fitter":
        self._token = RUN_PROGRESS.set(self.shown)
        return self

    def __exit__(self, *exc: Any) -> None:
        RUN_PROGRESS.reset(self._token)
        self.bar.close()

    def __call__(self, combo: Sequence[Effect], refine: Optional[int] = None, joint: Optional[bool] = None) -> CandidateFit:
        f = self.fit_fn(combo, refine=refine, joint=joint)
        self.shown.saw(f)
        return f


def singles_in_full(fit: Fitter, candidates: Sequence[Effect]) -> List[CandidateFit]:
    """Every single candidate fitted in full."""
    fits = []
    for e in candidates:
        fits.append(fit((e,)))
        fit.bar.update(1)
    return fits


def coarse_singles(fit: Fitter, candidates: Sequence[Effect], options: DiscoverOptions,
                   kept: Optional[dict] = None) -> List[CandidateFit]:
    """The full search's singles: coarse scans of every candidate first (grid and one ensemble,
    ``options.screen_refine`` levels: runs the full fits reuse), full fits only of those whose
    coarse χ² is within ``options.screen_margin`` of the best (at least ``options.screen_keep``), the
    others kept as screened; ``kept``: fits in full by name (the tier's) that stand for their coarse
    scan's fit (a coarse scan's single runs may miss what that fit found)."""
    kept = kept or {}
    coarse = []
    for e in candidates:
        coarse.append(fit((e,), refine=options.screen_refine))
        fit.bar.update(0.5)
    best = sorted(c.chi2 for c in coarse)
    cut = max(best[0] + options.screen_margin, best[min(options.screen_keep, len(best)) - 1])
    fits = []
    for e, c in zip(candidates, coarse):
        if e.name in kept:
            fits.append(kept[e.name])
        elif c.chi2 <= cut:
            fits.append(fit((e,)))
        else:
            c.screened = True
            fits.append(c)
        fit.bar.update(0.5)
    return fits


def pairs_gated(problem: Any, singles: List[CandidateFit]) -> bool:
    """The tier's gate for the pairs: no pair containing the single the selection would name is
    predicted to gain the least likelihood-ratio threshold (:func:`no_pair_gains`)."""
    return no_pair_gains(singles, problem.best_single(singles), problem.step, problem.base, problem.known,
                         problem.options.significance)


def fit_sets(problem: Any, fit: Fitter, candidates: Sequence[Effect], singles: List[CandidateFit],
             options: DiscoverOptions, *, gated: bool = True, only_best_predicted: bool = False,
             level: Optional[str] = None) -> List[CandidateFit]:
    """The sets of up to ``problem.max_effects`` effects fitted after ``singles``
    (:func:`.pairs.pairs_to_fit`; at the slider level with more than ``options.rank_from``
    candidates the pairs ranked by the linearised model, :meth:`.problem.Problem.guide`); none if
    ``gated`` and no set can be selected over the singles (:meth:`.problem.Problem.no_set_can_win`).
    ``only_best_predicted`` (the fast path): only the pair predicted best, and only if predicted to
    beat the best single by the selection's threshold. Slider level, more sets than
    ``options.joint_sets``: all get the coordinate pass, the joint refinement those
    :func:`.refine.sets_to_refine` picks (recorded: ``problem.record.refined``). ``level``: that of the
    fits (None: the problem's)."""
    if problem.max_effects < 2 or (gated and problem.no_set_can_win(singles)):
        return []
    level = level or problem.level
    slider = level == "slider"
    ranked = problem.guide() if slider and len(candidates) > options.rank_from else None
    combos = pairs_to_fit(candidates, singles, problem.max_effects, level, ranked, options.extending_pairs,
                          options.guided_pairs)
    if only_best_predicted and ranked:
        win = ranked[0][1] < min(f.chi2 for f in singles if not f.screened) - problem.thr_m
        combos = [c for c in combos if win and frozenset(e.name for e in c) == frozenset(ranked[0][0])]
    fit.bar.total = len(candidates) + len(combos)
    fit.bar.refresh()
    staged = slider and len(combos) > options.joint_sets
    sets = []
    for combo in combos:
        # Many sets: the coordinate pass of each first, the joint refinement of the best below.
        sets.append(fit(combo, joint=False if staged else None))
        fit.bar.update(1)
    if staged:
        names = [frozenset(e.name for e in c) for c in combos]
        top = [frozenset(p) for p, _ in (ranked or [])[:1]]
        passes = [s.chi2 for s in sets]
        steps = [problem.step(s) for s in sets]
        order = sets_to_refine(passes, steps, next((i for i in range(len(sets)) if names[i] in top), None),
                               options.joint_sets, problem.thr_m)
        fit.bar.total += len(order)
        for i in order:
            sets[i] = fit(combos[i])  # the coordinate pass's runs are cached
            fit.bar.update(1)
        problem.record.refined.extend(dict(effects=sorted(names[i]), pass_chi2=passes[i], step_chi2=steps[i],
                                           refined=i in order, chi2=sets[i].chi2) for i in range(len(sets)))
    return sets


def predicted_singles(cands: Sequence[Effect], pred: Dict[str, Tuple[float, float]],
                      fit: Callable[[Effect], CandidateFit], n: int,
                      keep: Optional[set] = None, fast_keep: int = DEFAULT.fast_keep,
                      alpha: float = DEFAULT.significance) -> List[CandidateFit]:
    """The ``fast_keep`` best predicted candidates (or those named in ``keep``) fitted in full
    (``fit``), the others kept as screened fits at their predicted χ² and value (``linearised``), in
    the order of ``cands``."""
    if keep is None:
        keep = {e.name for e in sorted(cands, key=lambda e: pred[e.name][0])[:fast_keep]}
    out = []
    for e in cands:
        if e.name in keep:
            out.append(fit(e))
            continue
        c2, v = pred[e.name]
        out.append(CandidateFit((e.name,), {e.name: v}, {e.name: math.inf}, c2, n - 1, c2 <= chi2_quantile(n - 1, alpha),
                                c2 + math.log(n), screened=True, linearised=True))
    return out


def no_pair_gains(singles: List[CandidateFit], best: Optional[CandidateFit],
                  step: Callable[[CandidateFit], float], base: Parameters,
                  known: Callable[[str], bool] = lambda name: True, alpha: float = DEFAULT.significance) -> bool:
    """Whether no pair containing the single ``best`` (the one the selection would name) could be
    selected over it: for every other candidate X, a Gauss–Newton step from ``best``'s fitted point
    with X at its baseline (:func:`.refine.step_chi2`, both effects free) is predicted to lower χ²
    by less than the least likelihood-ratio threshold for adding an effect (6.63 at ``alpha`` 0.01). The forward
    selection only extends the named single, so pairs without it cannot change the verdict; the
    linearised model overestimates the gain of large moves, which errs towards the full search.
    ``known(name)``: whether the linearised model has the effect's column (asked after each step; a
    run of the moved model may have failed): without it nothing is predicted, and the answer is no."""
    if best is None or len(best.effects) != 1 or not best.predicted:
        return False
    (a,) = best.effects
    thr = lrt_threshold(1, 1, alpha)
    for f in singles:
        x = f.effects[0]
        if x == a:
            continue
        pair = CandidateFit((a, x), {a: best.values[a], x: EFFECTS[x].baseline_value(base)}, {}, best.chi2,
                            best.dof - 1, best.adequate, best.bic, predicted=best.predicted,
                            model_spread=best.model_spread)
        if step(pair) < best.chi2 - thr or not (known(a) and known(x)):
            return False
    return True


def adopt_set_valleys(problem: Any, fits: List[CandidateFit]) -> List[CandidateFit]:
    """A set whose members but one moved by less than their relevance thresholds has found that one's
    valley: where the single's own fit lies above the set's χ² by more than z² (its scan settled
    beside the valley), the single at the set's value — its ensemble, one batch of runs — takes the
    single's place when it fits better, with the set's interval for it, marginal over the others and
    so no narrower (docs/model.md §9.1, "Sets of effects")."""
    from dataclasses import replace

    from ..chain import realise_model
    from ..stats import gap_of, interval_z

    base, o = problem.base, problem.options
    z2 = interval_z(o.interval_level) ** 2
    out = list(fits)
    for f in sorted(fits, key=lambda f: f.chi2):
        relevant = [e for e in f.effects if EFFECTS[e].relevant(f.values[e], base)[0]]
        at = [i for i, s in enumerate(out) if len(f.effects) > 1 and len(relevant) == 1 and s.effects == (relevant[0],)
              and not s.screened and s.chi2 > f.chi2 + z2]
        if not at:
            continue
        e, s = relevant[0], out[at[0]]
        after = problem.simulate(realise_model(base, {e: f.values[e]}))
        chi2 = gap_of(after.features, problem.meas, after.spread, problem.runs_base, problem.modes, after.counts)[1]
        if math.isfinite(chi2) and chi2 < s.chi2:
            out[at[0]] = replace(s, values={e: f.values[e]}, stderrs={e: f.stderrs[e]}, chi2=chi2,
                                 adequate=chi2 <= chi2_quantile(s.dof, o.significance),
                                 bic=chi2 + math.log(max(problem.n, 2)), predicted=dict(after.features),
                                 model_spread=dict(after.spread), intervals={e: f.intervals[e]}, roughness={})
    return out
