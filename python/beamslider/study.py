"""Uncertainty studies: behaviour probabilities and sensitivities of the free slider (docs/model.md §8)
under uncertain parameters, run locally (rayon through the Rust core) or on a Dask cluster.

A study samples the uncertain parameters (distributions from TOML; Latin hypercube, scrambled
Sobol' points, Saltelli's scheme for Sobol' indices, or a full-factorial grid of levels), runs
the free-slider model at every sample and operating point (a ``duration_s`` run from rest,
classified by the core exactly as a point of an operating map) and aggregates per operating
point: the probability of each behaviour, mean / standard deviation / quantiles of the final
slider position ``s_final``, the final amplitude ``amplitude_final_h`` and the turning point
``turn_s``, and their sensitivity indices with respect to each uncertain parameter.

Execution: :func:`run_study` runs all points through the Rust core in one call (rayon, the
interpreter released) or, given a Dask scheduler address or ``distributed.Client``, submits
chunks of points as tasks (each task runs :func:`beamslider._core.run_study_chunk` on a worker,
rayon inside, the interpreter released). Either way every finished point is appended at once as
one JSON line to ``OUT/study.jsonl`` — the results-file format of the operating maps (a header
line, then one map row per point, with the extra keys ``sample``, ``point`` and ``params``) — so
a study survives a killed worker (Dask re-runs the lost chunk; no finished point is lost) and a
killed client (``resume=True`` runs only the missing points). Every point is deterministic and
independent: the rows do not depend on the executor, the number of workers or threads, or the
chunking (bitwise, apart from ``wall_time_s``).

Sensitivity indices:

- ``method = "saltelli"``: first-order ``S1`` (Saltelli et al. 2010) and total ``ST`` (Jansen 1999)
  Sobol' indices from N (D + 2) runs (matrices A, B and A with column i from B, built from a
  scrambled Sobol' sequence of dimension 2D), with bootstrap 95 % half-widths ``S1_conf``/``ST_conf``;
  the estimators are those of SALib's ``sobol.analyze`` (checked against the Ishigami function);
- ``"lhs"``/``"sobol"``: Spearman rank correlation ``rho`` of each output with each parameter;
- ``"grid"``: ``rho`` plus the main effect: the mean output at each level of each parameter.

The virtual uncertain parameter ``natural_frequency_factor`` (c) detunes the linear natural
frequencies of the beam by the factor c while holding the nonlinear coefficient b* of docs/model.md §9:
Young's modulus E and the rotational clamping stiffness k_r are scaled by c² (so the ratio
κ = k_r L/(EI), hence the mode shapes and the matrix K, are unchanged and every ωₙ scales by c
exactly, for zero axial preload), and the axial clamping stiffness k_t is changed so that
k_ax = 1/(L/(EA) + 1/k_t), hence b = (k_ax/2) K₁₁² and b*, stay as they were. With k_t = ∞ it
stays ∞ and b* scales with c² instead.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _core
from .maps import BEHAVIOURS, COLOURS, LABELS, LETTERS, _toml_number, rows_to_table
from .params import Parameters

try:  # Python >= 3.11
    import tomllib as _toml
except ImportError:  # pragma: no cover
    import tomli as _toml  # type: ignore[no-redef]

RESULTS_FILE = "study.jsonl"
"""Name of the results file inside a study's output folder."""

FORMAT_VERSION = 1
"""The map results-file version the study files follow."""

METHODS = ("lhs", "sobol", "saltelli", "grid")
"""Sampling methods."""

DISTRIBUTIONS = ("uniform", "normal", "truncnormal", "lognormal", "triangular")
"""Distributions of an uncertain parameter (see :class:`Uncertain`)."""

VIRTUAL = ("natural_frequency_factor",)
"""Uncertain inputs that are not fields of :class:`Parameters` (see the module docstring)."""

OUTPUTS = ("s_final", "amplitude_final_h", "turn_s")
"""Row features summarised per operating point."""

_PARAM_FIELDS = {f.name for f in dataclasses.fields(Parameters)}


# --- configuration ------------------------------------------------------------------------------


