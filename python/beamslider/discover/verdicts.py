"""What the data resolve: a candidate's interval must exclude the baseline before it is named,
candidates the data cannot tell apart are reported as a group (``confounded``), and the
separability tool's advice says which measurement would resolve or separate them
(docs/guide/discrepancy.md, "Naming rule")."""

from __future__ import annotations

import itertools
import math
from enum import Enum
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from ..params import Parameters
from .effects import EFFECTS, Effect
from .fitting import CandidateFit, interval_z
from .models import OperatingPoint


CONFOUND_COS = 0.95
"""|cos θ| of the feature changes of two single fits from which they enter the model through one
combination (the separability tool's threshold, :func:`.separability.separability`)."""


ADVICE_GRID: Tuple[Tuple[float, float, float], ...] = tuple(
    (f, a, s0) for s0 in (0.3, 0.15)
    for f, a in ((104.0, 14.0), (110.0, 10.0), (116.0, 10.0), (120.0, 6.0), (124.0, 6.0), (124.0, 14.0), (126.0, 10.0)))
"""Operating points (f_ex Hz, a_ex m/s², s0) among which the advice looks for the measurement that
resolves or separates candidates (those already measured are left out): seven points of the
paper's map from its s0 = 0.3, and the same from s0 = 0.15, nearer the clamping, where the slider
ends elsewhere on the beam (what the runs from 0.3 pin at one position, as a camera's offset
against its scale, separates there); a point where a run ends at the clamping is skipped
(:data:`CLAMP_CLEARANCE`)."""


def interval_of(f: CandidateFit, e: str) -> Tuple[float, float]:
    """The :data:`.fitting.INTERVAL_LEVEL` (95 %) interval of parameter ``e`` in fit ``f`` that
    the report shows and that must exclude the baseline (docs/model.md §9.1): slider level, the
    profile's Δχ² = z² interval widened by its roughness (one effect, :func:`.fitting._interval`)
    or the joint fit's Wald interval (several, :func:`.refine.gauss_newton`); else the value ±
    z standard errors (the smooth least-squares fits of the beam level)."""
    if e in f.intervals:
        lo, hi = f.intervals[e]
        return float(lo), float(hi)
    v, se = f.values[e], f.stderrs.get(e, math.inf)
    z = interval_z()
    return (v - z * se, v + z * se) if math.isfinite(se) else (-math.inf, math.inf)


class Why(str, Enum):
    """The kind of a reason why a fitted set may not be named (:class:`Reason`); the verdict's logic
    reads these, the report shows the reasons' text."""

    SCREENED = "screened out"
    """Only its coarse scan was made (:data:`.naming.SCREEN_MARGIN`)."""
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
    candidates, :func:`.fitting.lrt_threshold`: the price at which the forward selection adds a
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


def signature(f: CandidateFit, before: Dict[str, float], sig: Dict[str, float]) -> Dict[str, float]:
    """The feature changes of fit ``f`` from the baseline (``before``), in units of ``sig``."""
    return {k: (f.predicted[k] - before[k]) / sig[k] for k in sig
            if k in f.predicted and k in before and math.isfinite(f.predicted[k]) and sig[k] > 0}


def cosine(a: Dict[str, float], b: Dict[str, float]) -> Tuple[float, float, float]:
    """cos θ between two signatures over their common features, and their norms."""
    keys = [k for k in a if k in b]
    x, y = np.array([a[k] for k in keys]), np.array([b[k] for k in keys])
    na, nb = float(np.linalg.norm(x)), float(np.linalg.norm(y))
    return (float(x @ y / (na * nb)) if na > 0 and nb > 0 else 0.0), na, nb


