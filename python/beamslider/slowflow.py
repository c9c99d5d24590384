"""Layer (b) of issue 17: drift law and slow flow on the super-slow manifold.

- :func:`drift_table` — (b1) V(s, branch) measured in the PCS model (issue §3.1): the horizontal
  drift of the slider's centre of mass on each branch, by sequential continuation (down-sweep
  from the centre for L, up-sweep from s_min for H); resumable JSON-lines file.
- :func:`features` — the local features of issue §3.2 computed from layer (a) (Λ_g, θ̂/θ_gap,
  f_slope, a_ex/g, Â, branch).
- :func:`fit_drift_law` — (b2) a transferable drift law fitted on several operating points'
  tables (distance-weighted k-nearest neighbours in standardised feature space, per branch; V = 0
  where Λ_g < 1; odd symmetry by construction), with leave-one-operating-point-out validation.
- :func:`predict` — HB manifold (layer (a)) + drift (a table or a fitted law) + slow flow
  (core, exact per-cell integration with event location) + the operating-map classifier.

Closed form / fitted: the manifold, its folds and the feature formulas are closed form (layer
(a)); V is measured (b1) or fitted (b2); s_dn comes from the option ``s_dn`` of :func:`predict`
(single-term HB gives none, issue §8).
"""

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
from .simulate import _number

__all__ = [
    "DriftTable",
    "DriftLaw",
    "Prediction",
    "drift_table",
    "read_drift_table",
    "features",
    "fit_drift_law",
    "predict",
    "slow_model",
]