@dataclass
class Uncertain:
    """One uncertain input and its distribution.

    ``name``: a :class:`Parameters` field (TOML key) or ``natural_frequency_factor``.
    ``distribution``: ``uniform`` (``low``, ``high``), ``normal`` (``mean``, ``std``),
    ``truncnormal`` (``mean``, ``std``, ``low``, ``high``), ``lognormal`` (``median``, ``sigma``:
    the standard deviation of the logarithm) or ``triangular`` (``low``, ``mode``, ``high``).
    ``levels``: the values of a ``grid`` study (default: ``low``, midpoint, ``high``)."""

    name: str
    distribution: str = "uniform"
    low: Optional[float] = None
    high: Optional[float] = None
    mean: Optional[float] = None
    std: Optional[float] = None
    median: Optional[float] = None
    sigma: Optional[float] = None
    mode: Optional[float] = None
    levels: Optional[List[float]] = None

    def __post_init__(self) -> None:
        if self.name not in _PARAM_FIELDS and self.name not in VIRTUAL:
            raise ValueError(f"invalid uncertain parameter {self.name!r}: must be a parameter name "
                             f"(TOML key of beamslider.Parameters) or one of {', '.join(VIRTUAL)}")
        if self.name in ("n_modes", "solver_max_iter", "contact_solver"):
            raise ValueError(f"invalid uncertain parameter {self.name!r}: not a continuous quantity")
        need = {"uniform": ("low", "high"), "normal": ("mean", "std"), "truncnormal": ("mean", "std", "low", "high"),
                "lognormal": ("median", "sigma"), "triangular": ("low", "mode", "high")}
        if self.distribution not in need:
            raise ValueError(f"invalid distribution {self.distribution!r} of `{self.name}`: must be one of "
                             f"{', '.join(DISTRIBUTIONS)}")
        for k in need[self.distribution]:
            v = getattr(self, k)
            if v is None or not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                raise ValueError(f"uncertain `{self.name}` ({self.distribution}) needs a finite number `{k}`")
        lo, hi = self.low, self.high
        if self.distribution in ("uniform", "truncnormal", "triangular") and not lo < hi:
            raise ValueError(f"uncertain `{self.name}`: need low < high, got low = {lo}, high = {hi}")
        if self.distribution in ("normal", "truncnormal") and not self.std > 0:
            raise ValueError(f"uncertain `{self.name}`: need std > 0, got {self.std}")
        if self.distribution == "lognormal" and not (self.sigma > 0 and self.median > 0):
            raise ValueError(f"uncertain `{self.name}`: need median > 0 and sigma > 0")
        if self.distribution == "triangular" and not lo <= self.mode <= hi:
            raise ValueError(f"uncertain `{self.name}`: need low <= mode <= high")
        if self.levels is not None:
            lv = [float(x) for x in self.levels]
            if not lv or not all(math.isfinite(x) for x in lv):
                raise ValueError(f"uncertain `{self.name}`: `levels` must be a non-empty list of finite numbers")
            self.levels = lv

    def frozen(self) -> Any:
        """The scipy.stats frozen distribution."""
        from scipy import stats

        d = self.distribution
        if d == "uniform":
            return stats.uniform(loc=self.low, scale=self.high - self.low)
        if d == "normal":
            return stats.norm(loc=self.mean, scale=self.std)
        if d == "truncnormal":
            a, b = (self.low - self.mean) / self.std, (self.high - self.mean) / self.std
            return stats.truncnorm(a, b, loc=self.mean, scale=self.std)
        if d == "lognormal":
            return stats.lognorm(s=self.sigma, scale=self.median)
        c = (self.mode - self.low) / (self.high - self.low)
        return stats.triang(c, loc=self.low, scale=self.high - self.low)

    def ppf(self, u: np.ndarray) -> np.ndarray:
        """Values at the probabilities ``u`` in (0, 1)."""
        return np.asarray(self.frozen().ppf(u), dtype=float)

    def grid_levels(self) -> List[float]:
        """Levels of a grid study."""
        if self.levels is not None:
            return list(self.levels)
        if self.low is not None and self.high is not None:
            return [float(self.low), 0.5 * (self.low + self.high), float(self.high)]
        f = self.frozen()
        return [float(x) for x in f.ppf([0.05, 0.5, 0.95])]

    def to_dict(self) -> Dict[str, Any]:
        return {k: v for k, v in dataclasses.asdict(self).items() if v is not None and k != "name"}


