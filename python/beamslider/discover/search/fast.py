"""The fast path of the slider-level naming (opt-in, ``discover(search="fast")``; docs/model.md §9.1,
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
:func:`.tiered.tiered_singles`, :func:`.common.no_pair_gains`): where the tier settles the answer the coarse scans
and the pairs are skipped; elsewhere the full search runs and gives its own verdict, the tier's
runs reused (checked against the full search on the table's cases: docs/validation/discover.md)."""

from __future__ import annotations

from typing import Any, List, Sequence

from ..effects import Effect
from ..options import DiscoverOptions
from ..result import CandidateFit
from .common import Fitter, fit_sets, predicted_singles, singles_in_full


def search(problem: Any, candidates: Sequence[Effect], options: DiscoverOptions) -> List[CandidateFit]:
    """The fast search of ``candidates``: ``options.fast_keep`` singles fitted in full by prediction, at
    most the pair predicted best (module docs); with ``options.screen_from`` candidates or fewer,
    as the full search."""
    with Fitter(problem, candidates) as fit:
        if len(candidates) <= options.screen_from:
            fits = singles_in_full(fit, candidates)
            return fits + fit_sets(problem, fit, candidates, fits, options)
        fits = predicted_singles(candidates, problem.predict(candidates), lambda e: fit((e,)), len(problem.meas),
                                 fast_keep=options.fast_keep, alpha=options.significance)
        fit.bar.update(len(candidates))
        return fits + fit_sets(problem, fit, candidates, fits, options, only_best_predicted=True)
