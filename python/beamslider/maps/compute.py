"""Operating maps: the behaviour classification and the maps themselves — free-slider runs by the core (locally or on Dask) (docs/model.md §8, the paper's Fig. 11). A map predicted by the slow flow is the predictor's (:func:`beamslider.superslow.predicted_map`, the same results format and writer).

A map started by ``beamslider map``, ``beamslider-batch map`` or :func:`operating_map` can be
resumed by any of them (same configuration, same results file).
"""

from __future__ import annotations

import errno
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, List, Optional, Union

import numpy as np

from .. import _core, _toml
from .._overwrite import clear_results, refuse_existing
from .._util import progress_bar, remove_dead_partials, write_text_atomic
from ..params import Parameters
from .config import MIN_CLASSIFY_S, RESULTS_FILE, criteria_values, map_config
from ..tables import MapTable
from .read import check_rows, grid_points, rows_to_table, saved_grid

__all__ = ["Classification", "classify", "classify_result", "operating_map", "run_map_config", "super_slow_signals"]


@dataclass
class Classification:
    """Behaviour of one run and the features behind it (see ``beamslider-core``'s ``classify``)."""

    behaviour: str
    """One of :data:`BEHAVIOURS`."""
    reason: str
    """Why (for ``undetermined``: why no behaviour fits)."""
    features: Dict[str, Any] = field(default_factory=dict)
    """s_initial, s_final, amplitude_final_h, amplitude_initial_h, amplitude_max_h, s_min, s_max,
    net_travel, travel_to_centre, turn_s, turn_t_s (NaN when no turning point), jump_up_t_s,
    jump_down_t_s, steady, phase (the phase reached at the end, e.g. ``steady_high`` or, for
    a run that has not settled, ``high_towards_centre``), settled (the behaviour is final; false
    for ``not_settled`` and for a behaviour reached whose run still creeps), drift_s and drift_a_h
    (change of s and A along their least-squares lines over the final drift window)."""


def classify(t: Any, s: Any, amplitude_h: Any, *, criteria: Optional[Dict[str, float]] = None) -> Classification:
    """Classify super-slow signals: uniformly sampled times ``t`` [s], slider position ``s`` and
    amplitude ``amplitude_h`` (1-s moving average of |Hilbert(w(4L/7))| divided by h). ``criteria``
    overrides thresholds of the core (keys as in the ``[criteria]`` table of a map config)."""
    t = np.ascontiguousarray(t, dtype=float)
    s = np.ascontiguousarray(s, dtype=float)
    a = np.ascontiguousarray(amplitude_h, dtype=float)
    if not (t.ndim == s.ndim == a.ndim == 1 and len(t) == len(s) == len(a)):
        raise ValueError("t, s and amplitude_h must be 1-D arrays of the same length")
    if len(t) < 3:
        raise ValueError(f"invalid parameter `t`: {len(t)} samples; need at least three (and at least "
                         f"{MIN_CLASSIFY_S:g} s of signal)")
    steps = np.diff(t)
    dt = float(np.median(steps))
    if not (np.all(np.isfinite(t)) and dt > 0 and np.all(np.abs(steps - dt) <= 1e-6 * max(dt, abs(float(t[-1]))))):
        raise ValueError("invalid parameter `t`: the samples must be uniformly spaced and increasing")
    if t[-1] - t[0] < MIN_CLASSIFY_S:
        raise ValueError(f"invalid parameter `t`: the signals span {t[-1] - t[0]:g} s; the classification needs at least "
                         f"{MIN_CLASSIFY_S:g} s (the amplitude's moving-average window)")
    c = _core.classify(s, a, dt, t0_s=float(t[0]), criteria=criteria_values(criteria))
    behaviour, reason = c.pop("behaviour"), c.pop("reason")
    for k in ("turn_s", "turn_t_s", "drift_s", "drift_a_h"):
        c[k] = float("nan") if c.get(k) is None else c[k]
    return Classification(behaviour=behaviour, reason=reason, features=c)


