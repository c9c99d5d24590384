"""``beamslider discover``: measured data + baseline model → named missing effects, updated TOML,
``report.json``, ``report.md`` and figures; ``beamslider synthesize``: hidden-effect test data.

Compare measured data with the --params baseline (default: the prototype), name the missing physical
effect(s) among the candidates (beamslider.discover.EFFECTS), add them and report the gap before and
after. Beam level: --enma FILE (ENMA CSV). Slider level: --measured FILE... (published measured
format, operating point in the file name). Both together: one joint fit (beam-level effects from
both, slider-level ones from the runs). Without data: the paper's case, a synthetic ENMA of the
prototype against the ideally clamped beam."""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path
from typing import Any, Dict, List, Tuple

from ..params import Parameters
from ._common import UserError, add_common, doc_body, out_dir, plan_outputs, positive


def add_parser(sub: Any) -> None:
    """Register ``beamslider discover`` and ``beamslider synthesize``."""
    sp = sub.add_parser(
        "discover", help="find and name the effect the model misses, add it, show the gap shrink",
        description=doc_body(__doc__))
    sp.add_argument("--enma", metavar="CSV", help="ENMA data (beam level)")
    sp.add_argument("--measured", metavar="FILE", nargs="+", help="measured free-slider runs (slider level; with --enma: joint fit)")
    sp.add_argument("--effects", metavar="LIST", help="comma list of candidate effects (default: all of the level)")
    sp.add_argument("--max-effects", type=positive(int), default=2, metavar="K", help="largest set fitted (2)")
    sp.add_argument("--search", choices=("tiered", "full", "fast"), default="tiered",
                    help="slider level: 'tiered' (default) screens the candidates by the linearised model, fits the best "
                         "predicted, and runs the full search only where that does not settle the answer; 'full' scans "
                         "every candidate; 'fast' screens and fits one pair at most (it may miss effects the full search "
                         "names, docs/model.md §9.1)")
    sp.add_argument("--fast", action="store_true", help="the same as --search fast")
    sp.add_argument("--gap-ratio", type=float, default=None, metavar="R",
                    help="a named effect must leave at most this share of the gap beyond the noise, "
                         "sqrt(max(chi2 - E[chi2], 0)/n) (0.3), else 'unexplained'")
    sp.add_argument("--option", metavar="KEY=VALUE", action="append", default=[],
                    help="a tuning value of the search or the rule (beamslider.discover.DiscoverOptions, each with "
                         "its section of docs/model.md §9), e.g. --option tier_keep=3 --option significance=0.005; "
                         "an unknown key is an error; report.json records them all (options)")
    sp.add_argument("--seed", type=int, default=0, help="noise seed of the paper's synthetic case (0)")
    sp.add_argument("--advice-grid", metavar="LIST",
                    help="slider level: operating points f_ex,a_ex,s0 separated by ';' among which the separability "
                         "tool looks for the run that would resolve an unresolved candidate or separate a "
                         "confounded group (default: seven points of the paper's map, from s0 = 0.3 and from 0.15; "
                         "'none': no advice runs)")
    sp.add_argument("--quick", action="store_true",
                    help="slider level: stop at the provisional answer, the leading candidate of the tiered search's "
                         "first tier (report.json with \"provisional\": true; docs/model.md §9.1, \"Provisional answer\"); "
                         "without it that answer is written and printed as soon as it is known and the final verdict "
                         "replaces it")
    sp.add_argument("--runs", metavar="FILE",
                    help="slider level: the file that keeps the free-slider runs made, JSON lines (default: runs.jsonl "
                         "in --out; 'none': keep none). The runs it holds from the same code are reused: a discover "
                         "that was interrupted, or is run again on the same operating points, makes only the runs "
                         "it has not made, with the same verdict")
    sp.add_argument("--scheduler", metavar="ADDRESS",
                    help="slider level: make the free-slider runs on a Dask cluster, chunks of each batch as tasks: "
                         "scheduler address, e.g. tcp://host:8786; the answer is the local run's (docs/cluster.md)")
    sp.add_argument("--scheduler-file", metavar="FILE", help="the Dask cluster of this scheduler file instead of --scheduler "
                    "(dask scheduler --scheduler-file FILE)")
    add_common(sp, window=False, force=True)
    sp.set_defaults(func=cmd_discover)

    sp = sub.add_parser(
        "synthesize", help="hidden-effect data from a truth model (ENMA CSV or measured-format runs)",
        description="Write data generated from --truth (TOML) with noise: 'enma' a virtual ENMA CSV "
                    "(enma_data.csv), 'slider' free-slider runs in the published measured format.")
    sp.add_argument("kind", choices=["enma", "slider"])
    sp.add_argument("--truth", metavar="TOML",
                    help="truth model: parameters and, by name, effects of discover's library, e.g. "
                         "'natural_frequency_detuning = 1.03' (default: the prototype)")
    sp.add_argument("--seed", type=int, default=0, help="noise seed (0)")
    sp.add_argument("--points", metavar="LIST", default="110,10,0.3;124,6,0.3",
                    help="slider: operating points f_ex,a_ex,s0 separated by ';' (110,10,0.3;124,6,0.3)")
    sp.add_argument("--duration", type=positive(float), default=15.0, metavar="S", help="slider: run length [s] (15)")
    sp.add_argument("--repeats", type=positive(int), default=2, metavar="N", help="enma: noisy repetitions (2)")
    sp.add_argument("--chain", metavar="LIST", default="",
                    help="slider: calibration errors of the measurement chain (docs/model.md §9.1), e.g. "
                         "'excitation_gain=0.95,velocity_gain=1.02' (also position_offset, position_scale, time_base)")
    sp.add_argument("--s0-offset", type=_s0_offset, default=0.0, metavar="DS",
                    help="slider: the truth runs start DS off the s0 their files name, as a slider placed by hand "
                         "is; without it the model at exactly the truth repeats the data's chaotic realisation "
                         "(0; e.g. 0.0015, abs(DS) <= 0.05)")
    add_common(sp, model_options=False, window=False, force=True)
    sp.set_defaults(func=cmd_synthesize)


