"""The naming rule (docs/model.md §9, §9.1): why a fitted set may not be named, the forward selection
by likelihood-ratio tests, and the verdict where nothing is named."""

from __future__ import annotations

from enum import Enum
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

from ..params import Parameters
from .effects import EFFECTS
from .result import CandidateFit
from .search.sets import SCREEN_MARGIN
from .stats import chi2_quantile, excess, interval_of, lrt_threshold


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


def judge(fits: Sequence[CandidateFit], base: Parameters, n: int, excess_before: float,
          gap_ratio: float, threshold: Optional[float] = None) -> Reasons:
    """The naming rule per fitted set: the reasons it may not be named (empty: it may). Not
    adequate (χ² > χ²₀.₉₉(n − k)); a parameter moved by less than its relevance threshold; a
    small share of the gap beyond the noise (:func:`excess`: sqrt(max(χ² − (n − k), 0)/n) >
    gap_ratio × the baseline's sqrt(max(χ²₀ − n, 0)/n)); a parameter whose interval contains its
    baseline value (not resolved, :func:`.rule.unresolved_reasons`); with ``threshold`` (the
    selection's price of a parameter), a negligible change that fits as well
    (:func:`.rule.beaten_by_negligible`)."""
    out: Reasons = {}
    for f in fits:
        reasons: List[Reason] = []
        if f.screened:
            reasons.append(Reason(Why.SCREENED, f"screened out: its coarse scan's chi2 = {f.chi2:.3g} is more than "
                                                f"{SCREEN_MARGIN:g} above the best coarse chi2 (not fitted in full)"
                                  if not f.linearised else f"screened out: the linearised model predicts chi2 = "
                                                           f"{f.chi2:.3g}, not among those fitted in full"))
        elif not f.adequate:
            reasons.append(Reason(Why.NOT_ADEQUATE, f"not adequate: chi2 = {f.chi2:.3g} > chi2_0.99({f.dof}) = "
                                                    f"{chi2_quantile(f.dof):.3g}"))
        for e in f.effects:
            ok, how = EFFECTS[e].relevant(f.values[e], base)
            if not ok:
                reasons.append(Reason(Why.NEGLIGIBLE, f"negligible change of {EFFECTS[e].field}: {how}", e))
        g = excess(f.chi2, f.dof, n)
        if g > gap_ratio * excess_before:
            reasons.append(Reason(Why.SMALL_SHARE, f"small share of the gap beyond the noise: {excess_before:.3g} -> "
                                                   f"{g:.3g} (more than {gap_ratio:g} x)"))
        reasons += unresolved_reasons(f, base)
        out[f.effects] = reasons
    return out if threshold is None else beaten_by_negligible(fits, out, threshold)


def select(fits: List[CandidateFit], chi2_0: float, n: int,
           fits_baseline: Optional[bool] = None) -> Tuple[Optional[CandidateFit], List[Tuple[str, ...]]]:
    """Nothing if the baseline is adequate (``fits_baseline``; None: χ² ≤ χ²_0.99(n)); else forward
    selection by likelihood-ratio tests: the best single effect must beat the baseline, and the
    best larger set containing the current choice must beat it, by more than :func:`lrt_threshold`
    (99 %, corrected for the number of sets the best was picked from)."""
    if fits_baseline is None:
        fits_baseline = chi2_0 <= chi2_quantile(n)
    if fits_baseline or not fits:
        return None, []
    by_size: Dict[int, List[CandidateFit]] = {}
    for f in fits:
        by_size.setdefault(len(f.effects), []).append(f)
    best: Optional[CandidateFit] = None
    best_chi2, best_k = chi2_0, 0
    for k in sorted(by_size):
        pool = [c for c in by_size[k] if best is None or set(best.effects) <= set(c.effects)]
        if not pool:
            continue
        top = min(pool, key=lambda c: c.chi2)
        if best_chi2 - top.chi2 > lrt_threshold(k - best_k, len(pool)):
            best, best_chi2, best_k = top, top.chi2, k
        else:
            break
    if best is None:
        return None, []
    alts = [c.effects for c in by_size[len(best.effects)] if c.effects != best.effects and c.chi2 - best.chi2 < 2.0]
    return best, alts


def no_set_can_win(singles: List[CandidateFit], judge: Callable[[List[CandidateFit]], Reasons]) -> bool:
    """Whether fitting sets is pointless: a single candidate passes the naming rule with a χ²
    below the least likelihood-ratio threshold for adding an effect (:func:`.stats.lrt_threshold`
    with m = 1, 6.63): the selection would name it, and no set (χ² ≥ 0) can beat it by the threshold."""
    reasons = judge(singles)
    ok = [f for f in singles if not reasons[f.effects]]
    return bool(ok) and min(f.chi2 for f in ok) <= lrt_threshold(1, 1)


def best_single(singles: List[CandidateFit], reasons: Dict[Tuple[str, ...], list], chi2_0: float,
                n: int) -> Optional[CandidateFit]:
    """The single candidate the selection would name among those passing the naming rule (the
    baseline not adequate: the candidates are being fitted)."""
    return select([f for f in singles if not reasons[f.effects] and len(f.effects) == 1], chi2_0, n, False)[0]


def unresolved_reasons(f: CandidateFit, base: Parameters) -> List[Reason]:
    """A reason per parameter of ``f`` whose interval (:func:`interval_of`) contains its baseline
    value: the data do not resolve that change (empty: all resolved)."""
    out = []
    for e in f.effects:
        lo, hi = interval_of(f, e)
        b = EFFECTS[e].baseline_value(base)
        if lo <= b <= hi:
            out.append(Reason(Why.NOT_RESOLVED, f"not resolved: the interval [{lo:.4g}, {hi:.4g}] of {EFFECTS[e].field} "
                                                f"contains the baseline {b:.4g}", e))
    return out


