"""The transferable drift law (docs/model.md §8's super-slow layer): the local features computed from the HB
manifold (Λ_g, θ̂/θ_gap, f_slope, s − s_res, Â/max Â_H, branch), the fitted law (distance-weighted
k-nearest neighbours in standardised feature space, per branch; V = 0 where Λ_g < Λ_c; odd symmetry
by construction), its JSON file and the built-in default law. Fitting: :mod:`beamslider.superslow.fit`."""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _core
from ..params import native


__all__ = ["DEFAULT_LAW_PATH", "DriftLaw", "FEATURES", "LAW_JUMP_DOWN_CANDIDATES",
           "LAW_JUMP_DOWN_N", "LAW_TABLE_SETTINGS", "LAW_TRAINING_POINTS", "S_DN_MIN",
           "default_drift_law", "features", "forcing_ratio", "law_inputs", "law_json", "load_drift_law",
           "monostable_inputs", "move_fold", "s_dn_forcing_ratio", "save_drift_law"]


# ---------------------------------------------------------------------------------------------
# Local features from the HB manifold


def features(manifold, branch: str, s: Sequence[float]) -> Dict[str, np.ndarray]:
    """Local features of docs/model.md §6.3 ("V from features") on one branch of a layer-(a) manifold at
    positions s (half coordinate, within the branch), computed by the core (``law::features``; Q
    interpolated linearly between the branch's continuation points, the exact mode shapes).

    Returns a dict of arrays: ``lift_off`` Λ_g = Ω²|ŵ_abs|/g with ŵ_abs = a_ex/Ω² + Φ(s)ᵀQ;
    ``slope_gap`` θ̂/θ_gap with θ̂ = |Φ'(s)ᵀQ|, θ_gap = (R − h)/B; ``f_slope``
    = −(Ω²/2g) Re[ŵ_abs conj(Φ'(s)ᵀQ)]; ``amplitude`` Â; ``ds_res`` = s − s_res (the first
    linear-resonance position of layer (a), 0.5 if there is none); ``amp_rel`` = Â / max Â of the
    high branch; ``s`` = s; ``grazing`` Â_g, the amplitude along the node's shape Q at which Λ_g = 1
    (the largest; ``inf`` where every amplitude lifts the slider off), which caps the low branch in
    the slow flow (docs/model.md §6.3, "Low branch at grazing"). The core recomputes the manifold from its parameters and settings
    (single-term HB with the manifold's ``n_modes`` and ``d_eff``).
    """
    b = manifold.high if branch == "H" else manifold.low
    if branch not in ("L", "H") or len(b) == 0:
        raise ValueError(f"invalid parameter `branch` = {branch!r}: the manifold has no such branch")
    if manifold.harmonics != 1 or manifold.static_sag or manifold.omega1_factor != 1.0:
        raise ValueError("invalid parameter `manifold`: features are defined on the single-term HB manifold "
                         "(harmonics=1, no static sag, omega1_factor=1)")
    s = np.atleast_1d(np.asarray(s, dtype=float))
    rows = _core.hb_features(native(manifold.params), f_ex_hz=float(manifold.f_ex), a_ex_m_s2=float(manifold.a_ex),
                             high=branch == "H", s=[float(x) for x in s], n_modes=int(manifold.n_modes), d_eff=manifold.d_eff)
    keys = ("lift_off", "slope_gap", "f_slope", "ds_res", "amp_rel", "amplitude_h", "s")
    out = {k: np.array([r[k] for r in rows], dtype=float).reshape(s.shape) for k in keys}
    out["amplitude"] = out.pop("amplitude_h")
    out["grazing"] = np.array([np.inf if r.get("grazing_h") is None else r["grazing_h"] for r in rows], dtype=float).reshape(s.shape)
    return out


# The regression inputs (standardised): the relative amplitude Â/max Â_H and the position s.
# Chosen by leave-one-operating-point-out validation on the 12 training tables
# (docs/results/superslow/validation_b_features.txt, scripts/repro/validate_superslow_b.py features): the
# the first list of features (log Λ_g, θ̂/θ_gap, f_slope, a_ex/g, Â) gave a V error of 0.68 × typical |V|,
# (log Λ_g, θ̂/θ_gap, f_slope, s − s_res, Â/max Â_H) 0.52 ×, (Â/max Â_H, s) 0.46 × (k = 4) and
# the most training points predicted right leave one out. Why s: the PCS high branch's stable
# zeros of V (where the FS slider stops) sit at nearly the same s across the map (0.33 from
# 110 to 130 Hz, 0.35–0.38 below), which no amplitude- or slope-only feature locates. Λ_g enters
# through the constraint V = 0 where Λ_g < Λ_c.
FEATURES = ("amp_rel", "s")


