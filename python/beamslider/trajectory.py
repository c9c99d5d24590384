"""Recorded trajectories (docs/model.md §7): the size of a run's recorded arrays and the memory
bound checked before a run, the streamed files (``.npz`` / CSV / Parquet) and their lazy reading.
Used by :func:`beamslider.simulate`; :func:`read_trajectory` reads files of the CLI too."""

from __future__ import annotations

import contextlib
import os
import warnings
import zipfile
from pathlib import Path
from typing import Any, Dict, Iterator, Mapping, Optional, Union

import numpy as np

from . import _core
from ._util import number

COLUMNS = ("t_s", "w_4L7_m", "s", "xC_m", "zC_m", "beta_rad")
"""Recorded channels of :func:`beamslider.simulate`, under the core's names (CSV header, ``.npz`` members)."""

MEMORY_FRACTION = 0.5
"""Default ``max_memory`` of :func:`beamslider.simulate`: this fraction of the available memory."""

FORMATS = (".npz", ".csv", ".parquet")
"""Trajectory file formats, by extension."""

CHUNK_ROWS = 1 << 18
"""Rows per row group (and per chunk copied) of a Parquet trajectory: 12.6 MB of six float64 columns."""

CSV_CHUNK_ROWS = 1 << 16
"""Rows parsed at a time when a CSV trajectory is converted for reading (a few MB)."""

PARQUET_HINT = 'pip install "beamslider[parquet]"'


class ParquetDependencyError(ImportError):
    """A Parquet file was asked for but pyarrow (the extra ``parquet``) is not installed."""


def require_pyarrow() -> Any:
    try:
        import pyarrow
        import pyarrow.parquet  # noqa: F401
    except ImportError as e:
        raise ParquetDependencyError(
            f"Parquet trajectories need pyarrow, which is not installed: {PARQUET_HINT} (or pip install pyarrow)"
        ) from e
    return pyarrow


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


def check_out(out: Any, overwrite: bool, need_folder: bool = True) -> Optional[Path]:
    if out is None:
        return None
    if not isinstance(out, (str, os.PathLike)):
        raise ValueError(f"invalid parameter `out` = {out!r}: give a file name ending in .npz, .csv or .parquet")
    target = Path(out)
    if target.suffix.lower() not in FORMATS:
        raise ValueError(f"invalid parameter `out` = {str(out)!r}: the file name must end in .npz, .csv or .parquet")
    if target.suffix.lower() == ".parquet":
        require_pyarrow()
    if target.exists() and not overwrite:
        raise ValueError(f"invalid parameter `out` = {str(out)!r}: the file exists (pass overwrite=True to replace it)")
    if need_folder and not target.parent.is_dir():
        raise ValueError(f"invalid parameter `out` = {str(out)!r}: the folder {target.parent} does not exist")
    return target


def check_memory(t_end: float, dt: float, record_every: int, max_memory: Optional[float]) -> None:
    """Refuse, before the run, an in-memory recording larger than ``max_memory``."""
    need = recorded_size(t_end, dt=dt, record_every=record_every)
    if max_memory is None:
        limit, what = MEMORY_FRACTION * available_memory(), f"half of the available memory ({_gb(available_memory())})"
    else:
        limit = number("max_memory", max_memory)
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


CSV_BYTES_PER_VALUE = 25
"""Most bytes of one value in a trajectory CSV (``-1.2345678901234567e-05,``)."""


def check_disk(target: Path, t_end: float, dt: float, record_every: int) -> None:
    """Refuse, before the run, a streamed recording larger than the free space of its folder
    (the CSV at its widest, the binary formats at 8 bytes a value)."""
    import shutil

    per_value = CSV_BYTES_PER_VALUE if target.suffix.lower() == ".csv" else 8
    need = recorded_size(t_end, dt=dt, record_every=record_every) // 8 * per_value
    folder = target.parent
    while not folder.exists() and folder != folder.parent:  # a folder still to be made: its parent's disk
        folder = folder.parent
    try:
        usage = shutil.disk_usage(folder)
    except OSError:
        return
    free = usage.free
    if usage.total == 0:  # /proc, /sys: a file system that holds no files, whatever the run's length
        raise ValueError(f"invalid parameter `out` = {str(target.parent)!r}: {folder} is on a virtual file system "
                         "(no space at all, as /proc or /sys): write elsewhere")
    if need > free:
        raise ValueError(
            f"invalid parameter `t_end` = {t_end:g}: with record_every = {record_every} the run would write about "
            f"{_gb(need)} to {target.parent}, which has {_gb(free)} free; raise record_every, shorten t_end or "
            "write elsewhere")


