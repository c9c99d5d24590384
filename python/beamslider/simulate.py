"""Runs of the free-slider (FS), pseudo-constrained (PCS) and beam-only models (docs/model.md §5–6),
the super-slow manifold (§6) and the envelope post-processing (§7)."""

from __future__ import annotations

import contextlib
import dataclasses
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Dict, Optional, Sequence, Tuple, Union

import numpy as np

from . import _core
from .params import Parameters, native, resolve
from .signals import envelope  # noqa: F401 (part of this module's face)
from ._util import MAX_INT, number, positive_int, progress_bar  # noqa: F401 (MAX_INT: part of this module's face)
from .trajectory import (COLUMNS, MEMORY_FRACTION, available_memory, check_disk, check_memory, check_out,  # noqa: F401
                         read_trajectory, recorded_size)

MODELS = ("fs", "pcs", "beam")

_FIELDS = ("t", "w", "s", "x_c", "z_c", "beta")

EXACT_ENVELOPE_SAMPLES = 2**18
"""Runs up to this many samples get the exact (whole-run FFT) envelope in figures and summaries;
longer ones the blocked envelope (power-of-two FFTs: a whole-run FFT of an awkward length such as
600 001 samples takes ten times one of 2^19)."""


PIXEL_COLUMNS = 2000
"""Columns a time panel of a figure is decimated to (more than the pixels of the figure's panels
at 120 dpi); streamed runs get this decimation from the core (:class:`RunOverview`)."""


@dataclass
class RunOverview:
    """What a summary and a figure need of a streamed run (``simulate(..., out=...)``), gathered
    by the core while the rows were written (core module ``overview``, docs/model.md §7), so that
    neither reads the trajectory back."""

    window: float
    """Moving-average window [s] of ``amplitude_h``."""
    t: np.ndarray
    """Centres of the 0.2-s bins of the super-slow signals [s]."""
    s: np.ndarray
    """Mean slider position s per bin [-]."""
    amplitude_h: np.ndarray
    """Super-slow amplitude of w(4L/7) / h per bin: the ``window``-second centred moving average
    of the binned |analytic signal| (FIR Hilbert transformer), exactly as an operating map
    computes it from samples every 20 steps (core ``envelope_stream``); the bins whose filter
    would see past the end (the last ≤ 0.25 s) are left out. Empty for runs shorter than one bin."""
    w_minmax: Optional[Tuple[np.ndarray, np.ndarray]]
    """(times [s], values [m]) of w(4L/7) decimated to ``columns`` pixel columns: the samples of
    each column's minimum and maximum in time order (as ``plotting.decimate_minmax``); None for
    short runs (< 4·columns rows) and runs that stopped early."""
    s_minmax: Optional[Tuple[np.ndarray, np.ndarray]]
    """The same decimation of s."""
    columns: int
    """Pixel columns of the decimation."""


