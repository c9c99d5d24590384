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
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Dict, Iterable, List, Optional, Sequence, Tuple, Union

import numpy as np

from ..params import Parameters
from .effects import EFFECTS

PathLike = Union[str, "os.PathLike[str]"]

PAPER_POINTS: Tuple[Tuple[float, float, float], ...] = ((104.0, 14.0, 0.3), (126.0, 10.0, 0.3), (124.0, 14.0, 0.3))
"""The paper's three reference runs (f_ex Hz, a_ex m/s², s0): the default plan's points."""

SLIDER_CANDIDATES: Tuple[str, ...] = tuple(n for n, e in EFFECTS.items() if e.level == "slider")
"""Every slider-level candidate, the measurement chain's included: the default plan's candidates."""

KINDS = ("nothing", "single", "pair", "outside", "chain+physics")
"""The kinds of hidden case (docs/model.md §9.2)."""

DEFAULT_COUNTS: Dict[str, int] = {"single": 12, "pair": 6, "outside": 6, "nothing": 4, "chain+physics": 2}
"""Cases of each kind in a default benchmark (30)."""

SIZE_RANGE = (1.5, 6.0)
"""A library effect's size, in units of its relevance threshold (:attr:`.effects.Effect.relevance`)."""

CLEARLY_BETTER = 11.0
"""χ² by which the truth must fit a case's data better than a wrong answer for the miss to be
discover's (the selection's price of one parameter among fourteen candidates, docs/model.md §9);
within it the data cannot tell the answer from the truth."""

S0_OFFSET_RANGE = (0.0005, 0.003)
"""|s0 offset| of a case's truth runs from the s0 their files name (either sign)."""


@dataclass(frozen=True)
class Outside:
    """A change the synthesiser makes and discover has no slider-level candidate for: the parameter
    ``field`` multiplied by a factor whose size lies in ``factor`` (either direction, ``both``), or,
    with ``absolute``, set to a value drawn in ``factor``."""

    name: str
    field: str
    description: str
    factor: Tuple[float, float]
    both: bool = True
    absolute: bool = False


OUTSIDE: Dict[str, Outside] = {o.name: o for o in (
    Outside("beam_damping", "damping_ratio", "modal damping ratio of the beam x 1.3-2 or / 1.3-2", (1.3, 2.0)),
    Outside("amplitude_damping", "damping_ratio_quadratic",
            "amplitude-dependent damping D2 in [3e-4, 1.2e-3] (the beam-level effect, not a slider candidate)",
            (3e-4, 1.2e-3), both=False, absolute=True),
    Outside("axial_stiffness", "k_t_n_per_m", "axial clamping stiffness x 1.5-3 or / 1.5-3 (the hardening b*)",
            (1.5, 3.0)),
    Outside("rotational_clamping", "k_r_nm_per_rad",
            "rotational clamping stiffness x 1.5-3 or / 1.5-3 (frequency and mode shape)", (1.5, 3.0)),
)}
"""The changes outside the library that a benchmark draws from (docs/model.md §9.2)."""


@dataclass(frozen=True)
class Plan:
    """What a lab would measure: free-slider runs at ``operating_points`` (f_ex Hz, a_ex m/s², s0)
    of ``duration_s``, judged against the ``candidates`` (names of :data:`.effects.EFFECTS`), with the
    synthesiser's noise on s and on the beam velocity."""

    operating_points: Tuple[Tuple[float, float, float], ...] = PAPER_POINTS
    duration_s: float = 60.0
    candidates: Tuple[str, ...] = SLIDER_CANDIDATES
    noise_s: float = 0.001
    noise_velocity_m_s: float = 0.002

    def __post_init__(self) -> None:
        pts = tuple(tuple(float(v) for v in p) for p in self.operating_points)
        if not pts or not all(len(p) == 3 and all(math.isfinite(v) for v in p) for p in pts):
            raise ValueError(f"invalid operating_points = {self.operating_points!r}: give (f_ex, a_ex, s0) triples")
        object.__setattr__(self, "operating_points", pts)
        if not (isinstance(self.duration_s, (int, float)) and math.isfinite(self.duration_s) and self.duration_s > 0):
            raise ValueError(f"invalid duration_s = {self.duration_s!r}: must be a finite number > 0")
        cands = tuple(self.candidates)
        bad = [c for c in cands if c not in EFFECTS or EFFECTS[c].level != "slider"]
        if bad or not cands:
            raise ValueError(f"invalid candidate {bad[0] if bad else None!r}: give slider-level effects of "
                             f"{', '.join(SLIDER_CANDIDATES)}")
        object.__setattr__(self, "candidates", cands)

    def to_dict(self) -> Dict[str, Any]:
        return dict(operating_points=[list(p) for p in self.operating_points], duration_s=self.duration_s,
                    candidates=list(self.candidates), noise_s=self.noise_s, noise_velocity_m_s=self.noise_velocity_m_s)


