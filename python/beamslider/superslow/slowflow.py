"""The slow flow on the HB manifold and the reduced predictor (docs/model.md §8's super-slow layer):
:func:`slow_model` (the manifold's branches with the drift V(s) of a PCS table or a fitted law),
:func:`predict` (manifold + drift + the core's slow flow, exact per-cell integration with event
location, + the operating-map classifier). Operating maps by the predictor:
:func:`beamslider.maps.predicted_map`."""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple, Union

import numpy as np

from .. import _core
from .._util import number
from ..params import Parameters, resolve
from .design_law import DesignLaw, builtin_law
from .law import DriftLaw, features, mono_features, move_fold
from .manifold import hb_manifold
from .tables import DriftTable

__all__ = ["MONO_NODES", "ROBUST_DS", "Prediction", "dead_band", "predict", "slow_model", "table_model"]


# ---------------------------------------------------------------------------------------------
# Slow flow


@dataclass
class Prediction:
    """Result of :func:`predict` (docs/model.md §6.3, "Slow flow")."""

    t: np.ndarray
    """Times [s] (every 0.2 s)."""
    s: np.ndarray
    """Slider position s(t) [-]."""
    amplitude: np.ndarray
    """Â(t) on the current branch [-] (not smoothed)."""
    branch: np.ndarray
    """'L' / 'H' per sample."""
    events: List[Tuple[str, float, float]]
    """(kind, t [s], s) with kind jump_up, jump_down, equilibrium, wall."""
    behaviour: str
    """The operating-map classifier's decision."""
    classification: dict
    """The classifier's full output (features, reason)."""
    s_final: float
    """s at t_end."""
    amplitude_final: float
    """Â at t_end [-]."""
    s_up: Optional[float]
    """Jump-up position used."""
    s_dn: Optional[float]
    """Jump-down position used (None: the high branch reaches the centre)."""
    s_dn_source: str
    """Where s_dn comes from: 'hb' (single-term HB, possibly with d_eff), 'table' (PCS), 'law' (the
    law's forcing-ratio rule, :meth:`DriftLaw.s_dn`), 'none'."""
    features: Dict[str, Dict[str, np.ndarray]]
    """Per branch: the node positions ``s`` and the features of :func:`features` there."""
    extrapolated: bool
    """Some node used by the flow lies outside the drift law's training range."""
    warnings: List[str]
    """Extrapolation, degenerate cycles, ..."""
    timings_s: Dict[str, float]
    """Wall times: manifold (a), drift evaluation, slow flow, robustness check (two more drift
    evaluations and slow flows) [s]."""
    build_up_s: float = 0.0
    """Build-up time used [s] (s = s0 until then)."""
    monostable: bool = False
    """The law's monostability vote said: a single low branch (no jump-up; :meth:`DriftLaw.monostable`)."""
    f_ex: float = 0.0
    a_ex: float = 0.0
    s0: float = 0.3
    robust: Optional[bool] = None
    """Whether the behaviour and the final s (within ROBUST_DS = 0.02; not for a relaxation
    oscillation, whose final s is the cycle's phase) stay the same when V is
    shifted by ± the law's ``v_resolution`` (the median standard error of its training V)
    wherever the slider can move; None without a law resolution or with ``robustness=False``.
    On the FS map, robust predictions agree far more often than the others
    (docs/results/superslow/validation_b_map.txt)."""
    shifted: List[Tuple[str, float]] = field(default_factory=list)
    """(behaviour, final s) under V − v_resolution and V + v_resolution."""


ROBUST_DS = 0.02
"""Largest change of the final s under V ± v_resolution for which a prediction counts as robust
(the tolerance of a run's final s, docs/model.md §6.3; the core's ``predictor::ROBUST_DS``)."""


def _stretch_low(s: np.ndarray, s_up: Optional[float], shift: float, lo: float) -> np.ndarray:
    """The low branch's nodes with its fold moved from s_up to s_up + shift (the learnt s_up
    correction of the b2 law): s' = z − (z − s)(z − s_up')/(z − s_up), z = the branch's upper end;
    Â and V stay those of the HB node s."""
    if s_up is None or shift == 0.0 or s.size < 2:
        return s
    z = float(s[-1])
    target = max(s_up + shift, lo)
    if not (z > s_up and z > target):
        return s
    return move_fold(s, z, s_up, target)


