"""Why a fitted set is not named: each reason's kind (:class:`Why`) with its text (docs/model.md §9.1,
"Resolved": ``report.json`` ``kinds``); the rule (:mod:`.rule`) reads the kinds."""

from __future__ import annotations

from enum import Enum
from typing import Any, Dict, List, Optional, Sequence, Tuple


class Why(str, Enum):
    """The kind of a reason why a fitted set may not be named (:class:`Reason`); the verdict's logic
    reads these, the report shows the reasons' text."""

    SCREENED = "screened out"
    """Only its coarse scan was made (:data:`.search.sets.SCREEN_MARGIN`)."""
    NOT_ADEQUATE = "not adequate"
    """χ² > χ²₀.₉₉(n − k)."""
    NEGLIGIBLE = "negligible change"
    """A parameter moved by less than its relevance threshold."""
    SMALL_SHARE = "small share of the gap"
    """The gap beyond the noise shrinks too little (in the fit, or in the full simulation)."""
    NOT_RESOLVED = "not resolved"
    """A parameter's interval contains its baseline value (:func:`unresolved_reasons`)."""
    NEGLIGIBLE_FITS_BETTER = "a negligible change fits better"
    """A negligible change (:func:`negligible_fits`) fits at least as well, each charged the
    selection's threshold per parameter (:func:`beaten_by_negligible`)."""
    POOR_FIT = "does not fit as right models do"
    """The full simulation of the set leaves a χ² above the goodness-of-fit bound
    (:func:`.stats.gof_bound`) that right models keep below."""
    OUTSIDE_FITS_BETTER = "an effect not among the candidates fits better"
    """An effect of the library the user left out of the candidates fits clearly better
    (:func:`outside_fits_better`)."""


class Reason(str):
    """One reason a fitted set may not be named: its text (what the report shows, starting with
    the kind's words), its :class:`Why` and the effect it concerns (None: the whole set)."""

    kind: Why
    effect: Optional[str]

    def __new__(cls, kind: Why, text: str, effect: Optional[str] = None) -> "Reason":
        obj = super().__new__(cls, text)
        obj.kind, obj.effect = kind, effect
        return obj

    def __reduce__(self):
        return (Reason, (self.kind, str(self), self.effect))


Reasons = Dict[Tuple[str, ...], List[Reason]]


def kinds(reasons: Sequence[Any]) -> set:
    """The :class:`Why` of each reason (a plain string, e.g. from a report file, has none)."""
    return {getattr(r, "kind", None) for r in reasons} - {None}