@dataclass(frozen=True)
class Case:
    """One hidden case: the library effects of the truth by name (in the units discover reports),
    the changes outside the library (parameter fields), the noise seed and the truth runs' s0
    offset."""

    index: int
    kind: str
    effects: Dict[str, float] = field(default_factory=dict)
    outside: Dict[str, float] = field(default_factory=dict)
    outside_kind: str = ""
    noise_seed: int = 0
    s0_offset: float = 0.0

    def label(self) -> str:
        parts = [f"{k} {v:.5g}" for k, v in self.effects.items()]
        parts += [f"{self.outside_kind}: {k} {v:.5g}" for k, v in self.outside.items()]
        return ", ".join(parts) or "nothing hidden"


# --- drawing ---------------------------------------------------------------------------------------


def threshold(name: str, base: Parameters) -> float:
    """The relevance threshold of effect ``name`` at ``base`` in the units of its value."""
    e = EFFECTS[name]
    if e.relevance_kind == "rel":
        return e.relevance * abs(e.baseline_value(base))
    if e.relevance_kind == "abs":
        return e.relevance
    raise ValueError(f"{name}: a compliance effect has no slider-level size")


def _search_range(name: str, base: Parameters) -> Tuple[float, float]:
    e = EFFECTS[name]
    lo, hi = e.search if all(math.isfinite(v) for v in e.search) else (e.lower, e.upper)
    a, b = e.value(lo, base), e.value(hi, base)
    return min(a, b), max(a, b)


def draw_size(name: str, rng: np.random.Generator, base: Parameters) -> float:
    """A value of effect ``name``: the baseline moved by U(1.5, 6) relevance thresholds, either sign
    (a sign whose value leaves the effect's search range is replaced by the other)."""
    e = EFFECTS[name]
    b = e.baseline_value(base)
    step = rng.uniform(*SIZE_RANGE) * threshold(name, base)
    sign = 1.0 if rng.random() < 0.5 else -1.0
    lo, hi = _search_range(name, base)
    for s in (sign, -sign):
        v = b + s * step
        if lo <= v <= hi and e.lower <= e.variable(v, base) <= e.upper:
            return float(v)
    raise ValueError(f"{name}: no value {step:.3g} from the baseline lies in its search range")


def _draw_outside(rng: np.random.Generator, base: Parameters) -> Tuple[str, Dict[str, float]]:
    o = OUTSIDE[list(OUTSIDE)[int(rng.integers(len(OUTSIDE)))]]
    x = rng.uniform(*o.factor)
    if o.absolute:
        return o.name, {o.field: float(x)}
    f = x if (not o.both or rng.random() < 0.5) else 1.0 / x
    return o.name, {o.field: float(getattr(base, o.field) * f)}


