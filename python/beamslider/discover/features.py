"""Features of measured data and of the model at the same conditions (beam level: ENMA; slider level:
free-slider runs), with uncertainties."""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Dict, Tuple

import numpy as np

from .. import enma
from ..enma import EnmaData
from .options import DEFAULT, DiscoverOptions


@dataclass
class Feature:
    """A physically meaningful number with its standard uncertainty."""

    name: str
    value: float
    stderr: float
    unit: str = ""
    description: str = ""


FLOORS = MappingProxyType({n: (k, v) for n, k, v in DEFAULT.feature_floors})
"""The default resolution floors of the features' uncertainties, by feature: (kind, floor), a view of
:attr:`.options.DiscoverOptions.feature_floors`, where they are set."""

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
    f_recorded=("Hz", "excitation frequency as recorded: spectral peak of the beam velocity near f_ex, "
                      "against the file's time stamps"),
)


def make_feature(name: str, value: float, stderr: float, options: DiscoverOptions = DEFAULT) -> Feature:
    """A feature with its uncertainty floored by :meth:`.options.DiscoverOptions.floor` (docs/model.md
    §9, "Ensembles, modes and features")."""
    unit, desc = DESCRIPTIONS.get(name.split("@")[0], ("", ""))
    floored = float(max(stderr if math.isfinite(stderr) else 0.0, options.floor(name, value)))
    return Feature(name, float(value), floored, unit, desc)


