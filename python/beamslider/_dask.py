"""The one chunked Dask runner of beamslider: maps, studies (and later design runs) send chunks of
points to a Dask cluster through :func:`run_chunks`; the client appends the returned rows to the
results file it holds locked. A chunk whose worker died is re-run (rows already written are
skipped by the writers), bad input (``ValueError``) and Ctrl-C are not retried.

Starting a cluster: ``dask scheduler --scheduler-file sched.json`` on one machine and
``dask worker --scheduler-file sched.json --nthreads 1`` on each worker machine (or a
``dask_jobqueue`` cluster on a batch system); then pass the address (``tcp://host:8786``), a
``distributed.Client`` or the scheduler file. See docs/cluster.md.
"""

from __future__ import annotations

import hashlib
import os
import time
from typing import Any, Callable, List, Optional, Sequence, Tuple


CONNECT_TIMEOUT_S = 20.0
"""How long to try to reach a scheduler before giving up [s]."""


def connect(scheduler: Any = None, scheduler_file: Optional[str] = None, *, timeout_s: Optional[float] = None) -> Tuple[Any, bool]:
    """A ``distributed.Client`` for ``scheduler`` (an address or a Client) or ``scheduler_file``;
    returns (client, whether we own it and must close it). Raises a ``ValueError`` naming the
    scheduler when it cannot be reached (before anything is written)."""
    try:
        from distributed import Client
    except ImportError:  # pragma: no cover
        raise ImportError("running on a cluster needs dask.distributed: pip install 'beamslider[study]'") from None
    if scheduler is not None and scheduler_file is not None:
        raise ValueError("invalid parameter `scheduler_file`: give a scheduler address or a scheduler file, not both")
    if isinstance(scheduler, Client):
        return scheduler, False
    if scheduler_file is not None:
        if not os.path.isfile(scheduler_file):
            raise ValueError(f"invalid parameter `scheduler_file` = {scheduler_file!r}: no such file")
        what = f"the scheduler of {scheduler_file}"
        kwargs = {"address": scheduler_file_address(scheduler_file)}
    elif isinstance(scheduler, str):
        what = f"the scheduler at {scheduler}"
        kwargs = {"address": scheduler}
    else:
        raise ValueError(f"invalid parameter `scheduler` = {scheduler!r}: give an address such as "
                         "'tcp://10.0.0.5:8786' or a distributed.Client")
    try:
        return Client(timeout=f"{CONNECT_TIMEOUT_S if timeout_s is None else timeout_s}s", **kwargs), True
    except (OSError, TimeoutError) as e:
        raise ValueError(f"cannot reach {what}: {e}") from None
    except ValueError as e:
        raise ValueError(f"cannot use {what}: {e}") from None


def scheduler_file_address(path: Any) -> str:
    """The scheduler address in a scheduler file (``dask scheduler --scheduler-file``: a JSON
    object with ``address`` = ``"tcp://host:port"``); a ValueError naming the file otherwise."""
    import json

    try:
        with open(os.fspath(path), "rb") as f:
            d = json.loads(f.read(1 << 20).decode("utf-8"))
    except (ValueError, RecursionError) as e:  # JSONDecodeError and UnicodeDecodeError are ValueErrors
        raise ValueError(f"invalid parameter `scheduler_file`: {path} is not a Dask scheduler file "
                         f"(JSON with an `address`): {str(e)[:80]}") from None
    address = d.get("address") if isinstance(d, dict) else None
    if not isinstance(address, str) or "://" not in address:
        raise ValueError(f"invalid parameter `scheduler_file`: {path} has no scheduler `address` "
                         "(expected a JSON object with address = \"tcp://host:port\", as dask scheduler writes)")
    return address


def run_chunks(client: Any, func: Callable[..., List[str]], chunks: Sequence[tuple], *, tag: str,
               on_rows: Callable[[List[str]], None], max_retries: int = 3,
               on_chunk: Optional[Callable[[int, int], None]] = None) -> None:
    """Run ``func(*chunk)`` for every chunk on the cluster; ``on_rows(rows)`` with each finished
    chunk's rows (in the calling thread, as they finish). A chunk lost with its worker is
    re-submitted up to ``max_retries`` times."""
    from distributed import as_completed

    digest = hashlib.sha1(tag.encode()).hexdigest()[:10]

    def submit(k: int, tries: int) -> Any:
        return client.submit(func, *chunks[k], key=f"beamslider-{digest}-{k}-r{tries}-{time.time_ns()}", pure=False)

    futures = {submit(k, 0): (k, 0) for k in range(len(chunks))}
    try:
        ac = as_completed(list(futures))
        done = 0
        for fut in ac:
            k, tries = futures.pop(fut)
            try:
                rows = fut.result()
            except Exception as e:  # a lost worker (KilledWorker, CommClosedError, ...) or a bad point
                if isinstance(e, (ValueError, KeyboardInterrupt)) or tries >= max_retries:
                    raise
                new = submit(k, tries + 1)
                futures[new] = (k, tries + 1)
                ac.add(new)
                continue
            on_rows(rows)
            done += 1
            if on_chunk is not None:
                on_chunk(done, len(chunks))
    finally:
        for fut in list(futures):
            fut.cancel()


def run_study_chunk(map_toml: str, chunk: List[Tuple[int, str, float, float, float, float]],
                    threads: Optional[int]) -> List[str]:
    """A Dask task of a study or a design run: one chunk of points through the Rust core (rayon, interpreter released)."""
    from beamslider import _core as core

    return core.run_study_chunk(map_toml, chunk, threads=threads)
