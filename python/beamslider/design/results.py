"""Results of a design run: the file ``design.jsonl`` (a header line with the configuration, then
one JSON line per evaluated design, appended, flushed and synced as soon as the design is done, under
the core's one-writer lock ``design.jsonl.lock``; read and written by the core's results-file code,
docs/model.md §8), the Pareto front and :class:`DesignResult`."""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np

from .. import _core
from .._json import json_safe
from .._overwrite import refuse_existing
from ..params import Parameters
from .config import RESULTS_FILE, DesignConfig

FORMAT = 1
"""Version of the design results file."""


def design_key(evaluator: str, mode: str, t_end_s: float, x: Any) -> str:
    """Identity of one evaluation: evaluator, mode (``nominal`` / ``robust``), run duration and the
    exact design vector (floats written with repr, so a resumed optimiser finds it bitwise)."""
    return json.dumps([evaluator, mode, float(t_end_s), [float(v) for v in np.asarray(x, dtype=float).ravel()]])


def read_design_file(path: Union[str, Path]) -> tuple:
    """(header, records, byte length of the complete part), read by the core's results-file reader
    (docs/model.md §8). An incomplete last line (a run killed while writing) is ignored; a damaged
    complete line, or a header of another kind of file, is a ValueError naming the file and line."""
    path = Path(path)
    if path.is_dir():
        path = path / RESULTS_FILE
    lines, good, _truncated = _core.read_json_lines(path, "beamslider_design", FORMAT)
    if not lines:
        return None, [], 0
    return json.loads(lines[0]), [json.loads(line) for line in lines[1:]], good


class DesignRecords(list):
    """The evaluated designs of a ``design.jsonl`` (dicts), with :meth:`to_pandas`."""

    header: Optional[Dict[str, Any]] = None

    def to_pandas(self) -> Any:
        """A pandas DataFrame, one row per evaluated design (extra ``pandas``): nested keys
        flattened to ``variables.<name>``, ``params.<name>``, …; ``samples`` (the classified points of
        each sample) stays a column of lists."""
        from ..tables import records_frame

        return records_frame(list(self), "DesignRecords.to_pandas")


def read_designs(path: Union[str, Path]) -> DesignRecords:
    """The evaluated designs of a design run's results file (``design.jsonl`` or its folder), in
    file order, with ``.to_pandas()``; the header is the attribute ``header``."""
    header, records, _good = read_design_file(path)
    out = DesignRecords(records)
    out.header = header
    return out


class DesignWriter:
    """The results of a design run, in memory and (``path`` given) in the file: ``add(record)``
    appends one line at once, ``get(key)`` returns a finished evaluation. ``resume=False`` refuses
    an existing non-empty file; ``resume=True`` checks that it belongs to the same configuration."""

    def __init__(self, config: DesignConfig, path: Optional[Path], resume: bool) -> None:
        self.records: Dict[str, Dict[str, Any]] = {}
        self.order: List[str] = []
        self._path: Optional[Path] = None
        self._lock = None
        if path is None:
            return
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        self._lock = _core.ResultsLock(str(path))
        try:
            header = {"beamslider_design": FORMAT, "config": json_safe(config.to_dict())}
            law = Path(config.drift_law) if config.evaluator == "predictor" and config.drift_law else None
            if law is not None and law.is_file():
                # The law's content, not only its path: a refitted law.json must not extend a run.
                header["drift_law_sha256"] = hashlib.sha256(law.read_bytes()).hexdigest()
            text = json.dumps(header)
            if path.exists() and path.stat().st_size > 0:
                if not resume:
                    refuse_existing(path, None, "designs", "design run")
                old, records, good = read_design_file(path)
                if old is not None and json.dumps(old) != text:
                    if old.get("config") == header["config"] and old.get("drift_law_sha256") != header.get("drift_law_sha256"):
                        raise ValueError(f"{path} was run with another content of the drift law {config.drift_law} "
                                         f"(or before the law's hash was recorded): cannot resume it with this law")
                    raise ValueError(f"{path} holds a run of another configuration: cannot resume it with this one")
                _core.append_json_lines(path, [] if old is not None else [text], good)  # drops a torn last line
                for r in records:
                    self._remember(r)
            else:
                _core.append_json_lines(path, [text], 0)
            self._path = path
        except BaseException:
            self.close()
            raise

    def _write(self, line: str) -> None:
        assert self._path is not None
        _core.append_json_lines(self._path, [line])

    def _remember(self, r: Dict[str, Any]) -> None:
        if r["key"] not in self.records:
            self.order.append(r["key"])
        self.records[r["key"]] = r

    def __contains__(self, key: str) -> bool:
        return key in self.records

    def get(self, key: str) -> Optional[Dict[str, Any]]:
        return self.records.get(key)

    def add(self, record: Dict[str, Any]) -> Dict[str, Any]:
        """Append one evaluated design (returned as read back from its JSON text)."""
        text = json.dumps(json_safe(record))
        rec = json.loads(text)
        if self._path is not None:
            self._write(text)
        self._remember(rec)
        return rec

    def close(self) -> None:
        self._path = None
        if self._lock is not None:
            self._lock.release()
            self._lock = None


