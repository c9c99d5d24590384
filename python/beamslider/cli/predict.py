"""``beamslider drift-table``, ``beamslider fit-law`` and ``beamslider predict``: the reduced
super-slow predictor (docs/model.md §6.3): the drift velocity V(s, branch) measured in PCS sweeps,
the transferable drift law fitted on the tables of several operating points, and the prediction of
one operating point from the HB manifold, a drift law and the slow flow."""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path
from typing import Any, List, Tuple

from ..params import Parameters
from ..superslow import (DEFAULT_LAW_PATH, design_coordinates, design_params, design_sample, fit_design_law,
                         load_drift_law, save_design_law, LAW_JUMP_DOWN_N, LAW_TABLE_SETTINGS, LAW_TRAINING_POINTS, drift_table, drift_tables,
                         fit_drift_law, load_law, predict, read_drift_table, refine_jump_down, save_drift_law)
from ._manifold import add_operating_point
from ._common import (DEFAULT_OUT, UserError, add_common, axis_values, figure, fmt, out_dir, params_from_args,
                      plan_outputs, positive, print_written, write_json)

DEFAULT_LAW_OUT = f"{DEFAULT_OUT}/law"
"""Where ``beamslider fit-law`` writes by default (law.json and drift/)."""


def _add_sweep(sp: Any, *, ds: float, window_s: float, settle_periods: int) -> None:
    """The options of the PCS sweeps of a drift table (s step, record window, settling periods)."""
    sp.add_argument("--ds", type=positive(float), default=ds, metavar="DS", help=f"s step of the sweeps ({ds:g})")
    sp.add_argument("--window-s", type=positive(float), default=window_s, metavar="S", help=f"record window per s ({window_s:g})")
    sp.add_argument("--settle-periods", type=positive(int), default=settle_periods, metavar="K",
                    help=f"settling periods per s ({settle_periods})")


def add_parser(sub: Any) -> None:
    """Register ``drift-table``, ``fit-law`` and ``predict``."""
    sp = sub.add_parser(
        "drift-table", help="drift velocity V(s, branch) from PCS sweeps (layer b1; minutes)",
        description="Measure the super-slow drift velocity V(s, branch) of the slider's centre of mass in "
                    "pseudo-constrained runs on both branches (down-sweep from the centre for the low branch, "
                    "up-sweep from the clamping for the high branch) and write drift_<f>Hz_<a>ms2.jsonl "
                    "(rows appended as produced; --resume continues a killed run).")
    add_operating_point(sp, positive_level=True)
    _add_sweep(sp, ds=0.02, window_s=1.0, settle_periods=40)
    sp.add_argument("--resume", action="store_true", help="continue an existing table made with the same settings")
    add_common(sp, window=False, force=True)
    sp.set_defaults(func=cmd_drift_table)

    sp = sub.add_parser(
        "fit-law", help="fit the transferable drift law (b2) on PCS tables of several points (minutes)",
        description="Compute the PCS drift tables of the training points (both sweeps each, two tables at a time, "
                    "resumable), narrow the law's jump-down bracket by bisection over candidate points "
                    "(refine_jump_down), fit the drift law and write DIR/law.json, with the tables under "
                    "DIR/drift/. The defaults are the recipe of the built-in law; with --params a law for "
                    "another beam or slider. Use it with beamslider predict --law DIR/law.json and "
                    "beamslider map --predictor DIR/law.json.")
    sp.add_argument("--points", metavar="F:A,...",
                    help="training points as f_ex:a_ex pairs (default: the built-in law's 12, "
                         + ",".join(f"{f:g}:{a:g}" for f, a in LAW_TRAINING_POINTS) + ")")
    sp.add_argument("--candidates-f-ex", default="100:130:2", metavar="GRID",
                    help="frequencies of the jump-down bisection's candidate points (100:130:2)")
    sp.add_argument("--candidates-a-ex", default="4:16:2", metavar="GRID",
                    help="levels of the jump-down bisection's candidate points (4:16:2)")
    sp.add_argument("--jump-down-n", type=int, default=LAW_JUMP_DOWN_N, metavar="N",
                    help=f"jump-down tables added by bisection ({LAW_JUMP_DOWN_N}; 0: none)")
    _add_sweep(sp, **{k: LAW_TABLE_SETTINGS[k] for k in ("ds", "window_s", "settle_periods")})
    sp.add_argument("--first-settle-periods", type=positive(int), default=400, metavar="K",
                    help="settling periods at the first s of a sweep, from rest (400)")
    sp.add_argument("--threads", "-j", type=positive(int), metavar="N", help="tables computed at a time (default: one per core)")
    sp.add_argument("--design", type=int, default=0, metavar="N",
                    help="a design law (docs/model.md §6.5): fit the law of the prototype (--params) and of N designs "
                         "drawn over the design box, and blend them (DIR/design_law.json; the built-in law: N = 64)")
    sp.add_argument("--design-seed", type=int, default=0, metavar="S", help="seed of the designs' Sobol' sequence (0)")
    sp.add_argument("--resume", action="store_true", help="continue the tables in --out (same settings) and refit")
    add_common(sp, window=False, out=DEFAULT_LAW_OUT, force=True)
    sp.set_defaults(func=cmd_fit_law)

    sp = sub.add_parser(
        "predict", help="reduced super-slow predictor: behaviour and final s of one operating point (milliseconds)",
        description="Predict one operating point with the reduced model of docs/model.md §6.3: HB manifold (layer a), a drift "
                    "law (a PCS drift table of this point, or a fitted law) and the slow flow with jump events, "
                    "classified by the operating-map classifier. Writes predict_<f>Hz_<a>ms2_s0_<s0>.csv/.json/.png.")
    add_operating_point(sp, positive_level=True)
    sp.add_argument("--s0", type=positive(float), default=0.3, metavar="S0", help="initial slider position (0.3)")
    sp.add_argument("--t-end", type=positive(float), default=120.0, metavar="S", help="duration (120)")
    g = sp.add_mutually_exclusive_group()
    g.add_argument("--drift", metavar="JSONL", help="drift table of this operating point (beamslider drift-table)")
    g.add_argument("--law", metavar="JSON", help="fitted drift law (beamslider.superslow.fit_drift_law(...).save); "
                                                 "neither --drift nor --law: the built-in default law, fitted at the "
                                                 "default parameters")
    sp.add_argument("--s-dn", choices=["auto", "hb", "table", "law", "none"], default="auto",
                    help="jump-down position: from the HB manifold (hb), from the PCS table (table, with --drift), "
                         "the HB manifold's else the law's forcing-ratio rule (law, with --law), or none; "
                         "auto (default): law with --law, hb with --drift")
    sp.add_argument("--d-eff", type=float, metavar="D", help="equivalent damping ratio of the HB manifold")
    add_common(sp, window=False, force=True)
    sp.set_defaults(func=cmd_predict)


