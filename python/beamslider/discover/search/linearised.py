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

from ...params import Parameters
from ..effects import Effect
from ..models import unreached_mode_features
from ..result import CandidateFit
from ..separability import bumped
from ..stats import chi2_quantile


FAST_KEEP = 3
"""Single candidates fitted in full: the best predicted."""


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
