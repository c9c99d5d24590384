"""The files the simulation commands write and ``beamslider plot`` reads back: file-name stems,
the simulation CSV (the core's channel names), the manifold CSV (docs/model.md §6) and the JSON
summary written beside a result."""

from __future__ import annotations

import csv
import hashlib
import json
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from .. import _core
from ..measurement import Measurement, read_measurement
from ..params import Parameters
from ..simulate import ManifoldResult, SimulationResult
from ._common import UserError, fmt, one_line


def run_stem(model: str, f_ex: float, a_ex: float, s0: float, s_pcs: Optional[float] = None) -> str:
    """File name stem of a run, e.g. ``fs_124Hz_14ms2_s0_0p3``."""
    if model == "fs":
        where = f"s0_{fmt(s0)}"
    elif model == "pcs":
        where = f"s_{fmt(s0 if s_pcs is None else s_pcs)}"
    else:
        where = "beam"
    return f"{model}_{fmt(f_ex)}Hz_{fmt(a_ex)}ms2_{where}"


def simulation_stem(result: SimulationResult) -> str:
    """File name stem of a run, e.g. ``fs_124Hz_14ms2_s0_0p3``."""
    s_pcs = float(result.s[0]) if result.model == "pcs" and len(result.s) else None
    return run_stem(result.model, result.f_ex, result.a_ex, result.s0, s_pcs)


DEFAULT_MANIFOLD_RECORD = 25


def manifold_file_stem(f_ex: float, a_ex: float, periods: int, record: int = DEFAULT_MANIFOLD_RECORD,
                       s: Optional[Sequence[float]] = None) -> str:
    """File name stem of a manifold carrying the settings that change it, e.g.
    ``manifold_124Hz_14ms2_100periods`` (plus ``_avgR`` for a non-default averaging and
    ``_s<hash>`` for a slider grid other than the default)."""
    stem = f"manifold_{fmt(f_ex)}Hz_{fmt(a_ex)}ms2_{int(periods)}periods"
    if record != DEFAULT_MANIFOLD_RECORD:
        stem += f"_avg{int(record)}"
    if s is not None:
        digest = hashlib.sha1(",".join(f"{float(v):.12g}" for v in s).encode()).hexdigest()[:8]
        stem += f"_s{digest}"
    return stem


def manifold_stem(m: ManifoldResult, s: Optional[Sequence[float]] = None) -> str:
    """File name stem of a computed manifold (see :func:`manifold_file_stem`); ``s`` = the grid
    asked for, None for the default grid."""
    return manifold_file_stem(m.f_ex, m.a_ex, m.periods, m.record, s)


def write_simulation_csv(path: Path, result: SimulationResult) -> None:
    """Recorded columns under the core's channel names (round-trip precision)."""
    cols = result.columns()
    data = np.column_stack(list(cols.values()))
    np.savetxt(path, data, delimiter=",", header=",".join(cols), comments="", fmt="%.17g")


def read_simulation_csv(path: Path) -> Dict[str, np.ndarray]:
    """The columns of a trajectory file (.npz memory-mapped, .parquet read by column, or CSV); a
    UserError naming the file when it is not one."""
    need = ["t_s", "w_4L7_m", "s", "xC_m", "zC_m", "beta_rad"]
    if not path.exists():
        raise UserError(f"{path}: no such file")
    if path.suffix in (".npz", ".parquet"):
        from ..simulate import read_trajectory

        try:
            cols = read_trajectory(path)
        except ValueError as e:
            raise UserError(one_line(e)) from None
        if any(n not in cols for n in need) or len(cols["t_s"]) < 2:
            raise UserError(f"{path}: not a beamslider trajectory with two or more rows")
        return cols
    try:
        with open(path, "r", encoding="utf-8") as f:
            header = f.readline().strip().split(",")
    except UnicodeDecodeError:
        raise UserError(f"{path}: not a text CSV file (not UTF-8)") from None
    missing = [n for n in need if n not in header]
    if missing:
        raise UserError(f"{path}: not a beamslider simulation CSV (missing columns {', '.join(missing)})")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # an empty file is reported below
            data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, encoding="utf-8")
    except ValueError as e:
        raise UserError(f"{path}: {one_line(e)}") from None
    if data.shape[0] < 2 or data.shape[1] != len(header):
        raise UserError(f"{path}: need at least two rows of {len(header)} values (found {data.shape[0]} rows of "
                        f"{data.shape[1]})")
    return {n: data[:, i] for i, n in enumerate(header)}


