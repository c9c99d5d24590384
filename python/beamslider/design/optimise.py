"""The design search: ``scipy.optimize.differential_evolution`` (vectorised: one call per
generation) whose whole population is evaluated as ONE batch — every run of every design of the
generation (operating points × uncertain samples) through the core's batch runner
(``_core.run_study_chunk``: rayon, interpreter released) or, with ``scheduler=``, as chunks on a
Dask cluster (the project's runner :mod:`beamslider._dask`). A design's line is written to
``design.jsonl`` as soon as its last run is done; a resumed search (same configuration and seed)
replays the same generations and takes the finished designs from the file, so no design is
evaluated twice and the result equals that of an uninterrupted run.

After the search: FS re-checks of the prototype and the best design (nominal at ``check_t_end_s``,
and robust over the uncertain sample when ``[uncertain]`` is given), with the predictor
additionally the ``recheck`` best distinct designs; the Pareto front of bandwidth vs slider mass;
the jam report.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _core
from .._overwrite import clear_results
from ..params import Parameters, native
from ..study.sampling import apply_sample
from .config import RESULTS_FILE, DesignConfig, read_config
from .objectives import robust_value, sample_objectives, slider_moved
from .results import DesignResult, DesignWriter, design_key, pareto_front

INFEASIBLE_ENERGY = 1.0e3
"""Energy (minimised: −score) given to a design that breaks a constraint; it is not run."""

_POINT_KEYS = ("f_ex_hz", "a_ex_m_s2", "s0", "behaviour", "amplitude_final_h", "s_final", "s_min", "s_max", "status",
               "t_end_s")


class _Search:
    """Evaluates batches of designs and keeps the results file."""

    def __init__(self, config: DesignConfig, writer: DesignWriter, *, client: Any, threads: Optional[int],
                 progress: Optional[bool], task_threads: int) -> None:
        self.c = config
        self.w = writer
        self.client = client
        self.threads = threads
        self.progress = progress
        self.task_threads = task_threads
        self.evaluated_now = 0
        self.runs_now = 0
        self.search_keys: List[str] = []
        self.generation = 0
        self._law = None

    # --- records ---------------------------------------------------------------------------
    def _aggregate(self, mode: str, per_sample: List[Dict[str, Any]]) -> Dict[str, Any]:
        c = self.c
        bw = [s["bandwidth_hz"] for s in per_sample]
        hv = [s["harvest"] for s in per_sample]
        how = "none" if mode == "nominal" else (c.robust if c.robust != "none" else "mean")
        out = {"bandwidth_hz": robust_value(bw, how, c.quantile), "harvest": robust_value(hv, how, c.quantile),
               "robust": how}
        if mode == "robust":
            out.update(bandwidth_mean_hz=float(np.mean(bw)), harvest_mean=float(np.mean(hv)),
                       bandwidth_quantile_hz=float(np.quantile(bw, c.quantile)),
                       harvest_quantile=float(np.quantile(hv, c.quantile)), quantile=c.quantile)
        return out

    def score(self, rec: Dict[str, Any]) -> float:
        """The maximised value of a record (bandwidth + weight · harvest, or harvest)."""
        if not rec["feasible"]:
            return -INFEASIBLE_ENERGY
        if rec.get("extrapolated"):  # outside what the predictor's law covers: unknown, not good
            return -0.5 * INFEASIBLE_ENERGY
        if self.c.maximise == "harvest":
            return float(rec["harvest"])
        return float(rec["bandwidth_hz"] + self.c.harvest_weight_hz * rec["harvest"])

    def _record(self, x: np.ndarray, params: Parameters, evaluator: str, mode: str, t_end: float,
                samples: List[Dict[str, float]], points: Optional[List[List[Dict[str, Any]]]], violation: str,
                wall: float) -> Dict[str, Any]:
        rec: Dict[str, Any] = {
            "key": design_key(evaluator, mode, t_end, x), "evaluator": evaluator, "mode": mode, "t_end_s": t_end,
            "x": [float(v) for v in x], "variables": {n: float(v) for n, v in zip(self.c.names, x)},
            "params": params.to_dict(), "slider_mass_kg": params.slider_mass_kg, "gap_ratio": params.gap_ratio,
            "feasible": not violation, "violation": violation, "wall_time_s": wall,
        }
        if violation:
            rec.update(bandwidth_hz=0.0, harvest=0.0, samples=[], moved=None, runs=0)
        else:
            per = []
            for values, pts in zip(samples, points or []):
                o = sample_objectives(pts, a_min_h=self.c.a_min_h)
                per.append({"values": values, **o, "points": pts})
            rec.update(self._aggregate(mode, per))
            rec["samples"] = per
            rec["moved"] = any(slider_moved(p) for p in (points or []))
            rec["extrapolated"] = any(bool(q.get("extrapolated")) for p in (points or []) for q in p)
            rec["runs"] = sum(len(p) for p in (points or []))
        rec["score"] = self.score(rec)
        return rec

    # --- evaluation ------------------------------------------------------------------------
    def evaluate(self, xs: Sequence[np.ndarray], *, evaluator: str, mode: str, t_end: float,
                 samples: List[Dict[str, float]], desc: str) -> List[Dict[str, Any]]:
        """Records of the designs ``xs`` (finished ones from the file, the rest run as one batch)."""
        xs = [np.asarray(x, dtype=float).ravel() for x in xs]
        keys = [design_key(evaluator, mode, t_end, x) for x in xs]
        out: Dict[str, Dict[str, Any]] = {}
        todo: List[Tuple[str, np.ndarray, Parameters, List[Parameters]]] = []
        for k, x in zip(keys, xs):
            if k in self.w or k in out or any(k == t[0] for t in todo):
                continue
            try:
                p = self.c.design_params(x)
                viol = self.c.violation(p)
            except ValueError as e:  # a combination of in-bound values the model rejects (e.g. B >= L)
                p, viol = self.c.params, f"invalid parameters: {e}"
            if viol:
                out[k] = self.w.add(self._record(x, p, evaluator, mode, t_end, samples, None, viol, 0.0))
                self.evaluated_now += 1
                continue
            todo.append((k, x, p, [apply_sample(p, v) if v else p for v in samples]))
        if todo:
            if evaluator == "fs":
                self._run_fs(todo, mode, t_end, samples, desc, out)
            else:
                self._run_predictor(todo, mode, t_end, samples, desc, out)
        return [out.get(k) or self.w.get(k) for k in keys]  # type: ignore[misc]

    def _run_fs(self, todo: List[Tuple[str, np.ndarray, Parameters, List[Parameters]]], mode: str, t_end: float,
                samples: List[Dict[str, float]], desc: str, out: Dict[str, Dict[str, Any]]) -> None:
        from .._util import progress_bar

        ops = self.c.operating_points()
        map_cfg = self.c.map_config()  # record_every, dt, criteria (each run brings its own duration)
        chunk: List[Tuple[int, Any, float, float, float, float]] = []
        where: Dict[int, Tuple[int, int, int]] = {}
        idx = 0
        for d, (_k, _x, _p, plist) in enumerate(todo):
            for s, ps in enumerate(plist):
                core = native(ps)  # the core's validated object: each design sample validated once
                for j, (f, a, s0) in enumerate(ops):
                    chunk.append((idx, core, f, a, s0, float(t_end)))
                    where[idx] = (d, s, j)
                    idx += 1
        got: List[List[List[Optional[Dict[str, Any]]]]] = [[[None] * len(ops) for _ in samples] for _ in todo]
        missing = [len(samples) * len(ops) for _ in todo]
        start = [time.perf_counter()] * len(todo)
        done = [0]

        with progress_bar(self.progress, len(chunk), desc, "pts") as bar:
            def on_rows(rows: List[str]) -> None:
                for text in rows:
                    r = json.loads(text)
                    d, s, j = where[int(r["index"])]
                    if got[d][s][j] is not None:
                        continue
                    got[d][s][j] = {k: r.get(k) for k in _POINT_KEYS}
                    missing[d] -= 1
                    done[0] += 1
                    self.runs_now += 1
                    if missing[d] == 0:
                        k, x, p, _pl = todo[d]
                        out[k] = self.w.add(self._record(x, p, "fs", mode, t_end, samples, got[d], "",
                                                         time.perf_counter() - start[d]))
                        self.evaluated_now += 1
                if bar is not None:
                    bar(done[0], len(chunk))

            if self.client is None:
                _core.run_study_chunk(map_cfg, chunk, threads=self.threads, on_rows=on_rows)
            else:
                from .._dask import run_chunks, run_study_chunk

                size = self.c.chunk_size
                chunks = [(map_cfg, chunk[i:i + size], self.task_threads) for i in range(0, len(chunk), size)]
                run_chunks(self.client, run_study_chunk, chunks, tag="design" + map_cfg.toml() + json.dumps([t[0] for t in todo]),
                           on_rows=on_rows)
        if any(m != 0 for m in missing):  # pragma: no cover - the runner returns every row or raises
            raise RuntimeError("design batch: runs missing")

    def _run_predictor(self, todo: List[Tuple[str, np.ndarray, Parameters, List[Parameters]]], mode: str, t_end: float,
                       samples: List[Dict[str, float]], desc: str, out: Dict[str, Dict[str, Any]]) -> None:
        from .._util import progress_bar
        from ..superslow import predicted_map
        from ..superslow import default_law, load_law

        if self._law is None:
            self._law = default_law() if self.c.drift_law == "default" else load_law(self.c.drift_law)
        total = len(todo) * len(samples) * len(self.c.operating_points())
        done = 0
        with progress_bar(self.progress, total, desc, "pts") as bar:
            for k, x, p, plist in todo:
                t0 = time.perf_counter()
                pts_all = []
                for ps in plist:
                    pts = []
                    for s0 in self.c.s0:
                        rows = predicted_map(ps, drift=self._law, f_ex=self.c.f_ex_hz(), a_ex=self.c.a_ex_m_s2, s0=s0,
                                             t_end=t_end)
                        pts += [{**{key: r.get(key) for key in _POINT_KEYS}, "extrapolated": bool(r.get("extrapolated"))}
                                for r in rows]
                    pts_all.append(pts)
                    done += len(pts)
                    self.runs_now += len(pts)
                    if bar is not None:
                        bar(done, total)
                out[k] = self.w.add(self._record(x, p, "predictor", mode, t_end, samples, pts_all, "",
                                                 time.perf_counter() - t0))
                self.evaluated_now += 1

    # --- the optimiser's objective -----------------------------------------------------------
    def energies(self, pop: np.ndarray) -> np.ndarray:
        """scipy's vectorised objective: ``pop`` has shape (N variables, S designs); returns −score."""
        pop = np.atleast_2d(pop)
        xs = [np.clip(pop[:, i], [v.low for v in self.c.variables], [v.high for v in self.c.variables])
              for i in range(pop.shape[1])]
        mode = "nominal" if self.c.robust == "none" else "robust"
        recs = self.evaluate(xs, evaluator=self.c.evaluator, mode=mode, t_end=self.c.t_end_s,
                             samples=self.c.samples_values(), desc=f"generation {self.generation}")
        self.generation += 1
        for r in recs:
            if r["key"] not in self.search_keys:
                self.search_keys.append(r["key"])
        return np.array([-r["score"] for r in recs], dtype=float)


