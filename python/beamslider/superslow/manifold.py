"""The super-slow manifold by harmonic balance (docs/model.md §8's super-slow layer).

The slider is taken as rigidly attached to the beam at x = sL; a Ritz reduction with N beam
modes and single-term harmonic balance gives the steady vibration amplitude against slider
position in milliseconds (a PCS sweep, :func:`beamslider.super_slow_manifold`, takes a minute):

- :func:`hb_manifold` — N modes, pseudo-arclength continuation in (Re Q, Im Q, s) from
  s_min = B/(2L) up to 0.5 (high branch) and from 0.5 down (low branch), folds, stability;
- :func:`closed_form_n1` — one mode: the closed-form cubic in A = a², its roots, the folds from
  the zeros of its discriminant, the linear resonance position and the high-branch estimate;
- :func:`backbone` — the single-mode backbone with the slider, Ω² M₁(s) = ω₁² + ¾ b a².

Amplitudes are Â = |w(4L/7)| / h (docs/model.md §7's measure; the first harmonic). Options (docs/model.md §6.4,
off by default): ``d_eff`` (equivalent damping), ``harmonics`` = 3, 5, 7 (multi-harmonic HB,
alternating frequency–time method) and ``static_sag`` (zeroth harmonic under the slider's weight).
Known limit (docs/model.md §6.3, "Sources of the jump positions"): with the beam's 0.1 % damping HB gives no jump-down of the high branch
(``s_dn`` is None), with single-term or multi-harmonic HB and with the static sag
(docs/results/superslow/validation_a_options.txt); an equivalent damping ``d_eff`` is the option that can
end it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import List, Optional, Sequence

import numpy as np

from .. import _core
from .._util import number, positive_int
from ..params import Parameters, native, resolve


__all__ = ["ClosedFormN1", "HbBranch", "HbManifold", "backbone", "closed_form_n1", "hb_manifold"]


@dataclass
class HbBranch:
    """Points of one branch (or one continuation run) of the HB manifold."""

    s: np.ndarray
    """Slider position s = x/L [-]."""
    amplitude: np.ndarray
    """Manifold amplitude Â = |Φ(4L/7)ᵀQ| / h [-] (amplitude of w(4L/7) in beam thicknesses)."""
    phase: np.ndarray
    """Phase lag of w(4L/7) behind the inertial forcing a_ex cos Ωt (= −ẅ₀) [rad], in (−π, π]."""
    stable: np.ndarray
    """Stability flag (bool): det ∂R/∂(Re Q, Im Q) > 0."""
    q: np.ndarray
    """Complex modal amplitudes Q, shape (points, n_modes) [m kg^½]; q(t) = Re(Q e^{iΩt})
    (the first harmonic)."""
    harmonic_amplitude: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    """With ``harmonics > 1`` or ``static_sag``: |Φ(4L/7)ᵀQ_k| / h per order of
    :attr:`HbManifold.harmonic_orders`, shape (points, orders) (order 0: the signed static
    deflection / h); empty for single-term HB."""

    def amplitude_at(self, s: Sequence[float]) -> np.ndarray:
        """Â at the given s by linear interpolation between the branch's points; NaN outside the
        branch's s-range."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        if self.s.size == 0:
            return np.full(s.shape, np.nan)
        order = np.argsort(self.s)
        xs, ys = self.s[order], self.amplitude[order]
        out = np.interp(s, xs, ys)
        out[(s < xs[0]) | (s > xs[-1])] = np.nan
        return out

    def __len__(self) -> int:
        return int(self.s.size)


