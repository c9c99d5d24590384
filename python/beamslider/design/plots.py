"""Figures of a design run: the Pareto front (bandwidth vs slider mass), prototype vs optimum maps
side by side, and the final amplitude against frequency of both."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Dict, List, Optional, Union

import numpy as np

from .results import DesignResult


def _table(rec: Dict[str, Any]) -> Dict[str, np.ndarray]:
    """The classified points of a nominal record as a map table (for maps.plot_operating_map)."""
    pts = rec["samples"][0]["points"]
    t = {k: np.array([p[k] for p in pts], dtype=float) for k in ("f_ex_hz", "a_ex_m_s2", "s0", "t_end_s")}
    t["behaviour"] = np.array([p["behaviour"] for p in pts], dtype=object).astype(str)
    t["status"] = np.array(["completed" if p["status"] == "predicted" else p["status"] for p in pts],
                           dtype=object).astype(str)
    return t


def _pair(result: DesignResult) -> List[tuple]:
    pairs = []
    for name in ("prototype", "best"):
        r = result.checks.get(f"{name}_nominal") or (result.prototype if name == "prototype" else result.best)
        if r is not None and r.get("feasible") and r.get("samples") and len(r["samples"]) == 1:
            pairs.append((name, r))
    return pairs


def _label(name: str, r: Dict[str, Any]) -> str:
    var = ", ".join(f"{k} = {v:.4g}" for k, v in r["variables"].items())
    return f"{name}: {var}\n{r['evaluator']} {r['t_end_s']:g} s, bandwidth {r['bandwidth_hz']:.1f} Hz, harvest {r['harvest']:.2f}"


def plot_pareto(result: DesignResult, *, path: Optional[Union[str, Path]] = None) -> Any:
    """Bandwidth against slider mass of every feasible search design, the Pareto front joined."""
    from .._mpl import require_matplotlib

    require_matplotlib("plot_pareto")
    from matplotlib.figure import Figure

    obj = "bandwidth_hz" if result.config.maximise == "bandwidth" else "harvest"
    fig = Figure(figsize=(6.0, 4.2), layout="constrained")
    ax = fig.subplots()
    feas = [r for r in result.search if r.get("feasible")]
    ax.scatter([r["slider_mass_kg"] * 1e3 for r in feas], [r[obj] for r in feas], s=14, color="0.6",
               label=f"evaluated ({len(feas)})")
    fr = result.pareto
    ax.plot([r["slider_mass_kg"] * 1e3 for r in fr], [r[obj] for r in fr], "o-", color="C3", label="Pareto front")
    if result.prototype is not None:
        ax.plot(result.prototype["slider_mass_kg"] * 1e3, result.prototype[obj], "s", color="C0", ms=8, label="prototype")
    ax.plot(result.best["slider_mass_kg"] * 1e3, result.best[obj], "*", color="C2", ms=13, label="best")
    ax.set_xlabel("slider mass m [g]")
    ax.set_ylabel("adaption bandwidth [Hz]" if obj == "bandwidth_hz" else r"harvestable level mean $(A/h)^2$")
    ax.set_title(f"search ({result.config.evaluator}, {result.config.t_end_s:g} s runs)", fontsize=10)
    ax.legend(fontsize=8)
    if path is not None:
        fig.savefig(str(path), dpi=150)
    return fig


def plot_maps(result: DesignResult, *, path: Optional[Union[str, Path]] = None) -> Any:
    """Prototype vs optimum: the behaviour over the band and levels (first s0), side by side."""
    from .._mpl import require_matplotlib

    require_matplotlib("plot_maps")
    from matplotlib.figure import Figure

    from ..maps import plot_operating_map

    pairs = _pair(result)
    fig = Figure(figsize=(1.5 + 6.0 * len(pairs), 4.4), layout="constrained")
    axes = fig.subplots(1, max(len(pairs), 1), squeeze=False)[0]
    for ax, (name, r) in zip(axes, pairs):
        t = _table(r)
        plot_operating_map(t, s0=float(t["s0"][0]), ax=ax, title=_label(name, r))
        if ax is not axes[-1] and ax.get_legend() is not None:
            ax.get_legend().remove()
    if path is not None:
        fig.savefig(str(path), dpi=150)
    return fig


def plot_amplitude(result: DesignResult, *, path: Optional[Union[str, Path]] = None) -> Any:
    """Final amplitude A/h against frequency, prototype vs optimum, one panel per level (first s0);
    adapted points filled, the threshold a_min dashed."""
    from .._mpl import require_matplotlib

    require_matplotlib("plot_amplitude")
    from matplotlib.figure import Figure

    from .objectives import ADAPTIVE

    pairs = _pair(result)
    levels = list(result.config.a_ex_m_s2)
    fig = Figure(figsize=(4.5 * len(levels), 3.8), layout="constrained")
    axes = fig.subplots(1, len(levels), squeeze=False)[0]
    for ax, a in zip(axes, levels):
        for (name, r), col in zip(pairs, ("C0", "C2")):
            pts = sorted((p for p in r["samples"][0]["points"] if p["a_ex_m_s2"] == a and p["s0"] == result.config.s0[0]),
                         key=lambda p: p["f_ex_hz"])
            f = [p["f_ex_hz"] for p in pts]
            amp = [np.nan if p["amplitude_final_h"] is None else p["amplitude_final_h"] for p in pts]
            ax.plot(f, amp, "-", color=col, label=f"{name} ({r['evaluator']}, {r['t_end_s']:g} s)")
            good = [p["behaviour"] in ADAPTIVE and (p["amplitude_final_h"] or 0) >= result.config.a_min_h for p in pts]
            ax.scatter(f, amp, c=[col if g else "white" for g in good], edgecolors=col, zorder=3, s=22)
        ax.axhline(result.config.a_min_h, ls="--", color="k", lw=0.8)
        ax.set_title(f"a_ex = {a:g} m/s², s0 = {result.config.s0[0]:g}", fontsize=10)
        ax.set_xlabel(r"$f_\mathrm{ex}$ [Hz]")
        ax.set_ylabel(r"final amplitude $A/h$")
    axes[0].legend(fontsize=8)
    if path is not None:
        fig.savefig(str(path), dpi=150)
    return fig


def write_outputs(result: DesignResult, out: Union[str, Path]) -> List[Path]:
    """summary.json, summary.txt and (with matplotlib) pareto.png, maps.png, amplitude.png in ``out``."""
    import json

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    p = out / "summary.json"
    p.write_text(json.dumps(result.summary(), indent=1) + "\n", encoding="utf-8")
    written.append(p)
    p = out / "summary.txt"
    p.write_text(result.text(), encoding="utf-8")
    written.append(p)
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return written
    for name, fn in (("pareto.png", plot_pareto), ("maps.png", plot_maps), ("amplitude.png", plot_amplitude)):
        fn(result, path=out / name)
        written.append(out / name)
    return written
