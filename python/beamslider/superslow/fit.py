"""Fitting the drift law on PCS drift tables of several operating points (docs/model.md §8's super-slow
layer): the training pairs of table rows and HB-manifold features, the lift-off threshold Λ_c, the
jump-down threshold of the forcing ratio, leave-one-operating-point-out validation
(:func:`fit_drift_law`) and the jump-down refinement (:func:`refine_jump_down`)."""

from __future__ import annotations

import math
import os
import time
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _core
from ..params import Parameters, resolve
from .law import FEATURES, DriftLaw, features, forcing_ratio, law_inputs, monostable_inputs, move_fold
from .manifold import hb_manifold
from .tables import DriftTable, drift_tables

__all__ = ["JD_WINDOW", "LIFT_V_EPS", "MONO_RISE_H", "ON_BRANCH_RATIO", "fit_drift_law", "jump_down_bracket",
           "learn_lift_off_threshold", "refine_jump_down"]


JD_WINDOW = 0.02
"""A PCS high branch ends *at* s_p (:func:`jump_down_bracket`) when its jump-down lies within this
distance of s_p, and *passes* s_p when it reaches s_p + JD_WINDOW."""


def jump_down_bracket(tables: Sequence[DriftTable], manifolds, monostable: Sequence[bool]) -> dict:
    """The jump-down threshold of the forcing ratio as a classification boundary (docs/model.md §6.3, "Sources of the jump positions";
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
    return bool(monostable_inputs(manifold) is not None and table.s_up_pcs is None and _stays_low(table, float(manifold.s_up)))


def _stays_low(table: DriftTable, s_fold: float) -> bool:
    """The PCS down sweep of ``table`` never exceeds MONO_RISE_H on the clamping side of s_fold."""
    m = table.sweep == "down"
    s = np.where(table.s[m] > 0.5, 1.0 - table.s[m], table.s[m])
    a = table.amplitude[m][s < s_fold]
    return bool(a.size == 0 or np.nanmax(a) < MONO_RISE_H)


ON_BRANCH_RATIO = 0.5
"""A row of a PCS up sweep (branch 'H') trains the high branch only if its amplitude is at least
this fraction of the HB high branch's at the same s. Rows below it never reached the high
branch (a monostable point's up sweep stays on its single low branch, at a few hundredths of h
where HB has ~1 h), and their V, measured on the low branch, must not be paired with high-branch
features. On the high branch PCS and HB agree within a few per cent (docs/model.md §6.4); the rows that
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
        out[br] = (law_inputs(f), v[m], np.asarray(f["lift_off"], dtype=float), se[m])
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
    """Fit the transferable drift law (docs/model.md §6.3, b2) on PCS drift tables of several operating
    points, and validate it leave one operating point out.

    Each table row (s, branch) is paired with the layer-(a) features at the same s on the same
    branch (rows where the HB branch does not exist are left out). Rows with Λ_g < Λ_c train
    nothing (the law is 0 there by construction).

    ``s_up_correction``: also learn the shift of the jump-up position, s_up(PCS) − s_up(HB)
    (median over the tables where both exist; single-term HB with the slider rigidly attached
    puts the fold too close to the centre, docs/model.md §6.3), applied by :func:`beamslider.superslow.predict`
    by moving the low branch's fold (``DriftLaw.s_up_shift``).

    ``monostable_vote``: also learn where the nonsmooth model has a single, low branch although
    HB has a fold (the PCS down sweep of a training point neither jumps up nor rises beyond
    MONO_RISE_H on the clamping side of the HB fold: the slider's impacts keep the beam off the
    high branch at low excitation), voted by the nearest training point in
    (ln Â_L(s_up), s_up) of the HB manifold (:meth:`DriftLaw.monostable`); the slow flow then
    follows the low branch through the fold towards the clamping (self-damping).

    The jump-down position (s_dn="law" of :func:`beamslider.superslow.predict`) is learnt as a
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
    and the FS runs stop near Λ_g ≈ 0.6–0.75. A number: that Λ_c (1: no lift-off below it).
    """
    if len(tables) < 2:
        raise ValueError("invalid parameter `tables`: need at least two operating points")
    if not 1 <= int(k) <= _core.LAW_MAX_K:
        raise ValueError(f"invalid parameter `k` = {k}: must lie in 1..={_core.LAW_MAX_K} (the core's law::MAX_K)")
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
        mf = hb_manifold(p, f_ex=t.f_ex, a_ex=t.a_ex, n_modes=n_modes, d_eff=None)
        mfs.append(mf)
        lc = learn_lift_off_threshold(t, mf) if lift_off_threshold == "learn" else None
        if lc is not None:
            lift_per.append({"f_ex": t.f_ex, "a_ex": t.a_ex, "lift_c": lc})
        xm = monostable_inputs(mf)
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
    jd_mfs = [hb_manifold(p, f_ex=t.f_ex, a_ex=t.a_ex, n_modes=n_modes, d_eff=None) for t in jd]
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
    mfs = [hb_manifold(p, f_ex=t.f_ex, a_ex=t.a_ex, n_modes=n_modes, d_eff=None) for t in tabs]
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
                cache[fa] = hb_manifold(p, f_ex=fa[0], a_ex=fa[1], n_modes=n_modes, d_eff=None)
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