def law_inputs(feat: Dict[str, np.ndarray]) -> np.ndarray:
    """The law's input matrix of a feature dict: one row per position, one column per name of FEATURES."""
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
    """Lift-off threshold Λ_c: V = 0 where Λ_g < Λ_c. 1 is the geometric limit (no lift-off
    below it); :func:`fit_drift_law` learns it from the tables (:func:`learn_lift_off_threshold`)."""
    lift_c_per_point: List[dict] = field(default_factory=list)
    """The tables' own Λ_c values (where their clampward drift ends), the median of which is ``lift_c``."""
    v_resolution: float = 0.0
    """Resolution of V [1/s]: the median standard error (four sub-windows) of the training rows'
    V. :func:`beamslider.superslow.predict` re-runs the slow flow with V shifted by ± this much and
    reports whether the prediction stays the same (``Prediction.robust``); 0: not checked."""
    outside_design: List[str] = field(default_factory=list)
    """Why the design this law was blended for lies outside what its design law covers
    (:meth:`beamslider.superslow.DesignLaw.law_for`); every prediction with it is ``extrapolated``."""
    _cores: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def core(self, exclude_group: Optional[int] = None):
        """The core's handle of this law (``beamslider._core.DriftLaw``: the law file parsed and
        checked once); with ``exclude_group``, of the law without the samples of that training
        point (leave one out: the same standardisation, Λ_c and scalars). Made at the first call
        and kept until a field of the law is assigned."""
        if exclude_group not in self._cores:
            d = law_dict(self, compact=True)
            if exclude_group is not None:
                for b in self.x:
                    keep = self.groups[b] != exclude_group
                    d["x"][b], d["v"][b] = self.x[b][keep].tolist(), self.v[b][keep].tolist()
                keep = self.mono_groups != exclude_group
                d["mono_x"], d["mono_y"] = self.mono_x[keep].tolist(), self.mono_y[keep].tolist()
            self._cores[exclude_group] = _core.DriftLaw(d)
        return self._cores[exclude_group]

    def __setattr__(self, name: str, value) -> None:
        # A changed field makes new handles (the core's copies would be stale).
        if name != "_cores":
            self.__dict__["_cores"] = {}
        object.__setattr__(self, name, value)

    def save(self, path: Union[str, os.PathLike]) -> None:
        """Write the law as JSON (:func:`save_drift_law`)."""
        save_drift_law(self, path)

    def __getstate__(self) -> dict:
        """Pickled without the core's handles (made again where the law is used)."""
        return {**self.__dict__, "_cores": {}}

    def monostable(self, manifold, exclude_group: Optional[int] = None) -> bool:
        """Whether the operating point has a single (low) branch in the nonsmooth model although
        single-term HB with the slider rigidly attached has a fold: the label of the nearest
        training point in standardised (ln Â_L(s_up), s_up) of the HB manifold (the low
        branch's amplitude at its fold and the fold's position), the label being "the PCS
        down sweep shows no jump-up and stays low" (``mono_y``); the core's vote
        (``law::DriftLaw::monostable``). False without an HB fold or without samples."""
        x = monostable_inputs(manifold)
        return x is not None and self.core(exclude_group).monostable([float(x[0]), float(x[1])])

    def evaluate(self, branch: str, feat: Dict[str, np.ndarray]) -> Tuple[np.ndarray, np.ndarray]:
        """V at the given features (half coordinate, towards the centre positive) and a flag per
        point: True where a feature lies outside the training range (extrapolation); evaluated
        by the core (``law::DriftLaw::evaluate``), as the predictor does."""
        return self._evaluate_x(branch, law_inputs(feat), np.asarray(feat["lift_off"], dtype=float).reshape(-1))

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
        """V and the outside flag at law inputs ``x`` (rows of FEATURES) with Λ_g ``lift_off``, by
        the core (``law::DriftLaw::evaluate``); ``exclude_group``: leave that training point out
        (the fit's validation). A branch without samples gives V = 0, outside everywhere."""
        x = np.asarray(x, dtype=float).reshape(-1, len(FEATURES))
        keep = self.groups[branch] != exclude_group if exclude_group is not None else slice(None)
        if self.v[branch][keep].size == 0:
            return np.zeros(x.shape[0]), np.ones(x.shape[0], dtype=bool)
        v, out = self.core(exclude_group).evaluate(high=branch == "H", x=x.tolist(),
                                                   lift_off=np.asarray(lift_off, dtype=float).reshape(-1).tolist())
        return np.asarray(v, dtype=float), np.asarray(out, dtype=bool)


