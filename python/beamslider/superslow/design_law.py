"""A drift law over the design box (docs/model.md §6.5): per-design laws blended by design distance.

The drift law of :mod:`.law` is fitted on the PCS tables of one set of parameters. A *design law*
holds such laws for many designs drawn over a box of the parameters that a designer changes or does
not know (:data:`DESIGN_BOX`), each design described by its coordinates (:func:`design_coordinates`).
For a new design it blends the laws of its ``k_sets`` nearest training designs, in the box scaled
to [0, 1] with a length scale per coordinate (chosen leaving one design out, :func:`fit_design_law`),
with inverse-distance weights: V on a grid of the law's inputs (Â/max Â_H, s) is the weighted mean
of the neighbours' V, and the scalars (Λ_c, s_up shift, ρ_c, s_p, V resolution) their weighted
means; the monostability samples are the neighbours' together. The result is an ordinary
:class:`DriftLaw` for that design (:meth:`DesignLaw.law_for`), used by :func:`predict` and
:func:`beamslider.maps.predicted_map` unchanged.

Outside what the law covers — a coordinate beyond the box, a parameter that is not a coordinate
changed from the base design, or a clearance below ``jam_gap_ratio`` where sliders barely move —
:meth:`DesignLaw.law_for` says why (``note``), and predictions from it are marked ``extrapolated``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _core
from ..params import Parameters, native
from .law import FEATURES, DriftLaw, law_dict, law_from_dict

__all__ = [
    "BUILTIN_LAW_NOTE", "BoxCoordinate", "DEFAULT_DESIGN_LAW_PATH", "DESIGN_BOX", "DESIGN_KIND", "DesignLaw",
    "JAM_GAP_RATIO", "builtin_law", "default_law", "design_coordinates", "design_params", "design_sample",
    "fit_design_law", "load_design_law", "load_law", "loo_design_error", "save_design_law",
]

DESIGN_KIND = "beamslider design drift law"
"""The ``kind`` of a design-law file."""


@dataclass(frozen=True)
class BoxCoordinate:
    """One coordinate of the design box: a name, its range and whether it is sampled on a log scale."""

    name: str
    low: float
    high: float
    log: bool = False

    def unit(self, x: float) -> float:
        """``x`` mapped to [0, 1] over the range (log scale where ``log``)."""
        if self.log:
            return math.log(x / self.low) / math.log(self.high / self.low)
        return (x - self.low) / (self.high - self.low)

    def value(self, u: float) -> float:
        """The inverse of :meth:`unit`."""
        return self.low * (self.high / self.low) ** u if self.log else self.low + u * (self.high - self.low)


DESIGN_BOX: Tuple[BoxCoordinate, ...] = (
    BoxCoordinate("gap_ratio", 1.02, 1.30),
    BoxCoordinate("slider_mass_kg", 0.020, 0.070),
    BoxCoordinate("contact_spacing_m", 7e-3, 13e-3),
    BoxCoordinate("inertia_factor", 0.7, 1.3),
    BoxCoordinate("com_offset_m", 0.0, 8e-3),
    BoxCoordinate("friction_coefficient", 0.10, 0.40),
    BoxCoordinate("restitution", 0.2, 0.8),
    BoxCoordinate("natural_frequency_factor", 0.95, 1.05),
    BoxCoordinate("damping_factor", 0.5, 2.0, log=True),
)
"""The box of the shipped design law. ``inertia_factor`` is J_C / (J_C0 (m/m0)(B/B0)²) (1: a
geometrically similar slider of the base design), ``natural_frequency_factor`` ω₁/ω₁0 (the
clamping and bending stiffnesses scaled as :func:`beamslider.study.detune` does),
``damping_factor`` D/D0; the others are :class:`Parameters` fields."""

JAM_GAP_RATIO = 1.03
"""Below this clearance ratio sliders barely move (FS runs of 40 s travel < 0.05 L, docs/design):
a design there is outside what the law covers."""

FIXED = ("length_m", "thickness_m", "density_kg_m3", "beam_mass_kg", "damping_ratio_quadratic", "axial_preload_n",
         "gravity_m_s2", "tilt_rad")
"""Fields that are not coordinates: a design that changes one of them is outside the law."""

GRID_AMP = (0.0, 1.25, 26)
"""Grid of Â/max Â_H on which a blended law is materialised (start, stop, nodes)."""
GRID_S = (0.0, 0.5, 51)
"""Grid of s on which a blended law is materialised."""


def _omega1(p: Parameters) -> float:
    return float(_core.beam_properties(native(p), [])["omega_rad_s"][0])


def design_coordinates(params: Parameters, base: Optional[Parameters] = None) -> Dict[str, float]:
    """The design coordinates of ``params`` relative to ``base`` (default: the prototype)."""
    b = base or Parameters()
    j_similar = b.slider_inertia_kg_m2 * (params.slider_mass_kg / b.slider_mass_kg) * (
        params.contact_spacing_m / b.contact_spacing_m) ** 2
    same_beam = all(getattr(params, f) == getattr(b, f) for f in ("youngs_modulus_pa", "k_r_nm_per_rad", "k_t_n_per_m"))
    return {
        "gap_ratio": params.gap_ratio,
        "slider_mass_kg": params.slider_mass_kg,
        "contact_spacing_m": params.contact_spacing_m,
        "inertia_factor": params.slider_inertia_kg_m2 / j_similar,
        "com_offset_m": params.com_offset_m,
        "friction_coefficient": params.friction_coefficient,
        "restitution": params.restitution,
        "natural_frequency_factor": 1.0 if same_beam else _omega1(params) / _omega1(b),
        "damping_factor": params.damping_ratio / b.damping_ratio if b.damping_ratio > 0 else 1.0,
    }


def design_params(x: Union[Dict[str, float], Sequence[float]], base: Optional[Parameters] = None) -> Parameters:
    """The :class:`Parameters` of design coordinates ``x`` (a dict, or values in :data:`DESIGN_BOX`
    order) on the base design: the inverse of :func:`design_coordinates`."""
    from ..study.sampling import detune

    b = base or Parameters()
    v = dict(x) if isinstance(x, dict) else dict(zip([c.name for c in DESIGN_BOX], [float(a) for a in x]))
    d = b.to_dict()
    for name in ("gap_ratio", "slider_mass_kg", "contact_spacing_m", "com_offset_m", "friction_coefficient", "restitution"):
        d[name] = float(v[name])
    d["slider_inertia_kg_m2"] = (b.slider_inertia_kg_m2 * (d["slider_mass_kg"] / b.slider_mass_kg)
                                 * (d["contact_spacing_m"] / b.contact_spacing_m) ** 2 * float(v["inertia_factor"]))
    d["damping_ratio"] = b.damping_ratio * float(v["damping_factor"])
    if float(v["natural_frequency_factor"]) != 1.0:
        d.update(detune(Parameters.from_dict(d), float(v["natural_frequency_factor"])))
    return Parameters.from_dict(d)


def design_sample(n: int, *, seed: int, method: str = "sobol", box: Sequence[BoxCoordinate] = DESIGN_BOX) -> List[Dict[str, float]]:
    """``n`` designs over the box: a scrambled Sobol' sequence or a Latin hypercube (``method``) with ``seed``."""
    from scipy.stats import qmc

    if method == "sobol":
        u = qmc.Sobol(d=len(box), scramble=True, seed=seed).random(n)
    elif method == "lhs":
        u = qmc.LatinHypercube(d=len(box), seed=seed).random(n)
    else:
        raise ValueError(f"invalid parameter `method` = {method!r}: 'sobol' or 'lhs'")
    return [{c.name: c.value(float(ui)) for c, ui in zip(box, row)} for row in u]


