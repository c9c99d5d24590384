"""Operating maps (MODEL.md §8, the paper's Fig. 11) and the behaviour classification.

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

from . import _core
from .params import Parameters, resolve
from .simulate import SimulationResult, _progress_bar

RESULTS_FILE = "map.jsonl"
"""Name of the results file inside a map's output folder."""

BEHAVIOURS = ("inactivity", "trivial_adaption", "signature_move", "relaxation_oscillation", "self_damping",
              "undetermined")
"""Behaviour names as written in results files (MODEL.md §8), in legend order."""

LETTERS = {"inactivity": "I", "trivial_adaption": "T", "signature_move": "S", "relaxation_oscillation": "R",
           "self_damping": "D", "undetermined": "?"}
"""One letter per behaviour for text tables."""

LABELS = {"inactivity": "inactivity", "trivial_adaption": "trivial adaption", "signature_move": "signature move",
          "relaxation_oscillation": "relaxation oscillation", "self_damping": "self-damping",
          "undetermined": "undetermined"}

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
    jump_down_t_s, steady."""


def _criteria_toml(criteria: Optional[Dict[str, float]]) -> Optional[str]:
    if not criteria:
        return None
    return "".join(f"{k} = {_toml_number(v)}\n" for k, v in criteria.items())


def _toml_number(v: Any) -> str:
    if isinstance(v, (bool, np.bool_)):
        raise ValueError(f"expected a number, got {v!r}")
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    x = float(v)
    if np.isnan(x):
        return "nan"
    if np.isinf(x):
        return "inf" if x > 0 else "-inf"
    return repr(x)


def classify(t: Any, s: Any, amplitude_h: Any, *, criteria: Optional[Dict[str, float]] = None) -> Classification:
    """Classify super-slow signals: uniformly sampled times ``t`` [s], slider position ``s`` and
    amplitude ``amplitude_h`` (1-s moving average of |Hilbert(w(4L/7))| divided by h). ``criteria``
    overrides thresholds of the core (keys as in the ``[criteria]`` table of a map config)."""
    t = np.ascontiguousarray(t, dtype=float)
    s = np.ascontiguousarray(s, dtype=float)
    a = np.ascontiguousarray(amplitude_h, dtype=float)
    if not (t.ndim == s.ndim == a.ndim == 1 and len(t) == len(s) == len(a)):
        raise ValueError("t, s and amplitude_h must be 1-D arrays of the same length")
    if len(t) < 2:
        raise ValueError("need at least two samples")
    dt = float(t[1] - t[0])
    c = json.loads(_core.classify(s, a, dt, t0_s=float(t[0]), criteria_toml=_criteria_toml(criteria)))
    behaviour, reason = c.pop("behaviour"), c.pop("reason")
    for k in ("turn_s", "turn_t_s"):
        c[k] = float("nan") if c.get(k) is None else c[k]
    return Classification(behaviour=behaviour, reason=reason, features=c)


def classify_result(result: SimulationResult, *, window: float = 1.0,
                    criteria: Optional[Dict[str, float]] = None) -> Classification:
    """Classify a free-slider run of :func:`beamslider.simulate` from its s(t) and the envelope of
    w(4L/7) (``window``-second moving average, in units of the thickness h)."""
    if result.model != "fs":
        raise ValueError(f"classification needs a free-slider run (model 'fs'), got {result.model!r}")
    amp = result.envelope(window) / result.params.thickness_m
    return classify(result.t, result.s, amp, criteria=criteria)


def _axis(name: str, values: Any) -> List[float]:
    arr = np.atleast_1d(np.asarray(values, dtype=float))
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"invalid parameter `{name}`: give a number or a non-empty 1-D sequence")
    return [float(v) for v in arr]


def map_config_toml(params: Optional[Parameters] = None, *, f_ex: Any, a_ex: Any, s0: Any = 0.3,
                    t_end: float = 120.0, record_every: int = 20,
                    criteria: Optional[Dict[str, float]] = None) -> str:
    """The map configuration as TOML (the format of ``beamslider-batch map --config``)."""
    p = resolve(params)
    lines = [f"duration_s = {_toml_number(float(t_end))}", f"record_every = {int(record_every)}", "", "[grid]"]
    for key, name, values in (("f_ex_hz", "f_ex", f_ex), ("a_ex_m_s2", "a_ex", a_ex), ("s0", "s0", s0)):
        lines.append(f"{key} = [{', '.join(_toml_number(v) for v in _axis(name, values))}]")
    lines += ["", "[params]", p.toml_text().strip()]
    if criteria:
        lines += ["", "[criteria]", _criteria_toml(criteria).strip()]
    return "\n".join(lines) + "\n"


def default_map_config() -> str:
    """The paper's map (f_ex = 100, 102, …, 130 Hz, a_ex = 4, 6, …, 16 m/s², s0 = 0.3, 120 s) as TOML."""
    return _core.default_map_config()


