"""Sampling of the uncertain inputs (LHS, Sobol', Saltelli, grid), the natural-frequency detuning and the list of runs."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Dict, List, Tuple

from ..params import Parameters, detune, native  # noqa: F401 (detune: part of this module's face)
from .config import VIRTUAL, StudyConfig


def apply_sample(params: Parameters, values: Dict[str, float]) -> Parameters:
    """``params`` with the uncertain values set (virtual inputs realised, see the module docstring)."""
    d = params.to_dict()
    d.update({k: float(v) for k, v in values.items() if k not in VIRTUAL})
    if "natural_frequency_factor" in values:  # relative to the sampled E, k_r, k_t
        d.update(detune(d, float(values["natural_frequency_factor"])))
    return Parameters.from_dict(d)  # validated once


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
    params: Parameters
    """Full parameters of the run (validated once, when the sample was applied)."""
    f_ex_hz: float
    a_ex_m_s2: float
    s0: float
    duration_s: float

    def chunk_tuple(self) -> Tuple[int, Any, float, float, float, float]:
        """The point as the core's study runner takes it (the parameters as the core's validated object)."""
        return (self.index, native(self.params), self.f_ex_hz, self.a_ex_m_s2, self.s0, self.duration_s)


def study_points(config: StudyConfig) -> List[StudyPoint]:
    """All runs of the study: every design row at every operating point (sample slowest)."""
    design = config.design()
    ops = config.operating_points()
    out: List[StudyPoint] = []
    for i, row in enumerate(design):
        values = {n: float(v) for n, v in zip(config.names, row)}
        params = apply_sample(config.params, values)
        for j, (f, a, s) in enumerate(ops):
            out.append(StudyPoint(index=i * len(ops) + j, sample=i, point=j, values=values, params=params,
                                  f_ex_hz=f, a_ex_m_s2=a, s0=s, duration_s=float(config.duration_s)))
    return out