def _weights(U: np.ndarray, u: np.ndarray, scales: np.ndarray, k: int) -> Tuple[np.ndarray, np.ndarray]:
    d = np.sqrt((((U - u) / scales) ** 2).sum(axis=1))
    o = np.argsort(d, kind="stable")[:k]
    w = 1.0 / np.maximum(d[o], 1e-9)
    return o, w / w.sum()


def _blend_v(laws: Sequence[DriftLaw], w: Sequence[float], branch: str, x: np.ndarray) -> Optional[np.ndarray]:
    """Σ w_j V_j(x) / Σ w_j over the laws with samples on ``branch`` (no lift-off gate); None if none has."""
    acc, ws = np.zeros(x.shape[0]), 0.0
    free = np.full(x.shape[0], np.inf)
    for law, wi in zip(laws, w):
        if law.x[branch].shape[0] == 0:
            continue
        acc += wi * law._evaluate_x(branch, x, free)[0]
        ws += wi
    return acc / ws if ws > 0 else None


@dataclass
class DesignLaw:
    """Drift laws of training designs over a box, blended for any design inside it (module docstring)."""

    box: Tuple[BoxCoordinate, ...]
    base: Parameters
    x: List[Dict[str, float]]
    """Coordinates of the training designs."""
    laws: List[DriftLaw]
    """Their fitted laws (:func:`beamslider.superslow.fit_drift_law`)."""
    scales: np.ndarray
    """Length scale of each coordinate in the unit box."""
    k_sets: int = 3
    jam_gap_ratio: float = JAM_GAP_RATIO
    loo: Dict[str, float] = field(default_factory=dict)
    """Leave-one-design-out V error (``ratio``: RMS error / RMS |V| over all training rows)."""

    @property
    def unit(self) -> np.ndarray:
        """Training designs in the unit box, shape (designs, coordinates)."""
        return np.array([[c.unit(xi[c.name]) for c in self.box] for xi in self.x])

    def outside(self, params: Parameters, coordinates: Optional[Dict[str, float]] = None) -> List[str]:
        """Why ``params`` lie outside what the law covers ([] inside); ``coordinates``: theirs, if
        already computed (:func:`design_coordinates` builds the beam for ω₁)."""
        why = [f"`{f}` = {getattr(params, f)!r} differs from the base design's {getattr(self.base, f)!r}"
               for f in FIXED if getattr(params, f) != getattr(self.base, f)]
        c = coordinates if coordinates is not None else design_coordinates(params, self.base)
        for b in self.box:
            if not (b.low - 1e-9 * max(1.0, abs(b.low)) <= c[b.name] <= b.high + 1e-9 * max(1.0, abs(b.high))):
                why.append(f"{b.name} = {c[b.name]:.6g} outside the box [{b.low:g}, {b.high:g}]")
        if c["gap_ratio"] < self.jam_gap_ratio:
            why.append(f"gap_ratio = {c['gap_ratio']:.4g} below {self.jam_gap_ratio:g}, where sliders barely move")
        return why

    def law_for(self, params: Parameters) -> Tuple[DriftLaw, Optional[str]]:
        """The blended :class:`DriftLaw` of design ``params`` and a note when it lies outside the law
        (None inside); the note's reasons are also the law's ``outside_design``."""
        c = design_coordinates(params, self.base)
        u = np.array([b.unit(c[b.name]) for b in self.box])
        o, w = _weights(self.unit, u, self.scales, self.k_sets)
        why = self.outside(params, c)
        note = ("design outside the drift law's box: " + "; ".join(why)) if why else None
        d0 = float(np.sqrt((((self.unit[o[0]] - u) / self.scales) ** 2).sum()))
        if d0 < 1e-6:  # a training design (to rounding of its coordinates): its own law, unchanged
            return dataclasses.replace(self.laws[o[0]], outside_design=why, _trees={}), note
        parts = [self.laws[i] for i in o]
        amp = np.linspace(*GRID_AMP[:2], int(GRID_AMP[2]))
        ss = np.linspace(*GRID_S[:2], int(GRID_S[2]))
        grid = np.array([[a, s] for s in ss for a in amp])
        xs, vs = {}, {}
        for br in ("L", "H"):
            v = _blend_v(parts, w, br, grid)
            xs[br], vs[br] = (grid, v) if v is not None else (np.zeros((0, len(FEATURES))), np.zeros(0))

        def mean(f):
            return float(sum(wi * f(law) for law, wi in zip(parts, w)))

        def mean_learnt(f):  # over the neighbours that learnt it (> 0); 0 when they weigh less than half
            ww = [(wi, f(law)) for law, wi in zip(parts, w) if f(law) > 0]
            tot = sum(a for a, _ in ww)
            return float(sum(a * b for a, b in ww) / tot) if tot >= 0.5 else 0.0

        mono_x = np.concatenate([law.mono_x for law in parts])
        mono_y = np.concatenate([law.mono_y for law in parts])
        law = DriftLaw(
            x=xs, v=vs, groups={b: np.zeros(vs[b].size, int) for b in vs}, mean=grid.mean(axis=0), std=grid.std(axis=0),
            lo=np.min([law.lo for law in parts], axis=0), hi=np.max([law.hi for law in parts], axis=0),
            points=sorted({tuple(p) for law in parts for p in law.points}), k=4,
            rho_c=mean_learnt(lambda q: q.rho_c), jump_down_s=mean_learnt(lambda q: q.jump_down_s),
            s_up_shift=mean(lambda q: q.s_up_shift), mono_x=mono_x, mono_y=mono_y,
            mono_std=np.sum([wi * q.mono_std for q, wi in zip(parts, w)], axis=0), mono_groups=np.zeros(mono_y.size, int),
            lift_c=mean(lambda q: q.lift_c), v_resolution=mean(lambda q: q.v_resolution),
            outside_design=why,
        )
        return law, note


