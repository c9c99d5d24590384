"""Study configuration: the uncertain inputs (:class:`Uncertain`) and :class:`StudyConfig` (TOML in and out)."""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _core, _toml
from ..maps.config import map_config
from ..params import Parameters

RESULTS_FILE = "study.jsonl"
"""Name of the results file inside a study's output folder."""

FORMAT_VERSION: int = _core.RESULTS_FORMAT_VERSION
"""The map results-file version the study files follow (the core's, docs/model.md §8)."""

METHODS = ("lhs", "sobol", "saltelli", "grid")
"""Sampling methods."""

DISTRIBUTIONS = ("uniform", "normal", "truncnormal", "lognormal", "triangular")
"""Distributions of an uncertain parameter (see :class:`Uncertain`)."""

VIRTUAL = ("natural_frequency_factor",)
"""Uncertain inputs that are not fields of :class:`Parameters` (see the module docstring)."""

OUTPUTS = ("s_final", "amplitude_final_h", "turn_s")
"""Row features summarised per operating point."""

_PARAM_FIELDS = {f.name for f in dataclasses.fields(Parameters)}


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
        if not isinstance(self.distribution, str) or self.distribution not in need:
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
        stray = [k for k in ("low", "high", "mean", "std", "median", "sigma", "mode")
                 if k not in need[self.distribution] and getattr(self, k) is not None]
        if stray:
            raise ValueError(f"uncertain `{self.name}` ({self.distribution}) does not use `{stray[0]}`: "
                             f"a {self.distribution} distribution takes {', '.join(need[self.distribution])}")
        if self.levels is not None:
            if not isinstance(self.levels, (list, tuple, np.ndarray)) or not all(
                    isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool) for x in self.levels):
                raise ValueError(f"uncertain `{self.name}`: `levels` = {self.levels!r} must be a non-empty list of finite numbers")
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


def uncertain_from_dict(unc: Any) -> List[Uncertain]:
    """The uncertain inputs of a configuration's ``[uncertain.<name>]`` tables (study and design
    files); a ValueError naming the table for a malformed one."""
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
    return uncertain


@dataclass
class StudyConfig(_toml.ConfigFile):
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

    TOML_KIND = "study"

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
        if not isinstance(self.quantiles, (list, tuple)) or not all(
                isinstance(q, (int, float)) and not isinstance(q, bool) and 0.0 <= q <= 1.0 for q in self.quantiles):
            raise ValueError(f"invalid parameter `study.quantiles` = {self.quantiles!r}: must lie in [0, 1]")
        if isinstance(self.params, dict):
            self.params = Parameters.from_dict(self.params)
        for name in ("f_ex_hz", "a_ex_m_s2", "s0"):
            v = getattr(self, name)
            setattr(self, name, [float(x) for x in np.atleast_1d(np.asarray(v, dtype=float))])
        # The core checks the operating points, duration, record_every, dt_s and criteria.
        self.map_config()

    # --- TOML ---------------------------------------------------------------------------------
    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> "StudyConfig":
        """From the parsed TOML tables."""
        d = dict(d)
        for key in ("grid", "study", "params", "criteria", "uncertain"):
            if not isinstance(d.get(key, {}), dict):
                raise ValueError(f"`{key}` in the study configuration must be a table ([{key}]), got {d[key]!r:.40}")
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
        uncertain = uncertain_from_dict(d.get("uncertain", {}))
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
        return _toml.dumps(self.to_dict())

    def map_config(self) -> "_core.MapConfig":
        """The map configuration the core runs each point with (grid = the operating points), parsed
        and checked once by the core."""
        return map_config(self.params, f_ex=self.f_ex_hz, a_ex=self.a_ex_m_s2, s0=self.s0, t_end=self.duration_s,
                          record_every=self.record_every, dt_s=self.dt_s, criteria=self.criteria)

    def map_toml(self) -> str:
        """The canonical TOML text of :meth:`map_config`."""
        return self.map_config().toml()

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


def _axis_values(name: str, v: Any) -> List[float]:
    if isinstance(v, dict):
        try:
            start, stop, step = float(v["start"]), float(v["stop"]), float(v["step"])
        except (KeyError, TypeError, ValueError):
            raise ValueError(f"invalid `{name}`: a range needs numbers start, stop, step") from None
        if not (step > 0 and stop >= start and math.isfinite(start) and math.isfinite(stop)):
            raise ValueError(f"invalid `{name}`: need finite start <= stop and step > 0")
        span = (stop - start) / step
        if not span < _core.MAX_AXIS_VALUES:
            raise ValueError(f"invalid `{name}`: {span:.3g} values, at most {_core.MAX_AXIS_VALUES}")
        n = int(math.floor(span + 1e-3)) + 1
        return [round((start + i * step) * 1e9) / 1e9 for i in range(n)]
    try:
        arr = np.atleast_1d(np.asarray(v, dtype=float))
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"invalid `{name}`: give a number, a list or {{start, stop, step}}") from None
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"invalid `{name}`: give a number, a list or {{start, stop, step}}")
    return [float(x) for x in arr]


def read_config(path: Union[str, "os.PathLike[str]"]) -> StudyConfig:
    """Read a study configuration (TOML)."""
    return StudyConfig.from_toml(path)
