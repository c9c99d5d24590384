"""Speed of the predictor for a new design (docs/model.md §6.5): everything that a new
:class:`beamslider.Parameters` needs (the built-in design law's blend for it in the core, the HB
manifolds and the slow flows: ``predicted_map(p, drift=<DesignLaw>)``) for the two-level band of the
design search (a_ex 10 and 14 m/s², 100–130 Hz step 2, s0 0.3, 120 s: 32 points), on one thread;
with ``--search``, the whole predictor design search of ``docs/results/design_law/search.toml``
(``beamslider design`` without its FS re-checks) on ``--threads`` threads.

    python scripts/bench/bench_design_law.py [--designs 20] [--seed 7]
    python scripts/bench/bench_design_law.py --search [--threads 2] [--maxiter N]

Prints the median and the range over designs drawn over the box (none of them a training design),
in wall time and in the process's CPU time (all its threads: with one thread the wall time of an
idle machine; the machine's load average is printed beside them), and the machine. The tabulation
of the training laws on the blend's grid (once per process, at each law's first blend) is done and
reported first, apart.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path

from beamslider.superslow import predicted_map
from beamslider.params import native
from beamslider.superslow import default_law, design_params, design_sample

ROOT = Path(__file__).resolve().parents[2]
SEARCH = ROOT / "docs" / "results" / "design_law" / "search.toml"


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"machine: {os.cpu_count()} cores, {cpu}, Python {platform.python_version()}"


def load() -> str:
    try:
        return "load average %.2f %.2f %.2f" % os.getloadavg()
    except OSError:
        return "load average unknown"


def band(a: argparse.Namespace) -> None:
    t0 = time.perf_counter()
    law = default_law()
    law.core()  # the core's handle: the file parsed once
    t_load = time.perf_counter() - t0
    f = [100.0 + 2 * i for i in range(16)]
    print(machine())
    print(f"before: {load()}")
    print(f"design law read once: {1e3 * t_load:.0f} ms ({len(law.laws)} designs)")
    # Each training law is tabulated on the blend's grid at its first blend (once per process, not
    # per design): blend a design next to every training design first, so that the bands below
    # measure what a new design needs.
    w0, c0 = time.perf_counter(), time.process_time()
    for xi in law.x:
        near = {c.name: c.value(c.unit(xi[c.name]) + 1e-3 * (0.5 - c.unit(xi[c.name]))) for c in law.box}
        law.core().law_for(native(design_params(near)))
    print(f"training laws tabulated on the blend's grid (once per process): {1e3 * (time.perf_counter() - w0):.0f} ms wall, "
          f"{1e3 * (time.process_time() - c0):.0f} ms CPU")
    predicted_map(design_params(design_sample(1, seed=a.seed + 1)[0]), drift=law, f_ex=f, a_ex=[10.0, 14.0], threads=1)
    wall, cpu, blends = [], [], []
    for x in design_sample(a.designs, seed=a.seed, method="lhs"):
        p = design_params(x)
        t0, c0 = time.perf_counter(), time.process_time()
        rows = predicted_map(p, drift=law, f_ex=f, a_ex=[10.0, 14.0], s0=0.3, t_end=120.0, threads=1)
        t1, c1 = time.perf_counter(), time.process_time()
        law.core().law_for(native(p))  # the blend alone (and its law file's JSON text), for the record
        t2 = time.perf_counter()
        assert len(rows) == 32
        wall.append(t1 - t0)
        cpu.append(c1 - c0)
        blends.append(t2 - t1)
    ms = lambda v: f"median {1e3 * statistics.median(v):.1f} ms (min {1e3 * min(v):.1f}, max {1e3 * max(v):.1f})"
    print(f"new design, 32-point two-level band, one thread, {len(wall)} designs: wall {ms(wall)}; "
          f"CPU {ms(cpu)}; the law's blend alone (with its JSON text) median {1e3 * statistics.median(blends):.1f} ms")
    print(f"after: {load()}")


def search(a: argparse.Namespace) -> None:
    from beamslider.design import optimise, read_config

    c = read_config(a.config)
    if a.maxiter is not None:
        c.maxiter = a.maxiter
    print(machine())
    print(f"before: {load()}")
    n = c.popsize * len(c.variables)
    print(f"predictor design search {a.config} (no FS re-checks): {len(c.variables)} variables, "
          f"{n} designs per generation, {c.maxiter} generations, {len(c.samples_values())} samples, "
          f"{len(c.operating_points())} points per sample, {a.threads} threads")
    with tempfile.TemporaryDirectory() as tmp:
        t0, c0 = time.perf_counter(), time.process_time()
        res = optimise(c, out=tmp, threads=a.threads, checks=False)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(f"search: wall {wall:.1f} s ({wall / 60:.2f} min), CPU {cpu:.1f} s; {res.evaluated_now} designs, "
          f"{res.runs_now} predicted points ({1e3 * wall / max(res.runs_now, 1):.3f} ms wall per point); "
          f"best {res.best.get('bandwidth_hz')} Hz")
    print(f"after: {load()}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=20)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--search", action="store_true", help="time the predictor design search instead")
    ap.add_argument("--config", default=str(SEARCH), help="the search's configuration (default: %(default)s)")
    ap.add_argument("--threads", type=int, default=2, help="threads of the search (default 2)")
    ap.add_argument("--maxiter", type=int, help="generations of the search (default: the configuration's)")
    a = ap.parse_args()
    search(a) if a.search else band(a)


if __name__ == "__main__":
    main()