def _best(records: List[Dict[str, Any]]) -> Dict[str, Any]:
    """Highest score; ties go to the earlier record (deterministic)."""
    best = records[0]
    for r in records[1:]:
        if r["score"] > best["score"]:
            best = r
    return best


def _jam_report(records: List[Dict[str, Any]]) -> Dict[str, Any]:
    runs = [r for r in records if r.get("feasible") and r.get("moved") is not None]
    jammed = sorted({r["gap_ratio"] for r in runs if not r["moved"]})
    moving = sorted({r["gap_ratio"] for r in runs if r["moved"]})
    if not runs:
        return {"text": "no runs"}
    if jammed:
        text = (f"the slider never moved (s_max - s_min < 0.02 L at every run) for R/h in {{{', '.join(f'{g:.4g}' for g in jammed)}}}; "
                f"largest jammed R/h = {max(jammed):.4g}; smallest moving R/h = {min(moving):.4g}" if moving else
                f"the slider never moved in any evaluated design (R/h {min(jammed):.4g}..{max(jammed):.4g})")
    else:
        text = f"the slider moved in every evaluated design (R/h down to {min(moving):.4g}): no jam seen within the bounds"
    return {"jammed_gap_ratios": jammed, "largest_jammed_gap_ratio": max(jammed) if jammed else None,
            "smallest_moving_gap_ratio": min(moving) if moving else None, "text": text}