def dead_band(v: np.ndarray, v_dead: float) -> np.ndarray:
    """V with a dead band: V − clip(V, −v_dead, v_dead) (continuous; |V| ≤ v_dead is no drift).
    A drift slower than the resolution of the PCS tables is read as rest, as the FS map's
    settled rule reads a slider drifting less than 0.005 in 30 s (< 1.7e-4 1/s) as steady."""
    v = np.asarray(v, dtype=float)
    return v - np.clip(v, -v_dead, v_dead) if v_dead > 0 else v


def slow_model(manifold, drift, *, s_dn: str = "auto", nodes: int = 121, v_dead: Optional[float] = None):
    """Nodes of the reduced model: each branch of ``manifold`` sampled at up to ``nodes`` points
    (plus its ends) in the half coordinate, with Â and V there.

    ``drift``: a :class:`DriftTable` (b1: V interpolated linearly in s on the branch's rows,
    held constant beyond them) or a :class:`DriftLaw` (b2). ``s_dn``: 'hb' — the HB manifold's
    own jump-down (None with single-term HB unless d_eff ends the high branch); 'law' — the HB
    manifold's own, else the law's (:meth:`DriftLaw.s_dn`: where the forcing ratio falls below the
    PCS tables' ``rho_c``; b2 only); 'table' — the PCS sweep's jump-down of the drift table (b1
    only); 'none'; 'auto' (default) — 'law' with a DriftLaw, 'hb' with a DriftTable.

    ``v_dead``: dead band of V [1/s] (:func:`dead_band`; None or 0: none). An option of this
    Python path only (measured in docs/results/superslow/validation_c_levers.txt; not used by the core).

    Returns (low, high, low_ends_in_fold, high_ends_in_fold, info dict).
    """
    v_dead = float(v_dead or 0.0)
    if v_dead < 0 or not math.isfinite(v_dead):
        raise ValueError(f"invalid parameter `v_dead` = {v_dead}: must be finite and >= 0")
    if s_dn not in ("auto", "hb", "table", "law", "none"):
        raise ValueError(f"invalid parameter `s_dn` = {s_dn!r}: one of 'auto', 'hb', 'table', 'law', 'none'")
    if s_dn == "auto":
        s_dn = "law" if isinstance(drift, DriftLaw) else "hb"
    lo_all, hi_all = manifold.s_range
    s_up = manifold.s_up
    s_dn_v = manifold.s_dn if s_dn in ("hb", "law") else None
    if s_dn == "table":
        if not isinstance(drift, DriftTable):
            raise ValueError("invalid parameter `s_dn` = 'table': needs a DriftTable as drift")
        s_dn_v = drift.s_jumps()[1]
    if s_dn == "law":
        if not isinstance(drift, DriftLaw):
            raise ValueError("invalid parameter `s_dn` = 'law': needs a DriftLaw as drift")
        if s_dn_v is None:
            s_dn_v = drift.s_dn(manifold)
        else:
            s_dn = "hb"
    info = {"extrapolated": isinstance(drift, DriftLaw) and (bool(drift.outside_design)
                                                             or drift.outside_points(manifold.f_ex, manifold.a_ex)),
            "features": {}, "s_up": s_up, "s_dn": s_dn_v, "s_dn_source": s_dn if s_dn_v is not None else "none"}
    out = {}
    for br in ("L", "H"):
        b = manifold.low if br == "L" else manifold.high
        if len(b) == 0:
            out[br] = ([], [], [])
            continue
        a, z = float(np.min(b.s)), float(np.max(b.s))
        if br == "H" and s_dn_v is not None:
            z = min(z, float(s_dn_v))
        if z <= a:
            out[br] = ([], [], [])
            continue
        s = np.unique(np.concatenate([np.linspace(a, z, nodes), [a, z]]))
        amp = b.amplitude_at(s)
        amp = np.where(np.isnan(amp), np.interp(s, np.sort(b.s), b.amplitude[np.argsort(b.s)]), amp)
        if isinstance(drift, DriftTable):
            ts, tv, _ = drift.branch_rows(br)
            v = np.interp(s, ts, tv) if ts.size else np.zeros_like(s)
            info["features"][br] = {"s": s}
        else:
            f = features(manifold, br, s)
            v, outside = drift.evaluate(br, f)
            if np.any(outside & (f["lift_off"] >= drift.lift_c)):
                info["extrapolated"] = True
            info["features"][br] = {"s": s, **f}
        v = dead_band(v, v_dead)
        out[br] = ([float(x) for x in s], [float(x) for x in amp], [float(x) for x in v])
    shift = float(getattr(drift, "s_up_shift", 0.0) or 0.0) if isinstance(drift, DriftLaw) else 0.0
    if shift and s_up is not None and out["L"][0]:
        s_l = _stretch_low(np.asarray(out["L"][0]), s_up, shift, float(lo_all))
        out["L"] = ([float(x) for x in s_l], out["L"][1], out["L"][2])
        info["s_up"] = float(s_l[0])
        info["s_up_hb"] = s_up
    if isinstance(drift, DriftLaw) and out["L"][0] and drift.monostable(manifold):
        out["L"], out["H"] = _monostable_low(manifold, drift, out["L"], v_dead), ([], [], [])
        info.update(s_up=None, s_dn=None, s_dn_source="none", monostable=True)
        return out["L"], out["H"], False, False, info
    high_fold = s_dn_v is not None and len(out["H"][0]) > 0
    return out["L"], out["H"], s_up is not None, high_fold, info


