#!/usr/bin/env python3
"""The checks behind an entry of ``beamslider/discover/lineage.py``: that a change of the code leaves
the kept runs and the benchmark's rows bitwise as the old code made them (docs/model.md §9.1, "Kept
runs"; §9.2, "Files").

    python3 scripts/repro/discover_lineage.py runs  RUNS_FILE --from DIGEST [--sample 60] [--seed 0]
    python3 scripts/repro/discover_lineage.py judge BENCH_DIR --cases 0,3,7

``runs``: a random sample of the runs that the code of digest ``--from`` kept in RUNS_FILE is made
again by this code (the core's runner and the feature extractor, nothing read from the file), and
each run's stored line (features, uncertainties, behaviour) is compared with the new one as JSON
text. Prints the count equal, the two digests and the line to enter in ``lineage.RUNS``.

``judge``: the benchmark's cases ``--cases`` of BENCH_DIR are judged again by this code (their runs
synthesised again, the kept runs of the folder read as this code reads them: a run the check asks
for anew is made and counted) and each row is compared with the folder's row, key by key, as JSON
text (the times aside; a key the old row lacks is listed, not compared). Prints the line to enter in
``lineage.JUDGES``. Exit 1 on any difference.
"""

from __future__ import annotations

import argparse
import json
import random
import sys
from pathlib import Path

from beamslider.discover import benchmark as bm
from beamslider.discover import runstore
from beamslider.discover.cases import Case, Plan


def _lines_of(path: Path, digest: str):
    for line in path.read_bytes().splitlines():
        try:
            d = json.loads(line)
        except ValueError:
            continue
        if isinstance(d, dict) and d.get("code") == digest and d.get("run") is not None:
            yield d


def check_runs(path: Path, digest: str, sample: int, seed: int) -> int:
    from beamslider import _core
    from beamslider.discover import models
    from beamslider.measurement import DISPLACEMENT_DETREND_S
    from beamslider.params import Parameters, native

    lines = list(_lines_of(path, digest))
    if not lines:
        print(f"no runs of code {digest} in {path}")
        return 1
    picked = random.Random(seed).sample(lines, min(sample, len(lines)))
    keys = [runstore._to_tuple(json.loads(d["key"])) for d in picked]
    jobs = [(native(Parameters(**dict(k[0]))), k[2], k[3], k[4], k[5]) for k in keys]
    res = _core.run_free_slider_batch(jobs, record_every=models.RUN_RECORD_EVERY, keep_every=models.RUN_KEEP_EVERY,
                                      window_s=1.0, detrend_s=DISPLACEMENT_DETREND_S)
    same = 0
    for d, k, r in zip(picked, keys, res):
        new = None if "error" in r else models._features_of_run(r, k[1])
        a = json.dumps(d["run"], sort_keys=True, allow_nan=True)
        b = json.dumps(runstore._encode(new), sort_keys=True, allow_nan=True)
        if a == b:
            same += 1
        else:
            print(f"different: {d['key'][:120]}")
    now = runstore.code_fingerprint()
    print(f"runs: {same} of {len(picked)} equal (of {len(lines)} kept by {digest}; this code {now})")
    if same == len(picked):
        print(f'enter in lineage.RUNS:  "{now}": ("{digest}", "{same} runs of {path.name} made again, '
              f'bitwise (scripts/repro/discover_lineage.py runs)"),')
        return 0
    return 1


def _comparable(row, old_keys=None):
    out = {k: v for k, v in row.items() if k not in ("cpu_s", "wall_s", "judge")}
    for part in (out, out.get("advised") or {}):
        tf = part.get("truth_fit")
        if isinstance(tf, dict) and old_keys is not None and "without" not in old_keys:
            part["truth_fit"] = {k: v for k, v in tf.items() if k != "without"}
    return out


def check_judge(folder: Path, cases) -> int:
    settings = json.loads((folder / bm.SETTINGS_FILE).read_text(encoding="utf-8"))
    plan = Plan.from_dict(settings["plan"])
    by_index = {c["index"]: Case(**c) for c in settings["cases"]}
    rows = bm._read_rows(folder / bm.CASES_FILE)
    store = runstore.RunStore(folder / "runs.jsonl")
    old_judges, bad = set(), 0
    for i in cases:
        old = rows[i]
        old_judges.add(old.get("judge"))
        before = store.added
        new = bm.run_case(by_index[i], plan, runs_file=store, advice=bool(settings.get("advice", True)))
        a = _comparable(old)
        b = _comparable(json.loads(json.dumps(new, allow_nan=True)), set(old.get("truth_fit", {})))
        diff = sorted(k for k in set(a) | set(b) if json.dumps(a.get(k), sort_keys=True) != json.dumps(b.get(k), sort_keys=True))
        bad += bool(diff)
        print(f"case {i} ({old['label'][:50]}): {'bitwise' if not diff else 'DIFFERENT in ' + ', '.join(diff)} "
              f"({store.added - before} runs made anew)", flush=True)
    now = bm.judge_fingerprint()
    if not bad and len(old_judges) == 1:
        print(f'enter in lineage.JUDGES:  "{now}": ("{old_judges.pop()}", "cases {",".join(map(str, cases))} of '
              f'{folder.name} judged again, bitwise (scripts/repro/discover_lineage.py judge)"),')
    return 1 if bad else 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="what", required=True)
    r = sub.add_parser("runs")
    r.add_argument("runs_file", type=Path)
    r.add_argument("--from", dest="digest", required=True)
    r.add_argument("--sample", type=int, default=60)
    r.add_argument("--seed", type=int, default=0)
    j = sub.add_parser("judge")
    j.add_argument("folder", type=Path)
    j.add_argument("--cases", required=True)
    a = ap.parse_args(argv)
    if a.what == "runs":
        return check_runs(a.runs_file, a.digest, a.sample, a.seed)
    return check_judge(a.folder, [int(x) for x in a.cases.split(",")])


if __name__ == "__main__":
    sys.exit(main())