def cmd_drift_table(args: argparse.Namespace) -> int:
    p = params_from_args(args)
    name = f"drift_{fmt(args.f_ex)}Hz_{fmt(args.a_ex)}ms2.jsonl"
    if not args.resume:
        plan_outputs(args, [name])
    path = out_dir(args) / name
    if args.force and not args.resume and path.exists():
        path.unlink()
    if args.resume and not path.exists():
        raise UserError(f"{path} does not exist: nothing to resume (drop --resume)")
    t0 = time.perf_counter()
    t = drift_table(p, f_ex=args.f_ex, a_ex=args.a_ex, ds=args.ds, window_s=args.window_s,
                    settle_periods=args.settle_periods, out=Path(path), resume=args.resume, progress=sys.stderr.isatty() if args.progress is None else args.progress)
    wall = time.perf_counter() - t0
    s_up, s_dn = t.s_jumps()
    show = lambda v: "none" if v is None else f"{v:.4f}"  # noqa: E731
    print(f"drift table {args.f_ex:g} Hz, {args.a_ex:g} m/s²: {len(t.s)} rows ({t.computed} computed, {wall:.1f} s); "
          f"PCS s_up = {show(s_up)}, s_dn = {show(s_dn)}")
    print(f"wrote {path}")
    return 0


def _points(text: str) -> List[Tuple[float, float]]:
    pts = []
    for item in text.split(","):
        f, sep, a = item.strip().partition(":")
        try:
            pt = (float(f), float(a))
        except ValueError:
            pt = None
        if not sep or pt is None or not all(math.isfinite(v) and v > 0 for v in pt):
            raise UserError(f"--points: {item.strip()!r} is not f_ex:a_ex with two positive numbers (e.g. 124:14)")
        pts.append(pt)
    if len(set(pts)) != len(pts):
        raise UserError("--points: a training point is given twice")
    return pts


def _law_content(path: Path) -> Any:
    """A law file without its fit time (the rest is deterministic)."""
    import json

    d = json.loads(path.read_text(encoding="utf-8"))
    d.pop("fit_time_s", None)
    return d


