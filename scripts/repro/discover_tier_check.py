#!/usr/bin/env python3
"""The tiered search (docs/model.md §9.1, "Cost") against the full search on the cases of the
discover table: for each case, the same data as `discover_table.py` (its truth at the reference
points and the case's advised run, 60-s runs, seed 3, the truth runs s0 + 0.0015 off), one
`discover(search="tiered")`; where the tier does not settle the answer the full search would run,
sharing the tier's runs, so its verdict is the full search's by construction: the check stops there
and says so (a coarse scan is the mark of the full search). Where the tier settles, its verdict and
values are printed beside the table's (the full search's), with the runs and CPU seconds it took, and
each named value's distance from its truth in standard errors.

``--s0-offset``: the truth runs' slider start off the s0 the files name (the table's 0.0015); another
offset is another realisation of the same case, checked against the table's verdict.

Usage:  python3 scripts/repro/discover_tier_check.py [--cases a,b] [--table docs/results/discover/table.md]
                                                     [--out docs/results/discover/tier_check.md] [--s0-offset 0.0015]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from beamslider import _core  # noqa: E402
from beamslider import discover as dc  # noqa: E402
from beamslider.discover import problem  # noqa: E402
from beamslider.discover.options import DEFAULT  # noqa: E402
from discover_table import CASES, OPS, P, case_runs, truth_values  # noqa: E402

S0_OFFSET = 0.0015


HEADER = """# The tiered search against the full search{title}

`python3 scripts/repro/discover_tier_check.py{opt} --out {out}`: for each case of
the discover table (docs/results/discover/table.md, the same data: three 60-s runs at the reference points
plus the case's advised run, seed 3, the truth runs s0 {off} off{other}), one `discover(search="tiered")`
with the case's candidates (docs/model.md §9.1, "Cost"). "settled": the tier gave the answer, shown beside
the table's (the full search's); "not settled": the full search runs from there, sharing the tier's runs,
so the verdict is the full search's by construction (the check stops at its first coarse scan). Named −
truth: each named value's distance from its hidden value, in its standard errors. Runs: the
core's runs of the tier (60-s runs); CPU: seconds of all threads of the process, the machine shared with
other runs (an idle 2-core machine's wall time is about CPU / 2).{agree}

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
    ap.add_argument("--s0-offset", type=float, default=S0_OFFSET,
                    help=f"the truth runs' slider start off the files' s0 ({S0_OFFSET:g}, the table's)")
    args = ap.parse_args()
    known = table_verdicts(args.table)
    real_fit, real_batch = problem.profile_fit, _core.run_free_slider_batch
    runs_done = [0]

    def fit(effects, *a, refine=None, **kw):
        if refine == DEFAULT.screen_refine:
            raise Escalated
        return real_fit(effects, *a, refine=refine, **kw)

    def batch(jobs, *a, **kw):
        runs_done[0] += len(jobs)
        return real_batch(jobs, *a, **kw)

    rows = ["| case | the table (full search) | tiered search | named − truth, in standard errors | runs | CPU s | agrees |",
            "|---|---|---|---|---|---|---|"]
    problem.profile_fit, _core.run_free_slider_batch = fit, batch
    try:
        for key in args.cases.split(","):
            label, spec, effects = CASES[key]
            full_label = f"{label} (truth runs from s0 + {S0_OFFSET:g})"
            with tempfile.TemporaryDirectory() as tmp:
                data = case_runs(key, OPS, 60.0, args.s0_offset, tmp)
                runs_done[0] = 0
                c0 = time.process_time()
                try:
                    d = dc.discover(measured=data, baseline=P, effects=effects, search="tiered")
                    named = "; ".join(f"{e} {dc.fmt_value(d.parameters[e]['value'])} ± "
                                      f"{dc.fmt_value(d.parameters[e]['stderr'])}" for e in d.named_effects)
                    got, settled = d.verdict, True
                    said = f"settled: {d.verdict}" + (f", {named}" if named else "")
                    hidden = truth_values(spec)
                    off = "; ".join(f"{e} {(d.parameters[e]['value'] - hidden[e]) / d.parameters[e]['stderr']:+.1f}"
                                    if e in hidden else f"{e} (not hidden)" for e in d.named_effects) or "—"
                except Escalated:
                    got, settled, said, off = None, False, "not settled: the full search (its verdict)", "—"
                cpu = time.process_time() - c0
            want, want_named = known.get(full_label, ("?", ""))
            agree = "by construction" if not settled else ("yes" if got == want else "**no**")
            if settled and args.s0_offset != S0_OFFSET:
                # Another realisation: the table's verdict and the same effects named.
                same = got == want and all(e in want_named for e in d.named_effects)
                agree = "yes" if same else "**no**"
            rows.append(f"| {label} | {want}: {want_named} | {said} | {off} | {runs_done[0]} | {cpu:.0f} | {agree} |")
            print(rows[-1], flush=True)
    finally:
        problem.profile_fit, _core.run_free_slider_batch = real_fit, real_batch
    if args.out is not None:
        other = args.s0_offset != S0_OFFSET
        signed = f"{'+' if args.s0_offset >= 0 else '−'} {abs(args.s0_offset):g}"
        head = HEADER.format(
            title=f", another slider start (s0 {signed})" if other else "",
            opt=f" --s0-offset {args.s0_offset:g}" if other else "", out=args.out, off=signed,
            other=f"; the table's runs start s0 + {S0_OFFSET:g} off, so these are other realisations" if other else "",
            agree=(" Agrees: the table's verdict, and the same effects named (values are those of this realisation)."
                   if other else ""))
        args.out.write_text(head + "\n".join(rows) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
