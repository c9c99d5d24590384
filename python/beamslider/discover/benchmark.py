"""Discover judged at random: hidden cases drawn by a seed, their runs synthesised, discover run on
each and its answer scored by one rule (docs/model.md §9.2, "The benchmark").

A case is a truth the baseline model does not hold, of one of five kinds: nothing hidden; one effect
of discover's library (:data:`.effects.EFFECTS`, the plan's candidates), its size drawn between 1.5
and 6 times the effect's relevance threshold with either sign; two such effects; a change outside
the library (:data:`OUTSIDE`); a measurement-chain calibration with a physical effect. Each case
draws its own noise seed and slider start offset (the truth runs never start at the s0 their files
name). The runs are synthesised in the published measured format
(:func:`.synthesize.synthesize_slider_runs`) and judged by :func:`.discover`; the score of a case
(:func:`score_case`) and the figures of a benchmark (:func:`summarise`) are computed here and
nowhere else.

The same machinery answers "what would my plan name?" before anything is measured
(:func:`detectability`): given operating points, a duration and effects with sizes, it draws noise
and starts, runs the same synthesis and discover, and counts how often each effect is named.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence, Union

import numpy as np

from ..params import Parameters
from .cases import (DEFAULT_COUNTS, PathLike, KINDS, OUTSIDE, PAPER_POINTS, S0_OFFSET_RANGE, SIZE_RANGE, SLIDER_CANDIDATES, Case,
                    Outside, Plan, draw_cases, draw_size, synthesize_case, threshold, truth_model)
from . import lineage
from .effects import EFFECTS
from .options import DEFAULT
from .scores import CLEARLY_BETTER, each_change_shows, final_score, score_case, summarise, summary_markdown
from .report import verdict_line

__all__ = ["BenchmarkResult", "CASES_FILE", "CLEARLY_BETTER", "Case", "DEFAULT_COUNTS", "KINDS", "OUTSIDE", "Outside",
           "PAPER_POINTS", "Plan", "S0_OFFSET_RANGE", "SETTINGS_FILE", "SIZE_RANGE", "SLIDER_CANDIDATES", "case_task",
           "detectability", "draw_cases", "draw_size", "each_change_shows", "final_score", "judge_fingerprint", "run_benchmark", "run_case",
           "score_case", "summarise", "summary_markdown", "synthesize_case", "threshold", "truth_fit", "truth_model"]


def judge_fingerprint() -> str:
    """A digest of the code that judges a case: the discover package's sources but the benchmark's and
    :mod:`.lineage` (a row made by another judge, not one this judge takes over in
    :data:`.lineage.JUDGES`, is judged again when a benchmark resumes, from its kept runs)."""
    import hashlib

    root = Path(__file__).resolve().parent
    h = hashlib.sha1()
    for f in sorted(root.rglob("*.py")):
        if f.name not in ("benchmark.py", "cases.py", "scores.py", "lineage.py"):
            h.update(str(f.relative_to(root)).encode())
            h.update(f.read_bytes())
    return h.hexdigest()[:16]


def truth_fit(case: Case, runs: Sequence[Any], cache: Any = None, baseline: Optional[Parameters] = None,
              threads: Optional[int] = None) -> Dict[str, Any]:
    """How well the truth itself fits the case's data: its ensemble's χ², gap and largest |z| by the
    baseline's test (docs/model.md §9) — the fit a right answer could reach, against which a wrong
    answer is judged "the data prefer the truth" or "the data cannot tell". ``without``: per hidden
    change (an effect's name; ``outside`` for the changes outside the library), the χ² of the truth
    with that change left out — by how much the data show it on top of the others (docs/model.md
    §9.2, "Visible"). One batch of runs for all."""
    from . import models

    try:
        from .stats import baseline_test
    except ImportError:  # pragma: no cover - the layout before the package's seam
        from .fitting import baseline_test  # type: ignore[no-redef]
    meas, _, ops = models.measured_slider_features(runs)
    modes = models.data_modes(meas)
    left_out = _left_out(case)
    ens = models.ensemble_slider_features([truth_model(case, baseline)] + [truth_model(c, baseline) for _, c in left_out],
                                          ops, modes=modes, cache=cache, threads=threads)

    def test(e: Any) -> Any:
        return baseline_test(e.mean, meas, {k: e.spread.get(k, 0.0) for k in meas}, len(DEFAULT.ensemble_s0_shifts),
                             modes, e.mode_counts)

    without = {name: (float(test(e).chi2) if e is not None else math.nan) for (name, _), e in zip(left_out, ens[1:])}
    if ens[0] is None:
        return dict(chi2=math.nan, gap=math.nan, z_worst=math.nan, n=len(meas), without=without)
    t = test(ens[0])
    return dict(chi2=float(t.chi2), gap=float(t.gap), z_worst=float(t.z_worst), n=int(t.n), without=without)


def _left_out(case: Case) -> List[Any]:
    """The case with each of its hidden changes left out in turn: (name, case) pairs."""
    out: List[Any] = [(e, replace(case, effects={k: v for k, v in case.effects.items() if k != e}))
                      for e in case.effects]
    if case.outside:
        out.append(("outside", replace(case, outside={}, outside_kind="")))
    return out


def _answer(d: Any) -> Dict[str, Any]:
    """What a discover answered, as the benchmark keeps it."""
    named = {e: dict(value=float(d.parameters[e]["value"]), stderr=float(d.parameters[e]["stderr"]),
                     interval=[float(v) for v in d.parameters[e]["interval"]]) for e in d.named_effects}
    group = list(d.confounded.get("group", [])) if d.verdict == "confounded" else []
    v = getattr(d, "judgment", None)
    best = list(d.unresolved.get("effects", [])) if d.unresolved else []
    if not best and v is not None and v.best_rejected is not None and d.verdict == "unexplained":
        best = list(v.best_rejected.effects)
    if not best and d.verdict == "unexplained" and d.rejected:
        best = list(d.rejected[0].get("effects", []))
    advice = None
    for src in (d.confounded, d.unresolved):
        rec = (src or {}).get("advice", {}) or {}
        if rec.get("recommended"):
            r = rec["recommended"]
            advice = [float(r["f_ex"]), float(r["a_ex"]), float(r["s0"])]
            break
    n = len(d.features)
    return dict(verdict=str(getattr(d.verdict, "value", d.verdict)), named=named, group=group, best=best,
                advice=advice, n=n, chi2_after=float(d.gap_after) ** 2 * n,
                gap_before=float(d.gap_before), gap_after=float(d.gap_after),
                gap_excess_before=float(d.gap_excess_before), gap_excess_after=float(d.gap_excess_after),
                chi2_before=float(d.chi2_before), because=v.because.name if v is not None else "",
                line=verdict_line(d) if v is not None else "", fits=_top_fits(d, v))


def _top_fits(d: Any, v: Any, k: int = 6) -> List[Dict[str, Any]]:
    # The best fits of the search with their reasons, to read a wrong answer by (not scored).
    out = []
    for f in sorted(getattr(d, "candidates", []), key=lambda f: f.chi2)[:k]:
        why = [getattr(r, "kind", None) for r in (v.reasons.get(f.effects, []) if v is not None else [])]
        out.append(dict(effects=list(f.effects), values={e: float(x) for e, x in f.values.items()},
                        chi2=float(f.chi2), screened=bool(f.screened),
                        why=[w.name for w in why if w is not None]))
    return out


def run_case(case: Case, plan: Plan, *, runs_file: Any = None, advice: bool = True, progress: Any = False,
             baseline: Optional[Parameters] = None, threads: Optional[int] = None) -> Dict[str, Any]:
    """Synthesise ``case``'s runs, run discover on them, score the answer; where the answer is
    "confounded" or "unexplained" with an advised run and not already right, synthesise that run
    with the same truth (a new noise seed and start offset, as a lab's next run), add it, and score
    again (``advised``). Returns the case's row (:func:`run_benchmark`)."""
    from .. import discover as package
    from ..measurement import read_measurement

    discover = package.discover

    base = baseline or Parameters()
    t0, c0 = time.perf_counter(), time.process_time()
    with tempfile.TemporaryDirectory(prefix="beamslider-bench-") as tmp:
        paths = synthesize_case(case, plan, tmp, baseline=base)
        runs = [read_measurement(p) for p in paths]
        d = discover(measured=runs, baseline=base, effects=list(plan.candidates), progress=progress,
                     runs_file=runs_file, threads=threads)
        first = _answer(d)
        row: Dict[str, Any] = dict(index=case.index, kind=case.kind, truth=case.effects, outside=case.outside,
                                   outside_kind=case.outside_kind, label=case.label(), noise_seed=case.noise_seed,
                                   s0_offset=case.s0_offset, answer=first, score=score_case(case, first),
                                   truth_fit=truth_fit(case, runs, runs_file, base, threads),
                                   judge=judge_fingerprint())
        if advice and first["advice"] and not row["score"]["right"] and first["verdict"] in ("confounded", "unexplained"):
            extra = _advised_run(case, plan, first["advice"], tmp, base)
            d2 = discover(measured=runs + [read_measurement(p) for p in extra], baseline=base,
                          effects=list(plan.candidates), progress=progress, runs_file=runs_file, threads=threads)
            second = _answer(d2)
            row["advised"] = dict(point=first["advice"], answer=second, score=score_case(case, second),
                                  truth_fit=truth_fit(case, runs + [read_measurement(p) for p in extra], runs_file,
                                                      base, threads))
    row["cpu_s"] = time.process_time() - c0
    row["wall_s"] = time.perf_counter() - t0
    return row


def _advised_run(case: Case, plan: Plan, point: Sequence[float], tmp: Any, base: Parameters) -> List[Path]:
    """The advised run of ``case`` at ``point``, as a lab's next run: the same truth, a noise seed and
    a start offset of its own."""
    rng = np.random.default_rng([case.noise_seed, 1])
    return synthesize_case(case, plan, Path(tmp) / "advised", points=[tuple(point)], noise_seed=case.noise_seed + 1,
                           s0_offset=rng.uniform(*S0_OFFSET_RANGE) * (1.0 if rng.random() < 0.5 else -1.0),
                           baseline=base)


def _with_left_out(row: Dict[str, Any], case: Case, plan: Plan, *, runs_file: Any = None,
                   baseline: Optional[Parameters] = None, threads: Optional[int] = None) -> Dict[str, Any]:
    """A row judged before the truth's fit recorded its changes left out (``truth_fit["without"]``),
    completed from the case's runs synthesised again (deterministic: the same files); the answers are
    not touched."""
    from ..measurement import read_measurement

    base = baseline or Parameters()
    row = json.loads(json.dumps(row))
    with tempfile.TemporaryDirectory(prefix="beamslider-bench-") as tmp:
        runs = [read_measurement(p) for p in synthesize_case(case, plan, tmp, baseline=base)]
        row["truth_fit"] = truth_fit(case, runs, runs_file, base, threads)
        if "advised" in row:
            extra = [read_measurement(p) for p in _advised_run(case, plan, row["advised"]["point"], tmp, base)]
            row["advised"]["truth_fit"] = truth_fit(case, runs + extra, runs_file, base, threads)
    return row


# --- many cases --------------------------------------------------------------------------------------

CASES_FILE = "cases.jsonl"
SETTINGS_FILE = "benchmark.json"


@dataclass
class BenchmarkResult:
    """A benchmark's case rows (one dict each, :func:`run_case`) and its figures (:func:`summarise`)."""

    rows: List[Dict[str, Any]]
    summary: Dict[str, Any]
    out_dir: Optional[Path] = None


def _read_rows(path: Path) -> Dict[int, Dict[str, Any]]:
    rows: Dict[int, Dict[str, Any]] = {}
    if not path.exists():
        return rows
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            r = json.loads(line)
            rows[int(r["index"])] = r
        except (ValueError, KeyError, TypeError):
            continue  # a line cut short by a killed process
    return rows


def _append_line(path: Path, obj: Dict[str, Any]) -> None:
    data = (json.dumps(obj, separators=(",", ":"), allow_nan=True) + "\n").encode()
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        while data:
            data = data[os.write(fd, data):]
    finally:
        os.close(fd)


def run_benchmark(seed: int, *, counts: Optional[Dict[str, int]] = None, plan: Optional[Plan] = None,
                  out_dir: Optional[PathLike] = None, advice: bool = True, progress: Any = False,
                  cases: Optional[Sequence[Case]] = None, on_case: Optional[Callable[[Dict[str, Any]], None]] = None,
                  threads: Optional[int] = None, scheduler: Any = None,
                  scheduler_file: Optional[str] = None) -> BenchmarkResult:
    """Draw the cases of ``seed`` (:func:`draw_cases`; or take ``cases``), run and score each
    (:func:`run_case`) and summarise (:func:`summarise`). With ``out_dir``: the settings in
    ``benchmark.json``, each case's row appended to ``cases.jsonl`` as it finishes, the free-slider
    runs kept in ``runs.jsonl`` (shared by the cases: the scan grids and the baseline's runs do not
    depend on the data) and the summary in ``summary.json`` and ``summary.md``; run again on the same
    folder it makes only the cases not yet in ``cases.jsonl`` (other settings are refused).
    ``scheduler`` / ``scheduler_file``: the cases run as tasks of a Dask cluster (docs/cluster.md), one
    case a task, each keeping its runs in the same ``runs.jsonl`` (a folder the workers reach); the
    rows are those of the local run (the simulations are deterministic) but for their times."""
    from .runstore import RunStore

    plan = plan or Plan()
    case_list = list(cases) if cases is not None else draw_cases(seed, counts, plan=plan)
    settings = dict(seed=seed, counts=(counts or DEFAULT_COUNTS) if cases is None else None, plan=plan.to_dict(),
                    advice=advice, cases=[_case_dict(c) for c in case_list])
    done: Dict[int, Dict[str, Any]] = {}
    store = None
    out = Path(out_dir) if out_dir is not None else None
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        sfile = out / SETTINGS_FILE
        if sfile.exists():
            old = json.loads(sfile.read_text(encoding="utf-8"))
            if old != json.loads(json.dumps(settings)):
                raise ValueError(f"{out} holds a benchmark of other settings ({SETTINGS_FILE}): give another folder")
        else:
            from .._util import write_text_atomic

            write_text_atomic(sfile, json.dumps(settings, indent=1))
        judges = lineage.accepted(judge_fingerprint(), lineage.JUDGES)
        done = {i: r for i, r in _read_rows(out / CASES_FILE).items() if r.get("judge") in judges}  # others re-judged
        store = RunStore(out / "runs.jsonl")
    new: Dict[int, Dict[str, Any]] = {}

    def finished(row: Dict[str, Any]) -> None:
        if out is not None:
            _append_line(out / CASES_FILE, row)
        new[int(row["index"])] = row
        if on_case is not None:
            on_case(row)

    for c in case_list:  # rows judged before the truth's fit recorded its changes left out
        if c.index in done and "without" not in done[c.index].get("truth_fit", {"without": None}):
            done[c.index] = _with_left_out(done[c.index], c, plan, runs_file=store, threads=threads)
            if out is not None:
                _append_line(out / CASES_FILE, done[c.index])
    todo = [c for c in case_list if c.index not in done]
    if todo and (scheduler is not None or scheduler_file is not None):
        _run_on_cluster(todo, plan, scheduler, scheduler_file, seed=seed, advice=advice, threads=threads,
                        runs_path=None if store is None else str(store.path.resolve()), finished=finished)
    else:
        for case in todo:
            finished(run_case(case, plan, runs_file=store, advice=advice, progress=progress, threads=threads))
    rows = [done.get(c.index) or new[c.index] for c in case_list]
    summary = summarise(rows)
    if out is not None:
        from .._util import write_text_atomic

        write_text_atomic(out / "summary.json", json.dumps(summary, indent=1, allow_nan=True))
        write_text_atomic(out / "summary.md", summary_markdown(summary, rows, seed=seed, plan=plan))
    return BenchmarkResult(rows, summary, out)


def _case_dict(c: Case) -> Dict[str, Any]:
    return asdict(c)


def case_task(case: Dict[str, Any], plan: Dict[str, Any], runs_path: Optional[str], advice: bool,
              threads: Optional[int]) -> List[str]:
    """A Dask task: one case (as :func:`_case_dict`) of a plan (as :meth:`Plan.to_dict`) run and
    scored (:func:`run_case`), its row as JSON text."""
    from .runstore import RunStore

    store = RunStore(runs_path) if runs_path else None
    row = run_case(Case(**case), Plan.from_dict(plan), runs_file=store, advice=advice, threads=threads)
    return [json.dumps(row, separators=(",", ":"), allow_nan=True)]


def _run_on_cluster(cases: Sequence[Case], plan: Plan, scheduler: Any, scheduler_file: Optional[str], *, seed: int,
                    advice: bool, threads: Optional[int], runs_path: Optional[str],
                    finished: Callable[[Dict[str, Any]], None]) -> None:
    from .. import _dask

    client, own = _dask.connect(scheduler, scheduler_file)
    try:
        _dask.run_chunks(client, case_task, [(_case_dict(c), plan.to_dict(), runs_path, advice, threads) for c in cases],
                         tag=f"discover-benchmark-{seed}", on_rows=lambda rows: [finished(json.loads(r)) for r in rows],
                         resume_hint="run the benchmark again with the same --out to go on from the cases kept")
    finally:
        if own:
            _dask.close_client(client)


# --- detectability ---------------------------------------------------------------------------------


def detectability(effects: Dict[str, Union[float, Sequence[float]]], *, plan: Optional[Plan] = None,
                  repeats: int = 4, seed: int = 0, out_dir: Optional[PathLike] = None, advice: bool = False,
                  progress: Any = False) -> Dict[str, Any]:
    """Before anything is measured: for each effect and size of ``effects`` (name → value or values,
    in the units discover reports), ``repeats`` cases with their own noise and start offsets are
    synthesised at the ``plan`` and judged exactly as the benchmark judges them; returns per effect
    and value how often it is named right (named alone, its truth inside its interval) and the
    answers. ``out_dir`` keeps the rows and runs (resumable, as :func:`run_benchmark`)."""
    plan = plan or Plan()
    if not (isinstance(repeats, int) and repeats >= 1):
        raise ValueError(f"invalid repeats = {repeats!r}: must be an integer >= 1")
    cases: List[Case] = []
    for name, values in effects.items():
        if name not in EFFECTS or EFFECTS[name].level != "slider":
            raise ValueError(f"unknown slider-level effect {name!r}: known are {', '.join(SLIDER_CANDIDATES)}")
        for v in ([values] if isinstance(values, (int, float)) else list(values)):
            for _ in range(repeats):
                rng = np.random.default_rng([seed, len(cases)])
                offset = rng.uniform(*S0_OFFSET_RANGE) * (1.0 if rng.random() < 0.5 else -1.0)
                cases.append(Case(len(cases), "single", {name: float(v)}, {}, "", int(rng.integers(2 ** 31)),
                                  float(offset)))
    res = run_benchmark(seed, plan=plan, out_dir=out_dir, advice=advice, progress=progress, cases=cases)
    table: Dict[str, Dict[str, Any]] = {}
    for r in res.rows:
        (name, v), = r["truth"].items()
        t = table.setdefault(name, {}).setdefault(f"{v:.6g}", dict(value=v, right=0, of=0, answers=[]))
        s = final_score(r)
        t["right"] += int(s["right"])
        t["of"] += 1
        t["answers"].append(s["outcome"])
    return dict(plan=plan.to_dict(), repeats=repeats, seed=seed, effects=table)