@dataclass
class SimulationResult:
    """Recorded trajectory of one run (every ``record_every``-th step, start state included)."""

    t: np.ndarray
    """Time [s]."""
    w: np.ndarray
    """Elastic beam displacement at the laser position x = 4L/7 [m] (docs/model.md §7)."""
    s: np.ndarray
    """Relative slider position s = x_C/L [-] (the prescribed s for the PCS)."""
    x_c: np.ndarray
    """Horizontal position of the slider's centre of mass x_C [m]."""
    z_c: np.ndarray
    """Vertical position of the slider's centre of mass z_C [m]."""
    beta: np.ndarray
    """Slider rotation angle beta [rad]."""
    status: str
    """"completed", "left_beam" or "diverged" (the trajectory then ends at the fault)."""
    message: str
    """Status as a sentence."""
    counters: Dict[str, Any]
    """Solver and contact counters (steps, contact_steps, solver_iterations, cap_hits, ...)."""
    final_state: Dict[str, Any]
    """Final state: t_s, modal q and u, slider_q = (x_C, z_C, beta), slider_u."""
    params: Parameters
    """Parameters of the run."""
    f_ex: float
    """Excitation frequency [Hz]."""
    a_ex: float
    """Base-acceleration amplitude [m/s^2]."""
    s0: float
    """Initial relative slider position s0 [-] as requested (used by the FS model only)."""
    model: str
    """"fs", "pcs" or "beam"."""
    path: Optional[Path] = None
    """The trajectory file of a streamed run (``simulate(..., out=...)``), else None."""
    overview: Optional[RunOverview] = None
    """Of a streamed run: the super-slow signals and the figure's decimation computed by the core
    as the rows were written (:class:`RunOverview`); None for in-memory runs."""

    def __getattr__(self, name: str) -> Any:
        # The columns of a streamed CSV or Parquet run are read on first use (see read_trajectory).
        lazy = self.__dict__.get("_lazy_columns")
        if name in _FIELDS and lazy is not None:
            self.__dict__[name] = lazy[COLUMNS[_FIELDS.index(name)]]
            return self.__dict__[name]
        raise AttributeError(name)

    @property
    def completed(self) -> bool:
        """True when the requested duration was simulated."""
        return self.status == "completed"

    @property
    def dt_record(self) -> float:
        """Spacing of the recorded samples [s]."""
        return float(self.t[1] - self.t[0]) if len(self.t) > 1 else float("nan")

    def envelope(self, window: float = 1.0) -> np.ndarray:
        """Super-slow amplitude of w(4L/7) [m]: |Hilbert| then a ``window``-second moving average
        (docs/model.md §7). Computed once per window and kept."""
        cache = self.__dict__.setdefault("_envelopes", {})
        if window not in cache:
            cache[window] = envelope(self.t, self.w, window=window)
        return cache[window]

    def display_envelope(self, window: float = 1.0) -> np.ndarray:
        """The envelope for figures and summaries: :meth:`envelope` up to ``EXACT_ENVELOPE_SAMPLES``
        samples; for longer runs the analytic signal is computed in overlapping power-of-two FFT
        blocks (:func:`blocked_envelope`, O(n log block) instead of one FFT of the whole run)."""
        if len(self.t) <= EXACT_ENVELOPE_SAMPLES:
            return self.envelope(window)
        cache = self.__dict__.setdefault("_envelopes_blocked", {})
        if window not in cache:
            cache[window] = blocked_envelope(self.t, self.w, window=window)
        return cache[window]

    def columns(self) -> Dict[str, np.ndarray]:
        """The recorded columns under the core's channel names (as in its CSV files)."""
        return {
            "t_s": self.t,
            "w_4L7_m": self.w,
            "s": self.s,
            "xC_m": self.x_c,
            "zC_m": self.z_c,
            "beta_rad": self.beta,
        }


@dataclass
class ManifoldResult:
    """Super-slow manifold: steady-state amplitude of w(4L/7) against s (docs/model.md §6)."""

    up_s: np.ndarray
    """Slider positions of the upward sweep [-]."""
    up_amplitude: np.ndarray
    """Mean |Hilbert(w(4L/7))| on the upward sweep [m]."""
    down_s: np.ndarray
    """Slider positions of the downward sweep [-]."""
    down_amplitude: np.ndarray
    """Mean |Hilbert(w(4L/7))| on the downward sweep [m]."""
    counters: Dict[str, Any]
    """Solver and contact counters over all runs."""
    f_ex: float
    """Excitation frequency [Hz]."""
    a_ex: float
    """Base-acceleration amplitude [m/s^2]."""
    periods: int
    """Excitation periods simulated at each s."""
    record: int
    """Periods at the end of each s over which the amplitude is averaged."""
    params: Parameters = field(default_factory=Parameters)
    """Parameters of the runs."""


MAX_STEPS = 100_000_000_000
"""Most time steps of one run (the core's ``dynamics::simulation::MAX_STEPS``): a longer duration is refused before the run."""


