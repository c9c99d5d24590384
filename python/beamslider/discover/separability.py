"""Identifiability of slider-level candidates (docs/guide/discrepancy.md, "Identifiability"): linearised signatures of each effect
in units of the feature uncertainties, their correlations, and for an inseparable pair the
operating point whose predicted features differ most."""

from __future__ import annotations

import itertools
import math
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..params import Parameters, resolve
from .chain import realise_model
from .effects import EFFECTS, Effect
from .._core import SimulationError
from .models import OperatingPoint, batch_slider_features, unreached_mode_features
from .options import DEFAULT, DiscoverOptions


def bumped(e: Effect, p: Parameters, steps: float) -> float:
    """The parameter of ``e`` moved from its value in ``p`` by ``steps`` relevance thresholds."""
    b = e.baseline_value(p)
    if e.relevance_kind == "compliance":
        u = e.variable(b, p)
        return e.value(u + steps * max(e.relevance * u, e.relevance_floor), p)
    if e.relevance_kind == "rel":
        return b * (1 + steps * e.relevance)
    return b + steps * e.relevance


def slider_sensitivities(effects: Sequence[str], baseline: Optional[Parameters], ops: Sequence[OperatingPoint], *,
                         steps: float = 5.0, threads: Optional[int] = None, cache=None,
                         options: DiscoverOptions = DEFAULT) -> Dict[str, Dict[str, float]]:
    """Change of each slider feature at ``ops``, in units of its uncertainty — the resolution floor
    (``options.feature_floors``) combined with the model's run-to-run spread (runs from s0 ± 0.002, as in
    :func:`discover`) — when each effect moves by ``steps`` relevance thresholds from the
    baseline (one FS run per effect and point; the measurement chain's candidates other than the
    excitation level re-read the baseline's run, docs/model.md §9.1). ``cache``, ``options``: a run
    cache and how its runs are read (:func:`.models.batch_slider_features`)."""
    base = resolve(baseline)
    models = [base, base, base] + [realise_model(base, {n: bumped(EFFECTS[n], base, steps)}) for n in effects]
    # All runs as one batch of the core's parallel runner.
    res = batch_slider_features(models, ops, s0_shifts=[0.0, -0.002, 0.002] + [0.0] * len(effects),
                                threads=threads, cache=cache, options=options)
    if res[0] is None:
        raise SimulationError("the baseline model's runs failed")
    f0 = res[0][0]
    reps = [r[0] for r in res[1:3] if r is not None]
    sig = {}
    for k, f in f0.items():
        vals = [f.value] + [r[k].value for r in reps if k in r]
        sig[k] = math.hypot(f.stderr, float(np.std(vals, ddof=1)) if len(vals) > 1 else 0.0)
    out: Dict[str, Dict[str, float]] = {}
    for name, r in zip(effects, res[3:]):
        if r is None:
            raise SimulationError(f"the runs of the model with {name} moved by {steps:g} relevance thresholds failed")
        f = r[0]
        out[name] = {k: (f[k].value - f0[k].value) / sig[k] for k in f0 if k in f}
    return out


def slider_changes(effects: Sequence[str], baseline: Optional[Parameters], ops: Sequence[OperatingPoint], *,
                   steps: float = 5.0, threads: Optional[int] = None, cache=None,
                   options: DiscoverOptions = DEFAULT) -> Dict[str, Dict[str, float]]:
    """The raw change of each slider feature at ``ops`` when each effect moves by ``steps``
    relevance thresholds from the baseline (one run per effect and point against the baseline's
    unshifted run; an effect whose runs fail has no changes): the linearised model of
    :func:`.confounding.confounded_sets` and :mod:`.search.linearised`, whose callers divide by their own
    uncertainties. ``cache``: the discover's run cache (the runs :func:`slider_sensitivities` made
    are not repeated), its runs read as ``options`` says."""
    base = resolve(baseline)
    moved = {n: bumped(EFFECTS[n], base, steps) for n in effects}
    models = [base] + [realise_model(base, {n: moved[n]}) for n in effects]
    res = batch_slider_features(models, ops, threads=threads, cache=cache, options=options)
    if res[0] is None:
        raise SimulationError("the baseline model's runs failed")
    f0 = res[0][0]
    return {n: ({} if r is None else {k: r[0][k].value - f0[k].value for k in f0 if k in r[0]})
            for n, r in zip(effects, res[1:])}


