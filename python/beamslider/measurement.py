"""Reader of the published measured data set (docs/model.md §7).

Each file has three numeric columns: time [s], beam velocity at x = 4L/7 relative to the frame
[m/s] and relative slider position s [-], sampled at 1e-4 s. The operating point is in the file
name, e.g. ``Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt``
(f_ex = 124 Hz, a_ex = 14 m/s^2, s0 = 0.3). Columns may be separated by whitespace, commas,
semicolons or tabs; lines starting with ``#`` or ``%`` and one leading header line of column
names are skipped. A file may be gzip-compressed (name ending in ``.gz``), like the sample in
``examples/data/``.
"""

from __future__ import annotations

import gzip
import os
import re
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Tuple, Union

import numpy as np

from . import _core
from .signals import envelope

DISPLACEMENT_DETREND_S = 0.1
"""Window of the moving average subtracted from the integrated displacement [s] (docs/model.md §7)."""

SAMPLING_TOLERANCE = 0.1
"""Largest relative deviation of a time step from the file's sampling interval."""


MAX_DISPLACEMENT_M = 0.05
"""Largest displacement amplitude of the beam at 4L/7 a measured file may integrate to [m]
(docs/model.md §1, "Units and plausibility"): the prototype's largest is about 3 mm (3 h); 50 mm
is beyond any clamped beam of this kind the model describes, and what a velocity in mm/s gives."""

MAX_SAMPLING_INTERVAL_S = 5e-3
"""Longest sampling interval of a measured file [s] when its name gives no f_ex (otherwise: two
samples per excitation period): a coarser file cannot hold the beam's vibration, and a time
column in ms makes one (docs/model.md §1, "Units and plausibility")."""


class MeasurementFormatError(ValueError):
    """A measured-data file does not have the published format; the message names file and line."""


@dataclass
class Measurement:
    """One measured run (the published data set, docs/model.md §7)."""

    path: Path
    """File it was read from."""
    t: np.ndarray
    """Time [s]."""
    velocity: np.ndarray
    """Beam velocity at x = 4L/7 relative to the frame [m/s]."""
    w: np.ndarray
    """Beam displacement at x = 4L/7 [m]: integrated velocity minus its 0.1 s moving average."""
    s: np.ndarray
    """Relative slider position [-]."""
    f_ex: Optional[float]
    """Excitation frequency from the file name [Hz] (None if the name does not say)."""
    a_ex: Optional[float]
    """Base-acceleration amplitude from the file name [m/s^2] (None if the name does not say)."""
    s0: Optional[float]
    """Initial relative slider position from the file name [-] (None if the name does not say)."""

    @property
    def dt(self) -> float:
        """Sampling interval [s]."""
        return float(self.t[1] - self.t[0])

    def envelope(self, window: float = 1.0) -> np.ndarray:
        """Super-slow amplitude of w(4L/7) [m] (docs/model.md §7)."""
        return envelope(self.t, self.w, window=window)


_NUMBER = r"(\d+(?:[.p]\d+)?)"


def _number(text: str) -> float:
    return float(text.replace("p", "."))


def parse_operating_point(name: str) -> Tuple[Optional[float], Optional[float], Optional[float]]:
    """(f_ex [Hz], a_ex [m/s^2], s0 [-]) from a file name such as
    ``..._fex124_ExcLevel14_RelSliderPosStart03.txt``; a missing part is None.
    ``RelSliderPosStart03`` means s0 = 0.3 (the digits after a leading 0 are decimals)."""
    stem = os.path.basename(name)
    f = re.search(r"fex" + _NUMBER, stem, re.IGNORECASE)
    a = re.search(r"ExcLevel" + _NUMBER, stem, re.IGNORECASE)
    s = re.search(r"RelSliderPosStart(\d+(?:[.p]\d+)?)", stem, re.IGNORECASE)
    s0: Optional[float] = None
    if s:
        digits = s.group(1)
        if "." in digits or "p" in digits:
            s0 = _number(digits)
        elif digits.startswith("0"):
            s0 = float("0." + digits[1:]) if len(digits) > 1 else 0.0
        else:
            s0 = float("0." + digits)
    return (_number(f.group(1)) if f else None, _number(a.group(1)) if a else None, s0)