def loo_design_error(laws: Sequence[DriftLaw], U: np.ndarray, scales: np.ndarray, k: int) -> Tuple[float, List[float]]:
    """Leave one design out: each design's training rows predicted by the blend of the others; the
    RMS error over all rows / RMS |V| (and per design)."""
    num = den = 0.0
    per = []
    idx_all = np.arange(len(laws))
    for j in idx_all:
        keep = idx_all != j
        o, w = _weights(U[keep], U[j], scales, k)
        parts = [laws[i] for i in idx_all[keep][o]]
        e2 = n2 = 0.0
        for br in ("L", "H"):
            xj, vj = laws[j].x[br], laws[j].v[br]
            if xj.shape[0] == 0:
                continue
            pred = _blend_v(parts, w, br, xj)
            pred = np.zeros_like(vj) if pred is None else pred
            e2 += float(((pred - vj) ** 2).sum())
            n2 += float((vj ** 2).sum())
        per.append(math.sqrt(e2 / n2) if n2 > 0 else float("nan"))
        num, den = num + e2, den + n2
    return (math.sqrt(num / den) if den > 0 else float("nan")), per


SCALE_GRID = (0.25, 0.5, 1.0, 2.0, 4.0, 1e6)
"""Length scales tried per coordinate (1e6: the coordinate is left out)."""


