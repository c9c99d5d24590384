"""Discrepancy workflow: find where model and measurement disagree, name the physical effect the
model is missing, add it, and show the disagreement shrink.

1. **Features** (:func:`enma_features`, :func:`slider_features`): physically meaningful numbers
   with uncertainties, computed by the same code from measured data and from the model at the same
   conditions — beam level (ENMA): linear frequency ``f0_hz``, hardening ``b_star``, damping
   ``damping_0`` and its amplitude trend ``damping_2``, deflection shape ``shape_L6``/``shape_L3``;
   slider level (free-slider runs): per operating point the behaviour type, early and late slider
   speed, turning point, final position and final amplitude.
2. **Candidate effects** (:data:`EFFECTS`), each a real extension of the model with a parameter,
   bounds and the features it moves.
3. **Naming** (:func:`discover`): every candidate and every pair is fitted to the disagreement
   (weighted least squares, χ² with the feature uncertainties). Criterion: nothing is named when
   the baseline agrees (χ² ≤ the 99 % quantile of χ²(n)); otherwise forward selection by
   likelihood-ratio tests with the measurement noise: the best single effect is named if it lowers
   χ² by more than the 99 % quantile of χ²(1) corrected for picking the best of m candidates
   (Bonferroni: 1 − 0.01/m, e.g. 9.14 for m = 4), and the best pair containing it replaces it only
   if it lowers χ² by more than that again (m = the pairs that extend it, e.g. 8.61 for m = 3) —
   a simpler explanation wins unless a richer one is clearly better.
4. **Adding it**: :func:`write_report` writes the updated TOML, ``report.json``, ``report.md`` and
   figures; the "after" features come from full simulations of the updated model.
5. **Synthesiser** (:func:`synthesize_enma`, :func:`synthesize_slider_runs`): hidden-effect data
   from any truth model, with noise and a seed.

Beam-level fits use the single-mode harmonic-balance relations of docs/model.md §9 generalised to a
preloaded first mode (eigenvector of diag(ω²) + H₀K) as a fast surrogate, bias-corrected by one
virtual ENMA of the baseline (the estimator's own small biases — time step, five-point damping
estimate, amplitude dependence of the shape — cancel); slider-level fits run the free-slider model.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _core, enma
from ._json import json_safe as _json_safe
from .enma import EnmaData
from .measurement import Measurement, read_measurement, write_measurement
from .params import Parameters, resolve

PathLike = Union[str, "os.PathLike[str]"]

SIGNIFICANCE = 0.01


# --- features -------------------------------------------------------------------------------------


@dataclass
class Feature:
    """A physically meaningful number with its standard uncertainty."""

    name: str
    value: float
    stderr: float
    unit: str = ""
    description: str = ""


#: Resolution floors of the feature uncertainties (relative for f0/b*/amplitudes, else absolute):
#: what a noise-free data set can still resolve given the estimators and the time step.
FLOORS = dict(f0_hz=("rel", 1e-4), b_star=("rel", 2e-3), damping_0=("abs", 1e-6), damping_2=("abs", 2e-6),
              shape_L6=("abs", 2e-4), shape_L3=("abs", 2e-4),
              speed_early=("abs", 2e-4), speed_late=("abs", 2e-4), s_turning=("abs", 2e-3),
              s_final=("abs", 2e-3), amplitude_final_h=("rel", 0.02))

DESCRIPTIONS = dict(
    f0_hz=("Hz", "linear natural frequency of mode 1 (backbone fit at a~ = 0)"),
    b_star=("1/s^2", "hardening coefficient b* of the backbone w~^2 = w^2 + 3/4 b* a~^2"),
    damping_0=("-", "damping ratio at zero amplitude (D~ w~/w = D0 + D2 a~^2)"),
    damping_2=("-", "amplitude growth D2 of the damping ratio"),
    shape_L6=("-", "deflection shape at x = L/6 and 5L/6 relative to L/2 (low amplitude)"),
    shape_L3=("-", "deflection shape at x = L/3 and 2L/3 relative to L/2 (low amplitude)"),
    speed_early=("1/s", "slider speed ds/dt over the first seconds (0.5 ... 5 s)"),
    speed_late=("1/s", "slider speed ds/dt over the last third of the run"),
    s_turning=("-", "turning point: extreme s before the slider reverses (signature move)"),
    s_final=("-", "final slider position (mean over the last second)"),
    amplitude_final_h=("-", "final beam amplitude at 4L/7 over h (envelope, last second)"),
)


def _floor(name: str, value: float, stderr: float) -> float:
    base = name.split("@")[0]
    kind, v = FLOORS.get(base, ("abs", 0.0))
    fl = v * abs(value) if kind == "rel" else v
    return float(max(stderr if math.isfinite(stderr) else 0.0, fl))


def _feature(name: str, value: float, stderr: float) -> Feature:
    unit, desc = DESCRIPTIONS.get(name.split("@")[0], ("", ""))
    return Feature(name, float(value), _floor(name, value, stderr), unit, desc)


def _linear_fit(x: np.ndarray, y: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Least squares y ≈ c0 + c1 x; coefficients and standard errors (residual scatter)."""
    A = np.column_stack([np.ones_like(x), x])
    c, *_ = np.linalg.lstsq(A, y, rcond=None)
    dof = max(len(x) - 2, 1)
    r = y - A @ c
    cov = float(r @ r) / dof * np.linalg.pinv(A.T @ A)
    return c, np.sqrt(np.maximum(np.diag(cov), 0.0))


def enma_features(data: EnmaData, *, low_amplitude_h: float = 0.3) -> Dict[str, Feature]:
    """Beam-level features of ENMA data (measured or virtual), with standard errors from the
    scatter of the points (noise and repeated runs), floored by :data:`FLOORS`."""
    fit = enma.fit_backbone(data)
    w0 = math.sqrt(fit.omega2)
    out = {
        "f0_hz": _feature("f0_hz", fit.linear_frequency_hz, fit.linear_frequency_stderr_hz),
        "b_star": _feature("b_star", fit.b_star, fit.b_star_stderr),
    }
    d = np.asarray(data.damping_ratio, dtype=float)
    ok = np.isfinite(d)
    if ok.sum() >= 3 and np.ptp(data.amplitude_h[ok]) > 0:
        # D~(a~) w~/w = D0 + D2 a~^2: the estimate refers to the phase-resonant frequency.
        y = d[ok] * (2 * math.pi * data.frequency_hz[ok]) / w0
        c, se = _linear_fit(data.amplitude_h[ok] ** 2, y)
        out["damping_0"] = _feature("damping_0", c[0], se[0])
        out["damping_2"] = _feature("damping_2", c[1], se[1])
    sh = np.asarray(data.shape, dtype=float)
    good = np.all(np.isfinite(sh), axis=1)
    if good.any():
        idx = np.flatnonzero(good)
        low = idx[data.amplitude_h[idx] <= low_amplitude_h]
        if len(low) < 3:
            low = idx[np.argsort(data.amplitude_h[idx])[:3]]
        for name, (i, j) in (("shape_L6", (0, 4)), ("shape_L3", (1, 3))):
            v = 0.5 * (sh[low, i] + sh[low, j])
            se = float(np.std(v, ddof=1) / math.sqrt(len(v))) if len(v) > 1 else 0.0
            out[name] = _feature(name, float(np.mean(v)), se)
    return out


