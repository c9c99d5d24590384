"""One overwrite vocabulary for the commands that keep a results file (``map``, ``study``,
``design``; docs/guide/reliability.md, "Signals and overwrites"): an earlier run's results are
continued with ``--resume`` (``resume=True``), replaced with ``--force`` (``force=True``), and
otherwise refused in one line that says both."""

from __future__ import annotations

from pathlib import Path
from typing import Optional, Sequence

from . import _core


class ResultsExistError(FileExistsError, ValueError):
    """An earlier run's results are in the output folder, and neither resume nor force was given."""


def _rows(path: Path) -> Optional[int]:
    """The lines of a results file after its header (None when it cannot be read)."""
    try:
        with open(path, "rb") as f:
            return max(sum(1 for line in f if line.strip()) - 1, 0)
    except OSError:
        return None


def refuse_existing(results: Path, total: Optional[int], unit: str, what: str) -> None:
    """Refuse an existing, non-empty ``results`` file of an earlier ``what`` (a map, a study, a
    design run), saying how many of its ``total`` ``unit`` it holds and what to do."""
    try:
        if results.stat().st_size == 0:
            return
    except OSError:
        return
    done = _rows(results)
    count = f" ({done} of {total} {unit} done)" if done is not None and total else ""
    raise ResultsExistError(f"{results} exists from an earlier {what}{count}: run again with --resume (resume=True) to "
                            "continue it or with --force (force=True) to start over, or choose another --out")


def clear_results(folder: Path, results_name: str, also: Sequence[str] = ()) -> None:
    """``--force``: the results file ``results_name`` of an earlier run in ``folder`` and its
    files ``also`` removed, under the results file's one-writer lock (a run still writing them
    makes this fail at once, naming its PID)."""
    if not folder.is_dir():
        return
    with _core.ResultsLock(folder / results_name):
        for name in (results_name, *also):
            (folder / name).unlink(missing_ok=True)
