#!/usr/bin/env python3
"""How well the excitation frequency as recorded (`f_recorded`, docs/model.md §9.1) is estimated:
synthetic 60-s runs of the prototype (sensor noise, truth from s0 + 0.0015) at six operating points,
written with an exact time base and with τ = 1.004; per run the estimate, its standard error and its
relative error against f_ex/τ.

Usage:  python3 scripts/repro/discover_recorded_frequency.py [--duration 60] [--tau 1.004]
"""

from __future__ import annotations

import argparse
import sys
import tempfile

import beamslider as bs
from beamslider import discover as dc
from beamslider.discover.features import recorded_frequency

OPS = [(104, 14, 0.3), (126, 10, 0.3), (124, 14, 0.3), (110, 10, 0.3), (124, 6, 0.3), (116, 10, 0.3)]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--tau", type=float, default=1.004)
    args = ap.parse_args()
    print("tau  f_ex  a_ex  recorded [Hz]  stderr [Hz]  relative error  z")
    worst = 0.0
    for tau in (1.0, args.tau):
        with tempfile.TemporaryDirectory() as tmp:
            paths = dc.synthesize_slider_runs(bs.Parameters(), operating_points=OPS, duration_s=args.duration,
                                              out_dir=tmp, seed=3, s0_offset=0.0015, chain={"time_base": tau})
            for p in paths:
                m = bs.read_measurement(p)
                f, se = recorded_frequency(m.t, m.velocity, m.f_ex)
                rel = f * tau / m.f_ex - 1
                worst = max(worst, abs(rel))
                print(f"{tau:g}  {m.f_ex:g}  {m.a_ex:g}  {f:.6f}  {se:.2e}  {rel:+.2e}  {(f - m.f_ex / tau) / se:+.2f}")
    print(f"largest relative error: {worst:.2e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
