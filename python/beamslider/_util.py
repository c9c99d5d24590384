"""Helpers shared across the package: argument checks and the progress bar driven by the core's monitor callback."""

from __future__ import annotations

import contextlib
import sys
from typing import Any, Callable, Iterator, Optional

import numpy as np

__all__ = ["MAX_INT", "number", "positive_int", "progress_bar", "stderr_is_terminal"]

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


@contextlib.contextmanager
def progress_bar(enabled: Optional[bool], total: float, desc: str, unit: str) -> Iterator[Optional[Callable[[float, float], None]]]:
    """A tqdm bar driven by the core's monitor callback ``(done, total)``; None when disabled.
    ``enabled=None``: on only when standard error is a terminal (no carriage-return frames in logs)."""
    if enabled is None:
        enabled = stderr_is_terminal()
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
