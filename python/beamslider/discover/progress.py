"""The progress a discover's search shows: a bar of fits done / to do, the runs made and the lowest
χ² fitted so far."""

from __future__ import annotations

import math
from typing import Any, Optional

from .report import fmt_value
from .result import CandidateFit


def progress_bar(enabled: Optional[bool], total: int, desc: str):
    """tqdm bar of fits done / to do (a no-op object when disabled; ``None``: the bar on a
    terminal, else a line now and then, :class:`beamslider._util.LogProgress`)."""
    from tqdm.auto import tqdm

    from .._util import LogProgress, stderr_is_terminal

    if enabled is None:
        if not stderr_is_terminal():
            return LogProgress(total, desc, "fit")
        enabled = True

    return tqdm(total=total, desc=desc, unit="fit", disable=not enabled, leave=False)


class FitProgress:
    """What the fits' progress shows beside the count of fits (on a terminal the bar's postfix, in
    a log a line at most every ``LOG_INTERVAL_S``, :class:`beamslider._util.LogProgress`): the runs
    made so far (the core's per-run callback, :data:`.models.RUN_PROGRESS`), so that a long fit
    still shows progress, and the lowest χ² fitted so far with its values (not a verdict: the
    naming rule and the other candidates come after)."""

    def __init__(self, bar: Any) -> None:
        self.bar, self.runs, self.best = bar, 0, None

    def __call__(self, n: int) -> None:
        self.runs += n
        self._show()

    def saw(self, f: CandidateFit) -> None:
        if math.isfinite(f.chi2) and (self.best is None or f.chi2 < self.best.chi2):
            self.best = f
            self._show()

    def _show(self) -> None:
        text = f"{self.runs} runs made"
        if self.best is not None:
            vals = ", ".join(f"{e} {fmt_value(self.best.values[e])}" for e in self.best.effects)
            text += f", lowest chi2 so far {self.best.chi2:.3g} ({vals})"
        self.bar.set_postfix_str(text, refresh=True)
