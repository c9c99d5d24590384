"""Sampling of the uncertain inputs (LHS, Sobol', Saltelli, grid), the natural-frequency detuning and the list of runs."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, List, Tuple

from ..params import Parameters
from .config import VIRTUAL, StudyConfig


def apply_sample(params: Parameters, values: Dict[str, float]) -> Parameters:
    """``params`` with the uncertain values set (virtual inputs realised, see the module docstring)."""
    d = params.to_dict()
    d.update({k: float(v) for k, v in values.items() if k not in VIRTUAL})
    if "natural_frequency_factor" in values:  # relative to the sampled E, k_r, k_t
        d.update(detune(Parameters.from_dict(d), float(values["natural_frequency_factor"])))
    return Parameters.from_dict(d)


def detune(params: Parameters, factor: float) -> Dict[str, float]:
    """Parameter values that scale every linear natural frequency by ``factor`` (c) at constant
    mode shapes and constant nonlinear coefficient b*: E → c² E, k_r → c² k_r and k_t such that
    k_ax = 1/(L/(EA) + 1/k_t) is unchanged (k_t = ∞ stays ∞)."""
    c2 = float(factor) ** 2
    if not (math.isfinite(c2) and c2 > 0):
        raise ValueError(f"invalid natural_frequency_factor = {factor!r}: must be finite and > 0")
    p = params
    area = p.beam_mass_kg / (p.density_kg_m3 * p.length_m)
    e_new = p.youngs_modulus_pa * c2
    out = {"youngs_modulus_pa": e_new, "k_r_nm_per_rad": p.k_r_nm_per_rad * c2}
    if math.isfinite(p.k_t_n_per_m):
        inv = 1.0 / p.k_t_n_per_m + p.length_m / (p.youngs_modulus_pa * area) - p.length_m / (e_new * area)
        if not inv > 0:
            raise ValueError(f"natural_frequency_factor = {factor}: no axial clamping stiffness k_t keeps b* "
                             f"(the beam alone is then softer axially than the nominal beam and frame)")
        out["k_t_n_per_m"] = 1.0 / inv
    return out


@dataclass
class StudyPoint:
    """One run of a study."""

    index: int
    """Position in the study (sample * n_operating_points + point)."""
    sample: int
    """Row of the design."""
    point: int
    """Operating point (map order)."""
    values: Dict[str, float]
    """The uncertain inputs."""
    params_toml: str
    """Full parameters of the run (canonical TOML)."""
    f_ex_hz: float
    a_ex_m_s2: float
    s0: float
    duration_s: float

    def chunk_tuple(self) -> Tuple[int, str, float, float, float, float]:
        return (self.index, self.params_toml, self.f_ex_hz, self.a_ex_m_s2, self.s0, self.duration_s)


def study_points(config: StudyConfig) -> List[StudyPoint]:
    """All runs of the study: every design row at every operating point (sample slowest)."""
    design = config.design()
    ops = config.operating_points()
    out: List[StudyPoint] = []
    for i, row in enumerate(design):
        values = {n: float(v) for n, v in zip(config.names, row)}
        text = apply_sample(config.params, values).toml_text()
        for j, (f, a, s) in enumerate(ops):
            out.append(StudyPoint(index=i * len(ops) + j, sample=i, point=j, values=values, params_toml=text,
                                  f_ex_hz=f, a_ex_m_s2=a, s0=s, duration_s=float(config.duration_s)))
    return out
