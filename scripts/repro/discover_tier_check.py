#!/usr/bin/env python3
"""The tiered search (docs/model.md §9.1, "Cost") against the full search on the cases of the
discover table: for each case, the same data as `discover_table.py` (its truth at the reference
points and the case's advised run, 60-s runs, seed 3, the truth runs s0 + 0.0015 off), one
`discover(search="tiered")`; where the tier does not settle the answer the full search would run,
sharing the tier's runs, so its verdict is the full search's by construction: the check stops there
and says so (a coarse scan is the mark of the full search). Where the tier settles, its verdict and
values are printed beside the table's (the full search's), with the runs and CPU seconds it took.

Usage:  python3 scripts/repro/discover_tier_check.py [--cases a,b] [--table docs/results/discover/table.md]
                                                     [--out docs/results/discover/tier_check.md]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import beamslider as bs  # noqa: E402
from beamslider import _core  # noqa: E402
from beamslider import discover as dc  # noqa: E402
from beamslider.discover import naming  # noqa: E402
from discover_table import CASES, EXTRA_OPS, OPS, P, truth_of  # noqa: E402

S0_OFFSET = 0.0015


HEADER = """# The tiered search against the full search

`python3 scripts/repro/discover_tier_check.py --out docs/results/discover/tier_check.md`: for each case of
the discover table (docs/results/discover/table.md, the same data: three 60-s runs at the reference points
plus the case's advised run, seed 3, the truth runs s0 + 0.0015 off), one `discover(search="tiered")`
with the case's candidates (docs/model.md §9.1, "Cost"). "settled": the tier gave the answer, shown beside
the table's (the full search's); "not settled": the full search runs from there, sharing the tier's runs,
so the verdict is the full search's by construction (the check stops at its first coarse scan). Runs: the
core's runs of the tier (60-s runs); CPU: seconds of all threads of the process, the machine shared with
other runs (an idle 2-core machine's wall time is about CPU / 2).

"""


class Escalated(Exception):
    """The tier did not settle: the full search's coarse scans begin."""


def table_verdicts(path: Path) -> dict:
    """Label -> (verdict, named column) of the table's first section (the last row of a label)."""
    out: dict = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        if out and not line.startswith("|"):
            break  # the end of the first table
        if line.startswith("| ") and not line.startswith(("| hidden truth", "|---")):
            cells = [c.strip() for c in line.strip("|").split(" | ")]
            if len(cells) >= 4:
                out[cells[0]] = (cells[2].split()[0], cells[3])
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--table", type=Path, default=Path("docs/results/discover/table.md"))
    ap.add_argument("--out", type=Path, default=None, help="also write the rows (markdown) there")
    args = ap.parse_args()
    known = table_verdicts(args.table)
    real_fit, real_batch = naming.profile_fit, _core.run_free_slider_batch
    runs_done = [0]

    def fit(effects, *a, refine=2, **kw):
        if refine == 0:
            raise Escalated
        return real_fit(effects, *a, refine=refine, **kw)

    def batch(jobs, *a, **kw):
        runs_done[0] += len(jobs)
        return real_batch(jobs, *a, **kw)

    rows = ["| case | the table (full search) | tiered search | runs | CPU s | agrees |", "|---|---|---|---|---|---|"]
    naming.profile_fit, _core.run_free_slider_batch = fit, batch
    try:
        for key in args.cases.split(","):
            label, spec, effects = CASES[key]
            full_label = f"{label} (truth runs from s0 + {S0_OFFSET:g})"
            with tempfile.TemporaryDirectory() as tmp:
                truth = truth_of(spec)
                params, chain = truth if isinstance(truth, tuple) else (truth, None)
                ops = OPS + [op for op in EXTRA_OPS.get(key, []) if op not in OPS]
                paths = dc.synthesize_slider_runs(params, operating_points=ops, duration_s=60.0, out_dir=tmp, seed=3,
                                                  s0_offset=S0_OFFSET, chain=chain)
                data = [bs.read_measurement(p) for p in paths]
                runs_done[0] = 0
                c0 = time.process_time()
                try:
                    d = dc.discover(measured=data, baseline=P, effects=effects, search="tiered")
                    named = "; ".join(f"{e} {dc.fmt_value(d.parameters[e]['value'])} ± "
                                      f"{dc.fmt_value(d.parameters[e]['stderr'])}" for e in d.named_effects)
                    got, settled = d.verdict, True
                    said = f"settled: {d.verdict}" + (f", {named}" if named else "")
                except Escalated:
                    got, settled, said = None, False, "not settled: the full search (its verdict)"
                cpu = time.process_time() - c0
            want, want_named = known.get(full_label, ("?", ""))
            agree = "by construction" if not settled else ("yes" if got == want else "**no**")
            rows.append(f"| {label} | {want}: {want_named} | {said} | {runs_done[0]} | {cpu:.0f} | {agree} |")
            print(rows[-1], flush=True)
    finally:
        naming.profile_fit, _core.run_free_slider_batch = real_fit, real_batch
    if args.out is not None:
        args.out.write_text(HEADER + "\n".join(rows) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