REPORT_FILES = ("updated.toml", "report.json", "report.md", "gap.png", "backbone.png", "slider.png")
"""What ``beamslider discover`` writes (:func:`beamslider.discover.write_report`)."""

RUNS_FILE = "runs.jsonl"
"""The default file of discover's kept runs in --out (:class:`beamslider.discover.runstore.RunStore`)."""


def _s0_offset(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(v) and abs(v) <= 0.05):
        raise argparse.ArgumentTypeError(f"{text!r}: must be finite with abs(DS) <= 0.05")
    return v


def _chain(text: str) -> Dict[str, float]:
    out: Dict[str, float] = {}
    for part in text.split(","):
        if not part.strip():
            continue
        name, _, val = part.partition("=")
        try:
            v = float(val)
        except ValueError:
            raise UserError(f"--chain {text!r}: give name=value pairs separated by ','") from None
        if not math.isfinite(v):
            raise UserError(f"--chain {text!r}: {name.strip()} must be finite")
        out[name.strip()] = v
    return out


def _points(text: str, option: str = "--points") -> List[Tuple[float, float, float]]:
    out = []
    for part in text.split(";"):
        if not part.strip():
            continue
        try:
            f, a, s0 = (float(v) for v in part.split(","))
        except ValueError:
            raise UserError(f"{option} {text!r}: give f_ex,a_ex,s0 triples separated by ';'") from None
        out.append((f, a, s0))
    if not out:
        raise UserError(f"{option}: no operating points")
    return out


def _options(items: List[str]) -> Any:
    """--option KEY=VALUE ... as a DiscoverOptions (values read as Python literals)."""
    import ast

    from ..discover import DiscoverOptions

    given: Dict[str, Any] = {}
    for item in items:
        key, eq, text = item.partition("=")
        if not eq or not key.strip():
            raise UserError(f"--option {item!r}: give KEY=VALUE")
        try:
            given[key.strip()] = ast.literal_eval(text.strip())
        except (ValueError, SyntaxError):
            raise UserError(f"--option {item!r}: the value must be a number, True/False or a tuple") from None
    try:
        return DiscoverOptions.of(given)
    except (ValueError, TypeError) as e:
        raise UserError(f"--option: {e}") from None


