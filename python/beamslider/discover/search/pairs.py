"""Which sets of effects are fitted (docs/model.md §9.1, "Sets of effects"): the pairs that extend the
best single candidates and those the linearised model predicts to fit best."""

from __future__ import annotations

import itertools
from typing import List, Optional, Sequence, Tuple

from ..effects import Effect
from ..options import DEFAULT
from ..result import CandidateFit


def pairs_to_fit(cand_effects: Sequence[Effect], singles: List[CandidateFit], max_effects: int, level: str,
                 ranked: Optional[List[Tuple[Tuple[str, str], float]]] = None, extending: int = DEFAULT.extending_pairs,
                 guided: int = DEFAULT.guided_pairs) -> List[Tuple[Effect, ...]]:
    """The sets of 2..max_effects effects to fit: all at the beam level (cheap surrogate); at the
    slider and joint levels those that extend one of the two best singles, and (joint) every set
    of beam-level effects only (their slider part is one evaluation). ``ranked``: every pair with
    the χ² the linearised model predicts for it (:func:`.separability.rank_pairs`, slider level);
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