def separability(effects: Optional[Sequence[str]] = None, *, baseline: Optional[Parameters] = None,
                 operating_points: Sequence[Tuple[float, float, float]], duration_s: float,
                 grid: Sequence[Tuple[float, float, float]] = (), max_cos: float = 0.95,
                 steps: float = 5.0) -> List[Dict[str, Any]]:
    """Which pairs of slider-level candidates the data at ``operating_points`` can tell apart.

    Each effect's signature is its sensitivity vector (:func:`slider_sensitivities`, features in
    units of their resolution floors). A pair is *separable* if the angle between the signatures
    is clear (|cos| ≤ ``max_cos``) and both move the features (norm ≥ 2); otherwise, for each
    point of ``grid`` (f_ex, a_ex, s0) the separation min(|z₁|, |z₂|)·sin θ is computed there and
    the best point recommended ("to tell A from B, measure …"). Returns one row per pair."""
    names = list(effects) if effects is not None else [n for n, e in EFFECTS.items() if e.level == "slider"]
    ops = [OperatingPoint(f, a, s0, duration_s) for f, a, s0 in operating_points]
    sens = slider_sensitivities(names, baseline, ops, steps=steps)

    def cos_norms(z1: Dict[str, float], z2: Dict[str, float]) -> Tuple[float, float, float]:
        keys = [k for k in z1 if k in z2]
        a = np.array([z1[k] for k in keys])
        b = np.array([z2[k] for k in keys])
        na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
        c = float(a @ b / (na * nb)) if na > 0 and nb > 0 else 1.0
        return c, na, nb

    grid_sens = {}
    rows = []
    for n1, n2 in itertools.combinations(names, 2):
        c, na, nb = cos_norms(sens[n1], sens[n2])
        row: Dict[str, Any] = dict(pair=[n1, n2], cos=c, norm=[na, nb],
                                   separable=bool(abs(c) <= max_cos and min(na, nb) >= 2.0))
        if not row["separable"] and grid:
            best = None
            for g in grid:
                if g not in grid_sens:
                    grid_sens[g] = slider_sensitivities(names, baseline, [OperatingPoint(*g, duration_s)], steps=steps)
                cg, ga, gb = cos_norms(grid_sens[g][n1], grid_sens[g][n2])
                sep = min(ga, gb) * math.sqrt(max(1 - cg * cg, 0.0))
                if best is None or sep > best[1]:
                    best = (g, sep, cg)
            if best is not None:
                row["recommended"] = dict(f_ex=best[0][0], a_ex=best[0][1], s0=best[0][2], separation=best[1],
                                          cos=best[2])
        rows.append(row)
    return rows


def predict_singles(cands: Sequence[Effect], base: Parameters, resid: Dict[str, float], sig: Dict[str, float],
                    changes: Callable[[List[str], float], Dict[str, Dict[str, float]]],
                    counts: Optional[Dict[str, int]] = None, steps: float = 5.0) -> Dict[str, Tuple[float, float]]:
    """Each candidate's predicted best χ² and value: the feature changes of moves by ±``steps``
    relevance thresholds (``DiscoverOptions.linear_steps``) (``changes(names, steps)``: raw changes from the baseline's run) give a
    quadratic per feature, Δ(x) = a x + c x² with x in units of the move; χ²(x) = Σ (r − Δ(x)/σ)²
    (``resid``: the data's residuals r from the baseline in units of ``sig``; a feature that a
    move loses counts r²) is minimised over 201 points of the candidate's search range. ``counts``:
    per operating point, how many of the baseline's ensemble runs end in the data's mode; where none
    does, the mode features there count as they are (the fitted χ² counts them as their expectation
    while a model misses the mode, and the baseline's run is in another mode: their changes from it
    are those of a different state, no signature of the candidate)."""
    names = [e.name for e in cands]
    up, down = changes(names, steps), changes(names, -steps)
    keys = [k for k in resid if sig.get(k, 0) > 0]
    off = unreached_mode_features(keys, counts)
    frozen = np.array([k in off for k in keys], dtype=bool)
    r = np.array([resid[k] for k in keys])
    out: Dict[str, Tuple[float, float]] = {}
    for e in cands:
        b = e.baseline_value(base)
        step = bumped(e, base, steps) - b
        dp = np.array([up.get(e.name, {}).get(k, math.nan) / sig[k] for k in keys])
        dm = np.array([down.get(e.name, {}).get(k, math.nan) / sig[k] for k in keys])
        ok = np.isfinite(dp) & np.isfinite(dm) & ~frozen
        a, c = (dp[ok] - dm[ok]) / 2, (dp[ok] + dm[ok]) / 2
        lo, hi = e.search if math.isfinite(e.search[0]) else (e.lower, e.upper)
        us = np.linspace(lo, hi, 201)
        vals = np.array([e.value(u, base) for u in us])
        xs = (vals - b) / step if step != 0 else np.zeros_like(vals)
        rest = float(np.sum(r[~ok] ** 2))
        chi2 = np.array([float(np.sum((r[ok] - a * x - c * x * x) ** 2)) + rest for x in xs])
        j = int(np.argmin(chi2))
        out[e.name] = (float(chi2[j]), float(vals[j]))
    return out


def rank_pairs(sens: Dict[str, Dict[str, float]], resid: Dict[str, float],
               frozen: Sequence[str] = ()) -> List[Tuple[Tuple[str, str], float]]:
    """Every pair of candidates with the χ² the linearised model predicts for its best fit:
    min over x of |r − S x|², S the two signatures (feature changes in units of the uncertainty per
    step, :func:`.separability.slider_sensitivities`) over the features both move, r the data's
    residuals from the baseline in the same units (features outside S count r²). ``frozen``:
    features counted as they are (the mode features of an operating point where no baseline run
    is in the data's mode: their changes are a mode switch, as in :mod:`.search.linearised`). Best first."""
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