MONO_NODES = 40


def _monostable_low(manifold, law: DriftLaw, low, v_dead: float = 0.0):
    """The single low branch of a monostable point (:meth:`DriftLaw.monostable`): below the
    (possibly shifted) fold s_up′ the low branch continues along the HB branch that reaches the
    clamping, on MONO_NODES nodes s_min + (s_up′ − s_min)·i/MONO_NODES, with its amplitude capped
    at the low branch's amplitude at the fold (no jump) and V from the law's low-branch samples."""
    su, a_su = low[0][0], low[1][0]
    lo = float(np.min(manifold.high.s)) if len(manifold.high) else su
    if not lo < su:
        return low
    s_new = lo + (su - lo) * np.arange(MONO_NODES) / MONO_NODES
    f = mono_features(manifold, s_new, a_su)
    amp = f["amplitude"]
    v = dead_band(law.evaluate("L", f)[0], v_dead)
    return ([float(x) for x in s_new] + list(low[0]), [float(x) for x in amp] + list(low[1]), [float(x) for x in v] + list(low[2]))


def table_model(table: DriftTable):
    """Nodes of the reduced model from a PCS drift table alone (b1 with the PCS manifold): each
    branch's rows give its nodes, Â (the window amplitude) and V; a branch ends in a fold where its
    native sweep jumped (down sweep: jump up; up sweep: jump down)."""
    out = {}
    for br in ("L", "H"):
        m = table.branch == br
        s = np.where(table.s[m] > 0.5, 1 - table.s[m], table.s[m])
        v = np.where(table.s[m] > 0.5, -table.v[m], table.v[m])
        a = table.amplitude[m]
        o = np.argsort(s)
        out[br] = ([float(x) for x in s[o]], [float(x) for x in a[o]], [float(x) for x in v[o]])
    s_up, s_dn = table.s_jumps()
    return out["L"], out["H"], s_up is not None and len(out["L"][0]) > 0, s_dn is not None and len(out["H"][0]) > 0, s_up, s_dn


