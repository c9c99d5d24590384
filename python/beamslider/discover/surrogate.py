"""The beam level's model side (docs/model.md §9): the surrogate of single-mode relations of the
core's first mode with preload, the excitation levels of an ENMA, and a virtual ENMA's features."""

from __future__ import annotations

import math
from typing import Dict, List, Sequence, Tuple

import numpy as np

from .. import _core, enma
from ..enma import EnmaData
from ..params import Parameters, native
from .features import Feature, enma_features
from .options import DEFAULT, DiscoverOptions


_X5 = [1 / 6, 1 / 3, 1 / 2, 2 / 3, 5 / 6]


def beam_surrogate(params: Parameters) -> Dict[str, float]:
    """Beam-level features of a model from the single-mode relations (docs/model.md §9) of its first
    mode with preload (the core's ``Beam::first_mode``: eigenpair of diag(ω²) + H₀K,
    b* = (k_ax/2)(vᵀKv)² h²/ψ(L/2)², shape ψ = Σ vₙφₙ)."""
    b = _core.beam_properties(native(params), _X5)
    psi = np.asarray(b["mode1_vector"]) @ np.asarray(b["phi"])
    return dict(f0_hz=b["omega1_preload_rad_s"] / (2 * math.pi), b_star=b["b_star_preload_per_s2"],
                damping_0=params.damping_ratio, damping_2=params.damping_ratio_quadratic,
                shape_L6=0.5 * (psi[0] + psi[4]) / psi[2], shape_L3=0.5 * (psi[1] + psi[3]) / psi[2])


def levels_for(data: EnmaData, params: Parameters) -> List[float]:
    lv = np.asarray(data.level_m_s2, dtype=float)
    if np.all(np.isfinite(lv)) and len(lv):
        return sorted(set(float(x) for x in lv))
    # Unknown levels: a~ ≈ γ₁ φ₁(L/2) a / (2 D ω₁²) / h at phase resonance.
    b = _core.beam_properties(native(params))
    gain = b["gamma"][0] * b["phi_mid"] / (2 * max(params.damping_ratio, 1e-5) * b["omega_rad_s"][0] ** 2)
    gain /= params.thickness_m
    amps = np.quantile(data.amplitude_h, np.linspace(0, 1, 12))
    return sorted(set(round(float(a / abs(gain)), 6) for a in amps if a > 0))


def simulated_enma_features(params: Parameters, levels_m_s2: Sequence[float], *, options: DiscoverOptions = DEFAULT
                            ) -> Tuple[Dict[str, Feature], EnmaData]:
    """Features of a virtual ENMA (up run) of the model at the given levels (floored by ``options``)."""
    data = enma.virtual(params, levels_m_s2=list(levels_m_s2), up_and_down=False)
    return enma_features(data, options=options), data


# --- slider level ---------------------------------------------------------------------------------
