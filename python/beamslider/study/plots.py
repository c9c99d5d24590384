"""Figures of a study: behaviour probability map and sensitivity bars."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Optional, Sequence, Union

import numpy as np

from ..maps import BEHAVIOURS, COLOURS, LABELS, LETTERS
from .statistics import StudyResult


def plot_behaviour_probability(result: StudyResult, *, s0: Optional[float] = None, path: Optional[Union[str, Path]] = None,
                               ax: Any = None, title: Optional[str] = None) -> Any:
    """Map of the most probable behaviour over (f_ex, a_ex), each cell shaded by its probability
    (full colour = 1) and labelled with it. Returns the figure; writes it to ``path`` when given."""
    from .._mpl import require_matplotlib

    require_matplotlib("plot_behaviour_probability")
    from matplotlib.colors import to_rgb
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch, Rectangle

    pts = result.points
    s0s = sorted({p.s0 for p in pts})
    s0 = s0s[0] if s0 is None else s0
    pts = [p for p in pts if p.s0 == s0]
    fs = np.array(sorted({p.f_ex_hz for p in pts}))
    as_ = np.array(sorted({p.a_ex_m_s2 for p in pts}))
    dfs = np.diff(fs).min() if len(fs) > 1 else 2.0
    das = np.diff(as_).min() if len(as_) > 1 else 2.0
    if ax is None:
        fig = Figure(figsize=(7.5, 4.2), layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    present = set()
    for p in pts:
        b, pr = p.most_probable, p.probabilities[p.most_probable]
        present.add(b)
        rgb = np.array(to_rgb(COLOURS.get(b, "#ffffff")))
        shade = 1.0 - pr * (1.0 - rgb)  # white at probability 0, full colour at 1
        ax.add_patch(Rectangle((p.f_ex_hz - dfs / 2, p.a_ex_m_s2 - das / 2), dfs, das, facecolor=shade,
                               edgecolor="k", linewidth=0.4, hatch="//" if b == "undetermined" else None))
        if len(fs) * len(as_) <= 150:
            ax.text(p.f_ex_hz, p.a_ex_m_s2, f"{LETTERS[b]}\n{pr:.2f}", ha="center", va="center", fontsize=7)
    ax.set_xlim(fs[0] - dfs / 2, fs[-1] + dfs / 2)
    ax.set_ylim(as_[0] - das / 2, as_[-1] + das / 2)
    ax.set_xticks(fs if len(fs) <= 20 else fs[:: int(np.ceil(len(fs) / 20))])
    ax.set_yticks(as_)
    ax.set_xlabel(r"excitation frequency $f_\mathrm{ex}$ [Hz]")
    ax.set_ylabel(r"excitation level $a_\mathrm{ex}$ [m/s$^2$]")
    ax.set_title(title if title is not None else
                 f"most probable behaviour (shade = probability), $s_0$ = {s0:g}, {result.points[0].n} samples")
    handles = [Patch(facecolor=COLOURS[b], edgecolor="k", label=LABELS[b]) for b in BEHAVIOURS if b in present]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False, fontsize=9)
    if path is not None:
        fig.savefig(str(path), dpi=150)
    return fig


def plot_sensitivity(result: StudyResult, *, point: int = 0, path: Optional[Union[str, Path]] = None,
                     outputs: Sequence[str] = ("s_final", "amplitude_final_h")) -> Any:
    """Bars of the sensitivity indices at one operating point (index in map order): one panel per
    output, one group per uncertain input (S1 and ST with their 95 % intervals for a saltelli
    study, the rank correlation otherwise)."""
    from .._mpl import require_matplotlib

    require_matplotlib("plot_sensitivity")
    from matplotlib.figure import Figure

    p = result.points[point]
    names = result.config.names
    fig = Figure(figsize=(3.4 * len(outputs) + 0.6, 3.4), layout="constrained")
    axes = fig.subplots(1, len(outputs), squeeze=False)[0]
    x = np.arange(len(names))
    for ax, out in zip(axes, outputs):
        ind = p.sensitivity.get(out, {})
        if result.config.method == "saltelli":
            for k, (key, off, col) in enumerate((("S1", -0.18, "#1f77b4"), ("ST", 0.18, "#ff7f0e"))):
                v = np.array([ind[n][key] for n in names])
                e = np.array([ind[n][key + "_conf"] for n in names])
                ax.bar(x + off, v, width=0.36, yerr=e, color=col, capsize=3, label=key)
            ax.set_ylim(min(0.0, ax.get_ylim()[0]), max(1.05, ax.get_ylim()[1]))
            ax.legend(frameon=False, fontsize=8)
        else:
            v = np.array([ind[n]["rho"] for n in names])
            ax.bar(x, v, width=0.6, color="#1f77b4")
            ax.set_ylim(-1.05, 1.05)
            ax.axhline(0, color="k", linewidth=0.6)
        ax.set_xticks(x)
        ax.set_xticklabels([n.replace("_", "\n", 1) for n in names], fontsize=7)
        ax.set_title(out, fontsize=9)
    axes[0].set_ylabel("Sobol' index" if result.config.method == "saltelli" else "Spearman rank correlation")
    fig.suptitle(f"sensitivity at ({p.f_ex_hz:g} Hz, {p.a_ex_m_s2:g} m/s², $s_0$ = {p.s0:g}), {p.n} runs", fontsize=10)
    if path is not None:
        fig.savefig(str(path), dpi=150)
    return fig
