"""``beamslider study``: an uncertainty study (local or Dask) written as results rows, summary and
figures (:mod:`beamslider.study`).

Sample the uncertain parameters of a study configuration (TOML), run the free slider at every sample
and operating point (locally with one thread per core, or on a Dask cluster with --scheduler) and
aggregate behaviour probabilities, statistics and sensitivity indices. Each finished run is appended
to DIR/study.jsonl at once; --resume runs only the missing ones. Writes study.toml, summary.json,
summary.txt, behaviour_probability.png and sensitivity*.png."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from ..study import EXAMPLE_CONFIG, RESULTS_FILE, read_config, run_study, write_outputs
from ._common import add_common, add_config_run, doc_body, print_report


def add_parser(sub: Any) -> None:
    """Register ``beamslider study``."""
    sp = sub.add_parser("study", help="uncertainty study: behaviour probabilities and sensitivities (local or Dask)",
                        description=doc_body(__doc__))
    add_config_run(sp, "study")
    sp.add_argument("--chunk-size", type=int, metavar="N", help="points per Dask task (default: the configuration's)")
    sp.add_argument("--task-threads", type=int, default=1, metavar="N", help="rayon threads per Dask task (1)")
    sp.add_argument("--resume", action="store_true", help="continue the study in --out, skipping finished runs")
    add_common(sp, model_options=False, window=False, force=True)
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
    if args.force and args.resume:
        raise ValueError("--force starts the study in --out over: it does not go with --resume")
    res = run_study(config, out=out, resume=args.resume, force=args.force, scheduler=args.scheduler,
                    scheduler_file=args.scheduler_file, threads=args.threads,
                    chunk_size=args.chunk_size, task_threads=args.task_threads, progress=args.progress)
    wall = time.perf_counter() - t0
    written = write_outputs(res, out)
    return print_report(res.text(), f"{len(res.table['index'])} runs in {wall:.1f} s", [out / RESULTS_FILE, out / "study.toml", *written])


def add_cli(sub: Any, common: Any = None) -> None:
    """Register ``beamslider study`` on a CLI's subparsers (the former ``beamslider.study.add_cli``;
    ``common`` is ignored: the options are the package's)."""
    add_parser(sub)