MANIFOLD_HEADER = ["branch", "s", "amplitude_m"]
"""Columns of a manifold CSV, the same as ``beamslider-batch manifold`` writes (docs/model.md §6)."""


def write_manifold_csv(path: Path, m: ManifoldResult) -> None:
    """The manifold CSV as the core writes it (``beamslider-batch manifold``: s and the amplitude
    as the shortest decimals that read back exactly)."""
    text = _core.manifold_csv(np.asarray(m.up_s, dtype=float).tolist(), np.asarray(m.up_amplitude, dtype=float).tolist(),
                              np.asarray(m.down_s, dtype=float).tolist(), np.asarray(m.down_amplitude, dtype=float).tolist())
    Path(path).write_text(text, encoding="utf-8")


HB_MANIFOLD_HEADER = ["branch", "s", "amplitude_h", "phase_rad", "stable"]
"""Columns of a harmonic-balance manifold CSV (``beamslider hb-manifold``, and the default overlay
of ``simulate``/``compare``): branch high/low/middle, Â = |w(4L/7)|/h, phase, stability."""


@dataclass
class _Curve:
    s: np.ndarray
    amplitude: np.ndarray


@dataclass
class HbCurves:
    """The branches of a harmonic-balance manifold as read back from its CSV (what panel (c)
    draws): high, low and middle, each with ``s`` and ``amplitude`` (Â in units of h)."""

    high: _Curve
    low: _Curve
    middle: _Curve
    f_ex: float
    a_ex: float
    n_modes: int
    params: Parameters


def hb_manifold_file_stem(f_ex: float, a_ex: float, n_modes: int = 5) -> str:
    """File name stem of a harmonic-balance manifold, e.g. ``hb_manifold_124Hz_14ms2_N5``."""
    return f"hb_manifold_{fmt(f_ex)}Hz_{fmt(a_ex)}ms2_N{int(n_modes)}"


def write_hb_manifold_csv(path: Path, m: Any) -> None:
    """The branches of an :class:`~beamslider.superslow.HbManifold` as CSV (HB_MANIFOLD_HEADER)."""
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(HB_MANIFOLD_HEADER)
        for name in ("high", "low", "middle"):
            b = getattr(m, name)
            for row in zip(b.s, b.amplitude, b.phase, b.stable):
                w.writerow([name, f"{row[0]:.10g}", f"{row[1]:.10g}", f"{row[2]:.10g}", int(row[3])])


def _read_hb_manifold_rows(path: Path, r: Any, *, f_ex: float, a_ex: float, params: Parameters) -> HbCurves:
    rows: Dict[str, List[List[float]]] = {name: [[], []] for name in ("high", "low", "middle")}
    for lineno, row in enumerate(r, start=2):
        try:
            target = rows[row[0]]
            s, a = float(row[1]), float(row[2])
        except (KeyError, IndexError, ValueError):
            raise UserError(f"{path}:{lineno}: malformed HB manifold row {row!r}") from None
        target[0].append(s)
        target[1].append(a)
    m = re.search(r"_N(\d+)", Path(path).name)
    curves = {k: _Curve(np.array(v[0]), np.array(v[1])) for k, v in rows.items()}
    return HbCurves(**curves, f_ex=f_ex, a_ex=a_ex, n_modes=int(m.group(1)) if m else 0, params=params)


