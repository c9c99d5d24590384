"""The beam-level search (docs/model.md §9): every single candidate and every set of up to
``max_effects`` fitted by least squares on the surrogate (cheap); where the selection picks one, the
surrogate's bias correction is re-centred at it and every set fitted again."""

from __future__ import annotations

from typing import Any, List, Sequence

from ..effects import EFFECTS, Effect
from ..options import DiscoverOptions
from ..result import CandidateFit
from ..rule import select
from .common import Fitter, fit_sets, singles_in_full


def fit_all(problem: Any, fit: Fitter, candidates: Sequence[Effect], options: DiscoverOptions) -> List[CandidateFit]:
    """Every single candidate and every set of up to ``problem.max_effects`` of them, with ``fit``."""
    fits = singles_in_full(fit, candidates)
    return fits + fit_sets(problem, fit, candidates, fits, options, gated=False, level="beam")


def search(problem: Any, candidates: Sequence[Effect], options: DiscoverOptions) -> List[CandidateFit]:
    """The beam-level search of ``candidates`` (module docs)."""
    with Fitter(problem, candidates) as fit:
        fits = fit_all(problem, fit, candidates, options)
    best0, _ = select(fits, problem.chi2_0, problem.n, problem.baseline_fits, options.significance)
    if best0 is None:
        return fits
    problem.refit_beam_bias(fits)
    return [problem.fit([EFFECTS[e] for e in f.effects]) for f in fits]
