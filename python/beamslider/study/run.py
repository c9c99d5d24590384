"""Running a study: all points through the Rust core locally, or chunks of points on a Dask cluster."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any, Callable, List, Optional, Union

import numpy as np

from .. import _core
from .._overwrite import clear_results, refuse_existing
from .._util import progress_bar
from .config import RESULTS_FILE, StudyConfig, read_config
from .results import open_results
from .sampling import StudyPoint, study_points
from .statistics import StudyResult, aggregate


def _chunks(todo: List[StudyPoint], size: int) -> List[List[StudyPoint]]:
    return [todo[i:i + size] for i in range(0, len(todo), size)]


def _run_dask(client: Any, map_cfg: Any, todo: List[StudyPoint], writer: Any, *, chunk_size: int,
              task_threads: Optional[int], max_retries: int, on_chunk: Optional[Callable[[int, int], None]],
              tick: Callable[[], None]) -> None:
    from .._dask import run_chunks, run_study_chunk

    def on_rows(rows: List[str]) -> None:
        writer.add(rows)
        tick()

    chunks = [(map_cfg, [p.chunk_tuple() for p in ch], task_threads) for ch in _chunks(todo, chunk_size)]
    run_chunks(client, run_study_chunk, chunks, tag="study" + map_cfg.toml(), on_rows=on_rows, max_retries=max_retries,
               on_chunk=on_chunk)


def run_study(config: Union[StudyConfig, str, "os.PathLike[str]"], *, out: Optional[Union[str, Path]] = None,
              resume: bool = False, force: bool = False, scheduler: Any = None, scheduler_file: Optional[str] = None,
              threads: Optional[int] = None,
              chunk_size: Optional[int] = None, task_threads: Optional[int] = 1, max_retries: int = 3,
              progress: bool = False, on_chunk: Optional[Callable[[int, int], None]] = None) -> "StudyResult":
    """Run a study and aggregate it.

    ``config``: a :class:`StudyConfig` or the path of its TOML file. ``out``: output folder; every
    finished point is appended to ``out/study.jsonl`` at once (and the configuration written to
    ``out/study.toml``); ``resume=True`` keeps the points already there and runs the rest,
    ``force=True`` replaces an earlier study there (otherwise refused).

    Local (``scheduler=None``): all points in one call of the Rust core on ``threads`` threads
    (default one per core). Dask (``scheduler`` = a scheduler address such as
    ``"tcp://10.0.0.5:8786"`` or a ``distributed.Client``, or ``scheduler_file`` written by ``dask
    scheduler --scheduler-file``; contacted before any file is written): chunks of ``chunk_size``
    points (default the configuration's) as tasks (the shared runner ``beamslider._dask``), each on ``task_threads`` rayon threads (default 1: Dask already
    runs one task per worker thread); a chunk whose worker died is re-run (up to ``max_retries``
    times on top of Dask's own retries). ``on_chunk(done, total)`` is called after each finished
    chunk (Dask). Ctrl-C stops the study keeping the finished points (``KeyboardInterrupt``).
    """
    if not isinstance(config, StudyConfig):
        config = read_config(config)
    if force and resume:
        raise ValueError("invalid parameter `force`: replaces the study in `out`; it does not go with resume")
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1):
        raise ValueError(f"invalid parameter `threads` = {threads!r}: must be an integer >= 1")
    size = config.chunk_size if chunk_size is None else chunk_size
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 1:
        raise ValueError(f"invalid parameter `chunk_size` = {size!r}: must be an integer >= 1")
    map_cfg = config.map_config()
    points = study_points(config)
    by_index = {p.index: p for p in points}
    client, own = None, False
    if scheduler is not None or scheduler_file is not None:
        from .._dask import connect

        client, own = connect(scheduler, scheduler_file)
    try:
        if out is not None and force:
            clear_results(Path(out), RESULTS_FILE, ["study.toml"])
        elif out is not None and not resume:
            refuse_existing(Path(out) / RESULTS_FILE, len(points), "runs", "study")
        return _run_study(config, map_cfg, points, by_index, out=out, resume=resume, client=client, threads=threads,
                          size=int(size), task_threads=task_threads, max_retries=max_retries, progress=progress,
                          on_chunk=on_chunk)
    finally:
        if own:
            from .._dask import close_client

            close_client(client)


def _run_study(config: StudyConfig, map_cfg: Any, points: List[StudyPoint], by_index: dict, *, out: Any,
               resume: bool, client: Any, threads: Optional[int], size: int, task_threads: Optional[int],
               max_retries: int, progress: Any, on_chunk: Any) -> "StudyResult":
    if out is not None:
        folder = Path(out)
        folder.mkdir(parents=True, exist_ok=True)
        writer = open_results(config, points, folder / RESULTS_FILE, resume, map_cfg)
        (folder / "study.toml").write_text(config.to_toml_text(), encoding="utf-8")
    else:
        writer = open_results(config, points, None, False, map_cfg)
    todo = [p for p in points if p.index not in writer]
    try:
        with progress_bar(progress, len(points), "study", "pts") as cb:
            def tick() -> None:
                if cb is not None:
                    cb(len(writer), len(points))

            tick()
            if todo and client is None:
                def on_rows(batch: List[str]) -> None:
                    writer.add(batch)
                    tick()

                writer.add(_core.run_study_chunk(map_cfg, [p.chunk_tuple() for p in todo], threads=threads,
                                                 on_rows=on_rows))
            elif todo:
                _run_dask(client, map_cfg, todo, writer, chunk_size=size, task_threads=task_threads,
                          max_retries=max_retries, on_chunk=on_chunk, tick=tick)
    finally:
        writer.close()
    if len(writer) != len(points):  # pragma: no cover - every path above either completes or raises
        raise RuntimeError(f"{len(points) - len(writer)} points of the study are missing")
    return aggregate(config, [json.loads(r) for r in writer.rows()])
