#!/usr/bin/env python3
"""Benchmark of an uncertainty study: samples per second locally (rayon through the Rust core) and on
a 2-worker Dask LocalCluster (2 processes x 1 thread, chunks of points as tasks).

The same study runs on both executors — Latin hypercube over μ ~ U[0.22, 0.31] and the natural
frequency factor ~ U[0.95, 1.05] at (124 Hz, 14 m/s², s0 = 0.3) — and the rows are checked to be
bitwise identical (apart from the wall time). Cluster start-up is timed separately and not counted.

    python3 scripts/bench/bench_study.py [--samples 24] [--duration 20] [--chunk-size 2]
"""

import argparse
import os
import tempfile
import time
from pathlib import Path

from beamslider.study import RESULTS_FILE, StudyConfig, Uncertain, read_results, run_study


def rows(path):
    _h, r, _g, _t = read_results(path)
    return sorted(({k: v for k, v in x.items() if k != "wall_time_s"} for x in r), key=lambda x: x["index"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=24)
    ap.add_argument("--duration", type=float, default=20.0, help="simulated seconds per run (paper: 120)")
    ap.add_argument("--chunk-size", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    cfg = StudyConfig(uncertain=[Uncertain("friction_coefficient", low=0.22, high=0.31),
                                 Uncertain("natural_frequency_factor", low=0.95, high=1.05)],
                      method="lhs", samples=args.samples, seed=11, duration_s=args.duration,
                      chunk_size=args.chunk_size)
    n = args.samples
    print(f"machine: {os.cpu_count()} cores; study: {n} samples x 1 operating point x {args.duration:g} s")
    run_study(StudyConfig(uncertain=cfg.uncertain, samples=2, duration_s=0.01))  # warm the imports (scipy.stats)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        t0 = time.perf_counter()
        run_study(cfg, out=tmp / "local")
        local = time.perf_counter() - t0
        print(f"local (rayon, {os.cpu_count()} threads):        {local:7.1f} s  {n / local:6.2f} samples/s")

        from distributed import Client, LocalCluster

        t0 = time.perf_counter()
        with LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            client.run(lambda: __import__("beamslider.study"))  # warm the workers' imports
            startup = time.perf_counter() - t0
            t0 = time.perf_counter()
            run_study(cfg, out=tmp / "dask", scheduler=client)
            dask = time.perf_counter() - t0
        print(f"Dask LocalCluster ({args.workers} workers x 1 thread): {dask:7.1f} s  {n / dask:6.2f} samples/s "
              f"(chunks of {args.chunk_size}; cluster start-up {startup:.1f} s not counted)")
        same = rows(tmp / "local" / RESULTS_FILE) == rows(tmp / "dask" / RESULTS_FILE)
        print(f"rows bitwise identical (apart from wall_time_s): {same}")
        print(f"simulated time per wall second: local {n * args.duration / local:.1f}, Dask {n * args.duration / dask:.1f}")


if __name__ == "__main__":
    main()
