"""The measurement chain as candidate effects (docs/model.md §9.1): a model together with the
calibration errors of the instruments that measured its data, and the map from the model's
slider-level features to what those instruments would report."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Tuple, Union

from ..params import Parameters
from .effects import EFFECTS, realise_effects
from .features import Feature, make_feature
from .options import DEFAULT, DiscoverOptions

Chain = Tuple[Tuple[str, float], ...]
"""Measurement-chain values by effect name (sorted; empty: an ideal chain)."""


@dataclass(frozen=True)
class Model:
    """A model (its physical parameters) seen through a measurement chain."""

    params: Parameters
    chain: Chain = ()

    def value(self, name: str) -> float:
        """The chain parameter ``name`` (its neutral value when not set)."""
        return dict(self.chain).get(name, EFFECTS[name].neutral)


def as_model(x: Union[Parameters, Model]) -> Model:
    """``x`` as a :class:`Model` (a plain parameter set: an ideal measurement chain)."""
    return x if isinstance(x, Model) else Model(x)


def realise_model(p: Parameters, values: Dict[str, float]) -> Model:
    """``p`` with the effects set to ``values`` (by name): the physical ones realised in the
    parameters (:func:`.effects.realise_effects`), the measurement chain's kept beside them."""
    chain = tuple(sorted((n, float(v)) for n, v in values.items() if EFFECTS[n].chain))
    return Model(realise_effects(p, {n: v for n, v in values.items() if not EFFECTS[n].chain}), chain)


def excitation_factor(m: Model) -> float:
    """Factor on the a_ex of every run: the level the shaker really ran at over the named one."""
    return m.value("excitation_gain")


def chain_map(name: str, value: float, m: Model) -> float:
    """The slider-level feature ``name`` (``<feature>@<tag>``) of value ``value`` as the chain of
    ``m`` reports it (docs/model.md §9.1): the velocity gain G and the time base τ (stamps τ t)
    scale the amplitude integrated from the velocity by G τ; the camera reports s as o + k s, so
    positions map to o + k s and speeds to k/τ times the true ones; the stamps record the
    excitation frequency as f_ex/τ."""
    if not m.chain:
        return value
    base = name.split("@", 1)[0]
    k, o, tau = m.value("position_scale"), m.value("position_offset"), m.value("time_base")
    if base == "amplitude_final_h":
        return value * m.value("velocity_gain") * tau
    if base in ("speed_early", "speed_late"):
        return value * k / tau
    if base in ("s_turning", "s_final"):
        return o + k * value
    if base == "f_recorded":
        return value / tau
    return value


def chain_features(feats: Dict[str, Feature], m: Model, options: DiscoverOptions = DEFAULT) -> Dict[str, Feature]:
    """:func:`chain_map` applied to a run's features (their uncertainties re-floored by ``options``)."""
    if not m.chain:
        return feats
    return {k: make_feature(k, chain_map(k, f.value, m), f.stderr, options) for k, f in feats.items()}
