#!/usr/bin/env python3
"""Benchmark: wall time of the paper's full operating map (docs/model.md §8, Fig. 11): 112 points,
f_ex = 100, 102, …, 130 Hz × a_ex = 4, 6, …, 16 m/s², s0 = 0.3, 120 s each, on all cores.

Usage:  python3 scripts/bench_map.py [--out docs] [--threads N] [--t-end 120]
Needs the installed package (pip install .). Writes into --out: operating_map.jsonl (results
rows), operating_map.txt (letter table with the wall time) and operating_map.png (the figure).
The same map from the Rust binary:  beamslider-batch map --out DIR  (cargo build --release).
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import beamslider
from beamslider.maps import RESULTS_FILE, plot_operating_map, text_table


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs", help="folder for operating_map.{jsonl,txt,png} (default docs)")
    ap.add_argument("--threads", type=int, default=None, help="worker threads (default: one per core)")
    ap.add_argument("--t-end", type=float, default=120.0, help="simulated time per point [s] (120)")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="bench-map-"))
    f_ex = np.arange(100.0, 131.0, 2.0)
    a_ex = np.arange(4.0, 17.0, 2.0)
    t0 = time.perf_counter()
    table = beamslider.operating_map(f_ex=f_ex, a_ex=a_ex, s0=0.3, t_end=args.t_end, threads=args.threads,
                                     out=work, progress=True)
    wall = time.perf_counter() - t0
    n = len(table["index"])
    cpu = float(table["wall_time_s"].sum())
    threads = args.threads or os.cpu_count()
    head = (f"paper's operating map: {n} points x {args.t_end:g} s, {threads} threads on {os.cpu_count()} cores: "
            f"wall time {wall:.1f} s (sum of per-point times {cpu:.1f} s, {cpu / n:.2f} s per point)")
    txt = head + "\n" + text_table(table)
    counts = {b: int((table["behaviour"] == b).sum()) for b in beamslider.maps.BEHAVIOURS}
    txt += "counts: " + ", ".join(f"{b} {c}" for b, c in counts.items()) + "\n"
    undetermined = np.flatnonzero(table["behaviour"] == "undetermined")
    for i in undetermined:
        txt += f"undetermined {table['f_ex_hz'][i]:g} Hz {table['a_ex_m_s2'][i]:g} m/s^2: {table['reason'][i]}\n"
    (out / "operating_map.txt").write_text(txt, encoding="utf-8")
    shutil.copy(work / RESULTS_FILE, out / "operating_map.jsonl")
    plot_operating_map(table, path=out / "operating_map.png",
                       title=f"operating map (model), $s_0$ = 0.3, {args.t_end:g} s per point")
    shutil.rmtree(work, ignore_errors=True)
    print(txt, end="")
    print(f"wrote {out / 'operating_map.txt'}, {out / 'operating_map.jsonl'}, {out / 'operating_map.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
