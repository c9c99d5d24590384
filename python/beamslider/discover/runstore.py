"""A discover's free-slider runs kept on disk, so that a discover that is interrupted, or run again
on the same runs' operating points (more candidates, another gap ratio, an added run at the advised
point, data of another device measured at the same points), makes only the runs it has not made
yet (docs/model.md §9.1, "Kept runs").

The file is JSON lines, one run a line: its inputs (the key of :func:`.models.batch_slider_features`:
physical parameters, operating point, excitation level, s0, duration), the features and behaviour the
run gave (or that it failed), and a fingerprint of the code that made it. A run is reused only by
the same code — or by code entered in :data:`.lineage.RUNS` as making the same runs, bitwise — so a
reused run is bitwise the run that would be made (the simulations are deterministic): verdicts,
values and intervals do not depend on what the file held. The slider
paths of the report's figures are not kept (about 32 kB a run); the few runs drawn are made again.

Lines are appended with one ``write`` each to a file opened for appending, so two discovers may
share a file; a line cut short by a killed process is skipped when the file is read.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any, Optional, Tuple, Union

from . import lineage
from .features import Feature

FORMAT = 1
"""The version of a line's layout."""

_FINGERPRINT: Optional[str] = None


RUN_SOURCES = ("discover/models.py", "discover/features.py", "discover/runstore.py", "measurement.py", "params.py")
"""The package's sources that turn a run's key into its stored features (with the core's binary):
the runner's call and settings, the feature extractor, this file's layout, the detrending window and
the parameters' conversion. The modules that choose which runs to make and judge their features
(the search, the rule, the report) are not among them: a changed rule re-judges the same runs."""


def code_fingerprint() -> str:
    """A digest of the code that makes a run's features: the core's binary and :data:`RUN_SOURCES`
    (a changed simulator or feature extractor invalidates every kept run)."""
    global _FINGERPRINT
    if _FINGERPRINT is None:
        from .. import _core

        root = Path(__file__).resolve().parent.parent
        h = hashlib.sha1()
        h.update(Path(_core.__file__).resolve().name.encode())
        h.update(Path(_core.__file__).resolve().read_bytes())
        for rel in RUN_SOURCES:
            h.update(rel.encode())
            h.update((root / rel).read_bytes())
        _FINGERPRINT = h.hexdigest()[:16]
    return _FINGERPRINT


def _key_text(key: Tuple[Any, ...]) -> str:
    return json.dumps(key, default=float, separators=(",", ":"))


def _encode(run: Any) -> Any:
    if run is None:
        return None
    feats, behaviour = run[0], run[1]
    return {"behaviour": behaviour,
            "features": {k: [float(f.value), float(f.stderr), f.unit, f.description] for k, f in feats.items()}}


def _decode(d: Any) -> Any:
    if d is None:
        return None
    feats = {k: Feature(k, float(v[0]), float(v[1]), str(v[2]), str(v[3])) for k, v in d["features"].items()}
    return feats, str(d["behaviour"]), None


class RunStore(dict):
    """The run cache of a discover (:data:`.models.RunCache`) backed by a JSON-lines file: the
    runs the file holds for this code are there from the start, and every run set is appended.
    Entries read from the file have no slider path (None). ``loaded``: runs read from the file;
    ``added``: runs appended since."""

    def __init__(self, path: Union[str, os.PathLike]) -> None:
        super().__init__()
        self.path = Path(path)
        self.loaded = 0
        self.added = 0
        fp = code_fingerprint()
        taken = lineage.accepted(fp, lineage.RUNS)  # this code's runs and those it takes over
        if self.path.is_dir():
            raise ValueError(f"invalid runs file {self.path}: it is a folder")
        try:
            raw = self.path.read_bytes()
        except FileNotFoundError:
            raw = b""
        except OSError as e:
            raise ValueError(f"cannot read runs file {self.path}: {e.strerror or e}") from None
        self._on_disk: set = set()  # the keys the file holds: a run made again (for its path) is not appended
        whole = raw.split(b"\n")[:-1]  # the lines ended by a newline
        if whole and not any(_ours(line) for line in whole):
            raise ValueError(f"invalid runs file {self.path}: it is not a file of runs that discover keeps "
                             "(give a new file, or that of an earlier discover)")
        for line in raw.splitlines():
            try:
                d = json.loads(line)
                if not (isinstance(d, dict) and d.get("v") == FORMAT and d.get("code") in taken):
                    continue
                key = _to_tuple(json.loads(d["key"]))
                super().__setitem__(key, _decode(d["run"]))
                self._on_disk.add(key)
                self.loaded += 1
            except (ValueError, KeyError, TypeError, IndexError):
                continue  # a line cut short, or not one of ours
        self._fp = fp
        self._tail_newline = bool(raw) and not raw.endswith(b"\n")
        try:  # writable before any run is made
            self.path.parent.mkdir(parents=True, exist_ok=True)
            os.close(os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644))
        except OSError as e:
            raise ValueError(f"cannot write runs file {self.path}: {e.strerror or e}") from None

    def __setitem__(self, key: Tuple[Any, ...], run: Any) -> None:
        super().__setitem__(key, run)
        if key in self._on_disk:  # made again for the slider path the file does not keep
            return
        self._on_disk.add(key)
        self.added += 1
        line = json.dumps({"v": FORMAT, "code": self._fp, "key": _key_text(key), "run": _encode(run)},
                          separators=(",", ":"), allow_nan=True) + "\n"
        if self._tail_newline:  # the last line of the file was cut short: end it first
            line = "\n" + line
            self._tail_newline = False
        data = line.encode()
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            while data:
                data = data[os.write(fd, data):]
        finally:
            os.close(fd)


def _ours(line: bytes) -> bool:
    """Whether a whole line is a run of a runs file (of any code version)."""
    try:
        d = json.loads(line)
    except ValueError:
        return False
    return isinstance(d, dict) and {"v", "code", "key", "run"} <= set(d)


def _to_tuple(x: Any) -> Any:
    """A key read back from JSON: its lists as the tuples they were."""
    return tuple(_to_tuple(v) for v in x) if isinstance(x, list) else x