def confounded_group(best: CandidateFit, fits: Sequence[CandidateFit], reasons: Reasons,
                     before: Dict[str, float], sig: Dict[str, float], base: Parameters,
                     delta_chi2: float) -> Optional[Dict[str, Any]]:
    """The candidates that fit as well as the single effect ``best`` — each passing the naming rule
    alone, χ² within ``delta_chi2`` of it (the selection's likelihood-ratio threshold: the data do
    not prefer one at the significance that named it) — because they move the features alike
    (|cos θ| ≥ :data:`CONFOUND_COS` between the fits' feature changes): then the data resolve one
    combination of them, not which one. None if there is no such candidate."""
    if len(best.effects) != 1:
        return None
    s0 = signature(best, before, sig)
    members = [best]
    cos: Dict[str, float] = {}
    for f in fits:
        if len(f.effects) != 1 or f.effects == best.effects or reasons.get(f.effects):
            continue
        if f.chi2 - best.chi2 > delta_chi2:
            continue
        c, _, _ = cosine(s0, signature(f, before, sig))
        if abs(c) >= CONFOUND_COS:
            members.append(f)
            cos[f.effects[0]] = c
    if len(members) < 2:
        return None
    terms = []
    for f in members:
        e = f.effects[0]
        b = EFFECTS[e].baseline_value(base)
        terms.append(f"({EFFECTS[e].field} - {b:.4g})/({f.values[e] - b:+.4g})")
    return dict(group=[f.effects[0] for f in members], cos=cos,
                chi2={f.effects[0]: f.chi2 for f in members},
                values={f.effects[0]: f.values[f.effects[0]] for f in members},
                intervals={f.effects[0]: list(interval_of(f, f.effects[0])) for f in members},
                combination=" + ".join(terms) + " = 1",
                explanation="each alone fits equally and moves the features alike (linearised: cos of the "
                            "feature changes " + ", ".join(f"{best.effects[0]}/{k} {v:+.3f}" for k, v in cos.items())
                            + "); the data resolve the combination, in which a change of any one of them "
                              "by its fitted amount explains the data, not which of them changed")


def _rho2(v: np.ndarray, cols: List[np.ndarray]) -> Tuple[float, np.ndarray]:
    """min over x of |v − A x|², A the columns ``cols``, and the minimiser."""
    A = np.column_stack(cols)
    x = np.linalg.lstsq(A, v, rcond=None)[0]
    return float(np.sum((v - A @ x) ** 2)), x


CONFIRM_SINGLES = 2
"""Of the single effects outside the fitted ones that the linearised model puts within the
threshold of a named set (:func:`confounded_sets`), this many (the closest) are fitted in full."""


