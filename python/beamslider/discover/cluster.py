"""A discover's free-slider runs as tasks of a Dask cluster (docs/cluster.md, "A discover on a
cluster"): :func:`on_cluster` connects to a scheduler and sets :data:`.models.RUN_BATCH` to a
:class:`ClusterRunner`, which makes each batch of runs as chunks on the workers through the
package's one chunked runner (:func:`beamslider._dask.run_chunks`: a chunk lost with its worker is
re-run, a lost cluster is one line). The runs are deterministic, so the discover's answer is that
of the local run (docs/model.md §9.1, "Kept runs": a run is the same wherever it is made)."""

from __future__ import annotations

from contextlib import contextmanager
from typing import Any, Callable, Dict, Iterator, List, Optional, Sequence, Tuple

from .. import _dask
from .models import RUN_BATCH

CHUNKS_PER_THREAD = 3
"""Chunks a batch is cut into per worker thread of the cluster: a few, so that a slow chunk (a
model whose runs take longer) does not leave the other workers idle at the end of the batch."""

TASK_THREADS = 1
"""Threads of the core's runner inside one task: one, as each worker thread runs one task (start
the workers with ``--nthreads`` = their cores, or one thread and ``--nworkers auto``)."""

LOST_HINT = ("the runs of this batch are lost with it, those of the batches before are kept in the runs file "
             "(runs_file, --runs): the same command goes on from them, locally or on a new cluster")
"""What a discover whose cluster is lost keeps: the caller appends a batch's runs to the kept-runs
store (:class:`.runstore.RunStore`) when the batch returns whole, so a lost batch keeps none."""


def run_chunk(jobs: Sequence[Tuple[Any, ...]], start: int, settings: Dict[str, Any]) -> List[Tuple[int, List[Dict[str, Any]]]]:
    """A Dask task: the jobs ``start``, ``start + 1``, ... of a batch through the core's runner on
    the worker (:data:`TASK_THREADS`); one row, (``start``, the results in the jobs' order)."""
    from .. import _core

    return [(start, _core.run_free_slider_batch(list(jobs), threads=TASK_THREADS, **settings))]


def chunk_size(n_jobs: int, threads: int) -> int:
    """Jobs per chunk: the batch cut into :data:`CHUNKS_PER_THREAD` chunks per worker thread."""
    return max(1, -(-n_jobs // max(1, threads * CHUNKS_PER_THREAD)))


def cluster_threads(client: Any) -> int:
    """The worker threads of the client's cluster (1 when it cannot tell: chunks of one job each)."""
    try:
        return max(1, sum(client.nthreads().values()))
    except Exception:  # noqa: BLE001 - a scheduler that does not answer: run_chunks judges it
        return 1


class ClusterRunner:
    """``_core.run_free_slider_batch``'s signature and results, the jobs made as chunks on the
    workers of ``client``'s cluster; ``on_done(n)`` with each finished chunk's n runs. ``threads``
    (the local runner's threads) is not used: each task runs on :data:`TASK_THREADS`. A lost
    cluster is a :class:`beamslider._dask.ClusterLostError` naming the scheduler (``name``)."""

    def __init__(self, client: Any, name: str, lost_timeout_s: Optional[float] = None) -> None:
        self.client, self.name, self.lost_timeout_s = client, name, lost_timeout_s

    def __call__(self, jobs: Sequence[Tuple[Any, ...]], *, record_every: int = 5, keep_every: int = 5,
                 window_s: float = 1.0, detrend_s: Optional[float] = None, threads: Optional[int] = None,
                 on_done: Optional[Callable[[int], Any]] = None) -> List[Dict[str, Any]]:
        jobs = list(jobs)
        settings = dict(record_every=record_every, keep_every=keep_every, window_s=window_s, detrend_s=detrend_s)
        size = chunk_size(len(jobs), cluster_threads(self.client)) if jobs else 1
        chunks = [(jobs[i:i + size], i, settings) for i in range(0, len(jobs), size)]
        out: List[Optional[Dict[str, Any]]] = [None] * len(jobs)

        def on_rows(rows: List[Tuple[int, List[Dict[str, Any]]]]) -> None:
            for start, results in rows:
                out[start:start + len(results)] = results
                if on_done is not None:
                    on_done(len(results))

        try:
            _dask.run_chunks(self.client, run_chunk, chunks, tag="discover-runs", on_rows=on_rows,
                             lost_timeout_s=self.lost_timeout_s, resume_hint=LOST_HINT)
        except _dask.ClusterLostError as e:
            raise _dask.ClusterLostError(f"{self.name}: {e}") from None
        return out  # type: ignore[return-value]


def scheduler_name(client: Any, scheduler_file: Optional[str] = None) -> str:
    """The scheduler as a message names it: its address (and the scheduler file it came from)."""
    address = getattr(getattr(client, "scheduler", None), "address", None) or "unknown address"
    return f"the scheduler at {address}" + (f" (of {scheduler_file})" if scheduler_file else "")


@contextmanager
def on_cluster(scheduler: Any = None, scheduler_file: Optional[str] = None, *,
               lost_timeout_s: Optional[float] = None) -> Iterator[Optional[ClusterRunner]]:
    """Inside: the free-slider runs of a discover are made on the Dask cluster of ``scheduler`` (an
    address or a ``distributed.Client``) or ``scheduler_file`` (:func:`beamslider._dask.connect`,
    which refuses both and an unreachable scheduler in one line before anything runs); on exit
    the local runner is back and a client opened here is closed. Neither given: nothing changes
    (yields None)."""
    if scheduler is None and scheduler_file is None:
        yield None
        return
    _dask.lost_timeout(lost_timeout_s)  # a bad timeout refused before connecting
    client, own = _dask.connect(scheduler, scheduler_file)
    runner = ClusterRunner(client, scheduler_name(client, scheduler_file), lost_timeout_s)
    token = RUN_BATCH.set(runner)
    try:
        yield runner
    finally:
        RUN_BATCH.reset(token)
        if own:
            _dask.close_client(client)
