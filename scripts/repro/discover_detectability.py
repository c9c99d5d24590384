#!/usr/bin/env python3
"""Whether a hidden change is visible in the discover table's runs at all: the baseline's test
(docs/model.md §9.1: χ² against its 99 % quantile and the |z| bound) on runs of a truth, repeated
over slider start offsets (the noise seed barely moves the features) and noise seeds, beside the
same test on runs of the prototype itself.

A change the runs do not see passes the baseline's test about as often as the prototype does; no
verdict other than "none" can then be asked of discover (a rule that said "unexplained" there
would say it as often for the prototype's own runs).

Usage:  python3 scripts/repro/discover_detectability.py [--truths "restitution=0.3;restitution=0.1;restitution=0.7"]
                                                  [--seeds 3] [--s0-offsets=-0.003,...,0.003] [--duration 60]
                                                  [--out docs/results/discover/detectability.md]

``--truths``: ";"-separated truths, each ","-separated ``effect=value`` pairs (effect names of
docs/model.md §9.1; an empty truth is the prototype, always included). Data as the table's
(scripts/repro/discover_table.py): the three reference operating points, s noise 0.001.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Dict, List

import numpy as np

import beamslider as bs
from beamslider import discover as dc
from beamslider.discover import models, stats
from beamslider.discover.options import DEFAULT

OPS = [(104.0, 14.0, 0.3), (126.0, 10.0, 0.3), (124.0, 14.0, 0.3)]
P = bs.Parameters()


def baseline_test(runs) -> Dict[str, float]:
    """The baseline's test as `discover` makes it before any fit: χ², feature count, the largest
    |z|, the 99 % quantile, adequacy, the gap beyond the noise (`discover.stats.baseline_test`)."""
    meas, _, ops = models.measured_slider_features(runs)
    modes = models.data_modes(meas) if DEFAULT.mode_conditioning else None
    ens = models.ensemble_slider_features([P], ops, modes=modes)[0]
    if ens is None:
        raise bs.SimulationError("the prototype's runs failed")
    t = stats.baseline_test(ens.mean, meas, ens.spread, len(DEFAULT.ensemble_s0_shifts), modes, ens.mode_counts)
    return dict(chi2=t.chi2, n=t.n, z=t.z_worst, limit=stats.chi2_quantile(t.n), fits=t.fits,
                excess=stats.excess(t.chi2, t.n, t.n))


def parse_truth(text: str) -> Dict[str, float]:
    out = {}
    for kv in filter(None, (s.strip() for s in text.split(","))):
        name, _, value = kv.partition("=")
        if name not in dc.EFFECTS:
            raise SystemExit(f"error: unknown effect {name!r}: known are {', '.join(dc.EFFECTS)}")
        out[name] = float(value)
    return out


def parse_seeds(text: str) -> List[int]:
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--truths", default="restitution=0.3;restitution=0.1;restitution=0.7")
    ap.add_argument("--seeds", default="3", help="noise seeds: a range a-b or a comma list (3)")
    ap.add_argument("--s0-offsets", default="-0.003,-0.002,-0.001,0.0005,0.001,0.0015,0.002,0.003",
                    help="the truth runs start this far off the s0 their files name (comma list)")
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--out", type=Path, default=None, help="write the table (markdown) there")
    args = ap.parse_args()
    truths = [{}] + [parse_truth(t) for t in args.truths.split(";") if t.strip()]
    seeds = parse_seeds(args.seeds)
    offsets = [float(v) for v in args.s0_offsets.split(",")]
    rows = ["| hidden truth | runs (seed × s0 offset) | baseline passes | χ² median [min, max] | max \\|z\\| median | "
            "gap beyond the noise median | χ² limit |", "|---|---|---|---|---|---|---|"]
    t0, c0 = time.perf_counter(), time.process_time()
    for truth in truths:
        m = dc.realise_model(P, truth)
        res: List[Dict[str, float]] = []
        for off in offsets:
            for seed in seeds:
                with tempfile.TemporaryDirectory() as tmp:
                    paths = dc.synthesize_slider_runs(m.params, operating_points=OPS, duration_s=args.duration,
                                                      out_dir=tmp, seed=seed, s0_offset=off,
                                                      chain=dict(m.chain) or None)
                    r = baseline_test([bs.read_measurement(p) for p in paths])
                res.append(r)
                print(f"{truth or 'prototype'} seed {seed} offset {off:g}: chi2 {r['chi2']:.1f}/{r['n']} "
                      f"(limit {r['limit']:.1f}) |z| {r['z']:.2f} fits {r['fits']}", flush=True)
        c2 = np.array([r["chi2"] for r in res])
        label = ", ".join(f"{k} {v:g}" for k, v in truth.items()) or "nothing (the prototype)"
        rows.append(f"| {label} | {len(res)} | {sum(bool(r['fits']) for r in res)} of {len(res)} | "
                    f"{np.median(c2):.1f} [{c2.min():.1f}, {c2.max():.1f}] | "
                    f"{np.median([r['z'] for r in res]):.2f} | {np.median([r['excess'] for r in res]):.2f} | "
                    f"{np.median([r['limit'] for r in res]):.1f} |")
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    text = (f"# Which hidden changes the table's runs see\n\nThe baseline's test on runs of each truth (scripts/repro/discover_detectability.py --truths "
            f"\"{args.truths}\" --seeds {args.seeds} --s0-offsets={args.s0_offsets} --duration {args.duration:g}): "
            f"the three reference operating points {OPS}, s noise 0.001; {wall:.0f} s wall, {cpu:.0f} s CPU on "
            f"{os.cpu_count()} cores.\n\n" + "\n".join(rows) + "\n")
    print(text)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