@dataclass
class StudyConfig:
    """A study: the operating points and settings of a map, the nominal parameters, the uncertain
    inputs and the sampling. As TOML (``beamslider study --config``)::

        duration_s = 120.0          # simulated time per run [s]
        # record_every = 20 ; dt_s = 2e-5
        [grid]                      # operating points, as in a map configuration
        f_ex_hz = [124.0]
        a_ex_m_s2 = [14.0]
        s0 = 0.3
        [params]                    # nominal parameters (defaults otherwise)
        [criteria]                  # classification thresholds (defaults otherwise)
        [study]
        method = "lhs"              # lhs | sobol | saltelli | grid
        samples = 64                # lhs/sobol: samples; saltelli: base N (N (D + 2) runs)
        seed = 1
        chunk_size = 4              # points per Dask task
        quantiles = [0.05, 0.5, 0.95]
        [uncertain.friction_coefficient]
        distribution = "uniform"
        low = 0.22
        high = 0.31
        [uncertain.natural_frequency_factor]
        distribution = "uniform"
        low = 0.95
        high = 1.05
    """

    uncertain: List[Uncertain]
    f_ex_hz: List[float] = field(default_factory=lambda: [124.0])
    a_ex_m_s2: List[float] = field(default_factory=lambda: [14.0])
    s0: List[float] = field(default_factory=lambda: [0.3])
    params: Parameters = field(default_factory=Parameters)
    duration_s: float = 120.0
    record_every: int = 20
    dt_s: Optional[float] = None
    criteria: Dict[str, float] = field(default_factory=dict)
    method: str = "lhs"
    samples: int = 32
    seed: int = 0
    chunk_size: int = 4
    quantiles: List[float] = field(default_factory=lambda: [0.05, 0.5, 0.95])

    def __post_init__(self) -> None:
        if not self.uncertain:
            raise ValueError("a study needs at least one [uncertain.<name>] table")
        self.uncertain = [u if isinstance(u, Uncertain) else Uncertain(**u) for u in self.uncertain]
        names = [u.name for u in self.uncertain]
        if len(set(names)) != len(names):
            raise ValueError(f"uncertain parameters named twice: {names}")
        if self.method not in METHODS:
            raise ValueError(f"invalid parameter `study.method` = {self.method!r}: must be one of {', '.join(METHODS)}")
        for k in ("samples", "chunk_size", "record_every"):
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"invalid parameter `{k}` = {v!r}: must be an integer >= 1")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise ValueError(f"invalid parameter `study.seed` = {self.seed!r}: must be an integer >= 0")
        if not all(0.0 <= q <= 1.0 for q in self.quantiles):
            raise ValueError(f"invalid parameter `study.quantiles` = {self.quantiles!r}: must lie in [0, 1]")
        if isinstance(self.params, dict):
            self.params = Parameters.from_dict(self.params)
        for name in ("f_ex_hz", "a_ex_m_s2", "s0"):
            v = getattr(self, name)
            setattr(self, name, [float(x) for x in np.atleast_1d(np.asarray(v, dtype=float))])
        # The core checks the operating points, duration, record_every, dt_s and criteria.
        self.map_toml()

    # --- TOML ---------------------------------------------------------------------------------
    @classmethod
    def from_toml_text(cls, text: str) -> "StudyConfig":
        """Parse study TOML (see the class docstring)."""
        try:
            d = _toml.loads(text)
        except _toml.TOMLDecodeError as e:
            raise ValueError(f"cannot read the study configuration: {e}") from None
        return cls.from_dict(d)

    @classmethod
    def from_toml(cls, path: Union[str, "os.PathLike[str]"]) -> "StudyConfig":
        """Read a study TOML file."""
        with open(os.fspath(path), "rb") as f:
            data = f.read()
        try:
            return cls.from_toml_text(data.decode("utf-8"))
        except ValueError as e:
            raise ValueError(f"{os.fspath(path)}: {e}") from None

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> "StudyConfig":
        """From the parsed TOML tables."""
        d = dict(d)
        allowed = {"duration_s", "record_every", "dt_s", "grid", "params", "criteria", "study", "uncertain"}
        unknown = sorted(set(d) - allowed)
        if unknown:
            raise ValueError(f"unknown key {unknown[0]!r} in the study configuration: allowed are {', '.join(sorted(allowed))}")
        grid = dict(d.get("grid", {}))
        kw: Dict[str, Any] = {}
        for key in ("f_ex_hz", "a_ex_m_s2", "s0"):
            if key in grid:
                kw[key] = _axis_values(f"grid.{key}", grid.pop(key))
        if grid:
            raise ValueError(f"unknown key {sorted(grid)[0]!r} in [grid]: allowed are f_ex_hz, a_ex_m_s2, s0")
        study = dict(d.get("study", {}))
        for key in ("method", "samples", "seed", "chunk_size", "quantiles"):
            if key in study:
                kw[key] = study.pop(key)
        if study:
            raise ValueError(f"unknown key {sorted(study)[0]!r} in [study]: allowed are method, samples, seed, chunk_size, quantiles")
        unc = d.get("uncertain", {})
        if not isinstance(unc, dict):
            raise ValueError("[uncertain] must hold one table per parameter: [uncertain.<name>]")
        uncertain = []
        for name, spec in unc.items():
            if not isinstance(spec, dict):
                raise ValueError(f"[uncertain.{name}] must be a table (distribution = ..., low = ..., ...)")
            fields_ = {f.name for f in dataclasses.fields(Uncertain)} - {"name"}
            bad = sorted(set(spec) - fields_)
            if bad:
                raise ValueError(f"unknown key {bad[0]!r} in [uncertain.{name}]: allowed are {', '.join(sorted(fields_))}")
            uncertain.append(Uncertain(name=name, **spec))
        for key in ("duration_s", "record_every", "dt_s"):
            if key in d:
                kw[key] = d[key]
        return cls(uncertain=uncertain, params=Parameters.from_dict(d.get("params", {})),
                   criteria=dict(d.get("criteria", {})), **kw)

    def to_dict(self) -> Dict[str, Any]:
        """The configuration as plain data (the tables of the TOML file)."""
        d: Dict[str, Any] = {"duration_s": float(self.duration_s), "record_every": int(self.record_every)}
        if self.dt_s is not None:
            d["dt_s"] = float(self.dt_s)
        d["grid"] = {"f_ex_hz": list(self.f_ex_hz), "a_ex_m_s2": list(self.a_ex_m_s2), "s0": list(self.s0)}
        d["params"] = self.params.to_dict()
        d["criteria"] = dict(self.criteria)
        d["study"] = {"method": self.method, "samples": int(self.samples), "seed": int(self.seed),
                      "chunk_size": int(self.chunk_size), "quantiles": [float(q) for q in self.quantiles]}
        d["uncertain"] = {u.name: u.to_dict() for u in self.uncertain}
        return d

    def to_toml_text(self) -> str:
        """TOML text of the study (readable by :meth:`from_toml_text`)."""
        return _dump_toml(self.to_dict())

    def map_toml(self) -> str:
        """The map configuration the core runs each point with (grid = the operating points)."""
        lines = [f"duration_s = {_toml_number(float(self.duration_s))}", f"record_every = {int(self.record_every)}"]
        if self.dt_s is not None:
            lines.append(f"dt_s = {_toml_number(float(self.dt_s))}")
        lines += ["", "[grid]"]
        for key in ("f_ex_hz", "a_ex_m_s2", "s0"):
            lines.append(f"{key} = [{', '.join(_toml_number(v) for v in getattr(self, key))}]")
        lines += ["", "[params]", self.params.toml_text().strip()]
        if self.criteria:
            lines += ["", "[criteria]"] + [f"{k} = {_toml_number(v)}" for k, v in self.criteria.items()]
        text = "\n".join(lines) + "\n"
        _core.map_config(text)  # validates
        return text

    # --- design -------------------------------------------------------------------------------
    @property
    def names(self) -> List[str]:
        """Names of the uncertain inputs, in order."""
        return [u.name for u in self.uncertain]

    def operating_points(self) -> List[Tuple[float, float, float]]:
        """(f_ex, a_ex, s0) in map order: s0 slowest, then a_ex, f_ex fastest."""
        return [(f, a, s) for s in self.s0 for a in self.a_ex_m_s2 for f in self.f_ex_hz]

    def design(self) -> np.ndarray:
        """The samples of the uncertain inputs: array (n_samples, D), deterministic given ``seed``."""
        return sample(self.uncertain, self.method, self.samples, seed=self.seed)


