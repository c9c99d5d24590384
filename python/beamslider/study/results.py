"""The study results file ``study.jsonl``: header, reading, and the appending writer."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union


from .. import _core
from .config import FORMAT_VERSION, RESULTS_FILE, StudyConfig
from .sampling import StudyPoint


def _header(config: StudyConfig) -> Dict[str, Any]:
    settings = json.loads(_core.map_settings_json(config.map_toml()))
    return {"beamslider_map": FORMAT_VERSION, "settings": settings,
            "study": {"config": config.to_dict(), "n_points": len(config.operating_points()) * len(config.design())}}


def read_results(path: Union[str, Path]) -> Tuple[Optional[Dict[str, Any]], List[Dict[str, Any]], int, bool]:
    """Read a study results file (or its folder): (header, rows, byte length of the complete part,
    truncated). An incomplete or unparsable *last* line (a client killed while writing) is ignored;
    a bad line elsewhere is a ``ValueError``."""
    path = Path(path)
    if path.is_dir():
        path = path / RESULTS_FILE
    header, rows, good, truncated = None, [], 0, False
    with open(path, "rb") as f:
        lines = f.read().split(b"\n")
    tail = lines.pop()  # text after the last newline: empty, or a truncated line
    if tail:
        truncated = True
    for k, raw in enumerate(lines):
        try:
            obj = json.loads(raw.decode("utf-8")) if raw.strip() else None
        except (ValueError, UnicodeDecodeError):
            if k == len(lines) - 1:
                truncated = True
                break
            raise ValueError(f"{path}:{k + 1}: a line in the middle of the file is not a complete result row") from None
        if k == 0:
            if not isinstance(obj, dict) or "beamslider_map" not in obj:
                raise ValueError(f"{path}: not a beamslider results file (no header line)")
            if obj["beamslider_map"] != FORMAT_VERSION:
                raise ValueError(f"{path}: format version {obj['beamslider_map']} (this version reads {FORMAT_VERSION})")
            header = obj
        elif obj is not None:
            rows.append(obj)
        good += len(raw) + 1
    return header, rows, good, truncated


class _Writer:
    """Appends rows to the results file, one JSON line each, flushed at once."""

    def __init__(self, path: Path, config: StudyConfig, points: Dict[int, StudyPoint], resume: bool) -> None:
        self.path = path
        self.points = points
        self.rows: Dict[int, Dict[str, Any]] = {}
        header = _header(config)
        path.parent.mkdir(parents=True, exist_ok=True)
        # One writer per results file: a second one fails here, naming the holder's PID.
        self.lock = _core.ResultsLock(path)
        try:
            exists = path.exists() and path.stat().st_size > 0
            if exists and not resume:
                raise ValueError(f"{path}: the results file exists: resume it, or choose another output")
            if exists:
                old, rows, good, _trunc = read_results(path)
                if old is not None and (old.get("settings") != header["settings"] or old.get("study") != header["study"]):
                    raise ValueError(f"{path}: the results file was written by another study configuration")
                with open(path, "r+b") as f:
                    f.truncate(good)
                for r in rows:
                    self._check(r)
                    self.rows[int(r["index"])] = r
                self.fd = os.open(path, os.O_WRONLY | os.O_APPEND)
                if old is None:
                    self._line(header)
            else:
                self.fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_TRUNC, 0o644)
                self._line(header)
        except BaseException:
            self.lock.release()
            raise

    def _check(self, r: Dict[str, Any]) -> None:
        p = self.points.get(int(r.get("index", -1)))
        if p is None or (r["f_ex_hz"], r["a_ex_m_s2"], r["s0"]) != (p.f_ex_hz, p.a_ex_m_s2, p.s0) \
                or r.get("params") != p.values:
            raise ValueError(f"{self.path}: row {r.get('index')} does not belong to this study")

    def _line(self, obj: Dict[str, Any]) -> None:
        # One write of the whole line to a file opened with O_APPEND: rows never interleave.
        data = (json.dumps(obj, separators=(",", ":")) + "\n").encode("utf-8")
        n = os.write(self.fd, data)
        while n < len(data):  # pragma: no cover - regular files take the whole write
            n += os.write(self.fd, data[n:])

    def add(self, texts: Sequence[str]) -> None:
        for t in texts:
            r = json.loads(t)
            i = int(r["index"])
            if i in self.rows:  # a chunk re-run after a lost worker may repeat a row
                continue
            p = self.points[i]
            r["sample"], r["point"], r["params"] = p.sample, p.point, dict(p.values)
            self._line(r)
            self.rows[i] = r

    def close(self) -> None:
        os.close(self.fd)
        self.lock.release()


class _Memory(_Writer):
    def __init__(self, points: Dict[int, StudyPoint]) -> None:  # noqa: D401 - rows in memory only
        self.points, self.rows, self.path = points, {}, None

    def _line(self, obj: Dict[str, Any]) -> None:
        pass

    def close(self) -> None:
        pass