def rows_to_table(rows: Sequence[Dict[str, Any]]) -> Dict[str, np.ndarray]:
    """Map rows (dicts as in the results file) as a dict of numpy arrays: the scalar features
    (float; NaN for a missing turning point), ``behaviour``, ``reason``, ``status`` (str),
    ``steady`` (bool), ``jump_up_t_s``/``jump_down_t_s`` (object arrays of lists) and the solver
    counters as ``counters_<name>`` (int)."""
    rows = sorted(rows, key=lambda r: r["index"])
    out: Dict[str, np.ndarray] = {}
    for k in _SCALARS:
        out[k] = np.array([np.nan if r.get(k) is None else r[k] for r in rows], dtype=float)
    out["index"] = out["index"].astype(int)
    for k in ("behaviour", "reason", "status"):
        out[k] = np.array([r[k] for r in rows], dtype=object).astype(str) if rows else np.array([], dtype=str)
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
    A truncated last line (a map killed while writing) is ignored."""
    path = Path(path)
    if path.is_dir():
        path = path / RESULTS_FILE
    _settings, rows, _truncated = _core.read_map_results(path)
    return rows_to_table([json.loads(r) for r in rows])


def run_map_config(config_toml: str, *, out: Optional[Union[str, Path]] = None, resume: bool = False,
                   threads: Optional[int] = None, progress: bool = False) -> Dict[str, np.ndarray]:
    """Run a map from configuration TOML text (see :func:`map_config_toml`); ``out`` is the output
    folder (results appended to ``out/map.jsonl`` point by point, the configuration written to
    ``out/map.toml``)."""
    canonical, f, a, s = _core.map_config(config_toml)
    total = len(f) * len(a) * len(s)
    if threads is not None and (not isinstance(threads, (int, np.integer)) or isinstance(threads, bool) or threads < 1):
        raise ValueError(f"invalid parameter `threads` = {threads!r}: must be an integer >= 1")
    results = None
    if out is not None:
        folder = Path(out)
        results = folder / RESULTS_FILE
        # Everything the run would refuse is refused before map.toml is (over)written.
        _core.check_map(config_toml, out=results, resume=resume)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "map.toml").write_text(canonical, encoding="utf-8")
    with _progress_bar(progress, total, "map", "pts") as bar:
        rows = _core.run_map(config_toml, out=results, resume=resume,
                             threads=None if threads is None else int(threads), progress=bar)
    return rows_to_table([json.loads(r) for r in rows])


def operating_map(params: Optional[Parameters] = None, *, f_ex: Any, a_ex: Any, s0: Any = 0.3,
                  t_end: float = 120.0, threads: Optional[int] = None, out: Optional[Union[str, Path]] = None,
                  resume: bool = False, record_every: int = 20, criteria: Optional[Dict[str, float]] = None,
                  progress: bool = False) -> Dict[str, np.ndarray]:
    """Operating map (MODEL.md §8): the behaviour of the free slider at every (f_ex, a_ex, s0) of the
    grid, each point a ``t_end``-second run from rest classified by the core, in parallel on
    ``threads`` threads (default: one per core).

    ``out``: output folder; each finished point is appended to ``out/map.jsonl`` at once, and with
    ``resume=True`` the points already there are skipped (a map started by ``beamslider map`` or
    ``beamslider-batch map`` with the same settings can be resumed, and vice versa). Ctrl-C stops
    the map (``KeyboardInterrupt``) keeping the finished points.

    Returns a dict of numpy arrays, one entry per grid point in grid order (s0 slowest, then a_ex,
    f_ex fastest): see :func:`rows_to_table`.
    """
    cfg = map_config_toml(params, f_ex=f_ex, a_ex=a_ex, s0=s0, t_end=t_end, record_every=record_every,
                          criteria=criteria)
    return run_map_config(cfg, out=out, resume=resume, threads=threads, progress=progress)


def failures(table: Dict[str, np.ndarray]) -> List[str]:
    """One line per grid point whose run did not complete (status ``left_beam``, ``diverged`` or
    ``error``), with its inputs and the reason."""
    return [f"#{table['index'][i]} f_ex = {table['f_ex_hz'][i]:g} Hz, a_ex = {table['a_ex_m_s2'][i]:g} m/s^2, "
            f"s0 = {table['s0'][i]:g}: {table['status'][i]}: {table['reason'][i]}"
            for i in np.flatnonzero(table["status"] != "completed")]


def text_table(table: Dict[str, np.ndarray], s0: Optional[float] = None) -> str:
    """The map as text: rows a_ex (highest first), columns f_ex, one letter per behaviour
    (:data:`LETTERS`; ``.`` = not run)."""
    s0s = sorted(set(table["s0"].tolist())) if s0 is None else [s0]
    out = []
    for s in s0s:
        m = table["s0"] == s
        fs = sorted(set(table["f_ex_hz"][m].tolist()))
        as_ = sorted(set(table["a_ex_m_s2"][m].tolist()), reverse=True)
        out.append(f"s0 = {s:g}; rows a_ex [m/s^2], columns f_ex [Hz]; "
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
           "relaxation_oscillation": "#ff7f0e", "self_damping": "#d62728", "undetermined": "#ffffff"}
"""Colour of each behaviour in the map figure."""


def plot_operating_map(table: Dict[str, np.ndarray], *, s0: Optional[float] = None, title: Optional[str] = None,
                       path: Optional[Union[str, Path]] = None, ax: Any = None) -> Any:
    """Categorical map of the behaviours over (f_ex, a_ex) with a legend, like the paper's Fig. 11
    (one cell per grid point; cells not run are left blank, undetermined cells hatched).
    Returns the figure; writes it to ``path`` when given."""
    from ._mpl import require_matplotlib

    require_matplotlib("plot_operating_map")
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch, Rectangle

    s0s = sorted(set(table["s0"].tolist()))
    if not s0s:
        raise ValueError("the map is empty")
    s0 = s0s[0] if s0 is None else s0
    m = table["s0"] == s0
    fs = np.array(sorted(set(table["f_ex_hz"][m].tolist())))
    as_ = np.array(sorted(set(table["a_ex_m_s2"][m].tolist())))
    dfs = np.diff(fs).min() if len(fs) > 1 else 1.0
    das = np.diff(as_).min() if len(as_) > 1 else 1.0
    if ax is None:
        fig = Figure(figsize=(7.5, 4.2), layout="constrained")  # no pyplot: headless and thread-safe
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    present = set()
    for i in np.flatnonzero(m):
        b = str(table["behaviour"][i])
        present.add(b)
        f, a = table["f_ex_hz"][i], table["a_ex_m_s2"][i]
        ax.add_patch(Rectangle((f - dfs / 2, a - das / 2), dfs, das, facecolor=COLOURS.get(b, "w"),
                               edgecolor="k", linewidth=0.4, hatch="//" if b == "undetermined" else None))
    ax.set_xlim(fs[0] - dfs / 2, fs[-1] + dfs / 2)
    ax.set_ylim(as_[0] - das / 2, as_[-1] + das / 2)
    ax.set_xticks(fs if len(fs) <= 20 else fs[:: int(np.ceil(len(fs) / 20))])
    ax.set_yticks(as_ if len(as_) <= 20 else as_[:: int(np.ceil(len(as_) / 20))])
    ax.tick_params(axis="x", labelsize=8)
    ax.set_xlabel(r"excitation frequency $f_\mathrm{ex}$ [Hz]")
    ax.set_ylabel(r"excitation level $a_\mathrm{ex}$ [m/s$^2$]")
    ax.set_title(title if title is not None else f"operating map, $s_0$ = {s0:g}")
    handles = [Patch(facecolor=COLOURS[b], edgecolor="k", label=LABELS[b], hatch="//" if b == "undetermined" else None)
               for b in BEHAVIOURS if b != "undetermined" or b in present]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False, fontsize=9)
    if path is not None:
        fig.savefig(str(path), dpi=150)
    return fig