def draw_cases(seed: int, counts: Optional[Dict[str, int]] = None, *, plan: Optional[Plan] = None,
               baseline: Optional[Parameters] = None) -> List[Case]:
    """The cases of a benchmark: ``counts`` per kind (:data:`DEFAULT_COUNTS`) in an order shuffled
    by ``seed``; case i draws its truth, noise seed and start offset from (seed, i) alone, so the
    first cases of a larger benchmark are those of a smaller one with the same order."""
    plan = plan or Plan()
    base = baseline or Parameters()
    counts = dict(DEFAULT_COUNTS if counts is None else counts)
    bad = [k for k in counts if k not in KINDS]
    if bad:
        raise ValueError(f"unknown case kind {bad[0]!r}: known are {', '.join(KINDS)}")
    if any(not isinstance(n, int) or n < 0 for n in counts.values()):
        raise ValueError(f"invalid counts = {counts!r}: give integers >= 0")
    kinds = [k for k in KINDS for _ in range(counts.get(k, 0))]
    np.random.default_rng(seed).shuffle(kinds)
    physical = [c for c in plan.candidates if not EFFECTS[c].chain]
    chain = [c for c in plan.candidates if EFFECTS[c].chain]
    if any(k in ("single", "pair") for k in kinds) and len(plan.candidates) < (2 if "pair" in kinds else 1):
        raise ValueError("the plan has too few candidates for the cases asked")
    if "chain+physics" in kinds and not (physical and chain):
        raise ValueError("chain+physics cases need a physical and a measurement-chain candidate in the plan")
    cases = []
    for i, kind in enumerate(kinds):
        rng = np.random.default_rng([seed, i])
        effects: Dict[str, float] = {}
        outside: Dict[str, float] = {}
        okind = ""
        if kind == "single":
            names = [plan.candidates[int(rng.integers(len(plan.candidates)))]]
        elif kind == "pair":
            names = [plan.candidates[int(j)] for j in rng.choice(len(plan.candidates), 2, replace=False)]
        elif kind == "chain+physics":
            names = [chain[int(rng.integers(len(chain)))], physical[int(rng.integers(len(physical)))]]
        else:
            names = []
        for n in names:
            effects[n] = draw_size(n, rng, base)
        if kind == "outside":
            okind, outside = _draw_outside(rng, base)
        offset = rng.uniform(*S0_OFFSET_RANGE) * (1.0 if rng.random() < 0.5 else -1.0)
        cases.append(Case(i, kind, effects, outside, okind, int(rng.integers(2 ** 31)), float(offset)))
    return cases


# --- one case --------------------------------------------------------------------------------------


def truth_model(case: Case, baseline: Optional[Parameters] = None):
    """The truth of ``case`` as a :class:`.chain.Model`: the baseline with the outside changes, the
    library effects realised on it as discover realises its candidates."""
    from .chain import realise_model

    base = baseline or Parameters()
    p = Parameters(**{**base.to_dict(), **case.outside}) if case.outside else base
    return realise_model(p, dict(case.effects))


def synthesize_case(case: Case, plan: Plan, out_dir: PathLike, *, points=None, noise_seed: Optional[int] = None,
                    s0_offset: Optional[float] = None, baseline: Optional[Parameters] = None) -> List[Path]:
    """The measured files of ``case`` at the plan's points (or ``points``) in ``out_dir``."""
    from .synthesize import synthesize_slider_runs

    m = truth_model(case, baseline)
    return synthesize_slider_runs(m.params, operating_points=list(points or plan.operating_points),
                                  duration_s=plan.duration_s, out_dir=out_dir, noise_s=plan.noise_s,
                                  noise_velocity_m_s=plan.noise_velocity_m_s,
                                  seed=case.noise_seed if noise_seed is None else noise_seed,
                                  s0_offset=case.s0_offset if s0_offset is None else s0_offset,
                                  chain=dict(m.chain) or None)


def judge_fingerprint() -> str:
    """A digest of the code that judges a case: the discover package's sources but this module (a
    row made by another judge is judged again when a benchmark resumes, from its kept runs)."""
    import hashlib

    root = Path(__file__).resolve().parent
    h = hashlib.sha1()
    for f in sorted(root.rglob("*.py")):
        if f.name != "benchmark.py":
            h.update(str(f.relative_to(root)).encode())
            h.update(f.read_bytes())
    return h.hexdigest()[:16]