def fit_design_law(designs: Sequence[Dict[str, float]], laws: Sequence[DriftLaw], *, base: Optional[Parameters] = None,
                   box: Sequence[BoxCoordinate] = DESIGN_BOX, k_sets: int = 3, scales: Optional[Sequence[float]] = None,
                   sweeps: int = 2) -> DesignLaw:
    """A design law from the laws of training designs (coordinates ``designs``, laws fitted at
    :func:`design_params` of each). The length scales, when not given, minimise the
    leave-one-design-out V error by coordinate search over :data:`SCALE_GRID` (``sweeps`` passes)."""
    box = tuple(box)
    if len(designs) != len(laws) or len(laws) < k_sets + 1:
        raise ValueError(f"a design law needs one law per design and more than k_sets = {k_sets} designs")
    U = np.array([[c.unit(d[c.name]) for c in box] for d in designs])
    if scales is None:
        sc = np.ones(len(box))
        best, _ = loo_design_error(laws, U, sc, k_sets)
        for _ in range(sweeps):
            for i in range(len(box)):
                for g in SCALE_GRID:
                    t = sc.copy()
                    t[i] = g
                    e, _ = loo_design_error(laws, U, t, k_sets)
                    if e < best - 1e-4:
                        best, sc = e, t
    else:
        sc = np.asarray(scales, dtype=float)
    err, per = loo_design_error(laws, U, sc, k_sets)
    return DesignLaw(box=box, base=base or Parameters(), x=[dict(d) for d in designs], laws=list(laws), scales=sc,
                     k_sets=k_sets, loo={"ratio": err, "per_design": per})


