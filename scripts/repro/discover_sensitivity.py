#!/usr/bin/env python3
"""Why a single model run cannot fit the final state of a long free-slider run: the profile
chi2(mu) of synthetic mu = 0.26 data on a fine grid, and the spread of the features under
perturbations the data cannot resolve (s0 by +-0.001, +-0.002; mu by +-2e-4, +-5e-4).

Usage:  python3 scripts/repro/discover_sensitivity.py [--duration 60] [--threads 2] [--out docs/results/discover/sensitivity.md]

Data: `synthesize_slider_runs` of mu = 0.26 at the three reference points (104, 14), (126, 10),
(124, 14) m/s^2, s0 = 0.3, s noise 0.001, seed 3; the model runs go through the core's batch runner
(the features of `beamslider.discover`, measurement uncertainties only, no model spread).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import beamslider as bs
from beamslider import discover as dc
from beamslider.discover.models import batch_slider_features, measured_slider_features

OPS = [(104.0, 14.0, 0.3), (126.0, 10.0, 0.3), (124.0, 14.0, 0.3)]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--out", type=Path, default=Path("docs/results/discover/sensitivity.md"))
    ap.add_argument("--force", action="store_true", help="overwrite --out")
    a = ap.parse_args()
    if a.out.exists() and not a.force:
        print(f"error: {a.out} exists (use --force to overwrite)", file=sys.stderr)
        return 1
    P = bs.Parameters()
    mu_of = lambda m: bs.Parameters(**{**P.to_dict(), "friction_coefficient": float(m)})  # noqa: E731
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        paths = dc.synthesize_slider_runs(mu_of(0.26), operating_points=OPS, duration_s=a.duration, out_dir=tmp, seed=3)
        meas, _, ops = measured_slider_features([bs.read_measurement(p) for p in paths])
    keys = list(meas)
    short = [k.split("@")[0].replace("amplitude_final_h", "A_final").replace("speed_", "v_") + "@" + k.split("@")[1][:3]
             for k in keys]
    mus = np.round(np.arange(0.240, 0.2801, 0.0025), 5)
    scan = batch_slider_features([mu_of(m) for m in mus], ops, threads=a.threads)
    lines = [f"Sensitivity of the slider-level features ({a.duration:g}-s runs; `python3 scripts/repro/discover_sensitivity.py`). "
             f"Data: mu = 0.26 synthesised at {OPS} (f_ex Hz, a_ex m/s², s0), s noise 0.001, seed 3.", "",
             "## 1. Profile of one run per mu (z = (model − measured)/measurement uncertainty)", "",
             "| mu | chi2 | " + " | ".join(short) + " |", "|---|---|" + "---|" * len(keys)]
    for m, r in zip(mus, scan):
        z = [((r[0][k].value - meas[k].value) / meas[k].stderr) if r and k in r[0] else float("nan") for k in keys]
        chi2 = float(np.nansum(np.square(z))) + 25.0 * int(np.isnan(z).sum())
        lines.append(f"| {m:.4f} | {chi2:.4g} | " + " | ".join("—" if np.isnan(v) else f"{v:+.1f}" for v in z) + " |")
    rows = [(mu, ds, dmu) for mu in (0.26, 0.25, 0.2) for ds, dmu in
            [(0.0, 0.0), (-0.002, 0.0), (-0.001, 0.0), (0.001, 0.0), (0.002, 0.0),
             (0.0, -5e-4), (0.0, -2e-4), (0.0, 2e-4), (0.0, 5e-4)]]
    pert = batch_slider_features([mu_of(mu + dmu) for mu, _, dmu in rows], ops, s0_shifts=[r[1] for r in rows],
                                 threads=a.threads)
    lines += ["", "## 2. Features under perturbations the data cannot resolve", "",
              "Values; the last row of each block: the spread (standard deviation) over the block and, in "
              "parentheses, the measurement uncertainty of that feature.", "",
              "| mu | Δs0 | Δmu | " + " | ".join(short) + " |", "|---|---|---|" + "---|" * len(keys)]
    for b in range(3):
        block = list(zip(rows[9 * b:9 * b + 9], pert[9 * b:9 * b + 9]))
        for (mu, ds, dmu), r in block:
            lines.append(f"| {mu:.2f} | {ds:+.3f} | {dmu:+.4f} | " + " | ".join(
                f"{r[0][k].value:.4f}" if r and k in r[0] else "—" for k in keys) + " |")
        sd = []
        for k in keys:
            v = [r[0][k].value for _, r in block if r and k in r[0]]
            sd.append(f"{np.std(v, ddof=1):.2g} ({meas[k].stderr:.2g})" if len(v) > 1 else "—")
        lines.append(f"| **spread** | | | " + " | ".join(sd) + " |")
    lines += ["", f"{len(mus) * 3 + len(rows) * 3} runs, {time.perf_counter() - t0:.0f} s wall."]
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