def _fold_amplitude(manifold) -> float:
    lo = manifold.low
    return float(lo.amplitude[int(np.argmin(lo.s))])


def monostable_inputs(manifold) -> Optional[np.ndarray]:
    """(ln Â_L at the HB fold, s_up) or None without a fold."""
    lo = manifold.low
    if manifold.s_up is None or len(lo) == 0:
        return None
    return np.array([math.log(max(_fold_amplitude(manifold), 1e-12)), float(manifold.s_up)])


S_DN_MIN = _core.S_DN_MIN
"""Smallest s at which :func:`s_dn_forcing_ratio` looks for the end of the high branch (the core's)."""


def forcing_ratio(manifold, s: Sequence[float]) -> np.ndarray:
    """ρ(s) = a_ex / (Ω² Â_H(s) h) on the HB high branch: the base acceleration over the beam's
    acceleration amplitude at x = 4L/7, the inverse of the dynamic amplification (NaN where the
    branch does not exist). Single-mode HB (docs/model.md §6.4) ends the high branch where Â_H(s) reaches
    the damping-limited peak F(s)/(2DωΩ), F = (γ + mφ(s)) a_ex: there ρ is proportional to the
    damping ratio D. The nonsmooth model's high branch ends at a ρ set by its effective damping
    (the slider's impacts), learnt from the PCS tables as ``DriftLaw.rho_c``."""
    s = np.asarray(s, dtype=float)
    amp = manifold.high.amplitude_at(s) if len(manifold.high) else np.full(s.shape, np.nan)
    omega = 2 * math.pi * manifold.f_ex
    with np.errstate(divide="ignore", invalid="ignore"):
        return manifold.a_ex / (omega ** 2 * amp * manifold.params.thickness_m)


def s_dn_forcing_ratio(manifold, rho_c: float, s_p: float = 0.0) -> Optional[float]:
    """Jump-down position from the forcing ratio (docs/model.md §6.4 end of the high branch with the
    effective damping of the nonsmooth model; the core's ``predict::law_s_dn``, as the predictor
    uses it): the first s ≥ S_DN_MIN on the HB high branch where
    ρ(s) (:func:`forcing_ratio`) falls below ``rho_c``, linearly interpolated between the branch's
    points; None where it never does (the high branch reaches the centre). With ``s_p`` > 0 (the
    PCS high branches end at one position, :func:`jump_down_bracket`): s_p if ρ(s_p) ≤ ``rho_c``,
    else None (also when the branch does not reach s_p)."""
    hb = manifold.high
    if len(hb) == 0 or not rho_c > 0:
        return None
    return _core.law_s_dn(np.asarray(hb.s, dtype=float).tolist(), np.asarray(hb.amplitude, dtype=float).tolist(),
                          f_ex_hz=float(manifold.f_ex), a_ex_m_s2=float(manifold.a_ex), rho_c=float(rho_c), s_p=float(s_p),
                          thickness_m=float(manifold.params.thickness_m))


def move_fold(s, z: float, fold: float, new_fold: float):
    """The linear stretch of a low branch that keeps its upper end z and moves its fold from
    ``fold`` to ``new_fold``: s′ = z − (z − s)(z − new_fold)/(z − fold). The slow model stretches
    the HB low branch onto the shifted fold with it (:func:`beamslider.superslow.slow_model`, the
    core's ``slow_model``); the training pairs a PCS row with the HB position by its inverse,
    ``move_fold(s, z, s_up_pcs, s_up_hb)``."""
    s = np.asarray(s, dtype=float)
    return z - (z - s) * (z - new_fold) / (z - fold)


def law_dict(law: DriftLaw, *, compact: bool = False) -> dict:
    """The law file's content (:func:`law_json`). ``compact``: only what an evaluation reads (no
    leave-one-out reports, groups or fit time), as stored inside a design law."""
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
    if law.outside_design:
        d["outside_design"] = list(law.outside_design)
    if compact:
        for key in ("groups", "loo", "loo_per_point", "fit_time_s", "rho_bracket", "loo_s_dn", "loo_s_up", "mono_groups",
                    "lift_c_per_point"):
            d.pop(key)
    return d


