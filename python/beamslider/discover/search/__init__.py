"""The search strategies (docs/model.md §9.1, "Cost"): which candidate sets are fitted and how. One
module per strategy, each ``search(problem, candidates, options) -> list[CandidateFit]``: at the
slider level :mod:`.tiered` (the default), :mod:`.full` and :mod:`.fast`; the beam level
:mod:`.beam`, both levels together :mod:`.joint`. What they share is :mod:`.common` (the fits with
their progress, the coarse scans, the sets and the tier's gate) and :mod:`.pairs` (which pairs).
They judge nothing: the rule (:mod:`..rule`) decides the verdict from their fits; they ask it only
whether to go on (a set that could not be selected is not fitted)."""

from __future__ import annotations

from typing import Any, Callable, Dict, List, Sequence

from ..effects import Effect
from ..options import DiscoverOptions
from ..result import CandidateFit
from . import beam, fast, full, joint, tiered
from .common import adopt_set_valleys

Strategy = Callable[[Any, Sequence[Effect], DiscoverOptions], List[CandidateFit]]
"""``search(problem, candidates, options)``: the fits of single candidates and sets."""

STRATEGIES: Dict[str, Strategy] = {"tiered": tiered.search, "full": full.search, "fast": fast.search}
"""The slider level's strategies by name (``discover(search=...)``, ``--search``)."""


def strategy_of(search: str, fast_: bool = False) -> str:
    """The strategy's name (``fast_``: ``"fast"``), checked."""
    if search not in STRATEGIES:
        raise ValueError(f"invalid search = {search!r}: give 'tiered', 'full' or 'fast'")
    return "fast" if fast_ else search


def run(problem: Any, strategy: str) -> List[CandidateFit]:
    """The fits of ``problem``'s candidates: by ``strategy`` at the slider level, else by the level's
    own search."""
    by_level = {"beam": beam.search, "joint": joint.search}
    search = by_level.get(problem.level, STRATEGIES[strategy])
    fits = search(problem, problem.candidates, problem.options)
    return adopt_set_valleys(problem, fits) if problem.level == "slider" else fits
