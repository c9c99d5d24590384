"""The cases of discover's benchmark (docs/model.md §9.2): the plan a lab would measure, the hidden
truths drawn by a seed (nothing, one or two effects of the library, a change outside it, a
calibration with a physical effect), each with its noise seed and start offset, and their runs
synthesised in the published measured format."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np

from ..params import Parameters
from .effects import EFFECTS

PathLike = Union[str, "os.PathLike[str]"]

PAPER_POINTS: Tuple[Tuple[float, float, float], ...] = ((104.0, 14.0, 0.3), (126.0, 10.0, 0.3), (124.0, 14.0, 0.3))
"""The paper's three reference runs (f_ex Hz, a_ex m/s², s0): the default plan's points."""

SLIDER_CANDIDATES: Tuple[str, ...] = tuple(n for n, e in EFFECTS.items() if e.level == "slider")
"""Every slider-level candidate, the measurement chain's included: the default plan's candidates."""

KINDS = ("nothing", "single", "pair", "outside", "chain+physics")
"""The kinds of hidden case (docs/model.md §9.2)."""

DEFAULT_COUNTS: Dict[str, int] = {"single": 12, "pair": 6, "outside": 6, "nothing": 4, "chain+physics": 2}
"""Cases of each kind in a default benchmark (30)."""

SIZE_RANGE = (1.5, 6.0)
"""A library effect's size, in units of its relevance threshold (:attr:`.effects.Effect.relevance`)."""

S0_OFFSET_RANGE = (0.0005, 0.003)
"""|s0 offset| of a case's truth runs from the s0 their files name (either sign)."""


@dataclass(frozen=True)
class Outside:
    """A change the synthesiser makes and discover has no slider-level candidate for: the parameter
    ``field`` multiplied by a factor whose size lies in ``factor`` (either direction, ``both``), or,
    with ``absolute``, set to a value drawn in ``factor``."""

    name: str
    field: str
    description: str
    factor: Tuple[float, float]
    both: bool = True
    absolute: bool = False


OUTSIDE: Dict[str, Outside] = {o.name: o for o in (
    Outside("beam_damping", "damping_ratio", "modal damping ratio of the beam x 1.3-2 or / 1.3-2", (1.3, 2.0)),
    Outside("amplitude_damping", "damping_ratio_quadratic",
            "amplitude-dependent damping D2 in [3e-4, 1.2e-3] (the beam-level effect, not a slider candidate)",
            (3e-4, 1.2e-3), both=False, absolute=True),
    Outside("axial_stiffness", "k_t_n_per_m", "axial clamping stiffness x 1.5-3 or / 1.5-3 (the hardening b*)",
            (1.5, 3.0)),
    Outside("rotational_clamping", "k_r_nm_per_rad",
            "rotational clamping stiffness x 1.5-3 or / 1.5-3 (frequency and mode shape)", (1.5, 3.0)),
)}
"""The changes outside the library that a benchmark draws from (docs/model.md §9.2)."""