@dataclass
class HbManifold:
    """HB super-slow manifold at one excitation (docs/model.md §6.4)."""

    high: HbBranch
    """High branch: from s_min (near the clamping) up to s_dn or 0.5."""
    low: HbBranch
    """Low branch: from 0.5 (the centre) down to s_up or s_min."""
    middle: HbBranch
    """Unstable branch between the folds (empty without coexistence)."""
    up_run: HbBranch
    """Whole continuation run from s_min upwards (all folds included)."""
    down_run: HbBranch
    """Whole continuation run from 0.5 downwards."""
    folds_s: np.ndarray
    """Fold (turning point) positions [-], ascending."""
    folds_amplitude: np.ndarray
    """Â at the folds [-]."""
    s_up: Optional[float]
    """Jump-up position: where the low branch ends (None if it reaches s_min)."""
    s_dn: Optional[float]
    """Jump-down position: where the high branch ends (None if it reaches 0.5)."""
    s_res: np.ndarray
    """Linear resonance positions: lowest frequency of (Λ, M(s)) equals Ω [-]."""
    s_range: tuple
    """Range of the continuation (s_min, s_max) [-]."""
    n_modes: int
    """Retained beam modes N."""
    harmonics: int
    """Harmonics of the ansatz (1)."""
    d_eff: Optional[float]
    """Equivalent damping ratio used for all modes (None: the parameters' damping_ratio)."""
    f_ex: float
    """Excitation frequency [Hz]."""
    a_ex: float
    """Base-acceleration amplitude [m/s^2]."""
    steps: int
    """Continuation steps taken."""
    warnings: List[str] = field(default_factory=list)
    """Non-fatal problems (e.g. a step cap reached)."""
    params: Parameters = field(default_factory=Parameters)
    """Parameters used."""
    omega1_factor: float = 1.0
    """Factor applied to ω₁ (sensitivity studies)."""
    s_grid: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """The grid s (with ``sample=True``) [-]."""
    high_on_grid: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """Â of the high branch solved exactly at each grid s (NaN where it does not exist)."""
    low_on_grid: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """Â of the low branch solved exactly at each grid s (NaN where it does not exist)."""
    static_sag: bool = False
    """Static sag under the slider's weight included (zeroth harmonic, docs/model.md §6.4)."""
    harmonic_orders: tuple = ()
    """Harmonic orders k of the ansatz, in the column order of ``HbBranch.harmonic_amplitude``
    (empty for single-term HB)."""

    def backbone(self, amplitude: Sequence[float], s: Sequence[float]) -> np.ndarray:
        """Single-mode backbone with the slider Ω_bb(Â, s) [rad/s] (see :func:`backbone`)."""
        return backbone(self.params, amplitude=amplitude, s=s, omega1_factor=self.omega1_factor)


@dataclass
class ClosedFormN1:
    """The N = 1 closed form of docs/model.md §6.4 on an s-grid."""

    s: np.ndarray
    """Slider positions [-]."""
    roots: np.ndarray
    """Â of the real roots of the cubic, shape (len(s), 3), ascending (low, middle, high); NaN
    where absent (with one root, column 0 holds it)."""
    n_roots: np.ndarray
    """Number of real roots (1 or 3)."""
    discriminant: np.ndarray
    """Discriminant Δ of the (scaled) cubic: > 0 where three roots coexist."""
    folds: np.ndarray
    """Zeros of Δ(s) (bracketed on the grid, refined by Brent's method) [-]."""
    s_up: Optional[float]
    """First fold: the jump-up position."""
    s_dn: Optional[float]
    """Second fold: the jump-down position (None if the high branch reaches the grid's end)."""
    s_res: np.ndarray
    """Linear resonance positions, M₁(s_res) = ω₁²/Ω² [-]."""
    backbone: np.ndarray
    """High-branch estimate √(4(M₁Ω² − ω₁²)/(3b)) as Â (NaN where M₁Ω² ≤ ω₁²)."""


def _f(values: Sequence[float]) -> np.ndarray:
    return np.asarray(values, dtype=float)


def _branch(d, n_modes: int, n_orders: int = 0) -> HbBranch:
    q = (np.asarray(d["q_re"]) + 1j * np.asarray(d["q_im"])).reshape(-1, n_modes)
    harm = np.asarray(d["harmonic_amplitude_h"], dtype=float).reshape(-1, n_orders) if n_orders else np.zeros((0, 0))
    return HbBranch(s=_f(d["s"]), amplitude=_f(d["amplitude_h"]), phase=_f(d["phase_rad"]), stable=np.asarray(d["stable"], dtype=bool), q=q,
                    harmonic_amplitude=harm)


