"""The naming rule (docs/model.md §9, "Naming rule"; §9.1): from the fits of a search, the verdict.
:func:`decide` states it in order — each fitted set's reasons not to be named (:func:`judge`), the
forward selection by likelihood-ratio tests (:func:`select`), the confounded groups
(:mod:`.confounding`), the effects left out of the candidates, the full simulation of the named set,
and where nothing is named, "none" or "unexplained" (:func:`unnamed_verdict`) with the advice
(:mod:`.advice`) — and returns the typed :class:`.result.Verdict` the report reads."""

from __future__ import annotations

import math
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

from ..params import Parameters
from .advice import advise
from .chain import realise_model
from .confounding import confounded_group, confounded_sets, outside_fits_better
from .effects import EFFECTS
from .options import DEFAULT, DiscoverOptions
from .progress import progress_bar
from .reasons import Reason, Reasons, Why, kinds
from .result import After, Because, CandidateFit, Kind, Verdict
from .stats import chi2_quantile, excess, gap_of, interval_of, lrt_threshold, right_fit_bound, z_bound

__all__ = ["Reason", "Reasons", "Why", "kinds", "decide", "judge", "select", "criterion"]


def judge(fits: Sequence[CandidateFit], base: Parameters, n: int, excess_before: float,
          gap_ratio: float, threshold: Optional[float] = None, options: DiscoverOptions = DEFAULT) -> Reasons:
    """The naming rule per fitted set: the reasons it may not be named (empty: it may). Not
    adequate (χ² > χ²₀.₉₉(n − k)); a parameter moved by less than its relevance threshold; a
    small share of the gap beyond the noise (:func:`excess`: sqrt(max(χ² − (n − k), 0)/n) >
    gap_ratio × the baseline's sqrt(max(χ²₀ − n, 0)/n)); a parameter whose interval contains its
    baseline value (not resolved, :func:`.rule.unresolved_reasons`); with ``threshold`` (the
    selection's price of a parameter), a negligible change that fits as well
    (:func:`.rule.beaten_by_negligible`). ``options``: the level of the tests and of the intervals.
    docs/model.md §9, "Naming rule" (a)–(f)."""
    out: Reasons = {}
    for f in fits:
        reasons: List[Reason] = []
        if f.screened:
            reasons.append(Reason(Why.SCREENED, f"screened out: its coarse scan's chi2 = {f.chi2:.3g} is more than "
                                                f"{options.screen_margin:g} above the best coarse chi2 (not fitted in full)"
                                  if not f.linearised else f"screened out: the linearised model predicts chi2 = "
                                                           f"{f.chi2:.3g}, not among those fitted in full"))
        elif not f.adequate:
            reasons.append(Reason(Why.NOT_ADEQUATE, f"not adequate: chi2 = {f.chi2:.3g} > chi2_0.99({f.dof}) = "
                                                    f"{chi2_quantile(f.dof, options.significance):.3g}"))
        for e in f.effects:
            ok, how = EFFECTS[e].relevant(f.values[e], base)
            if not ok:
                reasons.append(Reason(Why.NEGLIGIBLE, f"negligible change of {EFFECTS[e].field}: {how}", e))
        g = excess(f.chi2, f.dof, n)
        if g > gap_ratio * excess_before:
            reasons.append(Reason(Why.SMALL_SHARE, f"small share of the gap beyond the noise: {excess_before:.3g} -> "
                                                   f"{g:.3g} (more than {gap_ratio:g} x)"))
        reasons += unresolved_reasons(f, base, options.interval_level)
        out[f.effects] = reasons
    return out if threshold is None else beaten_by_negligible(fits, out, threshold)


def select(fits: List[CandidateFit], chi2_0: float, n: int,
           fits_baseline: Optional[bool] = None, alpha: float = DEFAULT.significance
           ) -> Tuple[Optional[CandidateFit], List[Tuple[str, ...]]]:
    """Nothing if the baseline is adequate (``fits_baseline``; None: χ² ≤ χ²_0.99(n)); else forward
    selection by likelihood-ratio tests: the best single effect must beat the baseline, and the
    best larger set containing the current choice must beat it, by more than :func:`lrt_threshold`
    (99 %, corrected for the number of sets the best was picked from)."""
    if fits_baseline is None:
        fits_baseline = chi2_0 <= chi2_quantile(n, alpha)
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
        if best_chi2 - top.chi2 > lrt_threshold(k - best_k, len(pool), alpha):
            best, best_chi2, best_k = top, top.chi2, k
        else:
            break
    if best is None:
        return None, []
    alts = [c.effects for c in by_size[len(best.effects)] if c.effects != best.effects and c.chi2 - best.chi2 < 2.0]
    return best, alts


