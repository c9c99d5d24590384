#!/usr/bin/env python3
"""What a planned experiment would name, before anything is measured: discover's detectability
(docs/model.md §9.2, "Detectability") for a plan and a list of effects at sizes given in units of
each effect's relevance threshold.

    python3 scripts/repro/discover_plan_detectability.py [--effects friction_coefficient,tilt,...]
        [--thresholds 2,4] [--repeats 2] [--seed 0] [--points "104,14,0.3;126,10,0.3;124,14,0.3"]
        [--duration 60] --out DIR [--runs FILE]

Each effect at each size is drawn ``--repeats`` times with its own noise seed and start offset,
synthesised at the plan, judged by discover and scored as the benchmark scores a single effect
(named alone, its truth inside its interval; after at most one advised run where the answer is
confounded or unexplained with advice). ``DIR`` keeps the rows and the runs (resumable: the same
command goes on); ``--runs`` starts from a copy of another benchmark's kept runs (the baseline's
runs and the scan grids do not depend on the data). Writes DIR/detectability.json and
DIR/detectability.md.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path

import beamslider as bs
from beamslider.discover import benchmark as bm
from beamslider.discover.cases import PAPER_POINTS, Plan, threshold

DEFAULT_EFFECTS = "friction_coefficient,tilt,excitation_gain,com_offset,restitution,contact_spacing"


def _points(text: str):
    out = []
    for p in filter(None, (s.strip() for s in text.split(";"))):
        f, a, s0 = (float(v) for v in p.split(","))
        out.append((f, a, s0))
    return tuple(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--effects", default=DEFAULT_EFFECTS)
    ap.add_argument("--thresholds", default="2,4", help="sizes in units of each effect's relevance threshold")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--points", default=";".join(",".join(f"{v:g}" for v in p) for p in PAPER_POINTS))
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--runs", type=Path, default=None, help="start from a copy of these kept runs")
    args = ap.parse_args()
    base = bs.Parameters()
    plan = Plan(operating_points=_points(args.points), duration_s=args.duration)
    sizes = [float(v) for v in args.thresholds.split(",")]
    effects = {}
    for name in filter(None, (s.strip() for s in args.effects.split(","))):
        x0 = bm.EFFECTS[name].baseline_value(base)
        effects[name] = [x0 + k * threshold(name, base) for k in sizes]
    args.out.mkdir(parents=True, exist_ok=True)
    if args.runs is not None and not (args.out / "runs.jsonl").exists():
        shutil.copyfile(args.runs, args.out / "runs.jsonl")
    t0, c0 = time.perf_counter(), time.process_time()
    res = bm.detectability(effects, plan=plan, repeats=args.repeats, seed=args.seed, out_dir=args.out, advice=True,
                           progress=True)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    rows = ["| effect | size (thresholds) | value | named right | answers |", "|---|---|---|---|---|"]
    for name, by_value in res["effects"].items():
        x0, thr = bm.EFFECTS[name].baseline_value(base), threshold(name, base)
        for t in sorted(by_value.values(), key=lambda t: t["value"]):
            k = (t["value"] - x0) / thr
            answers = "; ".join(sorted(set(t["answers"])))
            rows.append(f"| {name} | {k:.3g} | {t['value']:.5g} | {t['right']} of {t['of']} | {answers} |")
    cmd = ("python3 scripts/repro/discover_plan_detectability.py --effects " + args.effects + f" --thresholds "
           f"{args.thresholds} --repeats {args.repeats} --seed {args.seed} --duration {args.duration:g}")
    text = (f"# What the plan would name\n\n`{cmd}`: plan {plan.operating_points}, {plan.duration_s:g} s each; "
            f"{args.repeats} draws per effect and size, each with its own noise and start offset; scored as the "
            f"benchmark scores a single effect (after at most one advised run). {wall:.0f} s wall, {cpu:.0f} s CPU "
            f"for the cases not already kept.\n\n" + "\n".join(rows) + "\n")
    (args.out / "detectability.json").write_text(json.dumps(res, indent=1, default=str), encoding="utf-8")
    (args.out / "detectability.md").write_text(text, encoding="utf-8")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
