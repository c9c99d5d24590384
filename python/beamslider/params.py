"""Model parameters of docs/model.md §1 (defaults = the paper's prototype).

The fields, their defaults, the table of docs/model.md §1 (symbol, meaning, unit, allowed values)
and the validation are the Rust core's (``crates/beamslider-core/src/params.rs``):
:class:`Parameters` is a dataclass made from them, and each run receives the core's validated
object (:func:`native`), so Python and Rust accept exactly the same values and files and a run
checks its parameters once, in the core, without converting them to TOML.
"""

from __future__ import annotations

import dataclasses
import math
import os
from typing import Any, Dict, Union

from . import _core

PathLike = Union[str, "os.PathLike[str]"]

_TABLE = _core.Params.fields()
_NAMES = tuple(row[0] for row in _TABLE)

SYMBOLS: Dict[str, str] = {name: symbol for name, symbol, _m, _u, _a in _TABLE}
"""Symbol of each field in docs/model.md (the core's table)."""

ALLOWED: Dict[str, str] = {name: allowed for name, _s, _m, _u, allowed in _TABLE}
"""Allowed values of each field, as the core's validation (``Params::validate``) enforces them:
the core's table, shown in docs/model.md §1 and probed at each bound by tests/test_model_doc.py."""

MEANINGS: Dict[str, str] = {name: f"{meaning} [{unit}]" for name, _s, meaning, unit, _a in _TABLE}
"""Meaning and unit of each field (the core's table)."""


class _Methods:
    """Conversion and I/O of :class:`Parameters`, all through the core."""

    def __post_init__(self) -> None:
        _adopt(self, _core.Params(**{n: getattr(self, n) for n in _NAMES}))

    def __setattr__(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)
        if name in _NAMES:
            self.__dict__.pop("_native", None)  # checked again by the core before the next run

    def __getstate__(self) -> Dict[str, Any]:
        return {n: getattr(self, n) for n in _NAMES}

    def __setstate__(self, state: Dict[str, Any]) -> None:
        self.__dict__.update(state)

    def to_dict(self) -> Dict[str, Any]:
        """Field name (TOML key) -> value."""
        return {n: getattr(self, n) for n in _NAMES}

    @classmethod
    def from_dict(cls, values: Dict[str, Any]) -> "Parameters":
        """From a mapping of TOML keys; missing keys take their defaults, unknown keys are a
        ``ValueError``."""
        return _wrap(cls, _core.Params(**dict(values)))

    def toml_text(self) -> str:
        """TOML text in the canonical form the Rust tools write (validated)."""
        return native(self).toml_text()

    def validate(self) -> None:
        """Check every field with the core; ``ValueError`` names the field and the allowed range."""
        native(self)

    @classmethod
    def from_toml(cls, path: PathLike, **overrides: Any) -> "Parameters":
        """Read a TOML parameter file (the same files the Rust binary reads). Missing keys take
        their defaults; ``overrides`` replace fields by name (a command line's ``--dt``); the result
        is validated once. Unknown keys or bad values raise ``ValueError``, a missing file ``OSError``."""
        return _wrap(cls, _core.Params.from_toml_file(os.fspath(path), **overrides))

    @classmethod
    def from_toml_text(cls, text: str) -> "Parameters":
        """Parse TOML text (see :meth:`from_toml`)."""
        return _wrap(cls, _core.Params.from_toml_text(text))

    def to_toml(self, path: PathLike) -> None:
        """Write the parameters as a TOML file."""
        text = self.toml_text()
        with open(os.fspath(path), "w", encoding="utf-8") as f:
            f.write(text)

    def natural_frequencies_hz(self) -> list:
        """Linear natural frequencies f_1..f_N of the elastically clamped beam [Hz] (docs/model.md §2)."""
        return [w / (2 * math.pi) for w in _core.beam_properties(native(self))["omega_rad_s"]]


def _adopt(obj: Any, core: Any) -> None:
    """Store the core's values (Python floats and ints) and its validated object."""
    for k, v in core.to_dict().items():
        object.__setattr__(obj, k, v)
    object.__setattr__(obj, "_native", core)


def _wrap(cls: type, core: Any) -> Any:
    obj = cls.__new__(cls)
    _adopt(obj, core)
    return obj


Parameters = dataclasses.make_dataclass(
    "Parameters",
    [(n, type(v), dataclasses.field(default=v)) for n, v in _core.Params().to_dict().items()],
    bases=(_Methods,),
    namespace={"__module__": __name__},
)
Parameters.__doc__ = (
    "All model parameters, SI units (docs/model.md §1; fields, defaults and allowed values are the core's). "
    "Invalid values raise ``ValueError`` naming the field and its allowed range, at construction and before "
    "every run.\n\nFields:\n\n" + "\n".join(f"- ``{n}`` ({SYMBOLS[n]}): {MEANINGS[n]}; {ALLOWED[n]}" for n in _NAMES)
)


def native(p: "Parameters") -> Any:
    """The core's validated object of ``p`` (``_core.Params``), made once and kept until a field
    changes; a changed field is checked here (``ValueError``)."""
    core = p.__dict__.get("_native")
    if core is None:
        core = _core.Params(**p.to_dict())
        object.__setattr__(p, "_native", core)
    return core


def detune(params: Any, factor: float) -> Dict[str, float]:
    """Parameter values that scale every linear natural frequency by ``factor`` (c) at constant
    mode shapes and constant nonlinear coefficient b*: E → c² E, k_r → c² k_r and k_t such that
    k_ax = 1/(L/(EA) + 1/k_t) is unchanged (k_t = ∞ stays ∞). ``params``: a :class:`Parameters`
    or a mapping of its fields (values not yet validated: the caller validates the result once)."""
    c2 = float(factor) ** 2
    if not (math.isfinite(c2) and c2 > 0):
        raise ValueError(f"invalid natural_frequency_factor = {factor!r}: must be finite and > 0")
    v = params if isinstance(params, dict) else params.to_dict()
    area = v["beam_mass_kg"] / (v["density_kg_m3"] * v["length_m"])
    e_new = v["youngs_modulus_pa"] * c2
    out = {"youngs_modulus_pa": e_new, "k_r_nm_per_rad": v["k_r_nm_per_rad"] * c2}
    if math.isfinite(v["k_t_n_per_m"]):
        inv = 1.0 / v["k_t_n_per_m"] + v["length_m"] / (v["youngs_modulus_pa"] * area) - v["length_m"] / (e_new * area)
        if not inv > 0:
            raise ValueError(f"natural_frequency_factor = {factor}: no axial clamping stiffness k_t keeps b* "
                             f"(the beam alone is then softer axially than the nominal beam and frame)")
        out["k_t_n_per_m"] = 1.0 / inv
    return out


def resolve(params: "Parameters | None") -> Parameters:
    """``None`` -> defaults; a ``Parameters`` is used as given (and validated by the core)."""
    if params is None:
        return Parameters()
    if isinstance(params, Parameters):
        return params
    if isinstance(params, dict):
        return Parameters.from_dict(params)
    raise TypeError(f"params must be a beamslider.Parameters, a dict or None, not {type(params).__name__}")
