"""Benchmark of the CLI's `simulate` end to end against the bare core run of the same
duration (record_every 1 and 10; target: CLI <= 2x core), the peak memory of a streamed 600-s
run (NPZ and Parquet), and a map on a LocalCluster of 2 workers against the local map.

    python scripts/bench/bench_output.py [--t-end 120] [--repeat 5] [--long 600] [--map-points 1000]
                                   [--map-t-end 0.5] [--skip cli long map] [--pythonpath DIR]

"Core" is the binding's in-memory run in this process (`beamslider.simulate`, the same six
channels at the same record_every, no file, no figure). "CLI" is what the README's main command
does, timed as a subprocess: `beamslider simulate --t-end T --record-every K --out DIR`, i.e.
interpreter start, imports, the run streamed to NPZ by Rust, the harmonic-balance manifold (the
default overlay) and the figure (the default), JSON and CSV files; the
same with `--manifold pcs` (the PCS continuation overlay, the earlier default) and with
`--no-manifold`. Figures are
medians of `--repeat` runs (CLI and core alternating); the load average is printed before and
after, since the machine may be shared. A breakdown of the CLI's work done one piece after the
other (`--skip breakdown` to leave it out) shows where the time goes. `--pythonpath DIR` times the
Python package found in DIR instead (e.g. an older checkout, with the same `_core` copied in).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

ENV = dict(os.environ)


def load() -> str:
    return "load average " + " ".join(f"{x:.2f}" for x in os.getloadavg())


def core_time(t_end: float, every: int) -> float:
    code = textwrap.dedent(f"""
        import time, beamslider
        beamslider.simulate(f_ex=124, a_ex=14, t_end=0.01, record_every=1)  # warm
        t0 = time.perf_counter()
        beamslider.simulate(f_ex=124, a_ex=14, s0=0.3, t_end={t_end}, record_every={every}, max_memory=1e12)
        print(time.perf_counter() - t0)
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=ENV)
    if r.returncode != 0:
        raise SystemExit(r.stderr)
    return float(r.stdout.strip().splitlines()[-1])


def cli_time(t_end: float, every: int, out: Path, extra: list) -> float:
    argv = [sys.executable, "-m", "beamslider", "simulate", "--t-end", str(t_end), "--record-every", str(every),
            "--out", str(out), "--force"] + list(extra)
    t0 = time.perf_counter()
    r = subprocess.run(argv, capture_output=True, text=True, env=ENV)
    wall = time.perf_counter() - t0
    if r.returncode != 0:
        raise SystemExit(r.stderr)
    if not (out / "fs_124Hz_14ms2_s0_0p3.png").exists():
        raise SystemExit("the CLI drew no figure")
    return wall


def breakdown(t_end: float, every: int, tmp: Path) -> str:
    """The CLI's pieces one after the other, in a fresh interpreter."""
    code = textwrap.dedent(f"""
        import time
        t0 = time.perf_counter()
        import beamslider.cli.simulate
        from beamslider import simulate, super_slow_manifold
        from beamslider.superslow import hb_manifold
        from beamslider.cli._files import simulation_summary
        t1 = time.perf_counter()
        r = simulate(f_ex=124, a_ex=14, t_end={t_end}, record_every={every}, out={str(tmp / 'bd.npz')!r},
                     overwrite=True)
        t2 = time.perf_counter()
        simulation_summary(r, t_end={t_end}, record_every={every}, wall_s=t2 - t1, window=1.0)
        t3 = time.perf_counter()
        m = hb_manifold(f_ex=124, a_ex=14)
        t3b = time.perf_counter()
        super_slow_manifold(f_ex=124, a_ex=14)
        t4 = time.perf_counter()
        import matplotlib.figure, matplotlib.backends.backend_agg
        from beamslider.plotting import plot_operating_point
        t5 = time.perf_counter()
        plot_operating_point(r, manifold=m, path={str(tmp / 'bd.png')!r})
        t6 = time.perf_counter()
        print(f"imports {{t1 - t0:.2f}} s, run streamed to NPZ {{t2 - t1:.2f}} s, summary {{t3 - t2:.2f}} s, "
              f"HB manifold {{t3b - t3:.3f}} s (PCS manifold {{t4 - t3b:.2f}} s, not in the default), matplotlib import {{t5 - t4:.2f}} s, figure {{t6 - t5:.2f}} s")
    """)
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=ENV)
    total = time.perf_counter() - t0
    if r.returncode != 0:
        raise SystemExit(r.stderr)
    return r.stdout.strip() + f" (process {total:.2f} s)"


