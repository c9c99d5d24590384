"""Confounding (docs/model.md §9, §9.1): candidates the data cannot tell apart are reported as a
group, and a named set is checked against the single effects of the library and against effects
left out of the candidates ("Outside the candidates")."""

from __future__ import annotations

import math
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..params import Parameters
from .effects import EFFECTS
from .result import CandidateFit
from .reasons import Reason, Reasons, Why, kinds
from .options import DEFAULT, DiscoverOptions
from .stats import interval_of


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
                     delta_chi2: float, options: DiscoverOptions = DEFAULT) -> Optional[Dict[str, Any]]:
    """The single candidates, fitted in full, that come within ``delta_chi2`` of the single effect
    ``best`` (the selection's likelihood-ratio threshold: the data do not prefer ``best`` to them at
    the significance that would name it), each by a relevant change (docs/model.md §9.1,
    "Confounded"): then the data resolve what the group's fits have in common, not which of them
    changed, and ``best`` is not named alone. A candidate only screened, or fitted at a negligible
    change, is no such rival. The cosines between the fits' feature changes are reported (how alike
    they move the features). None if there is no such candidate."""
    if len(best.effects) != 1:
        return None
    s0 = signature(best, before, sig)
    members = [best]
    cos: Dict[str, float] = {}
    for f in fits:
        if len(f.effects) != 1 or f.effects == best.effects or f.screened:
            continue
        if kinds(reasons.get(f.effects, [])) & {Why.NEGLIGIBLE, Why.SCREENED}:
            continue
        if f.chi2 - best.chi2 > delta_chi2:
            continue
        members.append(f)
        cos[f.effects[0]] = cosine(s0, signature(f, before, sig))[0]
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
                intervals={f.effects[0]: list(interval_of(f, f.effects[0], options.interval_level)) for f in members},
                combination=" + ".join(terms) + " = 1",
                explanation="each alone fits within the selection's threshold of the best (chi2 "
                            + ", ".join(f"{f.effects[0]} {f.chi2:.3g}" for f in members) + f"; threshold {delta_chi2:.3g}; "
                            "cos of the feature changes " + ", ".join(f"{best.effects[0]}/{k} {v:+.3f}" for k, v in cos.items())
                            + "): the data do not tell which of them changed")


def _rho2(v: np.ndarray, cols: List[np.ndarray]) -> Tuple[float, np.ndarray]:
    """min over x of |v − A x|², A the columns ``cols``, and the minimiser."""
    A = np.column_stack(cols)
    x = np.linalg.lstsq(A, v, rcond=None)[0]
    return float(np.sum((v - A @ x) ** 2)), x


def confounded_sets(best: CandidateFit, fits: Sequence[CandidateFit], reasons: Reasons, before: Dict[str, float],
                    sig: Dict[str, float], base: Parameters, delta_chi2: float, library: Sequence[str],
                    changes: Callable[[List[str]], Dict[str, Dict[str, float]]],
                    confirm: Callable[[str], Tuple[CandidateFit, List[Any]]],
                    candidates: Optional[Sequence[str]] = None,
                    options: DiscoverOptions = DEFAULT) -> Optional[Dict[str, Any]]:
    """The single effects and fitted sets of no more effects than the set ``best`` (two or more)
    that fit as well as it by moving the features as its fit does (docs/model.md §9.1,
    "Confounded"): then the data resolve that change, not which of them made it, and ``best`` is
    not named. A fitted set (``fits``) is such a set if it passes the naming rule (no
    ``reasons``), fits within ``delta_chi2`` of ``best`` and moves the features alike (|cos θ| ≥
    ``options.confound_cos``). A single effect of the ``library`` (the level's effects, candidates or
    not) that was not fitted is first screened in the linearised model: it may reproduce the fitted
    change d of ``best`` within ``delta_chi2`` of how well ``best``'s own signatures do,
    min_y |d − s y|² ≤ min_x |d − S_B x|² + ``delta_chi2`` (S the feature changes of a move by five
    relevance thresholds, ``changes(names)``, in units of ``sig``); the ``options.confirm_singles``
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
    for _, e in sorted(screened)[:options.confirm_singles]:
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
        if abs(cs) >= options.confound_cos:
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
                        keep: int = DEFAULT.confirm_singles, level: float = DEFAULT.interval_level) -> Optional[Reason]:
    """A reason not to name the set ``best`` of the candidates: a single effect of the library that
    is not among them fits the data better by more than ``threshold`` (the selection's price of a
    parameter), each set's χ² charged ``threshold`` per parameter — χ²_X + t < χ²_best + k t − t —
    and passes the naming rule alone; then the data prefer that effect to the candidates' set at
    the significance that would name it, and the candidates do not establish their change
    (docs/model.md §9.1, "Outside the candidates"). ``predicted``: each left-out effect's best χ²
    and value by the linearised model (:func:`.search.linearised.predict_singles`); the ``keep`` best predicted
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
    lo, hi = interval_of(f, e, level)
    return Reason(Why.OUTSIDE_FITS_BETTER,
                  f"an effect not among the candidates fits better: {EFFECTS[e].field} {f.values[e]:.4g} "
                  f"[{lo:.4g}, {hi:.4g}] ({e}: chi2 {f.chi2:.3g} against {best.chi2:.3g}, each charged "
                  f"{threshold:.3g} per parameter); the candidates do not establish their change")
