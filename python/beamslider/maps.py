"""Operating maps (docs/model.md §8, the paper's Fig. 11) and the behaviour classification.

The work is done by the Rust core (``beamslider-core``: modules ``classify`` and ``map``); this
module builds the map configuration (the same TOML ``beamslider-batch map --config`` reads),
turns the rows of the results file (JSON lines, ``<out>/map.jsonl``) into numpy arrays and draws
the categorical map. A map started by ``beamslider map``, ``beamslider-batch map`` or
:func:`operating_map` can be resumed by any of them (same configuration, same results file).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np

from . import _core, _toml
from .params import Parameters, resolve
from .simulate import SimulationResult, _progress_bar

RESULTS_FILE = "map.jsonl"
"""Name of the results file inside a map's output folder."""

BEHAVIOURS = ("inactivity", "trivial_adaption", "signature_move", "relaxation_oscillation", "self_damping",
              "not_settled", "undetermined")
"""Behaviour names as written in results files (docs/model.md §8), in legend order."""

LETTERS = {"inactivity": "I", "trivial_adaption": "T", "signature_move": "S", "relaxation_oscillation": "R",
           "self_damping": "D", "not_settled": "N", "undetermined": "?"}
"""One letter per behaviour for text tables."""

LABELS = {"inactivity": "inactivity", "trivial_adaption": "trivial adaption", "signature_move": "signature move",
          "relaxation_oscillation": "relaxation oscillation", "self_damping": "self-damping",
          "not_settled": "not settled", "undetermined": "undetermined"}

MIN_CLASSIFY_S = 1.0
"""Shortest signal :func:`classify` accepts [s] (the 1-s moving average of the amplitude)."""

_SCALARS = ("index", "f_ex_hz", "a_ex_m_s2", "s0", "t_end_s", "s_final", "amplitude_final_h", "amplitude_initial_h",
            "amplitude_max_h", "s_min", "s_max", "net_travel", "travel_to_centre", "turn_s", "turn_t_s",
            "wall_time_s")


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
    ``not_settled``, ``high_towards_centre``)."""


def _number(name: str, v: Any) -> Any:
    """A number for a TOML value (int stays int; bools and non-numbers are a ValueError naming ``name``)."""
    if isinstance(v, (bool, np.bool_)):
        raise ValueError(f"invalid parameter `{name}` = {v!r}: expected a number")
    if isinstance(v, (int, np.integer)):
        return int(v)
    try:
        return float(v)
    except (TypeError, ValueError):
        raise ValueError(f"invalid parameter `{name}` = {v!r}: expected a number") from None


def _criteria_toml(criteria: Optional[Dict[str, float]]) -> Optional[str]:
    if not criteria:
        return None
    return _toml.dumps({str(k): _number(f"criteria.{k}", v) for k, v in criteria.items()})


def map_config_dict(params: Optional[Parameters] = None, *, f_ex: Any, a_ex: Any, s0: Any = 0.3,
                    t_end: float = 120.0, record_every: int = 20, dt_s: Optional[float] = None,
                    criteria: Optional[Dict[str, float]] = None) -> Dict[str, Any]:
    """The tables of a map configuration (see :func:`map_config_toml`)."""
    d: Dict[str, Any] = {"duration_s": float(t_end), "record_every": int(record_every)}
    if dt_s is not None:
        d["dt_s"] = float(dt_s)
    d["grid"] = {key: _axis(name, values) for key, name, values in
                 (("f_ex_hz", "f_ex", f_ex), ("a_ex_m_s2", "a_ex", a_ex), ("s0", "s0", s0))}
    d["params"] = _toml.loads(resolve(params).toml_text())
    if criteria:
        d["criteria"] = {str(k): _number(f"criteria.{k}", v) for k, v in criteria.items()}
    return d


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
    c = json.loads(_core.classify(s, a, dt, t0_s=float(t[0]), criteria_toml=_criteria_toml(criteria)))
    behaviour, reason = c.pop("behaviour"), c.pop("reason")
    for k in ("turn_s", "turn_t_s"):
        c[k] = float("nan") if c.get(k) is None else c[k]
    return Classification(behaviour=behaviour, reason=reason, features=c)


def super_slow_signals(result: SimulationResult, *, window: float = 1.0):
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


def classify_result(result: SimulationResult, *, window: float = 1.0,
                    criteria: Optional[Dict[str, float]] = None) -> Classification:
    """Classify a free-slider run of :func:`beamslider.simulate` by its phases, from the same
    super-slow signals as a map point (:func:`super_slow_signals`): the label of a run from rest
    equals the map's label of that point for the same duration and recording interval."""
    if result.model != "fs":
        raise ValueError(f"classification needs a free-slider run (model 'fs'), got {result.model!r}")
    t, s, amp = super_slow_signals(result, window=window)
    return classify(t, s, amp, criteria=criteria)


