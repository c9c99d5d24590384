#!/usr/bin/env python3
"""The paper's start-position pair (Fig. 12, "var_start_pos"): the operating map
(f_ex = 100, 102, …, 130 Hz × a_ex = 4, 6, …, 16 m/s², 120 s) from s0 = 0.3 and from s0 = 0.4,
side by side, with the points whose behaviour changes with s0 outlined.

Usage:  python3 scripts/repro/start_position_pair.py [--work DIR] [--out docs/results] [--threads N] [--t-end 120]
Needs the installed package (pip install . or maturin develop --release). The two maps run in
DIR/s0_0.3 and DIR/s0_0.4 (resumable: run the script again after a kill). Writes into --out:
operating_map.{jsonl,txt,png} (s0 = 0.3, the paper's map), operating_map_s0.4.{jsonl,txt,png} and
start_position_pair.{png,txt} (both maps, the changed points and their reasons).
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import time
from pathlib import Path

import numpy as np

import beamslider
from beamslider.maps import (BEHAVIOURS, RESULTS_FILE, changed_with_s0, plot_operating_map, read_map,
                             t_end_text, text_table)

F_EX = np.arange(100.0, 131.0, 2.0)
A_EX = np.arange(4.0, 17.0, 2.0)


def summary(table, s0: float) -> str:
    m = table["s0"] == s0
    counts = {b: int((table["behaviour"][m] == b).sum()) for b in BEHAVIOURS}
    lines = ["counts: " + ", ".join(f"{b} {c}" for b, c in counts.items())]
    for i in np.flatnonzero(m & np.isin(table["behaviour"], ["undetermined", "not_settled"])):
        lines.append(f"{table['behaviour'][i]} {table['f_ex_hz'][i]:g} Hz {table['a_ex_m_s2'][i]:g} m/s^2: "
                     f"{table['reason'][i]}")
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default="start-position-work", help="folder for the resumable map runs")
    ap.add_argument("--out", default="docs/results", help="folder for the figures, tables and results (docs/results)")
    ap.add_argument("--threads", type=int, default=None, help="worker threads (default: one per core)")
    ap.add_argument("--t-end", type=float, default=120.0, help="simulated time per point [s] (120)")
    args = ap.parse_args()
    out, work = Path(args.out), Path(args.work)
    out.mkdir(parents=True, exist_ok=True)
    tables = {}
    for s0 in (0.3, 0.4):
        folder = work / f"s0_{s0:g}"
        t0 = time.perf_counter()
        tables[s0] = beamslider.operating_map(f_ex=F_EX, a_ex=A_EX, s0=s0, t_end=args.t_end, threads=args.threads,
                                              out=folder, resume=(folder / RESULTS_FILE).exists(), progress=True)
        wall = time.perf_counter() - t0
        t = tables[s0]
        stem = "operating_map" if s0 == 0.3 else f"operating_map_s0.{str(s0).split('.')[1]}"
        head = (f"operating map (model): {len(t['index'])} points, s0 = {s0:g}, {t_end_text(t)}; this call "
                f"{wall:.1f} s on {args.threads or os.cpu_count()} threads (sum of per-point times "
                f"{float(t['wall_time_s'].sum()):.1f} s)\n")
        (out / f"{stem}.txt").write_text(head + text_table(t) + summary(t, s0), encoding="utf-8")
        shutil.copy(folder / RESULTS_FILE, out / f"{stem}.jsonl")
        plot_operating_map(t, path=out / f"{stem}.png")
    both = {k: np.concatenate([tables[0.3][k], tables[0.4][k]]) for k in tables[0.3]}
    changed = changed_with_s0(both)
    plot_operating_map(both, path=out / "start_position_pair.png", mark_changes=True,
                       title=f"operating map from $s_0$ = 0.3 and 0.4, {t_end_text(both)} (outlined: "
                             f"behaviour changes with $s_0$)")
    lines = [f"start-position pair: s0 = 0.3 and 0.4, {t_end_text(both)}", text_table(both).rstrip("\n"),
             f"{len(changed)} of {len(F_EX) * len(A_EX)} points change behaviour with s0:"]
    for f, a in changed:
        r = {s0: np.flatnonzero((tables[s0]["f_ex_hz"] == f) & (tables[s0]["a_ex_m_s2"] == a))[0] for s0 in tables}
        lines.append(f"  {f:g} Hz {a:g} m/s^2: s0 = 0.3 {tables[0.3]['behaviour'][r[0.3]]} "
                     f"({tables[0.3]['reason'][r[0.3]]}); s0 = 0.4 {tables[0.4]['behaviour'][r[0.4]]} "
                     f"({tables[0.4]['reason'][r[0.4]]})")
    (out / "start_position_pair.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))
    print(f"wrote {out}/operating_map.*, {out}/operating_map_s0.4.*, {out}/start_position_pair.{{png,txt}}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
