"""``beamslider design``: slider design optimisation for broadband self-adaption
(:mod:`beamslider.design`), local or on Dask, resumable.

Search the design variables of a design configuration (TOML) with differential evolution; every
design is run over a band of operating points (FS, or the reduced predictor) and scored by its
adaption bandwidth [Hz] / harvestable level, nominal or robust. Each evaluated design is appended to
DIR/design.jsonl at once; --resume continues a killed run without evaluating any design twice.
Writes design.toml, summary.json, summary.txt, pareto.png, maps.png, amplitude.png."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from ._common import add_common, add_config_run, doc_body, print_report


def add_parser(sub: Any) -> None:
    """Register ``beamslider design``."""
    sp = sub.add_parser("design", help="optimise the slider design for the widest adaption band (local or Dask)",
                        description=doc_body(__doc__))
    add_config_run(sp, "design")
    sp.add_argument("--check-t-end", type=float, metavar="S",
                    help="duration of the FS re-checks (prototype, best, re-checked and reference designs) [s] (default: the search's t_end_s)")
    sp.add_argument("--robust-check-t-end", type=float, metavar="S",
                    help="duration of the robust FS re-checks [s] (default: --check-t-end)")
    sp.add_argument("--resume", action="store_true", help="continue the run in --out, skipping evaluated designs")
    add_common(sp, model_options=False, window=False, force=True)
    sp.set_defaults(func=cmd_design)


def cmd_design(args: Any) -> int:
    """``beamslider design``."""
    from ..design import EXAMPLE_TOML, RESULTS_FILE, optimise, read_config, write_outputs

    if args.print_config:
        print(EXAMPLE_TOML, end="")
        return 0
    if not args.config:
        raise ValueError("beamslider design needs --config design.toml (an example: beamslider design --print-config)")
    if not Path(args.config).is_file():
        raise ValueError(f"{args.config}: no such file")
    if args.scheduler and args.scheduler_file:
        raise ValueError("give --scheduler or --scheduler-file, not both")
    if args.threads is not None and not 1 <= args.threads <= 65536:
        raise ValueError(f"invalid --threads {args.threads}: must be in 1..=65536")
    config = read_config(args.config)
    out = Path(args.out)
    t0 = time.perf_counter()
    if args.force and args.resume:
        raise ValueError("--force starts the run in --out over: it does not go with --resume")
    res = optimise(config, out=out, resume=args.resume, force=args.force, scheduler=args.scheduler, scheduler_file=args.scheduler_file,
                   threads=args.threads, progress=args.progress, check_t_end_s=args.check_t_end,
                   robust_check_t_end_s=args.robust_check_t_end)
    written = write_outputs(res, out)
    return print_report(res.text(), f"wall time {time.perf_counter() - t0:.1f} s", [out / RESULTS_FILE, out / "design.toml", *written])