def _ls_slope(t: np.ndarray, s: np.ndarray) -> Tuple[float, float]:
    if len(t) < 3:
        return math.nan, math.nan
    c, se = _linear_fit(t - t.mean(), s)
    return float(c[1]), float(se[1])


def slider_features(t: np.ndarray, s: np.ndarray, amplitude_h: np.ndarray, *, tag: str = "",
                    noise_s: float = 0.0) -> Tuple[Dict[str, Feature], str]:
    """Slider-level features of one run (s(t) and the envelope of w(4L/7)/h), named
    ``<feature>@<tag>``, and the behaviour type (docs/model.md §8). ``noise_s`` is the standard
    deviation of the measured s (enters the uncertainties)."""
    from .maps import classify

    t = np.asarray(t, dtype=float)
    s = np.asarray(s, dtype=float)
    a = np.asarray(amplitude_h, dtype=float)
    t_end = float(t[-1])
    out: Dict[str, Feature] = {}

    def add(name: str, value: float, se: float) -> None:
        if math.isfinite(value):
            out[f"{name}@{tag}"] = _feature(f"{name}@{tag}", value, se)

    early = (t >= 0.5) & (t <= min(5.0, t_end))
    add("speed_early", *_ls_slope(t[early], s[early]))
    late = t >= t_end * 2 / 3
    add("speed_late", *_ls_slope(t[late], s[late]))
    last = t >= t_end - 1.0
    n_last = max(int(last.sum()), 1)
    add("s_final", float(np.mean(s[last])), noise_s / math.sqrt(n_last))
    add("amplitude_final_h", float(np.mean(a[last])), float(np.std(a[last])))
    # Turning point: the slider first moves away from the centre, then back by more than 0.01.
    s0 = s[0]
    away = -1.0 if s0 < 0.5 else 1.0
    ext = int(np.argmax(away * (s - s0)))
    if away * (s[ext] - s0) > 0.005 and away * (s[ext] - s[-1]) > 0.01:
        add("s_turning", float(s[ext]), noise_s)
    behaviour = classify(t, s, a).behaviour
    return out, behaviour


# --- candidate effects ----------------------------------------------------------------------------


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
    relevance: float = 0.0
    """Least physically relevant change of the parameter: absolute (``relevance_kind = "abs"``),
    relative to the baseline value (``"rel"``), or for compliances relative to the baseline
    compliance u with the absolute floor :attr:`relevance_floor` on u (``"compliance"``)."""
    relevance_kind: str = "abs"
    relevance_floor: float = 0.0
    relevance_reason: str = ""
    """Why this threshold (docs/discover.md)."""
    realise: Optional[Callable[[Parameters, float], Dict[str, float]]] = None
    """For a virtual parameter (not a field of :class:`Parameters`, e.g. the natural-frequency
    factor): the field values that realise the value; its baseline value is 1."""

    def baseline_value(self, p: Parameters) -> float:
        """The parameter's value in ``p`` (1 for a virtual factor)."""
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
)}


def _detune(p: Parameters, c: float) -> Dict[str, float]:
    from .study.sampling import detune

    return detune(p, c)


def _with(p: Parameters, **changes: Any) -> Parameters:
    return Parameters(**{**p.to_dict(), **changes})


def _apply(p: Parameters, effects: Sequence[Effect], u: Sequence[float]) -> Parameters:
    return _realise(p, {e.name: e.value(float(x), p) for e, x in zip(effects, u)})


def _realise(p: Parameters, values: Dict[str, float]) -> Parameters:
    """``p`` with the effects' parameters set to ``values`` (by effect name); virtual parameters
    (a natural-frequency factor) are realised last, relative to the other changes."""
    real = {EFFECTS[n].field: v for n, v in values.items() if EFFECTS[n].realise is None}
    q = _with(p, **real) if real else p
    for n, v in values.items():
        e = EFFECTS[n]
        if e.realise is not None:
            q = _with(q, **e.realise(q, float(v)))
    return q


# --- beam level: surrogate and simulation ---------------------------------------------------------

_X5 = [1 / 6, 1 / 3, 1 / 2, 2 / 3, 5 / 6]


def beam_surrogate(params: Parameters) -> Dict[str, float]:
    """Beam-level features of a model from the single-mode relations (docs/model.md §9) of its first
    mode with preload (the core's ``Beam::first_mode``: eigenpair of diag(ω²) + H₀K,
    b* = (k_ax/2)(vᵀKv)² h²/ψ(L/2)², shape ψ = Σ vₙφₙ)."""
    b = _core.beam_properties(params.toml_text(), _X5)
    psi = np.asarray(b["mode1_vector"]) @ np.asarray(b["phi"])
    return dict(f0_hz=b["omega1_preload_rad_s"] / (2 * math.pi), b_star=b["b_star_preload_per_s2"],
                damping_0=params.damping_ratio, damping_2=params.damping_ratio_quadratic,
                shape_L6=0.5 * (psi[0] + psi[4]) / psi[2], shape_L3=0.5 * (psi[1] + psi[3]) / psi[2])


def _levels_for(data: EnmaData, params: Parameters) -> List[float]:
    lv = np.asarray(data.level_m_s2, dtype=float)
    if np.all(np.isfinite(lv)) and len(lv):
        return sorted(set(float(x) for x in lv))
    # Unknown levels: a~ ≈ γ₁ φ₁(L/2) a / (2 D ω₁²) / h at phase resonance.
    b = _core.beam_properties(params.toml_text())
    gain = b["gamma"][0] * b["phi_mid"] / (2 * max(params.damping_ratio, 1e-5) * b["omega_rad_s"][0] ** 2)
    gain /= params.thickness_m
    amps = np.quantile(data.amplitude_h, np.linspace(0, 1, 12))
    return sorted(set(round(float(a / abs(gain)), 6) for a in amps if a > 0))


