"""ENMA computations (paper §3, docs/model.md §9): the virtual ENMA of a model (run by the Rust core), noise, the backbone fit and the clamping update."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Dict, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _core
from .._util import progress_bar
from ..params import Parameters, native, resolve
from .data import EnmaData, concat

__all__ = ["DEFAULT_LEVELS_M_S2", "BackboneFit", "ClampingUpdate", "backbone_hz", "beam_properties", "fit_backbone",
           "k_t_from_b_star", "model_backbone", "solve_k_r", "update_clamping", "virtual", "with_noise"]


#: Default excitation levels of :func:`virtual` [m/s²] (ã ≈ 0.06 … 0.9 for the prototype).
DEFAULT_LEVELS_M_S2 = tuple(0.25 * k for k in range(1, 17))


def virtual(params: Optional[Parameters] = None, *, levels_m_s2: Sequence[float] = DEFAULT_LEVELS_M_S2,
            up_and_down: bool = True, sensor_x_m: Optional[float] = None, kp_per_s: float = 40.0,
            ki_per_s2: float = 400.0, start_frequency_hz: Optional[float] = None, settle_periods: int = 50,
            phase_tol_rad: float = 1e-4, amplitude_tol: float = 1e-5, frequency_tol: float = 1e-6,
            eval_periods: int = 100, max_hold_s: float = 60.0, progress: bool = False) -> EnmaData:
    """Virtual ENMA of the beam of ``params`` (the slider is ignored; docs/model.md §9, paper §3.1).

    The excitation levels ``levels_m_s2`` [m/s²] are stepped up (and back down when
    ``up_and_down``). At each level a PI phase-locked loop (gains ``kp_per_s`` [rad/s per rad],
    ``ki_per_s2`` [rad/s² per rad], updated once per period) drives the response at
    ``sensor_x_m`` (default L/2) to lag the modal excitation force by 90°. The level is held
    until, over ``settle_periods`` periods, the phase error stays below ``phase_tol_rad``, the
    amplitude varies by less than ``amplitude_tol`` and the frequency by less than
    ``frequency_tol`` (relative) — or ``max_hold_s`` passes (``info["converged"]`` is False) —
    then ``eval_periods`` periods are evaluated. With the defaults the results do not depend on
    the gains or the window by more than 1e-5 in frequency and 1e-4 in amplitude.

    Returns:
        :class:`EnmaData` with run ``"up"``/``"down"``; ``info`` holds per-point settle times,
        convergence flags, phase errors, third-harmonic ratios and complex responses.
    """
    p = resolve(params)
    opts = dict(levels_m_s2=[float(v) for v in np.atleast_1d(levels_m_s2)], up_and_down=bool(up_and_down),
                sensor_x_m=None if sensor_x_m is None else float(sensor_x_m), kp_per_s=float(kp_per_s),
                ki_per_s2=float(ki_per_s2),
                start_frequency_hz=None if start_frequency_hz is None else float(start_frequency_hz),
                settle_periods=int(settle_periods), phase_tol_rad=float(phase_tol_rad),
                amplitude_tol=float(amplitude_tol), frequency_tol=float(frequency_tol),
                eval_periods=int(eval_periods), max_hold_s=float(max_hold_s))
    n_levels = len(opts["levels_m_s2"]) * (2 if up_and_down and len(opts["levels_m_s2"]) > 1 else 1) - (
        1 if up_and_down and len(opts["levels_m_s2"]) > 1 else 0)
    with progress_bar(progress, n_levels, "virtual ENMA", "pts") as cb:
        r = _core.virtual_enma(native(p), progress=cb, **_finite_options(opts))
        if cb is not None:
            cb(n_levels, n_levels)
    pts = r["points"]
    data = EnmaData(
        amplitude_h=np.array([q["amplitude_h"] for q in pts]),
        frequency_hz=np.array([q["frequency_hz"] for q in pts]),
        damping_ratio=np.array([q["damping_ratio"] for q in pts]),
        run=np.array([q["run"] for q in pts], dtype=object),
        level_m_s2=np.array([q["level_m_s2"] for q in pts]),
        shape=np.array([q["shape"] for q in pts]).reshape(len(pts), 5),
        source="virtual ENMA",
        info=dict(
            options=opts, simulated_s=r["simulated_s"], steps=r["steps"],
            settle_time_s=np.array([q["settle_time_s"] for q in pts]),
            converged=np.array([q["converged"] for q in pts], dtype=bool),
            phase_error_rad=np.array([q["phase_error_rad"] for q in pts]),
            third_harmonic_ratio=np.array([q["third_harmonic_ratio"] for q in pts]),
            response_m=np.array([[complex(a, -b) for a, b in zip(q["response_re_m"], q["response_im_m"])]
                                 for q in pts]).reshape(len(pts), 5),
        ),
    )
    return data


def _finite_options(d: Dict[str, Any]) -> Dict[str, Any]:
    for k, v in d.items():
        if isinstance(v, float) and not math.isfinite(v):
            raise ValueError(f"invalid ENMA option `{k}` = {v}: must be finite")
    return d


def with_noise(data: EnmaData, *, frequency_rel: float = 0.0, amplitude_rel: float = 0.0,
               damping_rel: float = 0.0, seed: int = 0, repeats: int = 1) -> EnmaData:
    """Noisy copies of ``data``: independent Gaussian relative noise (standard deviations
    ``frequency_rel``, ``amplitude_rel``, ``damping_rel``) from ``numpy.random.default_rng(seed)``.
    ``repeats`` > 1 concatenates that many independently noisy copies (like the paper's repeated
    up-and-down runs #1–#4); their run labels get the suffix ``#1``, ``#2``, …"""
    for name, v in (("frequency_rel", frequency_rel), ("amplitude_rel", amplitude_rel), ("damping_rel", damping_rel)):
        if not (math.isfinite(v) and v >= 0):
            raise ValueError(f"{name} = {v} must be finite and >= 0")
    if int(repeats) < 1:
        raise ValueError(f"repeats = {repeats} must be >= 1")
    rng = np.random.default_rng(seed)
    k = len(data)
    parts = []
    for r in range(int(repeats)):
        label = data.run if repeats == 1 else np.array([f"{x} #{r + 1}" for x in data.run], dtype=object)
        parts.append(dataclasses.replace(
            data,
            frequency_hz=data.frequency_hz * (1 + frequency_rel * rng.standard_normal(k)),
            amplitude_h=data.amplitude_h * (1 + amplitude_rel * rng.standard_normal(k)),
            damping_ratio=data.damping_ratio * (1 + damping_rel * rng.standard_normal(k)),
            run=label,
        ))
    out = concat(parts)
    out.source = f"{data.source} + noise (f {frequency_rel:g}, a {amplitude_rel:g}, D {damping_rel:g}, seed {seed}" + (
        f", {repeats} repeats)" if repeats > 1 else ")")
    out.info = dict(data.info)
    return out


# --- fitting --------------------------------------------------------------------------------------


@dataclass
class BackboneFit:
    """Least-squares fit of ω̃² = ω² + ¾ b* ã² (docs/model.md §9, paper eq. (4)).

    Attributes:
        omega2: ω² [rad²/s²]; b_star: b* [s⁻²]; covariance: 2×2 covariance of (ω², b*) from the
        residual scatter; omega2_stderr, b_star_stderr: standard errors; residual_rms_hz: RMS of
        the frequency residuals [Hz]; n_points: number of points; damping_ratio_mean,
        damping_ratio_stderr: mean measured damping and its standard error (NaN if none).
    """

    omega2: float
    b_star: float
    covariance: np.ndarray
    residual_rms_hz: float
    n_points: int
    damping_ratio_mean: float = math.nan
    damping_ratio_stderr: float = math.nan

    @property
    def omega2_stderr(self) -> float:
        return float(math.sqrt(self.covariance[0, 0]))

    @property
    def b_star_stderr(self) -> float:
        return float(math.sqrt(self.covariance[1, 1]))

    @property
    def linear_frequency_hz(self) -> float:
        """ω/2π [Hz]."""
        return math.sqrt(self.omega2) / (2 * math.pi)

    @property
    def linear_frequency_stderr_hz(self) -> float:
        return self.omega2_stderr / (2 * math.sqrt(self.omega2)) / (2 * math.pi)

    def frequency_hz(self, amplitude_h: Union[float, np.ndarray]) -> np.ndarray:
        """ω̃(ã)/2π of the fitted backbone [Hz]."""
        return backbone_hz(self.omega2, self.b_star, amplitude_h)

    def to_dict(self) -> Dict[str, Any]:
        return dict(omega2=self.omega2, omega2_stderr=self.omega2_stderr, b_star=self.b_star,
                    b_star_stderr=self.b_star_stderr, linear_frequency_hz=self.linear_frequency_hz,
                    linear_frequency_stderr_hz=self.linear_frequency_stderr_hz,
                    residual_rms_hz=self.residual_rms_hz, n_points=self.n_points,
                    damping_ratio_mean=self.damping_ratio_mean, damping_ratio_stderr=self.damping_ratio_stderr)


def backbone_hz(omega2: float, b_star: float, amplitude_h: Union[float, np.ndarray]) -> np.ndarray:
    """Single-mode backbone ω̃(ã)/2π = √(ω² + ¾ b* ã²)/2π [Hz] (the core's backbone, docs/model.md §9)."""
    a = np.asarray(amplitude_h, dtype=float)
    w2 = np.asarray(_core.backbone_omega2(float(omega2), float(b_star), a.ravel().tolist(), 1.0)).reshape(a.shape)
    return np.sqrt(np.maximum(w2, 0.0)) / (2 * math.pi)


def fit_backbone(data: EnmaData) -> BackboneFit:
    """Fit (ω², b*) by linear least squares over the phase-resonant points (ãₖ, ω̃ₖ):
    [1, ¾ãₖ²] (ω², b*)ᵀ ≈ ω̃ₖ². Standard errors from the residual variance (K − 2 degrees of freedom).

    Raises:
        ValueError: fewer than 3 points, or amplitudes that do not spread (all at one amplitude:
            ω² and b* cannot be separated).
    """
    a = np.asarray(data.amplitude_h, dtype=float)
    w = 2 * math.pi * np.asarray(data.frequency_hz, dtype=float)
    k = len(a)
    if k < 3:
        raise ValueError(f"fit_backbone needs at least 3 phase-resonant points (got {k}): "
                         "two unknowns (omega^2, b*) and one degree of freedom for the error estimate")
    x = 0.75 * a * a
    spread = float(np.ptp(x))
    if not spread > 1e-9 * max(float(np.max(x)), 1e-300) or float(np.max(x)) == 0.0:
        raise ValueError(f"fit_backbone: all {k} points are at one amplitude (a~ = {a[0]:g}); "
                         "omega^2 and b* need points at different amplitudes")
    A = np.column_stack([np.ones(k), x])
    y = w * w
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    res = y - A @ coef
    dof = k - 2
    s2 = float(res @ res) / dof
    cov = s2 * np.linalg.inv(A.T @ A)
    f_fit = backbone_hz(coef[0], coef[1], a)
    rms = float(np.sqrt(np.mean((f_fit - data.frequency_hz) ** 2)))
    d = np.asarray(data.damping_ratio, dtype=float)
    d = d[np.isfinite(d)]
    dm = float(np.mean(d)) if len(d) else math.nan
    ds = float(np.std(d, ddof=1) / math.sqrt(len(d))) if len(d) > 1 else math.nan
    return BackboneFit(float(coef[0]), float(coef[1]), cov, rms, k, dm, ds)


# --- model updating -------------------------------------------------------------------------------


def model_backbone(params: Optional[Parameters] = None) -> Tuple[float, float]:
    """(ω², b*) of a model's first mode (ω including an axial preload, b* of docs/model.md §9)."""
    b = _core.beam_properties(native(resolve(params)))
    return b["omega1_preload_rad_s"] ** 2, b["b_star_preload_per_s2"]


def beam_properties(params: Optional[Parameters] = None) -> Dict[str, Any]:
    """Modal data of the linear beam (ω, γ, K₁₁, k_ax, φ₁(L/2), b*, shape of mode 1)."""
    return dict(_core.beam_properties(native(resolve(params))))


@dataclass
class ClampingUpdate:
    """Result of :func:`update_clamping` with uncertainties (delta method from the fit)."""

    k_r_nm_per_rad: float
    k_r_stderr: float
    k_t_n_per_m: float
    k_t_stderr: float
    b_star_inf: float
    damping_ratio: float
    params: Parameters

    def to_dict(self) -> Dict[str, Any]:
        return dict(k_r_nm_per_rad=self.k_r_nm_per_rad, k_r_stderr=self.k_r_stderr,
                    k_t_n_per_m=self.k_t_n_per_m, k_t_stderr=self.k_t_stderr, b_star_inf=self.b_star_inf,
                    damping_ratio=self.damping_ratio)


def _with(p: Parameters, **changes: Any) -> Parameters:
    return Parameters(**{**p.to_dict(), **changes})


def _omega1(p: Parameters, k_r: float) -> float:
    return _core.beam_properties(native(_with(p, k_r_nm_per_rad=k_r)))["omega1_preload_rad_s"]


def solve_k_r(params: Parameters, omega_rad_s: float) -> float:
    """k_r [N m/rad] whose linear first natural frequency is ``omega_rad_s`` (brentq in log k_r;
    the linear frequency does not depend on k_t). ``inf`` when ω equals the ideally clamped one
    within 1e-10; ValueError outside the reachable range (pinned … clamped)."""
    from scipy.optimize import brentq

    p = resolve(params)
    ei_l = beam_properties(p)["ei_n_m2"] / p.length_m
    w_inf = _omega1(p, math.inf)
    lo, hi = 1e-4 * ei_l, 1e9 * ei_l
    w_lo = _omega1(p, lo)
    if omega_rad_s >= w_inf * (1 - 1e-10):
        if omega_rad_s <= w_inf * (1 + 1e-10):
            return math.inf
        raise ValueError(f"the fitted linear frequency {omega_rad_s / (2 * math.pi):.3f} Hz exceeds the ideally "
                         f"clamped beam's {w_inf / (2 * math.pi):.3f} Hz: no rotational stiffness k_r explains it "
                         "(stiffer beam or axial preload?)")
    if omega_rad_s <= w_lo:
        raise ValueError(f"the fitted linear frequency {omega_rad_s / (2 * math.pi):.3f} Hz is below the nearly "
                         f"pinned beam's {w_lo / (2 * math.pi):.3f} Hz: no k_r explains it")
    if omega_rad_s >= _omega1(p, hi):
        return hi
    g = brentq(lambda lk: _omega1(p, math.exp(lk)) - omega_rad_s, math.log(lo), math.log(hi), xtol=1e-12, rtol=1e-12)
    return float(math.exp(g))


def k_t_from_b_star(params: Parameters, b_star: float) -> Tuple[float, float]:
    """(k_t, b*_∞): k_t = EA / (L (b*_∞/b* − 1)) with b*_∞ of ``params`` at k_t = ∞
    (docs/model.md §9). k_t = inf when b* ≥ b*_∞."""
    p = resolve(params)
    b_inf = model_backbone(_with(p, k_t_n_per_m=math.inf))[1]
    if not b_star > 0:
        raise ValueError(f"the fitted b* = {b_star:g} s^-2 is not positive: no softening clamping explains it")
    ratio = b_inf / b_star - 1.0
    ea = beam_properties(p)["ea_n"]
    k_t = math.inf if ratio <= 0 else ea / (p.length_m * ratio)
    return k_t, b_inf


def update_clamping(params: Optional[Parameters], fit: BackboneFit, *, full_output: bool = False
                    ) -> Union[Parameters, ClampingUpdate]:
    """Update the clamping of ``params`` from a backbone fit (paper §3.2, docs/model.md §9):
    k_r solves ω_model(k_r) = ω; k_t = EA / (L (b*_∞/b* − 1)) with b*_∞ at the updated k_r and
    k_t → ∞; the damping ratio becomes the fit's mean measured damping (if any). Geometry,
    material and everything else stay as in ``params``.

    Returns the updated :class:`Parameters`, or with ``full_output`` a :class:`ClampingUpdate`
    that also holds the standard errors of k_r and k_t (delta method) and b*_∞.
    """
    p = resolve(params)
    w = math.sqrt(fit.omega2)
    k_r = solve_k_r(p, w)
    p_r = _with(p, k_r_nm_per_rad=k_r)
    k_t, b_inf = k_t_from_b_star(p_r, fit.b_star)
    changes: Dict[str, Any] = dict(k_r_nm_per_rad=k_r, k_t_n_per_m=k_t)
    if math.isfinite(fit.damping_ratio_mean):
        changes["damping_ratio"] = fit.damping_ratio_mean
    updated = _with(p, **changes)
    if not full_output:
        return updated
    # Delta method: σ_kr = σ_ω / |dω/dk_r|, σ_kt = |dk_t/db*| σ_b*.
    sw = fit.omega2_stderr / (2 * w)
    if math.isfinite(k_r):
        h = 1e-4 * k_r
        dw = (_omega1(p, k_r + h) - _omega1(p, k_r - h)) / (2 * h)
        s_kr = sw / abs(dw) if dw else math.inf
    else:
        s_kr = math.inf
    if math.isfinite(k_t):
        ratio = b_inf / fit.b_star - 1.0
        dkt_db = k_t / ratio * b_inf / fit.b_star ** 2
        s_kt = abs(dkt_db) * fit.b_star_stderr
    else:
        s_kt = math.inf
    return ClampingUpdate(k_r, s_kr, k_t, s_kt, b_inf, updated.damping_ratio, updated)