def cmd_discover(args: argparse.Namespace) -> int:
    from .. import discover as dc
    from .. import enma
    from ..measurement import read_measurement

    options = _options(args.option)
    effects = [e.strip() for e in args.effects.split(",") if e.strip()] if args.effects else None
    advice = None
    if args.advice_grid is not None:
        advice = [] if args.advice_grid.strip().lower() == "none" else _points(args.advice_grid, "--advice-grid")
    if args.gap_ratio is not None and not (0 < args.gap_ratio <= 1):
        raise UserError(f"--gap-ratio {args.gap_ratio}: must be in (0, 1]")
    plan_outputs(args, REPORT_FILES)  # nothing replaced without --force, before the fit runs
    t0 = time.perf_counter()
    prog = args.progress  # None: a bar on a terminal, a line now and then in a log
    given = "--fast" if args.fast else f"--search {args.search}"
    if args.fast:
        args.search = "fast"
    if args.runs is not None and not args.measured:
        raise UserError("--runs: only with --measured (the slider level's runs)")
    if args.quick and not args.measured:
        raise UserError("--quick: only with --measured (the slider level's tiered search)")
    if args.search == "fast" and not (args.measured and not args.enma):
        raise UserError(f"{given}: only for the slider level (--measured without --enma)")
    if args.scheduler and args.scheduler_file:
        raise UserError("give --scheduler or --scheduler-file, not both")
    if (args.scheduler or args.scheduler_file) and not args.measured:
        raise UserError("--scheduler/--scheduler-file: only with --measured (the slider level's runs are what it sends)")
    runs = None
    if args.measured:  # read (and refused) before anything is written
        same = {str(Path(p).resolve()) for p in args.measured}
        if len(same) < len(args.measured):
            raise UserError("--measured: a file is given twice (each run counts once)")
        runs = [read_measurement(p) for p in args.measured]
    from ..discover.cluster import on_cluster

    with on_cluster(args.scheduler, args.scheduler_file):  # the scheduler reached before any file is written
        return _run_and_report(args, dc, enma, runs, effects, advice, prog, options, t0)


def _run_and_report(args, dc, enma, runs, effects, advice, prog, options, t0) -> int:
    """The discover of the checked arguments, its kept runs, report and lines."""
    from .._dask import ClusterLostError

    store = None
    if args.measured and (args.runs or "").strip().lower() != "none":
        from ..discover.runstore import RunStore

        store = RunStore(args.runs if args.runs else Path(args.out) / RUNS_FILE)
        if store.loaded:
            print(f"runs: {store.loaded} kept runs read from {store.path} (an earlier discover's): only the runs "
                  "not among them are made", flush=True)

    def provisional(answer: Dict[str, Any]) -> None:
        # The leading candidate so far, as report.json and one line; the final verdict replaces it.
        from ._common import write_json_atomic

        out = out_dir(args)
        write_json_atomic(out / "report.json", answer)
        print(f"provisional ({answer['elapsed_s']:.0f} s): leading candidate " + ", ".join(
            f"{e} {dc.fmt_value(answer['values'][e])} ± {dc.fmt_value(answer['stderrs'][e])}" for e in answer["leading"])
            + f" (chi2 {answer['chi2']:.3g} against {answer['chi2_before']:.3g} before); "
            + ("--quick: stopped here" if args.quick else "the search goes on, its verdict replaces this"), flush=True)
        if args.quick:
            raise dc.StopAtProvisional(answer)

    try:
        d = _discover(args, dc, enma, runs, effects, advice, prog, store, options, provisional)
    except KeyboardInterrupt as e:
        if store is not None:  # what was kept and how to go on
            e.beamslider_note = (f"{store.added} runs made are kept in {store.path} (beside {store.loaded} read "  # type: ignore[attr-defined]
                                 "from it): the same command again goes on from them")
        raise
    except dc.StopAtProvisional:
        print(f"wrote {out_dir(args) / 'report.json'} (provisional)")
        return 0
    except ClusterLostError as e:
        kept = f" ({store.added} runs made kept in {store.path}, beside {store.loaded} read from it)" if store is not None else ""
        raise UserError(f"{e}{kept}") from None
    out = out_dir(args)
    written = dc.write_report(d, out)
    print((out / "report.md").read_text(encoding="utf-8").split("\n| feature")[0].rstrip())
    print(f"verdict: {dc.verdict_line(d)}")
    if store is not None:
        print(f"runs: {store.loaded} reused from {store.path}, {store.added} made")
    print(f"total {time.perf_counter() - t0:.1f} s")
    for p in written:
        print(f"wrote {p}")
    return 0