def simulated_enma_features(params: Parameters, levels_m_s2: Sequence[float]) -> Tuple[Dict[str, Feature], EnmaData]:
    """Features of a virtual ENMA (up run) of the model at the given levels."""
    data = enma.virtual(params, levels_m_s2=list(levels_m_s2), up_and_down=False)
    return enma_features(data), data


# --- slider level ---------------------------------------------------------------------------------


@dataclass
class OperatingPoint:
    """A measured free-slider run's conditions."""

    f_ex: float
    a_ex: float
    s0: float
    duration_s: float

    @property
    def tag(self) -> str:
        return f"{self.f_ex:g}Hz_{self.a_ex:g}ms2_s0{self.s0:g}"


def _noise_of(s: np.ndarray) -> float:
    """Standard deviation of white measurement noise on s (from second differences)."""
    if len(s) < 10:
        return 0.0
    return float(np.std(np.diff(s, 2)) / math.sqrt(6))


def measured_slider_features(runs: Sequence[Measurement]) -> Tuple[Dict[str, Feature], Dict[str, str], List[OperatingPoint]]:
    """Features of measured runs (several runs at one operating point: mean and scatter)."""
    groups: Dict[Tuple[float, float, float], List[Measurement]] = {}
    for m in runs:
        if m.f_ex is None or m.a_ex is None or m.s0 is None:
            raise ValueError(f"{m.path}: the operating point (f_ex, a_ex, s0) is not in the file name")
        groups.setdefault((m.f_ex, m.a_ex, m.s0), []).append(m)
    feats: Dict[str, Feature] = {}
    behaviours: Dict[str, str] = {}
    ops = []
    for (f, a, s0), ms in groups.items():
        op = OperatingPoint(f, a, s0, float(min(m.t[-1] for m in ms)))
        ops.append(op)
        per = []
        for m in ms:
            h = 1e-3
            amp = m.envelope(1.0) / h
            keep = m.t <= op.duration_s + 1e-9
            fe, beh = slider_features(m.t[keep], m.s[keep], amp[keep], tag=op.tag, noise_s=_noise_of(m.s))
            per.append(fe)
            behaviours[op.tag] = beh
        for name in per[0]:
            vals = np.array([p[name].value for p in per if name in p])
            ses = np.array([p[name].stderr for p in per if name in p])
            scatter = float(np.std(vals, ddof=1) / math.sqrt(len(vals))) if len(vals) > 1 else 0.0
            feats[name] = _feature(name, float(np.mean(vals)), math.hypot(float(np.mean(ses)), scatter))
    return feats, behaviours, ops


def _simulate_ops(params: Parameters, ops: Sequence[OperatingPoint], *, s0_shift: float = 0.0):
    from .simulate import simulate

    def one(op: OperatingPoint):
        return simulate(params, f_ex=op.f_ex, a_ex=op.a_ex, s0=op.s0 + s0_shift, t_end=op.duration_s, record_every=5)

    with ThreadPoolExecutor(max_workers=max(1, min(len(ops), os.cpu_count() or 1))) as ex:
        return list(ex.map(one, ops))


def model_slider_features(params: Parameters, ops: Sequence[OperatingPoint], *, s0_shift: float = 0.0
                          ) -> Tuple[Dict[str, Feature], Dict[str, str]]:
    """Features of free-slider runs of the model at the operating points (same code as measured)."""
    feats: Dict[str, Feature] = {}
    behaviours: Dict[str, str] = {}
    for op, r in zip(ops, _simulate_ops(params, ops, s0_shift=s0_shift)):
        amp = r.envelope(1.0) / params.thickness_m
        fe, beh = slider_features(r.t, r.s, amp, tag=op.tag)
        feats.update(fe)
        behaviours[op.tag] = beh
    return feats, behaviours


# --- naming ---------------------------------------------------------------------------------------


@dataclass
class CandidateFit:
    """One candidate set fitted to the measured features."""

    effects: Tuple[str, ...]
    values: Dict[str, float]
    stderrs: Dict[str, float]
    chi2: float
    dof: int
    adequate: bool
    bic: float


@dataclass
class Discovery:
    """Outcome of :func:`discover` (see :func:`write_report`)."""

    level: str
    named_effects: List[str]
    parameters: Dict[str, Dict[str, Any]]
    features: Dict[str, Dict[str, Any]]
    gap_before: float
    gap_after: float
    chi2_before: float
    candidates: List[CandidateFit]
    criterion: str
    baseline: Parameters
    updated: Parameters
    behaviours: Dict[str, Dict[str, str]] = field(default_factory=dict)
    alternatives: List[Tuple[str, ...]] = field(default_factory=list)
    data: Any = None
    runtime_s: float = 0.0
    verdict: str = "none"
    """``named`` (an effect set passed the naming rule), ``unexplained`` (the baseline does not fit
    and no candidate set passes), ``none`` (the baseline fits the data)."""
    rejected: List[Dict[str, Any]] = field(default_factory=list)
    """Fitted candidate sets not named, each with the reasons."""
    features_off: List[Dict[str, Any]] = field(default_factory=list)
    """Features still off after the update (|z| > 2), largest first."""
    gap_ratio: float = 0.3

    def to_json(self) -> Dict[str, Any]:
        return _json_safe(dict(
            verdict=self.verdict, level=self.level, named_effects=self.named_effects, parameters=self.parameters,
            rejected=self.rejected, features_off=self.features_off, gap_ratio=self.gap_ratio,
            gap_before=self.gap_before, gap_after=self.gap_after, gap_measure=GAP_MEASURE,
            chi2_before=self.chi2_before, criterion=self.criterion, features=self.features,
            behaviours=self.behaviours, alternatives=[list(a) for a in self.alternatives],
            candidates=[dict(effects=list(c.effects), values=c.values, stderrs=c.stderrs, chi2=c.chi2, dof=c.dof,
                             adequate=c.adequate, bic=c.bic) for c in self.candidates],
            baseline=self.baseline.to_dict(), updated=self.updated.to_dict(), runtime_s=self.runtime_s))


GAP_MEASURE = "RMS over the features of (model - measured) / measurement uncertainty"


def _chi2_quantile(dof: int) -> float:
    from scipy.stats import chi2

    return float(chi2.ppf(1 - SIGNIFICANCE, max(dof, 1)))


def _gap(model: Dict[str, float], meas: Dict[str, Feature]) -> Tuple[float, float]:
    z = [(model[k] - f.value) / f.stderr for k, f in meas.items() if k in model and math.isfinite(model[k])]
    z = np.asarray(z)
    return float(np.sqrt(np.mean(z ** 2))) if len(z) else 0.0, float(np.sum(z ** 2))


