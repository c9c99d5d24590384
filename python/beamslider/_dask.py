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

import asyncio
import hashlib
import logging
import os
import time
from typing import Any, Callable, List, Optional, Sequence, Tuple


CONNECT_TIMEOUT_S = 20.0
"""The one hard timeout of reaching a scheduler [s]: the connection, Dask's handshake and the
whole start of the client together (``timeout_s``; the environment variable
``BEAMSLIDER_CONNECT_TIMEOUT_S`` overrides the default)."""


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
    return start_client(kwargs["address"], what, connect_timeout(timeout_s)), True


def connect_timeout(value: Optional[float] = None) -> float:
    """The hard timeout of a connection [s]: ``value``, else ``BEAMSLIDER_CONNECT_TIMEOUT_S``, else
    :data:`CONNECT_TIMEOUT_S`."""
    if value is None:
        try:
            value = float(os.environ.get("BEAMSLIDER_CONNECT_TIMEOUT_S", CONNECT_TIMEOUT_S))
        except ValueError:
            value = CONNECT_TIMEOUT_S
    if not (value > 0 and value < 1e9):
        raise ValueError(f"invalid parameter `timeout_s` = {value!r}: must be > 0 seconds")
    return float(value)


def _in_thread(call: Callable[[], Any], timeout_s: float) -> Tuple[bool, Any, Optional[BaseException]]:
    """``call()`` in a daemon thread, waited for at most ``timeout_s``: (finished, value, error).
    Whatever the call does (a read that never returns, an allocation that fails), the caller
    gets control back in time."""
    import threading

    box: dict = {}

    def run() -> None:
        try:
            box["value"] = call()
        except BaseException as e:  # noqa: BLE001 - MemoryError of a garbled frame, CancelledError, ...
            box["error"] = e

    t = threading.Thread(target=run, name="beamslider-dask-connect", daemon=True)
    t.start()
    t.join(max(timeout_s, 0.0))
    if t.is_alive():
        return False, None, None
    return True, box.get("value"), box.get("error")


def _reason(e: BaseException) -> str:
    """A short reason for a failed handshake."""
    if isinstance(e, MemoryError):
        return "its answer is not Dask's protocol: the first frame would need an impossible allocation"
    if isinstance(e, (asyncio.TimeoutError, TimeoutError)):
        return "no answer to Dask's handshake"
    text = " ".join(str(e).split()) or type(e).__name__
    return text if len(text) <= 120 else text[:117] + "..."


def _reachable(address: str, timeout_s: float) -> Optional[str]:
    """For a tcp:// or tls:// address: why a plain connection to its host and port fails (None
    when it connects, or when the address is of another kind)."""
    import socket
    from urllib.parse import urlsplit

    try:
        u = urlsplit(address)
        host, port = u.hostname, u.port
    except ValueError:
        return None
    if u.scheme not in ("tcp", "tls") or not host or port is None:
        return None
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            return None
    except socket.timeout:
        return f"no connection within {timeout_s:g} s"
    except OSError as e:
        return e.strerror or str(e)


async def _identity(address: str, timeout_s: float) -> Any:
    """What the server at ``address`` says it is (Dask's ``identity`` call), within ``timeout_s``."""
    from distributed.comm import connect as comm_connect

    async def ask() -> Any:
        comm = await comm_connect(address, timeout=timeout_s)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    return await asyncio.wait_for(ask(), timeout_s)


def start_client(address: str, what: str, timeout_s: float) -> Any:
    """A ``distributed.Client`` of the scheduler at ``address``, started within ``timeout_s``
    (connection, handshake and client start under one deadline). A server that refuses the
    connection is "cannot reach ..."; one that accepts it and then answers something else than a
    scheduler (an HTTP server's ``400``, bytes that are not Dask's protocol, a Dask worker,
    nothing at all) is one line: ``ADDRESS is not a Dask scheduler (why)``."""
    from distributed import Client

    deadline = time.monotonic() + timeout_s
    left = lambda: max(deadline - time.monotonic(), 0.0)  # noqa: E731
    why = _reachable(address, timeout_s)
    if why is not None:
        raise ValueError(f"cannot reach {what}: {why}")
    with _quiet_handshake():
        done, ident, error = _in_thread(lambda: asyncio.run(_identity(address, left())), left() + 0.5)
    if not done:
        raise ValueError(f"{address} is not a Dask scheduler (no answer within {timeout_s:g} s)")
    if error is not None:
        if isinstance(error, KeyboardInterrupt):
            raise error
        raise ValueError(f"{address} is not a Dask scheduler ({_reason(error)})")
    kind = ident.get("type") if isinstance(ident, dict) else None
    if kind != "Scheduler":
        said = f"it says it is a Dask {kind}" if isinstance(kind, str) else "its answer to Dask's identity call is not a scheduler's"
        raise ValueError(f"{address} is not a Dask scheduler ({said})")
    done, client, error = _in_thread(lambda: Client(address=address, timeout=f"{max(left(), 0.1):g}s"), left() + 0.5)
    if not done:
        raise ValueError(f"{address} is not a Dask scheduler (the client did not start within {timeout_s:g} s)")
    if isinstance(error, KeyboardInterrupt):
        raise error
    if error is not None:
        raise ValueError(f"{address} is not a Dask scheduler ({_reason(error)})")
    return client


