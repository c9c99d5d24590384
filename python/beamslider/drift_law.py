"""Layer (b2) of issue 17: the local features of issue §3.2 computed from layer (a) (Λ_g, θ̂/θ_gap,
f_slope, s − s_res, Â/max Â_H, branch) and the transferable drift law fitted on several operating
points' PCS tables (distance-weighted k-nearest neighbours in standardised feature space, per
branch; V = 0 where Λ_g < Λ_c (learnt, 1 by the issue); odd symmetry by construction; leave-one-operating-point-out
validation), with its JSON file. Used by :mod:`beamslider.slowflow`."""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _core
from .params import Parameters, resolve
from .drift_pcs import DriftTable, drift_tables


# ---------------------------------------------------------------------------------------------
# Features of issue 17 §3.2 from layer (a)


_BEAM_CACHE: Dict[tuple, tuple] = {}


def _modes(p: Parameters, n_modes: int, s: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Φ(s) [kg^-½] and Φ'(s) [kg^-½ m^-1] of the first n_modes modes at positions s: linear
    interpolation in a table of the exact mode shapes on 4001 points of [0, 1] (the slope by a
    central difference, step 1e-6 L), computed once per parameter set."""
    import dataclasses

    key = (repr(p), int(n_modes))
    if key not in _BEAM_CACHE:
        q = dataclasses.replace(p, n_modes=int(n_modes))
        g = np.linspace(0.0, 1.0, 4001)
        h = 1e-6
        xs = np.concatenate([g, np.clip(g - h, 0, 1), np.clip(g + h, 0, 1)])
        d = _core.beam_properties(q.toml_text(), [float(v) for v in xs])
        phi = np.asarray(d["phi"], dtype=float)
        n = g.size
        f0, fm, fp = phi[:, :n], phi[:, n:2 * n], phi[:, 2 * n:]
        step = (np.clip(g + h, 0, 1) - np.clip(g - h, 0, 1)) * p.length_m
        if len(_BEAM_CACHE) > 16:
            _BEAM_CACHE.clear()
        _BEAM_CACHE[key] = (g, f0, (fp - fm) / step)
    g, f0, df = _BEAM_CACHE[key]
    phi = np.stack([np.interp(s, g, f0[k]) for k in range(f0.shape[0])], axis=1)
    dphi = np.stack([np.interp(s, g, df[k]) for k in range(df.shape[0])], axis=1)
    return phi, dphi


def features(manifold, branch: str, s: Sequence[float]) -> Dict[str, np.ndarray]:
    """Local features of issue 17 §3.2 on one branch of a layer-(a) manifold at positions s
    (half coordinate, within the branch): Q is interpolated linearly between the branch's
    continuation points.

    Returns a dict of arrays: ``lift_off`` Λ_g = Ω²|ŵ_abs|/g with ŵ_abs = a_ex/Ω² + Φ(s)ᵀQ;
    ``slope_gap`` θ̂/θ_gap with θ̂ = |Φ'(s)ᵀQ|, θ_gap = (R − h)/B; ``slope_mu`` θ̂/μ; ``f_slope``
    = −(Ω²/2g) Re[ŵ_abs conj(Φ'(s)ᵀQ)]; ``a_ex_g`` = a_ex/g; ``amplitude`` Â; ``ds_res`` =
    s − s_res (the first linear-resonance position of layer (a), 0.5 if there is none);
    ``amp_rel`` = Â / max Â of the high branch; ``s`` = s.
    """
    p = manifold.params
    b = manifold.high if branch == "H" else manifold.low
    s = np.atleast_1d(np.asarray(s, dtype=float))
    if len(b) == 0:
        raise ValueError(f"invalid parameter `branch` = {branch!r}: the manifold has no such branch")
    o = np.argsort(b.s)
    bs, bq = b.s[o], b.q[o]
    q = np.stack([np.interp(s, bs, bq[:, k].real) + 1j * np.interp(s, bs, bq[:, k].imag) for k in range(bq.shape[1])], axis=1)
    phi, dphi = _modes(p, bq.shape[1], s)
    omega = 2 * math.pi * manifold.f_ex
    g = p.gravity_m_s2
    w_abs = manifold.a_ex / omega**2 + np.sum(phi * q, axis=1)
    theta = np.sum(dphi * q, axis=1)
    theta_gap = (p.gap_ratio * p.thickness_m - p.thickness_m) / p.contact_spacing_m
    return {
        "lift_off": omega**2 * np.abs(w_abs) / g,
        "slope_gap": np.abs(theta) / theta_gap,
        "slope_mu": np.abs(theta) / p.friction_coefficient,
        "f_slope": -(omega**2 / (2 * g)) * np.real(w_abs * np.conj(theta)),
        "a_ex_g": np.full(s.shape, manifold.a_ex / g),
        "amplitude": np.interp(s, bs, b.amplitude[o]),
        "ds_res": s - (float(manifold.s_res[0]) if len(manifold.s_res) else 0.5),
        "amp_rel": np.interp(s, bs, b.amplitude[o]) / (float(np.max(manifold.high.amplitude)) if len(manifold.high) else 1.0),
        "s": s.copy(),
    }


# The regression inputs (standardised): the relative amplitude Â/max Â_H and the position s.
# Chosen by leave-one-operating-point-out validation on the 12 training tables
# (docs/superslow/validation_b_features.txt, scripts/validate_superslow_b.py features): the
# issue's list (log Λ_g, θ̂/θ_gap, f_slope, a_ex/g, Â) gave a V error of 0.68 × typical |V|,
# (log Λ_g, θ̂/θ_gap, f_slope, s − s_res, Â/max Â_H) 0.52 ×, (Â/max Â_H, s) 0.46 × (k = 4) and
# the most training points predicted right leave one out. Why s: the PCS high branch's stable
# zeros of V (where the FS slider stops) sit at nearly the same s across the map (0.33 from
# 110 to 130 Hz, 0.35–0.38 below), which no amplitude- or slope-only feature locates. Λ_g enters
# through the constraint V = 0 where Λ_g < Λ_c.
FEATURES = ("amp_rel", "s")


def _x(feat: Dict[str, np.ndarray]) -> np.ndarray:
    cols = []
    for name in FEATURES:
        cols.append(np.log(np.maximum(feat["lift_off"], 1e-12)) if name == "log_lift_off" else np.asarray(feat[name], dtype=float))
    return np.stack(cols, axis=1)


@dataclass
class DriftLaw:
    """A fitted transferable drift law (layer (b2)): V = 0 where Λ_g < Λ_c (``lift_c``), otherwise the
    distance-weighted mean of the k nearest training samples of the same branch in standardised
    feature space (odd symmetry: evaluated in the half coordinate)."""

    x: Dict[str, np.ndarray]
    """Training features per branch ('L', 'H'), shape (n, len(FEATURES))."""
    v: Dict[str, np.ndarray]
    """Training V (towards the centre positive) per branch [1/s]."""
    groups: Dict[str, np.ndarray]
    """Operating-point index of each training sample per branch."""
    mean: np.ndarray
    """Feature means (standardisation)."""
    std: np.ndarray
    """Feature standard deviations."""
    lo: np.ndarray
    """Training range of the features (min)."""
    hi: np.ndarray
    """Training range of the features (max)."""
    points: List[Tuple[float, float]]
    """Training operating points (f_ex, a_ex)."""
    k: int = 4
    """Neighbours."""
    loo: Dict[str, float] = field(default_factory=dict)
    """Leave-one-operating-point-out errors: RMS error of V, typical |V| (RMS), their ratio,
    per branch and overall."""
    loo_per_point: List[dict] = field(default_factory=list)
    """Per held-out operating point: RMS error and typical |V|."""
    fit_time_s: float = 0.0
    """Wall time of the fit (including the layer-(a) manifolds of the training points) [s]."""
    rho_c: float = 0.0
    """Forcing ratio at which the PCS high branch ends (s_dn="law", :meth:`s_dn`): the median over
    the training tables with a PCS jump-down of ρ(s_dn) = a_ex / (Ω² Â_H(s_dn) h) (0: none has one)."""
    loo_s_dn: List[dict] = field(default_factory=list)
    """Leave-one-point-out s_dn of the law against the PCS tables' s_dn."""
    jump_down_s: float = 0.0
    """Position s_p at which the PCS high branches end (the bracket rule): the high branch ends
    there if ρ(s_p) ≤ ``rho_c``, else not at all (:func:`s_dn_forcing_ratio`); 0: the first s
    where ρ(s) < ``rho_c`` (the median rule, and law files written before)."""
    rho_bracket: dict = field(default_factory=dict)
    """How ``rho_c`` was learnt (:func:`jump_down_bracket`): the rule ('bracket' or 'median'), the
    position s_p of the PCS jump-downs, and the bracket (lo, hi) of ρ(s_p) between the tables whose
    high branch ends there and those whose high branch passes it."""
    s_up_shift: float = 0.0
    """Learnt correction of the HB jump-up position (the low branch's fold moved by it): the
    median of s_up(PCS) − s_up(HB) over the training tables with both (0: none)."""
    loo_s_up: List[dict] = field(default_factory=list)
    """Per training point: s_up of HB, of the PCS table, and HB + the shift fitted without it."""
    mono_x: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    """Per training point with an HB fold: (ln Â_L at the fold [h], s_up of HB) (the inputs of
    the monostability vote, :meth:`monostable`)."""
    mono_y: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """1 where that point's PCS down sweep shows no jump-up and stays low (below MONO_RISE_H on the
    clamping side of the HB fold: a single, low branch), else 0."""
    mono_std: np.ndarray = field(default_factory=lambda: np.ones(2))
    """Standardisation of ``mono_x``."""
    mono_groups: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    """Training-point index of each monostability sample."""
    lift_c: float = 1.0
    """Lift-off threshold Λ_c: V = 0 where Λ_g < Λ_c. 1 is the issue's constraint (no lift-off
    below it); :func:`fit_drift_law` learns it from the tables (:func:`learn_lift_off_threshold`)."""
    lift_c_per_point: List[dict] = field(default_factory=list)
    """The tables' own Λ_c values (where their clampward drift ends), the median of which is ``lift_c``."""
    v_resolution: float = 0.0
    """Resolution of V [1/s]: the median standard error (four sub-windows) of the training rows'
    V. :func:`beamslider.slowflow.predict` re-runs the slow flow with V shifted by ± this much and
    reports whether the prediction stays the same (``Prediction.robust``); 0: not checked."""
    v_offset: float = 0.0
    """Added to V wherever Λ_g ≥ Λ_c (0; the robustness check's shifted copies, :meth:`shifted`)."""
    _trees: dict = field(default_factory=dict, repr=False, compare=False)

    def monostable(self, manifold, exclude_group: Optional[int] = None) -> bool:
        """Whether the operating point has a single (low) branch in the nonsmooth model although
        single-term HB with the slider rigidly attached has a fold: the label of the nearest
        training point in standardised (ln Â_L(s_up), s_up) of the HB manifold (the low
        branch's amplitude at its fold and the fold's position), the label being "the PCS
        down sweep shows no jump-up and stays low" (``mono_y``). False without an HB fold or
        without samples."""
        x = _mono_x(manifold)
        keep = self.mono_groups != exclude_group if exclude_group is not None else np.ones(self.mono_y.size, bool)
        if x is None or not keep.any():
            return False
        d = np.sum(((self.mono_x[keep] - x) / self.mono_std) ** 2, axis=1)
        return bool(self.mono_y[keep][int(np.argmin(d))] > 0.5)

    def evaluate(self, branch: str, feat: Dict[str, np.ndarray], exclude_group: Optional[int] = None) -> Tuple[np.ndarray, np.ndarray]:
        """V at the given features (half coordinate, towards the centre positive) and a flag per
        point: True where a feature lies outside the training range (extrapolation)."""
        return self._evaluate_x(branch, _x(feat), np.asarray(feat["lift_off"]), exclude_group)

    def shifted(self, dv: float) -> "DriftLaw":
        """A copy whose V is larger by ``dv`` [1/s] wherever Λ_g ≥ Λ_c (the robustness check)."""
        import copy

        c = copy.copy(self)
        c.v_offset = self.v_offset + float(dv)
        return c

    def outside_points(self, f_ex: float, a_ex: float) -> bool:
        """True where (f_ex, a_ex) lies outside the box of the training operating points (the
        law's inputs, Â/max Â_H and s, are bounded everywhere, so the operating point itself is
        the range that a law can be used outside of)."""
        if not self.points:
            return False
        f = [p[0] for p in self.points]
        a = [p[1] for p in self.points]
        return not (min(f) - 1e-9 <= f_ex <= max(f) + 1e-9 and min(a) - 1e-9 <= a_ex <= max(a) + 1e-9)

    def s_dn(self, manifold, rho_c: Optional[float] = None, s_p: Optional[float] = None) -> Optional[float]:
        """Jump-down position learnt from the PCS tables (s_dn="law"; :func:`s_dn_forcing_ratio`
        with the law's ``rho_c`` and ``jump_down_s``, or the ones given)."""
        rc = self.rho_c if rho_c is None else rho_c
        sp = self.jump_down_s if s_p is None else s_p
        return s_dn_forcing_ratio(manifold, rc, sp) if rc > 0 else None

    def _evaluate_x(self, branch, x, lift_off, exclude_group=None):
        from scipy.spatial import cKDTree

        key = (branch, exclude_group)
        if key not in self._trees:
            xt, vt = self.x[branch], self.v[branch]
            if exclude_group is not None:
                keep = self.groups[branch] != exclude_group
                xt, vt = xt[keep], vt[keep]
            self._trees[key] = (cKDTree((xt - self.mean) / self.std) if xt.shape[0] else None, vt)
        tree, vt = self._trees[key]
        out = np.zeros(x.shape[0])
        if tree is None:
            return out, np.ones(x.shape[0], dtype=bool)
        k = min(self.k, vt.size)
        dk, idx = tree.query((x - self.mean) / self.std, k=k)
        dk, idx = dk.reshape(x.shape[0], k), idx.reshape(x.shape[0], k)
        w = 1.0 / np.maximum(dk, 1e-6)
        out = (w * vt[idx]).sum(axis=1) / w.sum(axis=1)
        if self.v_offset:
            out = out + self.v_offset
        out[lift_off < self.lift_c] = 0.0
        outside = np.any((x < self.lo - 1e-9) | (x > self.hi + 1e-9), axis=1)
        return out, outside


def mono_features(manifold, s: Sequence[float], a_cap: float) -> Dict[str, np.ndarray]:
    """Features on the single low branch of a monostable point below the HB fold: those of the
    HB branch that reaches the clamping, with the amplitude capped at ``a_cap`` (the low branch's
    amplitude at the fold) in ``amplitude`` and ``amp_rel``."""
    f = features(manifold, "H", s)
    amp = np.minimum(f["amplitude"], a_cap)
    f["amp_rel"] = amp / float(np.max(manifold.high.amplitude))
    f["amplitude"] = amp
    return f


def _fold_amplitude(manifold) -> float:
    lo = manifold.low
    return float(lo.amplitude[int(np.argmin(lo.s))])


def _mono_x(manifold) -> Optional[np.ndarray]:
    """(ln Â_L at the HB fold, s_up) or None without a fold."""
    lo = manifold.low
    if manifold.s_up is None or len(lo) == 0:
        return None
    return np.array([math.log(max(_fold_amplitude(manifold), 1e-12)), float(manifold.s_up)])


S_DN_MIN = 0.2
"""Smallest s at which :func:`s_dn_forcing_ratio` looks for the end of the high branch."""


def forcing_ratio(manifold, s: Sequence[float]) -> np.ndarray:
    """ρ(s) = a_ex / (Ω² Â_H(s) h) on the HB high branch: the base acceleration over the beam's
    acceleration amplitude at x = 4L/7, the inverse of the dynamic amplification (NaN where the
    branch does not exist). Single-mode HB (issue §2.2) ends the high branch where Â_H(s) reaches
    the damping-limited peak F(s)/(2DωΩ), F = (γ + mφ(s)) a_ex: there ρ is proportional to the
    damping ratio D. The nonsmooth model's high branch ends at a ρ set by its effective damping
    (the slider's impacts), learnt from the PCS tables as ``DriftLaw.rho_c``."""
    s = np.asarray(s, dtype=float)
    amp = manifold.high.amplitude_at(s) if len(manifold.high) else np.full(s.shape, np.nan)
    omega = 2 * math.pi * manifold.f_ex
    with np.errstate(divide="ignore", invalid="ignore"):
        return manifold.a_ex / (omega ** 2 * amp * manifold.params.thickness_m)


def s_dn_forcing_ratio(manifold, rho_c: float, s_p: float = 0.0) -> Optional[float]:
    """Jump-down position from the forcing ratio (issue §2.2's end of the high branch with the
    effective damping of the nonsmooth model): the first s ≥ S_DN_MIN on the HB high branch where
    ρ(s) (:func:`forcing_ratio`) falls below ``rho_c``, linearly interpolated between the branch's
    points; None where it never does (the high branch reaches the centre). With ``s_p`` > 0 (the
    PCS high branches end at one position, :func:`jump_down_bracket`): s_p if ρ(s_p) ≤ ``rho_c``,
    else None (also when the branch does not reach s_p)."""
    hb = manifold.high
    if len(hb) == 0 or not rho_c > 0:
        return None
    s = np.sort(np.asarray(hb.s, dtype=float))
    if s_p > 0:
        if not (s[0] <= s_p <= s[-1]):
            return None
        return float(s_p) if float(forcing_ratio(manifold, [s_p])[0]) <= rho_c else None
    r = forcing_ratio(manifold, s)
    for i in range(1, s.size):
        if s[i] < S_DN_MIN or not (r[i] < rho_c):
            continue
        if s[i - 1] >= S_DN_MIN and r[i - 1] >= rho_c and r[i - 1] != r[i]:
            return float(s[i - 1] + (s[i] - s[i - 1]) * (r[i - 1] - rho_c) / (r[i - 1] - r[i]))
        return float(s[i])
    return None


JD_WINDOW = 0.02
"""A PCS high branch ends *at* s_p (:func:`jump_down_bracket`) when its jump-down lies within this
distance of s_p, and *passes* s_p when it reaches s_p + JD_WINDOW."""


def jump_down_bracket(tables: Sequence[DriftTable], manifolds, monostable: Sequence[bool]) -> dict:
    """The jump-down threshold of the forcing ratio as a classification boundary (issue 17 §2.5,
    s_dn="law"). The PCS high branches end at nearly one position s_p (the median of the tables'
    jump-down positions; 0.32 on the prototype at 120–130 Hz) or not at all, and whether they end
    is ordered by ρ(s_p) = a_ex/(Ω² Â_H(s_p) h) of layer (a). The tables whose high branch ends at
    or before s_p + JD_WINDOW give a lower bound lo = max ρ(s_p); those whose high branch passes
    s_p + JD_WINDOW (monostable points excluded) an upper bound hi = min ρ(s_p). ``rho_c`` is the
    geometric midpoint √(lo·hi) (lo alone, or hi alone, when one side is empty; 0 with no jump-down).

    Returns a dict: rule, s_p, lo, hi, rho_c, consistent (lo < hi), and per table its ρ(s_p) and
    side ('ends', 'passes' or None)."""
    s_dn = [t.s_dn_pcs for t in tables if t.s_dn_pcs is not None]
    out = {"rule": "bracket", "s_p": None, "lo": None, "hi": None, "rho_c": 0.0, "consistent": True, "tables": []}
    if not s_dn:
        return out
    s_p = float(np.median(s_dn))
    out["s_p"] = s_p
    lo, hi = [], []
    for t, mf, mono in zip(tables, manifolds, monostable):
        r = float(forcing_ratio(mf, [s_p])[0]) if len(mf.high) else float("nan")
        s_h = t.branch_rows("H")[0]
        side = None
        if np.isfinite(r) and not mono:
            if t.s_dn_pcs is not None and t.s_dn_pcs <= s_p + JD_WINDOW:
                side = "ends"
                lo.append(r)
            elif s_h.size and float(np.max(s_h)) >= s_p + JD_WINDOW:
                side = "passes"
                hi.append(r)
        out["tables"].append({"f_ex": t.f_ex, "a_ex": t.a_ex, "rho_sp": r if np.isfinite(r) else None, "side": side})
    out["lo"] = max(lo) if lo else None
    out["hi"] = min(hi) if hi else None
    if lo and hi:
        out["rho_c"] = float(math.sqrt(out["lo"] * out["hi"]))
        out["consistent"] = out["lo"] < out["hi"]
    elif lo:
        out["rho_c"] = float(out["lo"])
    return out


MONO_RISE_H = 0.175
"""Amplitude [h] a PCS down sweep must exceed on the clamping side of the HB fold to count as
having left its low branch: the midpoint of the map classifier's low (0.05 h) and high (0.3 h)
levels. A training point is labelled monostable (single low branch) when its down sweep neither
jumps up nor rises beyond it (:func:`fit_drift_law`)."""


def _is_monostable(table: DriftTable, manifold) -> bool:
    """The monostable label of a training table: HB has a fold, yet the PCS down sweep neither
    jumps up nor rises beyond MONO_RISE_H on the clamping side of it."""
    return bool(_mono_x(manifold) is not None and table.s_up_pcs is None and _stays_low(table, float(manifold.s_up)))


def _stays_low(table: DriftTable, s_fold: float) -> bool:
    """The PCS down sweep of ``table`` never exceeds MONO_RISE_H on the clamping side of s_fold."""
    m = table.sweep == "down"
    s = np.where(table.s[m] > 0.5, 1.0 - table.s[m], table.s[m])
    a = table.amplitude[m][s < s_fold]
    return bool(a.size == 0 or np.nanmax(a) < MONO_RISE_H)


def _manifold_for(params, f_ex, a_ex, n_modes, d_eff):
    from .superslow import hb_manifold

    return hb_manifold(params, f_ex=f_ex, a_ex=a_ex, n_modes=n_modes, d_eff=d_eff)


ON_BRANCH_RATIO = 0.5
"""A row of a PCS up sweep (branch 'H') trains the high branch only if its amplitude is at least
this fraction of the HB high branch's at the same s. Rows below it never reached the high
branch (a monostable point's up sweep stays on its single low branch, at a few hundredths of h
where HB has ~1 h), and their V, measured on the low branch, must not be paired with high-branch
features. On the high branch PCS and HB agree within a few per cent (issue §4.1); the rows that
fail lie a factor 5–40 below, so any ratio in 0.25–0.9 selects the same rows."""


def _on_high_branch(table: DriftTable, manifold, s: np.ndarray) -> np.ndarray:
    """Per row of ``table.branch_rows('H')`` (sorted by s, half coordinate): whether the PCS
    amplitude is at least ON_BRANCH_RATIO of the HB high branch's at that s (True outside the
    HB branch's s-range, where the row is dropped anyway)."""
    amp = table.branch_amplitude("H")
    hs, ha = np.asarray(manifold.high.s, dtype=float), np.asarray(manifold.high.amplitude, dtype=float)
    o = np.argsort(hs)
    a_hb = np.interp(s, hs[o], ha[o])
    return ~(amp < ON_BRANCH_RATIO * a_hb)


def move_fold(s, z: float, fold: float, new_fold: float):
    """The linear stretch of a low branch that keeps its upper end z and moves its fold from
    ``fold`` to ``new_fold``: s′ = z − (z − s)(z − new_fold)/(z − fold). The slow model stretches
    the HB low branch onto the shifted fold with it (:func:`beamslider.slowflow.slow_model`, the
    core's ``slow_model``); the training pairs a PCS row with the HB position by its inverse,
    ``move_fold(s, z, s_up_pcs, s_up_hb)``."""
    s = np.asarray(s, dtype=float)
    return z - (z - s) * (z - new_fold) / (z - fold)


def _training_samples(table: DriftTable, manifold) -> Dict[str, Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """Per branch: the law inputs, V, Λ_g and the standard error of V of the table's rows that
    lie on the HB branch (on the high branch also in amplitude, :func:`_on_high_branch`).

    A low-branch row is paired with the HB low branch as the slow flow reads it: the prediction
    stretches the HB low branch so that its fold sits at the (shifted) PCS fold, so a row of a
    table whose down sweep jumps up at s_up(PCS) takes the features of the HB position that the
    stretch onto s_up(PCS) moves to its s (:func:`move_fold`). Without it the rows
    between the PCS fold and the HB fold (where the PCS drift slows down before the jump) would
    be dropped or paired with the wrong amplitude."""
    out = {}
    for br in ("L", "H"):
        s, v, se = table.branch_rows(br)
        b = manifold.high if br == "H" else manifold.low
        if s.size == 0 or len(b) == 0:
            out[br] = (np.zeros((0, len(FEATURES))), np.zeros(0), np.zeros(0), np.zeros(0))
            continue
        lo, hi = float(np.min(b.s)), float(np.max(b.s))
        if br == "L" and manifold.s_up is not None and table.s_up_pcs is not None and table.s_up_pcs < hi:
            keep = s >= table.s_up_pcs
            s, v, se = s[keep], v[keep], se[keep]
            s = move_fold(s, hi, float(table.s_up_pcs), float(manifold.s_up))
        m = (s >= lo) & (s <= hi)
        if br == "H":
            m &= _on_high_branch(table, manifold, s)
        if not m.any():
            out[br] = (np.zeros((0, len(FEATURES))), np.zeros(0), np.zeros(0), np.zeros(0))
            continue
        f = features(manifold, br, s[m])
        out[br] = (_x(f), v[m], np.asarray(f["lift_off"], dtype=float), se[m])
    return out


LIFT_V_EPS = 5e-4
"""|V| [1/s] below which a PCS table row counts as at rest when :func:`learn_lift_off_threshold`
looks for the end of the clampward drift (three times the FS map's steady drift, 0.005 in 30 s)."""


def learn_lift_off_threshold(table: DriftTable, manifold, v_eps: float = LIFT_V_EPS) -> Optional[float]:
    """Λ_c of one PCS table: per branch, walking from the clamping towards the centre over the
    rows below s = 0.3, at least two rows at rest (|V| < ``v_eps``) followed by a row drifting
    towards the clamping (V ≤ −``v_eps``) mark where the self-damping drift ends; Λ_c is the
    lift-off number Λ_g of the HB branch that reaches the clamping (as the slow flow uses it there)
    midway between the two rows. The median over the branches that show it; None if none does
    (the drift reaches the clamping, or no drift towards it)."""
    per = []
    if len(manifold.high) == 0:
        return None
    for br in ("L", "H"):
        s, v, _ = table.branch_rows(br)
        keep = s < 0.3
        s, v = s[keep], v[keep]
        if s.size < 4:
            continue
        o = np.argsort(s)
        s, v = s[o], v[o]
        n = 0
        while n < s.size and abs(v[n]) < v_eps:
            n += 1
        if n < 2 or n >= s.size or not v[n] <= -v_eps:
            continue
        lam = features(manifold, "H", s[[n - 1, n]])["lift_off"]
        if np.all(np.isfinite(lam)):
            per.append(0.5 * float(lam[0] + lam[1]))
    return float(np.median(per)) if per else None


def fit_drift_law(tables: Sequence[DriftTable], *, params: Optional[Parameters] = None, k: int = 4, n_modes: int = 5,
                  s_up_correction: bool = True, monostable_vote: bool = True,
                  lift_off_threshold: Union[str, float] = "learn", jump_down: str = "bracket",
                  jump_down_tables: Sequence[DriftTable] = ()) -> DriftLaw:
    """Fit the transferable drift law (issue 17 §3.2, b2) on PCS drift tables of several operating
    points, and validate it leave one operating point out.

    Each table row (s, branch) is paired with the layer-(a) features at the same s on the same
    branch (rows where the HB branch does not exist are left out). Rows with Λ_g < Λ_c train
    nothing (the law is 0 there by construction).

    ``s_up_correction``: also learn the shift of the jump-up position, s_up(PCS) − s_up(HB)
    (median over the tables where both exist; single-term HB with the slider rigidly attached
    puts the fold too close to the centre, issue §8), applied by :func:`beamslider.slowflow.predict`
    by moving the low branch's fold (``DriftLaw.s_up_shift``).

    ``monostable_vote``: also learn where the nonsmooth model has a single, low branch although
    HB has a fold (the PCS down sweep of a training point neither jumps up nor rises beyond
    MONO_RISE_H on the clamping side of the HB fold: the slider's impacts keep the beam off the
    high branch at low excitation), voted by the nearest training point in
    (ln Â_L(s_up), s_up) of the HB manifold (:meth:`DriftLaw.monostable`); the slow flow then
    follows the low branch through the fold towards the clamping (self-damping).

    The jump-down position (s_dn="law" of :func:`beamslider.slowflow.predict`) is learnt as a
    threshold ``rho_c`` of the forcing ratio (:func:`forcing_ratio`); the high branch then ends
    where ρ(s) falls below it (:func:`s_dn_forcing_ratio`; ``loo_s_dn`` has each table's s_dn with
    ``rho_c`` fitted without it). ``jump_down``: 'bracket' (default): the boundary between the
    tables whose PCS high branch ends at s_p and those whose high branch passes it
    (:func:`jump_down_bracket`; :func:`refine_jump_down` adds tables inside the bracket);
    'median': the median of ρ at the tables' own jump-down positions (the rule before; it lies
    below the boundary by construction, since every table it uses has jumped down).
    ``jump_down_tables``: further tables that only locate this boundary (those
    :func:`refine_jump_down` adds inside the bracket); their V does not enter the law.

    ``lift_off_threshold``: Λ_c of the constraint V = 0 where Λ_g < Λ_c. 'learn' (default): the
    median over the tables of :func:`learn_lift_off_threshold` (where the PCS drift towards the
    clamping ends, in Λ_g of the HB manifold; 1 if no table shows it). Λ_g < 1 means no lift-off
    of a beam point moving with the HB amplitude; the PCS tables stop drifting at Λ_g ≈ 0.75–0.97
    (the slider's impacts lift it where the rigidly attached HB amplitude says they would not),
    and the FS runs stop near Λ_g ≈ 0.6–0.75. A number: that Λ_c (1 = the issue's constraint).
    """
    if len(tables) < 2:
        raise ValueError("invalid parameter `tables`: need at least two operating points")
    if int(k) < 1:
        raise ValueError(f"invalid parameter `k` = {k}: must be >= 1")
    if jump_down not in ("bracket", "median"):
        raise ValueError(f"invalid parameter `jump_down` = {jump_down!r}: 'bracket' or 'median'")
    if isinstance(lift_off_threshold, str):
        if lift_off_threshold != "learn":
            raise ValueError(f"invalid parameter `lift_off_threshold` = {lift_off_threshold!r}: 'learn' or a number in (0, 2]")
    elif not (isinstance(lift_off_threshold, (int, float)) and 0 < float(lift_off_threshold) <= 2):
        raise ValueError(f"invalid parameter `lift_off_threshold` = {lift_off_threshold!r}: 'learn' or a number in (0, 2]")
    t0 = time.perf_counter()
    p = resolve(params)
    xs: Dict[str, list] = {"L": [], "H": []}
    vs: Dict[str, list] = {"L": [], "H": []}
    gs: Dict[str, list] = {"L": [], "H": []}
    ls: Dict[str, list] = {"L": [], "H": []}
    ses: Dict[str, list] = {"L": [], "H": []}
    mfs = []
    rho_per: Dict[int, float] = {}
    mx, my, mg = [], [], []
    mono_flag: List[bool] = []
    lift_per = []
    for gi, t in enumerate(tables):
        mf = _manifold_for(p, t.f_ex, t.a_ex, n_modes, None)
        mfs.append(mf)
        lc = learn_lift_off_threshold(t, mf) if lift_off_threshold == "learn" else None
        if lc is not None:
            lift_per.append({"f_ex": t.f_ex, "a_ex": t.a_ex, "lift_c": lc})
        xm = _mono_x(mf)
        mono_flag.append(monostable_vote and _is_monostable(t, mf))
        if monostable_vote and xm is not None:
            mx.append(xm)
            my.append(1.0 if mono_flag[-1] else 0.0)
            mg.append(gi)
        if t.s_dn_pcs is not None:
            r = forcing_ratio(mf, [t.s_dn_pcs])[0]
            if np.isfinite(r):
                rho_per[gi] = float(r)
        for br, (x, v, lift, se) in _training_samples(t, mf).items():
            xs[br].append(x)
            ls[br].append(lift)
            ses[br].append(se)
            vs[br].append(v)
            gs[br].append(np.full(v.size, gi))
    X = {br: np.concatenate(xs[br]) if xs[br] else np.zeros((0, len(FEATURES))) for br in xs}
    V = {br: np.concatenate(vs[br]) if vs[br] else np.zeros(0) for br in vs}
    G = {br: np.concatenate(gs[br]) if gs[br] else np.zeros(0, int) for br in gs}
    LIFT = {br: np.concatenate(ls[br]) if ls[br] else np.zeros(0) for br in ls}
    SE = {br: np.concatenate(ses[br]) if ses[br] else np.zeros(0) for br in ses}
    allx = np.concatenate([X["L"], X["H"]])
    if allx.shape[0] == 0:
        raise ValueError("invalid parameter `tables`: no row lies on a branch of the HB manifold")
    # Λ_c, then drop the rows below it from the training set (the law is 0 there).
    if lift_off_threshold == "learn":
        lift_c = float(np.median([r["lift_c"] for r in lift_per])) if lift_per else 1.0
    else:
        lift_c = float(lift_off_threshold)
    for br in X:
        keep = LIFT[br] >= lift_c
        X[br], V[br], G[br], LIFT[br], SE[br] = X[br][keep], V[br][keep], G[br][keep], LIFT[br][keep], SE[br][keep]
    se_all = np.concatenate([SE["L"], SE["H"]])
    se_all = se_all[np.isfinite(se_all) & (se_all > 0)]
    v_resolution = float(np.median(se_all)) if se_all.size else 0.0
    allx = np.concatenate([X["L"], X["H"]])
    std = allx.std(axis=0)
    std[std == 0] = 1.0
    jd = list(jump_down_tables)
    if any(not isinstance(t, DriftTable) for t in jd):
        raise ValueError("invalid parameter `jump_down_tables`: DriftTable objects (refine_jump_down)")
    jd_mfs = [_manifold_for(p, t.f_ex, t.a_ex, n_modes, None) for t in jd]
    jd_mono = [monostable_vote and _is_monostable(t, mf) for t, mf in zip(jd, jd_mfs)]

    def rho_rule(keep):
        """rho_c, s_p and the bracket record from the training tables with index in ``keep`` (and
        all ``jump_down_tables``)."""
        if jump_down == "median":
            vals = [v for g, v in rho_per.items() if g in keep]
            return (float(np.median(vals)) if vals else 0.0), 0.0, {"rule": "median", "values": vals}
        br = jump_down_bracket([tables[g] for g in keep] + jd, [mfs[g] for g in keep] + jd_mfs, [mono_flag[g] for g in keep] + jd_mono)
        return br["rho_c"], (br["s_p"] or 0.0), br

    rho_c, s_p, bracket = rho_rule(list(range(len(tables))))
    law = DriftLaw(x=X, v=V, groups=G, mean=allx.mean(axis=0), std=std, lo=allx.min(axis=0), hi=allx.max(axis=0),
                   points=[(t.f_ex, t.a_ex) for t in tables], k=int(k), rho_c=rho_c, jump_down_s=s_p, rho_bracket=bracket,
                   lift_c=lift_c, lift_c_per_point=lift_per, v_resolution=min(v_resolution, 0.0999))
    if mx:
        law.mono_x, law.mono_y, law.mono_groups = np.array(mx), np.array(my), np.array(mg, dtype=int)
        sd = law.mono_x.std(axis=0)
        law.mono_std = np.where(sd > 0, sd, 1.0)
    # The learnt s_up correction (median PCS − HB over the tables with both), leave one out.
    d_up = {gi: t.s_up_pcs - mfs[gi].s_up for gi, t in enumerate(tables) if t.s_up_pcs is not None and mfs[gi].s_up is not None}
    if s_up_correction and d_up:
        law.s_up_shift = float(np.median(list(d_up.values())))
        for gi, t in enumerate(tables):
            others = [v for g, v in d_up.items() if g != gi]
            law.loo_s_up.append({"f_ex": t.f_ex, "a_ex": t.a_ex, "s_up_hb": mfs[gi].s_up, "s_up_pcs": t.s_up_pcs,
                                 "s_up_corrected_loo": None if (mfs[gi].s_up is None or not others) else mfs[gi].s_up + float(np.median(others))})
    for gi, t in enumerate(tables):
        rc, sp, _ = rho_rule([g for g in range(len(tables)) if g != gi])
        law.loo_s_dn.append({"f_ex": t.f_ex, "a_ex": t.a_ex, "s_dn_pcs": t.s_dn_pcs, "rho_pcs": rho_per.get(gi),
                             "rho_c_loo": rc, "s_dn_law": law.s_dn(mfs[gi], rho_c=rc, s_p=sp)})
    # Leave one operating point out.
    err2 = {"L": [], "H": []}
    for gi, t in enumerate(tables):
        row = {"f_ex": t.f_ex, "a_ex": t.a_ex}
        e_all, v_all = [], []
        for br in ("L", "H"):
            m = G[br] == gi
            if not m.any():
                continue
            xb = X[br][m]
            pred, _ = law._evaluate_x(br, xb, LIFT[br][m], exclude_group=gi)
            e = pred - V[br][m]
            err2[br].extend(e.tolist())
            e_all.extend(e.tolist())
            v_all.extend(V[br][m].tolist())
        if e_all:
            row["rms_error"] = float(np.sqrt(np.mean(np.square(e_all))))
            row["typical_v"] = float(np.sqrt(np.mean(np.square(v_all))))
            law.loo_per_point.append(row)
    typ = float(np.sqrt(np.mean(np.square(np.concatenate([V["L"], V["H"]])))))
    for br in ("L", "H"):
        if err2[br]:
            law.loo[f"rms_error_{br}"] = float(np.sqrt(np.mean(np.square(err2[br]))))
            law.loo[f"typical_v_{br}"] = float(np.sqrt(np.mean(np.square(V[br])))) if V[br].size else float("nan")
    allerr = err2["L"] + err2["H"]
    law.loo["rms_error"] = float(np.sqrt(np.mean(np.square(allerr)))) if allerr else float("nan")
    law.loo["typical_v"] = typ
    law.loo["ratio"] = law.loo["rms_error"] / typ if typ > 0 else float("nan")
    law.fit_time_s = time.perf_counter() - t0
    return law


def refine_jump_down(tables: Sequence[DriftTable], *, candidates: Sequence[Tuple[float, float]], n: int = 4,
                     params: Optional[Parameters] = None, n_modes: int = 5, out: Union[str, os.PathLike, None] = None,
                     threads: Optional[int] = None, progress: bool = False, **settings) -> List[DriftTable]:
    """Narrow the jump-down bracket of :func:`jump_down_bracket` by bisection: up to ``n`` times,
    compute the PCS drift table (``settings`` as :func:`drift_table`; ``out`` a folder as
    :func:`drift_tables`, resumable) of the candidate operating point whose layer-(a) ρ(s_p) lies
    inside the bracket (lo, hi) closest to its geometric midpoint, and add it. Only layer (a) and
    the PCS tables choose the points (no FS run). Stops early when no candidate lies inside the
    bracket or the tables show no jump-down. Returns the tables added, in order (pass them to
    :func:`fit_drift_law` as ``jump_down_tables``)."""
    if int(n) < 0:
        raise ValueError(f"invalid parameter `n` = {n}: must be >= 0")
    p = resolve(params)
    tabs = list(tables)
    mfs = [_manifold_for(p, t.f_ex, t.a_ex, n_modes, None) for t in tabs]
    if any(not (isinstance(c, (tuple, list)) and len(c) == 2) for c in candidates):
        raise ValueError("invalid parameter `candidates`: a list of (f_ex, a_ex) pairs")
    cand = [(float(f), float(a)) for f, a in candidates]
    cache: Dict[Tuple[float, float], object] = {}
    for _ in range(int(n)):
        mono = [_is_monostable(t, mf) for t, mf in zip(tabs, mfs)]
        br = jump_down_bracket(tabs, mfs, mono)
        if br["s_p"] is None or br["lo"] is None or br["hi"] is None or not br["consistent"]:
            break
        mid = math.log(br["rho_c"])
        have = {(t.f_ex, t.a_ex) for t in tabs}
        best, best_d = None, math.inf
        for fa in cand:
            if fa in have:
                continue
            if fa not in cache:
                cache[fa] = _manifold_for(p, fa[0], fa[1], n_modes, None)
            mf = cache[fa]
            r = float(forcing_ratio(mf, [br["s_p"]])[0]) if len(mf.high) else float("nan")
            if np.isfinite(r) and br["lo"] < r < br["hi"] and abs(math.log(r) - mid) < best_d:
                best, best_d = fa, abs(math.log(r) - mid)
        if best is None:
            break
        t = drift_tables(p, points=[best], out=out, resume=out is not None, threads=threads, progress=progress, **settings)[0]
        tabs.append(t)
        mfs.append(cache[best])
    return tabs[len(tables):]


def law_json(law: DriftLaw) -> str:
    """The law file's JSON text (what :func:`save_drift_law` writes; read by the core,
    ``beamslider-batch map --predictor``)."""
    d = {
        "kind": "beamslider drift law", "version": 1, "features": list(FEATURES), "k": law.k,
        "x": {b: law.x[b].tolist() for b in law.x}, "v": {b: law.v[b].tolist() for b in law.v},
        "groups": {b: law.groups[b].tolist() for b in law.groups}, "mean": law.mean.tolist(), "std": law.std.tolist(),
        "lo": law.lo.tolist(), "hi": law.hi.tolist(), "points": [list(p) for p in law.points], "loo": law.loo,
        "loo_per_point": law.loo_per_point, "fit_time_s": law.fit_time_s,
        "rho_c": law.rho_c, "jump_down_s": law.jump_down_s, "rho_bracket": law.rho_bracket, "loo_s_dn": law.loo_s_dn,
        "s_up_shift": law.s_up_shift, "loo_s_up": law.loo_s_up,
        "mono_x": law.mono_x.tolist(), "mono_y": law.mono_y.tolist(), "mono_std": law.mono_std.tolist(),
        "mono_groups": law.mono_groups.tolist(), "lift_c": law.lift_c, "lift_c_per_point": law.lift_c_per_point,
        "v_resolution": law.v_resolution,
    }
    return json.dumps(d)


def save_drift_law(law: DriftLaw, path: Union[str, os.PathLike]) -> None:
    """Write a fitted law as JSON (training samples included; read back by :func:`load_drift_law`
    and by the core: ``beamslider-batch map --predictor``)."""
    Path(path).write_text(law_json(law), encoding="utf-8")


# The recipe of the default law (scripts/validate_superslow_b.py; `beamslider fit-law` defaults):
# the four representative points of docs/model.md §8, (106, 10) of the start-position pair, then
# points spread over the map; the table settings; the jump-down bisection over the map's grid.
LAW_TRAINING_POINTS: Tuple[Tuple[float, float], ...] = (
    (124.0, 14.0), (104.0, 14.0), (126.0, 10.0), (124.0, 6.0), (106.0, 10.0), (124.0, 8.0), (116.0, 12.0),
    (110.0, 8.0), (120.0, 6.0), (130.0, 12.0), (114.0, 4.0), (100.0, 10.0))
LAW_TABLE_SETTINGS: Dict[str, float] = {"ds": 0.01, "settle_periods": 100, "window_s": 2.0}
LAW_JUMP_DOWN_N = 4
LAW_JUMP_DOWN_CANDIDATES: Tuple[Tuple[float, float], ...] = tuple(
    (float(f), float(a)) for f in range(100, 131, 2) for a in range(4, 17, 2))

DEFAULT_LAW_PATH = Path(__file__).resolve().parent / "data" / "default_law.json"
"""The package's copy of the default law (docs/superslow/law.json of the repository: 12 PCS training
tables and 4 jump-down tables at the default parameters, scripts/validate_superslow_b.py)."""


def default_drift_law() -> DriftLaw:
    """The built-in default drift law (b2), fitted at the default parameters (the paper's
    prototype): what :func:`beamslider.slowflow.predict` and ``beamslider predict`` use when no
    drift is given. For other parameters, fit a law of their own (:func:`fit_drift_law`)."""
    return load_drift_law(DEFAULT_LAW_PATH)


def load_drift_law(path: Union[str, os.PathLike]) -> DriftLaw:
    """Read a law written by :func:`save_drift_law` (ValueError for a file that is not one)."""
    try:
        d = json.loads(Path(path).read_text(encoding="utf-8"))
    except json.JSONDecodeError as e:
        raise ValueError(f"invalid parameter `law`: {path} is not a beamslider drift law file ({e})") from None
    if not isinstance(d, dict) or d.get("kind") != "beamslider drift law":
        raise ValueError(f"invalid parameter `law`: {path} is not a beamslider drift law file")
    if list(d.get("features", [])) != list(FEATURES):
        raise ValueError(f"invalid parameter `law`: {path} uses the features {d.get('features')}, this version {list(FEATURES)}")
    # The scalars the core checks too (predictor::DriftLaw::from_json_str), with its bounds.
    for key, default, ok, rule in (("rho_c", 0.0, lambda x: x >= 0, ">= 0"), ("jump_down_s", 0.0, lambda x: 0 <= x <= 0.5, "in [0, 0.5]"),
                                   ("lift_c", 1.0, lambda x: 0 < x <= 2, "in (0, 2]"), ("v_resolution", 0.0, lambda x: 0 <= x < 0.1, "in [0, 0.1)")):
        x = d.get(key, default)
        if not (isinstance(x, (int, float)) and math.isfinite(x) and ok(x)):
            raise ValueError(f"invalid parameter `law`: {path} has {key} = {x!r}, must be finite and {rule}")
    arr = lambda v: np.asarray(v, dtype=float)  # noqa: E731
    n = len(FEATURES)
    return DriftLaw(
        x={b: arr(v).reshape(-1, n) for b, v in d["x"].items()}, v={b: arr(v) for b, v in d["v"].items()},
        groups={b: np.asarray(v, dtype=int) for b, v in d["groups"].items()}, mean=arr(d["mean"]), std=arr(d["std"]),
        lo=arr(d["lo"]), hi=arr(d["hi"]), points=[tuple(p) for p in d["points"]], k=int(d["k"]), loo=d.get("loo", {}),
        loo_per_point=d.get("loo_per_point", []), fit_time_s=float(d.get("fit_time_s", 0.0)),
        rho_c=float(d.get("rho_c", 0.0)), jump_down_s=float(d.get("jump_down_s", 0.0)), rho_bracket=d.get("rho_bracket", {}), loo_s_dn=d.get("loo_s_dn", []),
        s_up_shift=float(d.get("s_up_shift", 0.0)), loo_s_up=d.get("loo_s_up", []),
        mono_x=arr(d.get("mono_x", [])).reshape(-1, 2), mono_y=arr(d.get("mono_y", [])),
        mono_std=arr(d.get("mono_std", [1.0, 1.0])), mono_groups=np.asarray(d.get("mono_groups", []), dtype=int),
        lift_c=float(d.get("lift_c", 1.0)), lift_c_per_point=d.get("lift_c_per_point", []),
        v_resolution=float(d.get("v_resolution", 0.0)),
    )


DriftLaw.save = save_drift_law  # type: ignore[attr-defined]