def simulate(
    params: Optional[Parameters] = None,
    *,
    f_ex: float,
    a_ex: float,
    s0: float = 0.3,
    t_end: float,
    model: str = "fs",
    s_pcs: Optional[float] = None,
    dt: Optional[float] = None,
    record_every: int = 10,
    progress: Optional[bool] = False,
    out: Union[str, "os.PathLike[str]", None] = None,
    overwrite: bool = False,
    max_memory: Optional[float] = None,
    _check_only: bool = False,
    _window: float = 1.0,
    _on_start: Optional[Callable[[], Any]] = None,
) -> SimulationResult:
    """Integrate the beam–slider system with Moreau's midpoint scheme (docs/model.md §5–6).

    Args:
        params: model parameters (``None``: the defaults of docs/model.md §1).
        f_ex: excitation frequency [Hz].
        a_ex: base-acceleration amplitude [m/s^2].
        s0: initial relative slider position [-] of the free slider.
        t_end: simulated duration [s].
        model: "fs" (free slider), "pcs" (pseudo-constrained at ``s_pcs``, default ``s0``) or
            "beam" (beam only).
        s_pcs: slider position of the PCS model [-].
        dt: time step [s]; overrides ``params.dt_s``.
        record_every: keep every k-th step (the start state is the first sample).
        progress: show a tqdm progress bar (None: only when standard error is a terminal).
        out: stream the trajectory to this file as it is computed, at constant memory:
            ``"run.npz"`` (NumPy, one float64 ``<column>.npy`` per channel, stored uncompressed),
            ``"run.csv"`` (shortest round-trip numbers) or ``"run.parquet"`` (Apache Parquet,
            float64 columns in row groups of ``CHUNK_ROWS``; needs the extra ``parquet``,
            i.e. pyarrow: the run streams to a temporary ``.npz`` that is then copied chunk by
            chunk). The file is written under a temporary name and renamed when the run ends;
            an interrupted run leaves nothing under ``out``. The result's columns are then read
            lazily (see :func:`read_trajectory`): memory-mapped from the ``.npz``, column by
            column on first use from Parquet, converted chunk by chunk on first use from a CSV.
        overwrite: replace an existing ``out`` (default: refuse).
        max_memory: bytes the recorded arrays of an in-memory run may take (default: half of
            :func:`available_memory`); a larger run is refused before it starts with a
            ``ValueError`` giving the size. Not used with ``out``.

    A streamed run's result also carries ``overview`` (:class:`RunOverview`): the super-slow
    signals (1-s window) and the min/max decimation its figure draws, computed as it streamed.

    The interpreter is released while the core runs; Ctrl-C raises ``KeyboardInterrupt``
    within a few milliseconds. A run that stops on a fault (slider left the beam, divergence)
    returns the trajectory up to the fault with ``status`` set, and warns.
    """
    p = resolve(params)
    if dt is not None:
        p = dataclasses.replace(p, dt_s=dt)
    if model not in MODELS:
        raise ValueError(f"invalid parameter `model` = {model!r}: must be one of {', '.join(map(repr, MODELS))}")
    if model != "pcs" and s_pcs is not None:
        raise ValueError("invalid parameter `s_pcs`: only used with model=\"pcs\"")
    f_ex, a_ex, s0 = number("f_ex", f_ex), number("a_ex", a_ex), number("s0", s0)
    s_pcs_value = None if model != "pcs" else (s0 if s_pcs is None else number("s_pcs", s_pcs))
    record_every = positive_int("record_every", record_every)
    t_end = number("t_end", t_end)
    if not (np.isfinite(t_end) and t_end >= 0):
        raise ValueError(f"invalid parameter `t_end` = {t_end!r}: the duration (duration_s) must be finite and >= 0 s")
    steps = int(_core.recorded_rows(t_end, p.dt_s, 1)) - 1
    if steps > MAX_STEPS:
        raise ValueError(f"invalid parameter `t_end` = {t_end:.6g}: {t_end / p.dt_s:.3e} time steps of dt = {p.dt_s:g} s, "
                         f"more than the limit of {MAX_STEPS:.0e} ({MAX_STEPS * p.dt_s:.3e} s)")
    if steps < 1:
        raise ValueError(f"invalid parameter `t_end` = {t_end!r}: must be at least one time step (dt = {p.dt_s:g} s); "
                         "a run of zero length records only the start state")
    if record_every > steps:
        raise ValueError(f"invalid parameter `record_every` = {record_every}: larger than the run's {steps} time steps "
                         f"(t_end / dt): it would record only the start state")
    if _check_only:  # the core's checks of the run's inputs, before its first step; nothing runs
        _core.simulate(native(p), f_ex_hz=float(f_ex), a_ex_m_s2=float(a_ex), s0=float(s0), t_end_s=t_end,
                       model=model, s_pcs=s_pcs_value, record_every=record_every, check_only=True)
        return None  # type: ignore[return-value]
    target = check_out(out, overwrite, need_folder=_on_start is None)  # the hook may make the folder
    if target is None:
        check_memory(t_end, p.dt_s, record_every, max_memory)
    else:
        check_disk(target, t_end, p.dt_s, record_every)
    stream = target
    if target is not None and target.suffix.lower() == ".parquet":
        stream = target.with_name(f".{target.name}.partial-{os.getpid()}.npz")
    try:
        res = _run(p, progress, stream, f_ex=float(f_ex), a_ex=float(a_ex), s0=float(s0), t_end=t_end, model=model,
                   s_pcs=s_pcs_value, record_every=record_every, window=float(_window), on_start=_on_start)
        if stream is not target:
            from .trajectory import write_parquet_from_npz

            write_parquet_from_npz(stream, target)
    finally:
        if stream is not target:
            with contextlib.suppress(OSError):
                os.remove(stream)
    result = _result(res, p, f_ex, a_ex, s0, model, target)
    if result.counters.get("cap_hits", 0):
        warnings.warn(
            f"the contact solver hit its iteration cap in {result.counters['cap_hits']} steps "
            "(raise solver_max_iter or use contact_solver=\"fast\")",
            RuntimeWarning,
            stacklevel=2,
        )
    if not result.completed:
        warnings.warn(result.message, RuntimeWarning, stacklevel=2)
    return result