@dataclass
class DriftTable:
    """V(s, branch) at one operating point (one row per (s, branch))."""

    f_ex: float
    """Excitation frequency [Hz]."""
    a_ex: float
    """Base-acceleration amplitude [m/s^2]."""
    s: np.ndarray
    """Slider positions [-]."""
    branch: np.ndarray
    """'L' or 'H' per row."""
    v: np.ndarray
    """Drift velocity V [1/s] (> 0: towards larger s; towards the centre for s < 0.5)."""
    v_se: np.ndarray
    """Standard error of V from the sub-windows [1/s]."""
    amplitude: np.ndarray
    """Mean |Hilbert(w(4L/7))|/h over the window [-]."""
    jump: np.ndarray
    """The sweep left its branch at this row (bool)."""
    sweep: np.ndarray
    """'down' or 'up' per row."""
    params_toml: str = ""
    """Canonical parameter TOML of the PCS runs."""
    computed: int = 0
    """Rows computed by the call (the others were read from the file)."""
    path: Optional[str] = None
    """The file, if any."""

    def branch_rows(self, branch: str) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s, V, se) of one branch sorted by s, in the half coordinate s' = min(s, 1 − s) with V
        towards the centre positive."""
        m = self.branch == branch
        s, v, e = self.s[m], self.v[m], self.v_se[m]
        far = s > 0.5
        s = np.where(far, 1.0 - s, s)
        v = np.where(far, -v, v)
        o = np.argsort(s)
        return s[o], v[o], e[o]

    s_up_pcs: Optional[float] = None
    """Jump-up position of the PCS down sweep: midpoint between its last low-branch s and the s
    where it left the branch (half coordinate; None if it never jumped)."""
    s_dn_pcs: Optional[float] = None
    """Jump-down position of the PCS up sweep (likewise)."""

    def s_jumps(self) -> Tuple[Optional[float], Optional[float]]:
        """(s_up, s_dn) of the PCS sweeps (see ``s_up_pcs``, ``s_dn_pcs``)."""
        return self.s_up_pcs, self.s_dn_pcs


def _table_from(header: str, rows: Sequence[str], computed: int = 0, path=None) -> DriftTable:
    h = json.loads(header)
    rs = [json.loads(r) for r in rows]
    half = lambda x: min(x, 1.0 - x)  # noqa: E731
    jumps = {}
    for sw in ("down", "up"):
        seq = sorted((r for r in rs if r["sweep"] == sw), key=lambda r: r["index"])
        jumps[sw] = None
        for a_, b_ in zip(seq, seq[1:]):
            if b_["jump"]:
                jumps[sw] = 0.5 * (half(a_["s"]) + half(b_["s"]))
                break
    # One row per (s, branch), preferring the branch's native sweep.
    keep: Dict[Tuple[float, str], dict] = {}
    for r in rs:
        key = (round(r["s"], 12), r["branch"])
        native = (r["sweep"], r["branch"]) in (("down", "L"), ("up", "H"))
        if key not in keep or native:
            keep[key] = r
    rs = sorted(keep.values(), key=lambda r: (r["branch"], r["s"]))
    col = lambda k, dt=float: np.array([r[k] for r in rs], dtype=dt)  # noqa: E731
    return DriftTable(
        f_ex=float(h["f_ex_hz"]),
        a_ex=float(h["a_ex_m_s2"]),
        s=col("s"),
        branch=col("branch", object).astype(str),
        v=col("v_per_s"),
        v_se=col("v_se_per_s"),
        amplitude=col("amplitude_h"),
        jump=col("jump", bool),
        sweep=col("sweep", object).astype(str),
        params_toml=h["params_toml"],
        computed=computed,
        path=None if path is None else str(path),
        s_up_pcs=jumps["down"],
        s_dn_pcs=jumps["up"],
    )


def _tqdm_progress(enabled: bool, desc: str):
    if not enabled:
        return None, lambda: None
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return None, lambda: None
    bar = tqdm(total=1, desc=desc, unit="pt")

    def cb(done, total):
        bar.total = total
        bar.n = done
        bar.refresh()

    return cb, bar.close


def drift_table(
    params: Optional[Parameters] = None,
    *,
    f_ex: float,
    a_ex: float,
    ds: float = 0.02,
    s: Optional[Sequence[float]] = None,
    settle_periods: int = 40,
    first_settle_periods: int = 400,
    window_s: float = 1.0,
    sub_windows: int = 4,
    mirror: bool = False,
    out: Union[str, os.PathLike, None] = None,
    resume: bool = False,
    progress: bool = False,
) -> DriftTable:
    """Drift velocity V(s, branch) from the PCS model (issue 17 §3.1, layer (b1)).

    Args:
        params: model parameters (``None``: defaults).
        f_ex: excitation frequency [Hz].
        a_ex: base-acceleration amplitude [m/s^2].
        ds: grid step from s_min = B/(2L) to 0.5 (ignored when ``s`` is given).
        s: increasing slider positions within [s_min, 0.5] (the sweeps' grid).
        settle_periods: settling periods at each s (≥ 40 in the issue).
        first_settle_periods: settling periods at the first s of a sweep (from rest).
        window_s: least record window [s] (rounded up to whole periods per sub-window).
        sub_windows: sub-windows for the standard error.
        mirror: run at 1 − s (the far half; V(1 − s) = −V(s) by symmetry).
        out: JSON-lines file the rows are appended to as they are produced.
        resume: continue an existing ``out`` made with the same settings (otherwise an existing
            file is an error: nothing is overwritten).
        progress: show a tqdm progress bar.

    Returns:
        :class:`DriftTable` (one row per (s, branch)).
    """
    p = resolve(params)
    f_ex, a_ex = _number("f_ex", f_ex), _number("a_ex", a_ex)
    if s is None:
        ds = _number("ds", ds)
        if not 0 < ds <= 0.5:
            raise ValueError(f"invalid parameter `ds` = {ds}: must lie in (0, 0.5]")
        lo = p.s_min() if hasattr(p, "s_min") else 0.5 * p.contact_spacing_m / p.length_m
        grid = list(np.arange(lo, 0.5 - 1e-9, ds)) + [0.5]
    else:
        grid = [float(v) for v in np.atleast_1d(np.asarray(s, dtype=float))]
    cb, close = _tqdm_progress(progress, f"drift table {f_ex:g} Hz, {a_ex:g} m/s²")
    try:
        header, rows, computed = _core.drift_table_pcs(
            p.toml_text(), f_ex_hz=f_ex, a_ex_m_s2=a_ex, s_values=[float(v) for v in grid],
            settle_periods=int(settle_periods), first_settle_periods=int(first_settle_periods),
            window_s=_number("window_s", window_s), sub_windows=int(sub_windows), mirror=bool(mirror),
            out=None if out is None else str(out), resume=bool(resume), progress=cb,
        )
    finally:
        close()
    return _table_from(header, rows, computed, out)


def read_drift_table(path: Union[str, os.PathLike]) -> DriftTable:
    """Read a drift-table file written by :func:`drift_table`."""
    header, rows = _core.read_drift_table(str(path))
    return _table_from(header, rows, 0, path)


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
    ``amp_rel`` = Â / max Â of the high branch.
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
    }


# The regression inputs (standardised). Chosen by the leave-one-operating-point-out error on the
# 12 validation tables (docs/superslow/validation_b_law.txt): with the list (log Λ_g,
# θ̂/θ_gap, f_slope, a_ex/g, Â) the error was 0.68 × typical |V| (k = 6), with s − s_res and
# Â/max Â_H in place of a_ex/g and Â it is 0.53 ×.
FEATURES = ("log_lift_off", "slope_gap", "f_slope", "ds_res", "amp_rel")


def _x(feat: Dict[str, np.ndarray]) -> np.ndarray:
    cols = []
    for name in FEATURES:
        cols.append(np.log(np.maximum(feat["lift_off"], 1e-12)) if name == "log_lift_off" else np.asarray(feat[name], dtype=float))
    return np.stack(cols, axis=1)


@dataclass
class DriftLaw:
    """A fitted transferable drift law (layer (b2)): V = 0 where Λ_g < 1, otherwise the
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
    k: int = 6
    """Neighbours."""
    loo: Dict[str, float] = field(default_factory=dict)
    """Leave-one-operating-point-out errors: RMS error of V, typical |V| (RMS), their ratio,
    per branch and overall."""
    loo_per_point: List[dict] = field(default_factory=list)
    """Per held-out operating point: RMS error and typical |V|."""
    fit_time_s: float = 0.0
    """Wall time of the fit (including the layer-(a) manifolds of the training points) [s]."""
    x_exist: np.ndarray = field(default_factory=lambda: np.zeros((0, len(FEATURES))))
    """Features of HB high-branch nodes on [max(s_up, 0.2), 0.5] of the training points (for s_dn)."""
    y_exist: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """1 where the PCS high branch exists at that node (below the table's s_dn), else 0."""
    g_exist: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    """Operating-point index of each existence sample."""
    loo_s_dn: List[dict] = field(default_factory=list)
    """Leave-one-point-out s_dn of the law against the PCS tables' s_dn."""
    _trees: dict = field(default_factory=dict, repr=False, compare=False)

    def evaluate(self, branch: str, feat: Dict[str, np.ndarray], exclude_group: Optional[int] = None) -> Tuple[np.ndarray, np.ndarray]:
        """V at the given features (half coordinate, towards the centre positive) and a flag per
        point: True where a feature lies outside the training range (extrapolation)."""
        return self._evaluate_x(branch, _x(feat), np.asarray(feat["lift_off"]), exclude_group)

    def s_dn(self, manifold, exclude_group: Optional[int] = None) -> Optional[float]:
        """Jump-down position learnt from the PCS tables (s_dn="law"): the first HB high-branch node
        above max(s_up, 0.2) where the distance-weighted vote of the k nearest training nodes says
        the PCS high branch no longer exists (None: it reaches the centre)."""
        if self.y_exist.size == 0 or len(manifold.high) == 0:
            return None
        s = _exist_nodes(manifold)
        if s.size == 0:
            return None
        p = self._exist_prob(_x(features(manifold, "H", s)), exclude_group)
        gone = np.nonzero(p < 0.5)[0]
        return None if gone.size == 0 else float(s[gone[0]])

    def _exist_prob(self, x, exclude_group=None):
        from scipy.spatial import cKDTree

        key = ("exist", exclude_group)
        if key not in self._trees:
            keep = self.g_exist != exclude_group if exclude_group is not None else np.ones(self.y_exist.size, bool)
            self._trees[key] = (cKDTree((self.x_exist[keep] - self.mean) / self.std), self.y_exist[keep])
        tree, y = self._trees[key]
        k = min(self.k, y.size)
        dk, idx = tree.query((x - self.mean) / self.std, k=k)
        dk, idx = dk.reshape(x.shape[0], k), idx.reshape(x.shape[0], k)
        w = 1.0 / np.maximum(dk, 1e-6)
        return (w * y[idx]).sum(axis=1) / w.sum(axis=1)

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
        out[lift_off < 1.0] = 0.0
        outside = np.any((x < self.lo - 1e-9) | (x > self.hi + 1e-9), axis=1)
        return out, outside


def _exist_nodes(manifold) -> np.ndarray:
    lo = max(manifold.s_up or 0.2, 0.2)
    hi = float(np.max(manifold.high.s))
    return np.linspace(lo, hi, 31) if hi > lo else np.zeros(0)


def _manifold_for(params, f_ex, a_ex, n_modes, d_eff):
    from .superslow import hb_manifold

    return hb_manifold(params, f_ex=f_ex, a_ex=a_ex, n_modes=n_modes, d_eff=d_eff)


def _training_samples(table: DriftTable, manifold) -> Dict[str, Tuple[np.ndarray, np.ndarray]]:
    out = {}
    for br in ("L", "H"):
        s, v, _ = table.branch_rows(br)
        b = manifold.high if br == "H" else manifold.low
        if s.size == 0 or len(b) == 0:
            out[br] = (np.zeros((0, len(FEATURES))), np.zeros(0))
            continue
        lo, hi = float(np.min(b.s)), float(np.max(b.s))
        m = (s >= lo) & (s <= hi)
        if not m.any():
            out[br] = (np.zeros((0, len(FEATURES))), np.zeros(0))
            continue
        f = features(manifold, br, s[m])
        out[br] = (_x(f), v[m])
    return out


def fit_drift_law(tables: Sequence[DriftTable], *, params: Optional[Parameters] = None, k: int = 6, n_modes: int = 5) -> DriftLaw:
    """Fit the transferable drift law (issue 17 §3.2, b2) on PCS drift tables of several operating
    points, and validate it leave one operating point out.

    Each table row (s, branch) is paired with the layer-(a) features at the same s on the same
    branch (rows where the HB branch does not exist are left out). Rows with Λ_g < 1 train
    nothing (the law is 0 there by construction).
    """
    if len(tables) < 2:
        raise ValueError("invalid parameter `tables`: need at least two operating points")
    if int(k) < 1:
        raise ValueError(f"invalid parameter `k` = {k}: must be >= 1")
    t0 = time.perf_counter()
    p = resolve(params)
    xs: Dict[str, list] = {"L": [], "H": []}
    vs: Dict[str, list] = {"L": [], "H": []}
    gs: Dict[str, list] = {"L": [], "H": []}
    xe, ye, ge, mfs = [], [], [], []
    for gi, t in enumerate(tables):
        mf = _manifold_for(p, t.f_ex, t.a_ex, n_modes, None)
        mfs.append(mf)
        se = _exist_nodes(mf) if len(mf.high) else np.zeros(0)
        if se.size:
            xe.append(_x(features(mf, "H", se)))
            ye.append(np.ones(se.size) if t.s_dn_pcs is None else (se <= t.s_dn_pcs).astype(float))
            ge.append(np.full(se.size, gi))
        for br, (x, v) in _training_samples(t, mf).items():
            xs[br].append(x)
            vs[br].append(v)
            gs[br].append(np.full(v.size, gi))
    X = {br: np.concatenate(xs[br]) if xs[br] else np.zeros((0, len(FEATURES))) for br in xs}
    V = {br: np.concatenate(vs[br]) if vs[br] else np.zeros(0) for br in vs}
    G = {br: np.concatenate(gs[br]) if gs[br] else np.zeros(0, int) for br in gs}
    allx = np.concatenate([X["L"], X["H"]])
    if allx.shape[0] == 0:
        raise ValueError("invalid parameter `tables`: no row lies on a branch of the HB manifold")
    # Drop lift-off-free rows from the training set (the law is 0 there).
    for br in X:
        keep = X[br][:, 0] >= 0.0
        X[br], V[br], G[br] = X[br][keep], V[br][keep], G[br][keep]
    allx = np.concatenate([X["L"], X["H"]])
    std = allx.std(axis=0)
    std[std == 0] = 1.0
    law = DriftLaw(x=X, v=V, groups=G, mean=allx.mean(axis=0), std=std, lo=allx.min(axis=0), hi=allx.max(axis=0),
                   points=[(t.f_ex, t.a_ex) for t in tables], k=int(k),
                   x_exist=np.concatenate(xe) if xe else np.zeros((0, len(FEATURES))),
                   y_exist=np.concatenate(ye) if ye else np.zeros(0), g_exist=np.concatenate(ge) if ge else np.zeros(0, int))
    for gi, t in enumerate(tables):
        law.loo_s_dn.append({"f_ex": t.f_ex, "a_ex": t.a_ex, "s_dn_pcs": t.s_dn_pcs, "s_dn_law": law.s_dn(mfs[gi], exclude_group=gi)})
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
            pred, _ = law._evaluate_x(br, xb, np.exp(xb[:, 0]), exclude_group=gi)
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
    """Where s_dn comes from: 'hb' (single-term HB, possibly with d_eff), 'table' (PCS), 'none'."""
    features: Dict[str, Dict[str, np.ndarray]]
    """Per branch: the node positions ``s`` and the features of :func:`features` there."""
    extrapolated: bool
    """Some node used by the flow lies outside the drift law's training range."""
    warnings: List[str]
    """Extrapolation, degenerate cycles, ..."""
    timings_s: Dict[str, float]
    """Wall times: manifold (a), drift evaluation, slow flow [s]."""
    build_up_s: float = 0.0
    """Build-up time used [s] (s = s0 until then)."""
    f_ex: float = 0.0
    a_ex: float = 0.0
    s0: float = 0.3


def slow_model(manifold, drift, *, s_dn: str = "hb", nodes: int = 121):
    """Nodes of the reduced model: each branch of ``manifold`` sampled at up to ``nodes`` points
    (plus its ends) in the half coordinate, with Â and V there.

    ``drift``: a :class:`DriftTable` (b1: V interpolated linearly in s on the branch's rows,
    held constant beyond them) or a :class:`DriftLaw` (b2). ``s_dn``: 'hb' — the HB manifold's
    own jump-down (None with single-term HB unless d_eff ends the high branch); 'table' — the
    PCS sweep's jump-down of the drift table (b1 only); 'none'.

    Returns (low, high, low_ends_in_fold, high_ends_in_fold, info dict).
    """
    if s_dn not in ("hb", "table", "law", "none"):
        raise ValueError(f"invalid parameter `s_dn` = {s_dn!r}: one of 'hb', 'table', 'law', 'none'")
    lo_all, hi_all = manifold.s_range
    s_up = manifold.s_up
    s_dn_v = manifold.s_dn if s_dn == "hb" else None
    if s_dn == "table":
        if not isinstance(drift, DriftTable):
            raise ValueError("invalid parameter `s_dn` = 'table': needs a DriftTable as drift")
        s_dn_v = drift.s_jumps()[1]
    if s_dn == "law":
        if not isinstance(drift, DriftLaw):
            raise ValueError("invalid parameter `s_dn` = 'law': needs a DriftLaw as drift")
        s_dn_v = drift.s_dn(manifold)
    info = {"extrapolated": False, "features": {}, "s_up": s_up, "s_dn": s_dn_v, "s_dn_source": s_dn if s_dn_v is not None else "none"}
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
            if np.any(outside & (f["lift_off"] >= 1.0)):
                info["extrapolated"] = True
            info["features"][br] = {"s": s, **f}
        out[br] = ([float(x) for x in s], [float(x) for x in amp], [float(x) for x in v])
    high_fold = s_dn_v is not None and len(out["H"][0]) > 0
    return out["L"], out["H"], s_up is not None, high_fold, info


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
    drift,
    s_dn: str = "hb",
    n_modes: int = 5,
    d_eff: Optional[float] = None,
    manifold=None,
    source: str = "hb",
    build_up: Union[str, float] = "auto",
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
            never silently.
        s_dn: source of the jump-down position: 'hb' (the HB manifold's own; none with single-term
            HB), 'table' (the PCS sweep of a DriftTable), 'law' (learnt from the PCS tables by a
            fitted DriftLaw, :meth:`DriftLaw.s_dn`), 'none'.
        n_modes: modes of the HB manifold.
        d_eff: equivalent damping ratio of the HB manifold (issue §2.5.1; None: off).
        manifold: a precomputed :func:`beamslider.superslow.hb_manifold` result (skips layer (a)).
        source: 'hb' — branches, Â and s_up from the HB manifold (layer (a)), V from ``drift``;
            'table' — everything from the PCS drift table (b1 only: its rows' Â and V, its sweeps'
            jump positions for s_up and s_dn; no layer (a)).
        build_up: time [s] the beam needs from rest to vibrate on the manifold; s stays at s0
            and Â ramps up meanwhile. 'auto': three envelope time constants 3/(D Ω) of the
            first mode (D = d_eff or the parameters' damping ratio; 3.9 s at 124 Hz); 0: start on
            the manifold.

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
        info = {"extrapolated": False, "features": {}, "s_up": su if lf else None, "s_dn": sd if hf else None,
                "s_dn_source": "table" if hf else "none"}
    else:
        mf = manifold if manifold is not None else _manifold_for(p, f_ex, a_ex, n_modes, d_eff)
        t1 = time.perf_counter()
        low, high, lf, hf, info = slow_model(mf, drift, s_dn=s_dn)
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
                        build_up_s=float(min(t_build, t_end)))
    t3 = time.perf_counter()
    cls = json.loads(r["classification"])
    warnings = list(r["warnings"])
    if info.get("note"):
        warnings.insert(0, info["note"])
    if info["extrapolated"]:
        pts = ", ".join(f"({f:g}, {a:g})" for f, a in drift.points)
        warnings.insert(0, f"drift law used outside its training range (trained on {pts}): V extrapolated from the nearest samples")
    return Prediction(
        t=np.asarray(r["t_s"]), s=np.asarray(r["s"]), amplitude=np.asarray(r["amplitude_h"]),
        branch=np.where(np.asarray(r["branch"]) == 1, "H", "L"), events=[tuple(e) for e in r["events"]],
        behaviour=cls["behaviour"], classification=cls, s_final=float(r["s_final"]),
        amplitude_final=float(r["amplitude_final_h"]), s_up=info["s_up"], s_dn=info["s_dn"], s_dn_source=info["s_dn_source"],
        features=info["features"], extrapolated=bool(info["extrapolated"]), warnings=warnings,
        timings_s={"manifold": t1 - t0, "drift": t2 - t1, "slow_flow": t3 - t2}, build_up_s=float(min(t_build, t_end)), f_ex=f_ex, a_ex=a_ex, s0=s0,
    )


def save_drift_law(law: DriftLaw, path: Union[str, os.PathLike]) -> None:
    """Write a fitted law as JSON (training samples included; read back by :func:`load_drift_law`)."""
    d = {
        "kind": "beamslider drift law", "version": 1, "features": list(FEATURES), "k": law.k,
        "x": {b: law.x[b].tolist() for b in law.x}, "v": {b: law.v[b].tolist() for b in law.v},
        "groups": {b: law.groups[b].tolist() for b in law.groups}, "mean": law.mean.tolist(), "std": law.std.tolist(),
        "lo": law.lo.tolist(), "hi": law.hi.tolist(), "points": [list(p) for p in law.points], "loo": law.loo,
        "loo_per_point": law.loo_per_point, "fit_time_s": law.fit_time_s,
        "x_exist": law.x_exist.tolist(), "y_exist": law.y_exist.tolist(), "g_exist": law.g_exist.tolist(), "loo_s_dn": law.loo_s_dn,
    }
    Path(path).write_text(json.dumps(d), encoding="utf-8")


def load_drift_law(path: Union[str, os.PathLike]) -> DriftLaw:
    """Read a law written by :func:`save_drift_law`."""
    d = json.loads(Path(path).read_text(encoding="utf-8"))
    if d.get("kind") != "beamslider drift law":
        raise ValueError(f"invalid parameter `law`: {path} is not a beamslider drift law file")
    if list(d.get("features", [])) != list(FEATURES):
        raise ValueError(f"invalid parameter `law`: {path} uses the features {d.get('features')}, this version {list(FEATURES)}")
    arr = lambda v: np.asarray(v, dtype=float)  # noqa: E731
    n = len(FEATURES)
    return DriftLaw(
        x={b: arr(v).reshape(-1, n) for b, v in d["x"].items()}, v={b: arr(v) for b, v in d["v"].items()},
        groups={b: np.asarray(v, dtype=int) for b, v in d["groups"].items()}, mean=arr(d["mean"]), std=arr(d["std"]),
        lo=arr(d["lo"]), hi=arr(d["hi"]), points=[tuple(p) for p in d["points"]], k=int(d["k"]), loo=d.get("loo", {}),
        loo_per_point=d.get("loo_per_point", []), fit_time_s=float(d.get("fit_time_s", 0.0)),
        x_exist=arr(d.get("x_exist", [])).reshape(-1, n), y_exist=arr(d.get("y_exist", [])),
        g_exist=np.asarray(d.get("g_exist", []), dtype=int), loo_s_dn=d.get("loo_s_dn", []),
    )


DriftLaw.save = save_drift_law  # type: ignore[attr-defined]


def predicted_map(
    params: Optional[Parameters] = None,
    *,
    drift: DriftLaw,
    f_ex: Sequence[float],
    a_ex: Sequence[float],
    s0: float = 0.3,
    t_end: float = 120.0,
    s_dn: str = "hb",
    d_eff: Optional[float] = None,
    out: Union[str, os.PathLike, None] = None,
    force: bool = False,
) -> List[dict]:
    """An operating map by the reduced predictor (issue 17 §4.4) with a fitted law (b2): one row per
    (f_ex, a_ex) in the results format of the FS maps (``map.jsonl`` version 2; ``status`` is
    ``predicted``, counters are zero, no end state). With ``out`` (a folder) the rows are written
    to ``out/map.jsonl`` (refused if it exists unless ``force``) and read back by
    :func:`beamslider.read_map`."""
    p = resolve(params)
    path = None
    if out is not None:
        path = Path(out) / "map.jsonl"
        if path.exists() and not force:
            raise FileExistsError(f"{path} exists: pass force=True to overwrite")
    rows = []
    k = 0
    for a in a_ex:
        for f in f_ex:
            t0 = time.perf_counter()
            r = predict(p, f_ex=float(f), a_ex=float(a), s0=s0, t_end=t_end, drift=drift, s_dn=s_dn, d_eff=d_eff)
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
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        try:
            import tomllib
        except ImportError:  # Python < 3.11
            import tomli as tomllib

        criteria = tomllib.loads(_core.default_map_config()).get("criteria", {})
        settings = {"params_toml": p.toml_text(), "duration_s": float(t_end), "record_every": 1, "criteria": criteria}
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(json.dumps({"beamslider_map": 2, "settings": settings, "predictor": {"law_points": [list(q) for q in drift.points], "s_dn": s_dn, "d_eff": d_eff}}) + "\n")
            for row in rows:
                fh.write(json.dumps(row) + "\n")
    return rows
