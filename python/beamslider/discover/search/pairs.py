"""Which sets of effects are fitted (docs/model.md §9.1, "Sets of effects"): the pairs that extend the
best single candidates and those the linearised model predicts to fit best."""

from __future__ import annotations

import itertools
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..effects import Effect
from ..options import DEFAULT
from ..result import CandidateFit


def rank_pairs(sens: Dict[str, Dict[str, float]], resid: Dict[str, float],
               frozen: Sequence[str] = ()) -> List[Tuple[Tuple[str, str], float]]:
    """Every pair of candidates with the χ² the linearised model predicts for its best fit:
    min over x of |r − S x|², S the two signatures (feature changes in units of the uncertainty per
    step, :func:`.separability.slider_sensitivities`) over the features both move, r the data's
    residuals from the baseline in the same units (features outside S count r²). ``frozen``:
    features counted as they are (the mode features of an operating point where no baseline run
    is in the data's mode: their changes are a mode switch, as in :mod:`.search.linearised`). Best first."""
    out = []
    skip = set(frozen)
    for a, b in itertools.combinations(sorted(sens), 2):
        keys = [k for k in resid if k in sens[a] and k in sens[b] and k not in skip]
        r = np.array([resid[k] for k in keys])
        A = np.column_stack([[sens[a][k] for k in keys], [sens[b][k] for k in keys]]) if keys else np.zeros((0, 2))
        rest = float(sum(v * v for k, v in resid.items() if k not in keys))
        if len(keys):
            x, *_ = np.linalg.lstsq(A, r, rcond=None)
            chi2 = float(np.sum((r - A @ x) ** 2)) + rest
        else:
            chi2 = rest
        out.append(((a, b), chi2))
    return sorted(out, key=lambda t: t[1])


def pairs_to_fit(cand_effects: Sequence[Effect], singles: List[CandidateFit], max_effects: int, level: str,
                 ranked: Optional[List[Tuple[Tuple[str, str], float]]] = None, extending: int = DEFAULT.extending_pairs,
                 guided: int = DEFAULT.guided_pairs) -> List[Tuple[Effect, ...]]:
    """The sets of 2..max_effects effects to fit: all at the beam level (cheap surrogate); at the
    slider and joint levels those that extend one of the two best singles, and (joint) every set
    of beam-level effects only (their slider part is one evaluation). ``ranked``: every pair with
    the χ² the linearised model predicts for it (:func:`rank_pairs`, slider level);
    then of the pairs that extend one of the two best singles only the
    ``extending`` (``DiscoverOptions.extending_pairs``) predicted best for each are fitted, and beside them the
    ``guided`` (``DiscoverOptions.guided_pairs``) predicted best overall."""
    top = [f.effects[0] for f in sorted(singles, key=lambda f: f.chi2)[:2]]
    out: List[Tuple[Effect, ...]] = []
    for k in range(2, max_effects + 1):
        if k == 2 and ranked is not None and level == "slider":
            want: List[frozenset] = []
            for t in top:
                want += [frozenset(p) for p, _ in ranked if t in p][:extending]
            want += [frozenset(p) for p, _ in ranked[:guided]]
            for combo in itertools.combinations(cand_effects, 2):
                if frozenset(e.name for e in combo) in want:
                    out.append(combo)
            continue
        for combo in itertools.combinations(cand_effects, k):
            names = {e.name for e in combo}
            if level == "beam" or set(top) & names or (level == "joint" and all(e.level == "beam" for e in combo)):
                out.append(combo)
    return out