def _discover(args, dc, enma, runs, effects, advice, prog, store, options, provisional):
    """The discover the arguments ask for (beam, slider or both levels; the paper's case without data)."""
    if args.enma and args.measured:
        # Joint fit over the beam (ENMA) and slider (runs) features.
        baseline = Parameters.from_toml(args.params) if args.params else Parameters()
        return dc.discover(enma_data=enma.read(args.enma), measured=runs, baseline=baseline, effects=effects,
                           max_effects=args.max_effects, gap_ratio=args.gap_ratio, progress=prog, advice_grid=advice,
                           runs_file=store, options=options)
    if args.enma:
        baseline = Parameters.from_toml(args.params) if args.params else Parameters()
        return dc.discover(enma_data=enma.read(args.enma), baseline=baseline, effects=effects,
                           max_effects=args.max_effects, gap_ratio=args.gap_ratio, options=options)
    if args.measured:
        baseline = Parameters.from_toml(args.params) if args.params else Parameters()
        return dc.discover(measured=runs, baseline=baseline, effects=effects, max_effects=args.max_effects,
                           gap_ratio=args.gap_ratio, progress=prog, advice_grid=advice, search=args.search,
                           runs_file=store, options=options, on_provisional=provisional)
    baseline = (Parameters.from_toml(args.params) if args.params
                else Parameters(k_r_nm_per_rad=math.inf, k_t_n_per_m=math.inf))
    data = dc.synthesize_enma(Parameters(), seed=args.seed)
    return dc.discover(enma_data=data, baseline=baseline, effects=effects, max_effects=args.max_effects,
                       gap_ratio=args.gap_ratio, options=options)


def cmd_synthesize(args: argparse.Namespace) -> int:
    from .. import discover as dc

    try:
        model = dc.truth_from_toml(args.truth) if args.truth else dc.Model(Parameters())
    except OSError as e:
        raise UserError(f"cannot read the truth {args.truth}: {e.strerror or e}") from None
    except ValueError as e:
        raise UserError(f"cannot read the truth {e}") from None
    truth, chain = model.params, dict(model.chain)
    for name, value in _chain(args.chain).items():
        if name in chain:
            raise UserError(f"{name} is set twice: in --truth and in --chain")
        chain[name] = value
    if args.kind == "enma" and chain:
        raise UserError(f"the measurement chain ({', '.join(sorted(chain))}) applies to slider runs only, not to 'enma'")
    if args.kind == "enma":
        plan_outputs(args, ["enma_data.csv"])
    else:
        from ..discover.synthesize import measured_file_name

        plan_outputs(args, [measured_file_name(f, a, s0) for f, a, s0 in _points(args.points)])
    out = out_dir(args)
    if args.kind == "enma":
        data = dc.synthesize_enma(truth, seed=args.seed, repeats=args.repeats)
        data.write(out / "enma_data.csv")
        print(f"wrote {out / 'enma_data.csv'}")
    else:
        for p in dc.synthesize_slider_runs(truth, operating_points=_points(args.points), duration_s=args.duration,
                                           out_dir=out, seed=args.seed, s0_offset=args.s0_offset, chain=chain):
            print(f"wrote {p}")
    return 0
