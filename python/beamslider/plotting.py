"""Figures as the paper shows them (its Figs. 6–9): for one operating point (a) w(4L/7)/h against
time, (b) slider position s against time, (c) super-slow dynamics: envelope amplitude/h against s
with the super-slow manifold (harmonic balance or PCS, docs/model.md §6–7) overlaid; model and measurement overlaid.

Figures are built with ``matplotlib.figure.Figure`` (no pyplot, no global backend change), so
they work headless and in threads; ``path`` writes a PNG. matplotlib is an optional dependency
(``pip install "beamslider[plot]"``): this module imports without it, and each ``plot_*`` raises
an ``ImportError`` naming the extra when it is missing.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Optional, Union

import numpy as np

from ._mpl import require_matplotlib
from .measurement import Measurement
from .simulate import PIXEL_COLUMNS, ManifoldResult, SimulationResult

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

PathLike = Union[str, "os.PathLike[str]"]

MODEL_COLOR = "C0"
MEASURED_COLOR = "C1"
UP_COLOR = "C2"
DOWN_COLOR = "C3"


def _thin(n: int, limit: int) -> slice:
    return slice(None, None, max(1, n // limit))


ENVELOPE_POINTS = 4000
"""Points of the envelope curve of panel (c) (the envelope is a moving average: smooth)."""


def decimate_minmax(t: np.ndarray, y: np.ndarray, columns: int = PIXEL_COLUMNS):
    """What a screen can show of a long trace: the samples split into ``columns`` equal runs, and
    of each run its minimum and its maximum (in time order), so that the envelope of the drawn
    line is the envelope of the data. Short traces (< 4·columns samples) are returned as they are.
    Works through memory-mapped arrays without copying them whole."""
    n = len(t)
    if n < 4 * columns:
        return np.asarray(t), np.asarray(y)
    per = n // columns
    m = per * columns
    ts, ys = [], []
    block = max(1, (1 << 22) // per)  # rows of the (columns, per) view at a time: bounded temporaries
    for a in range(0, columns, block):
        b = min(columns, a + block)
        yy = np.asarray(y[a * per:b * per]).reshape(b - a, per)
        i_min = yy.argmin(axis=1)
        i_max = yy.argmax(axis=1)
        lo = np.minimum(i_min, i_max)
        hi = np.maximum(i_min, i_max)
        rows = np.arange(b - a)
        base = a * per + rows * per
        idx = np.empty(2 * (b - a), dtype=np.int64)
        idx[0::2] = base + lo
        idx[1::2] = base + hi
        ts.append(np.asarray(t[idx]))
        ys.append(np.stack([yy[rows, lo], yy[rows, hi]], axis=1).ravel())
    if m < n:  # the remainder: its extremes too
        r = np.asarray(y[m:])
        k = np.array(sorted({int(r.argmin()), int(r.argmax())})) + m
        ts.append(np.asarray(t[k]))
        ys.append(np.asarray(y[k]))
    return np.concatenate(ts), np.concatenate(ys)


def minmax_band(t: np.ndarray, y: np.ndarray, columns: int = PIXEL_COLUMNS):
    """The band a long trace fills on screen: for each of ``columns`` equal runs of samples its
    first time, minimum and maximum (as :func:`decimate_minmax`). None for short traces
    (< 4·columns samples), which are drawn as they are. One filled polygon draws in a fraction
    of the time of a line zig-zagging between the extremes, and looks the same at that density."""
    if len(t) < 4 * columns:
        return None
    return band_of_pairs(*decimate_minmax(t, y, columns), columns)


def band_of_pairs(td: np.ndarray, yd: np.ndarray, columns: int):
    """:func:`minmax_band` from a decimation already made (:func:`decimate_minmax`, or the
    core's of a streamed run, ``SimulationResult.overview``)."""
    m = 2 * columns  # the column pairs (the remainder's extremes are dropped: under one column)
    lo = np.minimum(yd[0:m:2], yd[1:m:2])
    hi = np.maximum(yd[0:m:2], yd[1:m:2])
    return td[0:m:2], lo, hi


def plot_operating_point(
    result: Optional[SimulationResult] = None,
    *,
    manifold: Optional[ManifoldResult] = None,
    measurement: Optional[Measurement] = None,
    window: float = 1.0,
    title: Optional[str] = None,
    path: Optional[PathLike] = None,
    dpi: int = 120,
) -> Figure:
    """Three-panel figure of one operating point (docs/model.md §7 post-processing).

    Args:
        result: simulated run (model), or None.
        manifold: super-slow manifold to overlay on panel (c): the PCS sweeps (``ManifoldResult``),
            the harmonic-balance branches (``superslow.HbManifold`` or the CLI's ``HbCurves``), or None.
        measurement: measured run to overlay, or None.
        window: moving-average window of the envelope [s].
        title: figure title (default: the operating point).
        path: if given, the PNG file to write.
        dpi: resolution of the PNG.
    """
    if result is None and measurement is None and manifold is None:
        raise ValueError("nothing to plot: give a simulation result, a measurement or a manifold")
    require_matplotlib("plot_operating_point")
    from matplotlib.figure import Figure
    h = (result.params if result is not None else manifold.params if manifold is not None else None)
    thickness = h.thickness_m if h is not None else 1e-3
    # Fixed margins (sized for the labels below) rather than constrained layout: it would lay
    # the text out twice, about a third of the drawing time.
    fig = Figure(figsize=(12, 6.5))
    gs = fig.add_gridspec(2, 2, width_ratios=[1.6, 1], left=0.065, right=0.99, bottom=0.115, top=0.895,
                          wspace=0.16, hspace=0.42)
    ax_w = fig.add_subplot(gs[0, 0])
    ax_s = fig.add_subplot(gs[1, 0], sharex=ax_w)
    ax_a = fig.add_subplot(gs[:, 1])

    series = []
    if measurement is not None:
        series.append(("measurement", MEASURED_COLOR, measurement.t, measurement.w, measurement.s,
                       measurement.envelope(window) if len(measurement.t) > 2 else None))
    ov = result.overview if result is not None else None
    if result is not None:
        # A streamed run brings what the figure needs from the core (computed as it streamed):
        # the min/max decimation of w and s and the super-slow signals; nothing is read back.
        # Beside a measurement both envelopes are computed alike (FFT Hilbert, per sample).
        if ov is not None and ov.window == window and len(ov.amplitude_h) and measurement is None:
            env = None  # panel (c) from the overview
        else:
            env = result.display_envelope(window) if len(result.t) > 2 else None
            ov = ov if ov is not None and (ov.w_minmax is not None or ov.s_minmax is not None) else None
        series.append(("model", MODEL_COLOR, result.t, result.w, result.s, env))

    for label, color, t, w, s, env in series:
        mine = ov if label == "model" else None
        if mine is not None and mine.w_minmax is not None:
            band = band_of_pairs(*mine.w_minmax, mine.columns)
        else:
            band = minmax_band(t, w)
        if band is None:
            ax_w.plot(t, np.asarray(w) / thickness, color=color, lw=0.4, alpha=0.8, label=label)
        else:  # min/max per pixel column as one filled band (docs/model.md §7, figures)
            tb, lo, hi = band
            ax_w.fill_between(tb, lo / thickness, hi / thickness, color=color, lw=0, alpha=0.8, label=label)
        ts, ss = mine.s_minmax if mine is not None and mine.s_minmax is not None else decimate_minmax(t, s)
        ax_s.plot(ts, ss, color=color, lw=1.2, label=label)
        if mine is not None and env is None and mine.window == window and len(mine.amplitude_h):
            # the super-slow signals (0.2-s bins of a 1-s moving average: already smooth)
            xs, amp_h, x0, a0, x1, a1 = (mine.s, mine.amplitude_h, mine.s[0], mine.amplitude_h[0], mine.s[-1],
                                         mine.amplitude_h[-1])
        elif env is not None:
            k = _thin(len(t), ENVELOPE_POINTS)
            xs, amp_h, x0, a0, x1, a1 = (s[k], env[k] / thickness, s[0], env[0] / thickness, s[-1],
                                         env[-1] / thickness)
        else:
            continue
        ax_a.plot(xs, amp_h, color=color, lw=1.2, label=f"{label} (envelope)")
        ax_a.plot(x0, a0, "o", color=color, ms=6, mfc="white", zorder=5)
        ax_a.plot(x1, a1, "o", color=color, ms=6, zorder=5)
    if manifold is not None and hasattr(manifold, "high"):
        # harmonic-balance manifold (docs/model.md §6.4): amplitudes already in units of h
        n = getattr(manifold, "n_modes", 0)
        tag = f"HB manifold (N = {n})" if n else "HB manifold"
        for name, color, style in (("high", UP_COLOR, "--"), ("low", DOWN_COLOR, "--"), ("middle", "0.45", ":")):
            b = getattr(manifold, name)
            if len(b.s):
                order = np.argsort(b.s)
                ax_a.plot(np.asarray(b.s)[order], np.asarray(b.amplitude)[order], style, color=color, lw=1.0,
                          label=f"{tag}, {name} branch" + (" (unstable)" if name == "middle" else ""))
    elif manifold is not None:
        per = f", {manifold.periods} periods per s-step" if manifold.periods else ""
        ax_a.plot(manifold.up_s, manifold.up_amplitude / thickness, "^--", color=UP_COLOR, ms=3, lw=0.8,
                  label=f"PCS manifold, upward sweep{per}")
        ax_a.plot(manifold.down_s, manifold.down_amplitude / thickness, "v--", color=DOWN_COLOR, ms=3, lw=0.8,
                  label=f"PCS manifold, downward sweep{per}")
    if result is not None and not result.completed:
        # A run that stopped early (diverged, left the beam) may leave too little for an envelope.
        t_stop = float(result.t[-1]) if len(result.t) else 0.0
        empty = not any(env is not None and len(t) > 2 and t[-1] - t[0] >= window for _, _, t, _, _, env in series)
        empty = empty and not (ov is not None and env is None and len(ov.amplitude_h))
        note = f"model run {result.status} at t = {t_stop:.4g} s" + (
            f":\nshorter than the {window:g}-s envelope window,\nno super-slow amplitude to show" if empty else "")
        ax_a.text(0.5, 0.5 if empty else 0.04, note, transform=ax_a.transAxes, ha="center",
                  va="center" if empty else "bottom", fontsize=9, color="0.3",
                  bbox=dict(boxstyle="round", fc="white", ec="0.7"))

    ax_w.set_xlabel("time t [s]")
    ax_w.tick_params(labelbottom=True)
    ax_w.set_ylabel("w(4L/7) / h")
    ax_w.set_title("(a) beam response", loc="left")
    ax_s.set_xlabel("time t [s]")
    ax_s.set_ylabel("slider position s = x/L")
    ax_s.set_title("(b) slider position", loc="left")
    ax_a.set_xlabel("slider position s = x/L")
    ax_a.set_ylabel(f"amplitude of w(4L/7) / h ({window:g} s moving average)")
    ax_a.set_title("(c) super-slow dynamics (○ start, ● end)", loc="left")
    for ax in (ax_w, ax_s, ax_a):
        ax.grid(True, lw=0.3, alpha=0.6)
    if len(series) > 1:
        ax_w.legend(loc="upper right", fontsize=8)
        ax_s.legend(loc="best", fontsize=8)
    if ax_a.lines:
        ax_a.legend(loc="best", fontsize=8)
    fig.suptitle(title or _title(result, measurement, manifold))
    fig.supxlabel(f"w(4L/7): elastic deflection of the beam at the laser position x = 4L/7;  "
                  f"h = beam thickness = {thickness * 1e3:g} mm;  L = beam length", fontsize=9, color="0.25", y=0.012)
    if path is not None:
        fig.savefig(os.fspath(path), dpi=dpi)
    return fig


def _title(result, measurement, manifold) -> str:
    src = result or measurement or manifold
    f, a = getattr(src, "f_ex", None), getattr(src, "a_ex", None)
    parts = []
    if f is not None and a is not None:
        parts.append(f"f_ex = {f:g} Hz, a_ex = {a:g} m/s²")
    s0 = getattr(result, "s0", None) if result is not None and result.model == "fs" else getattr(measurement, "s0", None)
    if s0 is not None:
        parts.append(f"s₀ = {s0:g}")
    if result is not None and result.model != "fs":
        parts.append(f"{result.model.upper()} model")
    if result is not None and not result.completed:
        parts.append(f"[{result.status}]")
    return ", ".join(parts) or "beamslider"


def plot_manifold(
    manifold: ManifoldResult,
    *,
    title: Optional[str] = None,
    path: Optional[PathLike] = None,
    dpi: int = 120,
) -> Figure:
    """Super-slow manifold (docs/model.md §6): amplitude/h of w(4L/7) against s, both sweeps."""
    require_matplotlib("plot_manifold")
    from matplotlib.figure import Figure

    h = manifold.params.thickness_m
    fig = Figure(figsize=(7, 4.5), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(manifold.up_s, np.asarray(manifold.up_amplitude) / h, "^-", color=UP_COLOR, ms=3, lw=0.8,
            label="upward sweep")
    ax.plot(manifold.down_s, np.asarray(manifold.down_amplitude) / h, "v-", color=DOWN_COLOR, ms=3, lw=0.8,
            label="downward sweep")
    ax.set_xlabel("slider position s = x/L")
    ax.set_ylabel(f"amplitude of w(4L/7) / h   (h = {h * 1e3:g} mm)")
    ax.grid(True, lw=0.3, alpha=0.6)
    ax.legend(loc="best", fontsize=8)
    per = f" ({manifold.periods} periods per s-step)" if manifold.periods else ""
    ax.set_title(title or f"PCS manifold, f_ex = {manifold.f_ex:g} Hz, a_ex = {manifold.a_ex:g} m/s²{per}")
    if path is not None:
        fig.savefig(os.fspath(path), dpi=dpi)
    return fig
