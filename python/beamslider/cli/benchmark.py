"""``beamslider discover-benchmark``: discover judged on hidden cases drawn at random by a seed
(docs/model.md §9.2): nothing hidden, one or two effects of the library, a change outside it, a
calibration of the measurement chain with a physical effect. Each case's runs are synthesised,
discover runs on them and the answer is scored; a case answered "confounded" or "unexplained" with
an advised run takes that run and is scored again. Rows are appended to cases.jsonl in --out as
cases finish (run again to resume), the summary is written to summary.md and summary.json."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, Dict

from ._common import UserError, doc_body, positive


def add_parser(sub: Any) -> None:
    """Register ``beamslider discover-benchmark``."""
    sp = sub.add_parser("discover-benchmark", help="discover judged on hidden cases drawn by a seed",
                        description=doc_body(__doc__))
    sp.add_argument("--seed", type=int, required=True, help="the seed that draws the cases (state it before the run)")
    sp.add_argument("--cases", metavar="LIST", default=None,
                    help="cases per kind, e.g. 'single=12,pair=6,outside=6,nothing=4,chain+physics=2' (the default)")
    sp.add_argument("--points", metavar="LIST", default="104,14,0.3;126,10,0.3;124,14,0.3",
                    help="the plan's operating points f_ex,a_ex,s0 separated by ';' (the paper's three)")
    sp.add_argument("--duration", type=positive(float), default=60.0, metavar="S", help="run length [s] (60)")
    sp.add_argument("--effects", metavar="LIST", help="the candidates (default: every slider-level effect)")
    sp.add_argument("--no-advice", action="store_true", help="do not take the advised run of a confounded or "
                                                               "unexplained answer")
    sp.add_argument("--out", default="benchmark-out", help="folder of the rows, kept runs and summary (benchmark-out)")
    sp.add_argument("--scheduler", metavar="ADDRESS",
                    help="run the cases on a Dask cluster, one case a task: scheduler address, e.g. tcp://host:8786 "
                         "(docs/cluster.md; --out must be a folder the workers reach, for the kept runs)")
    sp.add_argument("--scheduler-file", metavar="FILE", help="the Dask cluster of this scheduler file instead of --scheduler")
    sp.add_argument("--progress", dest="progress", action="store_true", default=None,
                    help="discover's progress bar for each case")
    sp.set_defaults(func=cmd_benchmark)


def _counts(text: str) -> Dict[str, int]:
    out: Dict[str, int] = {}
    for part in text.split(","):
        if not part.strip():
            continue
        k, _, v = part.partition("=")
        try:
            out[k.strip()] = int(v)
        except ValueError:
            raise UserError(f"--cases {text!r}: give kind=count pairs separated by ','") from None
    return out


def cmd_benchmark(args: argparse.Namespace) -> int:
    from ..discover import benchmark as bm
    from .discover import _points

    try:
        plan = bm.Plan(operating_points=tuple(_points(args.points)), duration_s=args.duration,
                       candidates=tuple(e.strip() for e in args.effects.split(",") if e.strip()) if args.effects
                       else bm.SLIDER_CANDIDATES)
        counts = _counts(args.cases) if args.cases else None
        cases = bm.draw_cases(args.seed, counts, plan=plan)
    except ValueError as e:
        raise UserError(str(e)) from None
    if args.scheduler and args.scheduler_file:
        raise UserError("give --scheduler or --scheduler-file, not both")
    out = Path(args.out)
    total = len(cases)

    def on_case(row: Dict[str, Any]) -> None:
        s = bm.final_score(row)
        print(f"case {row['index'] + 1}/{total} ({row['kind']}: {row['label']}): "
              f"{'right' if s['right'] else s['outcome']} [{row['cpu_s']:.0f} s CPU]", flush=True)

    try:
        res = bm.run_benchmark(args.seed, counts=counts, plan=plan, out_dir=out, advice=not args.no_advice,
                               progress=args.progress, on_case=on_case,
                               scheduler=args.scheduler, scheduler_file=args.scheduler_file)
    except ValueError as e:
        raise UserError(str(e)) from None
    except KeyboardInterrupt as e:
        e.beamslider_note = (f"the finished cases are in {out / bm.CASES_FILE} and the runs made in "  # type: ignore[attr-defined]
                             f"{out / 'runs.jsonl'}: the same command again goes on from them")
        raise
    print((out / "summary.md").read_text(encoding="utf-8").split("\n## Confusion")[0].rstrip())
    print(f"wrote {out / 'summary.md'}, {out / 'summary.json'}, {out / bm.CASES_FILE}")
    return 0