def predict(
    params: Optional[Parameters] = None,
    *,
    f_ex: float,
    a_ex: float,
    s0: float = 0.3,
    t_end: float = 120.0,
    drift=None,
    s_dn: str = "auto",
    n_modes: int = 5,
    d_eff: Optional[float] = None,
    manifold=None,
    source: str = "hb",
    build_up: Union[str, float] = "auto",
    build_up_drift: bool = True,
    v_dead: Optional[float] = None,
    robustness: bool = True,
) -> Prediction:
    """Predict the behaviour of one operating point with the reduced super-slow model (docs/model.md §6.3).

    Args:
        params: model parameters (``None``: defaults).
        f_ex: excitation frequency [Hz].
        a_ex: base-acceleration amplitude [m/s^2].
        s0: initial slider position, within [B/(2L), 1 − B/(2L)].
        t_end: duration [s].
        drift: a :class:`DriftTable` of this operating point (b1), a fitted :class:`DriftLaw`
            (b2) or a :class:`DesignLaw` (blended for ``params``, docs/model.md §6.5). A law used
            outside its training range or design box is reported (``extrapolated``, a warning),
            never silently. ``None`` (default): the built-in design law (:func:`default_law`; at
            the prototype the default law itself).
        s_dn: source of the jump-down position: 'hb' (the HB manifold's own; none with single-term
            HB), 'table' (the PCS sweep of a DriftTable), 'law' (the HB manifold's own, else
            learnt from the PCS tables by a fitted DriftLaw: where the forcing ratio
            a_ex/(Ω²Â_H h) falls below the law's ``rho_c``, :meth:`DriftLaw.s_dn`), 'none';
            'auto' (default): 'law' with a DriftLaw, 'hb' with a DriftTable.
        n_modes: modes of the HB manifold.
        d_eff: equivalent damping ratio of the HB manifold (docs/model.md §6.4; None: off).
        manifold: a precomputed :func:`beamslider.superslow.hb_manifold` result (skips layer (a)).
        source: 'hb' — branches, Â and s_up from the HB manifold (layer (a)), V from ``drift``;
            'table' — everything from the PCS drift table (b1 only: its rows' Â and V, its sweeps'
            jump positions for s_up and s_dn; no layer (a)).
        build_up: time [s] the beam needs from rest to vibrate on the manifold; Â ramps up
            meanwhile. 'auto': three envelope time constants 3/(D Ω) of the first mode (D = d_eff
            or the parameters' damping ratio; 3.9 s at 124 Hz); 0: start on the manifold.
        build_up_drift: True (default): the slider drifts from t = 0 (PCS and FS runs from rest
            drift at once, docs/results/superslow/validation_c_build_up.txt) and a jump at a fold waits
            until the build-up is over; False: s stays at s0 during the build-up (the rule before).
        v_dead: dead band of V [1/s] (:func:`dead_band`; default none). Measured, not adopted:
            see docs/results/superslow/validation_c_levers.txt.
        robustness: with a law that has a ``v_resolution``, also run the slow flow with V shifted
            by ± that much and set ``Prediction.robust`` (two more slow flows; default True).

    Returns:
        :class:`Prediction` with s(t), Â(t), the events, the classifier's behaviour and the
        features.
    """
    p = resolve(params)
    f_ex, a_ex = number("f_ex", f_ex), number("a_ex", a_ex)
    s0, t_end = number("s0", s0), number("t_end", t_end)
    lo = 0.5 * p.contact_spacing_m / p.length_m
    if not (lo - 1e-12 <= s0 <= 1 - lo + 1e-12):
        raise ValueError(f"invalid parameter `s0` = {s0}: must lie on the beam, {lo:.4f} <= s0 <= {1 - lo:.4f}")
    if not (t_end > 0):
        raise ValueError(f"invalid parameter `t_end` = {t_end}: must be > 0")
    builtin_note = None
    if drift is None:
        drift, builtin_note = builtin_law(p)
    elif isinstance(drift, DesignLaw):
        drift, builtin_note = drift.law_for(p)
    if not isinstance(drift, (DriftTable, DriftLaw)):
        raise ValueError("invalid parameter `drift`: a DriftTable (b1), a DriftLaw (b2, fit_drift_law) or a DesignLaw")
    if isinstance(drift, DriftTable) and (abs(drift.f_ex - f_ex) > 1e-9 or abs(drift.a_ex - a_ex) > 1e-9):
        raise ValueError(f"invalid parameter `drift`: the table is for ({drift.f_ex:g} Hz, {drift.a_ex:g} m/s²), not ({f_ex:g}, {a_ex:g})")
    if source not in ("hb", "table"):
        raise ValueError(f"invalid parameter `source` = {source!r}: 'hb' or 'table'")
    if isinstance(build_up, str):
        if build_up != "auto":
            raise ValueError(f"invalid parameter `build_up` = {build_up!r}: 'auto' or a time in seconds")
        damping = d_eff if d_eff is not None else p.damping_ratio
        t_build = 3.0 / (damping * 2 * math.pi * f_ex) if damping > 0 else 0.0
    else:
        t_build = number("build_up", build_up)
        if t_build < 0:
            raise ValueError(f"invalid parameter `build_up` = {build_up}: must be >= 0")
    t0 = time.perf_counter()
    if source == "table":
        if not isinstance(drift, DriftTable):
            raise ValueError("invalid parameter `source` = 'table': needs a DriftTable as drift")
        t1 = time.perf_counter()
        low, high, lf, hf, su, sd = table_model(drift)
        if v_dead:
            low = (low[0], low[1], [float(x) for x in dead_band(low[2], v_dead)])
            high = (high[0], high[1], [float(x) for x in dead_band(high[2], v_dead)])
        info = {"extrapolated": False, "features": {}, "s_up": su if lf else None, "s_dn": sd if hf else None,
                "s_dn_source": "table" if hf else "none"}
    else:
        mf = manifold if manifold is not None else hb_manifold(p, f_ex=f_ex, a_ex=a_ex, n_modes=n_modes, d_eff=d_eff)
        t1 = time.perf_counter()
        low, high, lf, hf, info = slow_model(mf, drift, s_dn=s_dn, v_dead=v_dead)
        if (s_dn == "table" and info["s_dn"] is not None and info["s_up"] is not None and info["s_dn"] <= info["s_up"]):
            # The PCS high branch ends below the HB jump-up: the combined model has no
            # coexistence interval (a jump up would land nowhere). Fall back to the table's
            # own branches and jumps (source='table'), and say so.
            low, high, lf, hf, su, sd = table_model(drift)
            note = (f"PCS s_dn = {info['s_dn']:.4f} lies below the HB s_up = {info['s_up']:.4f}: no coexistence in the "
                    "combined model; the PCS table's own branches and jumps are used")
            info = {"extrapolated": False, "features": {}, "s_up": su if lf else None, "s_dn": sd if hf else None,
                    "s_dn_source": "table" if hf else "none", "note": note}
    t2 = time.perf_counter()
    r = _core.slow_flow(tuple(low), tuple(high), low_ends_in_fold=lf, high_ends_in_fold=hf, s0=s0, t_end_s=t_end,
                        build_up_s=float(min(t_build, t_end)), build_up_drift=bool(build_up_drift))
    t3 = time.perf_counter()
    cls = json.loads(r["classification"])
    robust, shifted = None, []
    if robustness and source == "hb" and isinstance(drift, DriftLaw) and drift.v_resolution > 0:
        for dv in (-drift.v_resolution, drift.v_resolution):
            lo2, hi2, lf2, hf2, _ = slow_model(mf, drift.shifted(dv), s_dn=s_dn, v_dead=v_dead)
            r2 = _core.slow_flow(tuple(lo2), tuple(hi2), low_ends_in_fold=lf2, high_ends_in_fold=hf2, s0=s0, t_end_s=t_end,
                                 build_up_s=float(min(t_build, t_end)), build_up_drift=bool(build_up_drift))
            shifted.append((json.loads(r2["classification"])["behaviour"], float(r2["s_final"])))
        # A relaxation oscillation's final s is the cycle's phase at t_end: only its behaviour counts.
        cycle = cls["behaviour"] == "relaxation_oscillation"
        robust = all(b == cls["behaviour"] and (cycle or abs(sf - float(r["s_final"])) <= ROBUST_DS) for b, sf in shifted)
    t4 = time.perf_counter()
    warnings = list(r["warnings"])
    if info.get("note"):
        warnings.insert(0, info["note"])
    if info["extrapolated"] and not (isinstance(drift, DriftLaw) and drift.outside_design):
        pts = ", ".join(f"({f:g}, {a:g})" for f, a in drift.points)
        warnings.insert(0, f"drift law used outside its training range (trained on {pts}): V extrapolated from the nearest samples")
    if builtin_note:
        warnings.insert(0, builtin_note)
    return Prediction(
        t=np.asarray(r["t_s"]), s=np.asarray(r["s"]), amplitude=np.asarray(r["amplitude_h"]),
        branch=np.where(np.asarray(r["branch"]) == 1, "H", "L"), events=[tuple(e) for e in r["events"]],
        behaviour=cls["behaviour"], classification=cls, s_final=float(r["s_final"]),
        amplitude_final=float(r["amplitude_final_h"]), s_up=info["s_up"], s_dn=info["s_dn"], s_dn_source=info["s_dn_source"],
        features=info["features"], extrapolated=bool(info["extrapolated"]), warnings=warnings,
        timings_s={"manifold": t1 - t0, "drift": t2 - t1, "slow_flow": t3 - t2, "robustness": t4 - t3}, build_up_s=float(min(t_build, t_end)), f_ex=f_ex, a_ex=a_ex, s0=s0,
        monostable=bool(info.get("monostable", False)), robust=robust, shifted=shifted,
    )
