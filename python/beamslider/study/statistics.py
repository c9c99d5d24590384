"""Aggregation: behaviour probabilities, statistics and sensitivity indices per operating point."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, List, Sequence, Tuple, Union

import numpy as np

from ..maps import BEHAVIOURS, LETTERS, rows_to_table
from ..tables import SampleTable
from .config import OUTPUTS, StudyConfig
from .results import read_results
from .._json import json_safe as _json_safe


@dataclass
class PointSummary:
    """The study at one operating point."""

    f_ex_hz: float
    a_ex_m_s2: float
    s0: float
    n: int
    """Runs at this point."""
    probabilities: Dict[str, float]
    """Behaviour → fraction of runs (all of :data:`maps.BEHAVIOURS`)."""
    most_probable: str
    stats: Dict[str, Dict[str, float]]
    """Output → ``mean``, ``std``, ``q<p>`` (e.g. ``q0.05``), ``n_finite`` (NaN-free runs; a
    missing turning point is NaN)."""
    sensitivity: Dict[str, Dict[str, Dict[str, float]]]
    """Output → parameter → indices (``S1``, ``ST``, ``S1_conf``, ``ST_conf`` for saltelli;
    ``rho`` otherwise). NaN where the output is not finite for every run."""
    main_effects: Dict[str, Dict[str, List[Tuple[float, float]]]] = field(default_factory=dict)
    """Grid studies: output → parameter → [(level, mean output at that level)]."""


@dataclass
class StudyResult:
    """Outcome of :func:`run_study` / :func:`aggregate`."""

    config: StudyConfig
    table: SampleTable
    """One entry per run, sorted by index: the map row columns (:func:`maps.rows_to_table`) plus
    ``sample``, ``point`` and ``param_<name>`` for each uncertain input (a dict of numpy arrays;
    ``.to_pandas()`` or :meth:`to_pandas` gives a DataFrame)."""
    points: List[PointSummary]
    """One summary per operating point, in map order."""

    def to_pandas(self) -> Any:
        """The runs as a pandas DataFrame, one row per sample and operating point (extra
        ``pandas``; ``behaviour`` categorical)."""
        return self.table.to_pandas()

    def summary_dict(self) -> Dict[str, Any]:
        """JSON-ready summary (no rows)."""
        return _json_safe({"config": self.config.to_dict(), "points": [dataclasses.asdict(p) for p in self.points]})

    def text(self) -> str:
        """A short text report."""
        lines = [f"study: {self.config.method}, {len(self.table['index'])} runs, uncertain "
                 + ", ".join(self.config.names)]
        for p in self.points:
            probs = ", ".join(f"{LETTERS[b]} {v:.2f}" for b, v in p.probabilities.items() if v > 0)
            lines.append(f"({p.f_ex_hz:g} Hz, {p.a_ex_m_s2:g} m/s^2, s0 = {p.s0:g}): n = {p.n}; {probs}")
            for out, st in p.stats.items():
                qs = " ".join(f"{k} {v:.4f}" for k, v in st.items() if k.startswith("q"))
                lines.append(f"  {out:<18} mean {st['mean']:.4f} std {st['std']:.4f} {qs} (finite {int(st['n_finite'])})")
                for name, ind in p.sensitivity.get(out, {}).items():
                    lines.append(f"    {name:<26} " + " ".join(f"{k} {v:+.3f}" for k, v in ind.items()))
                for name, eff in p.main_effects.get(out, {}).items():
                    lines.append(f"    mean by {name}: " + ", ".join(f"{lv:g} -> {m:.4f}" for lv, m in eff))
        return "\n".join(lines) + "\n"


def sobol_indices(y: np.ndarray, n: int, d: int, *, bootstrap: int = 200, seed: int = 0) -> Dict[str, np.ndarray]:
    """First-order (Saltelli 2010) and total (Jansen 1999) Sobol' indices from outputs ``y`` of a
    Saltelli design (rows A, B, AB_1..AB_D, N each): dict of arrays ``S1``, ``ST``, ``S1_conf``,
    ``ST_conf`` (bootstrap 95 % half-widths); S1 and ST equal SALib's ``sobol.analyze`` (without
    second order) for the same outputs."""
    y = np.asarray(y, dtype=float)
    if y.shape != (n * (d + 2),):
        raise ValueError(f"need {n * (d + 2)} outputs for N = {n}, D = {d}, got {y.shape}")
    if np.std(y) > 0:  # standardised over all runs first, as SALib (the S1 estimator is not shift invariant)
        y = (y - np.mean(y)) / np.std(y)
    ya, yb = y[:n], y[n:2 * n]
    yab = y[2 * n:].reshape(d, n)

    def est(idx: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        a, b, ab = ya[idx], yb[idx], yab[:, idx]
        var = np.var(np.concatenate([a, b]))
        if not var > 0:
            return np.zeros(d), np.zeros(d)
        s1 = np.mean(b * (ab - a), axis=1) / var
        st = 0.5 * np.mean((a - ab) ** 2, axis=1) / var
        return s1, st

    s1, st = est(np.arange(n))
    rng = np.random.default_rng(seed)
    boots = [est(rng.integers(0, n, n)) for _ in range(bootstrap)]
    z = 1.959963984540054
    s1c = z * np.std([b[0] for b in boots], axis=0, ddof=1) if bootstrap > 1 else np.full(d, np.nan)
    stc = z * np.std([b[1] for b in boots], axis=0, ddof=1) if bootstrap > 1 else np.full(d, np.nan)
    return {"S1": s1, "ST": st, "S1_conf": s1c, "ST_conf": stc}


def _spearman(x: np.ndarray, y: np.ndarray) -> float:
    from scipy.stats import rankdata

    if np.ptp(x) == 0 or np.ptp(y) == 0:
        return float("nan")
    return float(np.corrcoef(rankdata(x), rankdata(y))[0, 1])


def aggregate(config: StudyConfig, rows: Sequence[Dict[str, Any]]) -> StudyResult:
    """Summaries per operating point from the study's rows (as in the results file)."""
    rows = sorted(rows, key=lambda r: r["index"])
    table = SampleTable(rows_to_table(rows))
    table["sample"] = np.array([r["sample"] for r in rows], dtype=int)
    table["point"] = np.array([r["point"] for r in rows], dtype=int)
    for name in config.names:
        table[f"param_{name}"] = np.array([r["params"][name] for r in rows], dtype=float)
    ops = config.operating_points()
    n_samples = len(config.design())
    d = len(config.names)
    summaries = []
    for j, (f, a, s) in enumerate(ops):
        m = table["point"] == j
        order = np.argsort(table["sample"][m])
        beh = table["behaviour"][m][order]
        n = int(m.sum())
        probs = {b: (float(np.mean(beh == b)) if n else 0.0) for b in BEHAVIOURS}
        most = max(BEHAVIOURS, key=lambda b: probs[b]) if n else "undetermined"
        stats: Dict[str, Dict[str, float]] = {}
        sens: Dict[str, Dict[str, Dict[str, float]]] = {}
        effects: Dict[str, Dict[str, List[Tuple[float, float]]]] = {}
        complete = n == n_samples
        for out in OUTPUTS:
            y = table[out][m][order]
            fin = np.isfinite(y)
            st = {"mean": float(np.mean(y[fin])) if fin.any() else float("nan"),
                  "std": float(np.std(y[fin], ddof=1)) if fin.sum() > 1 else float("nan")}
            for q in config.quantiles:
                st[f"q{q:g}"] = float(np.quantile(y[fin], q)) if fin.any() else float("nan")
            st["n_finite"] = float(fin.sum())
            stats[out] = st
            sens[out] = {}
            for i, name in enumerate(config.names):
                x = table[f"param_{name}"][m][order]
                if config.method == "saltelli":
                    continue
                sens[out][name] = {"rho": _spearman(x, y) if fin.all() and n > 2 else float("nan")}
                if config.method == "grid":
                    effects.setdefault(out, {})[name] = [
                        (float(lv), float(np.nanmean(y[x == lv])) if np.isfinite(y[x == lv]).any() else float("nan"))
                        for lv in sorted(set(x.tolist()))]
            if config.method == "saltelli":
                if complete and fin.all():
                    ind = sobol_indices(y, config.samples, d, seed=config.seed)
                else:
                    ind = {k: np.full(d, np.nan) for k in ("S1", "ST", "S1_conf", "ST_conf")}
                for i, name in enumerate(config.names):
                    sens[out][name] = {k: float(v[i]) for k, v in ind.items()}
        summaries.append(PointSummary(f_ex_hz=f, a_ex_m_s2=a, s0=s, n=n, probabilities=probs, most_probable=most,
                                      stats=stats, sensitivity=sens, main_effects=effects))
    return StudyResult(config=config, table=table, points=summaries)


def read_study(path: Union[str, Path]) -> StudyResult:
    """Aggregate the results file of a study (``study.jsonl`` or its folder), complete or not."""
    header, rows, _good, _trunc = read_results(path)
    if header is None or "study" not in header:
        raise ValueError(f"{path}: not a study results file (no study header)")
    return aggregate(StudyConfig.from_dict(header["study"]["config"]), rows)
