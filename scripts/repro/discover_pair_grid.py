#!/usr/bin/env python3
"""χ² of chosen models against a case of the discover table, as a fit scores them: the ensemble of
runs from s0 + DiscoverOptions.ensemble_s0_shifts at each point, its mean against the case's synthesized runs, the
uncertainties from the ensemble's spread, the mode terms (docs/model.md §9.1).

Usage:  python3 scripts/repro/discover_pair_grid.py --case pair-mu-f0 \
            --effects friction_coefficient,natural_frequency_detuning --points "0.24,0.985;0.2222,0.9875"

Prints per point χ², how many of the ensemble's runs end in the data's mode at each operating
point, and the z of each feature (NaN: a mode feature where no run is in the data's mode)."""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import beamslider as bs
from beamslider import discover as dc
from beamslider.discover.stats import chi2_terms
from beamslider.discover.models import data_modes, ensemble_slider_features, measured_slider_features

sys.path.insert(0, str(Path(__file__).resolve().parent))
import discover_table as table  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="pair-mu-f0", choices=sorted(table.CASES))
    ap.add_argument("--effects", default="friction_coefficient,natural_frequency_detuning")
    ap.add_argument("--points", required=True, help="values of the effects, ';' between points")
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--s0-offset", type=float, default=0.0015)
    args = ap.parse_args()
    effects = args.effects.split(",")
    unknown = [e for e in effects if e not in dc.EFFECTS]
    if unknown:
        print(f"error: unknown effect {unknown[0]!r}", file=sys.stderr)
        return 1
    pts = [tuple(float(v) for v in s.split(",")) for s in args.points.split(";") if s.strip()]
    if any(len(p) != len(effects) for p in pts):
        print(f"error: each point needs {len(effects)} values", file=sys.stderr)
        return 1
    truth = table.truth_of(table.CASES[args.case][1])
    params, chain = truth if isinstance(truth, tuple) else (truth, None)
    with tempfile.TemporaryDirectory() as tmp:
        paths = dc.synthesize_slider_runs(params, operating_points=table.OPS, duration_s=args.duration, out_dir=tmp,
                                          seed=3, s0_offset=args.s0_offset, chain=chain)
        runs = [bs.read_measurement(p) for p in paths]
    meas, _, ops = measured_slider_features(runs)
    modes = data_modes(meas)
    names = list(meas)
    y = np.array([meas[k].value for k in names])
    se = np.array([meas[k].stderr for k in names])
    c0 = time.process_time()
    ens = ensemble_slider_features([dc.realise_model(table.P, dict(zip(effects, p))) for p in pts], ops, modes=modes)
    for p, e in zip(pts, ens):
        if e is None:
            print(p, "runs failed")
            continue
        sig = np.sqrt(se ** 2 + (1 + 1 / e.runs) * np.array([e.spread.get(k, 0.0) for k in names]) ** 2)
        c2 = chi2_terms(e.mean, names, y, sig, modes, e.mode_counts, e.runs)
        z = " ".join(f"{k}={(e.mean.get(k, math.nan) - v) / s:.1f}" for k, v, s in zip(names, y, sig))
        print(f"{dict(zip(effects, p))}: chi2 {c2:.2f}; runs in the data's mode {e.mode_counts}; z {z}", flush=True)
    print(f"CPU {time.process_time() - c0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