def no_set_can_win(singles: List[CandidateFit], judge: Callable[[List[CandidateFit]], Reasons],
                   alpha: float = DEFAULT.significance) -> bool:
    """Whether fitting sets is pointless: a single candidate passes the naming rule with a χ²
    below the least likelihood-ratio threshold for adding an effect (:func:`.stats.lrt_threshold`
    with m = 1, 6.63): the selection would name it, and no set (χ² ≥ 0) can beat it by the threshold."""
    reasons = judge(singles)
    ok = [f for f in singles if not reasons[f.effects]]
    return bool(ok) and min(f.chi2 for f in ok) <= lrt_threshold(1, 1, alpha)


def best_single(singles: List[CandidateFit], reasons: Dict[Tuple[str, ...], list], chi2_0: float,
                n: int, alpha: float = DEFAULT.significance) -> Optional[CandidateFit]:
    """The single candidate the selection would name among those passing the naming rule (the
    baseline not adequate: the candidates are being fitted)."""
    return select([f for f in singles if not reasons[f.effects] and len(f.effects) == 1], chi2_0, n, False, alpha)[0]


def unresolved_reasons(f: CandidateFit, base: Parameters, level: float = DEFAULT.interval_level) -> List[Reason]:
    """A reason per parameter of ``f`` whose interval (:func:`interval_of`) contains its baseline
    value: the data do not resolve that change (empty: all resolved)."""
    out = []
    for e in f.effects:
        lo, hi = interval_of(f, e, level)
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


# --- the verdict (docs/model.md §9, "Naming rule") ---------------------------------------------------

def decide(problem: Any, fits: List[CandidateFit]) -> Verdict:
    """The verdict from the fits of a search, in the order of docs/model.md §9, "Naming rule" (its
    steps numbered in the comments): the
    reasons per set (:func:`judge`, (a)–(f)); the forward selection among the sets with none
    (:func:`select`); a selected set that fits as well as other candidates moving the features alike
    is confounded (:func:`.confounding.confounded_group`, :func:`.confounding.confounded_sets`), one
    that an effect left out of the candidates fits clearly better is not named
    (:func:`.confounding.outside_fits_better`), nor one whose full simulation leaves too large a share
    of the gap; nothing named, "none" or "unexplained" (:func:`unnamed_verdict`); the advice for a
    confounded group or an unresolved candidate (:func:`.advice.advise`)."""
    o = problem.options
    # Naming rule 2: each set's reasons; 3: the forward selection among the sets with none.
    reasons = judge(fits, problem.base, problem.n, problem.excess_before, o.gap_ratio, problem.thr_m, options=o)
    best, alts = select([f for f in fits if not reasons[f.effects]], problem.chi2_0, problem.n,
                        problem.baseline_fits, o.significance)
    group: Dict[str, Any] = {}
    selected = best
    if best is not None and problem.measured is not None:  # 4: confounding
        group = _confounded(problem, best, fits, reasons) or {}
        if group:  # the data resolve a combination of the group, not which of them: nothing is named
            best, alts = None, []
    if best is not None and problem.measured is not None and problem.level == "slider" and problem.outside:
        # 5: an effect left out of the candidates that fits clearly better
        why = _outside_fits_better(problem, best)
        if why is not None:
            reasons[best.effects] = reasons[best.effects] + [why]
            best, alts = None, []
    after, poor = None, {}
    lead = best if best is not None else selected if group else None
    if lead is not None:  # 6, 7: the full simulation of the updated model (of a confounded group's best)
        after, poor = _simulated(problem, lead, reasons)
        if after is None or group:
            best, alts, after = None, [], None
    v = Verdict(Kind.NONE, Because.BASELINE_FITS, best, alts, reasons, group, after=after,
                negligible=sorted(negligible_fits(fits, reasons), key=lambda f: f.chi2),
                filler="passes the naming rule, but " + ("is confounded (see confounded)" if group
                                                         else "a simpler or better set was named"))
    if problem.baseline_fits:  # 1: the baseline's test
        pass
    elif best is not None:
        v.kind, v.because = Kind.NAMED, Because.NAMED
    elif poor:  # the selected set does not fit as right models do: its gap is shown
        v.kind, v.because, v.poor_fit = Kind.UNEXPLAINED, Because.POOR_FIT, poor
        v.best_rejected = next(f for f in fits if list(f.effects) == poor["effects"])
    elif group and group.get("among_candidates", True):
        v.kind, v.because = Kind.CONFOUNDED, Because.CONFOUNDED
    else:
        # 8: nothing named; also a named set that only effects outside the candidates mimic.
        kind, _, v.unresolved = unnamed_verdict(fits, reasons, problem.thr_m)
        v.kind = Kind(kind)
        v.because = (Because.NEGLIGIBLE_CHANGE if v.kind is Kind.NONE else Because.OUTSIDE_CANDIDATES if group
                     else Because.NOT_RESOLVED if v.unresolved is not None else Because.NO_SET_PASSES)
        v.best_rejected = _best_rejected(fits, reasons)
    to_advise = (group.get("group") if not poor else None) or (list(v.unresolved.effects) if v.unresolved is not None
                                                                else None)
    if to_advise and problem.measured is not None and o.advice_grid:
        v.advice = _advice(problem, to_advise, group)
    return v