def _axis_values(name: str, v: Any) -> List[float]:
    if isinstance(v, dict):
        try:
            start, stop, step = float(v["start"]), float(v["stop"]), float(v["step"])
        except (KeyError, TypeError, ValueError):
            raise ValueError(f"invalid `{name}`: a range needs numbers start, stop, step") from None
        if not (step > 0 and stop >= start):
            raise ValueError(f"invalid `{name}`: need start <= stop and step > 0")
        n = int(math.floor((stop - start) / step + 1e-3)) + 1
        return [round((start + i * step) * 1e9) / 1e9 for i in range(n)]
    arr = np.atleast_1d(np.asarray(v, dtype=float))
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"invalid `{name}`: give a number, a list or {{start, stop, step}}")
    return [float(x) for x in arr]


def _dump_value(v: Any) -> str:
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_dump_value(x) for x in v) + "]"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return _toml_number(v)


def _dump_toml(d: Dict[str, Any]) -> str:
    out: List[str] = []
    for k, v in d.items():
        if not isinstance(v, dict):
            out.append(f"{k} = {_dump_value(v)}")
    for k, v in d.items():
        if isinstance(v, dict):
            sub = {kk: vv for kk, vv in v.items() if not isinstance(vv, dict)}
            if sub or len(sub) == len(v):
                out += ["", f"[{k}]"] + [f"{kk} = {_dump_value(vv)}" for kk, vv in sub.items()]
            for kk, vv in v.items():
                if isinstance(vv, dict):
                    out += ["", f"[{k}.{kk}]"] + [f"{a} = {_dump_value(b)}" for a, b in vv.items()]
    return "\n".join(out).lstrip("\n") + "\n"


def read_config(path: Union[str, "os.PathLike[str]"]) -> StudyConfig:
    """Read a study configuration (TOML)."""
    return StudyConfig.from_toml(path)


# --- sampling -----------------------------------------------------------------------------------


def _saltelli_matrices(d: int, n: int, seed: int) -> Tuple[np.ndarray, np.ndarray]:
    from scipy.stats import qmc

    base = qmc.Sobol(d=2 * d, scramble=True, seed=seed).random(n)
    return base[:, :d], base[:, d:]


def sample(uncertain: Sequence[Uncertain], method: str, samples: int, *, seed: int = 0) -> np.ndarray:
    """Samples of the uncertain inputs, shape (n, D).

    ``lhs``: ``samples`` points of a Latin hypercube (scipy.stats.qmc.LatinHypercube); ``sobol``:
    the first ``samples`` points of a scrambled Sobol' sequence; ``saltelli``: N = ``samples``
    base points in the order A, B, AB_1, …, AB_D (N (D + 2) rows); ``grid``: all combinations of
    the levels (``samples`` is ignored). Probabilities are mapped through each distribution's
    inverse CDF."""
    from scipy.stats import qmc

    d = len(uncertain)
    if method == "grid":
        levels = [u.grid_levels() for u in uncertain]
        mesh = np.meshgrid(*levels, indexing="ij")
        return np.column_stack([m.ravel() for m in mesh])
    if method == "lhs":
        u = qmc.LatinHypercube(d=d, seed=seed).random(samples)
    elif method == "sobol":
        u = qmc.Sobol(d=d, scramble=True, seed=seed).random(samples)
    elif method == "saltelli":
        a, b = _saltelli_matrices(d, samples, seed)
        blocks = [a, b]
        for i in range(d):
            ab = a.copy()
            ab[:, i] = b[:, i]
            blocks.append(ab)
        u = np.vstack(blocks)
    else:
        raise ValueError(f"invalid sampling method {method!r}: must be one of {', '.join(METHODS)}")
    u = np.clip(u, 1e-12, 1 - 1e-12)
    return np.column_stack([unc.ppf(u[:, i]) for i, unc in enumerate(uncertain)])


def apply_sample(params: Parameters, values: Dict[str, float]) -> Parameters:
    """``params`` with the uncertain values set (virtual inputs realised, see the module docstring)."""
    d = params.to_dict()
    d.update({k: float(v) for k, v in values.items() if k not in VIRTUAL})
    if "natural_frequency_factor" in values:  # relative to the sampled E, k_r, k_t
        d.update(detune(Parameters.from_dict(d), float(values["natural_frequency_factor"])))
    return Parameters.from_dict(d)