def _fit_candidate(effects: Sequence[Effect], baseline: Parameters, meas: Dict[str, Feature],
                   model_fn: Callable[[Parameters], Dict[str, float]], *, diff_step: Optional[float],
                   max_nfev: int) -> CandidateFit:
    from scipy.optimize import least_squares

    names = [k for k in meas]
    sig = np.array([meas[k].stderr for k in names])
    y = np.array([meas[k].value for k in names])
    penalty = 1e3

    def resid(u: np.ndarray) -> np.ndarray:
        try:
            m = model_fn(_apply(baseline, effects, u))
        except (ValueError, _core.SimulationError):
            return np.full(len(names), penalty)
        r = np.array([(m.get(k, math.nan) - yk) / sk for k, yk, sk in zip(names, y, sig)])
        return np.where(np.isfinite(r), r, penalty)

    lo = np.array([e.lower for e in effects])
    hi = np.array([e.upper for e in effects])
    starts = [np.clip([e.variable(e.baseline_value(baseline), baseline) for e in effects], lo, hi)]
    starts.append(lo + 0.1 * (hi - lo))
    best = None
    for x0 in starts:
        kw = dict(bounds=(lo, hi), x_scale=np.maximum(hi - lo, 1e-12) * 0.05, max_nfev=max_nfev)
        if diff_step is not None:
            kw["diff_step"] = diff_step
        r = least_squares(resid, x0, **kw)
        if best is None or r.cost < best.cost:
            best = r
    assert best is not None
    chi2 = float(2 * best.cost)
    n, k = len(names), len(effects)
    J = best.jac
    try:
        cov_u = np.linalg.pinv(J.T @ J)
        se_u = np.sqrt(np.maximum(np.diag(cov_u), 0.0))
    except np.linalg.LinAlgError:
        se_u = np.full(k, math.inf)
    values, stderrs = {}, {}
    for e, u, su in zip(effects, best.x, se_u):
        v = e.value(u, baseline)
        values[e.name] = v
        if e.kind == "compliance":
            stderrs[e.name] = abs(e.scale(baseline) / u ** 2) * su if u > 0 else math.inf
        else:
            stderrs[e.name] = abs(e.scale(baseline)) * su
    dof = n - k
    return CandidateFit(tuple(e.name for e in effects), values, stderrs, chi2, dof,
                        chi2 <= _chi2_quantile(dof), chi2 + k * math.log(max(n, 2)))


def _profile_fit(effects: Sequence[Effect], baseline: Parameters, meas: Dict[str, Feature],
                 model_fn: Callable[[Parameters], Dict[str, float]], *, grid_n: int = 9, refine: int = 5,
                 progress: Optional[Callable[[], None]] = None) -> CandidateFit:
    """Fit for expensive, not smooth objectives (slider level): per effect a grid scan of χ² over
    its search range, golden-section refinement in the best bracket, one coordinate pass per
    effect; the standard error from the curvature of the χ² profile (χ² = χ²_min + (u − û)²/σ²)."""
    names = list(meas)
    sig = np.array([meas[k].stderr for k in names])
    y = np.array([meas[k].value for k in names])
    cache: Dict[Tuple[float, ...], float] = {}

    def chi2(u: np.ndarray) -> float:
        key = tuple(round(float(v), 12) for v in u)
        if key not in cache:
            try:
                m = model_fn(_apply(baseline, effects, u))
                r = np.array([(m.get(k, yk + 5 * sk) - yk) / sk for k, yk, sk in zip(names, y, sig)])
                cache[key] = float(r @ r) if np.all(np.isfinite(r)) else math.inf
            except (ValueError, _core.SimulationError):
                cache[key] = math.inf
            if progress is not None:
                progress()
        return cache[key]

    u = np.array([np.clip(e.variable(e.baseline_value(baseline), baseline), e.lower, e.upper) for e in effects])
    samples: List[List[Tuple[float, float]]] = [[] for _ in effects]
    for i, e in enumerate(effects):
        lo, hi = e.search if math.isfinite(e.search[0]) else (e.lower, e.upper)
        grid = np.linspace(lo, hi, grid_n)
        vals = []
        for g in grid:
            uu = u.copy()
            uu[i] = g
            vals.append(chi2(uu))
        j = int(np.argmin(vals))
        a, b = grid[max(j - 1, 0)], grid[min(j + 1, grid_n - 1)]
        pts = list(zip(grid, vals))
        gr = (math.sqrt(5) - 1) / 2
        c, d = b - gr * (b - a), a + gr * (b - a)
        fc, fd = chi2(np.where(np.arange(len(u)) == i, c, u)), chi2(np.where(np.arange(len(u)) == i, d, u))
        pts += [(c, fc), (d, fd)]
        for _ in range(max(refine - 2, 0)):
            if fc < fd:
                b, d, fd = d, c, fc
                c = b - gr * (b - a)
                fc = chi2(np.where(np.arange(len(u)) == i, c, u))
                pts.append((c, fc))
            else:
                a, c, fc = c, d, fd
                d = a + gr * (b - a)
                fd = chi2(np.where(np.arange(len(u)) == i, d, u))
                pts.append((d, fd))
        x_best, f_best = min(pts, key=lambda p: p[1])
        u[i] = x_best
        samples[i] = pts
    best_chi2 = chi2(u)
    values, stderrs = {}, {}
    for i, e in enumerate(effects):
        pts = sorted(samples[i])
        xs = np.array([p[0] for p in pts])
        fs = np.array([p[1] for p in pts])
        ok = np.isfinite(fs)
        step = (np.ptp(xs[ok]) / max(grid_n - 1, 1)) if ok.sum() > 2 else 1.0
        near = ok & (np.abs(xs - u[i]) <= 1.5 * step)
        su = math.inf
        if near.sum() >= 3:
            curv = np.polyfit(xs[near] - u[i], fs[near], 2)[0]
            if curv > 0:
                su = 1 / math.sqrt(curv)
        values[e.name] = e.value(u[i], baseline)
        stderrs[e.name] = abs(e.scale(baseline)) * su if e.kind != "compliance" else math.inf
    n, k = len(names), len(effects)
    return CandidateFit(tuple(e.name for e in effects), values, stderrs, best_chi2, n - k,
                        best_chi2 <= _chi2_quantile(n - k), best_chi2 + k * math.log(max(n, 2)))


def _lrt_threshold(df: int, m: int) -> float:
    """Likelihood-ratio threshold for adding ``df`` effects chosen as the best of ``m`` candidate
    sets: the (1 − α/m) quantile of χ²(df) (Bonferroni for picking the best of m)."""
    from scipy.stats import chi2

    return float(chi2.isf(SIGNIFICANCE / max(m, 1), max(df, 1)))