def _simulated(problem: Any, best: CandidateFit, reasons: Reasons) -> Tuple[Optional[After], Dict[str, Any]]:
    """The full simulation of the selected set and its two checks (docs/model.md §9, "Naming rule"
    6 and 7): the share of the gap beyond the noise it leaves (``reasons`` gets a SMALL_SHARE reason:
    (None, {})), and, at the slider level, its χ² against the goodness-of-fit bound of right models
    (:func:`.stats.gof_bound`; ``reasons`` gets a POOR_FIT reason: (None, the set, its χ², gap and
    bound)); (the simulation, {}) if it passes both."""
    o = problem.options
    after = _after(problem, best)
    gap_a, chi2_a = gap_of(after.features, problem.meas, after.spread, problem.runs_base, problem.modes, after.counts)
    g = excess(chi2_a, problem.n - len(best.effects), problem.n)
    if g > o.gap_ratio * problem.excess_before:  # the fit's gap was small enough, the simulation's is not
        reasons[best.effects] = reasons[best.effects] + [Reason(
            Why.SMALL_SHARE, f"small share of the gap beyond the noise in the full simulation of the updated "
                             f"model: {g:.3g} > {o.gap_ratio:g} x {problem.excess_before:.3g}")]
        return None, {}
    bound = right_fit_bound(problem.n, len(best.effects), o)
    if problem.level == "slider" and chi2_a > bound:
        reasons[best.effects] = reasons[best.effects] + [Reason(
            Why.POOR_FIT, f"does not fit as right models do: its full simulation leaves chi2 = {chi2_a:.3g} "
                          f"(gap {gap_a:.3g}) > {bound:.3g}, the {100 * (1 - o.significance):g} % bound of the "
                          f"baseline's chi2 on data it made itself")]
        return None, dict(effects=list(best.effects), values=dict(best.values), stderrs=dict(best.stderrs),
                          chi2=chi2_a, gap=gap_a, bound=bound, gap_bound=math.sqrt(bound / max(problem.n, 1)))
    return after, {}


def _confounded(problem: Any, best: CandidateFit, fits: List[CandidateFit], reasons: Reasons) -> Optional[Dict[str, Any]]:
    # The checks of a selected set against the other candidates and the level's library (§9, "confounded").
    o = problem.options
    group = confounded_group(best, fits, reasons, problem.before, problem.sig_base, problem.base, problem.thr_m, o)
    if group is not None or problem.level != "slider":
        return group
    return confounded_sets(best, fits, reasons, problem.before, problem.sig_base, problem.base, problem.thr_m,
                           problem.library, problem.changes, lambda name: _confirm(problem, name),
                           [e.name for e in problem.candidates], o)


