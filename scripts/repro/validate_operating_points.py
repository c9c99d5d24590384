#!/usr/bin/env python3
"""Validation of the four representative operating points of docs/model.md §8 (paper, section 4).

Runs the free-slider model for 120 s from s0 = 0.3 at
  (124 Hz, 14 m/s²) signature move, (104 Hz, 14 m/s²) trivial adaption,
  (126 Hz, 10 m/s²) relaxation oscillation, (124 Hz, 6 m/s²) self-damping,
computes the PCS super-slow manifold at each excitation, and writes for each the paper's
three-panel figure (PNG), the run summary (JSON) and the manifold (CSV) into the output folder,
plus summary.json with a few numbers per point to judge the behaviour by.

Usage:  python3 scripts/repro/validate_operating_points.py [--out validation-out] [--t-end 120]
                                                    [--manifold-periods 100]
Needs the installed package (pip install .). Takes a few minutes.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

import beamslider
from beamslider.cli import manifold_stem, simulation_stem, write_json, write_manifold_csv
from beamslider.plotting import plot_operating_point

POINTS = [
    (124.0, 14.0, "signature move"),
    (104.0, 14.0, "trivial adaption"),
    (126.0, 10.0, "relaxation oscillation"),
    (124.0, 6.0, "self-damping"),
]


def describe(result: beamslider.SimulationResult) -> dict:
    """Numbers that tell the §8 behaviours apart: s extremes and where they happen, envelope
    levels, and the number of jumps of the envelope between low and high."""
    h = result.params.thickness_m
    env = result.envelope(1.0) / h
    t, s = result.t, result.s
    i_min, i_max = int(np.argmin(s)), int(np.argmax(s))
    # Jumps: crossings of the mid level between the 10th and 90th percentile of the envelope.
    lo, hi = np.percentile(env, [10, 90])
    crossings = 0
    if hi > 2 * lo + 0.05:
        mid = 0.5 * (lo + hi)
        above = env > mid
        # ignore chatter: look at 0.5 s decimated samples
        step = max(1, int(round(0.5 / result.dt_record)))
        a = above[::step]
        crossings = int(np.count_nonzero(a[1:] != a[:-1]))
    return {
        "s0": float(s[0]),
        "s_min": float(s[i_min]),
        "t_at_s_min": float(t[i_min]),
        "s_max": float(s[i_max]),
        "t_at_s_max": float(t[i_max]),
        "s_final": float(s[-1]),
        "amplitude_over_h_initial_1s": float(np.mean(env[t < 1.0])),
        "amplitude_over_h_max": float(env.max()),
        "amplitude_over_h_final": float(env[-1]),
        "mid_level_crossings": crossings,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="validation-out", help="output folder (default ./validation-out)")
    ap.add_argument("--t-end", type=float, default=120.0, help="simulated time per point [s] (120)")
    ap.add_argument("--s0", type=float, default=0.3, help="initial slider position (0.3)")
    ap.add_argument("--manifold-periods", type=int, default=100, help="periods per s on the manifold (100)")
    ap.add_argument("--no-progress", dest="progress", action="store_false")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    summary = {}
    for f_ex, a_ex, expected in POINTS:
        t0 = time.perf_counter()
        r = beamslider.simulate(f_ex=f_ex, a_ex=a_ex, s0=args.s0, t_end=args.t_end, record_every=10,
                                progress=args.progress)
        m = beamslider.super_slow_manifold(f_ex=f_ex, a_ex=a_ex, periods=args.manifold_periods,
                                           record=min(25, args.manifold_periods), progress=args.progress)
        wall = time.perf_counter() - t0
        stem = simulation_stem(r)
        write_manifold_csv(out / f"{manifold_stem(m)}.csv", m)
        numbers = describe(r)
        numbers.update({"expected": expected, "status": r.status, "wall_time_s": wall})
        write_json(out / f"{stem}.json", {**numbers, "counters": r.counters})
        plot_operating_point(r, manifold=m, path=out / f"{stem}.png",
                             title=f"f_ex = {f_ex:g} Hz, a_ex = {a_ex:g} m/s², s₀ = {args.s0:g} "
                                   f"(paper: {expected})")
        summary[f"{f_ex:g}Hz_{a_ex:g}ms2"] = numbers
        print(f"{f_ex:g} Hz {a_ex:g} m/s² ({expected}): {r.status}, s {numbers['s0']:.3f} -> "
              f"min {numbers['s_min']:.3f} @ {numbers['t_at_s_min']:.1f} s, max {numbers['s_max']:.3f} -> "
              f"final {numbers['s_final']:.3f}; amplitude/h {numbers['amplitude_over_h_initial_1s']:.3f} -> "
              f"max {numbers['amplitude_over_h_max']:.3f}, final {numbers['amplitude_over_h_final']:.3f}; "
              f"{numbers['mid_level_crossings']} jumps ({wall:.1f} s)", flush=True)
    write_json(out / "summary.json", summary)
    print(f"wrote {out}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