def confounded_sets(best: CandidateFit, fits: Sequence[CandidateFit], reasons: Reasons, before: Dict[str, float],
                    sig: Dict[str, float], base: Parameters, delta_chi2: float, library: Sequence[str],
                    changes: Callable[[List[str]], Dict[str, Dict[str, float]]],
                    confirm: Callable[[str], Tuple[CandidateFit, List[Any]]],
                    candidates: Optional[Sequence[str]] = None) -> Optional[Dict[str, Any]]:
    """The single effects and fitted sets of no more effects than the set ``best`` (two or more)
    that fit as well as it by moving the features as its fit does (docs/model.md §9.1,
    "Confounded"): then the data resolve that change, not which of them made it, and ``best`` is
    not named. A fitted set (``fits``) is such a set if it passes the naming rule (no
    ``reasons``), fits within ``delta_chi2`` of ``best`` and moves the features alike (|cos θ| ≥
    :data:`CONFOUND_COS`). A single effect of the ``library`` (the level's effects, candidates or
    not) that was not fitted is first screened in the linearised model: it may reproduce the fitted
    change d of ``best`` within ``delta_chi2`` of how well ``best``'s own signatures do,
    min_y |d − s y|² ≤ min_x |d − S_B x|² + ``delta_chi2`` (S the feature changes of a move by five
    relevance thresholds, ``changes(names)``, in units of ``sig``); the :data:`CONFIRM_SINGLES`
    closest are fitted in full (``confirm(name)``: the fit and the naming rule's reasons) and
    judged as the fitted sets. ``candidates``: the effects the user suspects; the others are
    listed as ``not_candidates``. None if there is no such set."""
    if len(best.effects) < 2:
        return None
    d = signature(best, before, sig)
    fitted = {frozenset(f.effects): f for f in fits}
    own = frozenset(best.effects)
    singles = [e for e in library if frozenset((e,)) not in fitted and e not in own]
    screened: List[Tuple[float, str]] = []
    if singles:
        raw = changes(sorted(set(singles) | own))
        sig_of = {e: {k: v / sig[k] for k, v in raw.get(e, {}).items() if k in sig and sig[k] > 0} for e in raw}
        for e in singles:
            if not sig_of.get(e) or any(not sig_of.get(b) for b in own):
                continue  # a run of a moved model failed: no signature
            keys = [k for k in d if k in sig_of[e] and all(k in sig_of[b] for b in own)]
            if len(keys) <= len(own):
                continue
            v = np.array([d[k] for k in keys])
            r_own, _ = _rho2(v, [np.array([sig_of[b][k] for k in keys]) for b in best.effects])
            r_e, _ = _rho2(v, [np.array([sig_of[e][k] for k in keys])])
            if r_e <= r_own + delta_chi2:
                screened.append((r_e, e))
    extra = {}
    for _, e in sorted(screened)[:CONFIRM_SINGLES]:
        f, why = confirm(e)
        extra[f.effects] = why
        fitted[frozenset(f.effects)] = f
    found: List[Tuple[CandidateFit, str]] = []
    for c, f in fitted.items():
        if c == own or len(c) > len(own):
            continue
        if {**reasons, **extra}.get(f.effects) or f.chi2 - best.chi2 > delta_chi2:
            continue
        cs, _, _ = cosine(d, signature(f, before, sig))
        if abs(cs) >= CONFOUND_COS:
            found.append((f, f"chi2 {f.chi2:.3g}, cos {cs:+.3f}" + (" (fitted to confirm the linearised model)"
                                                                    if f.effects in extra else "")))
    if not found:
        return None

    def says(f: CandidateFit) -> str:
        return " with ".join(f"{EFFECTS[e].field} {EFFECTS[e].baseline_value(base):.4g} -> {f.values[e]:.4g}"
                             for e in f.effects)

    group = list(dict.fromkeys(list(best.effects) + [e for f, _ in found for e in f.effects]))
    outside = [e for e in group if candidates is not None and e not in candidates]
    # Whether the candidates themselves hold another set that fits alike; if every such set needs an
    # effect the user did not suspect, the candidates leave the data unexplained.
    among = any(all(e not in outside for e in f.effects) for f, _ in found)
    return dict(group=group, sets=[list(best.effects)] + [list(f.effects) for f, _ in found], not_candidates=outside,
                among_candidates=among,
                models=[{e: f.values[e] for e in f.effects} for f in [best] + [g for g, _ in found]],
                values={**{e: g.values[e] for g, _ in found for e in g.effects},
                        **{e: best.values[e] for e in best.effects}},
                chi2={"+".join(f.effects): f.chi2 for f in [best] + [g for g, _ in found]},
                combination=" = ".join(f"({says(f)})" for f in [best] + [g for g, _ in found]),
                explanation="the set " + " + ".join(best.effects) + " fits as well as "
                            + "; as ".join(" + ".join(f.effects) + f" ({h})" for f, h in found)
                            + ", moving the measured features alike; the data resolve that change of the features, "
                              "not which of them made it"
                            + (f" ({', '.join(outside)}: not among the candidates)" if outside else ""))