def recheck_choice(search: Sequence[Dict[str, Any]], c: DesignConfig) -> List[str]:
    """Keys of the designs to re-check with FS: the ``c.recheck`` best feasible designs by score, or,
    with ``c.recheck_tolerance_hz`` > 0, the best one and then, in turn, the design farthest from
    those chosen (Euclidean distance in the unit box of the bounds; the better score breaks ties)
    among the designs that score within the tolerance of the best (farthest-point sampling of the
    set the predictor does not tell apart, docs/validation/design_law.md)."""
    ranked: List[Dict[str, Any]] = []
    keys = set()
    for r in sorted((r for r in search if r["feasible"]), key=lambda r: -r["score"]):
        if r["key"] not in keys:
            keys.add(r["key"])
            ranked.append(r)
    if c.recheck_tolerance_hz <= 0 or not ranked:
        return [r["key"] for r in ranked[:c.recheck]]
    near = [r for r in ranked if r["score"] >= ranked[0]["score"] - c.recheck_tolerance_hz]
    lo = np.array([v.low for v in c.variables])
    span = np.array([v.high - v.low for v in c.variables])
    u = (np.array([r["x"] for r in near], dtype=float) - lo) / np.where(span > 0, span, 1.0)
    chosen = [0]
    gap = np.linalg.norm(u - u[0], axis=1)
    while len(chosen) < min(c.recheck, len(near)):
        k = int(np.argmax(gap))  # first of the largest: the better score among equals
        chosen.append(k)
        gap = np.minimum(gap, np.linalg.norm(u - u[k], axis=1))
    return [near[k]["key"] for k in chosen]


