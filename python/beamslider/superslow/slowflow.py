"""The reduced predictor of one operating point (docs/model.md §6.3): :func:`predict` wraps the core's
(the HB manifold, the drift from a fitted law or a PCS table, the slow flow with exact per-cell
integration and event location, the operating-map classifier; ``beamslider._core.predict``).
Operating maps by the predictor: :func:`beamslider.superslow.predicted_map`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _core
from .._util import number
from ..params import Parameters, native, resolve
from .design_law import DesignLaw, builtin_law
from .law import DriftLaw
from .tables import DriftTable

__all__ = ["MONO_NODES", "ROBUST_DS", "Prediction", "predict", "table_model"]


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
    """Per branch ('L', 'H'; HB source): the core's features at the nodes (``s``, ``lift_off``,
    ``slope_gap``, ``f_slope``, ``ds_res``, ``amp_rel``, ``amplitude``; :func:`features`)."""
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
(the tolerance of a run's final s, docs/model.md §6.3; the core's ``predict::ROBUST_DS``)."""

MONO_NODES = 40
"""Nodes of a monostable point's single low branch below its fold (the core's ``law::MONO_NODES``)."""


def table_model(table: DriftTable):
    """A PCS drift table's rows as the core reads them (b1): per branch (s′, Â, V) in the half
    coordinate sorted by s′ (Â the window amplitude, V towards the centre positive), whether each
    branch ends in a fold (its native sweep jumped: down sweep jump up, up sweep jump down), and
    the sweeps' jump positions (s_up, s_dn)."""
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


def _outside_range(law: DriftLaw, features: Sequence[Sequence[Dict[str, float]]], f_ex: float, a_ex: float) -> str:
    """Which value lies outside the law's training range: the operating point against the box of
    its training points, else the law's inputs (``FEATURES``) at the nodes that can move, the
    farthest out per input and branch (as the core's ``DriftLaw::evaluate`` judges them)."""
    from .law import FEATURES

    out = []
    for name, v, unit, axis in (("f_ex", f_ex, " Hz", 0), ("a_ex", a_ex, " m/s²", 1)):
        lo, hi = min(p[axis] for p in law.points), max(p[axis] for p in law.points)
        if not lo - 1e-9 <= v <= hi + 1e-9:
            out.append(f"{name} = {v:g}{unit}, trained from {lo:g} to {hi:g}{unit}")
    for branch, nodes in zip(("low", "high"), features):
        for i, name in enumerate(FEATURES):
            lo, hi = float(law.lo[i]), float(law.hi[i])
            off = [n[name] for n in nodes if n.get("lift_off", 0.0) >= law.lift_c and not lo - 1e-9 <= n[name] <= hi + 1e-9]
            if off:
                v = max(off, key=lambda x: max(lo - x, x - hi))
                out.append(f"{name} = {v:.3g} on the {branch} branch, trained from {lo:.3g} to {hi:.3g}")
    return "; ".join(out) or "a node's inputs"


NUMERICAL_FIELDS = ("dt_s", "contact_solver", "solver_tol_rel", "solver_tol_abs", "solver_max_iter")
"""Fields that set how a run is computed, not the model: a drift table made with other values of
these still describes the run's model."""