def truth_fit(case: Case, runs: Sequence[Any], cache: Any = None, baseline: Optional[Parameters] = None,
              threads: Optional[int] = None) -> Dict[str, float]:
    """How well the truth itself fits the case's data: its ensemble's χ², gap and largest |z| by the
    baseline's test (docs/model.md §9) — the fit a right answer could reach, against which a wrong
    answer is judged "the data prefer the truth" or "the data cannot tell"."""
    from . import models

    try:
        from .stats import baseline_test
    except ImportError:  # pragma: no cover - the layout before the package's seam
        from .fitting import baseline_test  # type: ignore[no-redef]
    meas, _, ops = models.measured_slider_features(runs)
    modes = models.data_modes(meas)
    ens = models.ensemble_slider_features([truth_model(case, baseline)], ops, modes=modes, cache=cache,
                                          threads=threads)[0]
    if ens is None:
        return dict(chi2=math.nan, gap=math.nan, z_worst=math.nan, n=len(meas))
    t = baseline_test(ens.mean, meas, {k: ens.spread.get(k, 0.0) for k in meas}, len(models.ENSEMBLE_S0_SHIFTS),
                      modes, ens.mode_counts)
    return dict(chi2=float(t.chi2), gap=float(t.gap), z_worst=float(t.z_worst), n=int(t.n))


def _answer(d: Any) -> Dict[str, Any]:
    """What a discover answered, as the benchmark keeps it."""
    named = {e: dict(value=float(d.parameters[e]["value"]), stderr=float(d.parameters[e]["stderr"]),
                     interval=[float(v) for v in d.parameters[e]["interval"]]) for e in d.named_effects}
    group = list(d.confounded.get("group", [])) if d.verdict == "confounded" else []
    best = list(d.unresolved.get("effects", [])) if d.unresolved else []
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
                chi2_before=float(d.chi2_before))


def score_case(case: Case, answer: Dict[str, Any]) -> Dict[str, Any]:
    """The score of one answer (docs/model.md §9.2): ``right``, the ``outcome`` in words, and per
    named truth whether its stated interval holds it (``covered``).

    Right: nothing hidden → "none"; library effects → "named", exactly the truth's effects, each
    truth inside its stated interval; outside the library → "unexplained" (a stand-in named is
    wrong, a confounded group of stand-ins is counted apart)."""
    v, named = answer["verdict"], answer["named"]
    covered = {e: bool(named[e]["interval"][0] <= x <= named[e]["interval"][1])
               for e, x in case.effects.items() if e in named}
    if case.kind == "nothing":
        right = v == "none"
        outcome = "right" if right else ("false alarm: " + ", ".join(named) if named else f"false alarm ({v})")
    elif case.kind == "outside":
        right = v == "unexplained"
        outcome = ("right" if right else "stand-in named: " + ", ".join(named) if v == "named" else
                   "confounded stand-ins: " + ", ".join(answer["group"]) if v == "confounded" else "not seen (none)")
    else:
        same = set(named) == set(case.effects)
        right = v == "named" and same and all(covered.values())
        if right:
            outcome = "right"
        elif v == "named" and same:
            outcome = "interval misses the truth: " + ", ".join(e for e, ok in covered.items() if not ok)
        elif v == "named":
            wrong = sorted(set(named) - set(case.effects))
            missed = sorted(set(case.effects) - set(named))
            outcome = "named " + ", ".join(named) + (f" (wrong: {', '.join(wrong)})" if wrong else "") + \
                      (f" (missed: {', '.join(missed)})" if missed else "")
        elif v == "confounded":
            outcome = "confounded: " + ", ".join(answer["group"])
        elif v == "unexplained":
            outcome = "unexplained" + (f" (best: {', '.join(answer['best'])})" if answer["best"] else "")
        else:
            outcome = "missed (none)"
    return dict(right=bool(right), outcome=outcome, covered=covered)


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
            rng = np.random.default_rng([case.noise_seed, 1])
            extra_dir = Path(tmp) / "advised"
            extra = synthesize_case(case, plan, extra_dir, points=[tuple(first["advice"])],
                                    noise_seed=case.noise_seed + 1,
                                    s0_offset=rng.uniform(*S0_OFFSET_RANGE) * (1.0 if rng.random() < 0.5 else -1.0),
                                    baseline=base)
            d2 = discover(measured=runs + [read_measurement(p) for p in extra], baseline=base,
                          effects=list(plan.candidates), progress=progress, runs_file=runs_file, threads=threads)
            second = _answer(d2)
            row["advised"] = dict(point=first["advice"], answer=second, score=score_case(case, second),
                                  truth_fit=truth_fit(case, runs + [read_measurement(p) for p in extra], runs_file,
                                                      base, threads))
    row["cpu_s"] = time.process_time() - c0
    row["wall_s"] = time.perf_counter() - t0
    return row


