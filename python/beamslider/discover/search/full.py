"""The full search, ``search="full"`` (docs/model.md §9.1, "Cost"): with more than
``options.screen_from`` candidates each is first scanned coarsely and fitted in full only near the
best; then the sets (pairs ranked by the linearised model), unless a single candidate cannot be
beaten."""

from __future__ import annotations

from typing import Any, Dict, List, Optional, Sequence

from ..effects import Effect
from ..options import DiscoverOptions
from ..result import CandidateFit
from .common import Fitter, coarse_singles, fit_sets, singles_in_full


def search(problem: Any, candidates: Sequence[Effect], options: DiscoverOptions) -> List[CandidateFit]:
    """The full search of ``candidates`` (module docs)."""
    with Fitter(problem, candidates) as fit:
        return scan(problem, fit, candidates, options)


def scan(problem: Any, fit: Fitter, candidates: Sequence[Effect], options: DiscoverOptions,
         kept: Optional[Dict[str, CandidateFit]] = None) -> List[CandidateFit]:
    """The full search with ``fit``; ``kept``: fits in full (the tier's) that stand for their coarse
    scans (:func:`.common.coarse_singles`)."""
    if len(candidates) > options.screen_from:
        fits = coarse_singles(fit, candidates, options, kept)
    else:
        fits = singles_in_full(fit, candidates)
    return fits + fit_sets(problem, fit, candidates, fits, options)
