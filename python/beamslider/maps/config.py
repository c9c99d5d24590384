"""Operating maps: the behaviour vocabulary and the map configuration (the same TOML ``beamslider-batch map --config`` reads; docs/model.md §8)."""

from __future__ import annotations

from typing import Any, Dict, List, Optional

import numpy as np

from .. import _core, _toml
from ..params import Parameters, native, resolve
from ..tables import BEHAVIOURS

__all__ = ["BEHAVIOURS", "LABELS", "LETTERS", "MIN_CLASSIFY_S", "RESULTS_FILE", "criteria_toml", "criteria_values", "default_map_config",
           "map_config_dict", "map_config_toml"]


RESULTS_FILE = "map.jsonl"
"""Name of the results file inside a map's output folder."""




LETTERS = {"inactivity": "I", "trivial_adaption": "T", "signature_move": "S", "relaxation_oscillation": "R",
           "self_damping": "D", "not_settled": "N", "undetermined": "?"}
"""One letter per behaviour for text tables."""


LABELS = {"inactivity": "inactivity", "trivial_adaption": "trivial adaption", "signature_move": "signature move",
          "relaxation_oscillation": "relaxation oscillation", "self_damping": "self-damping",
          "not_settled": "not settled", "undetermined": "undetermined"}


MIN_CLASSIFY_S = 1.0
"""Shortest signal :func:`classify` accepts [s] (the 1-s moving average of the amplitude)."""


def _number(name: str, v: Any) -> Any:
    """A number for a TOML value (int stays int; bools and non-numbers are a ValueError naming ``name``)."""
    if isinstance(v, (bool, np.bool_)):
        raise ValueError(f"invalid parameter `{name}` = {v!r}: expected a number")
    if isinstance(v, (int, np.integer)):
        return int(v)
    try:
        return float(v)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"invalid parameter `{name}` = {v!r:.40}: expected a number") from None


def _integer(name: str, v: Any) -> int:
    """An integer count for a TOML value (a ValueError naming ``name`` for anything else)."""
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
        if isinstance(v, float) and v.is_integer():
            return int(v)
        raise ValueError(f"invalid parameter `{name}` = {v!r:.40}: expected an integer")
    return int(v)


def criteria_values(criteria: Optional[Dict[str, float]]) -> Optional[Dict[str, float]]:
    """The classification thresholds as the core takes them (keys of the core's ``Criteria``, each
    value a number: ``ValueError`` naming ``criteria.<key>`` otherwise); None for the defaults."""
    if not criteria:
        return None
    return {str(k): _number(f"criteria.{k}", v) for k, v in criteria.items()}


def criteria_toml(criteria: Optional[Dict[str, float]]) -> Optional[str]:
    """The ``[criteria]`` table of a map configuration file as TOML text (None for the defaults)."""
    values = criteria_values(criteria)
    return None if values is None else _toml.dumps(values)


def map_config_dict(params: Optional[Parameters] = None, *, f_ex: Any, a_ex: Any, s0: Any = 0.3,
                    t_end: float = 120.0, record_every: int = 20, dt_s: Optional[float] = None,
                    criteria: Optional[Dict[str, float]] = None) -> Dict[str, Any]:
    """The tables of a map configuration (see :func:`map_config_toml`)."""
    d: Dict[str, Any] = {"duration_s": float(_number("duration_s", t_end)), "record_every": _integer("record_every", record_every)}
    if dt_s is not None:
        d["dt_s"] = float(_number("dt_s", dt_s))
    d["grid"] = {key: _axis(name, values) for key, name, values in
                 (("f_ex_hz", "f_ex", f_ex), ("a_ex_m_s2", "a_ex", a_ex), ("s0", "s0", s0))}
    d["params"] = _toml.loads(resolve(params).toml_text())
    if criteria:
        d["criteria"] = {str(k): _number(f"criteria.{k}", v) for k, v in criteria.items()}
    return d


def map_config(params: Optional[Parameters] = None, *, f_ex: Any, a_ex: Any, s0: Any = 0.3, t_end: float = 120.0,
               record_every: int = 20, dt_s: Optional[float] = None,
               criteria: Optional[Dict[str, float]] = None) -> "_core.MapConfig":
    """The core's map configuration of :func:`map_config_dict`'s arguments, built from the typed
    parameters (no TOML text) and checked once by the core."""
    crit = criteria_values(criteria)
    return _core.MapConfig.of(native(resolve(params)), f_ex_hz=_axis("f_ex", f_ex), a_ex_m_s2=_axis("a_ex", a_ex),
                              s0=_axis("s0", s0), duration_s=float(_number("duration_s", t_end)),
                              record_every=_integer("record_every", record_every),
                              dt_s=None if dt_s is None else float(_number("dt_s", dt_s)), criteria=crit)


def _axis(name: str, values: Any) -> List[float]:
    arr = np.atleast_1d(np.asarray(values, dtype=float))
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"invalid parameter `{name}`: give a number or a non-empty 1-D sequence")
    return [float(v) for v in arr]


def map_config_toml(params: Optional[Parameters] = None, *, f_ex: Any, a_ex: Any, s0: Any = 0.3,
                    t_end: float = 120.0, record_every: int = 20,
                    criteria: Optional[Dict[str, float]] = None) -> str:
    """The map configuration as TOML (the format of ``beamslider-batch map --config``)."""
    return _toml.dumps(map_config_dict(params, f_ex=f_ex, a_ex=a_ex, s0=s0, t_end=t_end,
                                         record_every=record_every, criteria=criteria))


def default_map_config() -> str:
    """The paper's map (f_ex = 100, 102, …, 130 Hz, a_ex = 4, 6, …, 16 m/s², s0 = 0.3, 120 s) as TOML."""
    return _core.MapConfig.default().toml()
