"""ENMA figure: the paper's Fig. 3 panels (backbones, damping, deflection shapes; docs/model.md §9)."""

from __future__ import annotations

import math
import os
from typing import Dict, Optional

import numpy as np

from ..params import Parameters
from .compute import BackboneFit, backbone_hz, beam_properties, model_backbone
from .data import SHAPE_X_OVER_L, EnmaData, PathLike

__all__ = ["plot_enma"]


# --- figure -----------------------------------------------------------------------------------


def plot_enma(data: EnmaData, fit: Optional[BackboneFit] = None, *,
              models: Optional[Dict[str, Parameters]] = None, path: Optional[PathLike] = None):
    """The paper's Fig. 3: (a) frequency vs amplitude (points coloured by amplitude, the fitted
    backbone, the backbones of ``models``), (b) damping vs amplitude, (c) deflection shape with the
    linear mode shapes of ``models``. Returns the figure; saves it when ``path`` is given."""
    from .._mpl import require_matplotlib

    require_matplotlib("plot_enma")
    import matplotlib

    if path is not None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, 3, figsize=(15, 4.6), constrained_layout=True)
    a = data.amplitude_h
    norm = matplotlib.colors.Normalize(vmin=float(np.min(a)), vmax=float(np.max(a)) if np.ptp(a) > 0 else float(np.max(a)) + 1)
    cmap = plt.get_cmap("viridis")
    a_max = 1.1 * float(np.max(a))
    ag = np.linspace(0, a_max, 200)
    styles = ["--", ":", "-."]
    ax = axs[0]
    for run in dict.fromkeys(data.run):
        m = data.run == run
        marker = "^" if run == "up" else "v" if run == "down" else "o"
        ax.scatter(a[m], data.frequency_hz[m], c=cmap(norm(a[m])), marker=marker, s=36, edgecolor="k",
                   linewidth=0.4, zorder=3)
        ax.scatter([], [], c="0.7", marker=marker, s=36, edgecolor="k", linewidth=0.4, label=f"data, run {run}")
    if fit is not None:
        ax.plot(ag, fit.frequency_hz(ag), "k-", lw=1.5,
                label=f"fit: f = {fit.linear_frequency_hz:.2f} Hz, b* = {fit.b_star:.3g} 1/s²")
    for i, (name, p) in enumerate((models or {}).items()):
        w2, bs = model_backbone(p)
        ax.plot(ag, backbone_hz(w2, bs, ag), styles[i % 3], lw=1.3, label=f"{name}: f = {math.sqrt(w2) / 2 / math.pi:.2f} Hz, b* = {bs:.3g}")
    ax.set_xlabel("modal amplitude ã = ŵ(L/2)/h [-]")
    ax.set_ylabel("phase-resonant frequency [Hz]")
    ax.set_title("(a) amplitude-dependent modal frequency")
    ax.set_xlim(0, a_max)
    ax.legend(fontsize=8, loc="upper left")
    ax.grid(alpha=0.3)

    ax = axs[1]
    if data.has_damping:
        ax.scatter(a, 100 * data.damping_ratio, c=cmap(norm(a)), s=36, edgecolor="k", linewidth=0.4, zorder=3)
        if fit is not None and math.isfinite(fit.damping_ratio_mean):
            ax.axhline(100 * fit.damping_ratio_mean, color="k", lw=1.2,
                       label=f"mean D = {100 * fit.damping_ratio_mean:.3f} %")
            ax.legend(fontsize=8)
    else:
        ax.text(0.5, 0.5, "no damping data", ha="center", va="center", transform=ax.transAxes)
    ax.set_xlabel("modal amplitude ã [-]")
    ax.set_ylabel("modal damping ratio D̃ [%]")
    ax.set_title("(b) amplitude-dependent modal damping")
    ax.set_xlim(0, a_max)
    ax.grid(alpha=0.3)

    ax = axs[2]
    if data.has_shape:
        for k in range(len(data)):
            if np.all(np.isfinite(data.shape[k])):
                ax.plot(SHAPE_X_OVER_L, data.shape[k], "o", color=cmap(norm(a[k])), ms=5, mec="k", mew=0.3)
    for i, (name, p) in enumerate((models or {}).items()):
        b = beam_properties(p)
        ax.plot(b["shape_x_over_l"], b["shape_phi1"], styles[i % 3], lw=1.3, label=f"{name}: linear mode 1")
    ax.set_xlabel("x / L [-]")
    ax.set_ylabel("deflection shape (normalised) [-]")
    ax.set_title("(c) modal deflection shape")
    ax.set_xlim(0, 1)
    ax.grid(alpha=0.3)
    if models:
        ax.legend(fontsize=8, loc="lower center")
    sm = matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(sm, ax=axs[2], label="ã of the point")
    if path is not None:
        fig.savefig(os.fspath(path), dpi=130)
        plt.close(fig)
    return fig