def cmd_fit_law(args: argparse.Namespace) -> int:
    p = params_from_args(args)
    pts = _points(args.points) if args.points else list(LAW_TRAINING_POINTS)
    if len(pts) < 2:
        raise UserError("--points: at least two training points (the law is validated leaving one out)")
    if args.jump_down_n < 0:
        raise UserError(f"--jump-down-n {args.jump_down_n}: must be >= 0")
    if args.design < 0 or args.design == 1 or args.design > 4096:
        raise UserError(f"--design {args.design}: 0 (one law) or 2 to 4096 designs")
    cand = [(f, a) for f in axis_values("--candidates-f-ex", args.candidates_f_ex)
            for a in axis_values("--candidates-a-ex", args.candidates_a_ex)]
    out = Path(args.out)
    if args.resume and args.force:
        raise UserError("give --resume or --force, not both")
    ours = [f for pat in ("law.json", "design_law.json", "drift/**/drift_*.jsonl", "designs/**/*")
            for f in out.glob(pat)] if out.exists() else []
    ours = [f for f in ours if f.is_file()]
    if ours and not (args.resume or args.force):
        raise UserError(f"{out} holds an earlier fit ({len(ours)} files, e.g. {ours[0]}): --resume continues it, "
                        "--force starts again")
    if args.force:
        for f in ours:
            f.unlink()
    settings = dict(ds=args.ds, settle_periods=args.settle_periods, first_settle_periods=args.first_settle_periods,
                    window_s=args.window_s)
    progress = sys.stderr.isatty() if args.progress is None else args.progress
    t0, c0 = time.perf_counter(), time.process_time()
    if args.design:
        return _fit_design(args, p, pts, cand, settings, progress, out, t0, c0)
    law, tabs, extra = _fit_one(args, p, pts, cand, settings, progress, out)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    lo = law.loo
    br = law.rho_bracket or {}
    print(f"drift law from {len(tabs)} tables + {len(extra)} jump-down tables in {wall:.1f} s ({cpu:.1f} s CPU)"
          + (f"; added {', '.join(f'({t.f_ex:g}, {t.a_ex:g})' for t in extra)}" if extra else ""))
    rel = lambda e, t: e / t if t > 0 else float("nan")  # noqa: E731  (a branch without rows: no typical |V|)
    print(f"leave one point out: V error {lo['ratio']:.3f} of the typical |V| (L {rel(lo['rms_error_L'], lo['typical_v_L']):.3f}, "
          f"H {rel(lo['rms_error_H'], lo['typical_v_H']):.3f})")
    print(f"s_up shift {law.s_up_shift:+.4f}, lift-off threshold Λ_c {law.lift_c:.3f}, "
          + (f"jump-down at s_p = {law.jump_down_s:.3f} where ρ ≤ ρ_c = {law.rho_c:.5f}" if law.rho_c > 0 else "no jump-down learnt")
          + (f" (bracket {br['lo']:.5f} … {br['hi']:.5f})" if br.get("lo") is not None and br.get("hi") is not None else "")
          + f", V resolution {law.v_resolution:.2e} 1/s")
    law_path = out / "law.json"
    if p == Parameters() and _law_content(law_path) == _law_content(DEFAULT_LAW_PATH):
        print("(the built-in default law: the same samples and constants)")
    print(f"wrote {law_path} (tables in {out / 'drift'}); use it: beamslider predict --law {law_path}, "
          f"beamslider map --predictor {law_path}")
    return 0


def _fit_one(args, p, pts, cand, settings, progress, out):
    """The law of one parameter set by the recipe (tables, jump-down bisection, fit) into out/law.json."""
    law_path, drift_dir = out / "law.json", out / "drift"
    tabs = drift_tables(p, points=pts, out=drift_dir, resume=args.resume, threads=args.threads, progress=progress, **settings)
    extra = refine_jump_down(tabs, candidates=cand, n=args.jump_down_n, params=p, out=drift_dir / "jump_down",
                             threads=args.threads, progress=progress, **settings) if args.jump_down_n else []
    law = fit_drift_law(tabs, params=p, jump_down_tables=extra)
    tmp = law_path.with_name(law_path.name + ".tmp")
    save_drift_law(law, tmp)
    tmp.replace(law_path)
    return law, tabs, extra