def detune(params: Parameters, factor: float) -> Dict[str, float]:
    """Parameter values that scale every linear natural frequency by ``factor`` (c) at constant
    mode shapes and constant nonlinear coefficient b*: E → c² E, k_r → c² k_r and k_t such that
    k_ax = 1/(L/(EA) + 1/k_t) is unchanged (k_t = ∞ stays ∞)."""
    c2 = float(factor) ** 2
    if not (math.isfinite(c2) and c2 > 0):
        raise ValueError(f"invalid natural_frequency_factor = {factor!r}: must be finite and > 0")
    p = params
    area = p.beam_mass_kg / (p.density_kg_m3 * p.length_m)
    e_new = p.youngs_modulus_pa * c2
    out = {"youngs_modulus_pa": e_new, "k_r_nm_per_rad": p.k_r_nm_per_rad * c2}
    if math.isfinite(p.k_t_n_per_m):
        inv = 1.0 / p.k_t_n_per_m + p.length_m / (p.youngs_modulus_pa * area) - p.length_m / (e_new * area)
        if not inv > 0:
            raise ValueError(f"natural_frequency_factor = {factor}: no axial clamping stiffness k_t keeps b* "
                             f"(the beam alone is then softer axially than the nominal beam and frame)")
        out["k_t_n_per_m"] = 1.0 / inv
    return out


@dataclass
class StudyPoint:
    """One run of a study."""

    index: int
    """Position in the study (sample * n_operating_points + point)."""
    sample: int
    """Row of the design."""
    point: int
    """Operating point (map order)."""
    values: Dict[str, float]
    """The uncertain inputs."""
    params_toml: str
    """Full parameters of the run (canonical TOML)."""
    f_ex_hz: float
    a_ex_m_s2: float
    s0: float
    duration_s: float

    def chunk_tuple(self) -> Tuple[int, str, float, float, float, float]:
        return (self.index, self.params_toml, self.f_ex_hz, self.a_ex_m_s2, self.s0, self.duration_s)


def study_points(config: StudyConfig) -> List[StudyPoint]:
    """All runs of the study: every design row at every operating point (sample slowest)."""
    design = config.design()
    ops = config.operating_points()
    out: List[StudyPoint] = []
    for i, row in enumerate(design):
        values = {n: float(v) for n, v in zip(config.names, row)}
        text = apply_sample(config.params, values).toml_text()
        for j, (f, a, s) in enumerate(ops):
            out.append(StudyPoint(index=i * len(ops) + j, sample=i, point=j, values=values, params_toml=text,
                                  f_ex_hz=f, a_ex_m_s2=a, s0=s, duration_s=float(config.duration_s)))
    return out


# --- results file -------------------------------------------------------------------------------


def _header(config: StudyConfig) -> Dict[str, Any]:
    settings = json.loads(_core.map_settings_json(config.map_toml()))
    return {"beamslider_map": FORMAT_VERSION, "settings": settings,
            "study": {"config": config.to_dict(), "n_points": len(config.operating_points()) * len(config.design())}}


def read_results(path: Union[str, Path]) -> Tuple[Optional[Dict[str, Any]], List[Dict[str, Any]], int, bool]:
    """Read a study results file (or its folder): (header, rows, byte length of the complete part,
    truncated). An incomplete or unparsable *last* line (a client killed while writing) is ignored;
    a bad line elsewhere is a ``ValueError``."""
    path = Path(path)
    if path.is_dir():
        path = path / RESULTS_FILE
    header, rows, good, truncated = None, [], 0, False
    with open(path, "rb") as f:
        lines = f.read().split(b"\n")
    tail = lines.pop()  # text after the last newline: empty, or a truncated line
    if tail:
        truncated = True
    for k, raw in enumerate(lines):
        try:
            obj = json.loads(raw.decode("utf-8")) if raw.strip() else None
        except (ValueError, UnicodeDecodeError):
            if k == len(lines) - 1:
                truncated = True
                break
            raise ValueError(f"{path}:{k + 1}: a line in the middle of the file is not a complete result row") from None
        if k == 0:
            if not isinstance(obj, dict) or "beamslider_map" not in obj:
                raise ValueError(f"{path}: not a beamslider results file (no header line)")
            if obj["beamslider_map"] != FORMAT_VERSION:
                raise ValueError(f"{path}: format version {obj['beamslider_map']} (this version reads {FORMAT_VERSION})")
            header = obj
        elif obj is not None:
            rows.append(obj)
        good += len(raw) + 1
    return header, rows, good, truncated


class _Writer:
    """Appends rows to the results file, one JSON line each, flushed at once."""

    def __init__(self, path: Path, config: StudyConfig, points: Dict[int, StudyPoint], resume: bool) -> None:
        self.path = path
        self.points = points
        self.rows: Dict[int, Dict[str, Any]] = {}
        header = _header(config)
        exists = path.exists() and path.stat().st_size > 0
        if exists and not resume:
            raise ValueError(f"{path}: the results file exists: resume it, or choose another output")
        if exists:
            old, rows, good, _trunc = read_results(path)
            if old is not None and (old.get("settings") != header["settings"] or old.get("study") != header["study"]):
                raise ValueError(f"{path}: the results file was written by another study configuration")
            with open(path, "r+b") as f:
                f.truncate(good)
            for r in rows:
                self._check(r)
                self.rows[int(r["index"])] = r
            self.f = open(path, "a", encoding="utf-8")
            if old is None:
                self._line(header)
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            self.f = open(path, "w", encoding="utf-8")
            self._line(header)

    def _check(self, r: Dict[str, Any]) -> None:
        p = self.points.get(int(r.get("index", -1)))
        if p is None or (r["f_ex_hz"], r["a_ex_m_s2"], r["s0"]) != (p.f_ex_hz, p.a_ex_m_s2, p.s0) \
                or r.get("params") != p.values:
            raise ValueError(f"{self.path}: row {r.get('index')} does not belong to this study")

    def _line(self, obj: Dict[str, Any]) -> None:
        self.f.write(json.dumps(obj, separators=(",", ":")) + "\n")
        self.f.flush()

    def add(self, texts: Sequence[str]) -> None:
        for t in texts:
            r = json.loads(t)
            i = int(r["index"])
            if i in self.rows:  # a chunk re-run after a lost worker may repeat a row
                continue
            p = self.points[i]
            r["sample"], r["point"], r["params"] = p.sample, p.point, dict(p.values)
            self._line(r)
            self.rows[i] = r

    def close(self) -> None:
        self.f.close()


