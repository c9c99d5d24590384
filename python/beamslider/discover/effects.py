"""The candidate physical effects: each a real extension of the model with a parameter, bounds and
the features it moves."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Dict, Sequence, Tuple


from .. import _core
from ..params import Parameters


def _ei_over_l(p: Parameters) -> float:
    """EI/L [N m] (the core's beam)."""
    return _core.beam_properties(p.toml_text())["ei_n_m2"] / p.length_m


def _ea_over_l(p: Parameters) -> float:
    """EA/L [N/m] (the core's beam)."""
    return _core.beam_properties(p.toml_text())["ea_n"] / p.length_m


@dataclass(frozen=True)
class Effect:
    """A candidate physical effect: one model parameter with bounds and the features it moves.

    The fit works on a dimensionless variable u in [lower, upper]: ``kind = "compliance"`` means
    value = scale/u (u = 0 is the ideal, rigid limit), ``"linear"`` means value = scale·u."""

    name: str
    description: str
    field: str
    unit: str
    kind: str
    lower: float
    upper: float
    scale: Callable[[Parameters], float]
    level: str
    moves: Tuple[str, ...]
    search: Tuple[float, float] = (math.nan, math.nan)
    """Range of u scanned by the profile fit of slider-level effects (default: the bounds)."""

    def value(self, u: float, p: Parameters) -> float:
        if self.kind == "compliance":
            return math.inf if u <= 0 else self.scale(p) / u
        return self.scale(p) * u

    def variable(self, value: float, p: Parameters) -> float:
        if self.kind == "compliance":
            return 0.0 if math.isinf(value) else self.scale(p) / value
        return value / self.scale(p)


EFFECTS: Dict[str, Effect] = {e.name: e for e in (
    Effect("rotational_clamping_compliance",
           "finite rotational stiffness k_r of the clamping (each end): lowers the linear frequency, widens the "
           "mode shape towards the clamps and changes b* through the shape", "k_r_nm_per_rad", "N m/rad",
           "compliance", 0.0, 2.0, _ei_over_l, "beam", ("f0_hz", "b_star", "shape_L6", "shape_L3")),
    Effect("axial_clamping_compliance",
           "finite axial stiffness k_t of the frame in series with the beam: lowers the stretching hardening b* "
           "only", "k_t_n_per_m", "N/m", "compliance", 0.0, 20.0, _ea_over_l, "beam", ("b_star",)),
    Effect("axial_preload",
           "static axial force H0 in the beam (tension positive, e.g. from thermal strain or assembly): adds "
           "H0 K q to the modal forces, shifts the linear frequency, moves the shape towards the string (tension) "
           "or buckling (compression) shape", "axial_preload_n", "N", "linear", -30.0, 200.0,
           lambda p: _ei_over_l(p) / p.length_m, "beam", ("f0_hz", "shape_L6", "shape_L3")),
    Effect("amplitude_dependent_damping",
           "damping that grows with amplitude (micro-slip in the clamping): D(t) = D + 4 D2 (w(L/2)/h)^2, "
           "D~(a~) = D + D2 a~^2", "damping_ratio_quadratic", "-", "linear", 0.0, 100.0, lambda p: 1e-4,
           "beam", ("damping_2",)),
    Effect("friction_coefficient",
           "Coulomb friction coefficient mu between slider and beam: sets how fast and where the slider moves",
           "friction_coefficient", "-", "linear", 0.0, 1.0, lambda p: 1.0, "slider",
           ("speed_early", "speed_late", "s_turning", "s_final", "amplitude_final_h"), (0.1, 0.5)),
    Effect("clearance",
           "relative inner height R/h of the slider opening (clearance R - h): changes impacts and the "
           "transport of the slider", "gap_ratio", "-", "linear", 1.005, 1.4, lambda p: 1.0, "slider",
           ("speed_early", "speed_late", "s_turning", "s_final", "amplitude_final_h"), (1.01, 1.15)),
)}


def _with(p: Parameters, **changes: Any) -> Parameters:
    return Parameters(**{**p.to_dict(), **changes})


def _apply(p: Parameters, effects: Sequence[Effect], u: Sequence[float]) -> Parameters:
    return _with(p, **{e.field: e.value(float(x), p) for e, x in zip(effects, u)})