def outside_fits_better(best: CandidateFit, predicted: Dict[str, Tuple[float, float]],
                        confirm: Callable[[str], Tuple[CandidateFit, List[Any]]], threshold: float,
                        keep: int = CONFIRM_SINGLES) -> Optional[Reason]:
    """A reason not to name the set ``best`` of the candidates: a single effect of the library that
    is not among them fits the data better by more than ``threshold`` (the selection's price of a
    parameter), each set's χ² charged ``threshold`` per parameter — χ²_X + t < χ²_best + k t − t —
    and passes the naming rule alone; then the data prefer that effect to the candidates' set at
    the significance that would name it, and the candidates do not establish their change
    (docs/model.md §9.1, "Outside the candidates"). ``predicted``: each left-out effect's best χ²
    and value by the linearised model (:func:`.fast.predict_singles`); the ``keep`` best predicted
    are fitted in full (``confirm(name)``: the fit and the naming rule's reasons). None if none
    does. Only effects the library holds are tried: an effect outside it may still be mimicked."""
    bar = best.chi2 + (len(best.effects) - 2) * threshold
    better = []
    for name in sorted(predicted, key=lambda x: predicted[x][0])[:keep]:
        f, why = confirm(name)
        if not why and f.chi2 < bar:
            better.append(f)
    if not better:
        return None
    f = min(better, key=lambda g: g.chi2)
    (e,) = f.effects
    lo, hi = interval_of(f, e)
    return Reason(Why.OUTSIDE_FITS_BETTER,
                  f"an effect not among the candidates fits better: {EFFECTS[e].field} {f.values[e]:.4g} "
                  f"[{lo:.4g}, {hi:.4g}] ({e}: chi2 {f.chi2:.3g} against {best.chi2:.3g}, each charged "
                  f"{threshold:.3g} per parameter); the candidates do not establish their change")


def advise(names: Sequence[str], base: Parameters, ops: Sequence[OperatingPoint],
           grid: Sequence[Tuple[float, float, float]], *, threads: Optional[int] = None,
           on_point: Optional[Callable[[], None]] = None,
           fitted: Optional[Union[Dict[str, float], Sequence[Dict[str, float]]]] = None, cache=None) -> Dict[str, Any]:
    """The separability tool's advice for candidates the data did not resolve (one name) or
    separate (several): the signatures (:func:`.separability.slider_sensitivities`, features in
    units of their uncertainty for a change of 5 relevance thresholds) at each point of ``grid``
    not yet measured, at the measured points' duration; the point where one candidate moves the
    features most, or where two separate best (min(|z₁|, |z₂|)·sin θ), is recommended.
    ``fitted``: for a confounded group, each member's fitted value (or each member set's values);
    the separation is then the distance between the features of the fitted models
    (:func:`fitted_differences`), which stays right where the linearised signatures do not (a large
    change of one mimicking another).
    ``on_point``: called after the measured points and after each grid point (progress).
    ``cache``: a run cache (:func:`.models.batch_slider_features`)."""
    from .separability import slider_sensitivities

    measured = {(op.f_ex, op.a_ex, op.s0) for op in ops}
    points = [g for g in grid if tuple(g) not in measured]
    duration = max(op.duration_s for op in ops)
    if not points:
        return dict(names=list(names), recommended=None, note="every point of the grid is measured already")
    def score_at(where: Sequence[OperatingPoint], clearance: Optional[float] = None) -> Optional[float]:
        if fitted:
            diffs = fitted_differences(fitted, base, where, threads=threads, clearance=clearance, cache=cache)
            return None if diffs is None else _score_fitted(diffs)
        return _score(names, slider_sensitivities(names, base, where, threads=threads, cache=cache))

    now = score_at(ops)
    if on_point is not None:
        on_point()
    best: Optional[Tuple[Tuple[float, float, float], float]] = None
    for g in points:
        score = score_at([OperatingPoint(*g, duration)], CLAMP_CLEARANCE)
        if on_point is not None:
            on_point()
        if score is not None and (best is None or score > best[1]):
            best = (g, score)
    if best is None:
        return dict(names=list(names), recommended=None,
                    note="at every point of the grid not yet measured a run ends at the clamping")
    what = ("distance between the fitted models' features" if fitted else
            "signature norm" if len(names) == 1 else "separation min(|z1|, |z2|) sin(theta)")
    weak = bool(fitted) and best[1] < WEAK_SEPARATION
    lead = ("no run of the grid separates them by " + f"{WEAK_SEPARATION:g} uncertainties; the best, a run at "
            if weak else "add a run at ")
    return dict(names=list(names), measure=what, at_measured_points=now, weak=weak,
                recommended=dict(f_ex=best[0][0], a_ex=best[0][1], s0=best[0][2], duration_s=duration,
                                 score=best[1]),
                text=f"{lead}f_ex = {best[0][0]:g} Hz, a_ex = {best[0][1]:g} m/s^2, s0 = {best[0][2]:g} "
                     f"({duration:g} s): {what} {best[1]:.3g}"
                     + ("" if fitted else " for a change of 5 relevance thresholds")
                     + f", against {now:.3g} at the measured points")