def law_json(law: DriftLaw) -> str:
    """The law file's JSON text (what :func:`save_drift_law` writes; read by the core,
    ``beamslider-batch map --predictor``)."""
    return json.dumps(law_dict(law))


def save_drift_law(law: DriftLaw, path: Union[str, os.PathLike]) -> None:
    """Write a fitted law as JSON (training samples included; read back by :func:`load_drift_law`
    and by the core: ``beamslider-batch map --predictor``)."""
    Path(path).write_text(law_json(law), encoding="utf-8")


# The recipe of the default law (scripts/repro/validate_superslow_b.py; `beamslider fit-law` defaults):
# the four representative points of docs/model.md §8, (106, 10) of the start-position pair, then
# points spread over the map; the table settings; the jump-down bisection over the map's grid.
LAW_TRAINING_POINTS: Tuple[Tuple[float, float], ...] = (
    (124.0, 14.0), (104.0, 14.0), (126.0, 10.0), (124.0, 6.0), (106.0, 10.0), (124.0, 8.0), (116.0, 12.0),
    (110.0, 8.0), (120.0, 6.0), (130.0, 12.0), (114.0, 4.0), (100.0, 10.0))
LAW_TABLE_SETTINGS: Dict[str, float] = {"ds": 0.01, "settle_periods": 100, "window_s": 2.0}
LAW_JUMP_DOWN_N = 4
LAW_JUMP_DOWN_CANDIDATES: Tuple[Tuple[float, float], ...] = tuple(
    (float(f), float(a)) for f in range(100, 131, 2) for a in range(4, 17, 2))

DEFAULT_LAW_PATH = Path(__file__).resolve().parent.parent / "data" / "default_law.json"
"""The default law (the one copy, python/beamslider/data/default_law.json: 12 PCS training tables and 4
jump-down tables at the default parameters, the recipe of ``beamslider fit-law``'s defaults)."""


def default_drift_law() -> DriftLaw:
    """The built-in default drift law (b2), fitted at the default parameters (the paper's
    prototype): what :func:`beamslider.superslow.predict` and ``beamslider predict`` use when no
    drift is given. For other parameters, fit a law of their own (:func:`fit_drift_law`)."""
    return load_drift_law(DEFAULT_LAW_PATH)


