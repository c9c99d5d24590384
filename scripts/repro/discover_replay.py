#!/usr/bin/env python3
"""Re-judge the discover table's cases from their kept runs: the check that a change of the search,
the rule or the report leaves every verdict and value bitwise as it was.

    python3 scripts/repro/discover_replay.py make  DIR [--cases a,b] [--duration 60] [--s0-offset 0.0015]
    python3 scripts/repro/discover_replay.py check DIR [--cases a,b]

``make`` (with the code before the change): for each case of ``discover_table.py`` (default: all,
cheapest first), the measured runs are synthesised into DIR/CASE/data/, discover runs on them with its
free-slider runs kept in DIR/CASE/runs.jsonl, and its report (``Discovery.to_json()``) is written to
DIR/CASE/before.json. A case already made is skipped, so ``make`` resumes where it stopped.

``check`` (with the changed code): each made case is judged again on the same data files with the
same kept runs, accepting the runs of the code recorded in the file (the check is for changes that
do not touch how a run is made, docs/model.md §9.1 "Kept runs"), and its report is compared with
before.json key by key, bitwise (JSON text of each value). Keys the new report adds are listed, not
compared; a key it lost is a difference. Prints one line a case and the runs made anew (0 when the
search asked for exactly the runs it asked for before); exit 1 on any difference.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import time
from pathlib import Path

import beamslider as bs
from beamslider import discover as dc
from beamslider.discover import runstore

HERE = Path(__file__).resolve().parent
_spec = importlib.util.spec_from_file_location("discover_table", HERE / "discover_table.py")
table = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(table)

ORDER = ("baseline", "negligible", "velocity", "restitution-high", "clearance", "inertia", "com", "tilt",
         "velocity-large", "friction-low", "mass", "timebase", "spacing", "offset", "scale", "excitation",
         "friction", "detuning", "spacing-advised", "offset-advised", "scale-advised", "restitution-high-out",
         "restitution", "tilt-out", "com-out", "mass-out", "restitution-out", "detuning-out", "pair-mass-tilt",
         "pair-mu-f0", "pair-mu-f0-advised")
"""The table's cases, cheapest first (CPU seconds of their rows)."""

VOLATILE = ("runtime_s",)
"""Report keys that measure the machine, not the judgment."""


def _judge(key: str, case: Path, runs_path: Path):
    _, _, effects = table.CASES[key]
    data = [bs.read_measurement(p) for p in sorted((case / "data").iterdir())]
    store = dc.RunStore(runs_path)
    d = dc.discover(measured=data, baseline=table.P, effects=effects, max_effects=2, progress=False,
                    runs_file=store)
    return d, store


def make(root: Path, cases, duration: float, s0_offset: float) -> int:
    for key in cases:
        case = root / key
        if (case / "before.json").exists():
            print(f"{key}: made already", flush=True)
            continue
        data = case / "data"
        if not data.exists():
            tmp = case / "data.partial"
            tmp.mkdir(parents=True, exist_ok=True)
            table.case_runs(key, table.OPS, duration, s0_offset, tmp)
            tmp.rename(data)
        t0, c0 = time.perf_counter(), time.process_time()
        d, store = _judge(key, case, case / "runs.jsonl")
        out = d.to_json()
        (case / "before.json.partial").write_text(json.dumps(out, indent=1, allow_nan=True), encoding="utf-8")
        (case / "before.json.partial").rename(case / "before.json")
        print(f"{key}: {d.verdict} {d.named_effects} ({time.perf_counter() - t0:.0f} s wall, "
              f"{time.process_time() - c0:.0f} s CPU, {store.added} runs made)", flush=True)
    return 0


def _code_of(runs_path: Path) -> str:
    for line in runs_path.read_text(encoding="utf-8").splitlines():
        try:
            return json.loads(line)["code"]
        except (ValueError, KeyError, TypeError):
            continue
    raise SystemExit(f"{runs_path}: no kept run")


def check(root: Path, cases) -> int:
    bad = 0
    for key in cases:
        case = root / key
        if not (case / "before.json").exists():
            continue
        before = json.loads((case / "before.json").read_text(encoding="utf-8"))
        # The kept runs of the code that made them: a copy, so that the check appends nothing to them.
        runs_copy = case / "runs.check.jsonl"
        runs_copy.write_bytes((case / "runs.jsonl").read_bytes())
        runstore._FINGERPRINT = _code_of(runs_copy)
        t0 = time.perf_counter()
        d, store = _judge(key, case, runs_copy)
        after = json.loads(json.dumps(d.to_json(), allow_nan=True))
        runs_copy.unlink()
        diff = [k for k in before if k not in VOLATILE and
                json.dumps(before[k], sort_keys=True) != json.dumps(after.get(k, "<missing>"), sort_keys=True)]
        new = sorted(set(after) - set(before))
        state = "bitwise" if not diff else "DIFFERS in " + ", ".join(diff)
        bad += bool(diff)
        print(f"{key}: {before['verdict']} -> {after['verdict']}: {state} ({time.perf_counter() - t0:.0f} s, "
              f"{store.added} runs made anew{'; new keys: ' + ', '.join(new) if new else ''})", flush=True)
    return 1 if bad else 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mode", choices=("make", "check"))
    ap.add_argument("dir", type=Path)
    ap.add_argument("--cases", default=",".join(ORDER))
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--s0-offset", type=float, default=0.0015)
    args = ap.parse_args()
    cases = [c for c in args.cases.split(",") if c]
    unknown = [c for c in cases if c not in table.CASES]
    if unknown:
        print(f"error: unknown case {unknown[0]!r} (known: {', '.join(table.CASES)})", file=sys.stderr)
        return 2
    if args.mode == "make":
        return make(args.dir, cases, args.duration, args.s0_offset)
    return check(args.dir, cases)


if __name__ == "__main__":
    sys.exit(main())
