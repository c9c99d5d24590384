"""Benchmark of issue 18: the CLI's `simulate` end to end against the bare core run of the same
duration (record_every 1 and 10; target: CLI <= 2x core), the peak memory of a streamed 600-s
run, and a map on a LocalCluster of 2 workers against the local map.

    python scripts/bench_output.py [--t-end 120] [--long 600] [--map-points 1000] [--map-t-end 0.5]

"Core" is beamslider-batch-free: the binding's in-memory run without any output (the time loop
and the recorder), timed in this process. The CLI is timed as a subprocess (interpreter start,
import, run, NPZ written by Rust, JSON, figure).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path


def core_time(t_end: float, every: int) -> float:
    import beamslider

    t0 = time.perf_counter()
    beamslider.simulate(f_ex=124, a_ex=14, s0=0.3, t_end=t_end, record_every=every, max_memory=1e12)
    return time.perf_counter() - t0


def cli_time(t_end: float, every: int, out: Path) -> float:
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "beamslider", "simulate", "--t-end", str(t_end), "--record-every",
                        str(every), "--no-manifold", "--no-progress", "--out", str(out)], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if r.returncode != 0:
        raise SystemExit(r.stderr)
    return wall


def streamed_peak(t_end: float, out: Path) -> dict:
    code = textwrap.dedent(f"""
        import json, resource, time, beamslider
        base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        t0 = time.perf_counter()
        r = beamslider.simulate(f_ex=124, a_ex=14, t_end={t_end}, record_every=1, out={str(out)!r})
        wall = time.perf_counter() - t0
        print(json.dumps({{"rows": len(r.t), "wall_s": wall, "base_kib": base,
                           "peak_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}}))
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(r.stderr)
    return json.loads(r.stdout.strip().splitlines()[-1])


def map_bench(points: int, t_end: float, tmp: Path) -> None:
    import numpy as np
    import beamslider
    from distributed import Client, LocalCluster

    n_f = int(np.ceil(np.sqrt(points)))
    f_ex = list(np.round(np.linspace(100, 130, n_f), 4))
    a_ex = list(np.round(np.linspace(4, 16, int(np.ceil(points / n_f))), 4))
    n = len(f_ex) * len(a_ex)
    t0 = time.perf_counter()
    local = beamslider.operating_map(f_ex=f_ex, a_ex=a_ex, t_end=t_end, out=tmp / "local", threads=2)
    t_local = time.perf_counter() - t0
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c, Client(c) as cl:
        t0 = time.perf_counter()
        remote = beamslider.operating_map(f_ex=f_ex, a_ex=a_ex, t_end=t_end, out=tmp / "dask", scheduler=cl,
                                          chunk_size=25)
        t_dask = time.perf_counter() - t0
    def equal(a, b):
        if a.dtype.kind == "f":
            return np.array_equal(a, b, equal_nan=True)
        if a.dtype == object:
            return all(list(x) == list(y) for x, y in zip(a, b))
        return np.array_equal(a, b)

    same = all(equal(local[k], remote[k]) for k in local if k != "wall_time_s")
    print(f"map of {n} points, t_end = {t_end:g} s: local (2 threads) {t_local:.1f} s, "
          f"LocalCluster (2 workers x 1 thread, chunks of 25) {t_dask:.1f} s; rows equal: {same}")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--t-end", type=float, default=120.0)
    ap.add_argument("--long", type=float, default=600.0)
    ap.add_argument("--map-points", type=int, default=1000)
    ap.add_argument("--map-t-end", type=float, default=0.5)
    ap.add_argument("--skip", nargs="*", default=[], choices=["cli", "long", "map"])
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        if "cli" not in a.skip:
            for every in (1, 10):
                core = core_time(a.t_end, every)
                cli = cli_time(a.t_end, every, tmp / f"cli{every}")
                print(f"simulate {a.t_end:g} s, record_every {every}: core {core:.2f} s, CLI end to end {cli:.2f} s "
                      f"= {cli / core:.2f}x core (target <= 2x)")
        if "long" not in a.skip:
            d = streamed_peak(a.long, tmp / "long.npz")
            size = (tmp / "long.npz").stat().st_size
            print(f"streamed {a.long:g} s at record_every 1: {d['rows']} rows, {size / 1e9:.2f} GB on disk in "
                  f"{d['wall_s']:.1f} s; peak RSS {d['peak_kib'] / 1024:.0f} MiB (after import {d['base_kib'] / 1024:.0f} MiB)")
        if "map" not in a.skip:
            map_bench(a.map_points, a.map_t_end, tmp)


if __name__ == "__main__":
    main()
