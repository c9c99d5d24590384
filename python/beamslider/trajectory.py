"""Recorded trajectories (docs/model.md §7): the size of a run's recorded arrays and the memory
bound checked before a run, the streamed files (``.npz`` / CSV) and their lazy reading. Used by
:func:`beamslider.simulate`; :func:`read_trajectory` reads files of the CLI too."""

from __future__ import annotations

import os
import warnings
import zipfile
from pathlib import Path
from typing import Any, Dict, Optional, Union

import numpy as np

from . import _core

COLUMNS = ("t_s", "w_4L7_m", "s", "xC_m", "zC_m", "beta_rad")
"""Recorded channels of :func:`beamslider.simulate`, under the core's names (CSV header, ``.npz`` members)."""

MEMORY_FRACTION = 0.5
"""Default ``max_memory`` of :func:`beamslider.simulate`: this fraction of the available memory."""

MAX_INT = 2**63 - 1
"""Largest integer argument the core takes (counts such as ``record_every``)."""


def _number(name: str, value: Any) -> float:
    """A real number argument as float; anything else is a ``ValueError`` naming the argument."""
    if isinstance(value, (str, bytes, bool, np.bool_)):
        raise ValueError(f"invalid parameter `{name}` = {value!r}: must be a number")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"invalid parameter `{name}` = {value!r}: must be a number") from None


def _positive_int(name: str, value: Any) -> int:
    if isinstance(value, (str, bytes, bool, np.bool_)):
        raise ValueError(f"invalid parameter `{name}` = {value!r}: must be an integer >= 1")
    try:
        v = int(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"invalid parameter `{name}` = {value!r}: must be an integer >= 1") from None
    if v != value or v < 1:
        raise ValueError(f"invalid parameter `{name}` = {value!r}: must be an integer >= 1")
    if v > MAX_INT:
        raise ValueError(f"invalid parameter `{name}` = {value!r}: must be an integer in 1..={MAX_INT}")
    return v


def available_memory() -> int:
    """Bytes this process can still allocate: the available physical memory (``MemAvailable``),
    capped by the address-space limit (``RLIMIT_AS``) less the address space in use."""
    avail = None
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except OSError:
        pass
    if avail is None:
        try:
            avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):  # pragma: no cover - not Unix
            avail = 8 * 2**30
    try:
        import resource

        soft, _hard = resource.getrlimit(resource.RLIMIT_AS)
        if soft != resource.RLIM_INFINITY:
            used = 0
            with open("/proc/self/status", encoding="ascii") as f:
                for line in f:
                    if line.startswith("VmSize:"):
                        used = int(line.split()[1]) * 1024
            avail = min(avail, max(0, soft - used))
    except (ImportError, OSError, ValueError):  # pragma: no cover - not Linux
        pass
    return int(avail)


def _gb(n: float) -> str:
    return f"{n / 1e9:.3g} GB" if n >= 1e8 else f"{n / 1e6:.3g} MB"


def recorded_size(t_end: float, *, dt: float, record_every: int, channels: int = len(COLUMNS)) -> int:
    """Bytes of the arrays a run records: (1 + round(t_end/dt) // record_every) rows of
    ``channels`` float64 values."""
    return int(_core.recorded_rows(float(t_end), float(dt), int(record_every))) * channels * 8


def _check_out(out: Any, overwrite: bool) -> Optional[Path]:
    if out is None:
        return None
    if not isinstance(out, (str, os.PathLike)):
        raise ValueError(f"invalid parameter `out` = {out!r}: give a file name ending in .npz or .csv")
    target = Path(out)
    if target.suffix.lower() not in (".npz", ".csv"):
        raise ValueError(f"invalid parameter `out` = {str(out)!r}: the file name must end in .npz or .csv "
                         "(parquet is not supported)")
    if target.exists() and not overwrite:
        raise ValueError(f"invalid parameter `out` = {str(out)!r}: the file exists (pass overwrite=True to replace it)")
    if not target.parent.is_dir():
        raise ValueError(f"invalid parameter `out` = {str(out)!r}: the folder {target.parent} does not exist")
    return target


def _check_memory(t_end: float, dt: float, record_every: int, max_memory: Optional[float]) -> None:
    """Refuse, before the run, an in-memory recording larger than ``max_memory``."""
    need = recorded_size(t_end, dt=dt, record_every=record_every)
    if max_memory is None:
        limit, what = MEMORY_FRACTION * available_memory(), f"half of the available memory ({_gb(available_memory())})"
    else:
        limit = _number("max_memory", max_memory)
        if not limit > 0:
            raise ValueError(f"invalid parameter `max_memory` = {max_memory!r}: must be > 0 (bytes)")
        what = f"max_memory = {_gb(limit)}"
    if need > limit:
        rows = need // (8 * len(COLUMNS))
        raise ValueError(
            f"invalid parameter `t_end` = {t_end:g}: with record_every = {record_every} ({rows} rows of "
            f"{len(COLUMNS)} channels: {', '.join(COLUMNS)}) the recorded arrays would take {_gb(need)}, more than "
            f"{what}; stream the run to a file with out=\"run.npz\" (constant memory), raise record_every or "
            "shorten t_end")


def read_trajectory(path: Union[str, "os.PathLike[str]"]) -> Dict[str, np.ndarray]:
    """The columns of a trajectory file written by :func:`simulate` (``out=``) or the CLI, by
    channel name (``t_s``, ``w_4L7_m``, ...). An ``.npz`` is memory-mapped (nothing is read until
    used; the members are stored uncompressed); a CSV is read into memory."""
    path = Path(path)
    if path.suffix.lower() == ".npz":
        return _npz_memmap(path)
    try:
        with open(path, "r", encoding="utf-8") as f:
            header = f.readline().strip().split(",")
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text CSV file (not UTF-8)") from None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, encoding="utf-8")
        except (ValueError, UnicodeDecodeError) as e:
            raise ValueError(f"{path}: {e}") from None
    if data.size and data.shape[1] != len(header):
        raise ValueError(f"{path}: rows of {data.shape[1]} values under a header of {len(header)} columns")
    return {n: (data[:, i] if data.size else np.empty(0)) for i, n in enumerate(header)}


def _npz_memmap(path: Path) -> Dict[str, np.ndarray]:
    out: Dict[str, np.ndarray] = {}
    try:
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as e:
        raise ValueError(f"{path}: not a readable .npz file ({e})") from None
    with zf, open(path, "rb") as raw:
        for info in zf.infolist():
            if not info.filename.endswith(".npy"):
                continue
            name = info.filename[:-4]
            if info.compress_type != zipfile.ZIP_STORED:
                with zf.open(info) as m:
                    out[name] = np.lib.format.read_array(m)
                continue
            raw.seek(info.header_offset)
            local = raw.read(30)
            start = info.header_offset + 30 + int.from_bytes(local[26:28], "little") + int.from_bytes(local[28:30], "little")
            raw.seek(start)
            version = np.lib.format.read_magic(raw)
            read_header = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
            shape, fortran, dtype = read_header(raw)
            if fortran or dtype.hasobject:
                raise ValueError(f"{path}: member {info.filename} is not a plain array")
            n = int(np.prod(shape))
            out[name] = (np.memmap(path, dtype=dtype, mode="r", offset=raw.tell(), shape=shape) if n
                         else np.empty(shape, dtype=dtype))
    return out