def streamed_peak(t_end: float, out: Path) -> dict:
    """Peak RSS of a streamed run at record_every 1 (NPZ, or Parquet by the file name)."""
    code = textwrap.dedent(f"""
        import json, resource, time, beamslider
        base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        t0 = time.perf_counter()
        r = beamslider.simulate(f_ex=124, a_ex=14, t_end={t_end}, record_every=1, out={str(out)!r})
        wall = time.perf_counter() - t0
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # before any column is read
        print(json.dumps({{"rows": len(r.t), "wall_s": wall, "base_kib": base, "peak_kib": peak}}))
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=ENV)
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
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--long", type=float, default=600.0)
    ap.add_argument("--map-points", type=int, default=1000)
    ap.add_argument("--map-t-end", type=float, default=0.5)
    ap.add_argument("--skip", nargs="*", default=[], choices=["cli", "breakdown", "long", "parquet", "map"])
    ap.add_argument("--pythonpath", help="time the beamslider package found in this folder")
    a = ap.parse_args()
    if a.pythonpath:
        ENV["PYTHONPATH"] = os.path.abspath(a.pythonpath)
        sys.path.insert(0, ENV["PYTHONPATH"])
    print(f"{load()} at the start; {os.cpu_count()} cores")
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        if "cli" not in a.skip:
            for every in (1, 10):
                core, full, pcs, bare = [], [], [], []
                for _ in range(a.repeat):
                    core.append(core_time(a.t_end, every))
                    full.append(cli_time(a.t_end, every, tmp / f"cli{every}", []))
                    pcs.append(cli_time(a.t_end, every, tmp / f"pcs{every}", ["--manifold", "pcs"]))
                    bare.append(cli_time(a.t_end, every, tmp / f"bare{every}", ["--no-manifold"]))
                c, f, q, b = (statistics.median(x) for x in (core, full, pcs, bare))
                print(f"simulate {a.t_end:g} s, record_every {every} (medians of {a.repeat}): core {c:.2f} s; "
                      f"CLI end to end with the defaults (HB manifold and figure) {f:.2f} s = {f / c:.2f}x core "
                      f"(target <= 2x); with --manifold pcs {q:.2f} s = {q / c:.2f}x, with --no-manifold {b:.2f} s = "
                      f"{b / c:.2f}x; {load()}")
                if "breakdown" not in a.skip:
                    print(f"  one after the other: {breakdown(a.t_end, every, tmp)}")
        if "long" not in a.skip:
            for name in ("long.npz",) + (() if "parquet" in a.skip else ("long.parquet",)):
                d = streamed_peak(a.long, tmp / name)
                size = (tmp / name).stat().st_size
                print(f"streamed {a.long:g} s at record_every 1 to {name}: {d['rows']} rows, {size / 1e9:.2f} GB on disk "
                      f"in {d['wall_s']:.1f} s; peak RSS {d['peak_kib'] / 1024:.0f} MiB (after import "
                      f"{d['base_kib'] / 1024:.0f} MiB); {load()}")
                (tmp / name).unlink()
        if "map" not in a.skip:
            map_bench(a.map_points, a.map_t_end, tmp)
            print(load())


if __name__ == "__main__":
    main()