class _Memory(_Writer):
    def __init__(self, points: Dict[int, StudyPoint]) -> None:  # noqa: D401 - rows in memory only
        self.points, self.rows, self.path = points, {}, None

    def _line(self, obj: Dict[str, Any]) -> None:
        pass

    def close(self) -> None:
        pass


# --- execution ----------------------------------------------------------------------------------


def _run_chunk(map_toml: str, chunk: List[Tuple[int, str, float, float, float, float]],
               threads: Optional[int]) -> List[str]:
    """A Dask task: one chunk of points through the Rust core (rayon, interpreter released)."""
    from beamslider import _core as core

    return core.run_study_chunk(map_toml, chunk, threads=threads)


def _chunks(todo: List[StudyPoint], size: int) -> List[List[StudyPoint]]:
    return [todo[i:i + size] for i in range(0, len(todo), size)]


def _run_dask(scheduler: Any, map_toml: str, todo: List[StudyPoint], writer: _Writer, *, chunk_size: int,
              task_threads: Optional[int], max_retries: int, on_chunk: Optional[Callable[[int, int], None]],
              tick: Callable[[], None]) -> None:
    try:
        from distributed import Client, as_completed
    except ImportError:  # pragma: no cover
        raise ImportError("running a study on a cluster needs dask.distributed: pip install 'beamslider[study]'") from None
    own = not isinstance(scheduler, Client)
    client = Client(scheduler) if own else scheduler
    tag = hashlib.sha1(map_toml.encode()).hexdigest()[:10]
    chunks = _chunks(todo, chunk_size)
    try:
        futures = {}
        for k, ch in enumerate(chunks):
            fut = client.submit(_run_chunk, map_toml, [p.chunk_tuple() for p in ch], task_threads,
                                key=f"beamslider-study-{tag}-{ch[0].index}-{ch[-1].index}-{time.time_ns()}", pure=False)
            futures[fut] = (k, 0)
        ac = as_completed(list(futures))
        done = 0
        for fut in ac:
            k, tries = futures.pop(fut)
            try:
                rows = fut.result()
            except Exception as e:  # a lost worker (KilledWorker, CommClosedError, ...) or a bad point
                if isinstance(e, (ValueError, KeyboardInterrupt)) or tries >= max_retries:
                    raise
                ch = chunks[k]
                new = client.submit(_run_chunk, map_toml, [p.chunk_tuple() for p in ch], task_threads,
                                    key=f"beamslider-study-{tag}-{ch[0].index}-{ch[-1].index}-r{tries + 1}-{time.time_ns()}",
                                    pure=False)
                futures[new] = (k, tries + 1)
                ac.add(new)
                continue
            writer.add(rows)
            done += 1
            tick()
            if on_chunk is not None:
                on_chunk(done, len(chunks))
    finally:
        for fut in list(futures):
            fut.cancel()
        if own:
            client.close()


def run_study(config: Union[StudyConfig, str, "os.PathLike[str]"], *, out: Optional[Union[str, Path]] = None,
              resume: bool = False, scheduler: Any = None, threads: Optional[int] = None,
              chunk_size: Optional[int] = None, task_threads: Optional[int] = 1, max_retries: int = 3,
              progress: bool = False, on_chunk: Optional[Callable[[int, int], None]] = None) -> "StudyResult":
    """Run a study and aggregate it.

    ``config``: a :class:`StudyConfig` or the path of its TOML file. ``out``: output folder; every
    finished point is appended to ``out/study.jsonl`` at once (and the configuration written to
    ``out/study.toml``); ``resume=True`` keeps the points already there and runs the rest.

    Local (``scheduler=None``): all points in one call of the Rust core on ``threads`` threads
    (default one per core). Dask (``scheduler`` = a scheduler address such as
    ``"tcp://10.0.0.5:8786"`` or a ``distributed.Client``): chunks of ``chunk_size`` points (default
    the configuration's) as tasks, each on ``task_threads`` rayon threads (default 1: Dask already
    runs one task per worker thread); a chunk whose worker died is re-run (up to ``max_retries``
    times on top of Dask's own retries). ``on_chunk(done, total)`` is called after each finished
    chunk (Dask). Ctrl-C stops the study keeping the finished points (``KeyboardInterrupt``).
    """
    from .simulate import _progress_bar

    if not isinstance(config, StudyConfig):
        config = read_config(config)
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1):
        raise ValueError(f"invalid parameter `threads` = {threads!r}: must be an integer >= 1")
    size = config.chunk_size if chunk_size is None else chunk_size
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 1:
        raise ValueError(f"invalid parameter `chunk_size` = {size!r}: must be an integer >= 1")
    map_toml = config.map_toml()
    points = study_points(config)
    by_index = {p.index: p for p in points}
    if out is not None:
        folder = Path(out)
        folder.mkdir(parents=True, exist_ok=True)
        writer: _Writer = _Writer(folder / RESULTS_FILE, config, by_index, resume)
        (folder / "study.toml").write_text(config.to_toml_text(), encoding="utf-8")
    else:
        writer = _Memory(by_index)
    todo = [p for p in points if p.index not in writer.rows]
    try:
        with _progress_bar(progress, len(points), "study", "pts") as cb:
            def tick() -> None:
                if cb is not None:
                    cb(len(writer.rows), len(points))

            tick()
            if todo and scheduler is None:
                def on_rows(batch: List[str]) -> None:
                    writer.add(batch)
                    tick()

                writer.add(_core.run_study_chunk(map_toml, [p.chunk_tuple() for p in todo], threads=threads,
                                                 on_rows=on_rows))
            elif todo:
                _run_dask(scheduler, map_toml, todo, writer, chunk_size=int(size), task_threads=task_threads,
                          max_retries=max_retries, on_chunk=on_chunk, tick=tick)
    finally:
        writer.close()
    missing = [i for i in by_index if i not in writer.rows]
    if missing:  # pragma: no cover - every path above either completes or raises
        raise RuntimeError(f"{len(missing)} points of the study are missing")
    return aggregate(config, [writer.rows[i] for i in sorted(writer.rows)])


