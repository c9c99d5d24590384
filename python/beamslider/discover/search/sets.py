"""Fitting the single candidates and the sets (docs/model.md §9.1, "Sets of effects", "Cost"): the
tier, the coarse scans of the full search, the pairs and their joint refinement."""

from __future__ import annotations

from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

from ...params import Parameters
from ..effects import Effect
from ..features import Feature
from ..fitting import EnsembleMany, ModelMany, fit_candidate, profile_fit
from ..models import RUN_PROGRESS
from ..refine import sets_to_refine
from ..result import CandidateFit
from ..stats import lrt_threshold
from .linearised import predicted_singles
from .pairs import pairs_to_fit
from .progress import FitProgress, progress_bar
from .tiered import TIER_SHARED, no_pair_gains, tiered_singles


def fit_sets(cand_effects: Sequence[Effect], max_effects: int, level: str, base: Parameters,
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
    """Fit every single candidate and the sets of up to ``max_effects`` (:func:`.search.pairs.pairs_to_fit`,
    with the pairs ranked by ``guide``, slider level: :func:`.search.pairs.rank_pairs`); no sets if
    ``done(singles)`` (no set can be selected over them, :func:`no_set_can_win`). ``predict``: the
    fast path (:mod:`.search.linearised`): singles screened by the linearised model, and the pair it predicts best
    only if predicted to beat the best single fitted by the selection's threshold. ``step``: a set's
    χ² predicted after a Gauss–Newton step from its coordinate pass (:func:`.refine.step_chi2`),
    which chooses the sets refined jointly (:func:`.refine.sets_to_refine`); ``record``: one entry
    per set so staged (pass and predicted χ², refined or not). ``tier`` (with ``predict``): the
    screening tier first (:func:`.search.tiered.tiered_singles`), the full search only where it does not
    settle: settled if no set can win (``done``) or, for the single ``named(singles)`` would name,
    no pair containing it is predicted to gain the selection's least threshold (:func:`.search.tiered.no_pair_gains`;
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
        # predicted to gain the least threshold (:func:`.search.tiered.no_pair_gains`).
        return (step is not None and named is not None
                and no_pair_gains(singles, named(singles), step, base, known or (lambda e: True)))

    bar = progress_bar(progress, len(cand_effects), f"discover ({level}): fits")
    shown = FitProgress(bar)
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


SCREEN_FROM = 3
"""Slider level, more candidates than this: each is first scanned coarsely (:func:`fit_sets`)."""


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