class _quiet_handshake:
    """While the handshake runs: a server that is not a scheduler makes distributed log the
    failed read with a traceback; the caller reports it in one line."""

    NAMES = ("distributed.comm.tcp", "distributed.comm.core", "distributed.core")

    def __enter__(self) -> None:
        self.levels = [(log, log.level) for log in map(logging.getLogger, self.NAMES)]
        for log, _ in self.levels:
            log.setLevel(logging.CRITICAL + 1)

    def __exit__(self, *exc: Any) -> None:
        for log, level in self.levels:
            log.setLevel(level)


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


LOST_TIMEOUT_S = 60.0
"""How long a run waits for a scheduler that stopped answering, or for workers when none is
left, before it stops [s] (``lost_timeout_s``; the environment variable
``BEAMSLIDER_CLUSTER_TIMEOUT_S`` overrides the default)."""

RESUME_HINT = "the finished rows are kept: run it again with --resume (resume=True) to finish, locally or on a new cluster"


class ClusterLostError(ConnectionError):
    """The Dask scheduler went away, or no worker was left, for longer than the timeout: the run
    stopped; the rows written so far are kept (resume finishes it)."""


def lost_timeout(value: Optional[float] = None) -> float:
    """The timeout of a lost cluster [s]: ``value``, else ``BEAMSLIDER_CLUSTER_TIMEOUT_S``, else :data:`LOST_TIMEOUT_S`."""
    if value is None:
        try:
            value = float(os.environ.get("BEAMSLIDER_CLUSTER_TIMEOUT_S", LOST_TIMEOUT_S))
        except ValueError:
            value = LOST_TIMEOUT_S
    if not (value > 0 and value < 1e9):
        raise ValueError(f"invalid parameter `lost_timeout_s` = {value!r}: must be > 0 seconds")
    return float(value)


def _quietly(call: Callable[[], Any]) -> None:
    """A clean-up call to a client that may be closed already (its error would hide the real one)."""
    try:
        call()
    except Exception:  # noqa: BLE001 - ClosedClientError, CommClosedError, ... of a dead scheduler
        pass


def _silence_distributed() -> None:
    """Quiet the client's own reconnect traces (a lost scheduler, a client closed while
    reconnecting): the run reports the loss in one line of its own."""
    import logging

    for name in ("distributed", "distributed.client", "tornado.application"):
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)


CLEANUP_TIMEOUT_S = 10.0
"""The longest a clean-up call to the client (cancelling the chunks left, closing it) may hold up
the end of a run [s]: a client whose scheduler is gone can wait on its event loop for longer."""


def _bounded(call: Callable[[], Any], timeout_s: float = CLEANUP_TIMEOUT_S) -> None:
    """A clean-up call run quietly in a daemon thread, waited for at most ``timeout_s``: an
    interrupted or failing run ends promptly even when the client's event loop does not answer."""
    import threading

    t = threading.Thread(target=_quietly, args=(call,), name="beamslider-dask-cleanup", daemon=True)
    t.start()
    t.join(timeout_s)


def close_client(client: Any) -> None:
    """Close a client we own, quietly when its scheduler is gone, and in bounded time."""
    if getattr(client, "status", "running") != "running":
        _silence_distributed()
    _bounded(lambda: client.close(timeout=5))


