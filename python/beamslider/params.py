"""Model parameters of docs/model.md §1 (defaults = the paper's prototype), as TOML.

The field names are the TOML keys the Rust core reads (``crates/beamslider-core/src/params.rs``);
validation is done by the core, so Python and Rust accept exactly the same files.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
from dataclasses import dataclass
from typing import Any, Dict, Union


from . import _core, _toml

PathLike = Union[str, "os.PathLike[str]"]


@dataclass
class Parameters:
    """All model parameters, SI units (docs/model.md §1). Invalid values raise ``ValueError``
    naming the field and its allowed range, at construction and before every run."""

    length_m: float = 0.140
    """Free length of the beam L [m]."""
    thickness_m: float = 1.0e-3
    """Beam thickness h [m]."""
    density_kg_m3: float = 7683.0
    """Beam density rho [kg/m^3]."""
    beam_mass_kg: float = 15.1e-3
    """Beam mass of the free length rho*A*L [kg]."""
    youngs_modulus_pa: float = 210e9
    """Young's modulus E [Pa]."""
    slider_mass_kg: float = 46.2e-3
    """Slider mass m [kg]."""
    slider_inertia_kg_m2: float = 3.15e-6
    """Slider rotary inertia about its centre of mass J_C [kg m^2]."""
    contact_spacing_m: float = 10e-3
    """Horizontal distance B between the two contact points on one side [m]."""
    com_offset_m: float = 4.1e-3
    """Distance d from the slider's geometric centre down to its centre of mass [m]."""
    gap_ratio: float = 1.05
    """Relative inner height of the slider opening R/h [-] (> 1)."""
    k_r_nm_per_rad: float = 125.0
    """Rotational clamping stiffness k_r at each end [N m/rad]; ``math.inf`` = ideal clamping."""
    k_t_n_per_m: float = 1.93e7
    """Axial clamping stiffness k_t [N/m]; ``math.inf`` = ideal clamping."""
    damping_ratio: float = 1.0e-3
    """Modal damping ratio D of all modes [-]."""
    damping_ratio_quadratic: float = 0.0
    """Amplitude growth D2 of the damping ratio [-]: D(t) = D + 4 D2 (w(L/2,t)/h)^2, so that
    harmonic balance gives D~(a~) = D + D2 a~^2 (micro-slip in the clamping). 0 = linear."""
    axial_preload_n: float = 0.0
    """Static axial force H0 in the beam [N], tension positive (adds H0 K q to the modal forces)."""
    friction_coefficient: float = 0.2
    """Coulomb friction coefficient mu [-]."""
    restitution: float = 0.5
    """Normal restitution coefficient eps_N [-] (tangential eps_T = 0)."""
    gravity_m_s2: float = 9.81
    """Gravitational acceleration g [m/s^2], acting on the slider only."""
    tilt_rad: float = 0.0
    """Tilt alpha of the frame about the transverse axis [rad]: the slider's gravity is
    (g sin alpha, -g cos alpha) along/across the beam; alpha > 0 lowers the end x = L. 0 = level."""
    n_modes: int = 5
    """Number of retained beam modes N (1..20)."""
    dt_s: float = 2e-5
    """Fixed time step [s]."""
    contact_solver: str = "fast"
    """Local contact solver (docs/model.md §5): "fast" (exact) or "reference" (Gauss-Seidel of the paper)."""
    solver_tol_rel: float = 1e-5
    """Relative stop tolerance of the Gauss-Seidel solver [-]."""
    solver_tol_abs: float = 1e-7
    """Absolute stop tolerance of the Gauss-Seidel solver [N s]."""
    solver_max_iter: int = 10_000
    """Iteration cap of the Gauss-Seidel solver (sweeps per step)."""

    def __post_init__(self) -> None:
        self.validate()
        # Store what the core validated: Python floats and ints (not numpy scalars, not an int
        # beyond 2**53 in a float field), so that a TOML round trip gives an equal object.
        for f in dataclasses.fields(self):
            kind = str(f.type)
            if kind in ("float", "int"):
                object.__setattr__(self, f.name, float(getattr(self, f.name)) if kind == "float" else int(getattr(self, f.name)))

    # --- conversion -----------------------------------------------------------------------
    def to_dict(self) -> Dict[str, Any]:
        """Field name (TOML key) -> value."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, values: Dict[str, Any]) -> "Parameters":
        """From a mapping of TOML keys; missing keys take their defaults, unknown keys are a
        ``ValueError``."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - names)
        if unknown:
            raise ValueError(
                f"unknown parameter {unknown[0]!r}: allowed names are {', '.join(sorted(names))}"
            )
        return cls(**values)

    def toml_text(self) -> str:
        """TOML text in the canonical form the Rust tools write (validated)."""
        return _core.canonical_toml(_to_toml(self.to_dict()))

    def validate(self) -> None:
        """Check every field with the core; ``ValueError`` names the field and the allowed range."""
        values = self.to_dict()
        try:
            _core.params_from_toml(_to_toml(values))
        except ValueError as e:
            raise _one_line(e, values) from None

    @classmethod
    def from_toml(cls, path: PathLike) -> "Parameters":
        """Read a TOML parameter file (the same files the Rust binary reads). Missing keys take
        their defaults; unknown keys or bad values raise ``ValueError``, a missing file ``OSError``."""
        return cls(**_core.read_params_file(os.fspath(path)))

    @classmethod
    def from_toml_text(cls, text: str) -> "Parameters":
        """Parse TOML text (see :meth:`from_toml`)."""
        return cls(**_core.params_from_toml(text))

    def to_toml(self, path: PathLike) -> None:
        """Write the parameters as a TOML file."""
        text = self.toml_text()
        with open(os.fspath(path), "w", encoding="utf-8") as f:
            f.write(text)

    def natural_frequencies_hz(self) -> list:
        """Linear natural frequencies f_1..f_N of the elastically clamped beam [Hz] (docs/model.md §2)."""
        return list(_core.natural_frequencies(self.toml_text()))