def _select(fits: List[CandidateFit], chi2_0: float, n: int) -> Tuple[Optional[CandidateFit], List[Tuple[str, ...]]]:
    """Nothing if the baseline is adequate; else forward selection by likelihood-ratio tests: the
    best single effect must beat the baseline, and the best larger set containing the current
    choice must beat it, by more than :func:`_lrt_threshold` (99 %, corrected for the number of
    sets the best was picked from)."""
    if chi2_0 <= _chi2_quantile(n) or not fits:
        return None, []
    by_size: Dict[int, List[CandidateFit]] = {}
    for f in fits:
        by_size.setdefault(len(f.effects), []).append(f)
    best: Optional[CandidateFit] = None
    best_chi2, best_k = chi2_0, 0
    for k in sorted(by_size):
        pool = [c for c in by_size[k] if best is None or set(best.effects) <= set(c.effects)]
        if not pool:
            continue
        top = min(pool, key=lambda c: c.chi2)
        if best_chi2 - top.chi2 > _lrt_threshold(k - best_k, len(pool)):
            best, best_chi2, best_k = top, top.chi2, k
        else:
            break
    if best is None:
        return None, []
    alts = [c.effects for c in by_size[len(best.effects)] if c.effects != best.effects and c.chi2 - best.chi2 < 2.0]
    return best, alts


def _fit_sets(cand_effects: Sequence[Effect], max_effects: int, level: str, base: Parameters,
              meas: Dict[str, Feature], model_fn: Callable[[Parameters], Dict[str, float]],
              diff_step: Optional[float], max_nfev: int) -> List[CandidateFit]:
    """Fit every single candidate and the sets of up to ``max_effects``: at the beam level (cheap
    surrogate) all of them, at the slider level (full simulations) only the sets that extend one
    of the two best singles."""
    def fit(combo: Sequence[Effect]) -> CandidateFit:
        if level == "beam":
            return _fit_candidate(combo, base, meas, model_fn, diff_step=diff_step, max_nfev=max_nfev)
        return _profile_fit(combo, base, meas, model_fn)

    fits = [fit((e,)) for e in cand_effects]
    if max_effects < 2:
        return fits
    top = {f.effects[0] for f in sorted(fits, key=lambda f: f.chi2)[:2]}
    for k in range(2, max_effects + 1):
        for combo in itertools.combinations(cand_effects, k):
            if level == "beam" or top & {e.name for e in combo}:
                fits.append(fit(combo))
    return fits


def _judge(fits: Sequence[CandidateFit], base: Parameters, n: int, gap_before: float,
           gap_ratio: float) -> Dict[Tuple[str, ...], List[str]]:
    """The naming rule per fitted set: the reasons it may not be named (empty: it may). Not
    adequate (chi2 > chi2_0.99(n - k)); a parameter moved by less than its relevance threshold;
    a small share of the gap (fitted gap sqrt(chi2/n) > gap_ratio x gap before)."""
    out: Dict[Tuple[str, ...], List[str]] = {}
    for f in fits:
        reasons = []
        if not f.adequate:
            reasons.append(f"not adequate: chi2 = {f.chi2:.3g} > chi2_0.99({f.dof}) = {_chi2_quantile(f.dof):.3g}")
        for e in f.effects:
            ok, how = EFFECTS[e].relevant(f.values[e], base)
            if not ok:
                reasons.append(f"negligible change of {EFFECTS[e].field}: {how}")
        g = math.sqrt(max(f.chi2, 0.0) / max(n, 1))
        if g > gap_ratio * gap_before:
            reasons.append(f"small share of the gap: {gap_before:.3g} -> {g:.3g} (more than {gap_ratio:g} x)")
        out[f.effects] = reasons
    return out