def read_trajectory(path: Union[str, "os.PathLike[str]"]) -> Mapping[str, np.ndarray]:
    """The columns of a trajectory file written by :func:`simulate` (``out=``) or the CLI, by
    channel name (``t_s``, ``w_4L7_m``, ...), read lazily at bounded memory: an ``.npz`` is
    memory-mapped (nothing is read until used; the members are stored uncompressed); a
    ``.parquet`` file is read one column at a time when that column is first used (needs
    pyarrow); a CSV is converted on first use, ``CSV_CHUNK_ROWS`` rows at a time, into anonymous
    temporary files (one per column) that are then memory-mapped."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        return _npz_memmap(path)
    if suffix == ".parquet":
        return _ParquetColumns(path)
    return _CsvColumns(path)


class _LazyColumns(Mapping):
    """Columns by name, each read when first used and kept."""

    def __init__(self, path: Path, names: list) -> None:
        self.path = path
        self._names = names
        self._cols: Dict[str, np.ndarray] = {}

    def __iter__(self) -> Iterator[str]:
        return iter(self._names)

    def __len__(self) -> int:
        return len(self._names)

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self._names:
            raise KeyError(name)
        if name not in self._cols:
            self._load(name)
        return self._cols[name]

    def _load(self, name: str) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"<trajectory columns {', '.join(self._names)} of {self.path} (read on use)>"


class _ParquetColumns(_LazyColumns):
    def __init__(self, path: Path) -> None:
        require_pyarrow()
        import pyarrow.parquet as pq

        try:
            self._file = pq.ParquetFile(path)
        except Exception as e:  # pyarrow raises its own error types
            raise ValueError(f"{path}: not a readable Parquet file ({e})") from None
        super().__init__(path, list(self._file.schema_arrow.names))

    def _load(self, name: str) -> None:
        col = self._file.read(columns=[name]).column(0)
        self._cols[name] = col.to_numpy()


class _CsvColumns(_LazyColumns):
    def __init__(self, path: Path) -> None:
        try:
            with open(path, "r", encoding="utf-8") as f:
                header = f.readline().strip().split(",")
        except UnicodeDecodeError:
            raise ValueError(f"{path}: not a text CSV file (not UTF-8)") from None
        super().__init__(path, header)

    def _load(self, name: str) -> None:
        # All columns in one pass, CSV_CHUNK_ROWS rows at a time, each appended to its own anonymous
        # temporary file; then memory-mapped (bounded memory, one parse of the file).
        import itertools
        import tempfile

        files = [tempfile.TemporaryFile() for _ in self._names]
        rows = 0
        try:
            with open(self.path, "r", encoding="utf-8") as f, warnings.catch_warnings():
                warnings.simplefilter("ignore")
                f.readline()
                while True:
                    lines = list(itertools.islice(f, CSV_CHUNK_ROWS))
                    if not lines:
                        break
                    block = np.loadtxt(lines, delimiter=",", ndmin=2, dtype=np.float64)
                    if block.size and block.shape[1] != len(self._names):
                        raise ValueError(f"{self.path}: rows of {block.shape[1]} values under a header of "
                                         f"{len(self._names)} columns")
                    for i, tf in enumerate(files):
                        tf.write(np.ascontiguousarray(block[:, i]).tobytes())
                    rows += block.shape[0]
        except UnicodeDecodeError:
            raise ValueError(f"{self.path}: not a text CSV file (not UTF-8)") from None
        except ValueError as e:
            raise ValueError(e if str(e).startswith(str(self.path)) else f"{self.path}: {e}") from None
        for n, tf in zip(self._names, files):
            tf.flush()
            self._cols[n] = np.memmap(tf, dtype=np.float64, mode="r", shape=(rows,)) if rows else np.empty(0)
            tf.close()  # the mapping keeps the (unlinked) file alive


def write_parquet_from_npz(npz: Path, target: Path) -> None:
    """Copy the columns of a streamed ``.npz`` into a Parquet file, ``CHUNK_ROWS`` rows (one row
    group) at a time, read with plain reads (not memory-mapped: bounded resident memory).
    Written under a temporary name and renamed when complete."""
    pa = require_pyarrow()
    import pyarrow.parquet as pq

    members = _npz_members(npz)
    names = list(members)
    n = members[names[0]][1][0] if names else 0
    tmp = target.with_name(f".{target.name}.partial-{os.getpid()}")
    schema = pa.schema([(c, pa.float64()) for c in names])
    try:
        with open(npz, "rb") as raw, pq.ParquetWriter(tmp, schema, compression="snappy",
                                                       use_dictionary=False, write_statistics=False) as w:
            for a in range(0, max(n, 1), CHUNK_ROWS):
                m = min(CHUNK_ROWS, n - a)
                arrays = []
                for c in names:
                    offset, _shape, dtype = members[c]
                    raw.seek(offset + a * dtype.itemsize)
                    arrays.append(pa.array(np.fromfile(raw, dtype=dtype, count=m)))
                w.write_table(pa.Table.from_arrays(arrays, schema=schema), row_group_size=CHUNK_ROWS)
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.remove(tmp)
        raise


def _npz_members(path: Path) -> Dict[str, Any]:
    """The ``.npy`` members of an uncompressed ``.npz``: name → (data offset in the file, shape,
    dtype). Compressed members are not listed."""
    out: Dict[str, Any] = {}
    try:
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as e:
        raise ValueError(f"{path}: not a readable .npz file ({e})") from None
    with zf, open(path, "rb") as raw:
        for info in zf.infolist():
            if not info.filename.endswith(".npy") or info.compress_type != zipfile.ZIP_STORED:
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
            out[info.filename[:-4]] = (raw.tell(), shape, dtype)
    return out


def _npz_memmap(path: Path) -> Dict[str, np.ndarray]:
    out: Dict[str, np.ndarray] = {}
    stored = _npz_members(path)
    with zipfile.ZipFile(path) as zf:
        for info in zf.infolist():
            name = info.filename[:-4]
            if not info.filename.endswith(".npy"):
                continue
            if name not in stored:  # compressed: read it
                with zf.open(info) as m:
                    out[name] = np.lib.format.read_array(m)
                continue
            offset, shape, dtype = stored[name]
            n = int(np.prod(shape))
            out[name] = (np.memmap(path, dtype=dtype, mode="r", offset=offset, shape=shape) if n
                         else np.empty(shape, dtype=dtype))
    return out
