"""``beamslider plot``: re-plot a result written by simulate/compare/manifold, and/or a measurement."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ..params import Parameters
from ..simulate import SimulationResult
from ._common import UserError, add_common, out_dir, plan_outputs
from ._files import measurement, read_manifold_csv, read_meta, read_simulation_csv


def add_parser(sub: Any) -> None:
    """Register ``beamslider plot``."""
    sp = sub.add_parser("plot", help="re-plot results written by simulate/compare/manifold, or a measurement",
                        description="Plot a result written earlier (its .csv or .json) and/or a measurement file.")
    sp.add_argument("result", nargs="?", help="a <stem>.csv or <stem>.json written by beamslider")
    sp.add_argument("--manifold", metavar="CSV", help="manifold CSV to overlay")
    sp.add_argument("--measurement", metavar="FILE", help="measured file to overlay")
    add_common(sp, model_options=False, force=True)
    sp.set_defaults(func=cmd_plot)



def cmd_plot(args: argparse.Namespace) -> int:
    from .._mpl import require_matplotlib
    from ..plotting import plot_manifold, plot_operating_point

    if args.result is None and args.measurement is None:
        raise UserError("nothing to plot: give a simulation result (CSV or JSON) and/or --measurement FILE")
    result = None
    manifold = None
    stem = "plot"
    if args.result is not None:
        path = Path(args.result)
        csv_path, json_path = path.with_suffix(".csv"), path.with_suffix(".json")
        meta = read_meta(json_path) if path.suffix == ".json" or json_path.exists() else {}
        if meta.get("kind") == "manifold":
            p = Parameters.from_toml_text(meta.get("params_toml", ""))
            manifold = read_manifold_csv(csv_path, f_ex=meta["f_ex_hz"], a_ex=meta["a_ex_m_s2"], params=p)
            if isinstance(meta.get("periods"), int):
                manifold.periods = meta["periods"]
            require_matplotlib("beamslider plot")
            plan_outputs(args, [f"{path.stem}.png"])
            target = out_dir(args) / f"{path.stem}.png"
            plot_manifold(manifold, path=target)
            print(f"wrote {target}")
            return 0
        if meta.get("complete") is False:
            raise UserError(f"{json_path}: the run that writes {meta.get('data', 'this result')} did not finish "
                            "(incomplete result): run it again")
        if isinstance(meta.get("data"), str):
            csv_path = path.with_name(meta["data"])
        elif meta.get("kind") == "compare":
            csv_path = path.with_name(f"{path.stem}_model.csv")
        elif path.suffix in (".npz", ".parquet"):
            csv_path = path
        if csv_path.suffix in (".npz", ".parquet") and not meta:
            raise UserError(f"{path}: no summary {json_path.name} beside it: cannot tell whether the run finished")
        p = Parameters.from_toml_text(meta["params_toml"]) if "params_toml" in meta else Parameters()
        cols = read_simulation_csv(csv_path)
        result = SimulationResult(
            t=cols["t_s"], w=cols["w_4L7_m"], s=cols["s"], x_c=cols["xC_m"], z_c=cols["zC_m"], beta=cols["beta_rad"],
            status=meta.get("status", "completed"), message=meta.get("message", ""), counters=meta.get("counters", {}),
            final_state={}, params=p, f_ex=float(meta.get("f_ex_hz", "nan")), a_ex=float(meta.get("a_ex_m_s2", "nan")),
            s0=float(meta["s0"]) if meta.get("s0") is not None else float(cols["s"][0]), model=meta.get("model", "fs"),
        )
        man_csv = args.manifold or (path.with_name(meta["manifold_csv"]) if "manifold_csv" in meta else None)
        if man_csv is not None:
            manifold = read_manifold_csv(Path(man_csv), f_ex=result.f_ex, a_ex=result.a_ex, params=p)
        if args.measurement is None and meta.get("measurement"):
            args.measurement = meta["measurement"]
        stem = path.stem
    meas = measurement(args.measurement) if args.measurement else None
    if result is None and meas is not None:
        stem = Path(args.measurement).stem
        stem = Path(stem).stem if args.measurement.lower().endswith(".gz") else stem
    require_matplotlib("beamslider plot")
    plan_outputs(args, [f"{stem}.png"])
    target = out_dir(args) / f"{stem}.png"
    plot_operating_point(result, manifold=manifold, measurement=meas, window=args.window, path=target)
    print(f"wrote {target}")
    return 0