def discover(*, enma_data: Optional[EnmaData] = None, measured: Optional[Sequence[Measurement]] = None,
             baseline: Optional[Parameters] = None, effects: Optional[Sequence[str]] = None,
             max_effects: int = 2, progress: bool = False, gap_ratio: float = 0.3) -> Discovery:
    """Find the effects the ``baseline`` model misses, from beam-level ENMA data (``enma_data``)
    or slider-level free-slider runs (``measured``, files of the published format), name them,
    add them and measure the gap before and after (module docs: criterion). ``gap_ratio``: a named
    set must leave at most this share of the gap (0.3); otherwise the verdict is "unexplained"."""
    import time

    t0 = time.perf_counter()
    base = resolve(baseline)
    if not (isinstance(gap_ratio, (int, float)) and 0 < gap_ratio <= 1):
        raise ValueError(f"invalid gap_ratio = {gap_ratio!r}: must be in (0, 1]")
    if (enma_data is None) == (measured is None):
        raise ValueError("give either enma_data (beam level) or measured runs (slider level)")
    level = "beam" if enma_data is not None else "slider"
    names = list(effects) if effects is not None else [n for n, e in EFFECTS.items() if e.level == level]
    unknown = [n for n in names if n not in EFFECTS]
    if unknown:
        raise ValueError(f"unknown effect {unknown[0]!r}: known are {', '.join(EFFECTS)}")
    cand_effects = [EFFECTS[n] for n in names if EFFECTS[n].level == level]
    if not cand_effects:
        raise ValueError(f"none of the effects {names} acts at the {level} level")
    behaviours: Dict[str, Dict[str, str]] = {}
    if level == "beam":
        assert enma_data is not None
        meas = enma_features(enma_data)
        levels = _levels_for(enma_data, base)
        sim_base, _ = simulated_enma_features(base, levels)
        sur_base = beam_surrogate(base)
        bias = {k: sim_base[k].value - sur_base[k] for k in sim_base if k in sur_base}

        def model_fn(p: Parameters) -> Dict[str, float]:
            s = beam_surrogate(p)
            return {k: v + bias.get(k, 0.0) for k, v in s.items()}

        before = {k: f.value for k, f in sim_base.items()}
        diff_step, max_nfev = None, 200
    else:
        assert measured is not None
        meas, beh_meas, ops = measured_slider_features(measured)
        base_feats, beh_base = model_slider_features(base, ops)
        # Run-to-run variability of the model (repeated runs from s0 ± 0.002) joins the uncertainty.
        reps = [model_slider_features(base, ops, s0_shift=d)[0] for d in (-0.002, 0.002)]
        for k, f in list(meas.items()):
            vals = [base_feats[k].value] + [r[k].value for r in reps if k in r] if k in base_feats else []
            spread = float(np.std(vals, ddof=1)) if len(vals) > 1 else 0.0
            meas[k] = dataclasses.replace(f, stderr=math.hypot(f.stderr, spread))
        before = {k: f.value for k, f in base_feats.items()}
        behaviours = {"measured": beh_meas, "baseline": beh_base}

        def model_fn(p: Parameters) -> Dict[str, float]:
            return {k: f.value for k, f in model_slider_features(p, ops)[0].items()}

        diff_step, max_nfev = None, 0
    # Features the baseline cannot compute (e.g. no turning point) count as a disagreement of 5σ.
    for k in meas:
        if k not in before:
            before[k] = meas[k].value + 5 * meas[k].stderr
    gap_before, chi2_0 = _gap(before, meas)
    n = len(meas)
    fits: List[CandidateFit] = []
    if chi2_0 > _chi2_quantile(n):
        fits = _fit_sets(cand_effects, max_effects, level, base, meas, model_fn, diff_step, max_nfev)
    # The set the likelihood-ratio selection would pick without the naming rule.
    best, alts = _select(fits, chi2_0, n)
    if best is not None and level == "beam":
        # One refinement: re-centre the surrogate's bias correction at that model and refit (the
        # surrogate's own errors would otherwise count against adequacy).
        chosen = _realise(base, {e: best.values[e] for e in best.effects})
        sim_c, _ = simulated_enma_features(chosen, levels)
        sur_c = beam_surrogate(chosen)
        bias = {k: sim_c[k].value - sur_c[k] for k in sim_c if k in sur_c}
        fits = [_fit_candidate([EFFECTS[e] for e in f.effects], base, meas, model_fn, diff_step=diff_step,
                               max_nfev=max_nfev) for f in fits]
    verdicts = _judge(fits, base, n, gap_before, gap_ratio)
    best, alts = _select([f for f in fits if not verdicts[f.effects]], chi2_0, n)

    def after_of(p: Parameters) -> Tuple[Dict[str, float], Dict[str, str]]:
        # "After": full simulation of the updated model (not the surrogate).
        if level == "beam":
            return {k: f.value for k, f in simulated_enma_features(p, levels)[0].items()}, {}
        r = model_slider_features(p, ops)
        return {k: f.value for k, f in r[0].items()}, r[1]

    def gap_of(f: Dict[str, float]) -> float:
        f = dict(f)
        for k in meas:
            if k not in f:
                f[k] = meas[k].value + 5 * meas[k].stderr
        return _gap(f, meas)[0]

    after_f: Dict[str, float] = dict(before)
    beh_upd = behaviours.get("baseline", {})
    updated = base
    if best is not None:
        cand = _realise(base, {e: best.values[e] for e in best.effects})
        f_c, b_c = after_of(cand)
        g_c = gap_of(f_c)
        if g_c <= gap_ratio * gap_before:
            updated, after_f, beh_upd = cand, f_c, b_c
        else:
            # The fit's gap was small enough, the full simulation's is not: not named.
            verdicts[best.effects] = verdicts[best.effects] + [
                f"small share of the gap in the full simulation of the updated model: gap {g_c:.3g} > "
                f"{gap_ratio:g} x {gap_before:.3g}"]
            best, alts = None, []
    if level == "slider":
        behaviours["updated"] = beh_upd
    if best is None:
        named: List[str] = []
        params_out: Dict[str, Dict[str, Any]] = {}
    else:
        named = list(best.effects)
        params_out = {e: dict(field=EFFECTS[e].field, value=best.values[e], stderr=best.stderrs[e],
                              unit=EFFECTS[e].unit, baseline=EFFECTS[e].baseline_value(base),
                              relevance=EFFECTS[e].relevant(best.values[e], base)[1]) for e in named}
    for k in meas:
        if k not in after_f:
            after_f[k] = meas[k].value + 5 * meas[k].stderr
    gap_after, _ = _gap(after_f, meas)
    features = {k: dict(measured=f.value, uncertainty=f.stderr, baseline=before[k], updated=after_f[k],
                        unit=f.unit, description=f.description,
                        z_before=(before[k] - f.value) / f.stderr, z_after=(after_f[k] - f.value) / f.stderr,
                        exceeds_uncertainty=bool(abs(before[k] - f.value) > 2 * f.stderr))
                for k, f in meas.items()}
    negligible = [f for f in fits if verdicts[f.effects]
                  and all(r.startswith("negligible change") for r in verdicts[f.effects])]
    if chi2_0 <= _chi2_quantile(n):
        verdict = "none"
    elif best is not None:
        verdict = "named"
    elif negligible:
        # Adequate and closing the gap, but only by a physically negligible change: nothing to name.
        verdict = "none"
    else:
        verdict = "unexplained"
    rejected = [dict(effects=list(f.effects), values=f.values, stderrs=f.stderrs, chi2=f.chi2, dof=f.dof,
                     reasons=verdicts[f.effects] or ["passes the naming rule, but a simpler or better set was named"])
                for f in sorted(fits, key=lambda f: f.chi2) if best is None or f.effects != best.effects]
    off = sorted(((k, v["z_after"]) for k, v in features.items() if abs(v["z_after"]) > 2), key=lambda x: -abs(x[1]))
    criterion = (f"an effect set is named only if (1) the baseline does not fit, chi2 = {chi2_0:.3g} > chi2_0.99(n={n}) = "
                 f"{_chi2_quantile(n):.2f}; (2) the updated model is adequate, chi2 <= chi2_0.99(n-k); (3) each "
                 f"parameter moved by at least its relevance threshold (EFFECTS[...].relevance); (4) the gap after "
                 f"<= {gap_ratio:g} x gap before (fit and full simulation); among the sets that pass, forward "
                 f"selection by likelihood-ratio tests at 99 %, Bonferroni-corrected for picking the best of m "
                 f"sets (m = {len(cand_effects)}: {_lrt_threshold(1, len(cand_effects)):.2f}); otherwise the "
                 f"verdict is 'unexplained' and nothing is added")
    return Discovery(level, named, params_out, features, gap_before, gap_after, chi2_0, fits, criterion, base,
                     updated, behaviours, alts, enma_data if level == "beam" else list(measured or []),
                     time.perf_counter() - t0, verdict=verdict, rejected=rejected,
                     features_off=[dict(feature=k, z=z) for k, z in off], gap_ratio=gap_ratio)


# --- synthesiser ----------------------------------------------------------------------------------


