"""beamslider: the self-adaptive beam–slider system of Müller, Beck & Krack (MSSP 2023).

A Rust core (``beamslider._core``) integrates the model of docs/model.md (§1–§6); this package is its
Python face:

- :class:`Parameters` — model parameters (docs/model.md §1), TOML in and out;
- :func:`simulate` — free-slider / pseudo-constrained / beam-only runs (§5–6);
- :func:`super_slow_manifold` — PCS continuation of the super-slow manifold (§6);
- :func:`hb_manifold` (:mod:`beamslider.superslow`) — the same manifold by harmonic balance in
  milliseconds (docs/model.md §6.4);
- :func:`envelope` — |Hilbert| plus moving average (§7);
- :func:`read_measurement` — the published measured data set (§7);
- :func:`operating_map`, :func:`classify` — operating maps and behaviour classification (§8);
- :mod:`beamslider.enma` — virtual ENMA, backbone fit and clamping update (§9);
- :mod:`beamslider.discover` — find, name and add the effect a model misses (discrepancy workflow);
- :mod:`beamslider.plotting` — the paper's three-panel figures; ``beamslider`` — the command line.
"""

from typing import TYPE_CHECKING, Any

from ._core import SimulationError
from .params import Parameters
from .simulate import (ManifoldResult, SimulationResult, available_memory, envelope, manifold_grid, read_trajectory,
                       recorded_size, simulate, super_slow_manifold)

# The rest is imported on first use (PEP 562): ``import beamslider`` and ``beamslider simulate``
# stay quick (discover, enma, maps, superslow and their dependencies cost about a second).
_LAZY = {
    "design": (".design", None), "discover": (".discover", None), "enma": (".enma", None), "maps": (".maps", None),
    "study": (".study", None), "superslow": (".superslow", None),
    "HbManifold": (".superslow", "HbManifold"), "hb_manifold": (".superslow", "hb_manifold"),
    "Measurement": (".measurement", "Measurement"), "MeasurementFormatError": (".measurement", "MeasurementFormatError"),
    "parse_operating_point": (".measurement", "parse_operating_point"),
    "read_measurement": (".measurement", "read_measurement"),
    "Classification": (".maps", "Classification"), "classify": (".maps", "classify"),
    "classify_result": (".maps", "classify_result"), "operating_map": (".maps", "operating_map"),
    "plot_operating_map": (".maps", "plot_operating_map"), "read_map": (".maps", "read_map"),
}

if TYPE_CHECKING:  # pragma: no cover
    from . import design, discover, enma, maps, study, superslow  # noqa: F401
    from .maps import Classification, classify, classify_result, operating_map, plot_operating_map, read_map  # noqa: F401
    from .measurement import Measurement, MeasurementFormatError, parse_operating_point, read_measurement  # noqa: F401
    from .superslow import HbManifold, hb_manifold  # noqa: F401


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module 'beamslider' has no attribute {name!r}")
    import importlib

    module, attr = _LAZY[name]
    mod = importlib.import_module(module, __name__)
    value = mod if attr is None else getattr(mod, attr)
    globals()[name] = value
    return value


def __dir__() -> list:
    return sorted(set(globals()) | set(_LAZY))


__version__ = "0.1.0"

__all__ = [
    "available_memory",
    "read_trajectory",
    "recorded_size",
    "Classification",
    "HbManifold",
    "ManifoldResult",
    "Measurement",
    "MeasurementFormatError",
    "Parameters",
    "SimulationError",
    "SimulationResult",
    "classify",
    "classify_result",
    "design",
    "discover",
    "enma",
    "envelope",
    "hb_manifold",
    "manifold_grid",
    "maps",
    "operating_map",
    "parse_operating_point",
    "plot_operating_map",
    "read_map",
    "read_measurement",
    "simulate",
    "study",
    "superslow",
    "super_slow_manifold",
]