def run_chunks(client: Any, func: Callable[..., List[str]], chunks: Sequence[tuple], *, tag: str,
               on_rows: Callable[[List[str]], None], max_retries: int = 3,
               on_chunk: Optional[Callable[[int, int], None]] = None, lost_timeout_s: Optional[float] = None,
               resume_hint: str = RESUME_HINT) -> None:
    """Run ``func(*chunk)`` for every chunk on the cluster; ``on_rows(rows)`` with each finished
    chunk's rows (in the calling thread, as they finish). A chunk lost with its worker is
    re-submitted up to ``max_retries`` times. A scheduler that stops answering, or a cluster
    without workers, for longer than ``lost_timeout_s`` (:func:`lost_timeout`) ends the run with
    a :class:`ClusterLostError` saying how to resume (the rows already passed to ``on_rows`` are kept)."""
    from distributed import wait

    timeout = lost_timeout(lost_timeout_s)
    digest = hashlib.sha1(tag.encode()).hexdigest()[:10]

    def submit(k: int, tries: int) -> Any:
        return client.submit(func, *chunks[k], key=f"beamslider-{digest}-{k}-r{tries}-{time.time_ns()}", pure=False)

    def lost(why: str) -> ClusterLostError:
        _silence_distributed()
        return ClusterLostError(f"the Dask cluster is lost ({why}): stopped after {done} of {len(chunks)} chunks; {resume_hint}")

    # Ctrl-C inside distributed's `sync` schedules a cancel callback on the client's event loop
    # that can fail there (a NameError in some distributed releases) and log a traceback from the
    # loop's thread, and a scheduler that goes away makes the client's batched comm log its closing
    # with a traceback (at INFO); the run reports the interruption and the loss itself, so those
    # loggers are quiet while the chunks run and stay quiet when the run is interrupted.
    loop_logs = [logging.getLogger(name) for name in ("tornado.application", "distributed.batched")]
    loop_levels = [log.level for log in loop_logs]
    for log in loop_logs:
        log.setLevel(logging.CRITICAL + 1)
    futures = {submit(k, 0): (k, 0) for k in range(len(chunks))}
    done = 0
    trouble_since: Optional[float] = None
    interrupted = False
    try:
        while futures:
            try:
                finished, _ = wait(list(futures), timeout=min(1.0, timeout), return_when="FIRST_COMPLETED")
            except TimeoutError:
                finished = set()
            except (Exception, asyncio.CancelledError):  # noqa: BLE001 - a cancelled future, a closed client
                finished = {f for f in futures if f.done()}
                if not finished:
                    time.sleep(0.2)
            status = getattr(client, "status", "running")
            if status == "closed":
                raise lost("the scheduler stopped answering and the client gave up reconnecting")
            why = None
            if status != "running":
                why = f"no answer from the scheduler for {timeout:g} s"
            elif not finished and _workers(client) == 0:
                why = f"no worker for {timeout:g} s"
            if why is None:
                trouble_since = None
            else:
                trouble_since = trouble_since or time.monotonic()
                if time.monotonic() - trouble_since > timeout:
                    raise lost(why)
                continue
            for fut in finished:
                k, tries = futures.pop(fut)
                try:
                    rows = fut.result()
                except (Exception, asyncio.CancelledError) as e:  # a lost worker (KilledWorker, ...), a cancelled chunk or a bad point
                    if isinstance(e, ValueError) or tries >= max_retries:
                        raise
                    if getattr(client, "status", "running") != "running":
                        futures[fut] = (k, tries)  # the scheduler is away: judged above on the next round
                        trouble_since = trouble_since or time.monotonic()
                        continue
                    futures[submit(k, tries + 1)] = (k, tries + 1)
                    continue
                on_rows(rows)
                done += 1
                if on_chunk is not None:
                    on_chunk(done, len(chunks))
    except KeyboardInterrupt:
        interrupted = True
        _silence_distributed()
        raise
    finally:
        if futures and getattr(client, "status", "running") not in ("closing", "closed"):
            left = list(futures)
            _bounded(lambda: client.cancel(left))
        if not interrupted:
            for log, level in zip(loop_logs, loop_levels):
                log.setLevel(level)


def _workers(client: Any) -> int:
    """The number of workers the scheduler knows (-1 when it cannot tell)."""
    try:
        return len(client.scheduler_info().get("workers", {}))
    except Exception:  # noqa: BLE001
        return -1


def run_study_chunk(map_config: Any, chunk: List[Tuple[int, str, float, float, float, float]],
                    threads: Optional[int]) -> List[str]:
    """A Dask task of a study or a design run: one chunk of points through the Rust core (rayon, interpreter released)."""
    from beamslider import _core as core

    return core.run_study_chunk(map_config, chunk, threads=threads)
