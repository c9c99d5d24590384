"""Experimental Nonlinear Modal Analysis (ENMA) of the beam without slider and model updating of its clamping (paper §3, docs/model.md §9).

- :func:`virtual` — a virtual ENMA of any model: phase-resonance testing with a phase-locked loop
  at stepped excitation levels (run by the Rust core);
- :func:`read` / :meth:`EnmaData.write` — ENMA data as CSV (``amplitude_h``, ``frequency_hz``,
  optional ``damping_ratio``, ``run``, ``level_m_s2``, ``shape_1`` … ``shape_5``);
- :func:`fit_backbone` — least-squares fit of ω̃² = ω² + ¾ b* ã² with standard errors;
- :func:`update_clamping` — k_r from ω (root finding on the linear model), k_t from b*, the mean
  damping ratio; returns updated :class:`~beamslider.Parameters`;
- :func:`model_backbone` — (ω², b*) of a model; :func:`plot_enma` — the paper's Fig. 3 panels.

Modules: :mod:`.data` (the data and its CSV file), :mod:`.compute` (virtual ENMA, fit, update) and
:mod:`.draw` (the figure); every public name is importable from here.
"""

from .compute import (DEFAULT_LEVELS_M_S2, BackboneFit, ClampingUpdate, backbone_hz, beam_properties, fit_backbone,
                      k_t_from_b_star, model_backbone, solve_k_r, update_clamping, virtual, with_noise)
from .data import SHAPE_X_OVER_L, EnmaData, EnmaFormatError, PathLike, concat, make_data, read
from .draw import plot_enma

__all__ = [
    "DEFAULT_LEVELS_M_S2", "SHAPE_X_OVER_L", "BackboneFit", "ClampingUpdate", "EnmaData", "EnmaFormatError", "PathLike",
    "backbone_hz", "beam_properties", "concat", "fit_backbone", "k_t_from_b_star", "make_data", "model_backbone",
    "plot_enma", "read", "solve_k_r", "update_clamping", "virtual", "with_noise",
]