def _fit_design(args, p, pts, cand, settings, progress, out, t0, c0) -> int:
    """``fit-law --design N``: the prototype's law and those of N designs over the box, blended."""
    designs = [design_coordinates(p, p)] + design_sample(args.design, seed=args.design_seed)
    laws = []
    for i, x in enumerate(designs):
        d = out / "designs" / ("prototype" if i == 0 else f"design_{i - 1:03d}")
        d.mkdir(parents=True, exist_ok=True)
        q = p if i == 0 else design_params(x, p)
        (d / "params.toml").write_text(q.toml_text(), encoding="utf-8")
        if args.resume and (d / "law.json").exists():
            laws.append(load_drift_law(d / "law.json"))
            continue
        laws.append(_fit_one(args, q, pts, cand, settings, progress, d)[0])
        print(f"design {i}/{len(designs) - 1}: {d / 'law.json'} ({time.perf_counter() - t0:.0f} s)", flush=True)
    law = fit_design_law(designs, laws, base=p)
    path = out / "design_law.json"
    tmp = path.with_name(path.name + ".tmp")
    save_design_law(law, tmp)
    tmp.replace(path)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(f"design law from {len(laws)} designs in {wall:.1f} s ({cpu:.1f} s CPU); leave one design out: V error "
          f"{law.loo['ratio']:.3f} of the typical |V|; length scales "
          + ", ".join(f"{c.name} {s:g}" for c, s in zip(law.box, law.scales)))
    print(f"wrote {path}; use it: beamslider predict --law {path}, beamslider map --predictor {path}")
    return 0


def cmd_predict(args: argparse.Namespace) -> int:
    p = params_from_args(args)
    stem = f"predict_{fmt(args.f_ex)}Hz_{fmt(args.a_ex)}ms2_s0_{fmt(args.s0)}"
    plan_outputs(args, [f"{stem}.{ext}" for ext in ("csv", "json", "png")])
    try:
        drift = read_drift_table(args.drift) if args.drift else load_law(args.law) if args.law else None
    except FileNotFoundError as e:
        raise UserError(f"cannot read {e.filename or args.drift or args.law}: no such file") from None
    r = predict(p, f_ex=args.f_ex, a_ex=args.a_ex, s0=args.s0, t_end=args.t_end, drift=drift, s_dn=args.s_dn, d_eff=args.d_eff)
    out = out_dir(args)
    with open(out / f"{stem}.csv", "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["t_s", "s", "amplitude_h", "branch"])
        for row in zip(r.t, r.s, r.amplitude, r.branch):
            w.writerow([f"{row[0]:.6g}", f"{row[1]:.10g}", f"{row[2]:.10g}", row[3]])
    write_json(out / f"{stem}.json", {
        "kind": "prediction", "f_ex_hz": r.f_ex, "a_ex_m_s2": r.a_ex, "s0": r.s0, "t_end_s": args.t_end,
        "drift": args.drift or args.law or "built-in default law", "behaviour": r.behaviour, "s_final": r.s_final, "amplitude_final_h": r.amplitude_final,
        "events": [{"kind": k, "t_s": t, "s": s} for k, t, s in r.events], "s_up": r.s_up, "s_dn": r.s_dn,
        "s_dn_source": r.s_dn_source, "extrapolated": r.extrapolated, "monostable": r.monostable, "warnings": r.warnings,
        "robust": r.robust, "shifted": [{"behaviour": b, "s_final": s} for b, s in r.shifted],
        "classification": r.classification, "timings_s": r.timings_s, "params_toml": p.toml_text(),
    })
    drew = figure(_draw_prediction, r, out / f"{stem}.png")
    for w_ in r.warnings:
        print(f"beamslider: warning: {w_}", file=sys.stderr)
    print(f"predict {r.f_ex:g} Hz, {r.a_ex:g} m/s², s0 = {r.s0:g}: {r.behaviour}, s_final = {r.s_final:.4f}, "
          f"Â_final = {r.amplitude_final:.3f} h ({1e3 * sum(r.timings_s.values()):.1f} ms)"
          + ("; monostable (the law's vote: no jump-up, a single low branch)" if r.monostable else "")
          + ("" if r.robust is None else "; robust (V ± its resolution gives the same)" if r.robust else
             "; NOT robust: V ± its resolution gives " + ", ".join(f"{b} at s = {s:.3f}" for b, s in r.shifted) + " (check with an FS run)"))
    return print_written(out, stem, drew)


def _draw_prediction(r: Any, path: Any) -> None:
    from .._mpl import require_matplotlib

    require_matplotlib("the prediction figure")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(6.4, 5.0), sharex=True)
    a1.plot(r.t, r.s, color="k")
    a1.set_ylabel("s")
    a2.plot(r.t, r.amplitude, color="tab:red")
    a2.set_ylabel("Â = |w(4L/7)|/h")
    a2.set_xlabel("t [s]")
    for k, t, s in r.events:
        if k in ("jump_up", "jump_down"):
            for a in (a1, a2):
                a.axvline(t, color="0.6", lw=0.8, ls=":")
    a1.set_title(f"predicted: {r.f_ex:g} Hz, {r.a_ex:g} m/s², s0 = {r.s0:g} — {r.behaviour}")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
