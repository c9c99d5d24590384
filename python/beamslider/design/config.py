"""Design configuration (user guide: design search): the design variables (``[design]``: any :class:`Parameters`
field with bounds), the band of operating points, the objective, the constraints, the optimiser
settings and (optionally) the uncertain inputs of a robust objective. TOML in and out."""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np

from .. import _core, _toml
from ..maps.config import map_config
from ..params import Parameters
from ..study.config import Uncertain, sample, uncertain_from_dict

RESULTS_FILE = "design.jsonl"
"""Name of the results file inside a design run's output folder."""

EVALUATORS = ("fs", "predictor")
"""``fs``: free-slider runs through the core's batch runner; ``predictor``: the reduced super-slow
predictor (:func:`beamslider.superslow.predicted_map`), best designs re-checked with FS."""

OBJECTIVES = ("bandwidth", "harvest")
ROBUST = ("none", "mean", "quantile")
INITS = ("latinhypercube", "sobol", "halton", "random")

_PARAM_FIELDS = [f.name for f in dataclasses.fields(Parameters)]
_NOT_CONTINUOUS = ("n_modes", "solver_max_iter", "contact_solver")

EXAMPLE_TOML = """\
# beamslider design configuration (beamslider design --print-config)
evaluator = "fs"                 # fs | predictor (drift_law = "default", the built-in design law, or a law file)
seed = 1                         # the optimiser's seed: same seed, same designs, same result

[design]                         # design variables: a Parameters field = [low, high]
gap_ratio = [1.02, 1.3]
slider_mass_kg = [0.02, 0.06]

[band]                           # operating points every design is run at
f_lo_hz = 100.0
f_hi_hz = 130.0
f_step_hz = 5.0
a_ex_m_s2 = [10.0, 14.0]
s0 = [0.3]
t_end_s = 30.0                   # the paper's maps use 120 s
a_min_h = 0.3                    # adapted = trivial adaption or signature move with A_final >= a_min_h

[objective]
maximise = "bandwidth"           # bandwidth [Hz] | harvest (mean (A/h)^2 over the band)
robust = "none"                  # none | mean | quantile (over the [uncertain] sample)
harvest_weight_hz = 1.0          # tie-break: score = bandwidth + weight * harvest

[constraints]
max_slider_mass_kg = 0.06
min_gap_ratio = 1.0              # jam limit (see the jam report)

[optimiser]                      # scipy.optimize.differential_evolution
popsize = 4                      # population = popsize * number of variables
maxiter = 2                      # generations after the initial population
init = "latinhypercube"
include_prototype = true         # the base parameters are a member of the first population
scale_inertia = true             # J_C scaled with m (B/B0)^2 when slider_mass_kg / contact_spacing_m vary
recheck = 2                      # FS re-checks of the best designs (predictor search)
recheck_tolerance_hz = 0.0       # > 0: re-check designs spread over those scoring within this of the best

# [reference.fs_only_best]       # named designs re-checked with FS beside the search's best
# gap_ratio = 1.064              # (variables not given keep the base value)
# slider_mass_kg = 0.04259

# [params]                       # base design (default: the paper's prototype)
# [uncertain.friction_coefficient]
# distribution = "uniform"
# low = 0.22
# high = 0.31
# [uncertain.natural_frequency_factor]
# distribution = "uniform"
# low = 0.95
# high = 1.05
# [sampling]                     # the FIXED sample of the uncertain inputs
# method = "lhs"
# samples = 4
# seed = 0
"""