@dataclass(frozen=True)
class Plan:
    """What a lab would measure: free-slider runs at ``operating_points`` (f_ex Hz, a_ex m/s², s0)
    of ``duration_s``, judged against the ``candidates`` (names of :data:`.effects.EFFECTS`), with the
    synthesiser's noise on s and on the beam velocity."""

    operating_points: Tuple[Tuple[float, float, float], ...] = PAPER_POINTS
    duration_s: float = 60.0
    candidates: Tuple[str, ...] = SLIDER_CANDIDATES
    noise_s: float = 0.001
    noise_velocity_m_s: float = 0.002

    def __post_init__(self) -> None:
        pts = tuple(tuple(float(v) for v in p) for p in self.operating_points)
        if not pts or not all(len(p) == 3 and all(math.isfinite(v) for v in p) for p in pts):
            raise ValueError(f"invalid operating_points = {self.operating_points!r}: give (f_ex, a_ex, s0) triples")
        object.__setattr__(self, "operating_points", pts)
        if not (isinstance(self.duration_s, (int, float)) and math.isfinite(self.duration_s) and self.duration_s > 0):
            raise ValueError(f"invalid duration_s = {self.duration_s!r}: must be a finite number > 0")
        cands = tuple(self.candidates)
        bad = [c for c in cands if c not in EFFECTS or EFFECTS[c].level != "slider"]
        if bad or not cands:
            raise ValueError(f"invalid candidate {bad[0] if bad else None!r}: give slider-level effects of "
                             f"{', '.join(SLIDER_CANDIDATES)}")
        object.__setattr__(self, "candidates", cands)

    def to_dict(self) -> Dict[str, Any]:
        return dict(operating_points=[list(p) for p in self.operating_points], duration_s=self.duration_s,
                    candidates=list(self.candidates), noise_s=self.noise_s, noise_velocity_m_s=self.noise_velocity_m_s)

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> "Plan":
        """The plan of :meth:`to_dict` (a benchmark's ``benchmark.json``, a cluster task)."""
        return cls(operating_points=tuple(tuple(x) for x in d["operating_points"]), duration_s=d["duration_s"],
                   candidates=tuple(d["candidates"]), noise_s=d["noise_s"], noise_velocity_m_s=d["noise_velocity_m_s"])


@dataclass(frozen=True)
class Case:
    """One hidden case: the library effects of the truth by name (in the units discover reports),
    the changes outside the library (parameter fields), the noise seed and the truth runs' s0
    offset."""

    index: int
    kind: str
    effects: Dict[str, float] = field(default_factory=dict)
    outside: Dict[str, float] = field(default_factory=dict)
    outside_kind: str = ""
    noise_seed: int = 0
    s0_offset: float = 0.0

    def label(self) -> str:
        parts = [f"{k} {v:.5g}" for k, v in self.effects.items()]
        parts += [f"{self.outside_kind}: {k} {v:.5g}" for k, v in self.outside.items()]
        return ", ".join(parts) or "nothing hidden"


# --- drawing ---------------------------------------------------------------------------------------


def threshold(name: str, base: Parameters) -> float:
    """The relevance threshold of effect ``name`` at ``base`` in the units of its value."""
    e = EFFECTS[name]
    if e.relevance_kind == "rel":
        return e.relevance * abs(e.baseline_value(base))
    if e.relevance_kind == "abs":
        return e.relevance
    raise ValueError(f"{name}: a compliance effect has no slider-level size")


def _search_range(name: str, base: Parameters) -> Tuple[float, float]:
    e = EFFECTS[name]
    lo, hi = e.search if all(math.isfinite(v) for v in e.search) else (e.lower, e.upper)
    a, b = e.value(lo, base), e.value(hi, base)
    return min(a, b), max(a, b)


def draw_size(name: str, rng: np.random.Generator, base: Parameters) -> float:
    """A value of effect ``name``: the baseline moved by U(1.5, 6) relevance thresholds, either sign
    (a sign whose value leaves the effect's search range is replaced by the other)."""
    e = EFFECTS[name]
    b = e.baseline_value(base)
    step = rng.uniform(*SIZE_RANGE) * threshold(name, base)
    sign = 1.0 if rng.random() < 0.5 else -1.0
    lo, hi = _search_range(name, base)
    for s in (sign, -sign):
        v = b + s * step
        if lo <= v <= hi and e.lower <= e.variable(v, base) <= e.upper:
            return float(v)
    raise ValueError(f"{name}: no value {step:.3g} from the baseline lies in its search range")


def _draw_outside(rng: np.random.Generator, base: Parameters) -> Tuple[str, Dict[str, float]]:
    o = OUTSIDE[list(OUTSIDE)[int(rng.integers(len(OUTSIDE)))]]
    x = rng.uniform(*o.factor)
    if o.absolute:
        return o.name, {o.field: float(x)}
    f = x if (not o.both or rng.random() < 0.5) else 1.0 / x
    return o.name, {o.field: float(getattr(base, o.field) * f)}


