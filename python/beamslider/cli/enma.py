"""``beamslider enma``: ENMA data (measured, or a virtual ENMA of a truth model) → backbone fit →
updated clamping (k_r, k_t, damping) → TOML, report and the paper's Fig. 3.

Fit the single-mode backbone w~^2 = w^2 + 3/4 b* a~^2 to ENMA data and update the clamping
stiffnesses k_r, k_t (and the damping ratio) of the --params model (default: the prototype with
ideal clamping). Without DATA, a virtual ENMA of --truth (default: the prototype) makes the data.
Writes enma_data.csv, enma_updated.toml, enma_report.json, enma_report.md and enma.png into --out."""

from __future__ import annotations

import argparse
import math
import time
from typing import Any, Dict

from .. import enma
from ..params import Parameters
from ._common import UserError, add_common, axis_values, doc_body, out_dir, plan_outputs, positive, write_json


def add_parser(sub: Any) -> None:
    """Register the subcommand."""
    sp = sub.add_parser(
        "enma", help="ENMA data -> backbone fit -> updated clamping k_r, k_t (paper section 3)",
        description=doc_body(__doc__))
    sp.add_argument("data", nargs="?", help="ENMA CSV (columns amplitude_h, frequency_hz[, damping_ratio, run, ...])")
    sp.add_argument("--truth", metavar="TOML", help="model of the virtual ENMA when no DATA is given (default: prototype)")
    sp.add_argument("--levels", metavar="GRID", help="virtual ENMA levels a_ex [m/s^2]: START:STOP:STEP or a comma list "
                                                    "(default 0.25:4:0.25)")
    sp.add_argument("--noise-frequency", type=float, default=0.0, metavar="REL",
                    help="relative Gaussian noise on the virtual frequencies (e.g. 0.002)")
    sp.add_argument("--repeats", type=positive(int), default=1, metavar="N",
                    help="independently noisy repetitions of the virtual up-and-down run (default 1)")
    sp.add_argument("--seed", type=int, default=0, help="noise seed (0)")
    add_common(sp, window=False, force=True)
    sp.set_defaults(func=cmd_enma)


def cmd_enma(args: argparse.Namespace) -> int:
    baseline = (Parameters.from_toml(args.params) if args.params
                else Parameters(k_r_nm_per_rad=math.inf, k_t_n_per_m=math.inf))
    plan_outputs(args, ([] if args.data else ["enma_data.csv"]) + ["enma_updated.toml", "enma_report.json", "enma_report.md", "enma.png"])
    t0 = time.perf_counter()
    if args.data:
        if args.truth or args.levels or args.noise_frequency or args.repeats != 1:
            raise UserError("--truth/--levels/--noise-frequency/--repeats make virtual data: not with a DATA file")
        data = enma.read(args.data)
        truth = None
    else:
        truth = Parameters.from_toml(args.truth) if args.truth else Parameters()
        levels = axis_values("--levels", args.levels) if args.levels else list(enma.DEFAULT_LEVELS_M_S2)
        data = enma.virtual(truth, levels_m_s2=levels, progress=args.progress)
        if args.noise_frequency or args.repeats > 1:
            data = enma.with_noise(data, frequency_rel=args.noise_frequency, seed=args.seed, repeats=args.repeats)
    t_data = time.perf_counter() - t0
    out = out_dir(args)
    fit = enma.fit_backbone(data)
    upd = enma.update_clamping(baseline, fit, full_output=True)
    assert isinstance(upd, enma.ClampingUpdate)
    w2_base, b_base = enma.model_backbone(baseline)
    w2_upd, b_upd = enma.model_backbone(upd.params)
    written = []
    if not args.data:
        data.write(out / "enma_data.csv")
        written.append(out / "enma_data.csv")
    upd.params.to_toml(out / "enma_updated.toml")
    written.append(out / "enma_updated.toml")
    f_fit = fit.linear_frequency_hz
    report: Dict[str, Any] = dict(
        data=dict(source=data.source, points=len(data), runs=sorted(set(map(str, data.run))),
                  amplitude_h_range=[float(data.amplitude_h.min()), float(data.amplitude_h.max())],
                  seconds_to_make=t_data),
        fit=fit.to_dict(),
        update=upd.to_dict(),
        baseline=dict(linear_frequency_hz=math.sqrt(w2_base) / (2 * math.pi), b_star=b_base,
                      k_r_nm_per_rad=baseline.k_r_nm_per_rad, k_t_n_per_m=baseline.k_t_n_per_m,
                      fitted_vs_baseline_frequency_rel=f_fit / (math.sqrt(w2_base) / (2 * math.pi)) - 1,
                      fitted_vs_baseline_b_star_rel=fit.b_star / b_base - 1),
        updated=dict(linear_frequency_hz=math.sqrt(w2_upd) / (2 * math.pi), b_star=b_upd),
    )
    if truth is not None:
        report["truth"] = dict(k_r_nm_per_rad=truth.k_r_nm_per_rad, k_t_n_per_m=truth.k_t_n_per_m,
                               k_r_error_rel=upd.k_r_nm_per_rad / truth.k_r_nm_per_rad - 1
                               if math.isfinite(truth.k_r_nm_per_rad) else None,
                               k_t_error_rel=upd.k_t_n_per_m / truth.k_t_n_per_m - 1
                               if math.isfinite(truth.k_t_n_per_m) else None)
    write_json(out / "enma_report.json", report)
    written.append(out / "enma_report.json")
    md = _markdown(report)
    (out / "enma_report.md").write_text(md, encoding="utf-8")
    written.append(out / "enma_report.md")
    enma.plot_enma(data, fit, models={"baseline": baseline, "updated": upd.params}, path=out / "enma.png")
    written.append(out / "enma.png")
    print(md, end="")
    for p in written:
        print(f"wrote {p}")
    return 0


