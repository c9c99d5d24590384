"""The separability tool's advice (docs/model.md §9.1; docs/guide/discrepancy.md, "Naming rule"):
which measurement would resolve an unresolved candidate or separate a confounded group."""

from __future__ import annotations

import itertools
import math
from typing import Any, Callable, Dict, Optional, Sequence, Tuple, Union

import numpy as np

from ..params import Parameters
from .confounding import cosine
from .models import OperatingPoint
from .options import DEFAULT, DiscoverOptions


def advise(names: Sequence[str], base: Parameters, ops: Sequence[OperatingPoint],
           grid: Sequence[Tuple[float, float, float]], *, threads: Optional[int] = None,
           on_point: Optional[Callable[[], None]] = None,
           fitted: Optional[Union[Dict[str, float], Sequence[Dict[str, float]]]] = None, cache=None,
           options: DiscoverOptions = DEFAULT) -> Dict[str, Any]:
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
    ``cache``: a run cache (:func:`.models.batch_slider_features`). A point where a run ends with a
    contact point within ``options.clamp_clearance`` of a clamping is skipped; a fitted group no run
    separates by ``options.weak_separation`` uncertainties is said to be weakly separated."""
    from .separability import slider_sensitivities

    measured = {(op.f_ex, op.a_ex, op.s0) for op in ops}
    points = [g for g in grid if tuple(g) not in measured]
    duration = max(op.duration_s for op in ops)
    if not points:
        return dict(names=list(names), recommended=None, note="every point of the grid is measured already")
    def score_at(where: Sequence[OperatingPoint], clearance: Optional[float] = None) -> Optional[float]:
        if fitted:
            diffs = fitted_differences(fitted, base, where, threads=threads, clearance=clearance, cache=cache,
                                       options=options)
            return None if diffs is None else _score_fitted(diffs)
        return _score(names, slider_sensitivities(names, base, where, threads=threads, cache=cache, options=options))

    now = score_at(ops)
    if on_point is not None:
        on_point()
    best: Optional[Tuple[Tuple[float, float, float], float]] = None
    for g in points:
        score = score_at([OperatingPoint(*g, duration)], options.clamp_clearance)
        if on_point is not None:
            on_point()
        if score is not None and (best is None or score > best[1]):
            best = (g, score)
    if best is None:
        return dict(names=list(names), recommended=None,
                    note="at every point of the grid not yet measured a run ends at the clamping")
    what = ("distance between the fitted models' features" if fitted else
            "signature norm" if len(names) == 1 else "separation min(|z1|, |z2|) sin(theta)")
    weak = bool(fitted) and best[1] < options.weak_separation
    lead = ("no run of the grid separates them by " + f"{options.weak_separation:g} uncertainties; the best, a run at "
            if weak else "add a run at ")
    return dict(names=list(names), measure=what, at_measured_points=now, weak=weak,
                recommended=dict(f_ex=best[0][0], a_ex=best[0][1], s0=best[0][2], duration_s=duration,
                                 score=best[1]),
                text=f"{lead}f_ex = {best[0][0]:g} Hz, a_ex = {best[0][1]:g} m/s^2, s0 = {best[0][2]:g} "
                     f"({duration:g} s): {what} {best[1]:.3g}"
                     + ("" if fitted else " for a change of 5 relevance thresholds")
                     + f", against {now:.3g} at the measured points")


def fitted_differences(values: Union[Dict[str, float], Sequence[Dict[str, float]]], base: Parameters,
                       ops: Sequence[OperatingPoint], *, threads: Optional[int] = None,
                       clearance: Optional[float] = None, cache=None, options: DiscoverOptions = DEFAULT
                       ) -> Optional[Dict[str, Dict[str, float]]]:
    """The features of each single candidate's fitted model (``values``: effect name -> fitted
    value; or a list of models, each its effects' values: the sets of a confounded group, keyed
    "a+b") at ``ops``, relative to the baseline, in units of the uncertainty: the resolution floor
    and the largest run-to-run spread (over s0 and s0 ± 0.002) of the baseline and of the fitted
    models — where two explanations that fit the data alike predict differently beyond what their
    own sensitivity to unresolvable perturbations blurs. ``clearance``: None if a run ends with a
    contact point of the slider (s ± B/2L, B of the baseline) closer than this to a clamping.
    ``cache``, ``options``: a run cache and how its runs are read (:func:`.models.batch_slider_features`)."""
    from .chain import realise_model
    from .models import batch_slider_features
    from .._core import SimulationError

    sets = [{n: v} for n, v in values.items()] if isinstance(values, dict) else [dict(v) for v in values]
    names = ["+".join(v) for v in sets]
    shifts = (0.0, -0.002, 0.002)
    models = [base] + [realise_model(base, v) for v in sets]
    res = batch_slider_features([m for m in models for _ in shifts], ops, s0_shifts=list(shifts) * len(models),
                                threads=threads, cache=cache, options=options)
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
