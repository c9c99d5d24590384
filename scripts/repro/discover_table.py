#!/usr/bin/env python3
"""The discover table: hidden truth -> verdict, fitted values, gap before -> after, wall time, for
slider-level data synthesised from a truth model (in-library and out-of-library effects, a
negligible change, the baseline itself).

Usage:  python3 scripts/repro/discover_table.py [--duration 60] [--out docs/results/discover/table.md] [--cases a,b] [--rows-only] [--s0-offset 0.0015]
                                          [--ops "104,14,0.3;126,10,0.3;124,14,0.3"] [--max-effects 1] [--resume] [--json-dir DIR]
                                          [--runs FILE]

``--resume``: the cases whose rows --out already holds (same label) are kept, not re-run; ``--json-dir``:
each case's full report (every fitted set with its reasons and intervals) as DIR/CASE.json.

Data: `synthesize_slider_runs` of the truth at the operating points (default: the three reference points,
s noise 0.001, seed 3); baseline: the prototype; candidates: all slider-level effects, or all but
the hidden one ("out of library"); the contact spacing and the measurement chain's calibrations, and two
effects at once (sets of up to two effects by default, as `beamslider discover`). The runs of each
chi2 evaluation go through the core's parallel runner; the wall time of each discover is measured
and printed with the load average.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import beamslider as bs
from beamslider import discover as dc

OPS = [(104.0, 14.0, 0.3), (126.0, 10.0, 0.3), (124.0, 14.0, 0.3)]
SLIDER = [n for n, e in dc.EFFECTS.items() if e.level == "slider"]
P = bs.Parameters()

CASES = {
    "friction": ("mu = 0.26", dict(friction_coefficient=0.26), SLIDER),
    "clearance": ("R/h = 1.08", dict(gap_ratio=1.08), SLIDER),
    "detuning": ("f0 x 0.98", "detune:0.98", SLIDER),
    "mass": ("slider mass x 1.1", dict(slider_mass_kg=P.slider_mass_kg * 1.1), SLIDER),
    "restitution": ("restitution 0.3", dict(restitution=0.3), SLIDER),
    "tilt": ("frame tilt 8 mrad", dict(tilt_rad=0.008), SLIDER),
    "inertia": ("slider rotary inertia x 1.3", dict(slider_inertia_kg_m2=P.slider_inertia_kg_m2 * 1.3), SLIDER),
    "com": ("com offset 5.5 mm", dict(com_offset_m=5.5e-3), SLIDER),
    "tilt-out": ("frame tilt 8 mrad, tilt not a candidate", dict(tilt_rad=0.008), [n for n in SLIDER if n != "tilt"]),
    "com-out": ("com offset 5.5 mm, com offset not a candidate", dict(com_offset_m=5.5e-3),
                [n for n in SLIDER if n != "com_offset"]),
    "detuning-out": ("f0 x 0.98, detuning not a candidate", "detune:0.98",
                     [n for n in SLIDER if n != "natural_frequency_detuning"]),
    "mass-out": ("slider mass x 1.1, mass not a candidate", dict(slider_mass_kg=P.slider_mass_kg * 1.1),
                 [n for n in SLIDER if n != "slider_mass"]),
    "restitution-out": ("restitution 0.3, restitution not a candidate", dict(restitution=0.3),
                        [n for n in SLIDER if n != "restitution"]),
    # Restitution 0.3 is mimicked by a negligible change; 0.7 moves these runs' features clearly.
    "restitution-high": ("restitution 0.7", dict(restitution=0.7), SLIDER),
    "restitution-high-out": ("restitution 0.7, restitution not a candidate", dict(restitution=0.7),
                             [n for n in SLIDER if n != "restitution"]),
    # A friction valley between the screen's grid points 0.15 and 0.2 (docs/model.md §9.1, "Cost").
    "friction-low": ("mu = 0.17", dict(friction_coefficient=0.17), SLIDER),
    "negligible": ("mu = 0.203 (below the 0.01 threshold)", dict(friction_coefficient=0.203), SLIDER),
    "baseline": ("nothing (the prototype)", {}, SLIDER),
    # The contact spacing and the measurement chain (docs/model.md §9.1), by effect name.
    "spacing": ("contact spacing x 1.15", "effects:contact_spacing=0.0115", SLIDER),
    "excitation": ("excitation level 5 % low", "effects:excitation_gain=0.95", SLIDER),
    "velocity": ("velocity sensor gain 1.06", "effects:velocity_gain=1.06", SLIDER),
    "offset": ("camera offset 0.012", "effects:position_offset=0.012", SLIDER),
    "scale": ("camera scale 1.035", "effects:position_scale=1.035", SLIDER),
    "timebase": ("time base 1.004", "effects:time_base=1.004", SLIDER),
    # Two effects at once, values off the scan grids.
    "pair-mu-f0": ("mu = 0.24 and f0 x 0.985", "effects:friction_coefficient=0.24,natural_frequency_detuning=0.985",
                   SLIDER),
    "pair-mass-tilt": ("slider mass 49.9 g and tilt 7 mrad", "effects:slider_mass=0.0499,tilt=0.007", SLIDER),
    # The velocity gain at a value these runs resolve (1.06 is within the amplitudes' uncertainty).
    "velocity-large": ("velocity sensor gain 1.12", "effects:velocity_gain=1.12", SLIDER),
    # A confounded verdict's advice taken: its recommended run added to the three (EXTRA_OPS).
    "spacing-advised": ("contact spacing x 1.15, the advised run added", "effects:contact_spacing=0.0115", SLIDER),
    "offset-advised": ("camera offset 0.012, the advised run added", "effects:position_offset=0.012", SLIDER),
    "scale-advised": ("camera scale 1.035, the advised run added", "effects:position_scale=1.035", SLIDER),
    "pair-mu-f0-advised": ("mu = 0.24 and f0 x 0.985, the advised run added",
                           "effects:friction_coefficient=0.24,natural_frequency_detuning=0.985", SLIDER),
}

EXTRA_OPS = {
    "spacing-advised": [(110.0, 10.0, 0.3)],   # the advice of the "spacing" row (verdicts.advise)
    "offset-advised": [(116.0, 10.0, 0.15)],   # the advice of the "offset" row
    "scale-advised": [(116.0, 10.0, 0.15)],    # the advice of the "scale" row
    "pair-mu-f0-advised": [(116.0, 10.0, 0.3)],  # the advice of the "pair-mu-f0" row
}
"""Operating points (f_ex Hz, a_ex m/s², s0) added to --ops for a case: the run that a confounded
verdict of the same case on the three runs recommends."""


def truth_of(spec):
    """The truth: parameters, or (parameters, measurement chain) for a spec by effect name."""
    if isinstance(spec, str) and spec.startswith("detune:"):
        return dc.realise_effects(P, {"natural_frequency_detuning": float(spec.split(":")[1])})
    if isinstance(spec, str) and spec.startswith("effects:"):
        vals = {k: float(v) for k, v in (kv.split("=") for kv in spec.split(":", 1)[1].split(","))}
        m = dc.realise_model(P, vals)
        return m.params, (dict(m.chain) or None)
    return bs.Parameters(**{**P.to_dict(), **spec})


def case_runs(key: str, ops, duration: float, s0_offset: float, out_dir) -> list:
    """The measured runs of case ``key``: its truth synthesised at ``ops`` plus the case's advised
    runs (``EXTRA_OPS``), seed 3, the truth runs ``s0_offset`` off the s0 their files name."""
    truth = truth_of(CASES[key][1])
    params, chain = truth if isinstance(truth, tuple) else (truth, None)
    case_ops = list(ops) + [op for op in EXTRA_OPS.get(key, []) if op not in ops]
    paths = dc.synthesize_slider_runs(params, operating_points=case_ops, duration_s=duration, out_dir=out_dir,
                                      seed=3, s0_offset=s0_offset, chain=chain)
    return [bs.read_measurement(p) for p in paths]


def truth_values(spec) -> dict:
    """The hidden values by effect name (for the table's truth column)."""
    if isinstance(spec, str) and spec.startswith("detune:"):
        return {"natural_frequency_detuning": float(spec.split(":")[1])}
    if isinstance(spec, str) and spec.startswith("effects:"):
        return {k: float(v) for k, v in (kv.split("=") for kv in spec.split(":", 1)[1].split(","))}
    by_field = {e.field: n for n, e in dc.EFFECTS.items()}
    return {by_field.get(k, k): v for k, v in spec.items()}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--ops", default=";".join(",".join(f"{v:g}" for v in op) for op in OPS))
    ap.add_argument("--max-effects", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("docs/results/discover/table.md"))
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--force", action="store_true", help="overwrite --out")
    ap.add_argument("--rows-only", action="store_true", help="print the table rows only, --out is not written")
    ap.add_argument("--resume", action="store_true",
                    help="keep the rows --out already holds for the cases asked (same label) and run only the others")
    ap.add_argument("--search", choices=("tiered", "full", "fast"), default="tiered",
                    help="discover's search (docs/model.md §9.1, \"Cost\"): tiered (the default), full or fast")
    ap.add_argument("--json-dir", type=Path, default=None, help="write each case's report.json there as CASE.json")
    ap.add_argument("--runs", type=Path, default=None,
                    help="a file of kept runs the cases share (docs/model.md §9.1, \"Kept runs\"): the same rows, "
                         "each case making only the runs no case before it made (its wall time then counts those)")
    ap.add_argument("--s0-offset", type=float, default=0.0,
                    help="the truth runs start this far off the s0 their files name (no inverse crime; default 0)")
    args = ap.parse_args()
    ops = [tuple(float(v) for v in part.split(",")) for part in args.ops.split(";") if part.strip()]
    if args.out.exists() and not args.force and not args.rows_only and not args.resume:
        print(f"error: {args.out} exists (use --force to overwrite)", file=sys.stderr)
        return 1
    rows = ["| hidden truth | candidates | verdict | named: fitted ± stderr [95 % interval] | truth | gap before → after | gap beyond the noise before → after | wall time (load), CPU time of all threads |",
            "|---|---|---|---|---|---|---|---|"]
    done = {}
    if args.resume and args.out.exists():
        for line in args.out.read_text(encoding="utf-8").splitlines():
            if line.startswith("| ") and not line.startswith(("| hidden truth", "|---")):
                done[line.split(" | ")[0][2:]] = line
    if args.json_dir is not None:
        args.json_dir.mkdir(parents=True, exist_ok=True)
    for key in args.cases.split(","):
        label, spec, effects = CASES[key]
        if args.s0_offset:
            label = f"{label} (truth runs from s0 + {args.s0_offset:g})"
        if label in done:
            rows.append(done[label])
            print(f"kept (--resume): {label}", flush=True)
            continue
        with tempfile.TemporaryDirectory() as tmp:
            runs = case_runs(key, ops, args.duration, args.s0_offset, tmp)
            t0, c0 = time.perf_counter(), time.process_time()
            d = dc.discover(measured=runs, baseline=P, effects=effects, max_effects=args.max_effects, progress=True,
                            search=args.search, runs_file=args.runs)
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            load = os.getloadavg()
        named = "; ".join(f"{e} {dc.fmt_value(d.parameters[e]['value'])} ± {dc.fmt_value(d.parameters[e]['stderr'])} "
                          f"[{dc.fmt_value(d.parameters[e]['interval'][0])}, {dc.fmt_value(d.parameters[e]['interval'][1])}]"
                          for e in d.named_effects) or "—"
        if d.verdict == "confounded":  # the group, each member's fitted value (and interval, one effect)
            c = d.confounded
            named += " (the group: " + "; ".join(
                f"{e} {dc.fmt_value(c['values'][e])}" + (f" [{dc.fmt_value(c['intervals'][e][0])}, "
                                                         f"{dc.fmt_value(c['intervals'][e][1])}]"
                                                         if e in c.get("intervals", {}) else "")
                for e in c["group"] if e in c.get("values", {})) + ")"
        elif d.unresolved:
            u = d.unresolved
            named += " (best candidate, not resolved: " + "; ".join(
                f"{e} {dc.fmt_value(u['values'][e])} [{dc.fmt_value(u['intervals'][e][0])}, "
                f"{dc.fmt_value(u['intervals'][e][1])}]" for e in u["effects"]) + ")"
        truth_txt = ", ".join(f"{k} {dc.fmt_value(v)}" for k, v in truth_values(spec).items()) or "—"
        cands = f"all {len(SLIDER)}" if len(effects) == len(SLIDER) else f"all but {set(SLIDER).difference(effects).pop()}"
        if args.json_dir is not None:
            (args.json_dir / f"{key}.json").write_text(json.dumps(d.to_json(), indent=1), encoding="utf-8")
        line = (f"| {label} | {cands} | {d.verdict} | {named} | {truth_txt} | {d.gap_before:.3g} → {d.gap_after:.3g} | "
                f"{d.gap_excess_before:.3g} → {d.gap_excess_after:.3g} | {wall:.0f} s (load {load[0]:.1f}), CPU {cpu:.0f} s |")
        rows.append(line)
        print(line, flush=True)
        print("   ", dc.verdict_line(d), flush=True)
        best = d.rejected[0] if d.rejected and not d.named_effects else None
        if best:
            print("    best rejected:", best["effects"], {k: round(v, 6) for k, v in best["values"].items()},
                  f"chi2 {best['chi2']:.3g}", best["reasons"], flush=True)
        text = (f"Slider-level discover (scripts/repro/discover_table.py): {len(ops)} runs of {args.duration:g} s at "
                f"{ops} (f_ex Hz, a_ex m/s², s0), s noise 0.001, seed 3, sets of up to {args.max_effects} effect(s), "
                f"baseline the prototype; wall time on {os.cpu_count()} cores with the 1-min load average of the "
                f"machine at the end of each case; the CPU time of all threads of the process (core runs, features, "
                f"fits) is what an otherwise idle machine spends, so CPU/2 is the idle 2-core wall time.\n\n" + "\n".join(rows) + "\n")
        if not args.rows_only:
            args.out.parent.mkdir(parents=True, exist_ok=True)
            args.out.write_text(text, encoding="utf-8")
    if not args.rows_only:
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
