"""The statistics of the naming rule (docs/model.md §9, §9.1): the χ² of a model against the measured
features with mode conditioning, the gap beyond the noise, the quantiles and likelihood-ratio
thresholds, the baseline's test and the interval that must exclude a parameter's baseline value."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from .features import Feature
from .models import Modes, as_modes, is_mode_feature, mode_penalty, tag_of
from .options import DEFAULT, DiscoverOptions
from .result import CandidateFit

SIGNIFICANCE = DEFAULT.significance
"""The default level of the tests (:attr:`.options.DiscoverOptions.significance`; a name of the
package's API, not a setting: give ``discover(options=...)``)."""


def interval_z(level: float = DEFAULT.interval_level) -> float:
    """z of the two-sided ``level`` interval (:attr:`.options.DiscoverOptions.interval_level`: 1.96
    at 95 %)."""
    from scipy.stats import norm

    return float(norm.ppf(0.5 + level / 2))


def short_of_baseline(interval: Tuple[float, float], value: float, baseline: float, chi2_fit: float,
                      chi2_baseline: float, z: float) -> Tuple[float, float]:
    """A single effect's interval with its end on the baseline's side moved to the parabolic crossing
    of Δχ² = z² between the fit (``value``, ``chi2_fit``) and the baseline (``chi2_baseline``, its
    ensemble's χ²), where the baseline fits worse by more than z² and the interval reaches it: the
    profile at the baseline value is known from its ensemble, which a scan of single runs can miss
    (docs/model.md §9.1, "One effect")."""
    lo, hi = interval
    d = chi2_baseline - chi2_fit
    if not (math.isfinite(d) and d > z * z and lo <= baseline <= hi and value != baseline):
        return lo, hi
    cross = value + (baseline - value) * z / math.sqrt(d)
    return (max(lo, cross), hi) if baseline < value else (lo, min(hi, cross))


def excess(chi2: float, dof: int, n: int) -> float:
    """Gap beyond the noise: sqrt(max(χ² − dof, 0)/n) (:data:`.result.GAP_EXCESS_MEASURE`)."""
    return math.sqrt(max(chi2 - dof, 0.0) / max(n, 1))


def chi2_quantile(dof: int, alpha: float = DEFAULT.significance) -> float:
    """The (1 − ``alpha``) quantile of χ²(dof): an adequate model's χ² is at most this (docs/model.md §9)."""
    from scipy.stats import chi2

    return float(chi2.ppf(1 - alpha, max(dof, 1)))


def sigma(f: Feature, spread: float, runs: int) -> float:
    """Uncertainty of (model − measured) for a model feature that is the mean of ``runs`` runs whose
    spread is ``spread`` (runs = 0: no model spread): the measured value is one draw of the truth's
    spread, the model's mean has spread²/runs."""
    return math.sqrt(f.stderr ** 2 + (spread ** 2 * (1 + 1 / runs) if runs > 0 else 0.0))


def mode_terms(model: Dict[str, float], modes: Optional[Modes], counts: Optional[Dict[str, int]],
               runs: int) -> Tuple[set, float]:
    """The operating points (tags) whose mode features the model cannot predict (none of its runs
    ends in the data's mode, :meth:`.models.Modes.mode_of`), and the sum of the mode penalties
    (:func:`.models.mode_penalty`). ``counts``: per tag, how many of the model's ``runs`` runs are
    in the data's mode (an ensemble); None: ``model`` is one run, whose own mode decides."""
    unpredicted, pen = set(), 0.0
    modes = as_modes(modes)
    for tag, md in (modes or {}).items():
        if md is None:
            continue
        if counts is not None and tag in counts:
            k, r = counts[tag], max(runs, 1)
        else:
            k, r = (1 if modes.mode_of(model, tag) == md else 0), 1
        if k == 0:
            unpredicted.add(tag)
        pen += mode_penalty(k, r)
    return unpredicted, pen


def chi2_terms(model: Optional[Dict[str, float]], names: Sequence[str], y: np.ndarray, sig: np.ndarray,
               modes: Optional[Modes] = None, counts: Optional[Dict[str, int]] = None, runs: int = 1) -> float:
    """χ² of the measured features ``names`` (values ``y``, uncertainties ``sig``) against
    ``model``: Σ z² (a feature the model lacks counts as 5σ), where a mode feature of an
    operating point the model cannot predict in the data's mode counts as its expectation, 1,
    plus the mode penalties (:func:`mode_terms`): the likelihood of bimodal features is that of
    the data's mode times that of the features within it."""
    if model is None:
        return math.inf
    unpredicted, pen = mode_terms(model, modes, counts, runs)
    total = pen
    for k, yk, sk in zip(names, y, sig):
        if tag_of(k) in unpredicted and is_mode_feature(k):
            total += 1.0
        elif k in model and math.isfinite(model[k]):
            total += ((model[k] - yk) / sk) ** 2
        else:
            total += 25.0
    return float(total)


def missing_z(name: str, counts: Optional[Dict[str, int]]) -> float:
    """z of a feature an ensemble lacks: 1 (its expectation) for a mode feature of an operating
    point where none of its runs is in the data's mode, 5 otherwise (:func:`chi2_terms`)."""
    tag = tag_of(name)
    return 1.0 if counts and tag in counts and counts[tag] == 0 and is_mode_feature(name) else 5.0


def gap_of(model: Dict[str, float], meas: Dict[str, Feature], spread: Optional[Dict[str, float]] = None,
         runs: int = 0, modes: Optional[Modes] = None, counts: Optional[Dict[str, int]] = None) -> Tuple[float, float]:
    """(RMS gap sqrt(χ²/n), χ²) of ``model`` against the measured features (:func:`chi2_terms`;
    ``spread``/``runs``: the model's ensemble, :func:`sigma`; ``modes``/``counts``: the data's
    modes and the ensemble's runs in them)."""
    sp = spread or {}
    names = list(meas)
    if not names:
        return 0.0, 0.0
    y = np.array([meas[k].value for k in names])
    sig = np.array([sigma(meas[k], sp.get(k, 0.0), runs) for k in names])
    chi2 = chi2_terms(model, names, y, sig, modes, counts, max(runs, 1))
    return float(math.sqrt(chi2 / len(names))), chi2


def lrt_threshold(df: int, m: int, alpha: float = DEFAULT.significance) -> float:
    """Likelihood-ratio threshold for adding ``df`` effects chosen as the best of ``m`` candidate
    sets: the (1 − α/m) quantile of χ²(df) (Bonferroni for picking the best of m)."""
    from scipy.stats import chi2

    return float(chi2.isf(alpha / max(m, 1), max(df, 1)))


def gof_bound(n: int, k: int, scale: float = DEFAULT.gof_scale, share: float = DEFAULT.gof_dof_share,
              alpha: float = DEFAULT.significance) -> float:
    """The largest χ² over ``n`` features that the full simulation of a named set of ``k`` effects may
    show: c·χ²₁₋α(share·(n − k)), the (1 − α) quantile of the baseline's χ² on data it made itself,
    c·χ²(share·n), with k degrees of freedom fitted (docs/model.md §9.1, "Goodness of fit")."""
    from scipy.stats import chi2

    if math.isinf(scale):
        return math.inf
    return float(scale * chi2.ppf(1 - alpha, max(share * (n - k), 0.5)))


def right_fit_bound(n: int, k: int, options: DiscoverOptions = DEFAULT, alpha: Optional[float] = None) -> float:
    """:func:`gof_bound` with the options' calibration, at their significance (or ``alpha``): the χ²
    within which a model of ``k`` fitted effects fits ``n`` features as right models do
    (docs/model.md §9.1, "Goodness of fit")."""
    return gof_bound(n, k, options.gof_scale, options.gof_dof_share, options.significance if alpha is None else alpha)


def z_bound(n: int, alpha: float = DEFAULT.significance) -> float:
    """The largest |z| of one of ``n`` features an adequate baseline may show: the two-sided 99 %
    bound, Bonferroni-corrected for the n features (3.42 for 16)."""
    from scipy.stats import norm

    return float(norm.isf(alpha / (2 * max(n, 1))))


def baseline_fits(chi2_0: float, n: int, z_worst: float = 0.0, alpha: float = DEFAULT.significance) -> bool:
    """Whether the baseline is adequate: χ² ≤ χ²_0.99(n) and no feature beyond :func:`z_bound`
    (``z_worst``: the largest |z| of its features). The omnibus χ² alone loses power with every
    feature that agrees: a 5 % excitation-level error moves one slider speed by 4.4 uncertainties,
    which χ² 28.1 over 16 features (limit 32.0) does not show (docs/model.md §9.1)."""
    return chi2_0 <= chi2_quantile(n, alpha) and z_worst <= z_bound(n, alpha)


@dataclass
class BaselineTest:
    """The baseline's test before any fit (:func:`baseline_test`)."""

    before: Dict[str, float]
    """The baseline's features, a feature it lacks filled at :func:`missing_z` uncertainties."""
    gap: float
    chi2: float
    n: int
    z_worst: float
    fits: bool
    """:func:`baseline_fits`."""


def baseline_test(model: Dict[str, float], meas: Dict[str, Feature], spread: Optional[Dict[str, float]] = None,
                  runs: int = 0, modes: Optional[Modes] = None, counts: Optional[Dict[str, int]] = None,
                  alpha: float = DEFAULT.significance) -> BaselineTest:
    """The baseline's features ``model`` (an ensemble: ``spread``, ``runs``, ``counts``) tested against
    the measured ones: χ² (:func:`gap_of`), the largest |z| and :func:`baseline_fits` (docs/model.md §9.1)."""
    sp = spread or {}
    before = dict(model)
    before.update({k: f.value + missing_z(k, counts) * sigma(f, sp.get(k, 0.0), runs) for k, f in meas.items()
                   if k not in model})
    gap, chi2 = gap_of(before, meas, sp, runs, modes, counts)
    z = max((abs(before[k] - f.value) / sigma(f, sp.get(k, 0.0), runs) for k, f in meas.items()), default=0.0)
    return BaselineTest(before, gap, chi2, len(meas), z, baseline_fits(chi2, len(meas), z, alpha))


def interval_of(f: CandidateFit, e: str, level: float = DEFAULT.interval_level) -> Tuple[float, float]:
    """The ``level`` (95 %) interval of parameter ``e`` in fit ``f`` that
    the report shows and that must exclude the baseline (docs/model.md §9.1): slider level, the
    profile's Δχ² = z² interval widened by its roughness (one effect, :func:`.fitting._interval`)
    or the joint fit's Wald interval (several, :func:`.refine.gauss_newton`); else the value ±
    z standard errors (the smooth least-squares fits of the beam level)."""
    if e in f.intervals:
        lo, hi = f.intervals[e]
        return float(lo), float(hi)
    v, se = f.values[e], f.stderrs.get(e, math.inf)
    z = interval_z(level)
    return (v - z * se, v + z * se) if math.isfinite(se) else (-math.inf, math.inf)
