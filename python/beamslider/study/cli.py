"""The ``beamslider study`` subcommand and the files it writes."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any, Callable, List, Union


from .config import RESULTS_FILE, StudyConfig, Uncertain, read_config
from .plots import plot_behaviour_probability, plot_sensitivity
from .run import run_study
from .statistics import StudyResult


EXAMPLE_CONFIG = StudyConfig(
    uncertain=[Uncertain("friction_coefficient", "uniform", low=0.22, high=0.31),
               Uncertain("natural_frequency_factor", "uniform", low=0.95, high=1.05)],
    method="lhs", samples=16, seed=1)


def add_cli(sub: Any, common: Callable[..., None]) -> None:
    """Register ``beamslider study`` on the CLI's subparsers (``common`` adds --out/--no-progress)."""
    sp = sub.add_parser("study", help="uncertainty study: behaviour probabilities and sensitivities (local or Dask)",
                        description="Sample the uncertain parameters of a study configuration (TOML), run the free "
                                    "slider at every sample and operating point (locally with one thread per core, or "
                                    "on a Dask cluster with --scheduler) and aggregate behaviour probabilities, "
                                    "statistics and sensitivity indices. Each finished run is appended to "
                                    "DIR/study.jsonl at once; --resume runs only the missing ones. Writes study.toml, "
                                    "summary.json, summary.txt, behaviour_probability.png and sensitivity*.png.")
    sp.add_argument("--config", metavar="TOML", help="study configuration (see --print-config)")
    sp.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address, e.g. tcp://host:8786 (default: local)")
    sp.add_argument("--scheduler-file", metavar="FILE",
                    help="Dask scheduler file (dask scheduler --scheduler-file FILE) instead of --scheduler")
    sp.add_argument("--threads", "-j", type=int, metavar="N", help="local worker threads (default: one per core)")
    sp.add_argument("--chunk-size", type=int, metavar="N", help="points per Dask task (default: the configuration's)")
    sp.add_argument("--task-threads", type=int, default=1, metavar="N", help="rayon threads per Dask task (1)")
    sp.add_argument("--resume", action="store_true", help="continue the study in --out, skipping finished runs")
    sp.add_argument("--print-config", action="store_true", help="print an example configuration (TOML) and exit")
    common(sp, model_options=False, window=False)
    sp.set_defaults(func=cmd_study)


def cmd_study(args: Any) -> int:
    """``beamslider study``."""
    if args.print_config:
        print(EXAMPLE_CONFIG.to_toml_text(), end="")
        return 0
    if not args.config:
        raise ValueError("beamslider study needs --config study.toml (an example: beamslider study --print-config)")
    if not Path(args.config).is_file():
        raise ValueError(f"{args.config}: no such file")
    config = read_config(args.config)
    out = Path(args.out)
    t0 = time.perf_counter()
    if args.scheduler and args.scheduler_file:
        raise ValueError("give --scheduler or --scheduler-file, not both")
    res = run_study(config, out=out, resume=args.resume, scheduler=args.scheduler, scheduler_file=args.scheduler_file,
                    threads=args.threads,
                    chunk_size=args.chunk_size, task_threads=args.task_threads, progress=args.progress)
    wall = time.perf_counter() - t0
    written = write_outputs(res, out)
    print(res.text(), end="")
    print(f"{len(res.table['index'])} runs in {wall:.1f} s")
    for p in [out / RESULTS_FILE, out / "study.toml", *written]:
        print(f"wrote {p}")
    return 0


def write_outputs(result: StudyResult, out: Union[str, Path]) -> List[Path]:
    """Write summary.json, summary.txt, behaviour_probability.png (per s0) and sensitivity.png (per
    operating point) into ``out``; returns the paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "summary.json", out / "summary.txt"]
    paths[0].write_text(json.dumps(result.summary_dict(), indent=1) + "\n", encoding="utf-8")
    paths[1].write_text(result.text(), encoding="utf-8")
    s0s = sorted({p.s0 for p in result.points})
    for s0 in s0s:
        p = out / ("behaviour_probability.png" if len(s0s) == 1 else f"behaviour_probability_s0_{s0:g}.png")
        plot_behaviour_probability(result, s0=s0, path=p)
        paths.append(p)
    n = len(result.points)
    for j in range(n if n <= 12 else 0):
        p = out / ("sensitivity.png" if n == 1 else f"sensitivity_{j}.png")
        plot_sensitivity(result, point=j, path=p)
        paths.append(p)
    return paths