def final_score(row: Dict[str, Any]) -> Dict[str, Any]:
    """A row's score after at most one advised run (its first score where no run was advised)."""
    return row.get("advised", {}).get("score", row["score"])


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
        judge = judge_fingerprint()
        done = {i: r for i, r in _read_rows(out / CASES_FILE).items() if r.get("judge") == judge}  # others re-judged
        store = RunStore(out / "runs.jsonl")
    new: Dict[int, Dict[str, Any]] = {}

    def finished(row: Dict[str, Any]) -> None:
        if out is not None:
            _append_line(out / CASES_FILE, row)
        new[int(row["index"])] = row
        if on_case is not None:
            on_case(row)

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

    p = Plan(operating_points=tuple(tuple(x) for x in plan["operating_points"]), duration_s=plan["duration_s"],
             candidates=tuple(plan["candidates"]), noise_s=plan["noise_s"],
             noise_velocity_m_s=plan["noise_velocity_m_s"])
    store = RunStore(runs_path) if runs_path else None
    row = run_case(Case(**case), p, runs_file=store, advice=advice, threads=threads)
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


def _rate(k: int, n: int) -> Dict[str, Any]:
    """k of n with the binomial standard error."""
    p = k / n if n else math.nan
    return dict(right=k, of=n, rate=p, stderr=math.sqrt(p * (1 - p) / n) if n else math.nan)


def summarise(rows: Sequence[Dict[str, Any]]) -> Dict[str, Any]:
    """The benchmark's figures (docs/model.md §9.2): per kind the share right on the first answer
    and after at most one advised run (with binomial errors); coverage, the share of named truths
    inside their stated 95 % intervals; false alarms, effects named on nothing-hidden data;
    confounded groups of stand-ins for outside cases; CPU seconds per case; the confusion table
    (what was named for what)."""
    by_kind: Dict[str, Any] = {}
    for kind in KINDS:
        rs = [r for r in rows if r["kind"] == kind]
        if rs:
            by_kind[kind] = dict(first=_rate(sum(r["score"]["right"] for r in rs), len(rs)),
                                 after_advice=_rate(sum(final_score(r)["right"] for r in rs), len(rs)))
    cov = [ok for r in rows for ok in final_score(r)["covered"].values()]
    nothing = [r for r in rows if r["kind"] == "nothing"]
    false_alarms = sum(len(r["answer"]["named"]) for r in nothing)
    confusion: Dict[str, Dict[str, int]] = {}
    for r in rows:
        truth = r["outside_kind"] and f"outside: {r['outside_kind']}" or (" + ".join(sorted(r["truth"])) or "nothing")
        ans = r.get("advised", {}).get("answer", r["answer"])
        got = (" + ".join(sorted(ans["named"])) if ans["verdict"] == "named" else
               f"confounded: {' + '.join(sorted(ans['group']))}" if ans["verdict"] == "confounded" else ans["verdict"])
        confusion.setdefault(truth, {}).setdefault(got, 0)
        confusion[truth][got] += 1
    # A wrong final answer is discover's miss where the truth fits its data clearly better (by more
    # than the selection's price of a parameter, about 11 for fourteen candidates), else the data
    # cannot tell the answer from the truth (what the plan resolves: detectability).
    missed, cannot_tell = [], []
    for r in rows:
        s, tf = final_score(r), r.get("advised", {}).get("truth_fit", r.get("truth_fit"))
        a = r.get("advised", {}).get("answer", r["answer"])
        if s["right"] or not tf or not math.isfinite(tf.get("chi2", math.nan)):
            continue
        chi2_answer = a["chi2_after"] if a["verdict"] == "named" else a["gap_before"] ** 2 * a["n"]
        (missed if chi2_answer - tf["chi2"] > CLEARLY_BETTER else cannot_tell).append(int(r["index"]))
    cpu = [float(r["cpu_s"]) for r in rows]
    return dict(cases=len(rows), by_kind=by_kind,
                coverage=dict(inside=sum(cov), of=len(cov), rate=(sum(cov) / len(cov)) if cov else math.nan),
                false_alarms=dict(effects_named=false_alarms, cases=len(nothing),
                                  cases_with_alarm=sum(bool(r["answer"]["named"]) or r["answer"]["verdict"] != "none"
                                                       for r in nothing)),
                confounded_stand_ins=sum(r["kind"] == "outside" and r["answer"]["verdict"] == "confounded" for r in rows),
                advised_runs=sum("advised" in r for r in rows),
                wrong_where_the_truth_fits_better=missed, wrong_where_the_data_cannot_tell=cannot_tell,
                cpu_s=dict(median=float(np.median(cpu)) if cpu else math.nan, total=float(sum(cpu))),
                confusion=confusion)


