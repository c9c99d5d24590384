"""The default search, ``search="tiered"`` (docs/model.md §9.1, "Cost"): the linearised model's
prediction orders the single candidates, the best predicted are fitted in full
(:func:`tiered_singles`), and where that settles the answer (no set can be selected over a named
single, or no pair containing it is predicted to gain the selection's least threshold) the search
stops; elsewhere the full search (:mod:`.full`) runs, keeping the tier's first fits in full. With
``options.screen_from`` candidates or fewer each is fitted in full, and no pair is fitted where the
same gate holds."""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable, Dict, List, Sequence, Tuple

from ..effects import Effect
from ..options import DEFAULT, DiscoverOptions
from ..result import CandidateFit
from ..stats import right_fit_bound
from . import full
from .common import Fitter, fit_sets, pairs_gated, predicted_singles, singles_in_full


def search(problem: Any, candidates: Sequence[Effect], options: DiscoverOptions) -> List[CandidateFit]:
    """The tiered search of ``candidates`` (module docs)."""
    with Fitter(problem, candidates) as fit:
        if len(candidates) <= options.screen_from:
            fits = singles_in_full(fit, candidates)
            if problem.max_effects >= 2 and pairs_gated(problem, fits):
                return fits
            return fits + fit_sets(problem, fit, candidates, fits, options)
        pred = problem.predict(candidates)
        lead = getattr(problem, "provisional", None)  # the leading candidate as soon as there is one
        fits, complete = tiered_singles(candidates, pred,
                                        (lambda e: leading(problem, fit, lead, e)) if lead else (lambda e: fit((e,))),
                                        len(problem.meas), options.tier_keep,
                                        options.tier_margin, options.significance, least=options.tier_least,
                                        good=lambda f: fits_as_right_models(problem, f, options))
        if complete and (problem.max_effects < 2 or problem.no_set_can_win(fits) or pairs_gated(problem, fits)):
            fit.bar.update(len(candidates))
            return fits
        # The full search keeps the tier's first options.tier_shared fits by prediction; a later one, made
        # to settle the answer, enters as its coarse scan does (from the fit's cached runs), so the full
        # search's verdict is that of a tier of that many fits.
        first = sorted((f for f in fits if not f.screened), key=lambda f: pred[f.effects[0]][0])[:options.tier_shared]
        return full.scan(problem, fit, candidates, options, {f.effects[0]: f for f in first})


def leading(problem: Any, fit: Fitter, lead: Any, e: Effect) -> CandidateFit:
    """A tier's fit in full of ``e``, handed to the provisional answer (``lead``) as it leads. The
    first answer is the coordinate pass's fit, before a poor single's refinement on ensembles (docs/model.md
    §9.1, "Provisional answer"): the same runs, made once and reused by the fit in full that follows."""
    if lead.best is None and getattr(problem, "level", None) == "slider":
        lead.saw(problem.fit((e,), options=dataclasses.replace(problem.options, poor_single_alpha=0.0)))
    return lead.saw(fit((e,)))


def tiered_singles(cands: Sequence[Effect], pred: Dict[str, Tuple[float, float]],
                   fit: Callable[[Effect], CandidateFit], n: int,
                   keep: int = DEFAULT.tier_keep, margin: float = DEFAULT.tier_margin,
                   alpha: float = DEFAULT.significance, *, least: int = 1,
                   good: Callable[[CandidateFit], bool] = lambda f: f.adequate) -> Tuple[List[CandidateFit], bool]:
    """The screening tier of the default search (docs/model.md §9.1, "Cost"): the best predicted
    candidate fitted in full, then each next best predicted while fewer than ``least`` are fitted,
    its predicted χ², times :func:`tier_scale`, is within ``margin`` of the best χ² fitted so far,
    or no candidate fitted so far fits as right models do (``good``: adequate, and at the slider
    level within the goodness-of-fit bound, :func:`fits_as_right_models`), at most ``keep`` in full; the others kept as screened at their
    predicted χ² (:func:`predicted_singles`).
    Returns the fits, in the order of ``cands``, and whether the tier is complete: every candidate
    left unfitted is predicted, so scaled, beyond the margin, and no fitted χ² lies more than
    ``margin`` above its prediction (a valley the fit missed); else the caller runs the
    full search, which keeps the fits made in full (also where more candidates are predicted near
    than ``keep``)."""
    order = sorted(cands, key=lambda e: pred[e.name][0])
    full: Dict[str, CandidateFit] = {}
    for e in order:
        best = min((f.chi2 for f in full.values()), default=math.inf)
        if (len(full) >= least and pred[e.name][0] * tier_scale(pred, full, margin) > best + margin
                and any(good(f) for f in full.values())):
            break
        if len(full) == keep:
            return predicted_singles(cands, pred, lambda e: full[e.name], n, keep=set(full), alpha=alpha), False
        full[e.name] = fit(e)
    fits = predicted_singles(cands, pred, lambda e: full[e.name], n, keep=set(full), alpha=alpha)
    trusted = all(f.chi2 - pred[k][0] <= margin for k, f in full.items() if math.isfinite(f.chi2))
    return fits, trusted


def fits_as_right_models(problem: Any, f: CandidateFit, o: DiscoverOptions = DEFAULT) -> bool:
    """Whether a single fitted in full fits as right models do: adequate, and at the slider level
    within the goodness-of-fit bound of right models (docs/model.md §9.1, "Goodness of fit")."""
    if not f.adequate or getattr(problem, "level", None) != "slider":
        return f.adequate
    return f.chi2 <= right_fit_bound(len(problem.meas), len(f.effects), o)


def tier_scale(pred: Dict[str, Tuple[float, float]], full: Dict[str, CandidateFit],
               margin: float = DEFAULT.tier_margin) -> float:
    """The factor on the tier's predictions (:func:`tiered_singles`): 1, or, where a fitted χ² lies
    more than ``margin`` below its prediction, the least ratio of such a fitted χ² to its
    prediction. A change beyond the quadratic's reach is overestimated (R/h 1.08 predicted at χ² 84
    fits at 7.3); the other candidates' predictions are taken as overestimated by as much."""
    ratios = [max(f.chi2, 0.0) / pred[k][0] for k, f in full.items()
              if math.isfinite(f.chi2) and pred[k][0] - f.chi2 > margin]
    return min([1.0] + ratios)
