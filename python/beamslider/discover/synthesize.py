"""Hidden-effect test data from a truth model, with noise and a seed: a virtual ENMA CSV or free-slider
runs in the published measured format."""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _core, enma
from ..enma import EnmaData
from ..measurement import write_measurement
from ..params import Parameters, resolve
from .chain import Model, realise_model
from .effects import CHAIN_EFFECTS, EFFECTS
from .models import OperatingPoint, simulate_ops

PathLike = Union[str, "os.PathLike[str]"]


def synthesize_enma(truth: Optional[Parameters] = None, *, levels_m_s2: Sequence[float] = enma.DEFAULT_LEVELS_M_S2,
                    frequency_rel: float = 0.002, damping_rel: float = 0.02, shape_abs: float = 0.002,
                    repeats: int = 2, seed: int = 0) -> EnmaData:
    """Hidden-effect ENMA data: a virtual ENMA (up and down) of ``truth`` with Gaussian noise
    (relative on frequency and damping, absolute on the normalised shape) and ``repeats``
    independently noisy repetitions, reproducible by ``seed``."""
    data = enma.virtual(resolve(truth), levels_m_s2=levels_m_s2)
    noisy = enma.with_noise(data, frequency_rel=frequency_rel, damping_rel=damping_rel, seed=seed, repeats=repeats)
    if shape_abs > 0:
        rng = np.random.default_rng(seed + 7919)
        sh = noisy.shape + shape_abs * rng.standard_normal(noisy.shape.shape)
        sh[:, 2] = 1.0  # the shape is normalised at L/2
        noisy.shape = sh
    noisy.source = f"synthetic ENMA (seed {seed})"
    return noisy


def truth_from_toml_text(text: str) -> Model:
    """A truth model from TOML text: parameters (docs/model.md §1, missing ones at their defaults)
    and, by name, effects of discover's library (docs/model.md §9.1, e.g.
    ``natural_frequency_detuning = 1.03``, ``contact_spacing = 0.0115``, ``excitation_gain = 0.95``),
    each in the units ``discover`` reports it in and realised on the parameters as ``discover``
    realises its candidates; the measurement chain's effects are returned as the model's chain.
    A key that is neither, or an effect and the parameter it sets both given, is a ``ValueError``."""
    from .. import _toml

    try:
        table = _toml.loads(text)
    except _toml.TOMLDecodeError as e:
        raise ValueError(f"invalid TOML: {e}") from None
    fields = set(Parameters().to_dict())
    effects = {k: v for k, v in table.items() if k in EFFECTS and k not in fields}
    unknown = sorted(k for k in table if k not in fields and k not in EFFECTS)
    if unknown:
        raise ValueError(f"unknown key {unknown[0]!r} in the truth: neither a parameter ({', '.join(sorted(fields))}) "
                         f"nor an effect of discover's library ({', '.join(EFFECTS)})")
    for k, v in effects.items():
        e = EFFECTS[k]
        if not e.chain and e.realise is None and e.field in table:
            raise ValueError(f"the truth sets {e.field} twice: as the parameter and as the effect {k!r}")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"the truth's effect {k!r} must be a finite number, not {v!r}")
    params = Parameters.from_toml_text(_toml.dumps({k: v for k, v in table.items() if k not in effects}))
    return realise_model(params, {k: float(v) for k, v in effects.items()})


def truth_from_toml(path: PathLike) -> Model:
    """:func:`truth_from_toml_text` of the UTF-8 file ``path`` (errors prefixed with the path)."""
    from .._toml import read_config_file

    return read_config_file(path, truth_from_toml_text)


def measured_file_name(f_ex: float, a_ex: float, s0: float) -> str:
    """The name of a measured file of this operating point (the laboratory's convention)."""
    s0_txt = f"{s0:g}".replace("0.", "0")
    return f"Time_VelBeam_RelSliderPos__fex{f_ex:g}_ExcLevel{a_ex:g}_RelSliderPosStart{s0_txt}.txt"


def synthesize_slider_runs(truth: Optional[Parameters] = None, *, operating_points: Sequence[Tuple[float, float, float]],
                           duration_s: float, out_dir: PathLike, noise_s: float = 0.001,
                           noise_velocity_m_s: float = 0.002, seed: int = 0, s0_offset: float = 0.0,
                           chain: Optional[Dict[str, float]] = None) -> List[Path]:
    """Hidden-effect free-slider runs of ``truth`` written in the published measured format
    (time, beam velocity at 4L/7, s at 1e-4 s; file names carry the operating point), with white
    noise on s and the velocity, reproducible by ``seed``. Returns the file paths.

    ``s0_offset``: the truth runs start at s0 + s0_offset while the files name s0 (a slider placed
    by hand is never exactly where the label says). With 0 the model run at exactly the truth
    repeats the data's realisation of the chaotic locomotion, which no real measurement allows (the
    "inverse crime" of synthetic tests): a scan point on the truth then scores far better than its
    neighbours (docs/results/discover/table.md).

    ``chain``: calibration errors of the measurement chain (docs/model.md §9.1) applied to the
    signals: ``excitation_gain`` g (the truth runs at g a_ex, the files name a_ex),
    ``velocity_gain`` G (velocity × G), ``position_offset`` o and ``position_scale`` k (s written
    as o + k s), ``time_base`` τ (samples stamped τ t)."""
    ch = dict(chain or {})
    unknown = sorted(set(ch) - set(CHAIN_EFFECTS))
    if unknown:
        raise ValueError(f"unknown measurement-chain parameter {unknown[0]!r}")
    g, gv = float(ch.get("excitation_gain", 1.0)), float(ch.get("velocity_gain", 1.0))
    o, k, tau = float(ch.get("position_offset", 0.0)), float(ch.get("position_scale", 1.0)), float(ch.get("time_base", 1.0))
    p = resolve(truth)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ops = [OperatingPoint(f, a, s0, duration_s) for f, a, s0 in operating_points]
    sim_ops = [OperatingPoint(f, a * g, s0 + float(s0_offset), duration_s) for f, a, s0 in operating_points]
    rng = np.random.default_rng(seed)
    paths = []
    for op, r in zip(ops, simulate_ops(p, sim_ops)):
        if not r.completed:
            raise _core.SimulationError(f"truth run at {op.tag} stopped: {r.message}")
        t = r.t
        vel = gv * np.gradient(r.w, t) + noise_velocity_m_s * rng.standard_normal(len(t))
        s = o + k * r.s + noise_s * rng.standard_normal(len(t))
        path = out / measured_file_name(op.f_ex, op.a_ex, op.s0)
        write_measurement(path, tau * t, vel, s)
        paths.append(path)
    return paths


# --- report ---------------------------------------------------------------------------------------
