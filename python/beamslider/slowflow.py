"""Layer (b) of issue 17: drift law and slow flow on the super-slow manifold.

- :func:`drift_table` — (b1) V(s, branch) measured in the PCS model (issue §3.1): the horizontal
  drift of the slider's centre of mass on each branch, by sequential continuation (down-sweep
  from the centre for L, up-sweep from s_min for H); resumable JSON-lines file.
- :func:`features` — the local features of issue §3.2 computed from layer (a) (Λ_g, θ̂/θ_gap,
  f_slope, a_ex/g, Â, branch).
- :func:`fit_drift_law` — (b2) a transferable drift law fitted on several operating points'
  tables (distance-weighted k-nearest neighbours in standardised feature space, per branch; V = 0
  where Λ_g < Λ_c, learnt from the tables; odd symmetry by construction), with leave-one-operating-point-out validation.
- :func:`predict` — HB manifold (layer (a)) + drift (a table or a fitted law) + slow flow
  (core, exact per-cell integration with event location) + the operating-map classifier.

Closed form / fitted: the manifold, its folds and the feature formulas are closed form (layer
(a)); V is measured (b1) or fitted (b2); s_dn comes from the option ``s_dn`` of :func:`predict`
(single-term HB gives none, issue §8).

The module is split by layer: :mod:`beamslider.drift_pcs` (b1 tables), :mod:`beamslider.drift_law`
(features and the b2 law) and this module (the slow flow, :func:`predict`, :func:`predicted_map`);
every name is importable from here.
"""

from __future__ import annotations

import dataclasses
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
from .simulate import _number
from .drift_law import (FEATURES, DriftLaw, _manifold_for, _modes, features, fit_drift_law, mono_features,  # noqa: F401
                        default_drift_law, law_json, load_drift_law, move_fold, refine_jump_down, save_drift_law)
from .drift_pcs import DriftTable, drift_table, drift_tables, read_drift_table  # noqa: F401

__all__ = [
    "DriftTable",
    "DriftLaw",
    "Prediction",
    "drift_table",
    "drift_tables",
    "read_drift_table",
    "features",
    "fit_drift_law",
    "default_drift_law",
    "refine_jump_down",
    "predict",
    "slow_model",
]


# ---------------------------------------------------------------------------------------------
# Slow flow