def _axis(name: str, values: Any) -> List[float]:
    arr = np.atleast_1d(np.asarray(values, dtype=float))
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"invalid parameter `{name}`: give a number or a non-empty 1-D sequence")
    return [float(v) for v in arr]


def map_config_toml(params: Optional[Parameters] = None, *, f_ex: Any, a_ex: Any, s0: Any = 0.3,
                    t_end: float = 120.0, record_every: int = 20,
                    criteria: Optional[Dict[str, float]] = None) -> str:
    """The map configuration as TOML (the format of ``beamslider-batch map --config``)."""
    return _toml.dumps(map_config_dict(params, f_ex=f_ex, a_ex=a_ex, s0=s0, t_end=t_end,
                                         record_every=record_every, criteria=criteria))


def default_map_config() -> str:
    """The paper's map (f_ex = 100, 102, …, 130 Hz, a_ex = 4, 6, …, 16 m/s², s0 = 0.3, 120 s) as TOML."""
    return _core.default_map_config()


def rows_to_table(rows: Sequence[Dict[str, Any]]) -> Dict[str, np.ndarray]:
    """Map rows (dicts as in the results file) as a dict of numpy arrays: the scalar features
    (float; NaN for a missing turning point), ``behaviour``, ``reason``, ``status``, ``phase`` (str),
    ``has_end_state`` (bool: the run can be continued by ``extend_to``),
    ``steady`` (bool), ``jump_up_t_s``/``jump_down_t_s`` (object arrays of lists) and the solver
    counters as ``counters_<name>`` (int)."""
    rows = sorted(rows, key=lambda r: r["index"])
    out: Dict[str, np.ndarray] = {}
    for k in _SCALARS:
        out[k] = np.array([np.nan if r.get(k) is None else r[k] for r in rows], dtype=float)
    out["index"] = out["index"].astype(int)
    for k in ("behaviour", "reason", "status", "phase"):
        out[k] = np.array([r.get(k, "") for r in rows], dtype=object).astype(str) if rows else np.array([], dtype=str)
    out["has_end_state"] = np.array(["end" in r for r in rows], dtype=bool)
    out["steady"] = np.array([bool(r["steady"]) for r in rows], dtype=bool)
    for k in ("jump_up_t_s", "jump_down_t_s"):
        arr = np.empty(len(rows), dtype=object)
        for i, r in enumerate(rows):
            arr[i] = list(r[k])
        out[k] = arr
    names = list(rows[0]["counters"]) if rows else []
    for n in names:
        if n == "closed_histogram":
            out["counters_closed_histogram"] = np.array([r["counters"][n] for r in rows], dtype=np.int64)
        else:
            out[f"counters_{n}"] = np.array([r["counters"][n] for r in rows], dtype=np.int64)
    return out


def read_map(path: Union[str, Path]) -> Dict[str, np.ndarray]:
    """Read a map's results (``map.jsonl`` or its folder) into the table of :func:`operating_map`.
    A truncated last line (a map killed while writing) is ignored; of an extended map the latest
    row of each point is read."""
    path = Path(path)
    if path.is_dir():
        path = path / RESULTS_FILE
    _settings, rows, _truncated = _core.read_map_results(path)
    latest: Dict[tuple, Dict[str, Any]] = {}
    for r in map(json.loads, rows):  # a later row of a point (an extended run) replaces the earlier
        latest.pop((r["f_ex_hz"], r["a_ex_m_s2"], r["s0"]), None)
        latest[(r["f_ex_hz"], r["a_ex_m_s2"], r["s0"])] = r
    return rows_to_table(list(latest.values()))


