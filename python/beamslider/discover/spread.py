"""The model's spread where the data cannot resolve it: the roughness of single-run χ² about a
parabola near a profile's minimum and the pooled spread of the features at a fitted point (see
:func:`.fitting.profile_fit`)."""

from __future__ import annotations

import math
from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from .models import Ensemble, Modes, as_modes, is_mode_feature, tag_of
from .options import DEFAULT


def chi2_roughness(xs: np.ndarray, fs: np.ndarray) -> float:
    """Scatter of single-run χ² values about a quadratic in x: the residual RMS of a least-squares
    parabola through the points (at least 5 distinct x, 4 residual degrees of freedom
    with 7), 0 with fewer. Where the locomotion is chaotic in the parameter (restitution), runs at
    neighbouring values differ by Δχ² of several units although the data cannot tell them apart."""
    xs, fs = np.asarray(xs, dtype=float), np.asarray(fs, dtype=float)
    ok = np.isfinite(fs)
    xs, fs = xs[ok], fs[ok]
    if np.unique(np.round(xs, 12)).size < 5:
        return 0.0
    ss, dof = parabola_scatter(xs, fs)
    return math.sqrt(ss / dof)


def parabola_scatter(x: np.ndarray, v: np.ndarray) -> Tuple[float, int]:
    """Sum of squared residuals of v about a least-squares parabola in x, and their degrees of
    freedom (len − 3): what a quadratic trend leaves unexplained (the roughness)."""
    t = (x - x.mean()) / max(float(np.ptp(x)), 1e-300)
    r = v - np.polyval(np.polyfit(t, v, 2), t)
    return float(r @ r), len(x) - 3


def pooled_spread(ens: Ensemble, levels: Sequence[Sequence[Optional[Dict[str, float]]]],
                   names: Sequence[str], modes: Optional[Modes] = None,
                   mode_min_dof: int = DEFAULT.mode_min_dof) -> Dict[str, float]:
    """The model's spread of each feature at the fitted point, pooled from two measurements of the
    same thing — its sensitivity to what the data cannot resolve: the variance over the ensemble
    of runs (R − 1 degrees of freedom) and the scatter about a quadratic trend of the single runs
    of the last refinement level of each profile scan (7 points, 4 degrees of freedom; the trend is
    what the data resolve, the scatter the roughness). Five runs alone give an unstable estimate
    (4 degrees of freedom: at μ = 0.26, 60 s, the final amplitude at 126 Hz spreads by 0.002 over
    the ensemble, by 0.007 over nine perturbations). ``modes``: the data's modes; a mode feature's
    spread comes from the runs in the data's mode only, or, with fewer than ``mode_min_dof``
    degrees of freedom, is the ensemble's spread over all runs."""
    out: Dict[str, float] = {}
    modes = as_modes(modes)
    for k in names:
        ss, dof = 0.0, 0
        tag = tag_of(k)
        md = (modes or {}).get(tag) if tag is not None and is_mode_feature(k) else None
        if md is not None and tag in ens.mode_counts:
            runs = ens.mode_counts[tag]
            if k in ens.mode_spread and runs > 1:
                ss += ens.mode_spread[k] ** 2 * (runs - 1)
                dof += runs - 1
        elif k in ens.spread and ens.runs > 1:
            ss += ens.spread[k] ** 2 * (ens.runs - 1)
            dof += ens.runs - 1
        for pts in levels:
            xs = np.array([j for j, m in enumerate(pts) if m is not None and k in m and math.isfinite(m[k])
                           and (md is None or modes.mode_of(m, tag) == md)], dtype=float)
            if len(xs) >= 5:
                v = np.array([pts[int(j)][k] for j in xs])  # type: ignore[index]
                ss_k, dof_k = parabola_scatter(xs, v)
                ss += ss_k
                dof += dof_k
        if md is not None and tag in ens.mode_counts and dof < mode_min_dof:
            out[k] = ens.spread.get(k, 0.0)  # too few runs in the data's mode: the spread over all runs
        else:
            out[k] = math.sqrt(ss / dof) if dof > 0 else 0.0
    return out