def read_manifold_csv(path: Path, *, f_ex: float, a_ex: float, params: Parameters) -> Any:
    """A manifold CSV written by this package: the PCS sweeps (:data:`MANIFOLD_HEADER`, returns a
    :class:`ManifoldResult`) or the harmonic-balance branches (:data:`HB_MANIFOLD_HEADER`, returns
    :class:`HbCurves`)."""
    up: List[List[float]] = [[], []]
    down: List[List[float]] = [[], []]
    with open(path, "r", encoding="utf-8") as f:
        r = csv.reader(f)
        header = next(r, None)
        if header == HB_MANIFOLD_HEADER:
            return _read_hb_manifold_rows(path, r, f_ex=f_ex, a_ex=a_ex, params=params)
        # "sweep" is the name older versions of this package wrote for the branch column.
        if header not in (MANIFOLD_HEADER, ["sweep", "s", "amplitude_m"]):
            raise UserError(f"{path}: not a beamslider manifold CSV (header branch,s,amplitude_m)")
        for lineno, row in enumerate(r, start=2):
            try:
                target = {"up": up, "down": down}[row[0]]
                target[0].append(float(row[1]))
                target[1].append(float(row[2]))
            except (KeyError, IndexError, ValueError):
                raise UserError(f"{path}:{lineno}: malformed manifold row {row!r}") from None
    m = re.search(r"_(\d+)periods", Path(path).name)  # the file name carries the periods per s-step
    return ManifoldResult(
        up_s=np.array(up[0]), up_amplitude=np.array(up[1]), down_s=np.array(down[0]),
        down_amplitude=np.array(down[1]), counters={}, f_ex=f_ex, a_ex=a_ex, periods=int(m.group(1)) if m else 0,
        record=0, params=params,
    )


def final_amplitude(result: SimulationResult, window: float, streamed: bool = True) -> float:
    """Super-slow amplitude [m] at the end of a run: of a streamed run, the last value of the
    super-slow signals the core computed as it streamed (``RunOverview``, the definition of the
    operating maps, without reading the trajectory back); else (in-memory runs, runs shorter
    than one 0.2-s bin, or ``streamed=False``) the last value of
    :meth:`SimulationResult.display_envelope`."""
    ov = result.overview
    if streamed and ov is not None and ov.window == window and len(ov.amplitude_h):
        return float(ov.amplitude_h[-1] * result.params.thickness_m)
    env = result.display_envelope(window) if len(result.t) > 2 else np.array([np.nan])
    return float(env[-1])


def simulation_summary(result: SimulationResult, *, t_end: float, record_every: int, wall_s: float,
                       window: float, streamed: bool = True) -> Dict[str, Any]:
    """The JSON summary of a run (``streamed``: see :func:`final_amplitude`)."""
    amp = final_amplitude(result, window, streamed)
    return {
        "kind": "simulation",
        "model": result.model,
        "f_ex_hz": result.f_ex,
        "a_ex_m_s2": result.a_ex,
        "s0": result.s0,
        "s_pcs": float(result.s[0]) if result.model == "pcs" and len(result.s) else None,
        "t_end_s": t_end,
        "record_every": record_every,
        "status": result.status,
        "message": result.message,
        "final_t_s": float(result.t[-1]),
        "final_s": float(result.s[-1]),
        "final_amplitude_m": amp,
        "final_amplitude_over_h": amp / result.params.thickness_m,
        "wall_time_s": wall_s,
        "counters": result.counters,
        "params_toml": result.params.toml_text(),
    }



def measurement(path: str) -> Measurement:
    try:
        return read_measurement(path)
    except FileNotFoundError:
        raise UserError(f"{path}: no such file") from None



def read_meta(path: Path) -> Dict[str, Any]:
    """The JSON summary written beside a result; a UserError naming the file when it is not one."""
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise UserError(f"{path}: not valid JSON ({e})") from None
    types = {"kind": str, "params_toml": str, "model": str, "status": str, "message": str, "manifold_csv": str,
             "measurement": str, "f_ex_hz": (int, float), "a_ex_m_s2": (int, float), "s0": (int, float, type(None)),
             "counters": dict}
    bad = [k for k, t in types.items() if isinstance(meta, dict) and k in meta and not isinstance(meta[k], t)]
    if not isinstance(meta, dict) or bad:
        what = f"field {bad[0]!r} has the wrong type" if bad else "not a JSON object"
        raise UserError(f"{path}: not a beamslider result summary ({what})")
    if meta.get("kind") == "manifold" and not all(k in meta for k in ("f_ex_hz", "a_ex_m_s2")):
        raise UserError(f"{path}: manifold summary without f_ex_hz / a_ex_m_s2")
    return meta

