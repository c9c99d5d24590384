"""The screening tier of the default search (docs/model.md §9.1, "Cost"): the linearised model's
prediction orders the single candidates, the best predicted are fitted in full, and the tier says
whether that settles the answer."""

from __future__ import annotations

import math
from typing import Callable, Dict, List, Optional, Sequence, Tuple

from ...params import Parameters
from ..effects import EFFECTS, Effect
from ..result import CandidateFit
from ..stats import lrt_threshold
from .linearised import predicted_singles


TIER_MARGIN = 20.0
"""The tier (:func:`tiered_singles`): a candidate predicted within this of the best fitted χ² is
fitted in full (the coarse scan's margin, :data:`.search.sets.SCREEN_MARGIN`)."""


TIER_KEEP = 4
"""The tier (:func:`tiered_singles`): at most this many single candidates fitted in full before the
answer goes to the full search. With the natural frequencies × 1.03 hidden (docs/validation/discover.md)
the detuning, predicted at χ² 53.4, fits at 3.44, and the scale it sets (:func:`tier_scale`, 0.064)
brings the mass, the com offset and the contact spacing within the margin: three fits leave the
spacing and send the answer to the full search (487 s CPU), the fourth settles it (258 s, the same
verdict)."""


TIER_SHARED = 3
"""The tier's fits in full that the full search keeps (the first by prediction,
:func:`.search.sets.fit_sets`): a fourth, made to settle the answer, enters the full search as its
coarse scan does, from the fit's cached runs, so the full search's verdict is that of a tier of
three fits."""


def tiered_singles(cands: Sequence[Effect], pred: Dict[str, Tuple[float, float]],
                   fit: Callable[[Effect], CandidateFit], n: int,
                   keep: int = TIER_KEEP) -> Tuple[List[CandidateFit], bool]:
    """The screening tier of the default search (docs/model.md §9.1, "Cost"): the best predicted
    candidate fitted in full, then each next best predicted while its predicted χ², times
    :func:`tier_scale`, is within :data:`TIER_MARGIN` of the best χ² fitted so far or no candidate
    fitted so far is adequate, at most ``keep`` in full; the others kept as screened at their
    predicted χ² (:func:`predicted_singles`).
    Returns the fits, in the order of ``cands``, and whether the tier is complete: every candidate
    left unfitted is predicted, so scaled, beyond the margin, and no fitted χ² lies more than
    :data:`TIER_MARGIN` above its prediction (a valley the fit missed); else the caller runs the
    full search, which keeps the fits made in full (also where more candidates are predicted near
    than ``keep``)."""
    order = sorted(cands, key=lambda e: pred[e.name][0])
    full: Dict[str, CandidateFit] = {}
    for e in order:
        best = min((f.chi2 for f in full.values()), default=math.inf)
        if (full and pred[e.name][0] * tier_scale(pred, full) > best + TIER_MARGIN
                and any(f.adequate for f in full.values())):
            break
        if len(full) == keep:
            return predicted_singles(cands, pred, lambda e: full[e.name], n, keep=set(full)), False
        full[e.name] = fit(e)
    fits = predicted_singles(cands, pred, lambda e: full[e.name], n, keep=set(full))
    trusted = all(f.chi2 - pred[k][0] <= TIER_MARGIN for k, f in full.items() if math.isfinite(f.chi2))
    return fits, trusted


def tier_scale(pred: Dict[str, Tuple[float, float]], full: Dict[str, CandidateFit]) -> float:
    """The factor on the tier's predictions (:func:`tiered_singles`): 1, or, where a fitted χ² lies
    more than :data:`TIER_MARGIN` below its prediction, the least ratio of such a fitted χ² to its
    prediction. A change beyond the quadratic's reach is overestimated (R/h 1.08 predicted at χ² 84
    fits at 7.3); the other candidates' predictions are taken as overestimated by as much."""
    ratios = [max(f.chi2, 0.0) / pred[k][0] for k, f in full.items()
              if math.isfinite(f.chi2) and pred[k][0] - f.chi2 > TIER_MARGIN]
    return min([1.0] + ratios)


def no_pair_gains(singles: List[CandidateFit], best: Optional[CandidateFit],
                  step: Callable[[CandidateFit], float], base: Parameters,
                  known: Callable[[str], bool] = lambda name: True) -> bool:
    """Whether no pair containing the single ``best`` (the one the selection would name) could be
    selected over it: for every other candidate X, a Gauss–Newton step from ``best``'s fitted point
    with X at its baseline (:func:`.refine.step_chi2`, both effects free) is predicted to lower χ²
    by less than the least likelihood-ratio threshold for adding an effect (6.63). The forward
    selection only extends the named single, so pairs without it cannot change the verdict; the
    linearised model overestimates the gain of large moves, which errs towards the full search.
    ``known(name)``: whether the linearised model has the effect's column (asked after each step; a
    run of the moved model may have failed): without it nothing is predicted, and the answer is no."""
    if best is None or len(best.effects) != 1 or not best.predicted:
        return False
    (a,) = best.effects
    thr = lrt_threshold(1, 1)
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