def _confirm(problem: Any, name: str) -> Tuple[CandidateFit, List[Reason]]:
    # One effect fitted in full and judged alone by the naming rule.
    f = problem.fit((EFFECTS[name],))
    return f, judge([f], problem.base, problem.n, problem.excess_before, problem.options.gap_ratio,
                    options=problem.options)[f.effects]


def _outside_fits_better(problem: Any, best: CandidateFit) -> Optional[Reason]:
    # An effect of the library left out of the candidates that fits clearly better: the candidates do
    # not establish their change (docs/model.md §9.1, "Outside the candidates").
    o = problem.options
    pred = problem.predict([EFFECTS[x] for x in problem.outside])
    bar = progress_bar(problem.progress, min(o.confirm_singles, len(pred)),
                       "discover: effects not among the candidates (fits)")

    def confirm(name: str) -> Tuple[CandidateFit, List[Reason]]:
        out = _confirm(problem, name)
        bar.update(1)
        return out

    why = outside_fits_better(best, pred, confirm, problem.thr_m, o.confirm_singles, o.interval_level)
    bar.close()
    return why


def _after(problem: Any, best: CandidateFit) -> After:
    # The full simulation of the updated model; the fit's spread pools the ensemble with the roughness
    # of its scan (pooled_spread).
    a = problem.simulate(realise_model(problem.base, {e: best.values[e] for e in best.effects}))
    sp = {**a.spread, **{k: v for k, v in best.model_spread.items() if k in a.spread or k in a.features}}
    return After(problem.filled(a.features, sp, a.counts), a.behaviours, sp, a.counts)


def _best_rejected(fits: Sequence[CandidateFit], reasons: Reasons) -> Optional[CandidateFit]:
    # The set an "unexplained" verdict shows: a relevant change the data resolve, adequate but not
    # named, before the lowest χ².
    ranked = sorted(fits, key=lambda f: f.chi2)
    resolved = [f for f in ranked if not kinds(reasons[f.effects]) & {Why.NEGLIGIBLE, Why.NOT_RESOLVED, Why.SCREENED,
                                                                      Why.NOT_ADEQUATE}]
    return resolved[0] if resolved else ranked[0] if ranked else None


def _advice(problem: Any, names: List[str], group: Dict[str, Any]) -> Dict[str, Any]:
    # The run that would separate a confounded group or resolve an unresolved candidate.
    grid = problem.options.advice_grid
    done = {(op.f_ex, op.a_ex, op.s0) for op in problem.ops}
    bar = progress_bar(problem.progress, 1 + sum(tuple(g) not in done for g in grid),
                       f"discover: advice for {', '.join(names)} (points)")
    out = advise(names, problem.base, problem.ops, grid, threads=problem.threads, on_point=lambda: bar.update(1),
                 fitted=group.get("models", group.get("values")), cache=problem.run_cache, options=problem.options)
    bar.close()
    return out


def criterion(problem: Any) -> str:
    """The naming rule in one text, with this problem's numbers (``report.json`` ``criterion``)."""
    o, n = problem.options, problem.n
    thr = problem.thr_m
    return (f"an effect set is named only if (1) the baseline does not fit, chi2 = {problem.chi2_0:.3g} > "
            f"chi2_0.99(n={n}) = {chi2_quantile(n, o.significance):.2f} or a feature's |z| = {problem.z_worst:.3g} > "
            f"{z_bound(n, o.significance):.3g} (99 %, Bonferroni over "
            f"the n features); (2) the updated model is adequate, chi2 <= chi2_0.99(n-k); (3) each "
            f"parameter moved by at least its relevance threshold (EFFECTS[...].relevance); (4) the gap beyond "
            f"the noise, sqrt(max(chi2 - E[chi2], 0)/n), after <= {o.gap_ratio:g} x before ({problem.excess_before:.3g}; "
            f"fit and full simulation); (5) it fits better than every set of negligible changes, each chi2 "
            f"charged {thr:.3g} per parameter; (6) slider level: no single effect of the library left out of the "
            f"candidates fits better by more than {thr:.3g}, each charged it per parameter; among the sets that pass, "
            f"forward selection by likelihood-ratio tests at 99 %, Bonferroni-corrected for picking the best of m "
            f"sets (m = {len(problem.candidates)}: {thr:.2f}); otherwise the "
            f"verdict is 'unexplained' and nothing is added")
