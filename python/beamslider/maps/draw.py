"""Operating maps: drawing the categorical map (docs/model.md §8, the paper's Fig. 11)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np

from .config import BEHAVIOURS, LABELS
from .read import marked_unsettled, t_end_text

__all__ = ["COLOURS", "changed_with_s0", "plot_operating_map"]


COLOURS = {"inactivity": "#9e9e9e", "trivial_adaption": "#1f77b4", "signature_move": "#2ca02c",
           "relaxation_oscillation": "#ff7f0e", "self_damping": "#d62728", "not_settled": "#f3e79b",
           "undetermined": "#ffffff"}
"""Colour of each behaviour in the map figure."""


_HATCH = {"undetermined": "//", "not_settled": ".."}


def changed_with_s0(table: Dict[str, np.ndarray]) -> List[tuple]:
    """(f_ex, a_ex) points of the grid whose behaviour differs between the s0 values of the map."""
    out = []
    keys = sorted(set(zip(table["f_ex_hz"].tolist(), table["a_ex_m_s2"].tolist())))
    for f, a in keys:
        m = (table["f_ex_hz"] == f) & (table["a_ex_m_s2"] == a)
        if len(set(table["behaviour"][m].tolist())) > 1 and m.sum() > 1:
            out.append((f, a))
    return out


def _panel(ax: Any, table: Dict[str, np.ndarray], s0: float, title: Optional[str], marks: Sequence[tuple]) -> set:
    from matplotlib.patches import Rectangle

    m = table["s0"] == s0
    fs = np.array(sorted(set(table["f_ex_hz"][m].tolist())))
    as_ = np.array(sorted(set(table["a_ex_m_s2"][m].tolist())))
    dfs = np.diff(fs).min() if len(fs) > 1 else 1.0
    das = np.diff(as_).min() if len(as_) > 1 else 1.0
    present = set()
    hollow = marked_unsettled(table)
    for i in np.flatnonzero(m):
        b = str(table["behaviour"][i])
        present.add(b)
        f, a = table["f_ex_hz"][i], table["a_ex_m_s2"][i]
        ax.add_patch(Rectangle((f - dfs / 2, a - das / 2), dfs, das, facecolor="w" if hollow[i] else COLOURS.get(b, "w"),
                               edgecolor="k", linewidth=0.4, hatch=_HATCH.get(b)))
        if hollow[i]:  # reached, not yet settled: a hollow cell in the behaviour's colour
            present.add("unsettled")
            ax.add_patch(Rectangle((f - dfs / 2 + 0.12 * dfs, a - das / 2 + 0.12 * das), 0.76 * dfs, 0.76 * das,
                                   facecolor="none", edgecolor=COLOURS.get(b, "k"), linewidth=2.5))
    for f, a in marks:
        ax.add_patch(Rectangle((f - dfs / 2 + 0.06 * dfs, a - das / 2 + 0.06 * das), 0.88 * dfs, 0.88 * das,
                               facecolor="none", edgecolor="k", linewidth=2.0))
    ax.set_xlim(fs[0] - dfs / 2, fs[-1] + dfs / 2)
    ax.set_ylim(as_[0] - das / 2, as_[-1] + das / 2)
    ax.set_xticks(fs if len(fs) <= 20 else fs[:: int(np.ceil(len(fs) / 20))])
    ax.set_yticks(as_ if len(as_) <= 20 else as_[:: int(np.ceil(len(as_) / 20))])
    ax.tick_params(axis="x", labelsize=8)
    ax.set_xlabel(r"excitation frequency $f_\mathrm{ex}$ [Hz]")
    ax.set_ylabel(r"excitation level $a_\mathrm{ex}$ [m/s$^2$]")
    ax.set_title(title if title is not None else f"operating map, $s_0$ = {s0:g}, {t_end_text(table, s0)}",
                 fontsize=10)
    return present


def plot_operating_map(table: Dict[str, np.ndarray], *, s0: Optional[float] = None, title: Optional[str] = None,
                       path: Optional[Union[str, Path]] = None, ax: Any = None,
                       mark_changes: bool = False) -> Any:
    """Categorical map of the behaviours over (f_ex, a_ex) with a legend, like the paper's Fig. 11
    (one cell per grid point; cells not run are left blank, undetermined cells hatched, not-settled
    cells dotted, a behaviour reached but not yet settled (``settled`` false) hollow: a white cell
    framed in the behaviour's colour). The title gives s0 and t_end. A map over several s0 draws one panel per s0
    (unless ``s0`` picks one); ``mark_changes`` outlines the points whose behaviour changes with
    s0 (the paper's start-position example, Fig. 12). Returns the figure; writes it to ``path``
    when given."""
    from .._mpl import require_matplotlib

    require_matplotlib("plot_operating_map")
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    s0s = sorted(set(table["s0"].tolist()))
    if not s0s:
        raise ValueError("the map is empty")
    if s0 is not None and s0 not in s0s:
        raise ValueError(f"invalid parameter `s0` = {s0!r}: the map has s0 in {s0s}")
    panels = [s0] if s0 is not None else s0s
    if ax is not None and len(panels) > 1:
        raise ValueError("invalid parameter `ax`: a map over several s0 draws several panels; give `s0` or no `ax`")
    marks = changed_with_s0(table) if mark_changes else []
    if ax is None:
        fig = Figure(figsize=(1.5 + 6.0 * len(panels), 4.2), layout="constrained")  # no pyplot: headless
        axes = fig.subplots(1, len(panels), squeeze=False)[0]
    else:
        fig = ax.figure
        axes = [ax]
    present = set()
    for a, s in zip(axes, panels):
        present |= _panel(a, table, s, title if len(panels) == 1 else None, marks)
    if title is not None and len(panels) > 1:
        fig.suptitle(title)
    handles = [Patch(facecolor=COLOURS[b], edgecolor="k", label=LABELS[b], hatch=_HATCH.get(b))
               for b in BEHAVIOURS if b not in _HATCH or b in present]
    if "unsettled" in present:
        handles.append(Patch(facecolor="w", edgecolor="0.4", linewidth=2.5, label="hollow: reached, not yet settled"))
    if marks:
        handles.append(Patch(facecolor="none", edgecolor="k", linewidth=2.0, label="changes with $s_0$"))
    axes[-1].legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False, fontsize=9)
    if path is not None:
        fig.savefig(str(path), dpi=150)
    return fig