def design_law_dict(law: DesignLaw) -> dict:
    """The design-law file's content (:func:`save_design_law`)."""
    return {
        "kind": DESIGN_KIND, "version": 1,
        "box": [{"name": c.name, "low": c.low, "high": c.high, "log": c.log} for c in law.box],
        "base": law.base.to_dict(), "k_sets": law.k_sets, "scales": [float(s) for s in law.scales],
        "jam_gap_ratio": law.jam_gap_ratio, "loo": law.loo,
        "designs": [{"x": dict(x), "law": law_dict(q, compact=True)} for x, q in zip(law.x, law.laws)],
    }


def save_design_law(law: DesignLaw, path: Union[str, os.PathLike]) -> None:
    """Write a design law as JSON (read back by :func:`load_design_law` and :func:`load_law`)."""
    Path(path).write_text(json.dumps(design_law_dict(law)), encoding="utf-8")


def design_law_from_dict(d: dict, source: str = "design law") -> DesignLaw:
    """A :class:`DesignLaw` from a file's content (ValueError naming the key for a malformed one)."""
    def need(key, kind):
        if key not in d or not isinstance(d[key], kind):
            raise ValueError(f"invalid parameter `law`: {source} lacks `{key}` ({kind.__name__ if isinstance(kind, type) else 'number'})")
        return d[key]

    if not isinstance(d, dict) or d.get("kind") != DESIGN_KIND:
        raise ValueError(f"invalid parameter `law`: {source} is not a {DESIGN_KIND} file")
    allowed = {"kind", "version", "box", "base", "k_sets", "scales", "jam_gap_ratio", "loo", "designs"}
    unknown = sorted(set(d) - allowed)
    if unknown:
        raise ValueError(f"invalid parameter `law`: {source} has the unknown key `{unknown[0]}` (a design law has {', '.join(sorted(allowed))})")
    if isinstance(d.get("version"), bool) or need("version", int) < 1:
        raise ValueError(f"invalid parameter `law`: {source} has version = {d['version']!r}, expected an integer >= 1")
    if d["version"] > 1:
        raise ValueError(f"invalid parameter `law`: {source} has version {d['version']}, newer than this build (1)")
    box = []
    for i, c in enumerate(need("box", list)):
        try:
            box.append(BoxCoordinate(str(c["name"]), float(c["low"]), float(c["high"]), bool(c.get("log", False))))
        except (KeyError, TypeError, ValueError, OverflowError):
            raise ValueError(f"invalid parameter `law`: {source}: box[{i}] needs name, low, high") from None
        if not (math.isfinite(box[-1].low) and math.isfinite(box[-1].high) and box[-1].low < box[-1].high):
            raise ValueError(f"invalid parameter `law`: {source}: box[{i}] needs finite low < high")
    names = [c.name for c in box]
    if sorted(names) != sorted(c.name for c in DESIGN_BOX):
        raise ValueError(f"invalid parameter `law`: {source}: box coordinates {names}, this version knows {[c.name for c in DESIGN_BOX]}")
    try:
        scales = np.asarray(need("scales", list), dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"invalid parameter `law`: {source}: `scales` needs {len(box)} numbers") from None
    if scales.shape != (len(box),) or not np.all(scales > 0) or not np.all(np.isfinite(scales)):
        raise ValueError(f"invalid parameter `law`: {source}: `scales` needs {len(box)} values > 0")
    k = need("k_sets", int)
    jam = d.get("jam_gap_ratio", JAM_GAP_RATIO)
    if isinstance(jam, bool) or not isinstance(jam, (int, float)) or not math.isfinite(jam) or jam < 1:
        raise ValueError(f"invalid parameter `law`: {source} has jam_gap_ratio = {jam!r}, expected a finite number >= 1")
    if not isinstance(d.get("loo", {}), dict):
        raise ValueError(f"invalid parameter `law`: {source}: `loo` needs a table")
    designs = need("designs", list)
    if k < 1 or len(designs) < k:
        raise ValueError(f"invalid parameter `law`: {source}: needs k_sets >= 1 and at least k_sets designs")
    xs, laws = [], []
    for i, e in enumerate(designs):
        if not isinstance(e, dict) or set(e) != {"x", "law"} or not isinstance(e.get("x"), dict) or not isinstance(e.get("law"), dict):
            raise ValueError(f"invalid parameter `law`: {source}: designs[{i}] needs `x` and `law`")
        missing = [n for n in names if isinstance(e["x"].get(n), bool) or not isinstance(e["x"].get(n), (int, float))
                   or not math.isfinite(e["x"][n])]
        if missing:
            raise ValueError(f"invalid parameter `law`: {source}: designs[{i}].x lacks {missing}")
        xs.append({n: float(e["x"][n]) for n in names})
        laws.append(law_from_dict(e["law"], f"{source}: designs[{i}].law"))
    try:
        base = Parameters.from_dict(need("base", dict))
    except (TypeError, ValueError) as e:
        raise ValueError(f"invalid parameter `law`: {source}: base: {str(e).splitlines()[0][:160]}") from None
    return DesignLaw(box=tuple(box), base=base, x=xs, laws=laws, scales=scales, k_sets=k, jam_gap_ratio=float(jam),
                     loo=d.get("loo", {}))


