"""Benchmark of one `beamslider discover` with all candidates on the sample measured data or on a
case of the hidden-effect table: the wall time and the CPU time of all threads (median of a few
repeats, each a fresh subprocess) and the verdict.

    python scripts/bench/bench_discover.py [--repeat 3] [--measured examples/data/*.txt.gz]
                                           [--effects LIST] [--max-effects 2]
                                           [--case restitution [--duration 60] [--s0-offset 0.0015]]
                                           [--runs FILE]

``--case``: the data of that case of `scripts/repro/discover_table.py` (its truth, three runs at the
reference points, seed 3, the truth runs ``--s0-offset`` off s0), synthesised once before the
repeats, and the case's candidates (all slider-level ones, or all but the hidden one).
``--runs FILE``: each repeat starts from a copy of the kept runs of an earlier discover (its
``runs.jsonl``; docs/model.md §9.1, "Kept runs"), e.g. of another case at the same operating points:
the wall time of a discover warm on those runs. Without it every run is made.
``--quick``: each discover stops at its provisional answer (``discover --quick``): the time to the
leading candidate of the tiered search's first tier.
``--stages [--search S]``: one discover in this process instead (``--search``: discover's search),
every batch of the core's runner attributed to the stage that asked for it (the baseline's
ensemble, the single candidates' coarse scans or linearised prediction and full fits, the linearised
model, the sets' coordinate passes and joint refinements, the confounding check of a named set, the
full simulation of the named set, the advice) with its runs, wall and CPU time: where a discover's
time goes.

Each repeat runs `python -m beamslider discover --measured FILES --out TMP --force` (all
candidates: the slider level's physical effects, the contact spacing and the measurement chain;
no `--effects` given) in a subprocess and measures its wall time and the CPU time of the child
(user + system of all its threads, `os.wait4`). The load average is printed before and after: the
machine may be shared, and the wall time on an idle 2-core machine is then about CPU / 2. The
verdict is the first line of the report (`report.md`) and `verdict` of `report.json`.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def load() -> str:
    return "load average " + " ".join(f"{x:.2f}" for x in os.getloadavg())


def one(files, effects, max_effects, search="tiered", runs=None, quick=False) -> tuple:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        argv = [sys.executable, "-m", "beamslider", "discover", "--measured", *files, "--out", str(out), "--force"]
        if runs is not None:  # the repeat starts from a copy of the kept runs
            out.mkdir()
            shutil.copyfile(runs, out / "runs.jsonl")
        if effects:
            argv += ["--effects", effects]
        argv += ["--max-effects", str(max_effects), "--search", search] + (["--quick"] if quick else [])
        t0 = time.perf_counter()
        p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        _, status, usage = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t0
        stdout, stderr = p.stdout.read(), p.stderr.read()  # type: ignore[union-attr]
        if os.waitstatus_to_exitcode(status) != 0:
            raise SystemExit(f"discover failed:\n{stderr}")
        rep = json.loads((out / "report.json").read_text())
        if rep.get("provisional"):  # --quick: the leading candidate, not a verdict
            return wall, usage.ru_utime + usage.ru_stime, "provisional", ", ".join(
                f"{e} {rep['values'][e]:.5g} in [{rep['intervals'][e][0]:.5g}, {rep['intervals'][e][1]:.5g}]"
                for e in rep["leading"])
        named = ", ".join(f"{e} {v['value']:.5g} in [{v['interval'][0]:.5g}, {v['interval'][1]:.5g}]"
                          for e, v in rep.get("parameters", {}).items()) or "-"
        del stdout
        return wall, usage.ru_utime + usage.ru_stime, rep["verdict"], named


def stage_of(frames) -> str:
    """The stage of the innermost discover function on the stack that names one (the confounding
    check of a named set with its fits as one stage)."""
    if any(fr.function == "confounded_sets" for fr in frames):
        return "confounding check of a named set"
    for fr in frames:
        name, loc = fr.function, fr.frame.f_locals
        if name == "slider_sensitivities":
            return "linearised model (signatures)"
        if name == "predict_singles":
            return "singles: linearised prediction"
        if name == "advise":
            return "advice"
        if name == "gauss_newton":
            return "sets: joint refinement"
        if name in ("after_of", "simulate"):
            return "full simulation of the named set"
        if name == "profile_fit":
            if len(loc.get("effects", ())) >= 2:
                return "sets: coordinate pass"
            return "singles: coarse scan" if loc.get("refine") == loc["options"].screen_refine else "singles: full fit"
        if name in ("build", "discover"):
            return "baseline ensemble"
    return "other"


def stages(files, effects: str, max_effects: int, search: str = "tiered") -> None:
    """One discover in this process with the core's runner counted per stage (:func:`stage_of`)."""
    import collections
    import inspect

    import beamslider as bs
    from beamslider import _core
    from beamslider import discover as dc

    stats: dict = collections.OrderedDict()
    real = _core.run_free_slider_batch

    def counted(jobs, *a, **kw):
        stage = stage_of(inspect.stack(0)[1:])
        t0, c0 = time.perf_counter(), time.process_time()
        out = real(jobs, *a, **kw)
        s = stats.setdefault(stage, dict(batches=0, runs=0, wall_s=0.0, cpu_s=0.0))
        s["batches"] += 1
        s["runs"] += len(jobs)
        s["wall_s"] += time.perf_counter() - t0
        s["cpu_s"] += time.process_time() - c0
        return out

    runs = [bs.read_measurement(f) for f in files]
    _core.run_free_slider_batch = counted
    try:
        t0, c0 = time.perf_counter(), time.process_time()
        d = dc.discover(measured=runs, effects=effects.split(",") if effects else None, max_effects=max_effects,
                        search=search)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    finally:
        _core.run_free_slider_batch = real
    print(f"{'stage':<36} {'batches':>7} {'runs':>6} {'wall s':>8} {'CPU s':>8}")
    for k, v in sorted(stats.items(), key=lambda kv: -kv[1]["cpu_s"]):
        print(f"{k:<36} {v['batches']:>7} {v['runs']:>6} {v['wall_s']:>8.1f} {v['cpu_s']:>8.1f}")
    print(f"{'all runs of the core':<36} {sum(v['batches'] for v in stats.values()):>7} "
          f"{sum(v['runs'] for v in stats.values()):>6} {sum(v['wall_s'] for v in stats.values()):>8.1f} "
          f"{sum(v['cpu_s'] for v in stats.values()):>8.1f}")
    print(f"discover: wall {wall:.1f} s, CPU {cpu:.1f} s ({load()}); verdict: {dc.verdict_line(d)}", flush=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--measured", nargs="+", default=None,
                    help="measured files (default: examples/data/*.txt.gz)")
    ap.add_argument("--effects", default="", help="comma-separated candidates (default: all)")
    ap.add_argument("--max-effects", type=int, default=2, help="largest set fitted (2, as the CLI)")
    ap.add_argument("--case", default=None, help="a case of scripts/repro/discover_table.py instead of --measured")
    ap.add_argument("--duration", type=float, default=60.0, help="--case: run length [s] (60)")
    ap.add_argument("--s0-offset", type=float, default=0.0015, help="--case: truth runs this far off s0 (0.0015)")
    ap.add_argument("--stages", action="store_true", help="one discover in this process, its runs counted per stage")
    ap.add_argument("--search", choices=("tiered", "full", "fast"), default="tiered",
                    help="discover's search (docs/model.md §9.1, \"Cost\"): tiered (the default), full or fast")
    ap.add_argument("--fast", action="store_true", help="the same as --search fast")
    ap.add_argument("--quick", action="store_true",
                    help="time the provisional answer: each discover stops at it (discover --quick; docs/model.md §9.1)")
    ap.add_argument("--runs", metavar="FILE", default=None,
                    help="kept runs (runs.jsonl of an earlier discover, e.g. of another case at the same points) "
                         "each repeat starts from (default: none, every run made)")
    args = ap.parse_args()
    data_dir = None
    if args.case is not None:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "repro"))
        from discover_table import CASES, OPS, SLIDER, truth_of

        from beamslider import discover as dc

        if args.case not in CASES:
            print(f"error: unknown case {args.case!r}: known are {', '.join(CASES)}", file=sys.stderr)
            return 1
        label, spec, effects = CASES[args.case]
        data_dir = tempfile.TemporaryDirectory()
        truth = truth_of(spec)
        params, chain = truth if isinstance(truth, tuple) else (truth, None)
        files = [str(p) for p in dc.synthesize_slider_runs(params, operating_points=OPS, duration_s=args.duration,
                                                           out_dir=data_dir.name, seed=3, s0_offset=args.s0_offset,
                                                           chain=chain)]
        if not args.effects and len(effects) != len(SLIDER):
            args.effects = ",".join(effects)
        print(f"case {args.case}: {label}, {len(OPS)} runs of {args.duration:g} s, truth runs from s0 + "
              f"{args.s0_offset:g}", flush=True)
    else:
        files = args.measured or sorted(glob.glob(str(Path(__file__).resolve().parents[2] / "examples/data/*.txt.gz")))
    if not files:
        print("error: no measured files", file=sys.stderr)
        return 1
    print(f"discover of {len(files)} file(s), {os.cpu_count()} cores, {load()}", flush=True)
    if args.stages:
        stages(files, args.effects, args.max_effects, search="fast" if args.fast else args.search)
        return 0
    walls, cpus = [], []
    for i in range(args.repeat):
        wall, cpu, verdict, named = one(files, args.effects, args.max_effects,
                                        "fast" if args.fast else args.search, runs=args.runs, quick=args.quick)
        walls.append(wall)
        cpus.append(cpu)
        print(f"  repeat {i + 1}: wall {wall:.1f} s, CPU {cpu:.1f} s, verdict {verdict}: {named} ({load()})", flush=True)
    print(f"median of {args.repeat}: wall {statistics.median(walls):.1f} s, CPU {statistics.median(cpus):.1f} s "
          f"(idle {os.cpu_count()}-core wall about CPU / {os.cpu_count()} = "
          f"{statistics.median(cpus) / (os.cpu_count() or 1):.1f} s); verdict {verdict}: {named}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
