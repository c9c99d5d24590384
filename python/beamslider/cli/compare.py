"""``beamslider compare``: a measurement file of the published data set against the model at its
operating point (docs/model.md §7)."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from ..simulate import simulate
from ._common import UserError, figure, out_dir, params_from_args, plan_outputs, positive, report, write_json_atomic
from ._files import measurement, simulation_summary
from ._manifold import add_run_options, check_manifold_args, manifold_name, resolve_manifold, run_manifold


def add_parser(sub: Any) -> None:
    """Register ``beamslider compare``."""
    sp = sub.add_parser("compare", help="a measurement file against the model at its operating point",
                        description="Read a measured file of the published data set, simulate the same "
                                    "operating point (from the file name) and overlay both.")
    sp.add_argument("measurement", help="e.g. Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt")
    sp.add_argument("--f-ex", type=positive(float), metavar="HZ", help="override f_ex from the file name")
    sp.add_argument("--a-ex", type=float, metavar="M_S2", help="override a_ex from the file name")
    sp.add_argument("--s0", type=float, help="override s0 from the file name")
    sp.add_argument("--start-from-measured", action="store_true",
                    help="start the model at the first measured s instead of the nominal s0")
    sp.add_argument("--t-end", type=positive(float), metavar="S", help="simulated time (default: measured duration)")
    add_run_options(sp)
    sp.set_defaults(func=cmd_compare)


def cmd_compare(args: argparse.Namespace) -> int:
    from ..plotting import plot_operating_point

    meas = measurement(args.measurement)
    f_ex = args.f_ex if args.f_ex is not None else meas.f_ex
    a_ex = args.a_ex if args.a_ex is not None else meas.a_ex
    s0 = args.s0 if args.s0 is not None else meas.s0
    if f_ex is None or a_ex is None or s0 is None:
        raise UserError(f"{args.measurement}: the file name does not give f_ex, a_ex and s0 "
                        "(like ..._fex124_ExcLevel14_RelSliderPosStart03.txt): pass --f-ex, --a-ex and --s0")
    if args.s0 is None:
        s0 = float(meas.s[0]) if args.start_from_measured else s0
    t_end = args.t_end if args.t_end is not None else float(meas.t[-1] - meas.t[0])
    p = params_from_args(args)
    name = Path(args.measurement).name
    stem = "compare_" + (name[:-3] if name.lower().endswith(".gz") else Path(name).stem).rsplit(".txt", 1)[0]
    resolve_manifold(args, a_ex)
    man_name = f"{manifold_name(args, f_ex, a_ex)}.csv" if args.manifold else None
    simulate(p, f_ex=f_ex, a_ex=a_ex, s0=s0, t_end=t_end, record_every=args.record_every, _check_only=True)  # names bad input first
    if args.manifold_kind == "pcs":
        check_manifold_args(args)
    out = plan_outputs(args, [f"{stem}_model.csv", f"{stem}.json", f"{stem}.png"] + ([man_name] if man_name else []))
    t0 = time.perf_counter()
    written = [out_dir(args) / f"{stem}_model.csv", out / f"{stem}.json", out / f"{stem}.png"]
    # Streamed from the core (temporary name, renamed when complete).
    result = simulate(p, f_ex=f_ex, a_ex=a_ex, s0=s0, t_end=t_end, record_every=args.record_every,
                      progress=args.progress, out=written[0], overwrite=True)
    wall = time.perf_counter() - t0
    # The model's final amplitude by the same method as the measurement's (FFT envelope).
    summary = simulation_summary(result, t_end=t_end, record_every=args.record_every, wall_s=wall,
                                 window=args.window, streamed=False)
    menv = meas.envelope(args.window)
    summary.update({
        "kind": "compare",
        "measurement": str(meas.path),
        "measured_final_s": float(meas.s[-1]),
        "measured_final_amplitude_m": float(menv[-1]),
        "measured_final_amplitude_over_h": float(menv[-1] / p.thickness_m),
        "data": written[0].name, "format": "csv", "complete": True,
    })
    manifold = None
    if args.manifold:
        manifold = run_manifold(args, p, f_ex, a_ex)
        summary["manifold_csv"] = man_name
        written.insert(2, out / man_name)
    write_json_atomic(written[1], summary)
    if not figure(plot_operating_point, result, manifold=manifold, measurement=meas, window=args.window,
                   path=written[-1]):
        written.pop()
    print(f"model final s = {summary['final_s']:.4f} (measured {summary['measured_final_s']:.4f}), "
          f"amplitude/h = {summary['final_amplitude_over_h']:.3f} "
          f"(measured {summary['measured_final_amplitude_over_h']:.3f})")
    return report(result, written)