def _pct(d: Dict[str, Any]) -> str:
    if not d["of"]:
        return "—"
    return f"{d['right']}/{d['of']} ({100 * d['rate']:.0f} % ± {100 * d['stderr']:.0f})"


def summary_markdown(summary: Dict[str, Any], rows: Sequence[Dict[str, Any]], *, seed: Any = None,
                     plan: Optional[Plan] = None) -> str:
    """The summary as Markdown: the figures, then one line a case."""
    lines = ["# Discover benchmark", ""]
    if plan is not None:
        pts = "; ".join(f"{f:g} Hz, {a:g} m/s², s0 {s:g}" for f, a, s in plan.operating_points)
        lines += [f"Seed {seed}; plan: {pts}, {plan.duration_s:g} s each; {len(plan.candidates)} candidates. "
                  "Rules and scores: docs/model.md §9.2.", ""]
    lines += ["| kind | right (first answer) | right (after at most one advised run) |", "|---|---|---|"]
    for kind, d in summary["by_kind"].items():
        lines.append(f"| {kind} | {_pct(d['first'])} | {_pct(d['after_advice'])} |")
    c = summary["coverage"]
    fa = summary["false_alarms"]
    lines += ["",
              f"- coverage of the stated 95 % intervals: {c['inside']}/{c['of']} named truths inside"
              + (f" ({100 * c['rate']:.0f} %)" if c["of"] else ""),
              f"- false alarms on nothing-hidden data: {fa['effects_named']} effects named in {fa['cases']} cases "
              f"({fa['cases_with_alarm']} cases not answered 'none')",
              f"- outside the library answered by a confounded group of stand-ins: {summary['confounded_stand_ins']}",
              f"- advised runs taken: {summary['advised_runs']}",
              f"- wrong final answers where the truth fits its data better by more than {CLEARLY_BETTER:g} in χ² "
              f"(discover's misses): cases {summary.get('wrong_where_the_truth_fits_better', [])}; where it does not "
              f"(the data cannot tell): cases {summary.get('wrong_where_the_data_cannot_tell', [])}",
              f"- CPU per case: median {summary['cpu_s']['median']:.0f} s, total {summary['cpu_s']['total']:.0f} s",
              "", "## Confusion (truth → final answer)", "", "| truth | answer | cases |", "|---|---|---|"]
    for truth, got in sorted(summary["confusion"].items()):
        for g, n in sorted(got.items()):
            lines.append(f"| {truth} | {g} | {n} |")
    lines += ["", "## Cases", "", "| # | kind | truth | first answer | after advice | CPU s |", "|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: r["index"]):
        adv = r.get("advised")
        lines.append(f"| {r['index']} | {r['kind']} | {r['label']} | {_answer_text(r['answer'])}: "
                     f"{'**right**' if r['score']['right'] else r['score']['outcome']} | "
                     + (f"{_answer_text(adv['answer'])}: {'**right**' if adv['score']['right'] else adv['score']['outcome']}"
                        if adv else "—") + f" | {r['cpu_s']:.0f} |")
    return "\n".join(lines) + "\n"


def _answer_text(a: Dict[str, Any]) -> str:
    if a["verdict"] == "named":
        return "named " + "; ".join(f"{e} {v['value']:.5g} [{v['interval'][0]:.5g}, {v['interval'][1]:.5g}]"
                                    for e, v in a["named"].items())
    if a["verdict"] == "confounded":
        return "confounded " + ", ".join(a["group"])
    return a["verdict"]


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
