"""``beamslider simulate``: one operating point (default: the signature move, 124 Hz, 14 m/s², s₀ = 0.3,
60 s) streamed to NPZ (or CSV) + JSON + the three-panel figure, with the PCS manifold overlaid."""

from __future__ import annotations

import argparse
import time
from typing import Any

from ..simulate import simulate
from ._common import figure, out_dir, params_from_args, plan_outputs, positive, report, write_json_atomic
from ._files import run_stem, simulation_summary
from ._manifold import add_operating_point, add_run_options, check_manifold_args, manifold_name, run_manifold


def add_parser(sub: Any) -> None:
    """Register ``beamslider simulate``."""
    sp = sub.add_parser("simulate", help="run one operating point and plot it (default: the signature move)",
                        description="Run one operating point (default: 124 Hz, 14 m/s², s0 = 0.3, 60 s) and "
                                    "write <stem>.npz (or .csv), <stem>.json and the three-panel figure <stem>.png.")
    add_operating_point(sp)
    sp.add_argument("--s0", type=float, default=0.3, help="initial slider position x/L (0.3)")
    sp.add_argument("--t-end", type=positive(float), default=60.0, metavar="S", help="simulated time [s] (60)")
    sp.add_argument("--model", choices=["fs", "pcs", "beam"], default="fs",
                    help="free slider, pseudo-constrained slider or beam only (fs)")
    sp.add_argument("--s-pcs", type=float, metavar="S", help="slider position of the PCS model (default s0)")
    sp.add_argument("--format", choices=["npz", "csv"], default="npz",
                    help="trajectory file: npz (NumPy, default; np.load or beamslider.read_trajectory) or csv "
                         "(shortest round-trip numbers); streamed to disk as the run goes")
    add_run_options(sp)
    sp.set_defaults(func=cmd_simulate)


def cmd_simulate(args: argparse.Namespace) -> int:
    from ..plotting import plot_operating_point

    p = params_from_args(args)
    stem = run_stem(args.model, args.f_ex, args.a_ex, args.s0, args.s_pcs)
    with_manifold = args.manifold and args.model != "beam"
    man_name = f"{manifold_name(args, args.f_ex, args.a_ex)}.csv" if with_manifold else None
    # Bad input is named before anything else.
    simulate(p, f_ex=args.f_ex, a_ex=args.a_ex, s0=args.s0, t_end=args.t_end, model=args.model, s_pcs=args.s_pcs,
             record_every=args.record_every, _check_only=True)
    if with_manifold:
        check_manifold_args(args)
    data_name = f"{stem}.{args.format}"
    plan_outputs(args, [data_name, f"{stem}.json", f"{stem}.png"] + ([man_name] if man_name else []))
    out = out_dir(args)
    written = [out / data_name, out / f"{stem}.json", out / f"{stem}.png"]
    # The sidecar says "incomplete" until the data file is in place (plot refuses it meanwhile).
    write_json_atomic(written[1], {
        "kind": "simulation", "data": data_name, "format": args.format, "complete": False, "model": args.model,
        "f_ex_hz": args.f_ex, "a_ex_m_s2": args.a_ex, "s0": args.s0, "t_end_s": args.t_end,
        "record_every": args.record_every, "params_toml": p.toml_text()})
    t0 = time.perf_counter()
    # The trajectory streams from the core to disk (temporary name, renamed when complete).
    result = simulate(p, f_ex=args.f_ex, a_ex=args.a_ex, s0=args.s0, t_end=args.t_end, model=args.model,
                      s_pcs=args.s_pcs, record_every=args.record_every, progress=args.progress,
                      out=written[0], overwrite=True)
    wall = time.perf_counter() - t0
    manifold = None
    summary = simulation_summary(result, t_end=args.t_end, record_every=args.record_every, wall_s=wall,
                                 window=args.window)
    summary.update({"data": data_name, "format": args.format, "complete": True})
    if with_manifold:
        manifold = run_manifold(args, p, args.f_ex, args.a_ex)
        summary["manifold_csv"] = man_name
        written.insert(2, out / man_name)
    write_json_atomic(written[1], summary)
    if not figure(plot_operating_point, result, manifold=manifold, window=args.window, path=written[-1]):
        written.pop()
    print(f"{result.model.upper()} {args.f_ex:g} Hz, {args.a_ex:g} m/s², {args.t_end:g} s: {result.status}; "
          f"final s = {summary['final_s']:.4f}, amplitude/h = {summary['final_amplitude_over_h']:.3f} "
          f"({wall:.1f} s)")
    return report(result, written)
