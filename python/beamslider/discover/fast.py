"""The fast path of the slider-level naming (opt-in, ``discover(fast=True)``; docs/model.md §9.1,
"Cost"): instead of a coarse scan of every candidate, the linearised model with curvature —
each candidate's runs moved by ± five relevance thresholds — predicts each single candidate's
best χ², and only the best predicted are fitted in full; of the sets, only the pair the
linearised model predicts best, and only if its predicted χ² beats the best single's fitted χ² by the
selection's likelihood-ratio threshold (it could not be selected otherwise, as far as the linearised
model tells; it overestimates the χ² of large changes, so a pair of large effects may be missed). The end-state
features of an operating point where the baseline misses the data's mode enter no quadratic (their
changes are a mode switch, not the candidate's signature). Not the default: the prediction has been
checked on the table's cases only.

The same prediction is the first tier of the default search (``discover(search="tiered")``,
:func:`tiered_singles`, :func:`no_pair_gains`): where the tier settles the answer the coarse scans
and the pairs are skipped; elsewhere the full search runs and gives its own verdict, the tier's
runs reused (checked against the full search on the table's cases: docs/validation/discover.md)."""

from __future__ import annotations

import math
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..params import Parameters
from .effects import EFFECTS, Effect
from .fitting import CandidateFit, chi2_quantile, lrt_threshold, select
from .models import unreached_mode_features
from .separability import bumped

FAST_KEEP = 3
"""Single candidates fitted in full: the best predicted."""

TIER_MARGIN = 20.0
"""The tier (:func:`tiered_singles`): a candidate predicted within this of the best fitted χ² is
fitted in full (the coarse scan's margin, :data:`.naming.SCREEN_MARGIN`)."""

TIER_KEEP = 4
"""The tier (:func:`tiered_singles`): at most this many single candidates fitted in full before the
answer goes to the full search. With the natural frequencies × 1.03 hidden (docs/validation/discover.md)
the detuning, predicted at χ² 53.4, fits at 3.44, and the scale it sets (:func:`tier_scale`, 0.064)
brings the mass, the com offset and the contact spacing within the margin: three fits leave the
spacing and send the answer to the full search (487 s CPU), the fourth settles it (258 s, the same
verdict)."""

TIER_SHARED = 3
"""The tier's fits in full that the full search keeps (the first by prediction,
:func:`.naming._fit_sets`): a fourth, made to settle the answer, enters the full search as its
coarse scan does, from the fit's cached runs, so the full search's verdict is that of a tier of
three fits."""

STEPS = 5.0
"""The linearised model's moves, ± this many relevance thresholds."""


def predict_singles(cands: Sequence[Effect], base: Parameters, resid: Dict[str, float], sig: Dict[str, float],
                    changes: Callable[[List[str], float], Dict[str, Dict[str, float]]],
                    counts: Optional[Dict[str, int]] = None) -> Dict[str, Tuple[float, float]]:
    """Each candidate's predicted best χ² and value: the feature changes of moves by ±:data:`STEPS`
    relevance thresholds (``changes(names, steps)``: raw changes from the baseline's run) give a
    quadratic per feature, Δ(x) = a x + c x² with x in units of the move; χ²(x) = Σ (r − Δ(x)/σ)²
    (``resid``: the data's residuals r from the baseline in units of ``sig``; a feature that a
    move loses counts r²) is minimised over 201 points of the candidate's search range. ``counts``:
    per operating point, how many of the baseline's ensemble runs end in the data's mode; where none
    does, the mode features there count as they are (the fitted χ² counts them as their expectation
    while a model misses the mode, and the baseline's run is in another mode: their changes from it
    are those of a different state, no signature of the candidate)."""
    names = [e.name for e in cands]
    up, down = changes(names, STEPS), changes(names, -STEPS)
    keys = [k for k in resid if sig.get(k, 0) > 0]
    off = unreached_mode_features(keys, counts)
    frozen = np.array([k in off for k in keys], dtype=bool)
    r = np.array([resid[k] for k in keys])
    out: Dict[str, Tuple[float, float]] = {}
    for e in cands:
        b = e.baseline_value(base)
        step = bumped(e, base, STEPS) - b
        dp = np.array([up.get(e.name, {}).get(k, math.nan) / sig[k] for k in keys])
        dm = np.array([down.get(e.name, {}).get(k, math.nan) / sig[k] for k in keys])
        ok = np.isfinite(dp) & np.isfinite(dm) & ~frozen
        a, c = (dp[ok] - dm[ok]) / 2, (dp[ok] + dm[ok]) / 2
        lo, hi = e.search if math.isfinite(e.search[0]) else (e.lower, e.upper)
        us = np.linspace(lo, hi, 201)
        vals = np.array([e.value(u, base) for u in us])
        xs = (vals - b) / step if step != 0 else np.zeros_like(vals)
        rest = float(np.sum(r[~ok] ** 2))
        chi2 = np.array([float(np.sum((r[ok] - a * x - c * x * x) ** 2)) + rest for x in xs])
        j = int(np.argmin(chi2))
        out[e.name] = (float(chi2[j]), float(vals[j]))
    return out


def predicted_singles(cands: Sequence[Effect], pred: Dict[str, Tuple[float, float]],
                      fit: Callable[[Effect], CandidateFit], n: int,
                      keep: Optional[set] = None) -> List[CandidateFit]:
    """The :data:`FAST_KEEP` best predicted candidates (or those named in ``keep``) fitted in full
    (``fit``), the others kept as screened fits at their predicted χ² and value (``linearised``), in
    the order of ``cands``."""
    if keep is None:
        keep = {e.name for e in sorted(cands, key=lambda e: pred[e.name][0])[:FAST_KEEP]}
    out = []
    for e in cands:
        if e.name in keep:
            out.append(fit(e))
            continue
        c2, v = pred[e.name]
        out.append(CandidateFit((e.name,), {e.name: v}, {e.name: math.inf}, c2, n - 1, c2 <= chi2_quantile(n - 1),
                                c2 + math.log(n), screened=True, linearised=True))
    return out


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


def best_single(singles: List[CandidateFit], reasons: Dict[Tuple[str, ...], list], chi2_0: float,
                n: int) -> Optional[CandidateFit]:
    """The single candidate the selection would name among those passing the naming rule (the
    baseline not adequate: the candidates are being fitted)."""
    return select([f for f in singles if not reasons[f.effects] and len(f.effects) == 1], chi2_0, n, False)[0]
