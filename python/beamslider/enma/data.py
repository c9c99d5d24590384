"""ENMA data (docs/model.md §9): the :class:`EnmaData` container, its checks and its CSV file (``amplitude_h``, ``frequency_hz``, optional ``damping_ratio``, ``run``, ``level_m_s2``, ``shape_1`` … ``shape_5``)."""

from __future__ import annotations

import csv
import dataclasses
import math
import os
from dataclasses import dataclass, field
from typing import Any, Dict, Optional, Sequence, Union

import numpy as np

__all__ = ["EnmaData", "EnmaFormatError", "PathLike", "SHAPE_X_OVER_L", "concat", "make_data", "read"]


PathLike = Union[str, "os.PathLike[str]"]


#: Sensor positions of the deflection shape, x/L.
SHAPE_X_OVER_L = np.arange(1, 6) / 6.0


_REQUIRED = ("amplitude_h", "frequency_hz")


_SHAPE_COLS = tuple(f"shape_{j}" for j in range(1, 6))


MAX_AMPLITUDE_H = 30.0
"""Largest ENMA amplitude ã = ŵ(L/2)/h a file may hold (docs/model.md §1, "Units and plausibility"):
the prototype's backbone reaches about 3; thirty thicknesses are beyond any amplitude the model
produces for a beam of this kind, and what ŵ in µm over h in mm gives."""


class EnmaFormatError(ValueError):
    """An ENMA data file that cannot be read (names the file, line and column)."""


@dataclass
class EnmaData:
    """Phase-resonant points of an ENMA, one per excitation level and run.

    Attributes:
        amplitude_h: modal amplitude ã = ŵ(L/2)/h [-].
        frequency_hz: phase-resonant frequency ω̃/2π [Hz].
        damping_ratio: damping estimate D̃ [-] (NaN where not measured).
        run: run label per point (``"up"``/``"down"`` for a virtual ENMA, any text measured).
        level_m_s2: excitation level a_ex [m/s²] (NaN where unknown).
        shape: deflection shape at x/L = 1/6 … 5/6, shape (K, 5) (NaN where unknown).
        source: where the data came from.
        info: extra facts (virtual ENMA: settle times, convergence, PLL settings).
    """

    amplitude_h: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    run: np.ndarray
    level_m_s2: np.ndarray
    shape: np.ndarray
    source: str = ""
    info: Dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.amplitude_h)

    @property
    def has_damping(self) -> bool:
        return bool(np.any(np.isfinite(self.damping_ratio)))

    @property
    def has_shape(self) -> bool:
        return bool(np.any(np.isfinite(self.shape)))

    def write(self, path: PathLike) -> None:
        """Write as CSV with a header (the format :func:`read` reads)."""
        cols = ["run", "level_m_s2", "amplitude_h", "frequency_hz", "damping_ratio", *_SHAPE_COLS]
        with open(os.fspath(path), "w", encoding="utf-8", newline="") as f:
            w = csv.writer(f)
            w.writerow(cols)
            for k in range(len(self)):
                w.writerow([self.run[k], _num(self.level_m_s2[k]), _num(self.amplitude_h[k]),
                            _num(self.frequency_hz[k]), _num(self.damping_ratio[k]),
                            *(_num(v) for v in self.shape[k])])

    def select(self, mask: np.ndarray) -> "EnmaData":
        """The points where ``mask`` is true."""
        m = np.asarray(mask, dtype=bool)
        return dataclasses.replace(self, amplitude_h=self.amplitude_h[m], frequency_hz=self.frequency_hz[m],
                                   damping_ratio=self.damping_ratio[m], run=self.run[m],
                                   level_m_s2=self.level_m_s2[m], shape=self.shape[m])


def _num(v: float) -> str:
    return "" if not np.isfinite(v) else repr(float(v))


def make_data(amplitude_h: Sequence[float], frequency_hz: Sequence[float], *,
              damping_ratio: Optional[Sequence[float]] = None, run: Optional[Sequence[str]] = None,
              level_m_s2: Optional[Sequence[float]] = None, shape: Optional[np.ndarray] = None,
              source: str = "") -> EnmaData:
    """ENMA data from arrays (missing optional columns become NaN / ``"1"``); validated like a file."""
    a = np.asarray(amplitude_h, dtype=float).ravel()
    k = len(a)
    f = np.asarray(frequency_hz, dtype=float).ravel()
    d = np.full(k, np.nan) if damping_ratio is None else np.asarray(damping_ratio, dtype=float).ravel()
    lv = np.full(k, np.nan) if level_m_s2 is None else np.asarray(level_m_s2, dtype=float).ravel()
    r = np.array(["1"] * k if run is None else [str(x) for x in run], dtype=object)
    sh = np.full((k, 5), np.nan) if shape is None else np.asarray(shape, dtype=float).reshape(k, 5)
    for name, arr in (("frequency_hz", f), ("damping_ratio", d), ("level_m_s2", lv), ("run", r)):
        if len(arr) != k:
            raise ValueError(f"{name} has {len(arr)} values but amplitude_h has {k}")
    data = EnmaData(a, f, d, r, lv, sh, source=source)
    _check_values(data, where=source or "ENMA data")
    return data


