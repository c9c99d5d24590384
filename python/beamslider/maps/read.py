"""Operating maps: reading the results file (JSON lines, ``<out>/map.jsonl``) into numpy arrays and its text summaries (docs/model.md §8)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np

from .. import _core
from ..tables import MapTable, rows_to_table
from .config import RESULTS_FILE

__all__ = ["check_rows", "failures", "grid_points", "marked_unsettled", "read_map", "rows_to_table", "t_end_text", "text_table"]


def grid_points(config: Union[str, "_core.MapConfig"]) -> set:
    """The (f_ex, a_ex, s0) points of a map configuration's grid (TOML text or the core's handle)."""
    f, a, s = (_core.MapConfig(config) if isinstance(config, str) else config).axes
    return {(float(x), float(y), float(z)) for x in f for y in a for z in s}


def saved_grid(folder: Path) -> Optional[set]:
    """The grid of the map.toml in ``folder`` (None without one); a ValueError naming it when it is not a map configuration."""
    cfg = Path(folder) / "map.toml"
    try:
        text = cfg.read_bytes().decode("utf-8")
    except FileNotFoundError:
        return None
    except UnicodeDecodeError as e:
        raise ValueError(f"{cfg}: not a map configuration (not UTF-8 text: {e.reason})") from None
    try:
        return grid_points(text)
    except ValueError as e:
        raise ValueError(f"{cfg}: {str(e).splitlines()[0]}") from None


def check_rows(path: Union[str, Path], grid: Optional[set] = None) -> None:
    """Refuse a results file whose rows do not belong to one map (docs/model.md §8): a second row
    of a point that does not extend the first (a later row replaces an earlier one only with a
    longer ``t_end_s``: an extension), or, with ``grid``, a point not on it. The ValueError names
    the file, the line and the point."""
    path = Path(path)
    seen: Dict[tuple, tuple] = {}
    with open(path, "rb") as fh:
        for lineno, raw in enumerate(fh, 1):
            if not raw.endswith(b"\n"):
                break  # a torn last line: ignored, as the core does
            try:
                r = json.loads(raw)
            except ValueError:
                continue  # the header's or a damaged line's (the core reports those)
            if not isinstance(r, dict) or "index" not in r or "f_ex_hz" not in r:
                continue
            try:
                key = (float(r["f_ex_hz"]), float(r["a_ex_m_s2"]), float(r["s0"]))
                t_end = float(r["t_end_s"])
            except (KeyError, TypeError, ValueError):
                continue
            where = f"f_ex = {key[0]:g} Hz, a_ex = {key[1]:g} m/s², s0 = {key[2]:g}"
            if grid is not None and key not in grid:
                raise ValueError(f"{path}:{lineno}: a row of a point not on the map's grid ({where}; grid in map.toml): "
                                 "not this map's row — remove the line or use another --out")
            if key in seen and not t_end > seen[key][1]:
                raise ValueError(f"{path}:{lineno}: a second row of the point {where} (first on line {seen[key][0]}) with "
                                 f"t_end_s = {t_end:g}, not longer than the first's ({seen[key][1]:g}): a duplicate — remove one of the lines")
            seen[key] = (lineno, t_end)


def read_map(path: Union[str, Path]) -> MapTable:
    """Read a map's results (``map.jsonl`` or its folder) into the table of :func:`operating_map`
    (``.to_pandas()``, ``.to_xarray()``). A truncated last line (a map killed while writing) is
    ignored; of an extended map the latest row of each point is read. A version-2 file (without
    ``settled``) reads with ``settled`` derived from ``steady`` (docs/model.md §8). A duplicated row,
    or a row of a point not on the grid of the ``map.toml`` beside the file, is refused
    (:func:`check_rows`)."""
    path = Path(path)
    if path.is_dir():
        path = path / RESULTS_FILE
    _header, rows, _good, _truncated = _core.read_results_file(path)
    check_rows(path, saved_grid(path.parent))
    latest: Dict[tuple, Dict[str, Any]] = {}
    for r in map(json.loads, rows):  # a later row of a point (an extended run) replaces the earlier
        latest.pop((r["f_ex_hz"], r["a_ex_m_s2"], r["s0"]), None)
        latest[(r["f_ex_hz"], r["a_ex_m_s2"], r["s0"])] = r
    return rows_to_table(list(latest.values()))


def failures(table: Dict[str, np.ndarray]) -> List[str]:
    """One line per grid point whose run did not complete (status ``left_beam``, ``diverged`` or
    ``error``), with its inputs and the reason (a predicted map's ``predicted`` rows are done)."""
    return [f"#{table['index'][i]} f_ex = {table['f_ex_hz'][i]:g} Hz, a_ex = {table['a_ex_m_s2'][i]:g} m/s^2, "
            f"s0 = {table['s0'][i]:g}: {table['status'][i]}: {table['reason'][i]}"
            for i in np.flatnonzero((table["status"] != "completed") & (table["status"] != "predicted"))]


def _columns(table: Dict[str, np.ndarray], s0: Optional[float]) -> tuple:
    """The columns the core's letter table reads (rows of ``s0`` only, when given)."""
    m = np.ones(len(table["s0"]), dtype=bool) if s0 is None else table["s0"] == s0
    settled = table.get("settled", np.ones(len(m), dtype=bool))
    return (np.asarray(table["s0"], dtype=float)[m].tolist(), np.asarray(table["f_ex_hz"], dtype=float)[m].tolist(),
            np.asarray(table["a_ex_m_s2"], dtype=float)[m].tolist(), np.asarray(table["t_end_s"], dtype=float)[m].tolist(),
            [str(v) for v in table["status"][m]], [str(v) for v in table["behaviour"][m]],
            np.asarray(settled, dtype=bool)[m].tolist())


def t_end_text(table: Dict[str, np.ndarray], s0: Optional[float] = None) -> str:
    """``t_end = 120 s``, or for an extended map ``t_end = 120 s (settled points kept from 60 s)``;
    ``predicted, t_end = 120 s`` for a map of the reduced predictor (the core's text, docs/model.md §8)."""
    return _core.map_text_table(_columns(table, s0))[1]


def marked_unsettled(table: Dict[str, np.ndarray]) -> np.ndarray:
    """Points whose behaviour is reached but has not settled (``settled`` false, not
    ``not_settled``, a completed or predicted run): drawn hollow, marked ``*`` in the text table."""
    n = len(table["behaviour"])
    settled = table.get("settled", np.ones(n, dtype=bool))
    done = (table["status"] == "completed") | (table["status"] == "predicted")
    return ~np.asarray(settled, dtype=bool) & (table["behaviour"] != "not_settled") & done


def text_table(table: Dict[str, np.ndarray], s0: Optional[float] = None) -> str:
    """The map as text (the core's letter table, as ``beamslider-batch map`` writes it): per s0 a
    header with s0 and t_end, rows a_ex (highest first), columns f_ex, one letter per behaviour
    (:data:`LETTERS`; ``.`` = not run), followed by ``*`` when the behaviour is reached but not yet
    settled (:func:`marked_unsettled`)."""
    return _core.map_text_table(_columns(table, s0))[0]
