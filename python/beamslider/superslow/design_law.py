"""A drift law over the design box (docs/model.md §6.5): per-design laws blended by design distance
(the blend is the core's, ``superslow::design_law``; fitting it is this module's).

The drift law of :mod:`.law` is fitted on the PCS tables of one set of parameters. A *design law*
holds such laws for many designs drawn over a box of the parameters that a designer changes or does
not know (:data:`DESIGN_BOX`), each design described by its coordinates (:func:`design_coordinates`).
For a new design it blends the laws of its ``k_sets`` nearest training designs, in the box scaled
to [0, 1] with a length scale per coordinate (chosen leaving one design out, :func:`fit_design_law`),
with inverse-distance weights: V on a grid of the law's inputs (Â/max Â_H, s) is the weighted mean
of the neighbours' V, and the scalars (Λ_c, s_up shift, ρ_c, s_p, V resolution) their weighted
means; the monostability samples are the neighbours' together. The result is an ordinary
:class:`DriftLaw` for that design (:meth:`DesignLaw.law_for`), used by :func:`predict` and
:func:`beamslider.superslow.predicted_map` unchanged.

Outside what the law covers — a coordinate beyond the box, a parameter that is not a coordinate
changed from the base design, or a clearance below ``jam_gap_ratio`` where sliders barely move —
:meth:`DesignLaw.law_for` says why (``note``), and predictions from it are marked ``extrapolated``.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _core
from ..params import Parameters, detune, native
from .law import DriftLaw, law_dict, law_from_dict

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

def design_coordinates(params: Parameters, base: Optional[Parameters] = None) -> Dict[str, float]:
    """The design coordinates of ``params`` relative to ``base`` (default: the prototype), computed
    by the core: the inertia factor J_C / (J_C0 (m/m0)(B/B0)²), the natural-frequency factor
    ω₁/ω₁0 (1 when E, k_r and k_t are the base's), the damping factor D/D0, the others the fields."""
    c = _core.design_coordinates(native(params), native(base or Parameters()))
    return dict(zip([b.name for b in DESIGN_BOX], c))


def design_params(x: Union[Dict[str, float], Sequence[float]], base: Optional[Parameters] = None) -> Parameters:
    """The :class:`Parameters` of design coordinates ``x`` (a dict, or values in :data:`DESIGN_BOX`
    order) on the base design: the inverse of :func:`design_coordinates`."""
    b = base or Parameters()
    v = dict(x) if isinstance(x, dict) else dict(zip([c.name for c in DESIGN_BOX], [float(a) for a in x]))
    d = b.to_dict()
    for name in ("gap_ratio", "slider_mass_kg", "contact_spacing_m", "com_offset_m", "friction_coefficient", "restitution"):
        d[name] = float(v[name])
    d["slider_inertia_kg_m2"] = (b.slider_inertia_kg_m2 * (d["slider_mass_kg"] / b.slider_mass_kg)
                                 * (d["contact_spacing_m"] / b.contact_spacing_m) ** 2 * float(v["inertia_factor"]))
    d["damping_ratio"] = b.damping_ratio * float(v["damping_factor"])
    if float(v["natural_frequency_factor"]) != 1.0:
        d.update(detune(d, float(v["natural_frequency_factor"])))
    return Parameters.from_dict(d)  # validated once


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

    _core_law: Optional[object] = field(default=None, repr=False, compare=False)
    _text: Optional[str] = field(default=None, repr=False, compare=False)

    @property
    def unit(self) -> np.ndarray:
        """Training designs in the unit box, shape (designs, coordinates)."""
        return np.array([[c.unit(xi[c.name]) for c in self.box] for xi in self.x])

    def core(self):
        """The core's handle of this law (``beamslider._core.DesignLaw``: the file parsed once)."""
        if self._core_law is None:
            content = self._text if self._text is not None else design_law_dict(self)  # the file's text, or its content
            self._core_law = _core.DesignLaw(content, "the design law")
        return self._core_law

    def __getstate__(self) -> dict:
        """Pickled without the core's handle (made again, from the file's text, where it is used)."""
        return {**self.__dict__, "_core_law": None}

    def outside(self, params: Parameters) -> List[str]:
        """Why ``params`` lie outside what the law covers ([] inside): a parameter that is not a
        coordinate changed from the base design, a coordinate beyond the box, or a clearance below
        ``jam_gap_ratio``."""
        return list(self.core().law_for(native(params))[1])

    def law_for(self, params: Parameters) -> Tuple[DriftLaw, Optional[str]]:
        """The blended :class:`DriftLaw` of design ``params`` (the core's blend) and a note when it
        lies outside the law (None inside); the note's reasons are also the law's ``outside_design``."""
        content, why = self.core().law_for(native(params))
        note = ("design outside the drift law's box: " + "; ".join(why)) if why else None
        return law_from_dict(content, "the blended law"), note


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


def design_law_from_dict(d: dict, source: str = "design law", text: Optional[str] = None) -> DesignLaw:
    """A :class:`DesignLaw` from a file's content (ValueError naming the key for a malformed one);
    ``text``: the file's JSON text, handed to the core as it is."""
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
        laws.append(law_from_dict(e["law"], f"{source}: designs[{i}].law", check=False))
    try:
        base = Parameters.from_dict(need("base", dict))
    except (TypeError, ValueError) as e:
        raise ValueError(f"invalid parameter `law`: {source}: base: {str(e).splitlines()[0][:160]}") from None
    # The core's reader checks the file whole, every law in it too (the one reader), and its handle is kept.
    core = _core.DesignLaw(text if text is not None else d, source)
    return DesignLaw(box=tuple(box), base=base, x=xs, laws=laws, scales=scales, k_sets=k, jam_gap_ratio=float(jam),
                     loo=d.get("loo", {}), _text=text, _core_law=core)


def load_design_law(path: Union[str, os.PathLike]) -> DesignLaw:
    """Read a design law written by :func:`save_design_law`."""
    try:
        text = Path(path).read_text(encoding="utf-8")
        d = json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as e:
        raise ValueError(f"invalid parameter `law`: {path} is not JSON ({str(e)[:120]})") from None
    if not isinstance(d, dict):
        raise ValueError(f"invalid parameter `law`: {path} is not a {DESIGN_KIND} file")
    return design_law_from_dict(d, str(path), text)


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
        text = Path(path).read_text(encoding="utf-8")
        d = json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as e:
        raise ValueError(f"invalid parameter `law`: {path} is not a beamslider law file ({str(e)[:120]})") from None
    if isinstance(d, dict) and d.get("kind") == DESIGN_KIND:
        return design_law_from_dict(d, str(path), text)
    return law_from_dict(d, str(path))