def draw_cases(seed: int, counts: Optional[Dict[str, int]] = None, *, plan: Optional[Plan] = None,
               baseline: Optional[Parameters] = None) -> List[Case]:
    """The cases of a benchmark: ``counts`` per kind (:data:`DEFAULT_COUNTS`) in an order shuffled
    by ``seed``; case i draws its truth, noise seed and start offset from (seed, i) alone, so the
    first cases of a larger benchmark are those of a smaller one with the same order."""
    plan = plan or Plan()
    base = baseline or Parameters()
    counts = dict(DEFAULT_COUNTS if counts is None else counts)
    bad = [k for k in counts if k not in KINDS]
    if bad:
        raise ValueError(f"unknown case kind {bad[0]!r}: known are {', '.join(KINDS)}")
    if any(not isinstance(n, int) or n < 0 for n in counts.values()):
        raise ValueError(f"invalid counts = {counts!r}: give integers >= 0")
    kinds = [k for k in KINDS for _ in range(counts.get(k, 0))]
    np.random.default_rng(seed).shuffle(kinds)
    physical = [c for c in plan.candidates if not EFFECTS[c].chain]
    chain = [c for c in plan.candidates if EFFECTS[c].chain]
    if any(k in ("single", "pair") for k in kinds) and len(plan.candidates) < (2 if "pair" in kinds else 1):
        raise ValueError("the plan has too few candidates for the cases asked")
    if "chain+physics" in kinds and not (physical and chain):
        raise ValueError("chain+physics cases need a physical and a measurement-chain candidate in the plan")
    cases = []
    for i, kind in enumerate(kinds):
        rng = np.random.default_rng([seed, i])
        effects: Dict[str, float] = {}
        outside: Dict[str, float] = {}
        okind = ""
        if kind == "single":
            names = [plan.candidates[int(rng.integers(len(plan.candidates)))]]
        elif kind == "pair":
            names = [plan.candidates[int(j)] for j in rng.choice(len(plan.candidates), 2, replace=False)]
        elif kind == "chain+physics":
            names = [chain[int(rng.integers(len(chain)))], physical[int(rng.integers(len(physical)))]]
        else:
            names = []
        for n in names:
            effects[n] = draw_size(n, rng, base)
        if kind == "outside":
            okind, outside = _draw_outside(rng, base)
        offset = rng.uniform(*S0_OFFSET_RANGE) * (1.0 if rng.random() < 0.5 else -1.0)
        cases.append(Case(i, kind, effects, outside, okind, int(rng.integers(2 ** 31)), float(offset)))
    return cases


# --- one case --------------------------------------------------------------------------------------


def truth_model(case: Case, baseline: Optional[Parameters] = None):
    """The truth of ``case`` as a :class:`.chain.Model`: the baseline with the outside changes, the
    library effects realised on it as discover realises its candidates."""
    from .chain import realise_model

    base = baseline or Parameters()
    p = Parameters(**{**base.to_dict(), **case.outside}) if case.outside else base
    return realise_model(p, dict(case.effects))


def synthesize_case(case: Case, plan: Plan, out_dir: PathLike, *, points=None, noise_seed: Optional[int] = None,
                    s0_offset: Optional[float] = None, baseline: Optional[Parameters] = None) -> List[Path]:
    """The measured files of ``case`` at the plan's points (or ``points``) in ``out_dir``."""
    from .synthesize import synthesize_slider_runs

    m = truth_model(case, baseline)
    return synthesize_slider_runs(m.params, operating_points=list(points or plan.operating_points),
                                  duration_s=plan.duration_s, out_dir=out_dir, noise_s=plan.noise_s,
                                  noise_velocity_m_s=plan.noise_velocity_m_s,
                                  seed=case.noise_seed if noise_seed is None else noise_seed,
                                  s0_offset=case.s0_offset if s0_offset is None else s0_offset,
                                  chain=dict(m.chain) or None)