def _map_chunk(config_toml: str, jobs: List[tuple], threads: int) -> List[str]:
    """A Dask task of a map: one chunk of jobs through the Rust core (rayon, interpreter released)."""
    from beamslider import _core as core

    return core.run_map_chunk(config_toml, jobs, threads=threads)


def run_map_config(config_toml: str, *, out: Optional[Union[str, Path]] = None, resume: bool = False,
                   threads: Optional[int] = None, progress: Optional[bool] = False, extend: bool = False,
                   report: bool = True, scheduler: Any = None, scheduler_file: Optional[str] = None,
                   chunk_size: int = 8, task_threads: int = 1, max_retries: int = 3) -> Dict[str, np.ndarray]:
    """Run a map from configuration TOML text (see :func:`map_config_toml`); ``out`` is the output
    folder (results appended to ``out/map.jsonl`` point by point, the configuration written to
    ``out/map.toml``). ``extend``: the map in ``out`` was run for a shorter duration; continue its
    not-settled points from their saved end states to the configuration's duration (the count
    is printed when ``report``). ``scheduler`` / ``scheduler_file``: run the points on a Dask
    cluster in chunks of ``chunk_size`` (see :func:`operating_map`)."""
    canonical, f, a, s = _core.map_config(config_toml)
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
    client, own = None, False
    if scheduler is not None or scheduler_file is not None:
        from ._dask import connect

        client, own = connect(scheduler, scheduler_file)  # before any file is written
    try:
        if out is not None:
            folder = Path(out)
            results = folder / RESULTS_FILE
            # Everything the run would refuse is refused before map.toml is (over)written.
            _core.check_map(config_toml, out=results, resume=resume, extend=extend)
            folder.mkdir(parents=True, exist_ok=True)
        # Takes the results file's lock (a second writer fails here), writes the header.
        run = _core.MapRun(config_toml, out=results, resume=resume, extend=extend)
        try:
            if out is not None:
                (Path(out) / "map.toml").write_text(canonical, encoding="utf-8")
            with _progress_bar(progress, total, "map", "pts") as bar:
                if client is None:
                    run.run_local(threads=None if threads is None else int(threads), progress=bar)
                else:
                    from ._dask import run_chunks

                    jobs = run.jobs()
                    chunks = [(config_toml, jobs[i:i + chunk_size], int(task_threads))
                              for i in range(0, len(jobs), chunk_size)]

                    def on_rows(rows: List[str]) -> None:
                        run.append(rows)
                        if bar is not None:
                            bar(run.done, total)

                    run_chunks(client, _map_chunk, chunks, tag="map" + canonical, on_rows=on_rows,
                               max_retries=max_retries)
            rows, extended = run.finish()
        finally:
            run.close()
    finally:
        if own:
            client.close()
    table = rows_to_table([json.loads(r) for r in rows])
    if report and (extend or extended):
        t_end = float(_toml.loads(canonical)["duration_s"])
        print(f"re-ran {extended} not-settled or undetermined of {len(table['index'])} points from their saved end states "
              f"to t_end = {t_end:g} s")
    return table


