#!/usr/bin/env python3
"""Compare a map extended in time with the same map run from rest (docs/classify.md).

Usage:  python3 scripts/repro/check_map_extension.py EXTENDED_DIR FRESH_DIR [--seed FILE] [--out FILE]

EXTENDED_DIR: a map run to t₁ and extended (`beamslider map --extend-to T`); FRESH_DIR: the same
grid run to T from rest. For every point it compares the latest row of the extended map with the
row of the fresh map: the label, and every field but `wall_time_s` (JSON values: floats compare
bit for bit). Rows kept from t₁ (settled then) are compared too: their label must equal the
T-second label; their other fields differ by construction (t_end_s, the features of the shorter
run). The flag `settled` is compared like the label. With --seed (an older map.jsonl of the same
grid), also lists every label or flag of FRESH_DIR that differs from the seed, with both reasons.
Prints the counts and every difference; exit 0 (this is a measurement, not a test).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def latest_rows(folder: Path):
    path = folder if folder.is_file() else folder / "map.jsonl"
    lines = path.read_text(encoding="utf-8").splitlines()
    rows = {}
    for line in lines[1:]:
        if not line.strip():
            continue
        r = json.loads(line)
        rows[(r["f_ex_hz"], r["a_ex_m_s2"], r["s0"])] = r  # a later row (extension) replaces
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("extended", type=Path)
    ap.add_argument("fresh", type=Path)
    ap.add_argument("--seed", type=Path, default=None, help="an older map.jsonl: list the label changes against it")
    ap.add_argument("--out", type=Path, default=None, help="also write the report to this file")
    args = ap.parse_args()
    ext, fresh = latest_rows(args.extended), latest_rows(args.fresh)
    if set(ext) != set(fresh):
        print(f"the maps have different grids ({len(ext)} and {len(fresh)} points)")
        return 0
    t_fresh = {r["t_end_s"] for r in fresh.values()}
    rerun = [k for k, r in ext.items() if r["t_end_s"] in t_fresh]
    kept = [k for k in ext if k not in rerun]
    settled = lambda r: r.get("settled", r.get("steady") or r["behaviour"] == "relaxation_oscillation") and r["behaviour"] != "not_settled"
    label_diff = [k for k in ext if (ext[k]["behaviour"], settled(ext[k])) != (fresh[k]["behaviour"], settled(fresh[k]))]
    row_diff = []
    for k in rerun:
        a = {x: v for x, v in ext[k].items() if x not in ("wall_time_s", "index")}
        b = {x: v for x, v in fresh[k].items() if x not in ("wall_time_s", "index")}
        if a != b:
            row_diff.append((k, sorted(x for x in set(a) | set(b) if a.get(x) != b.get(x))))
    lines = [
        f"extended map {args.extended} vs map from rest {args.fresh} ({len(ext)} points, t_end {sorted(t_fresh)} s)",
        f"re-run (continued from saved end states): {len(rerun)}; kept (settled at the shorter t_end): {len(kept)}",
        f"labels and settled flags equal: {len(ext) - len(label_diff)} of {len(ext)}",
        f"settled = false in the extended map: {sum(not settled(r) for r in ext.values())}, in the map from rest: "
        f"{sum(not settled(r) for r in fresh.values())}",
        f"continued rows equal to the rows from rest except wall time: {len(rerun) - len(row_diff)} of {len(rerun)}",
    ]
    for k in label_diff:
        lines.append(f"  label differs at {k[0]:g} Hz {k[1]:g} m/s^2 s0 {k[2]:g}: extended {ext[k]['behaviour']}, settled "
                     f"{settled(ext[k])} (t_end {ext[k]['t_end_s']:g} s: {ext[k]['reason']}); from rest {fresh[k]['behaviour']}, "
                     f"settled {settled(fresh[k])} ({fresh[k]['reason']})")
    for k, fields in row_diff:
        lines.append(f"  continued row differs at {k}: {', '.join(fields)}")
    if args.seed is not None:
        seed = latest_rows(args.seed)
        changed = [k for k in fresh if k in seed and (seed[k]["behaviour"], settled(seed[k])) != (fresh[k]["behaviour"], settled(fresh[k]))]
        lines.append(f"map from rest {args.fresh} vs the seed {args.seed}: {len(changed)} labels or flags changed")
        for k in sorted(changed):
            lines.append(f"  {k[0]:g} Hz {k[1]:g} m/s^2 s0 {k[2]:g}: {seed[k]['behaviour']} (settled {settled(seed[k])}) -> "
                         f"{fresh[k]['behaviour']} (settled {settled(fresh[k])}): {fresh[k]['reason']}")
    text = "\n".join(lines) + "\n"
    print(text, end="")
    if args.out:
        args.out.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