def synthesize_enma(truth: Optional[Parameters] = None, *, levels_m_s2: Sequence[float] = enma.DEFAULT_LEVELS_M_S2,
                    frequency_rel: float = 0.002, damping_rel: float = 0.02, shape_abs: float = 0.002,
                    repeats: int = 2, seed: int = 0) -> EnmaData:
    """Hidden-effect ENMA data: a virtual ENMA (up and down) of ``truth`` with Gaussian noise
    (relative on frequency and damping, absolute on the normalised shape) and ``repeats``
    independently noisy repetitions, reproducible by ``seed``."""
    data = enma.virtual(resolve(truth), levels_m_s2=levels_m_s2)
    noisy = enma.with_noise(data, frequency_rel=frequency_rel, damping_rel=damping_rel, seed=seed, repeats=repeats)
    if shape_abs > 0:
        rng = np.random.default_rng(seed + 7919)
        sh = noisy.shape + shape_abs * rng.standard_normal(noisy.shape.shape)
        sh[:, 2] = 1.0  # the shape is normalised at L/2
        noisy.shape = sh
    noisy.source = f"synthetic ENMA (seed {seed})"
    return noisy


def synthesize_slider_runs(truth: Optional[Parameters] = None, *, operating_points: Sequence[Tuple[float, float, float]],
                           duration_s: float, out_dir: PathLike, noise_s: float = 0.001,
                           noise_velocity_m_s: float = 0.002, seed: int = 0) -> List[Path]:
    """Hidden-effect free-slider runs of ``truth`` written in the published measured format
    (time, beam velocity at 4L/7, s at 1e-4 s; file names carry the operating point), with white
    noise on s and the velocity, reproducible by ``seed``. Returns the file paths."""
    p = resolve(truth)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ops = [OperatingPoint(f, a, s0, duration_s) for f, a, s0 in operating_points]
    rng = np.random.default_rng(seed)
    paths = []
    for op, r in zip(ops, _simulate_ops(p, ops)):
        if not r.completed:
            raise _core.SimulationError(f"truth run at {op.tag} stopped: {r.message}")
        t = r.t
        vel = np.gradient(r.w, t) + noise_velocity_m_s * rng.standard_normal(len(t))
        s = r.s + noise_s * rng.standard_normal(len(t))
        s0_txt = f"{op.s0:g}".replace("0.", "0")
        path = out / f"Time_VelBeam_RelSliderPos__fex{op.f_ex:g}_ExcLevel{op.a_ex:g}_RelSliderPosStart{s0_txt}.txt"
        write_measurement(path, t, vel, s)
        paths.append(path)
    return paths


# --- report ---------------------------------------------------------------------------------------


def write_report(d: Discovery, out_dir: PathLike) -> List[Path]:
    """Write ``updated.toml``, ``report.json``, ``report.md`` and the figures into ``out_dir``."""
    from ._mpl import require_matplotlib

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
    ax.set_title("named: " + (", ".join(d.named_effects) or "nothing (model agrees within uncertainty)"))
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    fig.savefig(out / "gap.png", dpi=120)
    plt.close(fig)
    written.append(out / "gap.png")
    figs = ["gap.png"]
    if d.level == "beam" and isinstance(d.data, EnmaData):
        enma.plot_enma(d.data, enma.fit_backbone(d.data), models={"baseline": d.baseline, "updated": d.updated},
                       path=out / "backbone.png")
        written.append(out / "backbone.png")
        figs.append("backbone.png")
    elif d.level == "slider" and d.data:
        ms = d.data
        ops = [OperatingPoint(m.f_ex, m.a_ex, m.s0, float(m.t[-1])) for m in ms]
        base_runs = _simulate_ops(d.baseline, ops)
        upd_runs = _simulate_ops(d.updated, ops)
        fig, axs = plt.subplots(1, len(ms), figsize=(5.5 * len(ms), 4), constrained_layout=True, squeeze=False)
        for ax, m, rb, ru, op in zip(axs[0], ms, base_runs, upd_runs, ops):
            ax.plot(m.t, m.s, color="0.4", lw=0.8, label="measured")
            ax.plot(rb.t, rb.s, "--", lw=1.3, label="baseline")
            ax.plot(ru.t, ru.s, "-", lw=1.3, label="updated")
            ax.set_title(op.tag.replace("_", " "))
            ax.set_xlabel("t [s]")
            ax.set_ylabel("s = x_C / L [-]")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        fig.savefig(out / "slider.png", dpi=120)
        plt.close(fig)
        written.append(out / "slider.png")
        figs.append("slider.png")
    md = _markdown(d, figs)
    (out / "report.md").write_text(md, encoding="utf-8")
    written.append(out / "report.md")
    return written


def verdict_line(d: Discovery) -> str:
    """The verdict in one line (the CLI prints it)."""
    if d.verdict == "named":
        what = ", ".join(f"{e} ({d.parameters[e]['field']} = {_fmt(d.parameters[e]['value'])} ± "
                         f"{_fmt(d.parameters[e]['stderr'])}, baseline {_fmt(d.parameters[e]['baseline'])})"
                         for e in d.named_effects)
        return f"named {what}; gap {d.gap_before:.3g} -> {d.gap_after:.3g}"
    if d.verdict == "unexplained":
        off = ", ".join(f"{f['feature']} z = {f['z']:+.1f}" for f in d.features_off[:3])
        best = d.rejected[0] if d.rejected else None
        why = (f"; best candidate {' + '.join(best['effects'])} rejected: {best['reasons'][0]}" if best else "")
        return f"unexplained discrepancy (gap {d.gap_before:.3g}; off: {off or 'no single feature beyond 2 sigma'}){why}"
    neg = [r for r in d.rejected if r["reasons"] and all(x.startswith("negligible change") for x in r["reasons"])]
    if neg:
        return (f"none (gap {d.gap_before:.3g} closed by a negligible change: {' + '.join(neg[0]['effects'])}, "
                f"{neg[0]['reasons'][0]})")
    return f"none (the baseline fits: gap {d.gap_before:.3g})"


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return "inf" if math.isinf(v) else f"{v:.5g}"
    return str(v)