def pareto_front(records: List[Dict[str, Any]], *, objective: str = "bandwidth_hz") -> List[Dict[str, Any]]:
    """The feasible records not dominated in (``objective`` high, ``slider_mass_kg`` low), sorted by mass.
    Ties (equal mass and objective) keep the first record."""
    feas = [r for r in records if r.get("feasible")]
    front = []
    for r in feas:
        m, b = r["slider_mass_kg"], r[objective]
        dominated = any((o["slider_mass_kg"] <= m and o[objective] >= b)
                        and (o["slider_mass_kg"] < m or o[objective] > b) for o in feas)
        if not dominated and not any(o["slider_mass_kg"] == m and o[objective] == b for o in front):
            front.append(r)
    return sorted(front, key=lambda r: r["slider_mass_kg"])


@dataclass
class DesignResult:
    """What :func:`beamslider.design.optimise` found.

    ``records``: every evaluated design (dicts as in ``design.jsonl``: ``x``, ``variables``,
    ``params``, ``bandwidth_hz``, ``harvest``, ``score``, ``feasible``, ``samples`` with the
    per-line objectives and the classified points, …); ``search``: those of the optimiser's search;
    ``best``: the search's best record and ``best_params`` its :class:`Parameters`; ``prototype``:
    the search record of the base design (if evaluated); ``pareto``: the Pareto front of bandwidth
    vs slider mass over the search's feasible designs; ``checks``: FS re-checks by name
    (``prototype_nominal``, ``best_nominal``, ``recheck_<k>``, ``ref_<name>_nominal``, and with uncertain
    inputs ``<same name>_robust`` of each over the fixed sample); :meth:`confirmed_best`: the
    search's design that the FS re-checks rank first;
    ``jam``: the jam report; ``optimiser``: scipy's result summary (nit, nfev, message)."""

    config: DesignConfig
    records: List[Dict[str, Any]]
    search: List[Dict[str, Any]]
    best: Dict[str, Any]
    best_params: Parameters
    prototype: Optional[Dict[str, Any]]
    pareto: List[Dict[str, Any]]
    checks: Dict[str, Dict[str, Any]] = field(default_factory=dict)
    jam: Dict[str, Any] = field(default_factory=dict)
    optimiser: Dict[str, Any] = field(default_factory=dict)
    wall_time_s: float = 0.0
    evaluated_now: int = 0
    """Designs evaluated by this call (not read back from a resumed file)."""
    runs_now: int = 0
    """Single runs (FS or predicted points) done by this call."""

    def confirmed_best(self) -> Optional[Tuple[str, Dict[str, Any]]]:
        """The FS-confirmed best: among the search's re-checked designs (``best`` and ``recheck_<k>``,
        not the prototype or the reference designs), the one with the highest FS bandwidth (then score), robust when
        robust re-checks exist, else nominal; None without re-checks."""
        robust = any(k.endswith("_robust") for k in self.checks)
        cands = []
        for k, r in self.checks.items():
            base = k[:-len("_robust")] if k.endswith("_robust") else (k[:-len("_nominal")] if k.endswith("_nominal") else k)
            if robust != k.endswith("_robust") or not (base == "best" or base.startswith("recheck_")):
                continue
            cands.append((base, r))
        if not cands:
            return None
        return max(cands, key=lambda t: (t[1].get("bandwidth_hz", -math.inf), t[1].get("score", -math.inf), t[0] == "best"))

    def to_pandas(self) -> Any:
        """Every evaluated design as a pandas DataFrame (see :meth:`DesignRecords.to_pandas`)."""
        return DesignRecords(self.records).to_pandas()

    def summary(self) -> Dict[str, Any]:
        """Plain-data summary (``summary.json``)."""
        def brief(r: Optional[Dict[str, Any]]) -> Optional[Dict[str, Any]]:
            if r is None:
                return None
            return {k: r.get(k) for k in ("evaluator", "mode", "t_end_s", "variables", "slider_mass_kg", "gap_ratio",
                                          "bandwidth_hz", "harvest", "score", "bandwidth_mean_hz", "bandwidth_quantile_hz",
                                          "harvest_mean", "harvest_quantile", "feasible", "violation", "moved")} | {
                "lines": r["samples"][0]["lines"] if len(r.get("samples", [])) == 1 else None}
        return json_safe({
            "evaluations_search": len(self.search), "evaluated_now": self.evaluated_now, "runs_now": self.runs_now,
            "wall_time_s": self.wall_time_s, "optimiser": self.optimiser,
            "best": brief(self.best), "prototype": brief(self.prototype),
            "pareto": [brief(r) for r in self.pareto],
            "checks": {k: brief(v) for k, v in self.checks.items()}, "jam": self.jam,
            "confirmed_best": (lambda cb: None if cb is None else {"name": cb[0], **brief(cb[1])})(self.confirmed_best()),
        })

    def text(self) -> str:
        """A short human-readable report."""
        c = self.config
        lines = [f"design search: {len(self.search)} designs ({c.evaluator}, {c.maximise}"
                 f"{'' if c.robust == 'none' else ', robust ' + c.robust}), band {c.f_lo_hz:g}-{c.f_hi_hz:g} Hz "
                 f"step {c.f_step_hz:g}, a_ex {', '.join(f'{a:g}' for a in c.a_ex_m_s2)} m/s^2, s0 "
                 f"{', '.join(f'{s:g}' for s in c.s0)}, t_end {c.t_end_s:g} s"]

        def row(name: str, r: Optional[Dict[str, Any]]) -> None:
            if r is None:
                return
            per = ""
            if len(r.get("samples", [])) == 1:
                per = " (" + ", ".join(f"{l['a_ex_m_s2']:g} m/s^2: {l['bandwidth_hz']:.2f} Hz" for l in r["samples"][0]["lines"]) + ")"
            var = ", ".join(f"{k} = {v:.5g}" for k, v in r["variables"].items())
            lines.append(f"  {name:<18} [{r['evaluator']}, {r['mode']}, {r['t_end_s']:g} s] {var}: bandwidth "
                         f"{r['bandwidth_hz']:.2f} Hz{per}, harvest {r['harvest']:.3f}"
                         + ("" if r.get("feasible", True) else f" INFEASIBLE ({r['violation']})"))

        row("prototype", self.prototype)
        row("best", self.best)
        for k, v in self.checks.items():
            row(k, v)
        cb = self.confirmed_best()
        if cb is not None:
            row(f"FS-confirmed best ({cb[0]})", cb[1])
        lines.append(f"  Pareto front (bandwidth vs slider mass): " + "; ".join(
            f"m = {r['slider_mass_kg'] * 1e3:.1f} g: {r['bandwidth_hz']:.2f} Hz" for r in self.pareto))
        if self.jam:
            lines.append(f"  jam report: {self.jam.get('text', '')}")
        lines.append(f"  {self.evaluated_now} designs / {self.runs_now} runs evaluated now in {self.wall_time_s:.1f} s"
                     f" ({self.optimiser.get('message', '')})")
        return "\n".join(lines) + "\n"