# --- aggregation --------------------------------------------------------------------------------


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
    table: Dict[str, np.ndarray]
    """One entry per run, sorted by index: the map row columns (:func:`maps.rows_to_table`) plus
    ``sample``, ``point`` and ``param_<name>`` for each uncertain input."""
    points: List[PointSummary]
    """One summary per operating point, in map order."""

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


def _json_safe(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_safe(v) for v in x]
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    return x


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
    table = rows_to_table(rows)
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


# --- figures ------------------------------------------------------------------------------------


def plot_behaviour_probability(result: StudyResult, *, s0: Optional[float] = None, path: Optional[Union[str, Path]] = None,
                               ax: Any = None, title: Optional[str] = None) -> Any:
    """Map of the most probable behaviour over (f_ex, a_ex), each cell shaded by its probability
    (full colour = 1) and labelled with it. Returns the figure; writes it to ``path`` when given."""
    from ._mpl import require_matplotlib

    require_matplotlib("plot_behaviour_probability")
    from matplotlib.colors import to_rgb
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch, Rectangle

    pts = result.points
    s0s = sorted({p.s0 for p in pts})
    s0 = s0s[0] if s0 is None else s0
    pts = [p for p in pts if p.s0 == s0]
    fs = np.array(sorted({p.f_ex_hz for p in pts}))
    as_ = np.array(sorted({p.a_ex_m_s2 for p in pts}))
    dfs = np.diff(fs).min() if len(fs) > 1 else 2.0
    das = np.diff(as_).min() if len(as_) > 1 else 2.0
    if ax is None:
        fig = Figure(figsize=(7.5, 4.2), layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    present = set()
    for p in pts:
        b, pr = p.most_probable, p.probabilities[p.most_probable]
        present.add(b)
        rgb = np.array(to_rgb(COLOURS.get(b, "#ffffff")))
        shade = 1.0 - pr * (1.0 - rgb)  # white at probability 0, full colour at 1
        ax.add_patch(Rectangle((p.f_ex_hz - dfs / 2, p.a_ex_m_s2 - das / 2), dfs, das, facecolor=shade,
                               edgecolor="k", linewidth=0.4, hatch="//" if b == "undetermined" else None))
        if len(fs) * len(as_) <= 150:
            ax.text(p.f_ex_hz, p.a_ex_m_s2, f"{LETTERS[b]}\n{pr:.2f}", ha="center", va="center", fontsize=7)
    ax.set_xlim(fs[0] - dfs / 2, fs[-1] + dfs / 2)
    ax.set_ylim(as_[0] - das / 2, as_[-1] + das / 2)
    ax.set_xticks(fs if len(fs) <= 20 else fs[:: int(np.ceil(len(fs) / 20))])
    ax.set_yticks(as_)
    ax.set_xlabel(r"excitation frequency $f_\mathrm{ex}$ [Hz]")
    ax.set_ylabel(r"excitation level $a_\mathrm{ex}$ [m/s$^2$]")
    ax.set_title(title if title is not None else
                 f"most probable behaviour (shade = probability), $s_0$ = {s0:g}, {result.points[0].n} samples")
    handles = [Patch(facecolor=COLOURS[b], edgecolor="k", label=LABELS[b]) for b in BEHAVIOURS if b in present]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False, fontsize=9)
    if path is not None:
        fig.savefig(str(path), dpi=150)
    return fig