def operating_map(params: Optional[Parameters] = None, *, f_ex: Any, a_ex: Any, s0: Any = 0.3,
                  t_end: float = 120.0, threads: Optional[int] = None, out: Optional[Union[str, Path]] = None,
                  resume: bool = False, record_every: int = 20, criteria: Optional[Dict[str, float]] = None,
                  progress: Optional[bool] = False, extend_to: Optional[float] = None, scheduler: Any = None,
                  scheduler_file: Optional[str] = None, chunk_size: int = 8,
                  predictor: Optional[Any] = None) -> Dict[str, np.ndarray]:
    """Operating map (docs/model.md §8): the behaviour of the free slider at every (f_ex, a_ex, s0) of the
    grid, each point a ``t_end``-second run from rest classified by the core, in parallel on
    ``threads`` threads (default: one per core).

    ``out``: output folder; each finished point is appended to ``out/map.jsonl`` at once, and with
    ``resume=True`` the points already there are skipped (a map started by ``beamslider map`` or
    ``beamslider-batch map`` with the same settings can be resumed, and vice versa). Ctrl-C stops
    the map (``KeyboardInterrupt``) keeping the finished points.

    ``extend_to``: extend the map in ``out`` (run for ``t_end`` seconds) to ``extend_to`` seconds:
    the points that had not settled (``not_settled``) or got no behaviour (``undetermined``) continue from the end states saved in the
    results file — each continued row is bitwise the row of a ``extend_to``-second run from rest,
    but for the wall time — and the settled points keep their rows; the number of re-run points
    is printed. An interrupted extension is finished by the same call.

    ``scheduler`` (an address such as ``"tcp://10.0.0.5:8786"`` or a ``distributed.Client``) or
    ``scheduler_file`` (written by ``dask scheduler --scheduler-file``): run the points on a Dask
    cluster, ``chunk_size`` points per task; the scheduler is contacted before any file is
    written, the results file, its lock and ``resume`` are the same, and every row is bitwise
    the row of the local map (but ``wall_time_s``). A chunk lost with its worker is re-run.

    Only one process may write a map folder at a time: a second one fails at once
    (``BlockingIOError`` naming the folder and the holder's PID).

    ``predictor``: a fitted drift law (:func:`beamslider.superslow.fit_drift_law`): the map is
    predicted by the reduced super-slow model instead of FS runs (milliseconds per point; one s0;
    same results format and writer, ``resume`` as for FS maps, see
    :func:`beamslider.slowflow.predicted_map`).

    Returns a dict of numpy arrays, one entry per grid point in grid order (s0 slowest, then a_ex,
    f_ex fastest): see :func:`rows_to_table`.
    """
    if predictor is not None:
        from .slowflow import predicted_map

        s0s = np.atleast_1d(np.asarray(s0, dtype=float))
        if s0s.size != 1 or extend_to is not None:
            raise ValueError("invalid parameter `predictor`: takes one s0 and no extend_to")
        if scheduler is not None or scheduler_file is not None:
            raise ValueError("invalid parameter `predictor`: a predicted map runs locally (milliseconds per point), not on a scheduler")
        rows = predicted_map(params, drift=predictor, f_ex=[float(v) for v in np.atleast_1d(f_ex)],
                             a_ex=[float(v) for v in np.atleast_1d(a_ex)], s0=float(s0s[0]), t_end=float(t_end), out=out,
                             resume=resume, threads=threads)
        return rows_to_table(rows)
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
        settings, _rows, _trunc = _core.read_map_results(results)
        done = json.loads(settings)["duration_s"] if settings else None
        if done not in (float(t_end), te):
            raise ValueError(f"invalid parameter `t_end` = {t_end!r}: the map in {out} was run for {done} s")
        cfg = map_config_toml(params, f_ex=f_ex, a_ex=a_ex, s0=s0, t_end=te, record_every=record_every,
                              criteria=criteria)
        return run_map_config(cfg, out=out, threads=threads, progress=progress, extend=True, scheduler=scheduler,
                              scheduler_file=scheduler_file, chunk_size=chunk_size)
    cfg = map_config_toml(params, f_ex=f_ex, a_ex=a_ex, s0=s0, t_end=t_end, record_every=record_every,
                          criteria=criteria)
    return run_map_config(cfg, out=out, resume=resume, threads=threads, progress=progress, scheduler=scheduler,
                          scheduler_file=scheduler_file, chunk_size=chunk_size)