_SPLIT = re.compile(r"[,;\s]+")


def _is_number(tok: str) -> bool:
    try:
        float(tok)
        return True
    except ValueError:
        return False


def _plain_rows(text: str) -> Optional[np.ndarray]:
    """The rows of a file of the usual form — every line three finite numbers, time increasing,
    no header, comment or blank line — parsed at once; None otherwise (:func:`_rows_checked` then
    reads it line by line and names what is wrong). The same values as that reader's."""
    lines = text.count("\n") + (0 if text.endswith("\n") else 1)
    flat = _core.plain_numbers(text)
    if flat is None or lines < 2 or flat.size != 3 * lines:
        return None
    data = flat.reshape(-1, 3)
    if not (np.all(np.isfinite(data)) and np.all(np.diff(data[:, 0]) > 0)):
        return None
    return data


def _rows_checked(text: str, path: Path) -> Tuple[np.ndarray, np.ndarray]:
    """The rows of a measured file read line by line, and their line numbers: an optional header
    line, comments (# or %) and blank lines skipped; :class:`MeasurementFormatError` naming the
    line for a wrong column count, a non-numeric or non-finite value or a time that does not increase."""
    rows = []
    header_seen = False
    for lineno, raw in enumerate(text.split("\n"), start=1):
        line = raw.strip()
        if not line or line[0] in "#%":
            continue
        toks = [t for t in _SPLIT.split(line) if t]
        if not rows and not header_seen and not any(_is_number(t) for t in toks):
            header_seen = True  # one line of column names before the data
            continue
        if len(toks) != 3:
            raise MeasurementFormatError(
                f"{path}:{lineno}: expected 3 columns (time, beam velocity, slider position), found {len(toks)}"
            )
        try:
            vals = [float(t) for t in toks]
        except ValueError:
            raise MeasurementFormatError(f"{path}:{lineno}: non-numeric value in {line[:60]!r}") from None
        if not all(np.isfinite(vals)):
            raise MeasurementFormatError(f"{path}:{lineno}: non-finite value in {line[:60]!r}")
        if rows and not vals[0] > rows[-1][0][0]:
            raise MeasurementFormatError(
                f"{path}:{lineno}: time {vals[0]:g} s does not increase (previous {rows[-1][0][0]:g} s)"
            )
        rows.append((vals, lineno))
    if len(rows) < 2:
        raise MeasurementFormatError(f"{path}: fewer than two data lines")
    return np.array([r[0] for r in rows], dtype=float), np.array([r[1] for r in rows])


