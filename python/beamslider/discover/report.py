"""The report of a discovery: updated TOML, ``report.json``, ``report.md`` and figures."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, List, Sequence, Union

import numpy as np

from .. import enma
from ..enma import EnmaData
from .effects import EFFECTS
from .chain import as_model, realise_model
from .models import OperatingPoint, slider_paths
from .options import DEFAULT
from .reasons import Why
from .result import Because, Discovery, GAP_EXCESS_MEASURE, GAP_MEASURE, Kind
from .stats import interval_of

PathLike = Union[str, "os.PathLike[str]"]


PLOT_POINTS = 4000
"""Points of a line of the report's slider figure, at most about (every k-th sample)."""


def write_report(d: Discovery, out_dir: PathLike) -> List[Path]:
    """Write ``updated.toml``, ``report.json``, ``report.md`` and the figures into ``out_dir``."""
    from .._mpl import require_matplotlib

    require_matplotlib("the discover report's figures")
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    d.updated.to_toml(out / "updated.toml")
    written.append(out / "updated.toml")
    with open(out / "report.json", "w", encoding="utf-8") as f:
        json.dump(d.to_json(), f, indent=2)
        f.write("\n")
    written.append(out / "report.json")
    # Figure 1: disagreement per feature before and after, in units of the uncertainty.
    names = list(d.features)
    zb = [d.features[k]["z_before"] for k in names]
    za = [d.features[k]["z_after"] for k in names]
    fig, ax = plt.subplots(figsize=(max(6.0, 0.9 * len(names) + 2), 4.2), constrained_layout=True)
    x = np.arange(len(names))
    ax.bar(x - 0.2, zb, 0.4, label=f"baseline (gap {d.gap_before:.3g})")
    ax.bar(x + 0.2, za, 0.4, label=f"updated (gap {d.gap_after:.3g})")
    ax.set_yscale("symlog", linthresh=2.0)
    ax.axhspan(-2, 2, color="0.85", zorder=0, label="±2 uncertainties")
    ax.set_xticks(x, names, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("(model − measured) / uncertainty (symlog)")
    ax.set_title(gap_title(d))
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    fig.savefig(out / "gap.png", dpi=120)
    plt.close(fig)
    written.append(out / "gap.png")
    figs = ["gap.png"]
    # Joint level: data = dict(enma=..., measured=[...]); both figures.
    enma_d = d.data.get("enma") if isinstance(d.data, dict) else (d.data if isinstance(d.data, EnmaData) else None)
    runs_d = d.data.get("measured") if isinstance(d.data, dict) else (d.data if d.level == "slider" else None)
    if enma_d is not None:
        fig = enma.plot_enma(enma_d, enma.fit_backbone(enma_d), models={"baseline": d.baseline, "updated": d.updated})
        fig.suptitle(gap_title(d))  # every figure states the report's verdict
        fig.savefig(out / "backbone.png", dpi=130)
        plt.close(fig)
        written.append(out / "backbone.png")
        figs.append("backbone.png")
    if runs_d:
        ms = runs_d
        ops = [OperatingPoint(m.f_ex, m.a_ex, m.s0, float(m.t[-1])) for m in ms]
        if d.paths:
            base_runs, upd_runs = ([d.paths[k].get(op.tag) for op in ops] for k in ("baseline", "updated"))
        else:
            # The updated model as its measurement chain records (the chain's named values included).
            named = {e: float(v["value"]) for e, v in d.parameters.items()}
            base_runs, upd_runs = slider_paths([as_model(d.baseline), realise_model(d.baseline, named)], ops)
        fig, axs = plt.subplots(1, len(ms), figsize=(5.5 * len(ms), 4), constrained_layout=True, squeeze=False)
        for ax, m, rb, ru, op in zip(axs[0], ms, base_runs, upd_runs, ops):
            # At most about PLOT_POINTS points a line: the slider moves over seconds, the samples are 0.1 ms.
            for r, style, kw in (((m.t, m.s), "-", dict(color="0.4", lw=0.8, label="measured")),
                                 (rb, "--", dict(lw=1.3, label="baseline")), (ru, "-", dict(lw=1.3, label="updated"))):
                if r is None:
                    continue
                k = max(1, len(r[0]) // PLOT_POINTS)
                ax.plot(r[0][::k], r[1][::k], style, **kw)
            ax.set_title(f"f_ex = {op.f_ex:g} Hz, a_ex = {op.a_ex:g} m/s², s₀ = {op.s0:g}")
            ax.set_xlabel("t [s]")
            ax.set_ylabel("s = x_C / L [-]")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        fig.suptitle(gap_title(d))  # every figure states the report's verdict
        fig.savefig(out / "slider.png", dpi=120)
        plt.close(fig)
        written.append(out / "slider.png")
        figs.append("slider.png")
    md = _markdown(d, figs)
    (out / "report.md").write_text(md, encoding="utf-8")
    written.append(out / "report.md")
    return written


def verdict_line(d: Discovery) -> str:
    """The verdict in one line (the CLI prints it), from the typed verdict (:attr:`.result.Discovery.judgment`)."""
    v = d.judgment
    if v.kind is Kind.NAMED:
        what = ", ".join(f"{e} ({d.parameters[e]['field']} = {fmt_value(d.parameters[e]['value'])} ± "
                         f"{fmt_value(d.parameters[e]['stderr'])}, baseline {fmt_value(d.parameters[e]['baseline'])})"
                         for e in v.named.effects)
        return (f"named {what}; gap {d.gap_before:.3g} -> {d.gap_after:.3g} "
                f"(beyond the noise {d.gap_excess_before:.3g} -> {d.gap_excess_after:.3g})")
    adv = v.advice.get("text")
    if v.because is Because.CONFOUNDED:
        c = v.group
        lead = "; " if v.advice.get("weak") else "; to separate them, "
        return (f"confounded: {', '.join(c['group'])} fit equally (the data resolve {c['combination']}, not which of "
                f"them changed; gap {d.gap_before:.3g})" + (f"{lead}{adv}" if adv else ""))
    if v.because is Because.NOT_RESOLVED:
        u = v.unresolved
        vals = ", ".join(f"{EFFECTS[e].field} = {fmt_value(u.values[e])} ± {fmt_value(u.stderrs[e])}" for e in u.effects)
        reasons = v.reasons[u.effects]
        why = next((r for r in reasons if r.kind is Why.NOT_RESOLVED), reasons[-1]).removeprefix("not resolved: ")
        return (f"unexplained discrepancy (gap {d.gap_before:.3g}) - best candidate {' + '.join(u.effects)} "
                f"({vals}), not resolved by these runs ({why})" + (f"; to resolve it, {adv}" if adv else ""))
    if v.because is Because.POOR_FIT:
        p = v.poor_fit
        vals = ", ".join(f"{EFFECTS[e].field} = {fmt_value(p['values'][e])} ± {fmt_value(p['stderrs'][e])}"
                         for e in p["effects"])
        return (f"unexplained discrepancy (gap {d.gap_before:.3g}) - best candidate {' + '.join(p['effects'])} "
                f"({vals}) does not fit as right models do: its full simulation leaves gap {p['gap']:.3g} > "
                f"{p['gap_bound']:.3g}")
    if v.because is Because.OUTSIDE_CANDIDATES:
        c = v.group
        lead = "; " if v.advice.get("weak") else "; to separate them, "
        return (f"unexplained discrepancy (gap {d.gap_before:.3g}) - the best set {' + '.join(c['sets'][0])} fits "
                f"as well as {', '.join(c['not_candidates'])}, not among the candidates (the data resolve "
                f"{c['combination']}, not which of them changed)" + (f"{lead}{adv}" if adv else ""))
    if v.because is Because.NO_SET_PASSES:
        off = ", ".join(f"{f['feature']} z = {f['z']:+.1f}" for f in d.features_off[:3])
        best = v.best_rejected
        why = f"; best candidate {' + '.join(best.effects)} rejected: {v.why_not(best)[0]}" if best else ""
        return f"unexplained discrepancy (gap {d.gap_before:.3g}; off: {off or 'no single feature beyond 2 sigma'}){why}"
    if v.because is Because.NEGLIGIBLE_CHANGE:
        neg = v.negligible[0]
        return (f"none (gap {d.gap_before:.3g} closed by a negligible change: {' + '.join(neg.effects)}, "
                f"{v.why_not(neg)[0]})")
    return f"none (the baseline fits: gap {d.gap_before:.3g})"


def gap_title(d: Discovery) -> str:
    """The title of ``gap.png``, from the typed verdict."""
    v = d.judgment
    if v.kind is Kind.NAMED:
        return "named: " + ", ".join(v.named.effects)
    if v.kind is Kind.CONFOUNDED:
        return "confounded: " + ", ".join(v.group["group"]) + " (nothing named)"
    if v.kind is Kind.UNEXPLAINED:
        return "unexplained: nothing named (" + v.because.value + ")"
    return "named: nothing (" + ("only a negligible change is needed" if v.because is Because.NEGLIGIBLE_CHANGE
                                 else "model agrees within uncertainty") + ")"


def fmt_value(v: Any) -> str:
    if isinstance(v, float):
        return "inf" if math.isinf(v) else f"{v:.5g}"
    return str(v)


def _markdown(d: Discovery, figs: Sequence[str]) -> str:
    v = d.judgment
    level = (d.options or DEFAULT).interval_level
    lines = [f"# Discrepancy report ({d.level} level)", "", f"**Verdict: {verdict_line(d)}**", ""]
    if v.kind is Kind.NAMED:
        lines.append("**Named effect(s): " + ", ".join(f"`{e}`" for e in v.named.effects) + "**")
    elif v.because is Because.OUTSIDE_CANDIDATES:
        lines.append(f"**Unexplained discrepancy** — {v.group['explanation']}: the candidates do not establish "
                     f"the change; nothing was added to the model. Resolved combination: "
                     f"{v.group['combination']}.")
    elif v.because is Because.POOR_FIT:
        p = v.poor_fit
        lines.append(f"**Unexplained discrepancy** — the best candidate {' + '.join(f'`{e}`' for e in p['effects'])} "
                     f"closes part of the gap, but the full simulation of the model with it leaves chi2 = "
                     f"{p['chi2']:.3g} (gap {p['gap']:.3g}), more than right models leave on data they made "
                     f"themselves (bound {p['bound']:.3g}, gap {p['gap_bound']:.3g}; docs/model.md §9.1, "
                     f"\"Goodness of fit\"): something the candidates do not hold is missing; nothing was added "
                     f"to the model.")
    elif v.kind is Kind.UNEXPLAINED:
        lines.append("**Unexplained discrepancy** — the baseline does not fit the data and no candidate effect "
                     "passes the naming rule; nothing was added to the model.")
    elif v.kind is Kind.CONFOUNDED:
        lines.append(f"**Confounded: {', '.join(f'`{e}`' for e in v.group['group'])}** — "
                     f"{v.group['explanation']}; nothing was added to the model. Resolved combination: "
                     f"{v.group['combination']}.")
    elif v.because is Because.NEGLIGIBLE_CHANGE:
        lines.append("**Named: nothing** — the data are explained by a change smaller than the candidates' "
                     "relevance thresholds.")
    else:
        lines.append("**Named: nothing** — the baseline agrees with the data within the measurement uncertainty.")
    if v.advice.get("text"):
        lines += ["", f"Advice (the separability tool): {v.advice['text']}."]
    lines += ["", f"Gap ({GAP_MEASURE}): before {d.gap_before:.3g}, after {d.gap_after:.3g} "
              f"(chi2 of the baseline {d.chi2_before:.3g} over {len(d.features)} features); "
              f"{GAP_EXCESS_MEASURE}: before {d.gap_excess_before:.3g}, after {d.gap_excess_after:.3g}.", ""]
    if d.parameters:
        lines += ["| effect | parameter | fitted | ± std. error | interval | baseline |", "|---|---|---|---|---|---|"]
        for e, p in d.parameters.items():
            iv = p.get("interval")
            ivs = f"[{fmt_value(iv[0])}, {fmt_value(iv[1])}]" if iv else ""
            lines.append(f"| {e} | {p['field']} [{p['unit']}] | {fmt_value(p['value'])} | {fmt_value(p['stderr'])} | "
                         f"{ivs} | {fmt_value(p['baseline'])} |")
        lines.append("")
        rough = {e: p["chi2_roughness"] for e, p in d.parameters.items() if p.get("chi2_roughness", 0.0) > 1.0}
        if rough:
            lines += ["Rough profile: " + ", ".join(f"{e} (single-run chi2 scatters by {v:.3g} about a parabola)"
                                                    for e, v in rough.items())
                      + ": runs at neighbouring values differ by more than the data resolve, so the stated error "
                        "spans the values within chi2_min + 1 + 2 x that scatter.", ""]
    if d.alternatives:
        lines += ["Equally good alternatives: " + "; ".join(", ".join(a) for a in d.alternatives), ""]
    if d.features_off:
        lines += ["Features still off (|z| > 2 after): " + ", ".join(f"{f['feature']} (z = {f['z']:+.1f})"
                                                                   for f in d.features_off), ""]
    if d.rejected:
        lines += ["Not named (best first):", ""]
        for r in d.rejected[:8]:
            vals = ", ".join(f"{EFFECTS[e].field} = {fmt_value(r['values'][e])}" for e in r["effects"])
            lines.append(f"- {' + '.join(r['effects'])} ({vals}; chi2 = {r['chi2']:.3g}): " + "; ".join(r["reasons"]))
        lines.append("")
    lines += ["| feature | measured | ± | baseline (model spread) | updated (model spread) | z before | z after |",
              "|---|---|---|---|---|---|---|"]
    for k, f in d.features.items():
        sb, su = f.get("model_spread_baseline", 0.0), f.get("model_spread_updated", 0.0)
        lines.append(f"| {k} | {fmt_value(f['measured'])} | {fmt_value(f['uncertainty'])} | {fmt_value(f['baseline'])} "
                     f"({fmt_value(sb)}) | {fmt_value(f['updated'])} ({fmt_value(su)}) | {f['z_before']:+.2f} | {f['z_after']:+.2f} |")
    if d.behaviours:
        lines += ["", "Behaviour types: " + "; ".join(f"{k}: {v}" for k, v in d.behaviours.items())]
    if d.modes:
        lines += ["", "Modes (end-state features are compared within the data's mode): " + "; ".join(
            f"{t}: ends {'high' if m['ends_high'] else 'low'}, {'a' if m['turning_point'] else 'no'} turning point, "
            f"baseline {m['baseline_runs_in_mode']}/{m['runs']} runs in it, updated {m['updated_runs_in_mode']}/{m['runs']}"
            for t, m in d.modes.items())]
    lines += ["", "Candidates (chi2, dof, adequate at 99 %; each parameter's interval, which must exclude its "
                  "baseline for it to be named):", ""]
    for c in sorted(d.candidates, key=lambda c: (len(c.effects), c.chi2)):
        vals = ", ".join(f"{EFFECTS[e].field} = {fmt_value(c.values[e])} in [{fmt_value(interval_of(c, e, level)[0])}, "
                         f"{fmt_value(interval_of(c, e, level)[1])}]" for e in c.effects)
        lines.append(f"- {' + '.join(c.effects)}: chi2 = {c.chi2:.3g}, dof {c.dof}, "
                     f"{'adequate' if c.adequate else 'not adequate'} ({vals})")
    lines += ["", f"Criterion: {d.criterion}.", "", f"Run time: {d.runtime_s:.1f} s.", ""]
    for fname in figs:
        lines.append(f"![{fname}]({fname})")
    return "\n".join(lines) + "\n"


# --- identifiability and the next measurement ------------------------------------------------------