def _g(x: float, fmt: str = ".4g") -> str:
    return "inf" if isinstance(x, float) and math.isinf(x) else format(x, fmt)


def _markdown(r: Dict[str, Any]) -> str:
    f, u, b, n = r["fit"], r["update"], r["baseline"], r["updated"]
    lines = [
        "# ENMA model updating (paper section 3, docs/model.md section 9)",
        "",
        f"Data: {r['data']['source']}, {r['data']['points']} points, a~ = "
        f"{r['data']['amplitude_h_range'][0]:.3f} ... {r['data']['amplitude_h_range'][1]:.3f}",
        "",
        "| quantity | fitted / updated | +- std. error | baseline (fitted vs baseline) | updated model |",
        "|---|---|---|---|---|",
        f"| linear frequency [Hz] | {f['linear_frequency_hz']:.3f} | {f['linear_frequency_stderr_hz']:.3f} | "
        f"{b['linear_frequency_hz']:.3f} ({100 * b['fitted_vs_baseline_frequency_rel']:+.2f} %) | {n['linear_frequency_hz']:.3f} |",
        f"| b* [1/s^2] | {f['b_star']:.4g} | {f['b_star_stderr']:.2g} | {b['b_star']:.4g} "
        f"({100 * b['fitted_vs_baseline_b_star_rel']:+.1f} %) | {n['b_star']:.4g} |",
        f"| k_r [N m/rad] | {_g(u['k_r_nm_per_rad'])} | {_g(u['k_r_stderr'], '.2g')} | {_g(b['k_r_nm_per_rad'])} | |",
        f"| k_t [N/m] | {_g(u['k_t_n_per_m'])} | {_g(u['k_t_stderr'], '.2g')} | {_g(b['k_t_n_per_m'])} | |",
        f"| damping ratio (mean) [%] | {_g(100 * u['damping_ratio'], '.4f')} | "
        f"{_g(100 * f['damping_ratio_stderr'], '.2g')} | | |",
        "",
        f"Residual RMS of the backbone fit: {f['residual_rms_hz']:.3f} Hz.",
    ]
    t = r.get("truth")
    if t:
        parts = []
        if t["k_r_error_rel"] is not None:
            parts.append(f"k_r {100 * t['k_r_error_rel']:+.2f} % (truth {_g(t['k_r_nm_per_rad'])})")
        if t["k_t_error_rel"] is not None:
            parts.append(f"k_t {100 * t['k_t_error_rel']:+.2f} % (truth {_g(t['k_t_n_per_m'])})")
        if parts:
            lines += ["", "Recovered vs truth: " + ", ".join(parts) + "."]
    return "\n".join(lines) + "\n"
