"""``beamslider manifold``: the super-slow manifold by PCS continuation (docs/model.md §6) written as
CSV + JSON + figure."""

from __future__ import annotations

import argparse
import time
from typing import Any

from ..simulate import simulate
from ._common import add_common, figure, params_from_args, plan_outputs, write_json
from ._manifold import add_manifold_options, add_operating_point, check_manifold_args, manifold_name, run_manifold


def add_parser(sub: Any) -> None:
    """Register ``beamslider manifold``."""
    sp = sub.add_parser("manifold", help="super-slow manifold by PCS continuation",
                        description="Compute the super-slow manifold (upward and downward sweeps, docs/model.md §6) "
                                    "and write manifold_<f>Hz_<a>ms2_<N>periods.csv/.json/.png.")
    add_operating_point(sp)
    add_common(sp, force=True)
    add_manifold_options(sp, default_on=False)
    sp.set_defaults(func=cmd_manifold, manifold=True)


def cmd_manifold(args: argparse.Namespace) -> int:
    from ..plotting import plot_manifold

    p = params_from_args(args)
    stem = manifold_name(args, args.f_ex, args.a_ex)
    simulate(p, f_ex=args.f_ex, a_ex=args.a_ex, t_end=1.0, model="beam", _check_only=True)  # names bad input first
    check_manifold_args(args)
    out = plan_outputs(args, [f"{stem}.{ext}" for ext in ("csv", "json", "png")])
    t0 = time.perf_counter()
    m = run_manifold(args, p, args.f_ex, args.a_ex)
    write_json(out / f"{stem}.json", {
        "kind": "manifold", "f_ex_hz": m.f_ex, "a_ex_m_s2": m.a_ex, "periods": m.periods, "record": m.record,
        "up": {"s": m.up_s.tolist(), "amplitude_m": m.up_amplitude.tolist()},
        "down": {"s": m.down_s.tolist(), "amplitude_m": m.down_amplitude.tolist()},
        "counters": m.counters, "wall_time_s": time.perf_counter() - t0, "params_toml": p.toml_text(),
    })
    exts = ["csv", "json"] + (["png"] if figure(plot_manifold, m, path=out / f"{stem}.png") else [])
    for ext in exts:
        print(f"wrote {out / f'{stem}.{ext}'}")
    return 0