def super_slow_signals(result: Any, *, window: float = 1.0):
    """The super-slow signals a map classifies (core module ``envelope_stream``): times of 0.2-s
    bins, s averaged per bin, and A = ``window``-second moving average of the binned |analytic
    signal| of w(4L/7) (FIR Hilbert transformer) in units of h. Returns (t, s, A)."""
    if len(result.t) < 2:
        raise ValueError("the run has fewer than two samples")
    t0, dt, s, a = _core.super_slow_signals(np.ascontiguousarray(result.w, dtype=float),
                                           np.ascontiguousarray(result.s, dtype=float),
                                           float(result.dt_record), result.params.thickness_m, float(window))
    s = np.asarray(s)
    return float(result.t[0]) + t0 + dt * np.arange(len(s)), s, np.asarray(a)


def classify_result(result: Any, *, window: float = 1.0,
                    criteria: Optional[Dict[str, float]] = None) -> Classification:
    """Classify a free-slider run of :func:`beamslider.simulate` by its phases, from the same
    super-slow signals as a map point (:func:`super_slow_signals`): the label of a run from rest
    equals the map's label of that point for the same duration and recording interval."""
    if result.model != "fs":
        raise ValueError(f"classification needs a free-slider run (model 'fs'), got {result.model!r}")
    t, s, amp = super_slow_signals(result, window=window)
    return classify(t, s, amp, criteria=criteria)


def _map_chunk(config: "_core.MapConfig", jobs: List[tuple], threads: int) -> List[str]:
    """A Dask task of a map: one chunk of jobs through the Rust core (rayon, interpreter released)."""
    from beamslider import _core as core

    return core.run_map_chunk(config, jobs, threads=threads)


def _watching(results: Optional[Path], bar: Any) -> Any:
    """The progress callback of a map: stops the run at the next row when its output folder has
    vanished (deleted or moved: the rows would go to a file nobody can read), then ``bar``."""
    if results is None:
        return bar

    def watch(done: float, total: float) -> None:
        if not results.exists():
            raise FileNotFoundError(errno.ENOENT, "the map's results file vanished during the run (output folder deleted "
                                    "or moved): stopped; run the map again into a folder that stays", str(results))
        if bar is not None:
            bar(done, total)

    return watch


