"""``beamslider map``: an operating map (docs/model.md §8) over a grid of f_ex, a_ex and s0, in parallel,
resumable and extensible in time."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from .. import _core
from ._common import EXIT_FAULT, UserError, add_common, axis_values, figure, out_dir, params_from_args, positive


def add_parser(sub: Any) -> None:
    """Register ``beamslider map``."""
    sp = sub.add_parser("map", help="operating map: behaviour over a grid of f_ex, a_ex (and s0), in parallel",
                        description="Classify the behaviour of the free slider (docs/model.md §8) at every point of a grid "
                                    "(default: the paper's map, f_ex 100:130:2 Hz, a_ex 4:16:2 m/s², s0 0.3, 120 s). "
                                    "Each finished point is appended to DIR/map.jsonl at once; --resume skips the points "
                                    "already there (also of a map started by beamslider-batch map). Writes map.toml, "
                                    "map.txt (letter table) and map.png (the categorical map, like the paper's Fig. 11; one panel per s0, "
                                    "points whose behaviour changes with s0 outlined).")
    sp.add_argument("--config", metavar="TOML", help="map configuration as read by beamslider-batch map --config")
    sp.add_argument("--f-ex", metavar="GRID", help="frequencies: START:STOP:STEP or a comma list (100:130:2)")
    sp.add_argument("--a-ex", metavar="GRID", help="levels: START:STOP:STEP or a comma list (4:16:2)")
    sp.add_argument("--s0", metavar="GRID", help="initial slider positions (0.3)")
    sp.add_argument("--t-end", type=positive(float), metavar="S", help="simulated time per point [s] (120)")
    sp.add_argument("--threads", "-j", type=positive(int), metavar="N", help="worker threads (default: one per core)")
    sp.add_argument("--resume", action="store_true", help="continue the map in --out, skipping finished points")
    sp.add_argument("--extend-to", type=positive(float), metavar="T",
                    help="extend the map in --out to T seconds: continue its points with settled = false and its undetermined points from their saved end "
                         "states (bitwise the T-second runs), keep the settled ones; prints the number re-run")
    sp.add_argument("--print-config", action="store_true", help="print the map configuration (TOML) and exit")
    sp.add_argument("--scheduler", metavar="ADDRESS",
                    help="run the points on a Dask cluster: scheduler address, e.g. tcp://host:8786 (docs/cluster.md)")
    sp.add_argument("--scheduler-file", metavar="FILE", help="run on the Dask cluster of this scheduler file "
                    "(dask scheduler --scheduler-file FILE)")
    sp.add_argument("--chunk-size", type=positive(int), default=8, metavar="N", help="points per Dask task (8)")
    sp.add_argument("--predictor", metavar="LAW",
                    help="predict the map with the reduced super-slow model instead of FS runs (milliseconds per "
                         "point): a drift law file (beamslider fit-law) or 'default' (the built-in law, fitted at "
                         "the default parameters); one s0, same results format")
    add_common(sp, window=False, force=True)
    sp.set_defaults(func=cmd_map)


def cmd_map(args: argparse.Namespace) -> int:
    from ..maps import RESULTS_FILE, failures, map_config, plot_operating_map, run_map_config, text_table

    extend = args.extend_to is not None
    if extend and args.resume:
        raise UserError("--extend-to finishes an interrupted extension by itself: leave out --resume")
    if args.force and (args.resume or extend):
        raise UserError("--force starts the map in --out over: it does not go with --resume or --extend-to")
    if extend and not args.config and all(v is None for v in (args.f_ex, args.a_ex, args.s0, args.t_end, args.params, args.dt)):
        saved = out_dir(args) / "map.toml"
        if not saved.exists():
            raise UserError(f"--extend-to: no map to extend in {saved.parent} (map.toml missing)")
        args.config = str(saved)
    if args.config:
        try:
            config = Path(args.config).read_text(encoding="utf-8")
        except FileNotFoundError:
            raise UserError(f"{args.config}: no such file") from None
        except UnicodeDecodeError as e:
            raise UserError(f"{args.config}: not a TOML map configuration (not UTF-8 text: {e.reason} at byte {e.start})") from None
        if any(v is not None for v in (args.f_ex, args.a_ex, args.s0, args.t_end, args.params, args.dt)):
            raise UserError("--config replaces --f-ex/--a-ex/--s0/--t-end/--params/--dt: put them in the TOML file")
    else:
        p = params_from_args(args)
        config = map_config(
            p, f_ex=axis_values("--f-ex", "100:130:2" if args.f_ex is None else args.f_ex),
            a_ex=axis_values("--a-ex", "4:16:2" if args.a_ex is None else args.a_ex),
            s0=axis_values("--s0", "0.3" if args.s0 is None else args.s0),
            t_end=args.t_end if args.t_end is not None else 120.0)
    if extend:
        cfg = _core.MapConfig(config) if isinstance(config, str) else config
        if not (args.extend_to > cfg.duration_s):
            raise UserError(f"--extend-to {args.extend_to:g}: must exceed the map's t_end ({cfg.duration_s:g} s)")
        config = cfg.with_duration(float(args.extend_to))
    if args.print_config:
        print(config if isinstance(config, str) else config.toml(), end="")
        return 0
    out = Path(args.out)  # created by the map itself, after the scheduler (if any) answered
    if args.scheduler and args.scheduler_file:
        raise UserError("give --scheduler or --scheduler-file, not both")
    t0 = time.perf_counter()
    if args.predictor:
        table = _predicted(args, out)
    else:
        try:
            table = run_map_config(config, out=out, resume=args.resume, threads=args.threads, progress=args.progress,
                                   extend=extend, scheduler=args.scheduler, scheduler_file=args.scheduler_file,
                                   chunk_size=args.chunk_size, force=args.force)
        except KeyboardInterrupt as e:
            e.beamslider_note = _kept(out, config, extend and args.extend_to)  # type: ignore[attr-defined]
            raise
    wall = time.perf_counter() - t0
    txt = text_table(table)
    (out / "map.txt").write_text(txt, encoding="utf-8")
    s0s = sorted(set(table["s0"].tolist()))
    pngs = [out / "map.png"]
    if not figure(plot_operating_map, table, path=pngs[0], mark_changes=len(s0s) > 1):
        pngs = []
    print(txt, end="")
    print(f"{len(table['index'])} points in {wall:.1f} s")
    for path in [out / RESULTS_FILE, *([] if args.predictor else [out / "map.toml"]), out / "map.txt", *pngs]:
        print(f"wrote {path}")
    if args.predictor:
        robust = [r for r in table.get("robust", []) if r is not None]
        if robust and not all(robust):
            print(f"{sum(1 for r in robust if not r)} of {len(robust)} predictions are not robust (V ± the law's "
                  "resolution changes them): check those points with FS runs")
    failed = failures(table)
    if failed:
        print(f"beamslider: {len(failed)} of {len(table['index'])} points failed (the others are done):", file=sys.stderr)
        for line in failed:
            print(f"  {line}", file=sys.stderr)
        return EXIT_FAULT
    return 0


def _kept(out: Path, config: Any, extend_to: Any) -> str:
    """What an interrupted map kept and how to go on."""
    from .. import _core
    from ..maps import RESULTS_FILE

    if extend_to:
        return f"the finished points are kept; run the same --extend-to {extend_to:g} again to finish the extension"
    try:
        f, a, s = (_core.MapConfig(config) if isinstance(config, str) else config).axes
        total = len(f) * len(a) * len(s)
        with open(out / RESULTS_FILE, "rb") as fh:
            done = max(sum(1 for line in fh if line.strip()) - 1, 0)
    except (OSError, ValueError):
        return "the finished points are kept; run again with --resume"
    return f"{min(done, total)} of {total} points kept; run again with --resume"


def _predicted(args: argparse.Namespace, out: Path) -> Any:
    """The map by the reduced predictor (``--predictor``): the grid of --f-ex/--a-ex/--s0/--t-end/--params."""
    import warnings

    from ..maps import rows_to_table
    from ..superslow import predicted_map
    from ..superslow import load_law

    if args.config or args.extend_to is not None or args.scheduler or args.scheduler_file:
        raise UserError("--predictor takes the grid from --f-ex/--a-ex/--s0/--t-end/--params (not --config, "
                        "--extend-to or a scheduler): a predicted map runs here, in milliseconds per point")
    s0 = axis_values("--s0", "0.3" if args.s0 is None else args.s0)
    if len(s0) != 1:
        raise UserError("--predictor: one s0 per map (run it once per s0)")
    try:
        law = None if args.predictor == "default" else load_law(args.predictor)
    except FileNotFoundError:
        raise UserError(f"{args.predictor}: no such file (give a law written by beamslider fit-law, or 'default')") from None
    p = params_from_args(args)
    if (out / "map.jsonl").exists() and not (args.resume or args.force):
        raise UserError(f"{out / 'map.jsonl'} exists from an earlier map: run again with --resume to continue it or with "
                        "--force to start over, or choose another --out")
    # A design law (None: the built-in one) is blended for the parameters by the core, inside the
    # predicted map; why the design lies outside it comes back as a warning.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rows = predicted_map(p, drift=law, f_ex=axis_values("--f-ex", "100:130:2" if args.f_ex is None else args.f_ex),
                             a_ex=axis_values("--a-ex", "4:16:2" if args.a_ex is None else args.a_ex), s0=s0[0],
                             t_end=args.t_end if args.t_end is not None else 120.0, out=out, resume=args.resume,
                             force=args.force, threads=args.threads)
    for w in caught:
        print(f"beamslider: warning: {w.message}", file=sys.stderr)
    table = rows_to_table(rows)
    table["robust"] = [r.get("robust") for r in sorted(rows, key=lambda r: r["index"])]
    return table