def _linear_fit(x: np.ndarray, y: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Least squares y ≈ c0 + c1 x; coefficients and standard errors (residual scatter)."""
    A = np.column_stack([np.ones_like(x), x])
    c, *_ = np.linalg.lstsq(A, y, rcond=None)
    dof = max(len(x) - 2, 1)
    r = y - A @ c
    cov = float(r @ r) / dof * np.linalg.pinv(A.T @ A)
    return c, np.sqrt(np.maximum(np.diag(cov), 0.0))


def enma_features(data: EnmaData, *, low_amplitude_h: float = 0.3, options: DiscoverOptions = DEFAULT
                  ) -> Dict[str, Feature]:
    """Beam-level features of ENMA data (measured or virtual), with standard errors from the
    scatter of the points (noise and repeated runs), floored by ``options.feature_floors``."""
    fit = enma.fit_backbone(data)
    w0 = math.sqrt(fit.omega2)
    out = {
        "f0_hz": make_feature("f0_hz", fit.linear_frequency_hz, fit.linear_frequency_stderr_hz, options),
        "b_star": make_feature("b_star", fit.b_star, fit.b_star_stderr, options),
    }
    d = np.asarray(data.damping_ratio, dtype=float)
    ok = np.isfinite(d)
    if ok.sum() >= 3 and np.ptp(data.amplitude_h[ok]) > 0:
        # D~(a~) w~/w = D0 + D2 a~^2: the estimate refers to the phase-resonant frequency.
        y = d[ok] * (2 * math.pi * data.frequency_hz[ok]) / w0
        c, se = _linear_fit(data.amplitude_h[ok] ** 2, y)
        out["damping_0"] = make_feature("damping_0", c[0], se[0], options)
        out["damping_2"] = make_feature("damping_2", c[1], se[1], options)
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
            out[name] = make_feature(name, float(np.mean(v)), se, options)
    return out


def _ls_slope(t: np.ndarray, s: np.ndarray) -> Tuple[float, float]:
    if len(t) < 3:
        return math.nan, math.nan
    c, se = _linear_fit(t - t.mean(), s)
    return float(c[1]), float(se[1])


def slider_features(t: np.ndarray, s: np.ndarray, amplitude_h: np.ndarray, *, tag: str = "",
                    noise_s: float = 0.0, options: DiscoverOptions = DEFAULT) -> Tuple[Dict[str, Feature], str]:
    """Slider-level features of one run (s(t) and the envelope of w(4L/7)/h), named
    ``<feature>@<tag>``, and the behaviour type (docs/model.md §8). ``noise_s`` is the standard
    deviation of the measured s (enters the uncertainties); ``options``: the turning point's
    smoothing and the floors (docs/model.md §9, "Ensembles, modes and features")."""
    from ..maps import classify

    t = np.asarray(t, dtype=float)
    s = np.asarray(s, dtype=float)
    a = np.asarray(amplitude_h, dtype=float)
    t_end = float(t[-1])
    out: Dict[str, Feature] = {}

    def add(name: str, value: float, se: float) -> None:
        if math.isfinite(value):
            out[f"{name}@{tag}"] = make_feature(f"{name}@{tag}", value, se, options)

    early = (t >= 0.5) & (t <= min(5.0, t_end))
    add("speed_early", *_ls_slope(t[early], s[early]))
    late = t >= t_end * 2 / 3
    add("speed_late", *_ls_slope(t[late], s[late]))
    last = t >= t_end - 1.0
    n_last = max(int(last.sum()), 1)
    add("s_final", float(np.mean(s[last])), noise_s / math.sqrt(n_last))
    add("amplitude_final_h", float(np.mean(a[last])), float(np.std(a[last])))
    # Turning point: the slider first moves away from the centre, then back by more than 0.01; the
    # extreme of s smoothed over options.turning_smooth_s (the extreme of noisy samples is biased outwards
    # by a few noise standard deviations: +3.6e-3 with the synthesiser's 1e-3, measured).
    from .. import _core

    dt = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    k = max(1, min(int(round(options.turning_smooth_s / dt)), len(s)))
    sm = np.asarray(_core.moving_average(np.ascontiguousarray(s), k)) if k > 1 else s
    s0 = sm[0]
    away = -1.0 if s0 < 0.5 else 1.0
    ext = int(np.argmax(away * (sm - s0)))
    if away * (sm[ext] - s0) > 0.005 and away * (sm[ext] - sm[-1]) > 0.01:
        add("s_turning", float(sm[ext]), noise_s / math.sqrt(k))
    behaviour = classify(t, s, a).behaviour
    return out, behaviour


def _peak_hz(t: np.ndarray, v: np.ndarray, f_ex: float) -> float:
    """Frequency of the largest peak of the Hann-windowed spectrum of ``v`` (zero-padded 4×) within
    f_ex/1.15 … f_ex/0.85 (a time base within ±15 %), interpolated by a parabola through the
    log-magnitudes of the peak's bin and its neighbours (Gaussian interpolation)."""
    n = len(v)
    dt = (float(t[-1]) - float(t[0])) / max(n - 1, 1)
    if n < 16 or dt <= 0:
        return math.nan
    n_fft = 4 * n  # zero-padded: the interpolation's bias falls with the bin width
    mag = np.abs(np.fft.rfft((v - np.mean(v)) * np.hanning(n), n_fft))
    df = 1.0 / (n_fft * dt)
    freq = np.arange(len(mag)) * df
    band = np.flatnonzero((freq >= f_ex / 1.15) & (freq <= f_ex / 0.85))
    band = band[(band > 0) & (band < len(mag) - 1)]
    if len(band) == 0:
        return math.nan
    i = int(band[np.argmax(mag[band])])
    a, b, c = np.log(np.maximum(mag[i - 1:i + 2], 1e-300))
    den = a - 2 * b + c
    return float((i + (0.5 * (a - c) / den if den < 0 else 0.0)) * df)


def recorded_frequency(t: np.ndarray, velocity: np.ndarray, f_ex: float, segments: int = DEFAULT.recorded_segments
                       ) -> Tuple[float, float]:
    """The excitation frequency as a run's time stamps record it [Hz], with its standard error: the
    median of the beam velocity's spectral peaks near ``f_ex`` (:func:`_peak_hz`) in
    ``segments`` equal segments (``DiscoverOptions.recorded_segments``), the error from their median absolute deviation. A
    whole run's peak is off by up to 6·10⁻⁴ f_ex in 15-s runs where the response's phase turns as the
    slider carries the beam through its resonance (a jump); the median keeps to 4·10⁻⁵ (synthetic
    runs, ``scripts/repro/discover_recorded_frequency.py``). The model runs at f_ex exactly; a time
    base τ (samples stamped τ t, docs/model.md §9.1) records f_ex/τ."""
    t = np.asarray(t, dtype=float)
    v = np.asarray(velocity, dtype=float)
    m = len(t) // segments
    segs = np.array([_peak_hz(t[j * m:(j + 1) * m], v[j * m:(j + 1) * m], f_ex) for j in range(segments)])
    segs = segs[np.isfinite(segs)]
    if len(segs) == 0:
        return math.nan, math.nan
    f = float(np.median(segs))
    mad = float(np.median(np.abs(segs - f)))
    se = 1.2533 * 1.4826 * mad / math.sqrt(len(segs)) if len(segs) > 1 else math.nan
    return f, se


# --- candidate effects ----------------------------------------------------------------------------