def failures(table: Dict[str, np.ndarray]) -> List[str]:
    """One line per grid point whose run did not complete (status ``left_beam``, ``diverged`` or
    ``error``), with its inputs and the reason (a predicted map's ``predicted`` rows are done)."""
    return [f"#{table['index'][i]} f_ex = {table['f_ex_hz'][i]:g} Hz, a_ex = {table['a_ex_m_s2'][i]:g} m/s^2, "
            f"s0 = {table['s0'][i]:g}: {table['status'][i]}: {table['reason'][i]}"
            for i in np.flatnonzero((table["status"] != "completed") & (table["status"] != "predicted"))]


def t_end_text(table: Dict[str, np.ndarray], s0: Optional[float] = None) -> str:
    """``t_end = 120 s``, or for an extended map ``t_end = 120 s (settled points kept from 60 s)``;
    ``predicted, t_end = 120 s`` for a map of the reduced predictor."""
    predicted = bool(np.any(table["status"] == "predicted"))
    m = (table["status"] == "completed") | (table["status"] == "predicted")
    if s0 is not None:
        m &= table["s0"] == s0
    if not m.any():
        return "t_end = -"
    lo, hi = float(table["t_end_s"][m].min()), float(table["t_end_s"][m].max())
    if lo == hi:
        return f"{'predicted, ' if predicted else ''}t_end = {round(hi, 3):g} s"
    return f"t_end = {round(hi, 3):g} s (settled points kept from {round(lo, 3):g} s)"


def text_table(table: Dict[str, np.ndarray], s0: Optional[float] = None) -> str:
    """The map as text: per s0 a header with s0 and t_end, rows a_ex (highest first), columns
    f_ex, one letter per behaviour (:data:`LETTERS`; ``.`` = not run)."""
    s0s = sorted(set(table["s0"].tolist())) if s0 is None else [s0]
    out = []
    for s in s0s:
        m = table["s0"] == s
        fs = sorted(set(table["f_ex_hz"][m].tolist()))
        as_ = sorted(set(table["a_ex_m_s2"][m].tolist()), reverse=True)
        out.append(f"s0 = {s:g}, {t_end_text(table, s)}; rows a_ex [m/s^2], columns f_ex [Hz]; "
                   + ", ".join(f"{LETTERS[b]} {LABELS[b]}" for b in BEHAVIOURS))
        corner = "a\\f"
        out.append(f"{corner:>6} " + "".join(f"{f:>4g}" for f in fs))
        for a in as_:
            cells = []
            for f in fs:
                k = np.flatnonzero(m & (table["f_ex_hz"] == f) & (table["a_ex_m_s2"] == a))
                cells.append(f"{LETTERS.get(table['behaviour'][k[0]], '?') if len(k) else '.':>4}")
            out.append(f"{a:>6g} " + "".join(cells))
    return "\n".join(out) + "\n"


COLOURS = {"inactivity": "#9e9e9e", "trivial_adaption": "#1f77b4", "signature_move": "#2ca02c",
           "relaxation_oscillation": "#ff7f0e", "self_damping": "#d62728", "not_settled": "#f3e79b",
           "undetermined": "#ffffff"}
"""Colour of each behaviour in the map figure."""

_HATCH = {"undetermined": "//", "not_settled": ".."}


def changed_with_s0(table: Dict[str, np.ndarray]) -> List[tuple]:
    """(f_ex, a_ex) points of the grid whose behaviour differs between the s0 values of the map."""
    out = []
    keys = sorted(set(zip(table["f_ex_hz"].tolist(), table["a_ex_m_s2"].tolist())))
    for f, a in keys:
        m = (table["f_ex_hz"] == f) & (table["a_ex_m_s2"] == a)
        if len(set(table["behaviour"][m].tolist())) > 1 and m.sum() > 1:
            out.append((f, a))
    return out