def plot_sensitivity(result: StudyResult, *, point: int = 0, path: Optional[Union[str, Path]] = None,
                     outputs: Sequence[str] = ("s_final", "amplitude_final_h")) -> Any:
    """Bars of the sensitivity indices at one operating point (index in map order): one panel per
    output, one group per uncertain input (S1 and ST with their 95 % intervals for a saltelli
    study, the rank correlation otherwise)."""
    from ._mpl import require_matplotlib

    require_matplotlib("plot_sensitivity")
    from matplotlib.figure import Figure

    p = result.points[point]
    names = result.config.names
    fig = Figure(figsize=(3.4 * len(outputs) + 0.6, 3.4), layout="constrained")
    axes = fig.subplots(1, len(outputs), squeeze=False)[0]
    x = np.arange(len(names))
    for ax, out in zip(axes, outputs):
        ind = p.sensitivity.get(out, {})
        if result.config.method == "saltelli":
            for k, (key, off, col) in enumerate((("S1", -0.18, "#1f77b4"), ("ST", 0.18, "#ff7f0e"))):
                v = np.array([ind[n][key] for n in names])
                e = np.array([ind[n][key + "_conf"] for n in names])
                ax.bar(x + off, v, width=0.36, yerr=e, color=col, capsize=3, label=key)
            ax.set_ylim(min(0.0, ax.get_ylim()[0]), max(1.05, ax.get_ylim()[1]))
            ax.legend(frameon=False, fontsize=8)
        else:
            v = np.array([ind[n]["rho"] for n in names])
            ax.bar(x, v, width=0.6, color="#1f77b4")
            ax.set_ylim(-1.05, 1.05)
            ax.axhline(0, color="k", linewidth=0.6)
        ax.set_xticks(x)
        ax.set_xticklabels([n.replace("_", "\n", 1) for n in names], fontsize=7)
        ax.set_title(out, fontsize=9)
    axes[0].set_ylabel("Sobol' index" if result.config.method == "saltelli" else "Spearman rank correlation")
    fig.suptitle(f"sensitivity at ({p.f_ex_hz:g} Hz, {p.a_ex_m_s2:g} m/s², $s_0$ = {p.s0:g}), {p.n} runs", fontsize=10)
    if path is not None:
        fig.savefig(str(path), dpi=150)
    return fig


# --- command line -------------------------------------------------------------------------------


EXAMPLE_CONFIG = StudyConfig(
    uncertain=[Uncertain("friction_coefficient", "uniform", low=0.22, high=0.31),
               Uncertain("natural_frequency_factor", "uniform", low=0.95, high=1.05)],
    method="lhs", samples=16, seed=1)


def add_cli(sub: Any, common: Callable[..., None]) -> None:
    """Register ``beamslider study`` on the CLI's subparsers (``common`` adds --out/--no-progress)."""
    sp = sub.add_parser("study", help="uncertainty study: behaviour probabilities and sensitivities (local or Dask)",
                        description="Sample the uncertain parameters of a study configuration (TOML), run the free "
                                    "slider at every sample and operating point (locally with one thread per core, or "
                                    "on a Dask cluster with --scheduler) and aggregate behaviour probabilities, "
                                    "statistics and sensitivity indices. Each finished run is appended to "
                                    "DIR/study.jsonl at once; --resume runs only the missing ones. Writes study.toml, "
                                    "summary.json, summary.txt, behaviour_probability.png and sensitivity*.png.")
    sp.add_argument("--config", metavar="TOML", help="study configuration (see --print-config)")
    sp.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address, e.g. tcp://host:8786 (default: local)")
    sp.add_argument("--threads", "-j", type=int, metavar="N", help="local worker threads (default: one per core)")
    sp.add_argument("--chunk-size", type=int, metavar="N", help="points per Dask task (default: the configuration's)")
    sp.add_argument("--task-threads", type=int, default=1, metavar="N", help="rayon threads per Dask task (1)")
    sp.add_argument("--resume", action="store_true", help="continue the study in --out, skipping finished runs")
    sp.add_argument("--print-config", action="store_true", help="print an example configuration (TOML) and exit")
    common(sp, model_options=False)
    sp.set_defaults(func=cmd_study)


def cmd_study(args: Any) -> int:
    """``beamslider study``."""
    if args.print_config:
        print(EXAMPLE_CONFIG.to_toml_text(), end="")
        return 0
    if not args.config:
        raise ValueError("beamslider study needs --config study.toml (an example: beamslider study --print-config)")
    if not Path(args.config).is_file():
        raise ValueError(f"{args.config}: no such file")
    config = read_config(args.config)
    out = Path(args.out)
    t0 = time.perf_counter()
    res = run_study(config, out=out, resume=args.resume, scheduler=args.scheduler, threads=args.threads,
                    chunk_size=args.chunk_size, task_threads=args.task_threads, progress=args.progress)
    wall = time.perf_counter() - t0
    written = write_outputs(res, out)
    print(res.text(), end="")
    print(f"{len(res.table['index'])} runs in {wall:.1f} s")
    for p in [out / RESULTS_FILE, out / "study.toml", *written]:
        print(f"wrote {p}")
    return 0


def write_outputs(result: StudyResult, out: Union[str, Path]) -> List[Path]:
    """Write summary.json, summary.txt, behaviour_probability.png (per s0) and sensitivity.png (per
    operating point) into ``out``; returns the paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "summary.json", out / "summary.txt"]
    paths[0].write_text(json.dumps(result.summary_dict(), indent=1) + "\n", encoding="utf-8")
    paths[1].write_text(result.text(), encoding="utf-8")
    s0s = sorted({p.s0 for p in result.points})
    for s0 in s0s:
        p = out / ("behaviour_probability.png" if len(s0s) == 1 else f"behaviour_probability_s0_{s0:g}.png")
        plot_behaviour_probability(result, s0=s0, path=p)
        paths.append(p)
    n = len(result.points)
    for j in range(n if n <= 12 else 0):
        p = out / ("sensitivity.png" if n == 1 else f"sensitivity_{j}.png")
        plot_sensitivity(result, point=j, path=p)
        paths.append(p)
    return paths