def _markdown(d: Discovery, figs: Sequence[str]) -> str:
    lines = [f"# Discrepancy report ({d.level} level)", "", f"**Verdict: {verdict_line(d)}**", ""]
    if d.named_effects:
        lines.append("**Named effect(s): " + ", ".join(f"`{e}`" for e in d.named_effects) + "**")
    elif d.verdict == "unexplained":
        lines.append("**Unexplained discrepancy** — the baseline does not fit the data and no candidate effect "
                     "passes the naming rule; nothing was added to the model.")
    else:
        lines.append("**Named: nothing** — the baseline agrees with the data within the measurement uncertainty.")
    lines += ["", f"Gap ({GAP_MEASURE}): before {d.gap_before:.3g}, after {d.gap_after:.3g} "
              f"(chi2 of the baseline {d.chi2_before:.3g} over {len(d.features)} features).", ""]
    if d.parameters:
        lines += ["| effect | parameter | fitted | ± std. error | baseline |", "|---|---|---|---|---|"]
        for e, p in d.parameters.items():
            lines.append(f"| {e} | {p['field']} [{p['unit']}] | {_fmt(p['value'])} | {_fmt(p['stderr'])} | "
                         f"{_fmt(p['baseline'])} |")
        lines.append("")
    if d.alternatives:
        lines += ["Equally good alternatives: " + "; ".join(", ".join(a) for a in d.alternatives), ""]
    if d.features_off:
        lines += ["Features still off (|z| > 2 after): " + ", ".join(f"{f['feature']} (z = {f['z']:+.1f})"
                                                                   for f in d.features_off), ""]
    if d.rejected:
        lines += ["Not named (best first):", ""]
        for r in d.rejected[:8]:
            vals = ", ".join(f"{EFFECTS[e].field} = {_fmt(r['values'][e])}" for e in r["effects"])
            lines.append(f"- {' + '.join(r['effects'])} ({vals}; chi2 = {r['chi2']:.3g}): " + "; ".join(r["reasons"]))
        lines.append("")
    lines += ["| feature | measured | ± | baseline | updated | z before | z after |", "|---|---|---|---|---|---|---|"]
    for k, f in d.features.items():
        lines.append(f"| {k} | {_fmt(f['measured'])} | {_fmt(f['uncertainty'])} | {_fmt(f['baseline'])} | "
                     f"{_fmt(f['updated'])} | {f['z_before']:+.2f} | {f['z_after']:+.2f} |")
    if d.behaviours:
        lines += ["", "Behaviour types: " + "; ".join(f"{k}: {v}" for k, v in d.behaviours.items())]
    lines += ["", "Candidates (chi2, dof, adequate at 99 %):", ""]
    for c in sorted(d.candidates, key=lambda c: (len(c.effects), c.chi2)):
        vals = ", ".join(f"{EFFECTS[e].field} = {_fmt(c.values[e])}" for e in c.effects)
        lines.append(f"- {' + '.join(c.effects)}: chi2 = {c.chi2:.3g}, dof {c.dof}, "
                     f"{'adequate' if c.adequate else 'not adequate'} ({vals})")
    lines += ["", f"Criterion: {d.criterion}.", "", f"Run time: {d.runtime_s:.1f} s.", ""]
    for fname in figs:
        lines.append(f"![{fname}]({fname})")
    return "\n".join(lines) + "\n"


# --- identifiability and the next measurement ------------------------------------------------------


def _bumped(e: Effect, p: Parameters, steps: float) -> float:
    """The parameter of ``e`` moved from its value in ``p`` by ``steps`` relevance thresholds."""
    b = e.baseline_value(p)
    if e.relevance_kind == "compliance":
        u = e.variable(b, p)
        return e.value(u + steps * max(e.relevance * u, e.relevance_floor), p)
    if e.relevance_kind == "rel":
        return b * (1 + steps * e.relevance)
    return b + steps * e.relevance


def slider_sensitivities(effects: Sequence[str], baseline: Optional[Parameters], ops: Sequence[OperatingPoint], *,
                         steps: float = 5.0) -> Dict[str, Dict[str, float]]:
    """Change of each slider feature at ``ops``, in units of its uncertainty — the resolution floor
    (:data:`FLOORS`) combined with the model's run-to-run spread (runs from s0 ± 0.002, as in
    :func:`discover`) — when each effect moves by ``steps`` relevance thresholds from the
    baseline (one FS run per effect and point)."""
    base = resolve(baseline)
    f0 = model_slider_features(base, ops)[0]
    reps = [model_slider_features(base, ops, s0_shift=d)[0] for d in (-0.002, 0.002)]
    sig = {}
    for k, f in f0.items():
        vals = [f.value] + [r[k].value for r in reps if k in r]
        sig[k] = math.hypot(f.stderr, float(np.std(vals, ddof=1)) if len(vals) > 1 else 0.0)
    out: Dict[str, Dict[str, float]] = {}
    for name in effects:
        e = EFFECTS[name]
        f = model_slider_features(_realise(base, {name: _bumped(e, base, steps)}), ops)[0]
        out[name] = {k: (f[k].value - f0[k].value) / sig[k] for k in f0 if k in f}
    return out


def separability(effects: Optional[Sequence[str]] = None, *, baseline: Optional[Parameters] = None,
                 operating_points: Sequence[Tuple[float, float, float]], duration_s: float,
                 grid: Sequence[Tuple[float, float, float]] = (), max_cos: float = 0.95,
                 steps: float = 5.0) -> List[Dict[str, Any]]:
    """Which pairs of slider-level candidates the data at ``operating_points`` can tell apart.

    Each effect's signature is its sensitivity vector (:func:`slider_sensitivities`, features in
    units of their resolution floors). A pair is *separable* if the angle between the signatures
    is clear (|cos| ≤ ``max_cos``) and both move the features (norm ≥ 2); otherwise, for each
    point of ``grid`` (f_ex, a_ex, s0) the separation min(|z₁|, |z₂|)·sin θ is computed there and
    the best point recommended ("to tell A from B, measure …"). Returns one row per pair."""
    names = list(effects) if effects is not None else [n for n, e in EFFECTS.items() if e.level == "slider"]
    ops = [OperatingPoint(f, a, s0, duration_s) for f, a, s0 in operating_points]
    sens = slider_sensitivities(names, baseline, ops, steps=steps)

    def cos_norms(z1: Dict[str, float], z2: Dict[str, float]) -> Tuple[float, float, float]:
        keys = [k for k in z1 if k in z2]
        a = np.array([z1[k] for k in keys])
        b = np.array([z2[k] for k in keys])
        na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
        c = float(a @ b / (na * nb)) if na > 0 and nb > 0 else 1.0
        return c, na, nb

    grid_sens = {}
    rows = []
    for n1, n2 in itertools.combinations(names, 2):
        c, na, nb = cos_norms(sens[n1], sens[n2])
        row: Dict[str, Any] = dict(pair=[n1, n2], cos=c, norm=[na, nb],
                                   separable=bool(abs(c) <= max_cos and min(na, nb) >= 2.0))
        if not row["separable"] and grid:
            best = None
            for g in grid:
                if g not in grid_sens:
                    grid_sens[g] = slider_sensitivities(names, baseline, [OperatingPoint(*g, duration_s)], steps=steps)
                cg, ga, gb = cos_norms(grid_sens[g][n1], grid_sens[g][n2])
                sep = min(ga, gb) * math.sqrt(max(1 - cg * cg, 0.0))
                if best is None or sep > best[1]:
                    best = (g, sep, cg)
            if best is not None:
                row["recommended"] = dict(f_ex=best[0][0], a_ex=best[0][1], s0=best[0][2], separation=best[1],
                                          cos=best[2])
        rows.append(row)
    return rows