SYMBOLS: Dict[str, str] = {
    "length_m": "L", "thickness_m": "h", "density_kg_m3": "ρ", "beam_mass_kg": "ρAL", "youngs_modulus_pa": "E",
    "slider_mass_kg": "m", "slider_inertia_kg_m2": "J_C", "contact_spacing_m": "B", "com_offset_m": "d",
    "gap_ratio": "R/h", "k_r_nm_per_rad": "k_r", "k_t_n_per_m": "k_t", "damping_ratio": "D",
    "damping_ratio_quadratic": "D₂", "axial_preload_n": "H₀", "friction_coefficient": "μ", "restitution": "ε_N",
    "gravity_m_s2": "g", "tilt_rad": "α", "n_modes": "N", "dt_s": "Δt", "contact_solver": "—", "solver_tol_rel": "—",
    "solver_tol_abs": "—", "solver_max_iter": "—",
}
"""Symbol of each field in docs/model.md."""

ALLOWED: Dict[str, str] = {
    "length_m": "finite, > 0",
    "thickness_m": "finite, > 0",
    "density_kg_m3": "finite, > 0",
    "beam_mass_kg": "finite, > 0",
    "youngs_modulus_pa": "finite, > 0",
    "slider_mass_kg": "finite, > 0",
    "slider_inertia_kg_m2": "finite, > 0",
    "contact_spacing_m": "finite, > 0, < `length_m`",
    "com_offset_m": "finite, ≥ 0",
    "gap_ratio": "finite, > 1, `gap_ratio`·`thickness_m` < `length_m`",
    "k_r_nm_per_rad": "> 0, `inf` allowed (ideal clamping)",
    "k_t_n_per_m": "> 0, `inf` allowed (ideal clamping)",
    "damping_ratio": "finite, ≥ 0",
    "damping_ratio_quadratic": "finite, ≥ 0",
    "axial_preload_n": "finite; a compression below the buckling load of the retained modes",
    "friction_coefficient": "finite, ≥ 0",
    "restitution": "in [0, 1]",
    "gravity_m_s2": "finite, ≥ 0",
    "tilt_rad": "finite, −π/2 < α < π/2",
    "n_modes": "integer 1..20",
    "dt_s": "finite, > 0; below the stability limit ≈ 2/ω_N of the highest mode; ≥ 10 steps per excitation period",
    "contact_solver": '"fast" or "reference"',
    "solver_tol_rel": "finite, > 0",
    "solver_tol_abs": "finite, ≥ 0",
    "solver_max_iter": "integer ≥ 1",
}
"""Allowed values of each field, as the core's validation (``Params::validate`` in
crates/beamslider-core/src/params.rs) enforces them; docs/model.md §1 shows this table and
tests/test_model_doc.py probes the core with values at each bound."""


def _toml_value(key: str, v: Any, kind: str) -> Any:
    """One value for the TOML text: floats for float fields and integers for integer fields so that
    the core's (strict) TOML reader sees the type it expects, strings as given so that the core
    names the field in its error."""
    if isinstance(v, bool):
        raise ValueError(f"invalid parameter `{key}` = {v!r}: must be a number")
    if isinstance(v, str):
        if any(0xD800 <= ord(ch) <= 0xDFFF for ch in v):
            raise ValueError(f"invalid parameter `{key}` = {v!r}: must be valid text (a lone surrogate is not)")
        return v
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise ValueError(f"invalid parameter `{key}` = {v!r}: must be a number") from None
    if kind == "int" and math.isfinite(x) and x == int(x):
        return int(x)
    return x


_KINDS = {f.name: str(f.type) for f in dataclasses.fields(Parameters)}


def _to_toml(values: Dict[str, Any]) -> str:
    """TOML text of parameter values (tomli-w; one ``key = value`` line per value, in order, so
    that a core error's line number names the key, see :func:`_one_line`)."""
    return _toml.dumps({k: _toml_value(k, v, _KINDS.get(k, "float")) for k, v in values.items()})


def _one_line(err: ValueError, values: Dict[str, Any]) -> ValueError:
    """Turn the core's multi-line TOML type error about generated text into one line naming the
    field (``invalid parameter `n_modes` = 2.5: invalid type ...``)."""
    msg = str(err)
    m = re.search(r"at line (\d+)", msg)
    if not msg.startswith("cannot read parameters") or m is None:
        return err
    line = int(m.group(1))
    keys = list(values)
    if not 1 <= line <= len(keys):
        return err
    key = keys[line - 1]
    reason = msg.strip().splitlines()[-1]
    return ValueError(f"invalid parameter `{key}` = {values[key]!r}: {reason}")


def resolve(params: "Parameters | None") -> Parameters:
    """``None`` -> defaults; a ``Parameters`` is used as given (and validated by the core)."""
    if params is None:
        return Parameters()
    if isinstance(params, Parameters):
        return params
    if isinstance(params, dict):
        return Parameters.from_dict(params)
    raise TypeError(f"params must be a beamslider.Parameters, a dict or None, not {type(params).__name__}")