@dataclass
class Prediction:
    """Result of :func:`predict` (issue 17 §3.3)."""

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
    (docs/superslow/validation_b_map.txt)."""
    shifted: List[Tuple[str, float]] = field(default_factory=list)
    """(behaviour, final s) under V − v_resolution and V + v_resolution."""


ROBUST_DS = 0.02
"""Largest change of the final s under V ± v_resolution for which a prediction counts as robust
(the issue's tolerance of a run's final s, §4.3; the core's ``predictor::ROBUST_DS``)."""


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
    Python path only (measured in docs/superslow/validation_c_levers.txt; not used by the core).

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
    info = {"extrapolated": isinstance(drift, DriftLaw) and drift.outside_points(manifold.f_ex, manifold.a_ex),
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
    """Predict the behaviour of one operating point with the reduced super-slow model (issue 17).

    Args:
        params: model parameters (``None``: defaults).
        f_ex: excitation frequency [Hz].
        a_ex: base-acceleration amplitude [m/s^2].
        s0: initial slider position, within [B/(2L), 1 − B/(2L)].
        t_end: duration [s].
        drift: a :class:`DriftTable` of this operating point (b1) or a fitted :class:`DriftLaw`
            (b2). A law used outside its training range is reported (``extrapolated``, a warning),
            never silently. ``None`` (default): the built-in default law
            (:func:`default_drift_law`, fitted at the default parameters; with other parameters
            a warning says so).
        s_dn: source of the jump-down position: 'hb' (the HB manifold's own; none with single-term
            HB), 'table' (the PCS sweep of a DriftTable), 'law' (the HB manifold's own, else
            learnt from the PCS tables by a fitted DriftLaw: where the forcing ratio
            a_ex/(Ω²Â_H h) falls below the law's ``rho_c``, :meth:`DriftLaw.s_dn`), 'none';
            'auto' (default): 'law' with a DriftLaw, 'hb' with a DriftTable.
        n_modes: modes of the HB manifold.
        d_eff: equivalent damping ratio of the HB manifold (issue §2.5.1; None: off).
        manifold: a precomputed :func:`beamslider.superslow.hb_manifold` result (skips layer (a)).
        source: 'hb' — branches, Â and s_up from the HB manifold (layer (a)), V from ``drift``;
            'table' — everything from the PCS drift table (b1 only: its rows' Â and V, its sweeps'
            jump positions for s_up and s_dn; no layer (a)).
        build_up: time [s] the beam needs from rest to vibrate on the manifold; Â ramps up
            meanwhile. 'auto': three envelope time constants 3/(D Ω) of the first mode (D = d_eff
            or the parameters' damping ratio; 3.9 s at 124 Hz); 0: start on the manifold.
        build_up_drift: True (default): the slider drifts from t = 0 (PCS and FS runs from rest
            drift at once, docs/superslow/validation_c_build_up.txt) and a jump at a fold waits
            until the build-up is over; False: s stays at s0 during the build-up (the rule before).
        v_dead: dead band of V [1/s] (:func:`dead_band`; default none). Measured, not adopted:
            see docs/superslow/validation_c_levers.txt.
        robustness: with a law that has a ``v_resolution``, also run the slow flow with V shifted
            by ± that much and set ``Prediction.robust`` (two more slow flows; default True).

    Returns:
        :class:`Prediction` with s(t), Â(t), the events, the classifier's behaviour and the
        features.
    """
    p = resolve(params)
    f_ex, a_ex = _number("f_ex", f_ex), _number("a_ex", a_ex)
    s0, t_end = _number("s0", s0), _number("t_end", t_end)
    lo = 0.5 * p.contact_spacing_m / p.length_m
    if not (lo - 1e-12 <= s0 <= 1 - lo + 1e-12):
        raise ValueError(f"invalid parameter `s0` = {s0}: must lie on the beam, {lo:.4f} <= s0 <= {1 - lo:.4f}")
    if not (t_end > 0):
        raise ValueError(f"invalid parameter `t_end` = {t_end}: must be > 0")
    builtin_note = None
    if drift is None:
        drift, builtin_note = builtin_law(p)
    if not isinstance(drift, (DriftTable, DriftLaw)):
        raise ValueError("invalid parameter `drift`: a DriftTable (b1) or a DriftLaw (b2, fit_drift_law)")
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
        t_build = _number("build_up", build_up)
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
        mf = manifold if manifold is not None else _manifold_for(p, f_ex, a_ex, n_modes, d_eff)
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
    if info["extrapolated"]:
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


BUILTIN_LAW_NOTE = ("the built-in drift law was fitted at the default parameters; these differ, so fit a law of "
                    "their own (fit_drift_law) before trusting the prediction")


def builtin_law(p: Parameters) -> Tuple[DriftLaw, Optional[str]]:
    """The built-in law and, when ``p`` are not the defaults it was fitted at, the note that says so."""
    return default_drift_law(), (None if p == Parameters() else BUILTIN_LAW_NOTE)


def _default_law_for(p: Parameters) -> DriftLaw:
    """The built-in law, with a UserWarning when ``p`` are not the defaults it was fitted at."""
    law, note = builtin_law(p)
    if note:
        import warnings

        warnings.warn(note, stacklevel=3)
    return law


def predicted_map(
    params: Optional[Parameters] = None,
    *,
    drift: Optional[DriftLaw] = None,
    f_ex: Sequence[float],
    a_ex: Sequence[float],
    s0: float = 0.3,
    t_end: float = 120.0,
    s_dn: str = "law",
    d_eff: Optional[float] = None,
    n_modes: int = 5,
    out: Union[str, os.PathLike, None] = None,
    force: bool = False,
    resume: bool = False,
    threads: Optional[int] = None,
) -> List[dict]:
    """An operating map by the reduced predictor (issue 17 §4.4) with a fitted law (b2): one row per
    (f_ex, a_ex) in the results format of the FS maps (``map.jsonl`` version 2; ``status`` is
    ``predicted``, counters are zero, no end state; extra keys ``events``, ``extrapolated``,
    ``s_dn_source``).

    ``s_dn='law'`` (the default: the HB manifold's jump-down, else the law's, :meth:`DriftLaw.s_dn`)
    and ``'hb'`` (the HB manifold's own only) are computed by the core (manifold, law, slow flow and classifier
    in Rust, ``threads`` threads, the interpreter released, Ctrl-C stops it) and written by the
    core's map results writer, as ``beamslider-batch map --predictor``: with ``out`` (a folder) the
    rows go to ``out/map.jsonl`` with the predictor in its header; an existing file is refused
    (``FileExistsError``) unless ``force`` (replaced) or ``resume`` (its points are kept; it must
    hold the same law and settings). ``s_dn='none'`` is evaluated in Python (:func:`predict`) and
    cannot be written (``out`` must be None). ``drift=None``: the built-in default law
    (:func:`default_drift_law`; a warning if ``params`` are not the defaults it was fitted at)."""
    from .maps import map_config_toml

    p = resolve(params)
    drift = _default_law_for(p) if drift is None else drift
    if s_dn not in ("hb", "law", "none"):
        raise ValueError(f"invalid parameter `s_dn` = {s_dn!r}: one of 'hb', 'law', 'none'")
    if not isinstance(drift, DriftLaw):
        raise ValueError("invalid parameter `drift`: a fitted DriftLaw (fit_drift_law / load_drift_law)")
    if s_dn == "none":
        if out is not None:
            raise ValueError(f"invalid parameter `out`: a map with s_dn={s_dn!r} is evaluated in Python and not written (the core writes s_dn='law' and 'hb')")
        return _predicted_rows_python(p, drift, f_ex, a_ex, s0, t_end, s_dn, d_eff, n_modes)
    path = None
    if out is not None:
        path = Path(out) / "map.jsonl"
        if path.exists() and not (force or resume):
            raise FileExistsError(f"{path} exists: pass force=True to overwrite or resume=True to continue it")
        if path.exists() and force and not resume:
            path.unlink()
    cfg = map_config_toml(p, f_ex=[float(v) for v in f_ex], a_ex=[float(v) for v in a_ex], s0=float(s0), t_end=float(t_end))
    law = drift if s_dn == "law" else dataclasses.replace(drift, rho_c=0.0, _trees={})
    rows = _core.predicted_map(cfg, law_json(law), out=None if path is None else str(path), resume=bool(resume),
                               threads=threads, n_modes=int(n_modes), d_eff=d_eff)
    return [json.loads(r) for r in rows]


def _predicted_rows_python(p, drift, f_ex, a_ex, s0, t_end, s_dn, d_eff, n_modes) -> List[dict]:
    rows = []
    k = 0
    for a in a_ex:
        for f in f_ex:
            t0 = time.perf_counter()
            r = predict(p, f_ex=float(f), a_ex=float(a), s0=s0, t_end=t_end, drift=drift, s_dn=s_dn, d_eff=d_eff, n_modes=n_modes)
            wall = time.perf_counter() - t0
            c = dict(r.classification)
            row = {"index": k, "f_ex_hz": float(f), "a_ex_m_s2": float(a), "s0": float(s0), "t_end_s": float(t_end),
                   "status": "predicted", **{key: c.get(key) for key in (
                       "behaviour", "reason", "s_final", "amplitude_final_h", "amplitude_initial_h", "amplitude_max_h", "s_min",
                       "s_max", "net_travel", "travel_to_centre", "turn_s", "turn_t_s", "jump_up_t_s", "jump_down_t_s",
                       "steady", "phase")},
                   "counters": {"steps": 0, "contact_steps": 0, "closed_histogram": [0, 0, 0, 0, 0], "solver_iterations": 0,
                                "max_iterations": 0, "cap_hits": 0, "first_guess_hits": 0, "linear_solves": 0,
                                "enumerations": 0, "fallbacks": 0},
                   "wall_time_s": wall, "events": [list(e) for e in r.events], "extrapolated": r.extrapolated,
                   "s_dn_source": r.s_dn_source}
            for key in ("turn_s", "turn_t_s"):
                if row[key] is not None and not math.isfinite(row[key]):
                    row[key] = None
            rows.append(row)
            k += 1
    return rows