def _grid(s: Optional[Sequence[float]]) -> Optional[List[float]]:
    if s is None:
        return None
    g = np.atleast_1d(np.asarray(s, dtype=float))
    if g.ndim != 1:
        raise ValueError("invalid parameter `s`: need a 1-D sequence of slider positions")
    return [float(v) for v in g]


def hb_manifold(
    params: Optional[Parameters] = None,
    *,
    f_ex: float,
    a_ex: float,
    n_modes: int = 5,
    harmonics: int = 1,
    d_eff: Optional[float] = None,
    s: Optional[Sequence[float]] = None,
    omega1_factor: float = 1.0,
    max_steps: int = 20_000,
    sample: bool = False,
    static_sag: bool = False,
) -> HbManifold:
    """Super-slow manifold by N-mode harmonic balance (docs/model.md §6.4, with its options).

    Args:
        params: model parameters (``None``: defaults). Its ``n_modes`` is replaced by ``n_modes``;
            ``axial_preload_n`` and ``damping_ratio_quadratic`` are included.
        f_ex: excitation frequency [Hz].
        a_ex: base-acceleration amplitude [m/s^2].
        n_modes: retained beam modes N (1..20).
        harmonics: H, the ansatz keeps the odd harmonics 1, 3, …, H (1, 3, 5 or 7; default 1 =
            single-term HB; docs/model.md §6.4). H > 1 is solved by the alternating frequency–time
            method (exact for the cubic terms) with the same continuation; ``amplitude`` stays
            the first-harmonic Â, the others are in ``HbBranch.harmonic_amplitude``.
        d_eff: equivalent damping ratio replacing the modal damping of all modes [-] (docs/model.md §6.4);
            ``None`` keeps ``params.damping_ratio``.
        s: increasing slider positions within [B/(2L), 0.5]; the continuation covers
            [s[0], s[-1]] (default B/(2L) .. 0.5). Branches are returned at the continuation's
            own points; use :meth:`HbBranch.amplitude_at` to sample them.
        omega1_factor: factor on ω₁ (detuning for sensitivity studies, docs/model.md §6.4).
        max_steps: cap of continuation steps per run.
        sample: also solve the high and low branches exactly at every grid s
            (``high_on_grid``, ``low_on_grid``; costs about 10 µs per point and branch).
        static_sag: include the static sag under the slider's weight m·g at x = sL (a zeroth
            harmonic Q₀; with it all harmonics 0..H are kept; docs/model.md §6.4). Off by default.

    Returns:
        :class:`HbManifold` with the branches (s, Â, phase, stable, Q), folds, ``s_up``,
        ``s_dn``, ``s_res``.
    """
    p = resolve(params)
    f_ex, a_ex = number("f_ex", f_ex), number("a_ex", a_ex)
    n_modes = positive_int("n_modes", n_modes)
    harmonics = positive_int("harmonics", harmonics)
    if harmonics not in (1, 3, 5, 7):
        raise ValueError(f"invalid parameter `harmonics`: {harmonics} (must be 1, 3, 5 or 7: the odd harmonics up to H)")
    if not isinstance(static_sag, (bool, np.bool_)):
        raise ValueError(f"invalid parameter `static_sag`: {static_sag!r} (must be True or False)")
    max_steps = positive_int("max_steps", max_steps)
    d = None if d_eff is None else number("d_eff", d_eff)
    out = _core.hb_manifold(
        native(p),
        f_ex_hz=f_ex,
        a_ex_m_s2=a_ex,
        n_modes=n_modes,
        harmonics=harmonics,
        d_eff=d,
        omega1_factor=number("omega1_factor", omega1_factor),
        s_values=_grid(s),
        max_steps=max_steps,
        sample_on_grid=bool(sample),
        static_sag=bool(static_sag),
    )
    n = int(out["n_modes"])
    orders = tuple(int(k) for k in out["harmonic_orders"])
    k = len(orders)
    return HbManifold(
        high=_branch(out["high"], n, k),
        low=_branch(out["low"], n, k),
        middle=_branch(out["middle"], n, k),
        up_run=_branch(out["up_run"], n, k),
        down_run=_branch(out["down_run"], n, k),
        folds_s=_f([f["s"] for f in out["folds"]]),
        folds_amplitude=_f([f["amplitude_h"] for f in out["folds"]]),
        s_up=out["s_up"],
        s_dn=out["s_dn"],
        s_res=_f(out["s_res"]),
        s_range=tuple(out["s_range"]),
        n_modes=n,
        harmonics=harmonics,
        d_eff=d,
        f_ex=f_ex,
        a_ex=a_ex,
        steps=int(out["steps"]),
        warnings=list(out["warnings"]),
        params=p,
        omega1_factor=float(omega1_factor),
        s_grid=_f(out["s_grid"]),
        high_on_grid=_f(out["high_on_grid"]),
        low_on_grid=_f(out["low_on_grid"]),
        static_sag=bool(static_sag),
        harmonic_orders=orders,
    )


