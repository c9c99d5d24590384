"""Experimental Nonlinear Modal Analysis (ENMA) of the beam without slider and model updating of
its clamping (paper §3, docs/model.md §9).

- :func:`virtual` — a virtual ENMA of any model: phase-resonance testing with a phase-locked loop
  at stepped excitation levels (run by the Rust core);
- :func:`read` / :meth:`EnmaData.write` — ENMA data as CSV (``amplitude_h``, ``frequency_hz``,
  optional ``damping_ratio``, ``run``, ``level_m_s2``, ``shape_1`` … ``shape_5``);
- :func:`fit_backbone` — least-squares fit of ω̃² = ω² + ¾ b* ã² with standard errors;
- :func:`update_clamping` — k_r from ω (root finding on the linear model), k_t from b*, the mean
  damping ratio; returns updated :class:`~beamslider.Parameters`;
- :func:`model_backbone` — (ω², b*) of a model; :func:`plot_enma` — the paper's Fig. 3 panels.

One module of about 600 lines on purpose: the four steps of one workflow (data, fit, update,
figure) share :class:`EnmaData` and its checks, and the public namespace ``beamslider.enma`` is
this file; the numerics it needs (virtual ENMA, beam quantities) are in the Rust core.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import os
from dataclasses import dataclass, field
from typing import Any, Dict, Optional, Sequence, Tuple, Union

import numpy as np

from . import _core
from .params import Parameters, resolve
from .simulate import _progress_bar

PathLike = Union[str, "os.PathLike[str]"]

#: Sensor positions of the deflection shape, x/L.
SHAPE_X_OVER_L = np.arange(1, 6) / 6.0
#: Default excitation levels of :func:`virtual` [m/s²] (ã ≈ 0.06 … 0.9 for the prototype).
DEFAULT_LEVELS_M_S2 = tuple(0.25 * k for k in range(1, 17))
_REQUIRED = ("amplitude_h", "frequency_hz")
_SHAPE_COLS = tuple(f"shape_{j}" for j in range(1, 6))


class EnmaFormatError(ValueError):
    """An ENMA data file that cannot be read (names the file, line and column)."""


@dataclass
class EnmaData:
    """Phase-resonant points of an ENMA, one per excitation level and run.

    Attributes:
        amplitude_h: modal amplitude ã = ŵ(L/2)/h [-].
        frequency_hz: phase-resonant frequency ω̃/2π [Hz].
        damping_ratio: damping estimate D̃ [-] (NaN where not measured).
        run: run label per point (``"up"``/``"down"`` for a virtual ENMA, any text measured).
        level_m_s2: excitation level a_ex [m/s²] (NaN where unknown).
        shape: deflection shape at x/L = 1/6 … 5/6, shape (K, 5) (NaN where unknown).
        source: where the data came from.
        info: extra facts (virtual ENMA: settle times, convergence, PLL settings).
    """

    amplitude_h: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    run: np.ndarray
    level_m_s2: np.ndarray
    shape: np.ndarray
    source: str = ""
    info: Dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.amplitude_h)

    @property
    def has_damping(self) -> bool:
        return bool(np.any(np.isfinite(self.damping_ratio)))

    @property
    def has_shape(self) -> bool:
        return bool(np.any(np.isfinite(self.shape)))

    def write(self, path: PathLike) -> None:
        """Write as CSV with a header (the format :func:`read` reads)."""
        cols = ["run", "level_m_s2", "amplitude_h", "frequency_hz", "damping_ratio", *_SHAPE_COLS]
        with open(os.fspath(path), "w", encoding="utf-8", newline="") as f:
            w = csv.writer(f)
            w.writerow(cols)
            for k in range(len(self)):
                w.writerow([self.run[k], _num(self.level_m_s2[k]), _num(self.amplitude_h[k]),
                            _num(self.frequency_hz[k]), _num(self.damping_ratio[k]),
                            *(_num(v) for v in self.shape[k])])

    def select(self, mask: np.ndarray) -> "EnmaData":
        """The points where ``mask`` is true."""
        m = np.asarray(mask, dtype=bool)
        return dataclasses.replace(self, amplitude_h=self.amplitude_h[m], frequency_hz=self.frequency_hz[m],
                                   damping_ratio=self.damping_ratio[m], run=self.run[m],
                                   level_m_s2=self.level_m_s2[m], shape=self.shape[m])


def _num(v: float) -> str:
    return "" if not np.isfinite(v) else repr(float(v))


def make_data(amplitude_h: Sequence[float], frequency_hz: Sequence[float], *,
              damping_ratio: Optional[Sequence[float]] = None, run: Optional[Sequence[str]] = None,
              level_m_s2: Optional[Sequence[float]] = None, shape: Optional[np.ndarray] = None,
              source: str = "") -> EnmaData:
    """ENMA data from arrays (missing optional columns become NaN / ``"1"``); validated like a file."""
    a = np.asarray(amplitude_h, dtype=float).ravel()
    k = len(a)
    f = np.asarray(frequency_hz, dtype=float).ravel()
    d = np.full(k, np.nan) if damping_ratio is None else np.asarray(damping_ratio, dtype=float).ravel()
    lv = np.full(k, np.nan) if level_m_s2 is None else np.asarray(level_m_s2, dtype=float).ravel()
    r = np.array(["1"] * k if run is None else [str(x) for x in run], dtype=object)
    sh = np.full((k, 5), np.nan) if shape is None else np.asarray(shape, dtype=float).reshape(k, 5)
    for name, arr in (("frequency_hz", f), ("damping_ratio", d), ("level_m_s2", lv), ("run", r)):
        if len(arr) != k:
            raise ValueError(f"{name} has {len(arr)} values but amplitude_h has {k}")
    data = EnmaData(a, f, d, r, lv, sh, source=source)
    _check_values(data, where=source or "ENMA data")
    return data


def _check_values(data: EnmaData, where: str, lines: Optional[Sequence[int]] = None) -> None:
    if len(data) == 0:
        raise EnmaFormatError(f"{where}: no data points")

    def at(k: int) -> str:
        return f"{where}, line {lines[k]}" if lines is not None else f"{where}, point {k + 1}"

    for name, arr, allow_nan in (("amplitude_h", data.amplitude_h, False), ("frequency_hz", data.frequency_hz, False),
                                 ("damping_ratio", data.damping_ratio, True)):
        for k, v in enumerate(arr):
            if math.isnan(v) and allow_nan:
                continue
            if not math.isfinite(v):
                raise EnmaFormatError(f"{at(k)}: {name} = {v} is not a finite number")
            if name == "damping_ratio" and v < 0:
                raise EnmaFormatError(f"{at(k)}: damping_ratio = {v} must be >= 0")
            if name != "damping_ratio" and not v > 0:
                raise EnmaFormatError(f"{at(k)}: {name} = {v} must be > 0")


def read(path: PathLike) -> EnmaData:
    """Read measured (or written) ENMA data: CSV with a header row and the columns
    ``amplitude_h`` (ã = ŵ(L/2)/h) and ``frequency_hz``; optional ``damping_ratio``, ``run``,
    ``level_m_s2``, ``shape_1`` … ``shape_5`` (x/L = 1/6 … 5/6). Lines starting with ``#`` and
    blank lines are skipped; other columns are ignored. Empty optional cells are missing values.

    Raises:
        OSError: the file cannot be opened.
        EnmaFormatError (a ``ValueError``): no header, a required column missing, a cell that is
            not a number, NaN/inf or non-positive amplitude/frequency, negative damping, no rows —
            the message names the file, line and column.
    """
    p = os.fspath(path)
    try:
        with open(p, "r", encoding="utf-8") as fh:
            raw = fh.read()
    except UnicodeDecodeError:
        raise EnmaFormatError(f"{p}: not a text file (UTF-8 CSV expected)") from None
    rows = [(i + 1, ln) for i, ln in enumerate(raw.splitlines()) if ln.strip() and not ln.lstrip().startswith("#")]
    if not rows:
        raise EnmaFormatError(f"{p}: empty file (expected a header row with amplitude_h,frequency_hz)")
    header_line, header_text = rows[0]
    header = [h.strip() for h in next(csv.reader([header_text]))]
    missing = [c for c in _REQUIRED if c not in header]
    if missing:
        raise EnmaFormatError(
            f"{p}, line {header_line}: header lacks the column(s) {', '.join(missing)} "
            f"(found: {', '.join(header) or 'nothing'}); required: amplitude_h, frequency_hz")
    dup = sorted({h for h in header if header.count(h) > 1 and h})
    if dup:
        raise EnmaFormatError(f"{p}, line {header_line}: duplicate column(s) {', '.join(dup)}")
    idx = {h: i for i, h in enumerate(header)}
    cols: Dict[str, list] = {c: [] for c in ("amplitude_h", "frequency_hz", "damping_ratio", "level_m_s2", *_SHAPE_COLS)}
    runs, lines = [], []
    for line_no, text in rows[1:]:
        cells = [c.strip() for c in next(csv.reader([text]))]
        if len(cells) != len(header):
            raise EnmaFormatError(f"{p}, line {line_no}: {len(cells)} cells but the header has {len(header)} columns")
        for name, store in cols.items():
            if name not in idx:
                store.append(math.nan)
                continue
            cell = cells[idx[name]]
            if cell == "" and name not in _REQUIRED:
                store.append(math.nan)
                continue
            try:
                store.append(float(cell))
            except ValueError:
                raise EnmaFormatError(f"{p}, line {line_no}, column {name}: {cell!r} is not a number") from None
        runs.append(cells[idx["run"]] if "run" in idx else "1")
        lines.append(line_no)
    data = EnmaData(
        amplitude_h=np.array(cols["amplitude_h"]), frequency_hz=np.array(cols["frequency_hz"]),
        damping_ratio=np.array(cols["damping_ratio"]), run=np.array(runs, dtype=object),
        level_m_s2=np.array(cols["level_m_s2"]),
        shape=np.column_stack([cols[c] for c in _SHAPE_COLS]) if lines else np.zeros((0, 5)),
        source=p)
    _check_values(data, where=p, lines=lines)
    return data


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
    with _progress_bar(progress, n_levels, "virtual ENMA", "pts") as cb:
        text = _core.virtual_enma(p.toml_text(), json.dumps(_finite_options(opts)), cb)
        if cb is not None:
            cb(n_levels, n_levels)
    r = json.loads(text)
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


def concat(parts: Sequence[EnmaData]) -> EnmaData:
    """The points of several data sets in one (e.g. repeated runs)."""
    if not parts:
        raise ValueError("concat needs at least one data set")
    return EnmaData(
        amplitude_h=np.concatenate([p.amplitude_h for p in parts]),
        frequency_hz=np.concatenate([p.frequency_hz for p in parts]),
        damping_ratio=np.concatenate([p.damping_ratio for p in parts]),
        run=np.concatenate([np.asarray(p.run, dtype=object) for p in parts]),
        level_m_s2=np.concatenate([p.level_m_s2 for p in parts]),
        shape=np.concatenate([p.shape for p in parts]),
        source=" + ".join(dict.fromkeys(p.source for p in parts)),
        info=dict(parts[0].info),
    )


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
    """Single-mode backbone ω̃(ã)/2π = √(ω² + ¾ b* ã²)/2π [Hz]."""
    a = np.asarray(amplitude_h, dtype=float)
    return np.sqrt(np.maximum(omega2 + 0.75 * b_star * a * a, 0.0)) / (2 * math.pi)


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
    b = _core.beam_properties(resolve(params).toml_text())
    return b["omega1_preload_rad_s"] ** 2, b["b_star_preload_per_s2"]


def beam_properties(params: Optional[Parameters] = None) -> Dict[str, Any]:
    """Modal data of the linear beam (ω, γ, K₁₁, k_ax, φ₁(L/2), b*, shape of mode 1)."""
    return dict(_core.beam_properties(resolve(params).toml_text()))


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
    return _core.beam_properties(_with(p, k_r_nm_per_rad=k_r).toml_text())["omega1_preload_rad_s"]


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


# --- figure -----------------------------------------------------------------------------------


def plot_enma(data: EnmaData, fit: Optional[BackboneFit] = None, *,
              models: Optional[Dict[str, Parameters]] = None, path: Optional[PathLike] = None):
    """The paper's Fig. 3: (a) frequency vs amplitude (points coloured by amplitude, the fitted
    backbone, the backbones of ``models``), (b) damping vs amplitude, (c) deflection shape with the
    linear mode shapes of ``models``. Returns the figure; saves it when ``path`` is given."""
    from ._mpl import require_matplotlib

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
