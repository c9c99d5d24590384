"""The candidate physical effects: each a real extension of the model with a parameter, bounds and
the features it moves."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Dict, Optional, Sequence, Tuple


from .. import _core
from ..params import Parameters, native


def _ei_over_l(p: Parameters) -> float:
    """EI/L [N m] (the core's beam)."""
    return _core.beam_properties(native(p))["ei_n_m2"] / p.length_m


def _ea_over_l(p: Parameters) -> float:
    """EA/L [N/m] (the core's beam)."""
    return _core.beam_properties(native(p))["ea_n"] / p.length_m


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
    relevance: float = 0.0
    """Least physically relevant change of the parameter: absolute (``relevance_kind = "abs"``),
    relative to the baseline value (``"rel"``), or for compliances relative to the baseline
    compliance u with the absolute floor :attr:`relevance_floor` on u (``"compliance"``)."""
    relevance_kind: str = "abs"
    relevance_floor: float = 0.0
    relevance_reason: str = ""
    """Why this threshold (docs/results/discover.md)."""
    realise: Optional[Callable[[Parameters, float], Dict[str, float]]] = None
    """For a virtual parameter (not a field of :class:`Parameters`, e.g. the natural-frequency
    factor): the field values that realise the value; its baseline value is 1."""
    chain: str = ""
    """A measurement-chain candidate (docs/model.md §9.1), not a parameter of the model:
    ``"excitation"`` scales the runs' a_ex, ``"features"`` maps the model's features to what the
    instruments would report (:mod:`.chain`); "" for a physical effect."""
    neutral: float = 1.0
    """The value of a measurement-chain parameter that changes nothing (a gain 1, an offset 0)."""

    def baseline_value(self, p: Parameters) -> float:
        """The parameter's value in ``p`` (1 for a virtual factor, :attr:`neutral` for the
        measurement chain)."""
        if self.chain:
            return self.neutral
        return 1.0 if self.realise is not None else float(getattr(p, self.field))

    def relevant(self, value: float, p: Parameters) -> Tuple[bool, str]:
        """Whether ``value`` differs from the baseline ``p`` by a physically relevant amount, and
        the change in words."""
        b = self.baseline_value(p)
        if self.relevance_kind == "compliance":
            ub, uv = self.variable(b, p), self.variable(value, p)
            thr = max(self.relevance * ub, self.relevance_floor)
            return abs(uv - ub) >= thr, f"compliance {ub:.4g} -> {uv:.4g} (relevant from a change of {thr:.3g})"
        if self.relevance_kind == "rel":
            thr = self.relevance * abs(b)
            return abs(value - b) >= thr, f"{b:.5g} -> {value:.5g} ({(value - b) / b:+.2%}, relevant from ±{self.relevance:.1%})"
        return abs(value - b) >= self.relevance, f"{b:.5g} -> {value:.5g} (change {value - b:+.3g}, relevant from ±{self.relevance:g})"

    def value(self, u: float, p: Parameters) -> float:
        if self.kind == "compliance":
            return math.inf if u <= 0 else self.scale(p) / u
        return self.scale(p) * u

    def variable(self, value: float, p: Parameters) -> float:
        if self.kind == "compliance":
            return 0.0 if math.isinf(value) else self.scale(p) / value
        return value / self.scale(p)


_SLIDER = ("speed_early", "speed_late", "s_turning", "s_final", "amplitude_final_h")
"""The slider-level features (docs/guide/discrepancy.md)."""

EFFECTS: Dict[str, Effect] = {e.name: e for e in (
    Effect("rotational_clamping_compliance",
           "finite rotational stiffness k_r of the clamping (each end): lowers the linear frequency, widens the "
           "mode shape towards the clamps and changes b* through the shape", "k_r_nm_per_rad", "N m/rad",
           "compliance", 0.0, 2.0, _ei_over_l, "beam", ("f0_hz", "b_star", "shape_L6", "shape_L3"),
           relevance=0.05, relevance_kind="compliance", relevance_floor=7e-4,
           relevance_reason="5 % of the baseline compliance EI/(L k_r), at least 7e-4 (5 % of the prototype's "
                            "0.014): lowers f0 by 0.24 %"),
    Effect("axial_clamping_compliance",
           "finite axial stiffness k_t of the frame in series with the beam: lowers the stretching hardening b* "
           "only", "k_t_n_per_m", "N/m", "compliance", 0.0, 20.0, _ea_over_l, "beam", ("b_star",),
           relevance=0.05, relevance_kind="compliance", relevance_floor=0.05,
           relevance_reason="5 % of the baseline compliance EA/(L k_t), at least 0.05 (5 % of the prototype's 1.09): "
                            "changes b* by 2.5 %"),
    Effect("axial_preload",
           "static axial force H0 in the beam (tension positive, e.g. from thermal strain or assembly): adds "
           "H0 K q to the modal forces, shifts the linear frequency, moves the shape towards the string (tension) "
           "or buckling (compression) shape", "axial_preload_n", "N", "linear", -30.0, 200.0,
           lambda p: _ei_over_l(p) / p.length_m, "beam", ("f0_hz", "shape_L6", "shape_L3"),
           relevance=2.5, relevance_reason="2.5 N shifts f0 by 0.26 %, as much as a 5 % change of k_r"),
    Effect("amplitude_dependent_damping",
           "damping that grows with amplitude (micro-slip in the clamping): D(t) = D + 4 D2 (w(L/2)/h)^2, "
           "D~(a~) = D + D2 a~^2", "damping_ratio_quadratic", "-", "linear", 0.0, 100.0, lambda p: 1e-4,
           "beam", ("damping_2",), relevance=5e-5,
           relevance_reason="D2 = 5e-5 raises the damping ratio at an amplitude of one thickness by 5 % of "
                            "D = 0.001"),
    Effect("friction_coefficient",
           "Coulomb friction coefficient mu between slider and beam: sets how fast and where the slider moves",
           "friction_coefficient", "-", "linear", 0.0, 1.0, lambda p: 1.0, "slider",
           ("speed_early", "speed_late", "s_turning", "s_final", "amplitude_final_h"), (0.1, 0.5),
           relevance=0.01, relevance_reason="0.01 = 5 % of the prototype's mu = 0.2, below what a friction "
                                            "measurement resolves"),
    Effect("clearance",
           "relative inner height R/h of the slider opening (clearance R - h): changes impacts and the "
           "transport of the slider", "gap_ratio", "-", "linear", 1.005, 1.4, lambda p: 1.0, "slider",
           ("speed_early", "speed_late", "s_turning", "s_final", "amplitude_final_h"), (1.01, 1.15),
           relevance=0.005, relevance_reason="R/h by 0.005 = 5 um of opening, 10 % of the prototype's "
                                             "clearance R - h = 50 um: the machining tolerance"),
    Effect("natural_frequency_detuning",
           "linear natural frequencies of the beam scaled by a factor c at constant mode shapes and b* "
           "(E -> c^2 E, k_r -> c^2 k_r, k_t keeping the axial stiffness; as the studies' natural_frequency_factor): "
           "the paper's second named uncertainty", "natural_frequency_factor", "-", "linear", 0.9, 1.1,
           lambda p: 1.0, "slider", ("speed_early", "speed_late", "s_turning", "s_final", "amplitude_final_h"),
           (0.95, 1.05), relevance=0.005, relevance_reason="0.5 % of the natural frequencies: 1.3 Hz of f0 = 260 Hz, "
                                                           "0.6 Hz of the beam-with-slider resonance near 120 Hz "
                                                           "(a third of the map's 2-Hz step)",
           realise=lambda p, c: _detune(p, c)),
    Effect("slider_mass",
           "slider mass m (manufacturing tolerance): shifts the resonance of the beam with slider and the "
           "slider's inertia in the impacts", "slider_mass_kg", "kg", "linear", 0.8, 1.2, lambda p: p.slider_mass_kg,
           "slider", ("speed_early", "speed_late", "s_turning", "s_final", "amplitude_final_h"), (0.8, 1.2),
           relevance=0.02, relevance_kind="rel", relevance_reason="2 % (0.9 g of 46 g), above the weighing "
                                                                  "and machining tolerance"),
    Effect("slider_inertia",
           "rotary inertia J of the slider about its centre of mass: sets its rocking between the contacts",
           "slider_inertia_kg_m2", "kg m^2", "linear", 0.5, 2.0, lambda p: p.slider_inertia_kg_m2, "slider",
           ("speed_early", "speed_late", "s_turning", "s_final", "amplitude_final_h"), (0.7, 1.4),
           relevance=0.05, relevance_kind="rel", relevance_reason="5 %: J is computed from the CAD geometry, "
                                                                  "not measured"),
    Effect("com_offset",
           "offset d of the slider's centre of mass from the beam's axis: couples its rotation to the impacts",
           "com_offset_m", "m", "linear", 0.0, 10.0, lambda p: 1e-3, "slider",
           ("speed_early", "speed_late", "s_turning", "s_final", "amplitude_final_h"), (2.0, 6.5),
           relevance=2e-4, relevance_reason="0.2 mm = 5 % of the prototype's d = 4.1 mm"),
    Effect("restitution",
           "coefficient of restitution of the slider-beam impacts (MODEL.md eps_N = eps_T)", "restitution", "-",
           "linear", 0.0, 1.0, lambda p: 1.0, "slider",
           ("speed_early", "speed_late", "s_turning", "s_final", "amplitude_final_h"), (0.2, 0.8),
           relevance=0.05, relevance_reason="0.05: impact tests of steel on steel scatter by about that"),
    Effect("tilt",
           "tilt alpha of the frame about the transverse axis (docs/model.md §3): gravity gets the component "
           "g sin(alpha) along the beam, alpha > 0 lowers the end x = L, and pushes the slider downhill",
           "tilt_rad", "rad", "linear", -100.0, 100.0, lambda p: 1e-3, "slider",
           ("speed_early", "speed_late", "s_turning", "s_final", "amplitude_final_h"), (-20.0, 20.0),
           relevance=2e-3, relevance_reason="2 mrad = 0.11 deg, what a frame set up with a machinist's bubble "
                                            "level (and the shaker's mounting) can be off by"),
    Effect("contact_spacing",
           "horizontal distance B between the two contact points on one side of the slider (docs/model.md §3): "
           "the lever of the contact forces in the slider's rocking, which it enters with J_C/(m B^2)",
           "contact_spacing_m", "m", "linear", 0.5, 2.0, lambda p: p.contact_spacing_m, "slider", _SLIDER,
           (0.8, 1.25), relevance=0.02, relevance_kind="rel",
           relevance_reason="2 % (0.2 mm of 10 mm): where a rounded edge touches the beam is known to about that "
                            "(docs/model.md §9.1)"),
    # The measurement chain (docs/model.md §9.1): the instruments, not the physics.
    Effect("excitation_gain",
           "calibration of the excitation level: the shaker ran at g a_ex while the files name a_ex (its "
           "control's reference accelerometer or set point off by the factor g)", "excitation_gain", "-", "linear",
           0.5, 1.5, lambda p: 1.0, "slider", _SLIDER, (0.85, 1.15), relevance=0.02, relevance_kind="rel",
           relevance_reason="2 %: a reference accelerometer's calibrated sensitivity and a shaker control's "
                            "level are accurate to 1-2 % (docs/model.md §9.1)", chain="excitation"),
    Effect("velocity_gain",
           "gain of the beam-velocity sensor (laser vibrometer and its acquisition): the measured velocity, and "
           "the amplitude integrated from it, is G times the true one", "velocity_gain", "-", "linear", 0.5, 1.5,
           lambda p: 1.0, "slider", _SLIDER, (0.85, 1.15), relevance=0.02, relevance_kind="rel",
           relevance_reason="2 %: a vibrometer's scale factor and the acquisition's voltage range are accurate to "
                            "about 1 % each (docs/model.md §9.1)", chain="features"),
    Effect("position_offset",
           "offset of the camera tracking of the slider: measured s = o + k s (o here; k: position_scale)",
           "position_offset", "-", "linear", -0.2, 0.2, lambda p: 1.0, "slider", _SLIDER, (-0.03, 0.03),
           relevance=0.005, relevance_reason="0.005 of L = 0.7 mm: where a tracking marker sits on the slider "
                                             "and the clamp edge in the image (docs/model.md §9.1)",
           chain="features", neutral=0.0),
    Effect("position_scale",
           "scale of the camera tracking of the slider: measured s = o + k s (k here; o: position_offset)",
           "position_scale", "-", "linear", 0.7, 1.3, lambda p: 1.0, "slider", _SLIDER, (0.9, 1.1),
           relevance=0.01, relevance_kind="rel",
           relevance_reason="1 %: a pixel-to-millimetre calibration from a target (docs/model.md §9.1)",
           chain="features"),
    Effect("time_base",
           "scale of the acquisition's time base: the samples are stamped tau t (slider speeds / tau, the "
           "amplitude integrated from the velocity x tau)", "time_base", "-", "linear", 0.9, 1.1, lambda p: 1.0,
           "slider", _SLIDER, (0.98, 1.02), relevance=1e-3, relevance_kind="rel",
           relevance_reason="0.1 %: twenty times a data acquisition's crystal (50 ppm), i.e. a sample rate "
                            "configured wrong, not drift (docs/model.md §9.1)", chain="features"),
)}

CHAIN_EFFECTS = tuple(n for n, e in EFFECTS.items() if e.chain)
"""The measurement-chain candidates (docs/model.md §9.1)."""


def _detune(p: Parameters, c: float) -> Dict[str, float]:
    from ..params import detune

    return detune(p, c)


def _with(p: Parameters, **changes: Any) -> Parameters:
    return Parameters(**{**p.to_dict(), **changes})


def apply_effects(p: Parameters, effects: Sequence[Effect], u: Sequence[float]) -> Parameters:
    return realise_effects(p, {e.name: e.value(float(x), p) for e, x in zip(effects, u)})


def realise_effects(p: Parameters, values: Dict[str, float]) -> Parameters:
    """``p`` with the effects' parameters set to ``values`` (by effect name); virtual parameters
    (a natural-frequency factor) are realised last, relative to the other changes. The
    measurement chain's values are not parameters of the model: :func:`.chain.realise_model`."""
    real = {EFFECTS[n].field: v for n, v in values.items() if EFFECTS[n].realise is None and not EFFECTS[n].chain}
    q = _with(p, **real) if real else p
    for n, v in values.items():
        e = EFFECTS[n]
        if e.realise is not None and not e.chain:
            q = _with(q, **e.realise(q, float(v)))
    return q


# --- beam level: surrogate and simulation ---------------------------------------------------------

_X5 = [1 / 6, 1 / 3, 1 / 2, 2 / 3, 5 / 6]
