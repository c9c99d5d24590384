"""Helpers shared across the package: argument checks and the progress bar driven by the core's monitor callback."""

from __future__ import annotations

import contextlib
import os
import re
import sys
import time
from typing import Any, Callable, Iterator, List, Optional

import numpy as np

__all__ = ["LogProgress", "MAX_INT", "number", "positive_int", "progress_bar", "remove_dead_partials", "stderr_is_terminal"]

MAX_INT = 2**63 - 1
"""Largest integer argument the core takes (counts such as ``record_every``)."""


def number(name: str, value: Any) -> float:
    """A real number argument as float; anything else is a ``ValueError`` naming the argument."""
    if isinstance(value, (str, bytes, bool, np.bool_)):
        raise ValueError(f"invalid parameter `{name}` = {value!r}: must be a number")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"invalid parameter `{name}` = {value!r}: must be a number") from None


def positive_int(name: str, value: Any) -> int:
    """A count argument (an integer in 1..=MAX_INT); anything else is a ``ValueError`` naming the argument."""
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


def write_text_atomic(path: "os.PathLike[str]", text: str) -> None:
    """``text`` written under a temporary name and renamed: a reader sees the old file or the new
    one, never a half-written one (another process resuming the same folder reads it)."""
    path = os.fspath(path)
    tmp = os.path.join(os.path.dirname(path), f".{os.path.basename(path)}.partial-{os.getpid()}")
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, path)


_PARTIAL = re.compile(r"^\..+\.partial-(\d+)(\.[A-Za-z0-9]+)?$")
"""A file being written under a temporary name by process PID (``.NAME.partial-PID`` and
``.NAME.partial-PID.npz``: :func:`write_text_atomic`, the core's streamed trajectories)."""


def _alive(pid: int) -> bool:
    """Whether process ``pid`` runs on this machine (True when that cannot be told)."""
    if os.name == "nt" or pid <= 0:
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # PermissionError: another user's process
        return True
    return True


def remove_dead_partials(folder: "os.PathLike[str]") -> List[str]:
    """Remove the temporary files in ``folder`` that a process which no longer runs (killed
    with SIGKILL, a crash, a lost machine's power) left half-written; files of running
    processes stay. Returns the names removed."""
    removed = []
    try:
        entries = list(os.scandir(os.fspath(folder)))
    except OSError:
        return removed
    for e in entries:
        m = _PARTIAL.match(e.name)
        if m is None or int(m.group(1)) == os.getpid() or _alive(int(m.group(1))):
            continue
        try:
            if e.is_file(follow_symlinks=False):
                os.remove(e.path)
                removed.append(e.name)
        except OSError:
            pass
    return removed


@contextlib.contextmanager
def progress_bar(enabled: Optional[bool], total: float, desc: str, unit: str) -> Iterator[Optional[Callable[[float, float], None]]]:
    """A tqdm bar driven by the core's monitor callback ``(done, total)``; None when disabled.
    ``enabled=None``: the bar when standard error is a terminal, else a plain line now and then
    (:class:`LogProgress`: no carriage-return frames in logs, yet a long run is not silent)."""
    if enabled is None and not stderr_is_terminal():
        log = LogProgress(total, desc, unit)
        try:
            yield log.at
        finally:
            log.close()
        return
    if not enabled:
        yield None
        return
    from tqdm.auto import tqdm

    bar = tqdm(total=round(total, 6), desc=desc, unit=unit, leave=True, dynamic_ncols=True,
               bar_format="{l_bar}{bar}| " + ("{n:.0f}/{total:.0f} " if unit == "pts" else "{n:.2f}/{total:.2f} ")
               + unit + " [{elapsed}<{remaining}]")

    def update(done: float, _total: float) -> None:
        step = round(done, 6) - bar.n
        if step > 0:
            bar.update(step)

    try:
        yield update
    except BaseException:
        bar.leave = False  # an error message follows; do not leave a stale bar above it
        raise
    finally:
        bar.close()


def stderr_is_terminal() -> bool:
    try:
        return sys.stderr is not None and sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


LOG_INTERVAL_S = 60.0
"""Seconds between the progress lines of :class:`LogProgress` (``BEAMSLIDER_PROGRESS_INTERVAL_S`` overrides)."""


class LogProgress:
    """Progress for a log file (standard error not a terminal): a line on standard error at most
    every :data:`LOG_INTERVAL_S` seconds, ``beamslider: map 12/112 pts (11 %), 3.0 min elapsed,
    about 25 min left``; nothing for a run shorter than that. tqdm-like: ``update(n)``,
    ``total``, ``refresh()``, ``close()``; ``at(done, total)`` is the core's monitor callback."""

    def __init__(self, total: float, desc: str, unit: str, interval_s: Optional[float] = None) -> None:
        if interval_s is None:
            try:
                interval_s = float(os.environ.get("BEAMSLIDER_PROGRESS_INTERVAL_S", LOG_INTERVAL_S))
            except ValueError:
                interval_s = LOG_INTERVAL_S
        self.total, self.desc, self.unit, self.interval_s = total, desc, unit, interval_s
        self.n = 0.0
        self.postfix = ""
        self.t0 = self._last = time.monotonic()

    def at(self, done: float, total: Optional[float] = None) -> None:
        if total:
            self.total = total
        self.n = done
        now = time.monotonic()
        if now - self._last >= self.interval_s:
            self._last = now
            self._line(now)

    def update(self, n: float = 1) -> None:
        self.at(self.n + n)

    def refresh(self) -> None:
        pass

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> None:
        """tqdm's: ``s`` follows the count in the lines (a line if the interval has passed)."""
        self.postfix = s
        if refresh:
            self.at(self.n)

    def close(self) -> None:
        pass

    def _line(self, now: float) -> None:
        elapsed = now - self.t0
        frac = self.n / self.total if self.total else 0.0
        count = f"{self.n:.0f}/{self.total:.0f}" if self.unit in ("pts", "fit", "table", "pt", "designs") else f"{self.n:.2f}/{self.total:.2f}"
        left = f", about {_minutes(elapsed * (1 - frac) / frac)} left" if 0 < frac < 1 else ""
        post = f", {self.postfix}" if self.postfix else ""
        try:
            print(f"beamslider: {self.desc} {count} {self.unit} ({100 * frac:.0f} %){post}, {_minutes(elapsed)} elapsed{left}",
                  file=sys.stderr, flush=True)
        except (OSError, ValueError):
            pass


def _minutes(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.1f} min"