def read_measurement(path: Union[str, "os.PathLike[str]"]) -> Measurement:
    """Read one file of the published measured data set and integrate the velocity to the
    displacement (docs/model.md §7): cumulative sum of velocity times the sampling interval, minus its
    0.1 s centred moving average (removes the drift).

    Raises ``OSError`` if the file cannot be read and :class:`MeasurementFormatError` (a
    ``ValueError``) naming the file and line for a wrong column count, a non-numeric or
    non-finite value, non-increasing time or uneven sampling (a gap), or fewer than two lines.
    """
    path = Path(path)
    opener = gzip.open if path.name.lower().endswith(".gz") else open
    try:
        with opener(path, "rt", encoding="utf-8-sig", errors="replace") as f:  # -sig: a leading BOM is not data
            text = f.read()
    except (EOFError, zlib.error, gzip.BadGzipFile) as e:  # a truncated or corrupt .gz
        raise MeasurementFormatError(f"{path}: not a readable gzip file ({e})") from None
    data = _plain_rows(text)
    if data is not None:
        linenos = np.arange(1, len(data) + 1)
    else:
        data, linenos = _rows_checked(text, path)
    t, v, s = data[:, 0], data[:, 1], data[:, 2]
    steps = np.diff(t)
    dt = float(np.median(steps))
    # The velocity is integrated with one sampling interval: a gap (missing samples) or an extra
    # sample would silently shift the displacement, so uneven sampling is an error.
    uneven = np.flatnonzero(np.abs(steps - dt) > SAMPLING_TOLERANCE * dt)
    if uneven.size:
        i = int(uneven[0]) + 1
        raise MeasurementFormatError(
            f"{path}:{linenos[i]}: time step {steps[i - 1]:g} s differs from the sampling interval {dt:g} s "
            "(missing or extra samples)"
        )
    # s is the slider position relative to the beam length: outside [0, 1] it is not on the beam.
    off = np.flatnonzero((s < 0.0) | (s > 1.0))
    if off.size:
        i = int(off[0])
        raise MeasurementFormatError(
            f"{path}:{linenos[i]}: slider position s = {s[i]:g} outside [0, 1] (s is x/L, relative to the beam length)"
        )
    f_ex, a_ex, s0 = parse_operating_point(path.name[:-3] if path.name.lower().endswith(".gz") else path.name)
    _check_sampling(path, dt, f_ex)
    with np.errstate(over="ignore", invalid="ignore"):
        w = integrate_velocity(v, dt)
    if not np.all(np.isfinite(w)):
        raise MeasurementFormatError(f"{path}: the beam velocity is too large to integrate (displacement overflows)")
    _check_displacement(path, w)
    return Measurement(path=path, t=t, velocity=v, w=w, s=s, f_ex=f_ex, a_ex=a_ex, s0=s0)


def _check_sampling(path: Path, dt: float, f_ex: Optional[float]) -> None:
    """A sampling interval that cannot hold the beam's vibration (a time column in ms?)."""
    limit = MAX_SAMPLING_INTERVAL_S if f_ex is None else min(MAX_SAMPLING_INTERVAL_S, 0.5 / f_ex)
    if dt > limit:
        at = f" at {f_ex:g} Hz" if f_ex is not None else ""
        raise MeasurementFormatError(
            f"{path}: the sampling interval {dt:g} s is too coarse for the beam's vibration{at} (at most {limit:.3g} s): "
            f"is the time column in ms? ({dt:g} ms = {dt * 1e-3:g} s; the published files sample every 1e-4 s)")


def _check_displacement(path: Path, w: np.ndarray) -> None:
    """A displacement no beam of the model reaches (a velocity in mm/s?)."""
    peak = float(np.max(np.abs(w))) if w.size else 0.0
    if peak > MAX_DISPLACEMENT_M:
        raise MeasurementFormatError(
            f"{path}: the beam velocity integrates to a displacement of up to {peak:.3g} m at 4L/7, far beyond anything the "
            f"model produces (at most {MAX_DISPLACEMENT_M * 1e3:g} mm; the prototype's largest is about 3 mm): is the velocity "
            f"in mm/s? (/1000: up to {peak:.3g} mm; the published files give m/s)")


def integrate_velocity(velocity: np.ndarray, dt: float) -> np.ndarray:
    """Displacement from velocity as in docs/model.md §7: cumulative sum of velocity * dt minus its
    centred moving average over 0.1 s."""
    x = np.cumsum(np.asarray(velocity, dtype=float)) * dt
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"invalid parameter `dt` = {dt!r}: must be finite and > 0")
    # A window longer than twice the signal averages all of it anyway (and may not fit an integer).
    window = max(1, int(round(min(DISPLACEMENT_DETREND_S / dt, 2 * x.size + 1))))
    return x - _core.moving_average(np.ascontiguousarray(x), window)


def write_measurement(path: Union[str, "os.PathLike[str]"], t: np.ndarray, velocity: np.ndarray, s: np.ndarray) -> None:
    """Write a file in the published format (tab-separated, no header): for tests and for
    exporting a simulation as a pseudo-measurement. A name ending in ``.gz`` is gzip-compressed."""
    data = np.column_stack([t, velocity, s])
    np.savetxt(os.fspath(path), data, fmt="%.10g", delimiter="\t")  # numpy compresses *.gz itself
