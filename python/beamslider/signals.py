"""Signals of uniformly sampled data (docs/model.md §7): the super-slow amplitude of a run's or a
measurement's beam response, by the core (``beamslider-core``'s ``signal``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from . import _core

__all__ = ["envelope"]


def envelope(t: Any, w: Any, window: float = 1.0) -> np.ndarray:
    """Super-slow amplitude of a uniformly sampled signal (docs/model.md §7): |Hilbert(w)| (FFT-based
    analytic signal) followed by a centred moving average over ``window`` seconds.

    Args:
        t: sample times [s], uniformly spaced.
        w: signal (e.g. w(4L/7) [m]).
        window: moving-average window [s].
    """
    t = np.asarray(t, dtype=float)
    w = np.ascontiguousarray(w, dtype=float)
    if t.ndim != 1 or w.ndim != 1 or t.shape != w.shape:
        raise ValueError(f"t and w must be 1-D arrays of the same length (got {t.shape} and {w.shape})")
    if t.size < 2:
        raise ValueError("need at least two samples")
    for name, arr in (("t", t), ("w", w)):
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise ValueError(f"invalid parameter `{name}`: {bad.size} non-finite value(s) (NaN or inf), the first at "
                             f"index {bad[0]}; the envelope of a signal with gaps is undefined")
    steps = np.diff(t)
    dt = float(np.median(steps))
    if not dt > 0 or np.any(np.abs(steps - dt) > 0.01 * dt):
        raise ValueError("t must be uniformly spaced and increasing")
    return _core.envelope(w, dt, float(window))