def load_design_law(path: Union[str, os.PathLike]) -> DesignLaw:
    """Read a design law written by :func:`save_design_law`."""
    try:
        d = json.loads(Path(path).read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as e:
        raise ValueError(f"invalid parameter `law`: {path} is not JSON ({str(e)[:120]})") from None
    if not isinstance(d, dict):
        raise ValueError(f"invalid parameter `law`: {path} is not a {DESIGN_KIND} file")
    return design_law_from_dict(d, str(path))


DEFAULT_DESIGN_LAW_PATH = Path(__file__).resolve().parent.parent / "data" / "default_design_law.json"
"""The built-in design law (python/beamslider/data/default_design_law.json): the default law at the
prototype and the laws of training designs over :data:`DESIGN_BOX` (``beamslider fit-law --design``)."""

_DEFAULT: Dict[str, DesignLaw] = {}


def default_law() -> DesignLaw:
    """The built-in design law (read once per process)."""
    if "law" not in _DEFAULT:
        _DEFAULT["law"] = load_design_law(DEFAULT_DESIGN_LAW_PATH)
    return _DEFAULT["law"]


BUILTIN_LAW_NOTE = ("the built-in drift law does not cover these parameters ({why}): the prediction is "
                    "extrapolated; fit a law of their own (beamslider fit-law) before trusting it")


def builtin_law(p: Parameters) -> Tuple[DriftLaw, Optional[str]]:
    """The built-in law for parameters ``p`` (the design law blended for them; at the prototype the
    default law itself) and, outside what it covers, the note that says why."""
    law, _ = default_law().law_for(p)
    return law, (BUILTIN_LAW_NOTE.format(why="; ".join(law.outside_design)) if law.outside_design else None)


def load_law(path: Union[str, os.PathLike]) -> Union[DriftLaw, DesignLaw]:
    """Read a drift law (:func:`save_drift_law`) or a design law (:func:`save_design_law`) by its ``kind``."""
    try:
        d = json.loads(Path(path).read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as e:
        raise ValueError(f"invalid parameter `law`: {path} is not a beamslider law file ({str(e)[:120]})") from None
    if isinstance(d, dict) and d.get("kind") == DESIGN_KIND:
        return design_law_from_dict(d, str(path))
    return law_from_dict(d, str(path))
