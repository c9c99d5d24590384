"""Speed of the predictor for a new design (docs/model.md §6.5): everything that a new
:class:`beamslider.Parameters` needs (the built-in design law's blend for it in the core, the HB
manifolds and the slow flows: ``predicted_map(p, drift=<DesignLaw>)``) for the two-level band of the design search (a_ex 10 and 14 m/s², 100–130 Hz step
2, s0 0.3, 120 s: 32 points), on one thread.

    python scripts/bench/bench_design_law.py [--designs 20] [--seed 7]

Prints the median and the range over designs drawn over the box (none of them a training design),
and the machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

from beamslider.maps import predicted_map
from beamslider.params import native
from beamslider.superslow import default_law, design_params, design_sample


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=20)
    ap.add_argument("--seed", type=int, default=7)
    a = ap.parse_args()
    t0 = time.perf_counter()
    law = default_law()
    law.core()  # the core's handle: the file parsed once
    t_load = time.perf_counter() - t0
    f = [100.0 + 2 * i for i in range(16)]
    times, blends = [], []
    predicted_map(design_params(design_sample(1, seed=a.seed + 1)[0]), drift=law, f_ex=f, a_ex=[10.0, 14.0], threads=1)
    for x in design_sample(a.designs, seed=a.seed, method="lhs"):
        p = design_params(x)
        t0 = time.perf_counter()
        rows = predicted_map(p, drift=law, f_ex=f, a_ex=[10.0, 14.0], s0=0.3, t_end=120.0, threads=1)
        t1 = time.perf_counter()
        law.core().law_for(native(p))  # the blend alone (and its law file's JSON text), for the record
        t2 = time.perf_counter()
        assert len(rows) == 32
        times.append(t1 - t0)
        blends.append(t2 - t1)
    cpu = platform.processor() or platform.machine()
    print(f"machine: {os.cpu_count()} cores, {cpu}, Python {platform.python_version()}")
    print(f"design law read once: {1e3 * t_load:.0f} ms ({len(law.laws)} designs)")
    print(f"new design, 32-point two-level band, one thread: median {1e3 * statistics.median(times):.1f} ms "
          f"(min {1e3 * min(times):.1f}, max {1e3 * max(times):.1f}; {len(times)} designs); the law's "
          f"blend alone median {1e3 * statistics.median(blends):.1f} ms")


if __name__ == "__main__":
    main()