def _panel(ax: Any, table: Dict[str, np.ndarray], s0: float, title: Optional[str], marks: Sequence[tuple]) -> set:
    from matplotlib.patches import Rectangle

    m = table["s0"] == s0
    fs = np.array(sorted(set(table["f_ex_hz"][m].tolist())))
    as_ = np.array(sorted(set(table["a_ex_m_s2"][m].tolist())))
    dfs = np.diff(fs).min() if len(fs) > 1 else 1.0
    das = np.diff(as_).min() if len(as_) > 1 else 1.0
    present = set()
    for i in np.flatnonzero(m):
        b = str(table["behaviour"][i])
        present.add(b)
        f, a = table["f_ex_hz"][i], table["a_ex_m_s2"][i]
        ax.add_patch(Rectangle((f - dfs / 2, a - das / 2), dfs, das, facecolor=COLOURS.get(b, "w"),
                               edgecolor="k", linewidth=0.4, hatch=_HATCH.get(b)))
    for f, a in marks:
        ax.add_patch(Rectangle((f - dfs / 2 + 0.06 * dfs, a - das / 2 + 0.06 * das), 0.88 * dfs, 0.88 * das,
                               facecolor="none", edgecolor="k", linewidth=2.0))
    ax.set_xlim(fs[0] - dfs / 2, fs[-1] + dfs / 2)
    ax.set_ylim(as_[0] - das / 2, as_[-1] + das / 2)
    ax.set_xticks(fs if len(fs) <= 20 else fs[:: int(np.ceil(len(fs) / 20))])
    ax.set_yticks(as_ if len(as_) <= 20 else as_[:: int(np.ceil(len(as_) / 20))])
    ax.tick_params(axis="x", labelsize=8)
    ax.set_xlabel(r"excitation frequency $f_\mathrm{ex}$ [Hz]")
    ax.set_ylabel(r"excitation level $a_\mathrm{ex}$ [m/s$^2$]")
    ax.set_title(title if title is not None else f"operating map, $s_0$ = {s0:g}, {t_end_text(table, s0)}",
                 fontsize=10)
    return present


def plot_operating_map(table: Dict[str, np.ndarray], *, s0: Optional[float] = None, title: Optional[str] = None,
                       path: Optional[Union[str, Path]] = None, ax: Any = None,
                       mark_changes: bool = False) -> Any:
    """Categorical map of the behaviours over (f_ex, a_ex) with a legend, like the paper's Fig. 11
    (one cell per grid point; cells not run are left blank, undetermined cells hatched, not-settled
    cells dotted). The title gives s0 and t_end. A map over several s0 draws one panel per s0
    (unless ``s0`` picks one); ``mark_changes`` outlines the points whose behaviour changes with
    s0 (the paper's start-position example, Fig. 12). Returns the figure; writes it to ``path``
    when given."""
    from ._mpl import require_matplotlib

    require_matplotlib("plot_operating_map")
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    s0s = sorted(set(table["s0"].tolist()))
    if not s0s:
        raise ValueError("the map is empty")
    if s0 is not None and s0 not in s0s:
        raise ValueError(f"invalid parameter `s0` = {s0!r}: the map has s0 in {s0s}")
    panels = [s0] if s0 is not None else s0s
    if ax is not None and len(panels) > 1:
        raise ValueError("invalid parameter `ax`: a map over several s0 draws several panels; give `s0` or no `ax`")
    marks = changed_with_s0(table) if mark_changes else []
    if ax is None:
        fig = Figure(figsize=(1.5 + 6.0 * len(panels), 4.2), layout="constrained")  # no pyplot: headless
        axes = fig.subplots(1, len(panels), squeeze=False)[0]
    else:
        fig = ax.figure
        axes = [ax]
    present = set()
    for a, s in zip(axes, panels):
        present |= _panel(a, table, s, title if len(panels) == 1 else None, marks)
    if title is not None and len(panels) > 1:
        fig.suptitle(title)
    handles = [Patch(facecolor=COLOURS[b], edgecolor="k", label=LABELS[b], hatch=_HATCH.get(b))
               for b in BEHAVIOURS if b not in _HATCH or b in present]
    if marks:
        handles.append(Patch(facecolor="none", edgecolor="k", linewidth=2.0, label="changes with $s_0$"))
    axes[-1].legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False, fontsize=9)
    if path is not None:
        fig.savefig(str(path), dpi=150)
    return fig