def _num(name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not math.isfinite(float(v)):
        raise ValueError(f"invalid parameter `{name}` = {v!r}: expected a finite number")
    return float(v)


def _int(name: str, v: Any, lo: int = 1) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
        raise ValueError(f"invalid parameter `{name}` = {v!r}: must be an integer >= {lo}")
    return int(v)


@dataclass
class Variable:
    """One design variable: a :class:`Parameters` field and its bounds."""

    name: str
    low: float
    high: float

    def __post_init__(self) -> None:
        if self.name not in _PARAM_FIELDS:
            import difflib

            near = difflib.get_close_matches(self.name, _PARAM_FIELDS, n=1, cutoff=0.5)
            hint = f"; did you mean {near[0]!r}?" if near else ""
            raise ValueError(f"invalid design variable {self.name!r}: not a field of beamslider.Parameters "
                             f"(TOML keys, docs/model.md §1){hint}")
        if self.name in _NOT_CONTINUOUS:
            raise ValueError(f"invalid design variable {self.name!r}: not a continuous quantity")
        lo = _num(f"design.{self.name}[0]", self.low)
        hi = _num(f"design.{self.name}[1]", self.high)
        if not lo < hi:
            raise ValueError(f"invalid bounds of design variable `{self.name}`: need low < high, got [{lo}, {hi}]")
        self.low, self.high = lo, hi
        # Both bounds must be valid parameter values (the core's ranges, e.g. gap_ratio > 1).
        for v in (lo, hi):
            try:
                Parameters(**{self.name: v})
            except ValueError as e:
                raise ValueError(f"invalid bounds of design variable `{self.name}`: {e}") from None


@dataclass
class DesignConfig(_toml.ConfigFile):
    """A design optimisation (see :data:`EXAMPLE_TOML` for the TOML form)."""

    variables: List[Variable]
    params: Parameters = field(default_factory=Parameters)
    evaluator: str = "fs"
    drift_law: Optional[str] = None
    seed: int = 1
    f_lo_hz: float = 100.0
    f_hi_hz: float = 130.0
    f_step_hz: float = 2.0
    a_ex_m_s2: List[float] = field(default_factory=lambda: [10.0, 14.0])
    s0: List[float] = field(default_factory=lambda: [0.3])
    t_end_s: float = 120.0
    a_min_h: float = 0.3
    record_every: int = 20
    criteria: Dict[str, float] = field(default_factory=dict)
    maximise: str = "bandwidth"
    robust: str = "none"
    quantile: float = 0.25
    harvest_weight_hz: float = 1.0
    max_slider_mass_kg: float = math.inf
    min_gap_ratio: float = 1.0
    popsize: int = 4
    maxiter: int = 2
    init: str = "latinhypercube"
    mutation: Tuple[float, float] = (0.5, 1.0)
    recombination: float = 0.7
    include_prototype: bool = True
    scale_inertia: bool = True
    recheck: int = 2
    recheck_tolerance_hz: float = 0.0
    """Scores the predictor does not tell apart [Hz]: with a value > 0 the re-checked designs are
    the best one and then, in turn, the design farthest from those chosen (in the unit box of the
    bounds) among the designs whose score lies within this of the best; 0 re-checks the best
    designs as ranked."""
    uncertain: List[Uncertain] = field(default_factory=list)
    sampling_method: str = "lhs"
    samples: int = 4
    sampling_seed: int = 0
    chunk_size: int = 8
    reference: Dict[str, Dict[str, float]] = field(default_factory=dict)
    """Named designs re-checked with FS beside the search's best (``[reference.<name>]``: variable =
    value; variables not given keep the base value)."""

    TOML_KIND = "design"

    def __post_init__(self) -> None:
        self.variables = [v if isinstance(v, Variable) else Variable(**v) for v in self.variables]
        if not self.variables:
            raise ValueError("a design needs at least one variable in [design] (name = [low, high])")
        names = [v.name for v in self.variables]
        if len(set(names)) != len(names):
            raise ValueError(f"design variables named twice: {names}")
        if isinstance(self.params, dict):
            self.params = Parameters.from_dict(self.params)
        if self.evaluator not in EVALUATORS:
            raise ValueError(f"invalid parameter `evaluator` = {self.evaluator!r}: must be one of {', '.join(EVALUATORS)}")
        if self.evaluator == "predictor" and not self.drift_law:
            raise ValueError("invalid parameter `drift_law`: the predictor evaluator needs a drift law: \"default\" "
                             "(the built-in design law) or a JSON file written by `beamslider fit-law`")
        if self.evaluator == "predictor" and len(self.s0) != 1:
            raise ValueError("invalid parameter `band.s0`: the predictor evaluator takes one s0")
        self.seed = _int("seed", self.seed, 0)
        for k in ("f_lo_hz", "f_hi_hz", "f_step_hz", "t_end_s", "a_min_h", "quantile", "harvest_weight_hz",
                  "recombination", "min_gap_ratio"):
            setattr(self, k, _num(k, getattr(self, k)))
        if not self.max_slider_mass_kg == math.inf:
            self.max_slider_mass_kg = _num("max_slider_mass_kg", self.max_slider_mass_kg)
        if not (self.f_step_hz > 0 and self.f_hi_hz > self.f_lo_hz):
            raise ValueError(f"invalid band: need f_lo_hz < f_hi_hz and f_step_hz > 0, got "
                             f"[{self.f_lo_hz}, {self.f_hi_hz}] step {self.f_step_hz}")
        span = (self.f_hi_hz - self.f_lo_hz) / self.f_step_hz
        if not (math.isfinite(self.f_lo_hz) and math.isfinite(self.f_hi_hz) and span < _core.MAX_AXIS_VALUES):
            raise ValueError(f"invalid band: [{self.f_lo_hz:.6g}, {self.f_hi_hz:.6g}] Hz in steps of {self.f_step_hz:.6g} Hz "
                             f"gives {span:.3g} frequencies, at most {_core.MAX_AXIS_VALUES}")
        if not self.a_min_h >= 0:
            raise ValueError(f"invalid parameter `a_min_h` = {self.a_min_h}: must be >= 0")
        if not 0.0 <= self.quantile <= 1.0:
            raise ValueError(f"invalid parameter `quantile` = {self.quantile}: must lie in [0, 1]")
        self.a_ex_m_s2 = [_num("band.a_ex_m_s2", a) for a in np.atleast_1d(self.a_ex_m_s2).tolist()]
        self.s0 = [_num("band.s0", s) for s in np.atleast_1d(self.s0).tolist()]
        if self.maximise not in OBJECTIVES:
            raise ValueError(f"invalid parameter `objective.maximise` = {self.maximise!r}: must be one of {', '.join(OBJECTIVES)}")
        if self.robust not in ROBUST:
            raise ValueError(f"invalid parameter `objective.robust` = {self.robust!r}: must be one of {', '.join(ROBUST)}")
        if self.robust != "none" and not self.uncertain:
            raise ValueError(f"objective.robust = {self.robust!r} needs uncertain inputs ([uncertain.<name>] tables)")
        self.uncertain = [u if isinstance(u, Uncertain) else Uncertain(**u) for u in self.uncertain]
        for k in ("popsize", "maxiter", "record_every", "samples", "chunk_size"):
            setattr(self, k, _int(k, getattr(self, k), 0 if k == "maxiter" else 1))
        self.recheck = _int("recheck", self.recheck, 0)
        self.recheck_tolerance_hz = _num("recheck_tolerance_hz", self.recheck_tolerance_hz)
        if not self.recheck_tolerance_hz >= 0.0:
            raise ValueError(f"invalid parameter `recheck_tolerance_hz` = {self.recheck_tolerance_hz}: must be >= 0")
        self.sampling_seed = _int("sampling.seed", self.sampling_seed, 0)
        if self.init not in INITS:
            raise ValueError(f"invalid parameter `optimiser.init` = {self.init!r}: must be one of {', '.join(INITS)}")
        self.mutation = tuple(_num("optimiser.mutation", m) for m in np.atleast_1d(self.mutation).tolist())  # type: ignore
        if self.include_prototype:
            for v in self.variables:
                x = getattr(self.params, v.name)
                if not v.low <= x <= v.high:
                    raise ValueError(f"include_prototype: the base value {v.name} = {x} lies outside the bounds "
                                     f"[{v.low}, {v.high}] (widen them or set include_prototype = false)")
        if not isinstance(self.reference, dict):
            raise ValueError("[reference] must hold tables of named designs: [reference.<name>] variable = value")
        ref: Dict[str, Dict[str, float]] = {}
        for name, vals in self.reference.items():
            if not (isinstance(name, str) and name.replace("_", "").isalnum()):
                raise ValueError(f"invalid reference design name {name!r}: letters, digits and underscores only")
            if not isinstance(vals, dict) or not vals:
                raise ValueError(f"[reference.{name}] must be a table of design variables: variable = value")
            bad = sorted(set(vals) - set(self.names))
            if bad:
                raise ValueError(f"unknown key {bad[0]!r} in [reference.{name}]: allowed are the design variables "
                                 f"{', '.join(self.names)}")
            ref[name] = {k: _num(f"reference.{name}.{k}", v) for k, v in vals.items()}
            self.design_params(self.reference_x(ref[name]))  # inside the bounds, valid parameters
        self.reference = ref
        self.map_config()  # the core validates band, duration, record_every, criteria

    # --- derived ------------------------------------------------------------------------------
    @property
    def names(self) -> List[str]:
        return [v.name for v in self.variables]

    @property
    def bounds(self) -> List[Tuple[float, float]]:
        return [(v.low, v.high) for v in self.variables]

    def f_ex_hz(self) -> List[float]:
        """Frequencies of the band: f_lo, f_lo + step, …, f_hi (the last step may be shorter)."""
        n = int(math.floor((self.f_hi_hz - self.f_lo_hz) / self.f_step_hz + 1e-9))
        fs = [round((self.f_lo_hz + i * self.f_step_hz) * 1e9) / 1e9 for i in range(n + 1)]
        if fs[-1] < self.f_hi_hz - 1e-9:
            fs.append(self.f_hi_hz)
        return fs

    def operating_points(self) -> List[Tuple[float, float, float]]:
        """(f_ex, a_ex, s0) in map order: s0 slowest, then a_ex, f_ex fastest."""
        return [(f, a, s) for s in self.s0 for a in self.a_ex_m_s2 for f in self.f_ex_hz()]

    def map_config(self, params: Optional[Parameters] = None) -> "_core.MapConfig":
        """Map configuration of the band (the core's runner reads record_every, dt, criteria from
        it), parsed and checked once by the core."""
        return map_config(params or self.params, f_ex=self.f_ex_hz(), a_ex=self.a_ex_m_s2, s0=self.s0, t_end=self.t_end_s,
                          record_every=self.record_every, criteria=self.criteria or None)

    def design_params(self, x: Any) -> Parameters:
        """The :class:`Parameters` of design vector ``x`` (variables in order). With ``scale_inertia``
        and ``slider_inertia_kg_m2`` not a variable, J_C = J_C0 (m/m0) (B/B0)² (geometrically
        similar slider: J ∝ m · size², size ∝ contact spacing B). Raises ValueError naming a
        variable outside its bounds."""
        x = np.asarray(x, dtype=float).ravel()
        if x.size != len(self.variables):
            raise ValueError(f"a design vector needs {len(self.variables)} values ({', '.join(self.names)}), got {x.size}")
        d = self.params.to_dict()
        for v, val in zip(self.variables, x):
            if not (math.isfinite(val) and v.low <= val <= v.high):
                raise ValueError(f"design variable `{v.name}` = {val!r} outside its bounds [{v.low}, {v.high}]")
            d[v.name] = float(val)
        if self.scale_inertia and "slider_inertia_kg_m2" not in self.names and (
                "slider_mass_kg" in self.names or "contact_spacing_m" in self.names):
            p0 = self.params
            d["slider_inertia_kg_m2"] = (p0.slider_inertia_kg_m2 * (d["slider_mass_kg"] / p0.slider_mass_kg)
                                         * (d["contact_spacing_m"] / p0.contact_spacing_m) ** 2)
        return Parameters.from_dict(d)

    def prototype_x(self) -> np.ndarray:
        """The base parameters as a design vector."""
        return np.array([float(getattr(self.params, v.name)) for v in self.variables])

    def reference_x(self, values: Dict[str, float]) -> np.ndarray:
        """The design vector of a reference design (variables not given: the base value)."""
        return np.array([float(values.get(v.name, getattr(self.params, v.name))) for v in self.variables])

    def violation(self, p: Parameters) -> str:
        """Why design ``p`` breaks a constraint ('' when feasible)."""
        out = []
        if p.slider_mass_kg > self.max_slider_mass_kg:
            out.append(f"slider_mass_kg = {p.slider_mass_kg:g} > max_slider_mass_kg = {self.max_slider_mass_kg:g}")
        if p.gap_ratio < self.min_gap_ratio:
            out.append(f"gap_ratio = {p.gap_ratio:g} < min_gap_ratio = {self.min_gap_ratio:g} (jam limit)")
        return "; ".join(out)

    def samples_values(self) -> List[Dict[str, float]]:
        """The FIXED sample of the uncertain inputs (one dict per sample); ``[{}]`` (the nominal
        design only) when the objective is not robust."""
        if self.robust == "none" or not self.uncertain:
            return [{}]
        arr = sample(self.uncertain, self.sampling_method, self.samples, seed=self.sampling_seed)
        names = [u.name for u in self.uncertain]
        return [{n: float(v) for n, v in zip(names, row)} for row in arr]

    def robust_samples_values(self) -> List[Dict[str, float]]:
        """The uncertain sample regardless of ``robust`` (for the robust re-check); [] without uncertain inputs."""
        if not self.uncertain:
            return []
        arr = sample(self.uncertain, self.sampling_method, self.samples, seed=self.sampling_seed)
        names = [u.name for u in self.uncertain]
        return [{n: float(v) for n, v in zip(names, row)} for row in arr]

    # --- TOML ---------------------------------------------------------------------------------
    def to_dict(self) -> Dict[str, Any]:
        d: Dict[str, Any] = {"evaluator": self.evaluator, "seed": self.seed}
        if self.drift_law:
            d["drift_law"] = str(self.drift_law)
        d["design"] = {v.name: [v.low, v.high] for v in self.variables}
        d["band"] = {"f_lo_hz": self.f_lo_hz, "f_hi_hz": self.f_hi_hz, "f_step_hz": self.f_step_hz,
                     "a_ex_m_s2": list(self.a_ex_m_s2), "s0": list(self.s0), "t_end_s": self.t_end_s,
                     "a_min_h": self.a_min_h, "record_every": self.record_every}
        d["objective"] = {"maximise": self.maximise, "robust": self.robust, "quantile": self.quantile,
                          "harvest_weight_hz": self.harvest_weight_hz}
        c: Dict[str, Any] = {"min_gap_ratio": self.min_gap_ratio}
        if math.isfinite(self.max_slider_mass_kg):
            c["max_slider_mass_kg"] = self.max_slider_mass_kg
        d["constraints"] = c
        d["optimiser"] = {"popsize": self.popsize, "maxiter": self.maxiter, "init": self.init,
                          "mutation": list(self.mutation), "recombination": self.recombination,
                          "include_prototype": self.include_prototype, "scale_inertia": self.scale_inertia,
                          "recheck": self.recheck, "chunk_size": self.chunk_size}
        if self.recheck_tolerance_hz > 0:  # absent at 0, so files written before the option still resume
            d["optimiser"]["recheck_tolerance_hz"] = self.recheck_tolerance_hz
        d["params"] = self.params.to_dict()
        if self.criteria:
            d["criteria"] = dict(self.criteria)
        if self.uncertain:
            d["uncertain"] = {u.name: u.to_dict() for u in self.uncertain}
            d["sampling"] = {"method": self.sampling_method, "samples": self.samples, "seed": self.sampling_seed}
        if self.reference:
            d["reference"] = {k: dict(v) for k, v in self.reference.items()}
        return d

    def to_toml_text(self) -> str:
        return _toml.dumps(self.to_dict())

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> "DesignConfig":
        d = dict(d)
        sections = {"design": None, "band": ("f_lo_hz", "f_hi_hz", "f_step_hz", "a_ex_m_s2", "s0", "t_end_s", "a_min_h",
                                             "record_every"),
                    "objective": ("maximise", "robust", "quantile", "harvest_weight_hz"),
                    "constraints": ("max_slider_mass_kg", "min_gap_ratio"),
                    "optimiser": ("popsize", "maxiter", "init", "mutation", "recombination", "include_prototype",
                                  "scale_inertia", "recheck", "recheck_tolerance_hz", "chunk_size"),
                    "sampling": ("method", "samples", "seed"), "params": None, "criteria": None, "uncertain": None,
                    "reference": None}
        top = ("evaluator", "drift_law", "seed")
        unknown = sorted(set(d) - set(sections) - set(top))
        if unknown:
            raise ValueError(f"unknown key {unknown[0]!r} in the design configuration: allowed are "
                             f"{', '.join(sorted(set(sections) | set(top)))}")
        kw: Dict[str, Any] = {k: d[k] for k in top if k in d}
        design = d.get("design", {})
        if not isinstance(design, dict):
            raise ValueError("[design] must be a table of variables: name = [low, high]")
        variables = []
        for name, b in design.items():
            if not (isinstance(b, (list, tuple)) and len(b) == 2):
                raise ValueError(f"invalid design variable `{name}` = {b!r}: give its bounds as [low, high]")
            variables.append(Variable(name, b[0], b[1]))
        for sec in sections:
            if sec in d and not isinstance(d[sec], dict):
                raise ValueError(f"`{sec}` in the design configuration must be a table ([{sec}]), got {d[sec]!r:.40}")
        for sec, keys in sections.items():
            if keys is None or sec not in d:
                continue
            t = dict(d[sec])
            bad = sorted(set(t) - set(keys))
            if bad:
                raise ValueError(f"unknown key {bad[0]!r} in [{sec}]: allowed are {', '.join(keys)}")
            for k, v in t.items():
                kw[{"method": "sampling_method", "seed": "sampling_seed"}.get(k, k) if sec == "sampling" else k] = v
        uncertain = uncertain_from_dict(d.get("uncertain", {}))
        return cls(variables=variables, params=Parameters.from_dict(d.get("params", {})),
                   criteria=dict(d.get("criteria", {})), uncertain=uncertain, reference=d.get("reference", {}), **kw)


def read_config(path: Union[str, "os.PathLike[str]"]) -> DesignConfig:
    """Read a design configuration (TOML)."""
    return DesignConfig.from_toml(path)
