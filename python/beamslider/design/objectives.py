"""Objectives of a design, computed from classified runs (the core's classifier, docs/model.md §8).

Adaption bandwidth (Hz). At each grid frequency f_i of one (a_ex, s0) line the run is *adapted*
when its behaviour is ``trivial_adaption`` or ``signature_move`` and its final amplitude
A_i = ``amplitude_final_h`` ≥ a_min (in units of h). The band [f_0, f_N] is split into the
intervals between neighbouring grid points, and the adapted set is built interval by interval:

- both ends adapted: the whole interval;
- neither adapted: nothing;
- one end adapted: the interval up to an edge inside it, at
  * the linear interpolation of A(f) = a_min between the two points when both are adaptive
    behaviours (the other end fails on its amplitude only), and
  * the midpoint otherwise (the behaviour changes somewhere between the two runs; nothing better
    is known without a finer grid).

The bandwidth is the total length of the adapted set: an empty set gives 0 Hz, a fully adapted
grid gives f_N − f_0 exactly; an isolated adapted point gives half of each neighbouring interval.

Harvestable level: the frequency average of (A/h)² over the band, by the trapezoidal rule
(∫ (A/h)² df / (f_N − f_0)); a run without a final amplitude counts as 0. (A/h)² is proportional
to the mean squared velocity of the beam at the measurement point at a given frequency, which an
electromechanical transducer could take out: a *proxy*, not a harvester model.

Robust versions: the objective of each member of a FIXED sample of the uncertain inputs, then the
mean (``robust = "mean"``) or a low quantile (``"quantile"``) over the sample.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Dict, List, Sequence, Tuple

import numpy as np

ADAPTIVE = ("trivial_adaption", "signature_move")
"""Behaviours that count as adaption (when the final amplitude reaches a_min)."""


def adapted_intervals(f_hz: Sequence[float], behaviour: Sequence[str], amplitude_h: Sequence[float], *,
                      a_min_h: float = 0.3) -> List[Tuple[float, float]]:
    """The adapted frequency set of one line of the band as a list of disjoint intervals [Hz]
    (module docstring for the edge rules). ``f_hz`` must be strictly increasing, at least two points."""
    f = np.asarray(f_hz, dtype=float)
    a = np.asarray(amplitude_h, dtype=float)
    b = [str(x) for x in behaviour]
    if f.ndim != 1 or len(f) < 2 or len(b) != len(f) or a.shape != f.shape:
        raise ValueError("adaption bandwidth: f_hz, behaviour and amplitude_h must be 1-D of the same length >= 2")
    if not np.all(np.diff(f) > 0):
        raise ValueError("adaption bandwidth: f_hz must be strictly increasing")
    adaptive = np.array([x in ADAPTIVE for x in b])
    good = adaptive & np.isfinite(a) & (a >= a_min_h)
    pieces: List[Tuple[float, float]] = []
    for i in range(len(f) - 1):
        lo, hi = f[i], f[i + 1]
        if good[i] and good[i + 1]:
            pieces.append((lo, hi))
        elif good[i] or good[i + 1]:
            if adaptive[i] and adaptive[i + 1] and np.isfinite(a[i]) and np.isfinite(a[i + 1]):
                # A crosses a_min between the two runs: linear interpolation of A(f).
                edge = lo + (a_min_h - a[i]) / (a[i + 1] - a[i]) * (hi - lo)
            else:
                edge = 0.5 * (lo + hi)
            pieces.append((lo, edge) if good[i] else (edge, hi))
    merged: List[Tuple[float, float]] = []
    for p in ((float(lo), float(hi)) for lo, hi in pieces):
        if p[1] <= p[0]:
            continue
        if merged and p[0] <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], p[1]))
        else:
            merged.append(p)
    return merged


def adaption_bandwidth(f_hz: Sequence[float], behaviour: Sequence[str], amplitude_h: Sequence[float], *,
                       a_min_h: float = 0.3) -> float:
    """Adaption bandwidth [Hz] of one line of the band (module docstring)."""
    return float(sum(hi - lo for lo, hi in adapted_intervals(f_hz, behaviour, amplitude_h, a_min_h=a_min_h)))


def harvestable_level(f_hz: Sequence[float], amplitude_h: Sequence[float]) -> float:
    """Trapezoidal frequency average of (A/h)² over the band (a proxy of harvestable power; A = NaN counts 0)."""
    f = np.asarray(f_hz, dtype=float)
    a = np.nan_to_num(np.asarray(amplitude_h, dtype=float), nan=0.0)
    if len(f) < 2:
        raise ValueError("harvestable level: need at least two frequencies")
    y = a ** 2
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(f)) / (f[-1] - f[0]))


def robust_value(values: Sequence[float], robust: str, quantile: float = 0.25) -> float:
    """The robust aggregate over a sample: ``none`` (one value: itself), ``mean`` or ``quantile``
    (numpy's linear quantile)."""
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        raise ValueError("robust objective: empty sample")
    if robust == "none":
        if v.size != 1:
            raise ValueError("robust = 'none' takes one value")
        return float(v[0])
    if robust == "mean":
        return float(np.mean(v))
    if robust == "quantile":
        return float(np.quantile(v, quantile))
    raise ValueError(f"invalid robust aggregate {robust!r}")


@dataclass
class LineObjectives:
    """Objectives of one (a_ex, s0) line."""

    a_ex_m_s2: float
    s0: float
    bandwidth_hz: float
    harvest: float
    intervals: List[Tuple[float, float]]


def line_objectives(points: List[Dict[str, Any]], *, a_min_h: float) -> List[LineObjectives]:
    """Split runs (dicts with f_ex_hz, a_ex_m_s2, s0, behaviour, amplitude_final_h) into lines of
    equal (a_ex, s0) and compute bandwidth and harvestable level of each."""
    lines: Dict[Tuple[float, float], List[Dict[str, Any]]] = {}
    for p in points:
        lines.setdefault((float(p["a_ex_m_s2"]), float(p["s0"])), []).append(p)
    out = []
    for (a, s), pts in sorted(lines.items(), key=lambda kv: (kv[0][1], kv[0][0])):
        pts = sorted(pts, key=lambda p: p["f_ex_hz"])
        f = [p["f_ex_hz"] for p in pts]
        amp = [np.nan if p.get("amplitude_final_h") is None else p["amplitude_final_h"] for p in pts]
        beh = [p["behaviour"] for p in pts]
        iv = adapted_intervals(f, beh, amp, a_min_h=a_min_h)
        out.append(LineObjectives(a, s, float(sum(h - l for l, h in iv)), harvestable_level(f, amp), iv))
    return out


def sample_objectives(points: List[Dict[str, Any]], *, a_min_h: float) -> Dict[str, Any]:
    """Objectives of one parameter set over the band: the mean over the (a_ex, s0) lines of the
    bandwidth and the harvestable level, plus the per-line values."""
    lines = line_objectives(points, a_min_h=a_min_h)
    return {"bandwidth_hz": float(np.mean([l.bandwidth_hz for l in lines])),
            "harvest": float(np.mean([l.harvest for l in lines])),
            "lines": [{"a_ex_m_s2": l.a_ex_m_s2, "s0": l.s0, "bandwidth_hz": l.bandwidth_hz, "harvest": l.harvest,
                       "intervals": [list(iv) for iv in l.intervals]} for l in lines]}


def slider_moved(points: List[Dict[str, Any]], *, min_travel: float = 0.02) -> bool:
    """Whether the slider moved in any run (s_max − s_min ≥ ``min_travel``, in units of L): a
    slider that never moves at any operating point of the band is reported as jammed."""
    for p in points:
        lo, hi = p.get("s_min"), p.get("s_max")
        if lo is not None and hi is not None and hi - lo >= min_travel:
            return True
    return False