def optimise(config: Union[DesignConfig, str, Path], *, out: Optional[Union[str, Path]] = None, resume: bool = False,
             force: bool = False,
             scheduler: Any = None, scheduler_file: Optional[str] = None, threads: Optional[int] = None,
             task_threads: int = 1, progress: Optional[bool] = False, check_t_end_s: Optional[float] = None,
             robust_check_t_end_s: Optional[float] = None, checks: bool = True) -> DesignResult:
    """Optimise the slider design of ``config`` (a :class:`DesignConfig` or the path of its TOML).

    ``out``: folder of the results file ``design.jsonl`` (one line per evaluated design, written at
    once) and ``design.toml``; ``resume=True`` continues a killed run there (no design evaluated
    twice, same result as an uninterrupted run), ``force=True`` replaces an earlier run there
    (otherwise refused). ``scheduler`` / ``scheduler_file``: the FS runs on
    a Dask cluster (chunks of ``chunk_size`` runs, ``task_threads`` rayon threads each); default
    local on ``threads`` threads (one per core). ``check_t_end_s``: duration of the FS re-checks
    (default: the search's ``t_end_s``), ``robust_check_t_end_s`` that of the robust re-checks
    (default ``check_t_end_s``); ``checks=False`` skips them. Ctrl-C stops the run keeping
    the finished designs (``KeyboardInterrupt``)."""
    from scipy.optimize import differential_evolution

    if not isinstance(config, DesignConfig):
        config = read_config(config)
    if force and resume:
        raise ValueError("invalid parameter `force`: replaces the run in `out`; it does not go with resume")
    c = config
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, (int, np.integer))
                                or not 1 <= threads <= 65536):
        raise ValueError(f"invalid parameter `threads` = {threads!r}: must be an integer in 1..=65536")
    t_check = c.t_end_s if check_t_end_s is None else float(check_t_end_s)
    t_robust = t_check if robust_check_t_end_s is None else float(robust_check_t_end_s)
    for name, v in (("check_t_end_s", t_check), ("robust_check_t_end_s", t_robust)):
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"invalid parameter `{name}` = {v!r}: must be a positive number of seconds")
    client, own = None, False
    if scheduler is not None or scheduler_file is not None:
        from .._dask import connect

        client, own = connect(scheduler, scheduler_file)  # before any file is written
    t0 = time.perf_counter()
    writer = None
    try:
        path = None
        if out is not None:
            path = Path(out) / RESULTS_FILE
            if force:
                clear_results(Path(out), RESULTS_FILE, ["design.toml"])
        writer = DesignWriter(c, path, resume)
        if out is not None:
            (Path(out) / "design.toml").write_text(c.to_toml_text(), encoding="utf-8")
        s = _Search(c, writer, client=client, threads=threads, progress=progress, task_threads=task_threads)
        kw: Dict[str, Any] = dict(bounds=c.bounds, popsize=c.popsize, maxiter=c.maxiter, init=c.init,
                                  mutation=c.mutation if len(c.mutation) == 2 else c.mutation[0],
                                  recombination=c.recombination, polish=False, tol=0.0, atol=0.0,
                                  vectorized=True, updating="deferred")
        if c.include_prototype:
            kw["x0"] = c.prototype_x()
        try:
            res = differential_evolution(s.energies, rng=c.seed, **kw)
        except TypeError:  # scipy < 1.15: `seed`
            res = differential_evolution(s.energies, seed=c.seed, **kw)
        search = [writer.get(k) for k in s.search_keys]
        best = _best(search)
        mode = "nominal" if c.robust == "none" else "robust"
        proto = None
        if c.include_prototype:
            proto = writer.get(design_key(c.evaluator, mode, c.t_end_s, c.prototype_x()))
        result_checks: Dict[str, Dict[str, Any]] = {}
        if checks:
            px = c.prototype_x()
            inside = all(v.low <= x <= v.high for v, x in zip(c.variables, px))
            named = ([("prototype", px)] if inside else []) + [("best", np.array(best["x"]))]
            if c.evaluator == "predictor" and c.recheck > 0:
                seen = recheck_choice(search, c)
                named += [(f"recheck_{i}", np.array(writer.get(k)["x"])) for i, k in enumerate(seen)]
            named += [(f"ref_{n}", c.reference_x(v)) for n, v in c.reference.items()]
            recs = s.evaluate([x for _, x in named], evaluator="fs", mode="nominal", t_end=t_check, samples=[{}],
                              desc="FS check (nominal)")
            for (name, _x), r in zip(named, recs):
                result_checks[f"{name}_nominal" if not name.startswith("recheck") else name] = r
            rs = c.robust_samples_values()
            if rs:  # every checked design over the same fixed sample
                recs = s.evaluate([x for _, x in named], evaluator="fs", mode="robust", t_end=t_robust, samples=rs,
                                  desc="FS check (robust)")
                for (name, _x), r in zip(named, recs):
                    result_checks[f"{name}_robust"] = r
        records = [writer.records[k] for k in writer.order]
        obj = "bandwidth_hz" if c.maximise == "bandwidth" else "harvest"
        return DesignResult(
            config=c, records=records, search=search, best=best, best_params=Parameters.from_dict(best["params"]),
            prototype=proto, pareto=pareto_front(search, objective=obj), checks=result_checks,
            jam=_jam_report([r for r in records if r["evaluator"] == "fs"] or records),
            optimiser={"nit": int(res.nit), "nfev": int(res.nfev), "message": str(res.message),
                       "population": int(len(getattr(res, "population", [])) or max(5, c.popsize * len(c.variables))),
                       "seed": c.seed},
            wall_time_s=time.perf_counter() - t0, evaluated_now=s.evaluated_now, runs_now=s.runs_now)
    finally:
        if writer is not None:
            writer.close()
        if own:
            from .._dask import close_client

            close_client(client)