def closed_form_n1(
    params: Optional[Parameters] = None,
    *,
    f_ex: float,
    a_ex: float,
    s: Optional[Sequence[float]] = None,
    d_eff: Optional[float] = None,
    omega1_factor: float = 1.0,
) -> ClosedFormN1:
    """Single-mode, single-harmonic closed form (docs/model.md §6.4) on an s-grid.

    Args:
        params: model parameters (``None``: defaults); needs ``damping_ratio_quadratic = 0``.
        f_ex: excitation frequency [Hz].
        a_ex: base-acceleration amplitude [m/s^2].
        s: increasing slider positions within [B/(2L), 1 − B/(2L)] (default: 201 values from
            B/(2L) to 0.5).
        d_eff: equivalent damping ratio of mode 1 [-] (``None``: ``params.damping_ratio``).
        omega1_factor: factor on ω₁.
    """
    p = resolve(params)
    f_ex, a_ex = number("f_ex", f_ex), number("a_ex", a_ex)
    grid = _grid(s)
    if grid is None:
        lo = 0.5 * p.contact_spacing_m / p.length_m
        grid = [float(v) for v in np.linspace(lo, 0.5, 201)]
    out = _core.hb_closed_form_n1(
        native(p),
        f_ex_hz=f_ex,
        a_ex_m_s2=a_ex,
        s_values=grid,
        d_eff=None if d_eff is None else number("d_eff", d_eff),
        omega1_factor=number("omega1_factor", omega1_factor),
    )
    return ClosedFormN1(
        s=_f(out["s"]),
        roots=_f(out["roots_h"]).reshape(-1, 3),
        n_roots=np.asarray(out["n_roots"], dtype=np.uint64),
        discriminant=_f(out["discriminant"]),
        folds=_f(out["folds"]),
        s_up=out["s_up"],
        s_dn=out["s_dn"],
        s_res=_f(out["s_res"]),
        backbone=_f(out["backbone_h"]),
    )


def backbone(
    params: Optional[Parameters] = None,
    *,
    amplitude: Sequence[float],
    s: Sequence[float],
    omega1_factor: float = 1.0,
) -> np.ndarray:
    """Single-mode backbone with the slider attached (docs/model.md §6.4):
    Ω_bb = √((ω₁² + H₀K₁₁ + ¾ b a²) / M₁(s)) [rad/s], a = Â h / |φ₁(4L/7)|.

    Args:
        params: model parameters (``None``: defaults).
        amplitude: Â = |w(4L/7)| / h [-] (broadcast against ``s``).
        s: slider positions [-].
        omega1_factor: factor on ω₁.
    """
    a, x = np.broadcast_arrays(np.asarray(amplitude, dtype=float), np.asarray(s, dtype=float))
    out = _core.hb_backbone(native(resolve(params)), [float(v) for v in a.ravel()], [float(v) for v in x.ravel()],
                            number("omega1_factor", omega1_factor))
    return np.asarray(out).reshape(a.shape)

