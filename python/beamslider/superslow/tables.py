"""Drift tables (docs/model.md §8's super-slow layer): the drift velocity V(s, branch) measured in the
PCS model — the horizontal drift of the slider's centre of mass on each branch by sequential
continuation (down-sweep from the centre for L, up-sweep from s_min for H), run by the core
(``drift_table_pcs``) into a resumable JSON-lines file; the training data of :mod:`beamslider.superslow.fit`."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _core
from .._util import number
from ..params import Parameters, native, resolve


__all__ = ["DriftTable", "drift_table", "drift_tables", "read_drift_table"]


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

    def _branch_order(self, branch: str) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(row mask of the branch, its rows' half coordinate, the order sorting it)."""
        m = self.branch == branch
        s = self.s[m]
        half = np.where(s > 0.5, 1.0 - s, s)
        return m, half, np.argsort(half)

    def branch_rows(self, branch: str) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s, V, se) of one branch sorted by s, in the half coordinate s' = min(s, 1 − s) with V
        towards the centre positive."""
        m, s, o = self._branch_order(branch)
        v = np.where(self.s[m] > 0.5, -self.v[m], self.v[m])
        return s[o], v[o], self.v_se[m][o]

    def branch_amplitude(self, branch: str) -> np.ndarray:
        """Â [h] of one branch's rows, in the order of :meth:`branch_rows`."""
        m, _, o = self._branch_order(branch)
        return self.amplitude[m][o]

    s_up_pcs: Optional[float] = None
    """Jump-up position of the PCS down sweep: midpoint between its last low-branch s and the s
    where it left the branch (half coordinate; None if it never jumped)."""
    s_dn_pcs: Optional[float] = None
    """Jump-down position of the PCS up sweep (likewise)."""

    def s_jumps(self) -> Tuple[Optional[float], Optional[float]]:
        """(s_up, s_dn) of the PCS sweeps (see ``s_up_pcs``, ``s_dn_pcs``)."""
        return self.s_up_pcs, self.s_dn_pcs


def _table_from(h: Dict[str, Any], rs: Sequence[Dict[str, Any]], computed: int = 0, path=None) -> DriftTable:
    """A :class:`DriftTable` of the core's header and rows (dicts)."""
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
        bar.total = int(total)
        bar.n = int(done)
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
    """Drift velocity V(s, branch) from the PCS model (docs/model.md §6.3, layer (b1)).

    Args:
        params: model parameters (``None``: defaults).
        f_ex: excitation frequency [Hz].
        a_ex: base-acceleration amplitude [m/s^2].
        ds: grid step from s_min = B/(2L) to 0.5 (ignored when ``s`` is given).
        s: increasing slider positions within [s_min, 0.5] (the sweeps' grid).
        settle_periods: settling periods at each s (≥ 40, docs/model.md §6.3).
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
    f_ex, a_ex = number("f_ex", f_ex), number("a_ex", a_ex)
    if s is None:
        ds = number("ds", ds)
        if not 0 < ds <= 0.5:
            raise ValueError(f"invalid parameter `ds` = {ds}: must lie in (0, 0.5]")
        lo = p.s_min() if hasattr(p, "s_min") else 0.5 * p.contact_spacing_m / p.length_m
        grid = list(np.arange(lo, 0.5 - 1e-9, ds)) + [0.5]
    else:
        grid = [float(v) for v in np.atleast_1d(np.asarray(s, dtype=float))]
    cb, close = _tqdm_progress(progress, f"drift table {f_ex:g} Hz, {a_ex:g} m/s²")
    try:
        header, rows, computed = _core.drift_table_pcs(
            native(p), f_ex_hz=f_ex, a_ex_m_s2=a_ex, s_values=[float(v) for v in grid],
            settle_periods=int(settle_periods), first_settle_periods=int(first_settle_periods),
            window_s=number("window_s", window_s), sub_windows=int(sub_windows), mirror=bool(mirror),
            out=None if out is None else str(out), resume=bool(resume), progress=cb,
        )
    finally:
        close()
    return _table_from(header, rows, computed, out)


def drift_tables(
    params: Optional[Parameters] = None,
    *,
    points: Sequence[Tuple[float, float]],
    out: Union[str, os.PathLike, None] = None,
    resume: bool = False,
    threads: Optional[int] = None,
    progress: bool = False,
    **settings,
) -> List[DriftTable]:
    """The drift tables of several operating points (e.g. a law's training set), computed
    concurrently: ``threads`` tables at a time (default: the CPU count; the core releases the
    interpreter, and each table's two sweeps run on two threads of their own). Each table is the
    one :func:`drift_table` computes alone (same settings, bitwise the same rows), in the order of
    ``points``. ``out``: a folder for the files ``drift_<f>Hz_<a>ms2.jsonl`` (``resume`` continues
    them); ``settings``: the keyword arguments of :func:`drift_table` (ds, settle_periods, ...)."""
    from concurrent.futures import ThreadPoolExecutor

    pts = [(number("f_ex", f), number("a_ex", a)) for f, a in points]
    if not pts:
        raise ValueError("invalid parameter `points`: at least one (f_ex, a_ex)")
    n = int(threads) if threads is not None else (os.cpu_count() or 1)
    if n < 1:
        raise ValueError(f"invalid parameter `threads` = {threads}: must be >= 1")
    folder = None if out is None else Path(out)
    if folder is not None:
        folder.mkdir(parents=True, exist_ok=True)
    bad = set(settings) - {"ds", "s", "settle_periods", "first_settle_periods", "window_s", "sub_windows", "mirror"}
    if bad:
        raise ValueError(f"invalid parameter `{sorted(bad)[0]}`: not a drift_table setting")
    p = resolve(params)

    def one(fa):
        f, a = fa
        path = None if folder is None else folder / f"drift_{f:g}Hz_{a:g}ms2.jsonl"
        return drift_table(p, f_ex=f, a_ex=a, out=path, resume=resume and path is not None and path.exists(), **settings)

    bar = None
    if progress:
        try:
            from tqdm import tqdm

            bar = tqdm(total=len(pts), desc="drift tables", unit="table")
        except ImportError:  # pragma: no cover
            bar = None
    out_tables: List[DriftTable] = []
    with ThreadPoolExecutor(max_workers=min(n, len(pts))) as ex:
        try:
            for tab in ex.map(one, pts):
                out_tables.append(tab)
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()
    return out_tables


def read_drift_table(path: Union[str, os.PathLike]) -> DriftTable:
    """Read a drift-table file written by :func:`drift_table`."""
    header, rows = _core.read_drift_table(str(path))
    return _table_from(header, rows, 0, path)
