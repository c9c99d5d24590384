"""The study results file ``study.jsonl``: read and written by the Rust core only (core
``study::StudyResults``; the map results format of docs/model.md §8 with the study's
configuration in the header and ``sample``/``point``/``params`` in every row). This module
converts between the core and Python: :func:`read_results` and :func:`open_results`."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

from .. import _core
from .._json import json_safe
from .config import RESULTS_FILE, StudyConfig
from .sampling import StudyPoint


def read_results(path: Union[str, Path]) -> Tuple[Optional[Dict[str, Any]], List[Dict[str, Any]], int, bool]:
    """Read a study results file (or its folder): (header, rows, byte length of the complete part,
    truncated). An incomplete last line (a client killed while writing) is ignored; a damaged
    complete line is a ``ValueError`` naming it."""
    path = Path(path)
    if path.is_dir():
        path = path / RESULTS_FILE
    header, rows, good, truncated = _core.read_results_file(path)
    return (json.loads(header) if header is not None else None), [json.loads(r) for r in rows], good, truncated


def study_header(config: StudyConfig) -> Dict[str, Any]:
    """The ``study`` object of the results file's header."""
    return {"config": config.to_dict(), "n_points": len(config.operating_points()) * len(config.design())}


def open_results(config: StudyConfig, points: Sequence[StudyPoint], path: Optional[Path], resume: bool,
                 map_config: Optional["_core.MapConfig"] = None) -> "_core.StudyResults":
    """The core's results of a study (``path`` None: in memory only; ``map_config``: the study's
    :meth:`StudyConfig.map_config` when the caller has it): ``add(rows)``, ``in``, ``len``,
    ``rows()``, ``close()``."""
    info = [{"index": p.index, "f_ex_hz": p.f_ex_hz, "a_ex_m_s2": p.a_ex_m_s2, "s0": p.s0, "sample": p.sample,
             "point": p.point, "params": json_safe(dict(p.values))} for p in points]
    return _core.StudyResults(None if path is None else str(path), map_config or config.map_config(),
                              json_safe(study_header(config)), info, resume=resume)