def _same_model(table: DriftTable, p: Parameters) -> None:
    """Refuse a drift table measured on another model than the run's (its header records the
    parameters it was made with; a table made in memory without them is not checked)."""
    if not table.params_toml:
        return
    made = _core.Params.from_toml_text(table.params_toml).to_dict()
    run = p.to_dict()
    for name, value in made.items():
        if name not in NUMERICAL_FIELDS and run[name] != value:
            raise ValueError(f"invalid parameter `drift`: the table was made with {name} = {value!r}, the run has "
                             f"{run[name]!r}: make a table with the run's parameters (drift-table --params)")


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
    source: str = "hb",
    build_up: Union[str, float] = "auto",
    build_up_drift: bool = True,
    v_dead: Optional[float] = None,
    robustness: bool = True,
) -> Prediction:
    """Predict the behaviour of one operating point with the reduced super-slow model (docs/model.md §6.3),
    computed by the core.

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
            'auto' (default): 'law' with a DriftLaw, 'hb' with a DriftTable. With 'table', a PCS
            jump-down below the HB jump-up (no coexistence in the combined model) falls back to the
            table's own branches and jumps, and a warning says so.
        n_modes: modes of the HB manifold.
        d_eff: equivalent damping ratio of the HB manifold (docs/model.md §6.4; None: off).
        source: 'hb' — branches, Â and s_up from the HB manifold (layer (a)), V from ``drift``;
            'table' — everything from the PCS drift table (b1 only: its rows' Â and V, its sweeps'
            jump positions for s_up and s_dn; no layer (a)).
        build_up: time [s] the beam needs from rest to vibrate on the manifold; Â ramps up
            meanwhile. 'auto': three envelope time constants 3/(D Ω) of the first mode (D = d_eff
            or the parameters' damping ratio; 3.9 s at 124 Hz); 0: start on the manifold.
        build_up_drift: True (default): the slider drifts from t = 0 (PCS and FS runs from rest
            drift at once, docs/results/superslow/validation_c_build_up.txt) and a jump at a fold waits
            until the build-up is over; False: s stays at s0 during the build-up (the rule before).
        v_dead: dead band of V [1/s]: V − clip(V, −v_dead, v_dead), so |V| ≤ v_dead is rest
            (default none). Measured, not adopted: see docs/results/superslow/validation_c_levers.txt.
        robustness: with a law that has a ``v_resolution``, also run the slow flow with V shifted
            by ± that much and set ``Prediction.robust`` (two more slow flows; default True).

    Returns:
        :class:`Prediction` with s(t), Â(t), the events, the classifier's behaviour and the
        features.
    """
    p = resolve(params)
    f_ex, a_ex = number("f_ex", f_ex), number("a_ex", a_ex)
    s0, t_end = number("s0", s0), number("t_end", t_end)
    builtin_note = None
    if drift is None:
        drift, builtin_note = builtin_law(p)
    elif isinstance(drift, DesignLaw):
        drift, builtin_note = drift.law_for(p)
    if not isinstance(drift, (DriftTable, DriftLaw)):
        raise ValueError("invalid parameter `drift`: a DriftTable (b1), a DriftLaw (b2, fit_drift_law) or a DesignLaw")
    if isinstance(drift, DriftTable) and (abs(drift.f_ex - f_ex) > 1e-9 or abs(drift.a_ex - a_ex) > 1e-9):
        raise ValueError(f"invalid parameter `drift`: the table is for ({drift.f_ex:g} Hz, {drift.a_ex:g} m/s²), not ({f_ex:g}, {a_ex:g})")
    if isinstance(drift, DriftTable):
        _same_model(drift, p)
    if s_dn == "auto":
        s_dn = "law" if isinstance(drift, DriftLaw) else "hb"
    if isinstance(build_up, str):
        if build_up != "auto":
            raise ValueError(f"invalid parameter `build_up` = {build_up!r}: 'auto' or a time in seconds")
        t_build = None
    else:
        t_build = number("build_up", build_up)
    v_dead = float(v_dead or 0.0)
    if isinstance(drift, DriftLaw):
        kw = {"law": drift.core()}
    else:
        low, high, _, _, su, sd = table_model(drift)
        kw = {"table": (low, high, su, sd)}
    r = _core.predict(native(p), f_ex_hz=f_ex, a_ex_m_s2=a_ex, s0=s0, t_end_s=t_end, s_dn=str(s_dn), source=str(source),
                      n_modes=int(n_modes), d_eff=d_eff, v_dead=v_dead, build_up_s=t_build,
                      build_up_drift=bool(build_up_drift), robustness=bool(robustness), **kw)
    flow, cls = r["flow"], r["flow"]["classification"]
    warnings = list(flow["warnings"])
    if r["note"]:
        warnings.insert(0, r["note"])
    if r["extrapolated"] and isinstance(drift, DriftLaw) and not drift.outside_design:
        pts = ", ".join(f"({f:g}, {a:g})" for f, a in drift.points)
        warnings.insert(0, f"drift law used outside its training range ({_outside_range(drift, r['features'], f_ex, a_ex)}; "
                           f"trained on {pts}): V extrapolated from the nearest samples")
    if builtin_note:
        warnings.insert(0, builtin_note)
    feats = {}
    for br, fs in zip(("L", "H"), r["features"]):
        if fs:
            feats[br] = {k: np.array([f[k] for f in fs], dtype=float) for k in fs[0]}
            feats[br]["amplitude"] = feats[br].pop("amplitude_h")
    t = r["timings_s"]
    return Prediction(
        t=np.asarray(flow["t_s"]), s=np.asarray(flow["s"]), amplitude=np.asarray(flow["amplitude_h"]),
        branch=np.asarray(flow["branch"]), events=[(e["kind"], e["t_s"], e["s"]) for e in flow["events"]],
        behaviour=cls["behaviour"], classification=cls, s_final=float(flow["s_final"]),
        amplitude_final=float(flow["amplitude_final_h"]), s_up=r["s_up"], s_dn=r["s_dn"], s_dn_source=r["s_dn_source"],
        features=feats, extrapolated=bool(r["extrapolated"]), warnings=warnings,
        timings_s={"manifold": t[0], "drift": t[1], "slow_flow": t[2], "robustness": t[3]}, build_up_s=float(r["build_up_s"]),
        f_ex=f_ex, a_ex=a_ex, s0=s0, monostable=bool(r["monostable"]), robust=r["robust"],
        shifted=[(b, float(sf)) for b, sf in r["shifted"]],
    )