WEAK_SEPARATION = 2.0
"""Distance (units of the uncertainty) between two fitted models' features at one run below which
the advice says that no run of its grid separates them: such a run adds less than 4 to the χ² of
the wrong one."""


CLAMP_CLEARANCE = 0.01
"""Advice skips a grid point where a run of the baseline or of a fitted model ends with a contact
point of the slider closer than this (fraction of L) to a clamping: there the slider sits at the
end of the modelled free length, and a run of the data from a slightly other s0 may leave it (a
run from s0 = 0.15 at (124 Hz, 14 m/s²) ends at s = 0.038, its contact point 0.3 mm from the
clamping; the truth from s0 + 0.0015 left the free length at 43.5 s)."""


def fitted_differences(values: Union[Dict[str, float], Sequence[Dict[str, float]]], base: Parameters,
                       ops: Sequence[OperatingPoint], *, threads: Optional[int] = None,
                       clearance: Optional[float] = None, cache=None) -> Optional[Dict[str, Dict[str, float]]]:
    """The features of each single candidate's fitted model (``values``: effect name -> fitted
    value; or a list of models, each its effects' values: the sets of a confounded group, keyed
    "a+b") at ``ops``, relative to the baseline, in units of the uncertainty: the resolution floor
    and the largest run-to-run spread (over s0 and s0 ± 0.002) of the baseline and of the fitted
    models — where two explanations that fit the data alike predict differently beyond what their
    own sensitivity to unresolvable perturbations blurs. ``clearance``: None if a run ends with a
    contact point of the slider (s ± B/2L, B of the baseline) closer than this to a clamping.
    ``cache``: a run cache (:func:`.models.batch_slider_features`)."""
    from .chain import realise_model
    from .models import batch_slider_features
    from .._core import SimulationError

    sets = [{n: v} for n, v in values.items()] if isinstance(values, dict) else [dict(v) for v in values]
    names = ["+".join(v) for v in sets]
    shifts = (0.0, -0.002, 0.002)
    models = [base] + [realise_model(base, v) for v in sets]
    res = batch_slider_features([m for m in models for _ in shifts], ops, s0_shifts=list(shifts) * len(models),
                                threads=threads, cache=cache)
    if any(r is None for r in res):
        raise SimulationError("a run of the fitted models at the advice's operating points failed")
    groups = [[r[0] for r in res[i * len(shifts):(i + 1) * len(shifts)] if r is not None] for i in range(len(models))]
    if clearance is not None:
        half = base.contact_spacing_m / (2 * base.length_m)
        ends = [f.value for m, g in zip(models, groups) if not getattr(m, "chain", ())  # true positions
                for r in g for k, f in r.items() if k.startswith("s_final@")]
        if any(min(v - half, 1 - v - half) < clearance for v in ends):
            return None
    f0 = groups[0][0]
    sig = {}
    for k, f in f0.items():
        spreads = [float(np.std([g[0][k].value] + [r[k].value for r in g[1:] if k in r], ddof=1))
                   for g in groups if k in g[0]]
        sig[k] = math.hypot(f.stderr, max(spreads))
    return {n: {k: (g[0][k].value - f0[k].value) / sig[k] for k in f0 if k in g[0] and sig[k] > 0}
            for n, g in zip(names, groups[1:])}


