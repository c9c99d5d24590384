#!/usr/bin/env python3
"""How the right model fits data it made: the baseline's test statistics on nothing-hidden data drawn
as the discover benchmark draws them (docs/model.md §9.2), the null distribution of discover's
goodness of fit.

    python3 scripts/repro/discover_null_calibration.py [--seed 201] [--cases 60] [--out FILE.jsonl]

Each case synthesises the plan's runs of the prototype with its own noise seed and start offset
(the benchmark's "nothing hidden" cases) and tests the prototype's ensemble against them exactly as
discover's first step does: χ² over the n features, the largest |z| and the verdict of the test (a
failed test is a false alarm: discover then searches for an effect). The model's runs do not depend
on the data, so they are made once (kept in memory). Prints the share of false alarms, quantiles of
χ²/n, of the gap (RMS z) and of the largest |z|; ``--out`` keeps one JSON line a case.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time

import numpy as np

import beamslider as bs
from beamslider.discover import benchmark as bm
from beamslider.discover import models
from beamslider.discover.options import DEFAULT

try:  # the statistics' module
    from beamslider.discover.stats import baseline_test
except ImportError:  # pragma: no cover - the layout before the package's seam
    from beamslider.discover.fitting import baseline_test


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=201)
    ap.add_argument("--cases", type=int, default=60)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    plan = bm.Plan()
    base = bs.Parameters()
    cases = bm.draw_cases(args.seed, {"nothing": args.cases}, plan=plan)
    cache: dict = {}
    rows = []
    t0 = time.process_time()
    for c in cases:
        with tempfile.TemporaryDirectory() as tmp:
            runs = [bs.read_measurement(p) for p in bm.synthesize_case(c, plan, tmp)]
        meas, _, ops = models.measured_slider_features(runs)
        modes = models.data_modes(meas)
        ens = models.ensemble_slider_features([base], ops, modes=modes, cache=cache)[0]
        spread = {k: ens.spread.get(k, 0.0) for k in meas}
        t = baseline_test(ens.mean, meas, spread, len(DEFAULT.ensemble_s0_shifts), modes, ens.mode_counts)
        row = dict(index=c.index, noise_seed=c.noise_seed, s0_offset=c.s0_offset, chi2=t.chi2, n=t.n,
                   gap=t.gap, z_worst=t.z_worst, fits=bool(t.fits))
        rows.append(row)
        print(json.dumps(row), flush=True)
        if args.out:
            with open(args.out, "a", encoding="utf-8") as f:
                f.write(json.dumps(row) + "\n")
    chi2n = np.array([r["chi2"] / r["n"] for r in rows])
    gap = np.array([r["gap"] for r in rows])
    z = np.array([r["z_worst"] for r in rows])
    fails = sum(not r["fits"] for r in rows)
    q = (0.5, 0.9, 0.95, 0.99)
    print(f"{len(rows)} nothing-hidden cases (seed {args.seed}), n = {rows[0]['n']} features: "
          f"baseline test failed in {fails} ({100 * fails / len(rows):.1f} %: discover's false alarms before any search)")
    print("chi2/n quantiles", dict(zip(q, np.round(np.quantile(chi2n, q), 3))))
    print("gap (RMS z) quantiles", dict(zip(q, np.round(np.quantile(gap, q), 3))))
    print("largest |z| quantiles", dict(zip(q, np.round(np.quantile(z, q), 3))))
    print(f"{time.process_time() - t0:.0f} s CPU")
    return 0


if __name__ == "__main__":
    sys.exit(main())