def _run(p: Parameters, progress: Optional[bool], out: Optional[Path], *, f_ex: float, a_ex: float, s0: float,
         t_end: float, model: str, s_pcs: Optional[float], record_every: int, window: float = 1.0,
         on_start: Optional[Callable[[], Any]] = None) -> Dict[str, Any]:
    with progress_bar(progress, t_end, f"{model.upper()} {f_ex:g} Hz {a_ex:g} m/s²", "s") as cb:
        res = _core.simulate(native(p), f_ex_hz=f_ex, a_ex_m_s2=a_ex, s0=s0, t_end_s=t_end, model=model,
                             s_pcs=s_pcs, record_every=record_every, progress=cb,
                             out=None if out is None else str(out), window_s=window, columns=PIXEL_COLUMNS,
                             on_start=on_start)
    res["window"] = window
    return res


def _overview(res: Dict[str, Any]) -> Optional[RunOverview]:
    o = res.get("overview")
    if o is None:
        return None
    w_pair, s_pair, ss = o
    if ss is None:
        t = s = a = np.empty(0)
    else:
        t0, dt, s, a = ss
        t = t0 + dt * np.arange(len(a))
    return RunOverview(window=res["window"], t=t, s=s, amplitude_h=a, w_minmax=w_pair, s_minmax=s_pair,
                       columns=PIXEL_COLUMNS)


def _result(res: Dict[str, Any], p: Parameters, f_ex: float, a_ex: float, s0: float, model: str,
            target: Optional[Path]) -> SimulationResult:
    empty = np.empty(0)
    result = SimulationResult(
        t=res.get("t_s", empty), w=res.get("w_4L7_m", empty), s=res.get("s", empty), x_c=res.get("xC_m", empty),
        z_c=res.get("zC_m", empty), beta=res.get("beta_rad", empty), status=res["status"], message=res["message"],
        counters=_lists(res["counters"]), final_state=_lists(res["final_state"]), params=p, f_ex=float(f_ex),
        a_ex=float(a_ex), s0=float(s0), model=model, path=target, overview=_overview(res))
    if target is not None:
        _attach(result, target)
    return result


