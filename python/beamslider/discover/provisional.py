"""The provisional answer of a discover (docs/model.md §9.1, "Provisional answer"): as soon as the
tiered search's first tier has fitted a candidate in full, the leading candidate so far (the lowest
χ² fitted) with its value, error and interval is handed to the caller, and again whenever the lead
improves; the rule's verdict at the end of the search replaces it. A caller that stops at the
first answer raises :class:`StopAtProvisional` from its callback."""

from __future__ import annotations

import math
import time
from typing import Any, Callable, Dict, Optional

from .result import CandidateFit
from .stats import interval_of


class StopAtProvisional(Exception):
    """Raised by a provisional callback to end the search at this answer (``--quick``); carries it."""

    def __init__(self, answer: Dict[str, Any]) -> None:
        super().__init__("stopped at the provisional answer")
        self.answer = answer


class Provisional:
    """Hands ``callback`` the leading candidate of the tier's full fits each time the lead improves."""

    def __init__(self, callback: Callable[[Dict[str, Any]], None], problem: Any, t0: float) -> None:
        self.callback, self.problem, self.t0 = callback, problem, t0
        self.best: Optional[CandidateFit] = None

    def saw(self, f: CandidateFit) -> CandidateFit:
        """Report ``f`` if it leads (a finite χ² below every fit seen so far); returns ``f``."""
        if not math.isfinite(f.chi2) or (self.best is not None and f.chi2 >= self.best.chi2):
            return f
        self.best = f
        p, level = self.problem, self.problem.options.interval_level
        self.callback(dict(
            provisional=True, level=p.level, leading=list(f.effects),
            values={e: f.values[e] for e in f.effects}, stderrs={e: f.stderrs[e] for e in f.effects},
            intervals={e: list(interval_of(f, e, level)) for e in f.effects}, chi2=f.chi2, dof=f.dof,
            adequate=bool(f.adequate), chi2_before=p.chi2_0, gap_before=p.gap_before, n_features=p.n,
            elapsed_s=time.perf_counter() - self.t0,
            note="provisional: the leading candidate of the search's first tier; the search goes on and its "
                 "verdict replaces this (docs/model.md §9.1, \"Provisional answer\")"))
        return f