def _check_values(data: EnmaData, where: str, lines: Optional[Sequence[int]] = None) -> None:
    if len(data) == 0:
        raise EnmaFormatError(f"{where}: no data points")

    def at(k: int) -> str:
        return f"{where}, line {lines[k]}" if lines is not None else f"{where}, point {k + 1}"

    for name, arr, allow_nan in (("amplitude_h", data.amplitude_h, False), ("frequency_hz", data.frequency_hz, False),
                                 ("damping_ratio", data.damping_ratio, True)):
        for k, v in enumerate(arr):
            if math.isnan(v) and allow_nan:
                continue
            if not math.isfinite(v):
                raise EnmaFormatError(f"{at(k)}: {name} = {v} is not a finite number")
            if name == "damping_ratio" and v < 0:
                raise EnmaFormatError(f"{at(k)}: damping_ratio = {v} must be >= 0")
            if name != "damping_ratio" and not v > 0:
                raise EnmaFormatError(f"{at(k)}: {name} = {v} must be > 0")
            if name == "amplitude_h" and v > MAX_AMPLITUDE_H:
                hint = (f": is it ŵ in µm over h in mm, or ŵ/h × 1000? (/1000: {v / 1000:g})" if v / 1000 <= MAX_AMPLITUDE_H
                        else "")
                raise EnmaFormatError(
                    f"{at(k)}, column amplitude_h: {v:g} is {v:g} beam thicknesses (ã = ŵ(L/2)/h), far beyond any amplitude "
                    f"the model produces (at most {MAX_AMPLITUDE_H:g}; the prototype's backbone reaches about 3){hint}")


def read(path: PathLike) -> EnmaData:
    """Read measured (or written) ENMA data: CSV with a header row and the columns
    ``amplitude_h`` (ã = ŵ(L/2)/h) and ``frequency_hz``; optional ``damping_ratio``, ``run``,
    ``level_m_s2``, ``shape_1`` … ``shape_5`` (x/L = 1/6 … 5/6). Lines starting with ``#`` and
    blank lines are skipped; other columns are ignored. Empty optional cells are missing values.

    Raises:
        OSError: the file cannot be opened.
        EnmaFormatError (a ``ValueError``): no header, a required column missing, a cell that is
            not a number, NaN/inf or non-positive amplitude/frequency, negative damping, no rows —
            the message names the file, line and column.
    """
    p = os.fspath(path)
    try:
        with open(p, "r", encoding="utf-8") as fh:
            raw = fh.read()
    except UnicodeDecodeError:
        raise EnmaFormatError(f"{p}: not a text file (UTF-8 CSV expected)") from None
    rows = [(i + 1, ln) for i, ln in enumerate(raw.splitlines()) if ln.strip() and not ln.lstrip().startswith("#")]
    if not rows:
        raise EnmaFormatError(f"{p}: empty file (expected a header row with amplitude_h,frequency_hz)")
    header_line, header_text = rows[0]
    header = [h.strip() for h in next(csv.reader([header_text]))]
    missing = [c for c in _REQUIRED if c not in header]
    if missing:
        raise EnmaFormatError(
            f"{p}, line {header_line}: header lacks the column(s) {', '.join(missing)} "
            f"(found: {', '.join(header) or 'nothing'}); required: amplitude_h, frequency_hz")
    dup = sorted({h for h in header if header.count(h) > 1 and h})
    if dup:
        raise EnmaFormatError(f"{p}, line {header_line}: duplicate column(s) {', '.join(dup)}")
    idx = {h: i for i, h in enumerate(header)}
    cols: Dict[str, list] = {c: [] for c in ("amplitude_h", "frequency_hz", "damping_ratio", "level_m_s2", *_SHAPE_COLS)}
    runs, lines = [], []
    for line_no, text in rows[1:]:
        cells = [c.strip() for c in next(csv.reader([text]))]
        if len(cells) != len(header):
            raise EnmaFormatError(f"{p}, line {line_no}: {len(cells)} cells but the header has {len(header)} columns")
        for name, store in cols.items():
            if name not in idx:
                store.append(math.nan)
                continue
            cell = cells[idx[name]]
            if cell == "" and name not in _REQUIRED:
                store.append(math.nan)
                continue
            try:
                store.append(float(cell))
            except ValueError:
                raise EnmaFormatError(f"{p}, line {line_no}, column {name}: {cell!r} is not a number") from None
        runs.append(cells[idx["run"]] if "run" in idx else "1")
        lines.append(line_no)
    data = EnmaData(
        amplitude_h=np.array(cols["amplitude_h"]), frequency_hz=np.array(cols["frequency_hz"]),
        damping_ratio=np.array(cols["damping_ratio"]), run=np.array(runs, dtype=object),
        level_m_s2=np.array(cols["level_m_s2"]),
        shape=np.column_stack([cols[c] for c in _SHAPE_COLS]) if lines else np.zeros((0, 5)),
        source=p)
    _check_values(data, where=p, lines=lines)
    return data


def concat(parts: Sequence[EnmaData]) -> EnmaData:
    """The points of several data sets in one (e.g. repeated runs)."""
    if not parts:
        raise ValueError("concat needs at least one data set")
    return EnmaData(
        amplitude_h=np.concatenate([p.amplitude_h for p in parts]),
        frequency_hz=np.concatenate([p.frequency_hz for p in parts]),
        damping_ratio=np.concatenate([p.damping_ratio for p in parts]),
        run=np.concatenate([np.asarray(p.run, dtype=object) for p in parts]),
        level_m_s2=np.concatenate([p.level_m_s2 for p in parts]),
        shape=np.concatenate([p.shape for p in parts]),
        source=" + ".join(dict.fromkeys(p.source for p in parts)),
        info=dict(parts[0].info),
    )