def _lists(d: Dict[str, Any]) -> Dict[str, Any]:
    """A dict of the core's fixed-size arrays (tuples) with lists instead."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}


def _attach(result: SimulationResult, path: Path) -> None:
    """Columns of a streamed run: memory-mapped (.npz) or read on first use (CSV, Parquet)."""
    cols = read_trajectory(path)
    if path.suffix.lower() == ".npz":
        for f, c in zip(_FIELDS, COLUMNS):
            setattr(result, f, cols[c])
    else:
        for f in _FIELDS:
            del result.__dict__[f]
        result.__dict__["_lazy_columns"] = cols


def manifold_grid(params: Optional[Parameters] = None) -> np.ndarray:
    """Default slider positions of the physical manifold sweep: s = 0, 0.005, ..., 0.5 from the
    first s whose contact points lie on the beam (s >= B/(2L), docs/model.md §6)."""
    return np.asarray(_core.physical_manifold_grid(native(resolve(params))))


def super_slow_manifold(
    params: Optional[Parameters] = None,
    *,
    f_ex: float,
    a_ex: float,
    s: Optional[Sequence[float]] = None,
    periods: int = 100,
    record: int = 25,
    progress: bool = False,
    _stop: Any = None,
) -> ManifoldResult:
    """Super-slow manifold by sequential PCS continuation in s, upward then downward from the
    same initial state (docs/model.md §6).

    Args:
        params: model parameters (``None``: defaults).
        f_ex: excitation frequency [Hz].
        a_ex: base-acceleration amplitude [m/s^2].
        s: increasing slider positions of the upward sweep [-] (the downward sweep reverses
            them); default :func:`manifold_grid` (s = B/(2L) .. 0.5 in steps of 0.005).
        periods: excitation periods simulated at each s (reference 100, paper 300).
        record: periods at the end of each s over which the amplitude is averaged.
        progress: show a tqdm progress bar (one tick per s).

    The interpreter is released while the core runs. ``_stop`` (a ``threading.Event``) lets
    another thread stop a manifold computed in the background (``KeyboardInterrupt`` is raised).
    """
    p = resolve(params)
    f_ex, a_ex = number("f_ex", f_ex), number("a_ex", a_ex)
    grid = manifold_grid(p) if s is None else np.atleast_1d(np.asarray(s, dtype=float))
    if grid.ndim != 1 or grid.size == 0:
        raise ValueError("invalid parameter `s`: need a non-empty 1-D sequence of slider positions")
    if grid.size > 1 and np.any(np.diff(grid) <= 0):
        raise ValueError("invalid parameter `s`: slider positions must be strictly increasing")
    periods = positive_int("periods", periods)
    record = positive_int("record", record)
    if record > periods:
        raise ValueError(f"invalid parameter `record` = {record}: must lie in 1..=periods ({periods})")
    with progress_bar(progress, 2 * grid.size, f"manifold {f_ex:g} Hz {a_ex:g} m/s²", "pts") as bar:
        cb = bar if _stop is None else _stoppable(bar, _stop)
        out = _core.super_slow_manifold(
            native(p),
            f_ex_hz=float(f_ex),
            a_ex_m_s2=float(a_ex),
            s_values=[float(v) for v in grid],
            periods=periods,
            record_periods=record,
            progress=cb,
        )
    return ManifoldResult(
        up_s=np.asarray(out["up"]["s"], dtype=float),
        up_amplitude=np.asarray(out["up"]["amplitude_m"], dtype=float),
        down_s=np.asarray(out["down"]["s"], dtype=float),
        down_amplitude=np.asarray(out["down"]["amplitude_m"], dtype=float),
        counters=_lists(out["counters"]),
        f_ex=float(f_ex),
        a_ex=float(a_ex),
        periods=periods,
        record=record,
        params=p,
    )


def _stoppable(bar: Optional[Callable[[float, float], None]], stop: Any) -> Callable[[float, float], None]:
    """A monitor callback that raises ``KeyboardInterrupt`` once ``stop`` is set (the core's own
    Ctrl-C check only works in the main thread)."""
    def update(done: float, total: float) -> None:
        if stop.is_set():
            raise KeyboardInterrupt
        if bar is not None:
            bar(done, total)
    return update


def blocked_envelope(t: Any, w: Any, window: float = 1.0, *, block: int = 2**19, margin: int = 2**16) -> np.ndarray:
    """|analytic signal| of a long signal by FFTs of overlapping blocks of ``block`` samples (a
    power of two: fast FFTs), each block keeping its middle (``margin`` samples dropped at either
    inner edge; the last block is aligned with the end of the run, so every block has the same
    length), then the ``window``-second moving average (docs/model.md §7; computed by the core).
    The Hilbert kernel decays as 1/t, so the kept samples differ from the whole-run FFT envelope
    by far less than the line width of a figure (measured in tests/test_scale.py); the cost is
    O(n log block) and the memory one block. Runs shorter than ``block`` use blocks of the largest
    power of two that fits (at least 4·``margin``, else one FFT of the whole run). Used for figures
    and summaries of runs longer than ``EXACT_ENVELOPE_SAMPLES``."""
    t = np.asarray(t)
    if len(w) < 2:
        raise ValueError("need at least two samples")
    x = np.ascontiguousarray(w, dtype=float)
    return _core.envelope(x, float(t[1] - t[0]), float(window), block=int(block), margin=int(margin))