def _widened(canonical: str, folder: Path) -> str:
    """The configuration to save on a resume: its grid axes joined with those of the map.toml in
    ``folder`` (a resume over fewer points must not narrow what a later --extend-to extends)."""
    try:
        old = _toml.loads((folder / "map.toml").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return canonical
    new = _toml.loads(canonical)
    grid = dict(new.get("grid", {}))
    for axis, values in old.get("grid", {}).items():
        if axis in grid and isinstance(values, list) and isinstance(grid[axis], list):
            grid[axis] = sorted({float(v) for v in values} | {float(v) for v in grid[axis]})
    return _toml.dumps({**new, "grid": grid})


def run_map_config(config_toml: Union[str, "_core.MapConfig"], *, out: Optional[Union[str, Path]] = None, resume: bool = False,
                   threads: Optional[int] = None, progress: Optional[bool] = False, extend: bool = False,
                   report: bool = True, scheduler: Any = None, scheduler_file: Optional[str] = None,
                   chunk_size: int = 8, task_threads: int = 1, max_retries: int = 3, force: bool = False) -> MapTable:
    """Run a map from configuration TOML text (see :func:`map_config_toml`) or the core's parsed
    configuration (``beamslider._core.MapConfig``, parsed and checked once); ``out`` is the output
    folder (results appended to ``out/map.jsonl`` point by point, the configuration written to
    ``out/map.toml``). ``extend``: the map in ``out`` was run for a shorter duration; continue its
    points with ``settled`` false and its undetermined points from their saved end states to the
    configuration's duration (the count is printed when ``report``); ``map.toml`` takes the new
    duration once the extension completes (an interrupted one is finished by the same call).
    ``force``: replace an earlier map in ``out`` (its results and files removed once the map is
    checked). ``scheduler`` / ``scheduler_file``: run the points on a Dask
    cluster in chunks of ``chunk_size`` (see :func:`operating_map`)."""
    cfg = _core.MapConfig(config_toml) if isinstance(config_toml, str) else config_toml
    canonical, (f, a, s) = cfg.toml(), cfg.axes
    total = len(f) * len(a) * len(s)
    if threads is not None and (not isinstance(threads, (int, np.integer)) or isinstance(threads, bool) or threads < 1
                                or threads > 65536):
        raise ValueError(f"invalid parameter `threads` = {threads!r}: must be an integer in 1..=65536")
    for name, v in (("chunk_size", chunk_size), ("task_threads", task_threads)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= 1_000_000:
            raise ValueError(f"invalid parameter `{name}` = {v!r}: must be an integer >= 1")
    results = None
    if extend and out is None:
        raise ValueError("invalid parameter `extend_to`: needs `out`, the folder of the map to extend")
    if force and (resume or extend):
        raise ValueError("invalid parameter `force`: replaces the map in `out`; it does not go with resume or extend_to")
    client, own = None, False
    if scheduler is not None or scheduler_file is not None:
        from .._dask import connect

        client, own = connect(scheduler, scheduler_file)  # before any file is written
    saved_toml = canonical
    try:
        if out is not None:
            folder = Path(out)
            results = folder / RESULTS_FILE
            if force:  # checked without the results it replaces, then they go
                cfg.check()
                clear_results(folder, RESULTS_FILE, ["map.toml", "map.txt", "map.png"])
            elif not (resume or extend):
                refuse_existing(results, total, "points", "map")
            # Everything the run would refuse is refused before map.toml is (over)written.
            cfg.check(out=results, resume=resume, extend=extend)
            if (resume or extend) and results.exists():
                old_grid = saved_grid(folder)
                check_rows(results, None if old_grid is None else old_grid | grid_points(cfg))
                saved_toml = _widened(canonical, folder)
            folder.mkdir(parents=True, exist_ok=True)
        # Takes the results file's lock (a second writer fails here), writes the header.
        run = _core.MapRun(cfg, out=results, resume=resume, extend=extend)
        try:
            if out is not None:
                remove_dead_partials(out)
            if out is not None and not extend:  # an extension's settings change once it completes
                write_text_atomic(Path(out) / "map.toml", saved_toml)
            if report and resume and run.done:
                print(f"{run.done} of {total} points kept from {results}; running the other {total - run.done}")
            with progress_bar(progress, total, "map", "pts") as bar:
                watch = _watching(results, bar)
                if client is None:
                    run.run_local(threads=None if threads is None else int(threads), progress=watch)
                else:
                    from .._dask import run_chunks

                    jobs = run.jobs()
                    chunks = [(cfg, jobs[i:i + chunk_size], int(task_threads))
                              for i in range(0, len(jobs), chunk_size)]

                    def on_rows(rows: List[str]) -> None:
                        run.append(rows)
                        if watch is not None:
                            watch(run.done, total)

                    run_chunks(client, _map_chunk, chunks, tag="map" + canonical, on_rows=on_rows,
                               max_retries=max_retries)
            rows, extended = run.finish()
            if out is not None and extend:
                write_text_atomic(Path(out) / "map.toml", saved_toml)
        finally:
            run.close()
    finally:
        if own:
            from .._dask import close_client

            close_client(client)
    table = rows_to_table([json.loads(r) for r in rows])
    if report and (extend or extended):
        t_end = float(_toml.loads(canonical)["duration_s"])
        print(f"re-ran {extended} of {len(table['index'])} points (settled = false, or undetermined) from their saved end "
              f"states to t_end = {t_end:g} s")
    return table


def operating_map(params: Optional[Parameters] = None, *, f_ex: Any, a_ex: Any, s0: Any = 0.3,
                  t_end: float = 120.0, threads: Optional[int] = None, out: Optional[Union[str, Path]] = None,
                  resume: bool = False, record_every: int = 20, criteria: Optional[Dict[str, float]] = None,
                  progress: Optional[bool] = False, extend_to: Optional[float] = None, scheduler: Any = None,
                  scheduler_file: Optional[str] = None, chunk_size: int = 8, force: bool = False) -> MapTable:
    """Operating map (docs/model.md §8): the behaviour of the free slider at every (f_ex, a_ex, s0) of the
    grid, each point a ``t_end``-second run from rest classified by the core, in parallel on
    ``threads`` threads (default: one per core).

    ``out``: output folder; each finished point is appended to ``out/map.jsonl`` at once, and with
    ``resume=True`` the points already there are skipped (a map started by ``beamslider map`` or
    ``beamslider-batch map`` with the same settings can be resumed, and vice versa). Ctrl-C stops
    the map (``KeyboardInterrupt``) keeping the finished points.

    ``extend_to``: extend the map in ``out`` (run for ``t_end`` seconds) to ``extend_to`` seconds:
    the points that have not settled (``settled`` false: ``not_settled``, or a behaviour reached
    whose run still creeps) or got no behaviour (``undetermined``) continue from the end states saved in the
    results file — each continued row is bitwise the row of a ``extend_to``-second run from rest,
    but for the wall time — and the settled points keep their rows; the number of re-run points
    is printed. An interrupted extension is finished by the same call.

    ``scheduler`` (an address such as ``"tcp://10.0.0.5:8786"`` or a ``distributed.Client``) or
    ``scheduler_file`` (written by ``dask scheduler --scheduler-file``): run the points on a Dask
    cluster, ``chunk_size`` points per task; the scheduler is contacted before any file is
    written, the results file, its lock and ``resume`` are the same, and every row is bitwise
    the row of the local map (but ``wall_time_s``). A chunk lost with its worker is re-run.

    Only one process may write a map folder at a time: a second one fails at once
    (``BlockingIOError`` naming the folder and the holder's PID). An earlier map in ``out`` is
    refused unless ``resume`` continues it or ``force`` replaces it.

    A map predicted by the reduced super-slow model (milliseconds per point) is the predictor's:
    :func:`beamslider.superslow.predicted_map` (same results format and writer).

    Returns a :class:`~beamslider.tables.MapTable`: a dict of numpy arrays, one entry per grid
    point in grid order (s0 slowest, then a_ex, f_ex fastest; see :func:`rows_to_table`), with
    ``.to_pandas()`` (a DataFrame) and ``.to_xarray()`` (a Dataset over f_ex_hz, a_ex_m_s2, s0).
    """
    if extend_to is not None:
        try:
            te = float(extend_to)
        except (TypeError, ValueError):
            raise ValueError(f"invalid parameter `extend_to` = {extend_to!r}: give a number of seconds") from None
        if not (np.isfinite(te) and te > float(t_end)):
            raise ValueError(f"invalid parameter `extend_to` = {extend_to!r}: must exceed the map's t_end ({float(t_end):g} s)")
        if out is None:
            raise ValueError("invalid parameter `extend_to`: needs `out`, the folder of the map to extend")
        results = Path(out) / RESULTS_FILE
        if not results.exists():
            raise ValueError(f"invalid parameter `extend_to`: no map to extend in {out} ({RESULTS_FILE} missing)")
        header, _rows, _good, _trunc = _core.read_results_file(results)
        done = json.loads(header)["settings"]["duration_s"] if header else None
        if done not in (float(t_end), te):
            raise ValueError(f"invalid parameter `t_end` = {t_end!r}: the map in {out} was run for {done} s")
        cfg = map_config(params, f_ex=f_ex, a_ex=a_ex, s0=s0, t_end=te, record_every=record_every, criteria=criteria)
        return run_map_config(cfg, out=out, threads=threads, progress=progress, extend=True, scheduler=scheduler,
                              scheduler_file=scheduler_file, chunk_size=chunk_size)
    cfg = map_config(params, f_ex=f_ex, a_ex=a_ex, s0=s0, t_end=t_end, record_every=record_every, criteria=criteria)
    return run_map_config(cfg, out=out, resume=resume, threads=threads, progress=progress, scheduler=scheduler,
                          scheduler_file=scheduler_file, chunk_size=chunk_size, force=force)