def load_drift_law(path: Union[str, os.PathLike]) -> DriftLaw:
    """Read a law written by :func:`save_drift_law` (ValueError for a file that is not one; a design
    law is read by :func:`beamslider.superslow.load_law`)."""
    try:
        d = json.loads(Path(path).read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as e:
        raise ValueError(f"invalid parameter `law`: {path} is not a beamslider drift law file ({str(e)[:120]})") from None
    return law_from_dict(d, str(path))


LAW_VERSION = 1
"""The newest law-file version this build reads (a newer one is refused, as the core does)."""

LAW_REQUIRED = ("x", "v", "mean", "std", "lo", "hi", "points", "k", "rho_c")
"""Keys every law file must have: what an evaluation reads and has no safe default (the shipped
laws, python/beamslider/data/default_law.json and the compact laws of the design law, have them)."""

LAW_KEYS = frozenset(("kind", "version", "features", "groups", "loo", "loo_per_point", "fit_time_s", "jump_down_s",
                      "rho_bracket", "loo_s_dn", "s_up_shift", "loo_s_up", "mono_x", "mono_y", "mono_std", "mono_groups",
                      "lift_c", "lift_c_per_point", "v_resolution", "outside_design") + LAW_REQUIRED)
"""Every key of a law file (:func:`law_dict`); anything else is refused (a typing error)."""


def _short(x) -> str:
    r = repr(x)
    return r if len(r) <= 40 else r[:37] + "..."


def law_from_dict(d: dict, source: str = "the law", *, check: bool = True) -> DriftLaw:
    """A :class:`DriftLaw` from a law file's content (ValueError naming ``source`` and the key for a
    malformed one). The scalars' bounds, the shapes and the samples are the core's reader's to check
    (``check=False``: checked already, by the core's reader of the design law that holds it)."""
    if not isinstance(d, dict) or d.get("kind") != "beamslider drift law":
        raise ValueError(f"invalid parameter `law`: {source} is not a beamslider drift law file")
    version = d.get("version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise ValueError(f"invalid parameter `law`: {source} has version = {version!r}, expected an integer >= 1")
    if version > LAW_VERSION:
        raise ValueError(f"invalid parameter `law`: {source} has version {version}, newer than this build ({LAW_VERSION})")
    unknown = sorted(set(d) - LAW_KEYS)
    if unknown:
        raise ValueError(f"invalid parameter `law`: {source} has the unknown key `{unknown[0]}` "
                         f"(a law file has {', '.join(sorted(LAW_KEYS))})")
    if d.get("features") != list(FEATURES):
        raise ValueError(f"invalid parameter `law`: {source} uses the features {d.get('features')}, this version {list(FEATURES)}")
    for key in LAW_REQUIRED:
        if key not in d:
            raise ValueError(f"invalid parameter `law`: {source} lacks `{key}`")
    k = d["k"]
    if isinstance(k, bool) or not isinstance(k, int) or k < 1:
        raise ValueError(f"invalid parameter `law`: {source} has k = {k!r}, expected an integer >= 1")
    for key in ("x", "v"):
        if not isinstance(d[key], dict) or not d[key] or not all(b in ("L", "H") for b in d[key]):
            raise ValueError(f"invalid parameter `law`: {source} has {key} = {_short(d[key])}, expected a table of the branches L and H")
    for key in ("x", "v", "groups"):
        if key in d and isinstance(d[key], dict) and not all(isinstance(val, list) for val in d[key].values()):
            raise ValueError(f"invalid parameter `law`: {source}: `{key}` needs a list per branch")
    for key in ("mean", "std", "lo", "hi", "points", "mono_x", "mono_y", "mono_std", "mono_groups", "loo_per_point", "loo_s_dn",
                "loo_s_up", "lift_c_per_point", "outside_design"):
        if key in d and not isinstance(d[key], list):
            raise ValueError(f"invalid parameter `law`: {source} has {key} = {_short(d[key])}, expected a list")
    for key in ("loo", "rho_bracket", "groups"):
        if key in d and not isinstance(d[key], dict):
            raise ValueError(f"invalid parameter `law`: {source} has {key} = {_short(d[key])}, expected a table")
    if not all(isinstance(p, list) and len(p) == 2 for p in d["points"]):
        raise ValueError(f"invalid parameter `law`: {source}: `points` needs [f_ex, a_ex] pairs")
    try:
        if check:
            _core.DriftLaw(d)
    except ValueError as e:
        raise ValueError(f"invalid parameter `law`: {source}: {e}") from None
    arr = lambda v: np.asarray(v, dtype=float)  # noqa: E731
    n = len(FEATURES)
    try:
        x = {b: arr(v).reshape(-1, n) for b, v in d["x"].items()}
        v = {b: arr(v) for b, v in d["v"].items()}
        groups = {b: np.asarray(d.get("groups", {}).get(b, np.zeros(v[b].size)), dtype=int) for b in v}
        law = DriftLaw(
            x=x, v=v, groups=groups, mean=arr(d["mean"]), std=arr(d["std"]),
            lo=arr(d["lo"]), hi=arr(d["hi"]), points=[tuple(p) for p in d["points"]], k=int(d["k"]), loo=d.get("loo", {}),
            loo_per_point=d.get("loo_per_point", []), fit_time_s=float(d.get("fit_time_s", 0.0)),
            rho_c=float(d.get("rho_c", 0.0)), jump_down_s=float(d.get("jump_down_s", 0.0)), rho_bracket=d.get("rho_bracket", {}), loo_s_dn=d.get("loo_s_dn", []),
            s_up_shift=float(d.get("s_up_shift", 0.0)), loo_s_up=d.get("loo_s_up", []),
            mono_x=arr(d.get("mono_x", [])).reshape(-1, 2), mono_y=arr(d.get("mono_y", [])),
            mono_std=arr(d.get("mono_std", [1.0, 1.0])), mono_groups=np.asarray(d.get("mono_groups", [0] * len(d.get("mono_y", []))), dtype=int),
            lift_c=float(d.get("lift_c", 1.0)), lift_c_per_point=d.get("lift_c_per_point", []),
            v_resolution=float(d.get("v_resolution", 0.0)), outside_design=[str(r) for r in d.get("outside_design", [])],
        )
    except (AttributeError, TypeError, ValueError, OverflowError) as e:
        raise ValueError(f"invalid parameter `law`: {source} is malformed ({str(e).splitlines()[0][:120]})") from None
    return law