def negligible_fits(fits: Sequence[CandidateFit], reasons: Reasons) -> List[CandidateFit]:
    """Adequate sets whose every parameter moved by a negligible amount and that close the gap as
    a named set must (no small share of the gap beyond the noise; their only other reason an
    unresolved interval): the data are explained without a physically relevant change, if no
    relevant change is resolved (:func:`relevant_resolved`) or fits clearly better unresolved
    (:func:`unnamed_verdict`). A negligible change that leaves more of the gap than the naming rule
    allows explains no more than the baseline does (docs/model.md §9.1, "Resolved")."""
    return [f for f in fits if reasons[f.effects] and f.adequate and not f.screened
            and all(any(getattr(r, "kind", None) is Why.NEGLIGIBLE and r.effect == e for r in reasons[f.effects])
                    for e in f.effects)
            and kinds(reasons[f.effects]) <= {Why.NEGLIGIBLE, Why.NOT_RESOLVED}]


def beaten_by_negligible(fits: Sequence[CandidateFit], reasons: Reasons, threshold: float) -> Reasons:
    """``reasons`` with one more for each set that passes the naming rule but fits no better than
    the best negligible change (:func:`negligible_fits`), each set's χ² charged ``threshold`` per
    fitted parameter (the selection's price of a parameter, as in :func:`unnamed_verdict`): the data
    do not prefer that relevant change to the baseline's neighbourhood, so it is not named
    (docs/model.md §9.1, "Resolved"). A relevant change that a set with less than a relevance
    threshold's change fits better is the wrong effect standing in for one the data barely see."""
    negl = min(negligible_fits(fits, reasons), key=lambda f: f.chi2 + threshold * len(f.effects), default=None)
    if negl is None:
        return reasons
    bar = negl.chi2 + threshold * len(negl.effects)
    vals = ", ".join(f"{EFFECTS[e].field} {v:.4g}" for e, v in negl.values.items())
    out = dict(reasons)
    for f in fits:
        if not reasons[f.effects] and f.chi2 + threshold * len(f.effects) >= bar:
            out[f.effects] = [Reason(Why.NEGLIGIBLE_FITS_BETTER, f"a negligible change fits better: {vals} "
                                     f"(chi2 {negl.chi2:.3g} against {f.chi2:.3g}, each charged {threshold:.3g} "
                                     f"per parameter)")]
    return out


def relevant_resolved(fits: Sequence[CandidateFit], reasons: Reasons) -> List[CandidateFit]:
    """Adequate sets, fitted in full, whose every parameter moved by a relevant amount and whose
    every interval (:func:`interval_of`) excludes the baseline, best first: the data resolve a
    relevant change away from the baseline. Then a negligible change that also fits
    (:func:`negligible_fits`) does not make the baseline adequate — a chaotic realisation near the
    baseline that happens to fit is not evidence against a change the data resolve — and the
    verdict is not "none" (docs/model.md §9.1, "Resolved")."""
    out = [f for f in fits if f.adequate and not f.screened
           and not kinds(reasons[f.effects]) & {Why.NEGLIGIBLE, Why.NOT_RESOLVED, Why.SCREENED, Why.NOT_ADEQUATE}]
    return sorted(out, key=lambda f: f.chi2)


def relevant_unresolved(fits: Sequence[CandidateFit], reasons: Reasons) -> List[CandidateFit]:
    """Adequate sets, fitted in full, whose every parameter moved by a relevant amount but whose
    interval contains the baseline for at least one of them, best first."""
    out = [f for f in fits if f.adequate and not f.screened and Why.NOT_RESOLVED in kinds(reasons[f.effects])
           and Why.NEGLIGIBLE not in kinds(reasons[f.effects])]
    return sorted(out, key=lambda f: f.chi2)


def unnamed_verdict(fits: Sequence[CandidateFit], reasons: Reasons, threshold: float
                    ) -> Tuple[str, Optional[CandidateFit], Optional[CandidateFit]]:
    """The verdict where the baseline does not fit and no set is named or confounded: ("none", the
    negligible fit, None) — the data are explained without a physically relevant change — or
    ("unexplained", None, the best relevant but unresolved set or None). A negligible fit gives
    "none" only if no relevant change is resolved (:func:`relevant_resolved`) and no relevant but
    unresolved set fits clearly better: with each set's χ² charged ``threshold`` per fitted
    parameter (the selection's likelihood-ratio threshold for one effect picked from the
    candidates, :func:`.stats.lrt_threshold`: the price at which the forward selection adds a
    parameter), the unresolved set beats the best negligible one by more than ``threshold``. Then
    the data prefer that change to the baseline's neighbourhood at the significance that would name
    it, though they do not locate it well enough to exclude the baseline — "unexplained, best
    candidate X, not resolved by these runs" (docs/model.md §9.1, "Resolved")."""
    if relevant_resolved(fits, reasons):
        return "unexplained", None, None

    def charged(f: CandidateFit) -> float:
        return f.chi2 + threshold * len(f.effects)

    unres = min(relevant_unresolved(fits, reasons), key=charged, default=None)
    negl = min(negligible_fits(fits, reasons), key=charged, default=None)
    if negl is not None and not (unres is not None and charged(negl) - charged(unres) > threshold):
        return "none", negl, None
    return "unexplained", None, unres