def _score_fitted(diffs: Dict[str, Dict[str, float]]) -> float:
    """The smallest distance between two fitted models' features (units of the uncertainty)."""
    out = math.inf
    for a, b in itertools.combinations(list(diffs), 2):
        keys = [k for k in diffs[a] if k in diffs[b]]
        out = min(out, float(np.linalg.norm([diffs[a][k] - diffs[b][k] for k in keys])))
    return out


def _score(names: Sequence[str], sens: Dict[str, Dict[str, float]]) -> float:
    """One candidate: the norm of its signature; several: the smallest pairwise separation."""
    if len(names) == 1:
        v = np.array(list(sens[names[0]].values()))
        return float(np.linalg.norm(v)) if len(v) else 0.0
    seps = []
    for a, b in itertools.combinations(names, 2):
        c, na, nb = cosine(sens[a], sens[b])
        seps.append(min(na, nb) * math.sqrt(max(1 - c * c, 0.0)))
    return float(min(seps))


EXTENDING_PAIRS = 3
"""Of the pairs that extend one of the two best single candidates, those fitted: the ones the
linearised model predicts to fit best (:func:`rank_pairs`); the others' full fits cost most of a
discover's runs and the linearised model ranks them (docs/model.md §9.1, "Sets of effects")."""


GUIDED_PAIRS = 3
"""Pairs fitted beyond those that extend one of the two best single candidates: the ones the
linearised model predicts to fit best (:func:`rank_pairs`), so that two effects that each fit badly
alone are still tried together."""


def rank_pairs(sens: Dict[str, Dict[str, float]], resid: Dict[str, float],
               frozen: Sequence[str] = ()) -> List[Tuple[Tuple[str, str], float]]:
    """Every pair of candidates with the χ² the linearised model predicts for its best fit:
    min over x of |r − S x|², S the two signatures (feature changes in units of the uncertainty per
    step, :func:`.separability.slider_sensitivities`) over the features both move, r the data's
    residuals from the baseline in the same units (features outside S count r²). ``frozen``:
    features counted as they are (the mode features of an operating point where no baseline run
    is in the data's mode: their changes are a mode switch, as in :mod:`.fast`). Best first."""
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
                 ranked: Optional[List[Tuple[Tuple[str, str], float]]] = None) -> List[Tuple[Effect, ...]]:
    """The sets of 2..max_effects effects to fit: all at the beam level (cheap surrogate); at the
    slider and joint levels those that extend one of the two best singles, and (joint) every set
    of beam-level effects only (their slider part is one evaluation). ``ranked``: every pair with
    the χ² the linearised model predicts for it (:func:`rank_pairs`, slider level);
    then of the pairs that extend one of the two best singles only the
    :data:`EXTENDING_PAIRS` predicted best for each are fitted, and beside them the
    :data:`GUIDED_PAIRS` predicted best overall."""
    top = [f.effects[0] for f in sorted(singles, key=lambda f: f.chi2)[:2]]
    out: List[Tuple[Effect, ...]] = []
    for k in range(2, max_effects + 1):
        if k == 2 and ranked is not None and level == "slider":
            want: List[frozenset] = []
            for t in top:
                want += [frozenset(p) for p, _ in ranked if t in p][:EXTENDING_PAIRS]
            want += [frozenset(p) for p, _ in ranked[:GUIDED_PAIRS]]
            for combo in itertools.combinations(cand_effects, 2):
                if frozenset(e.name for e in combo) in want:
                    out.append(combo)
            continue
        for combo in itertools.combinations(cand_effects, k):
            names = {e.name for e in combo}
            if level == "beam" or set(top) & names or (level == "joint" and all(e.level == "beam" for e in combo)):
                out.append(combo)
    return out
