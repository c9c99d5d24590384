"""The model side of the slider-level features: free-slider runs at measured operating points, their
ensembles and modes (docs/model.md §9.1); the beam level's surrogate and virtual ENMA are
:mod:`.surrogate`."""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _core
from ..measurement import DISPLACEMENT_DETREND_S, Measurement
from ..params import Parameters, native
from .chain import Model, as_model, chain_features, excitation_factor
from .features import Feature, make_feature, recorded_frequency, slider_features
from .options import DEFAULT, DiscoverOptions


@dataclass
class OperatingPoint:
    """A measured free-slider run's conditions."""

    f_ex: float
    a_ex: float
    s0: float
    duration_s: float

    @property
    def tag(self) -> str:
        return f"{self.f_ex:g}Hz_{self.a_ex:g}ms2_s0{self.s0:g}"


def _noise_of(s: np.ndarray) -> float:
    """Standard deviation of white measurement noise on s (from second differences)."""
    if len(s) < 10:
        return 0.0
    return float(np.std(np.diff(s, 2)) / math.sqrt(6))


def measured_slider_features(runs: Sequence[Measurement], options: DiscoverOptions = DEFAULT
                             ) -> Tuple[Dict[str, Feature], Dict[str, str], List[OperatingPoint]]:
    """Features of measured runs (several runs at one operating point: mean and scatter), read as
    ``options`` says (docs/model.md §9, "Ensembles, modes and features")."""
    groups: Dict[Tuple[float, float, float], List[Measurement]] = {}
    for m in runs:
        if m.f_ex is None or m.a_ex is None or m.s0 is None:
            raise ValueError(f"{m.path}: the operating point (f_ex, a_ex, s0) is not in the file name")
        groups.setdefault((m.f_ex, m.a_ex, m.s0), []).append(m)
    feats: Dict[str, Feature] = {}
    behaviours: Dict[str, str] = {}
    ops = []
    for (f, a, s0), ms in groups.items():
        op = OperatingPoint(f, a, s0, float(min(m.t[-1] for m in ms)))
        ops.append(op)
        per = []
        for m in ms:
            h = 1e-3
            amp = m.envelope(1.0) / h
            keep = m.t <= op.duration_s + 1e-9
            fe, beh = slider_features(m.t[keep], m.s[keep], amp[keep], tag=op.tag, noise_s=_noise_of(m.s),
                                      options=options)
            f_rec, se_rec = recorded_frequency(m.t[keep], m.velocity[keep], f, options.recorded_segments)
            if math.isfinite(f_rec):
                fe[f"f_recorded@{op.tag}"] = make_feature(f"f_recorded@{op.tag}", f_rec, se_rec, options)
            per.append(fe)
            behaviours[op.tag] = beh
        for name in per[0]:
            vals = np.array([p[name].value for p in per if name in p])
            ses = np.array([p[name].stderr for p in per if name in p])
            scatter = float(np.std(vals, ddof=1) / math.sqrt(len(vals))) if len(vals) > 1 else 0.0
            feats[name] = make_feature(name, float(np.mean(vals)), math.hypot(float(np.mean(ses)), scatter), options)
    return feats, behaviours, ops


def simulate_ops(params: Parameters, ops: Sequence[OperatingPoint], *, s0_shift: float = 0.0):
    """Full-resolution runs at the operating points (the synthesiser's truth runs)."""
    from ..simulate import simulate

    def one(op: OperatingPoint):
        return simulate(params, f_ex=op.f_ex, a_ex=op.a_ex, s0=op.s0 + s0_shift, t_end=op.duration_s, record_every=5)

    with ThreadPoolExecutor(max_workers=max(1, min(len(ops), os.cpu_count() or 1))) as ex:
        return list(ex.map(one, ops))


RUN_RECORD_EVERY = 5
"""Steps between recorded samples of a model run (Δt = 2e-5 s: 1e-4 s, the measured format's)."""
RUN_KEEP_EVERY = 5
"""Of those, every k-th sample of t, s and the 1-s envelope is kept for the features (5e-4 s)."""


PATH_POINTS = 4000
"""Samples of a run's slider path kept beside its features (about; float32): the report's figure."""

SliderPath = Tuple[np.ndarray, np.ndarray]
"""A run's slider path: t [s] and s, every k-th sample (:data:`PATH_POINTS`)."""

RunCache = Dict[Tuple[Any, ...], Optional[Tuple[Dict[str, Feature], str, SliderPath]]]
"""Features, behaviour and slider path of runs already made (None: failed), by physical
parameters, operating point, a_ex and s0 (:func:`batch_slider_features`): the measurement chain's
candidates other than the excitation level re-read the same runs. About 32 kB a run."""


def _params_key(p: Parameters) -> Tuple[Any, ...]:
    return tuple(sorted(p.to_dict().items()))


def _run_key(m: Model, op: OperatingPoint, shift: float, options: DiscoverOptions = DEFAULT) -> Tuple[Any, ...]:
    """The cache key of model ``m``'s run at ``op`` with s0 shifted by ``shift``, its features read as
    ``options`` says (:meth:`.options.DiscoverOptions.reading_key`: nothing more by default)."""
    return (_params_key(m.params), op.tag, op.f_ex, op.a_ex * excitation_factor(m), op.s0 + shift,
            op.duration_s) + options.reading_key()


RUN_BATCH: ContextVar[Optional[Callable[..., List[Dict[str, Any]]]]] = ContextVar("RUN_BATCH", default=None)
"""The runner of :func:`batch_slider_features`'s jobs: None, the core's parallel runner on this
machine (``_core.run_free_slider_batch``); set, a runner with its signature that returns the same
results in the jobs' order, e.g. one that makes them as tasks of a Dask cluster (docs/cluster.md).
The runs are deterministic, so the runner does not change them."""

RUN_PROGRESS: ContextVar[Optional[Callable[[int], None]]] = ContextVar("RUN_PROGRESS", default=None)
"""Called with the number of runs just made by :func:`batch_slider_features` when it is given no
``on_run`` of its own (set by the discover's fits for their progress)."""


def batch_slider_features(params_list: Sequence[Union[Parameters, Model]], ops: Sequence[OperatingPoint], *,
                          s0_shifts: Optional[Sequence[float]] = None, threads: Optional[int] = None,
                          on_run: Optional[Callable[[int], None]] = None, cache: Optional[RunCache] = None,
                          options: DiscoverOptions = DEFAULT) -> List[Optional[Tuple[Dict[str, Feature], Dict[str, str]]]]:
    """Features of free-slider runs of every model of ``params_list`` at the operating points
    (same code as measured), all runs as one batch of the core's parallel runner
    (``_core.run_free_slider_batch``: interpreter released, Ctrl-C, deterministic). A model whose
    parameters are invalid or one of whose runs fails numerically gives None. ``s0_shifts``: per
    model, a shift of every run's s0 (repeated runs). A :class:`.chain.Model` is run at its
    excitation factor times a_ex and its features are those its measurement chain reports
    (docs/model.md §9.1). Identical runs are made once; ``cache`` keeps them across calls. ``options``:
    how the runs' features are read (docs/model.md §9, "Ensembles, modes and features")."""
    shifts = list(s0_shifts) if s0_shifts is not None else [0.0] * len(params_list)
    models = [as_model(p) for p in params_list]
    known: RunCache = cache if cache is not None else {}
    keys: List[List[Tuple[Any, ...]]] = []
    jobs, todo = [], []
    for m, d in zip(models, shifts):
        row = []
        for op in ops:
            key = _run_key(m, op, d, options)
            if key not in known and key not in todo:
                todo.append(key)
                jobs.append((native(m.params), op.f_ex, key[3], key[4], op.duration_s))
            row.append(key)
        keys.append(row)
    if jobs:
        runner = RUN_BATCH.get() or _core.run_free_slider_batch
        res = runner(jobs, record_every=RUN_RECORD_EVERY, keep_every=RUN_KEEP_EVERY, window_s=1.0,
                     detrend_s=DISPLACEMENT_DETREND_S, threads=threads, on_done=on_run or RUN_PROGRESS.get())
        for key, r in zip(todo, res):
            known[key] = None if "error" in r else _features_of_run(r, key[1], options)
    out: List[Optional[Tuple[Dict[str, Feature], Dict[str, str]]]] = []
    for m, row in zip(models, keys):
        feats: Dict[str, Feature] = {}
        behaviours: Dict[str, str] = {}
        ok = True
        for op, key in zip(ops, row):
            r = known[key]
            if r is None:
                ok = False
                continue
            feats.update(chain_features(with_recorded_frequency(r[0], op, options), m, options))
            behaviours[op.tag] = r[1]
        out.append((feats, behaviours) if ok else None)
    return out


def slider_paths(models: Sequence[Union[Parameters, Model]], ops: Sequence[OperatingPoint], *,
                 threads: Optional[int] = None, cache: Optional[RunCache] = None,
                 options: DiscoverOptions = DEFAULT) -> List[List[Optional[SliderPath]]]:
    """Per model and operating point, the slider's path (t [s], s) of its run from s0 as the
    model's measurement chain would record it — stamps τ t, camera o + k s, the shaker at its
    excitation factor times a_ex (docs/model.md §9.1) — about :data:`PATH_POINTS` samples; None
    where the run fails. Runs not in ``cache`` are made (:func:`batch_slider_features`)."""
    ms = [as_model(p) for p in models]
    known: RunCache = cache if cache is not None else {}
    for m in ms:  # runs kept without their path (.runstore) are made again
        for op in ops:
            r = known.get(_run_key(m, op, 0.0, options))
            if r is not None and r[2] is None:
                del known[_run_key(m, op, 0.0, options)]
    batch_slider_features(ms, ops, threads=threads, cache=known, options=options)
    out: List[List[Optional[SliderPath]]] = []
    for m in ms:
        k, o, tau = m.value("position_scale"), m.value("position_offset"), m.value("time_base")
        runs = [known[_run_key(m, op, 0.0, options)] for op in ops]
        out.append([None if r is None else (tau * r[2][0], o + k * r[2][1]) for r in runs])
    return out


def with_recorded_frequency(feats: Dict[str, Feature], op: OperatingPoint, options: DiscoverOptions = DEFAULT
                            ) -> Dict[str, Feature]:
    """A model run's features with the excitation frequency it records (``f_recorded``): f_ex
    itself, the run's time being exact (:func:`.features.recorded_frequency`)."""
    name = f"f_recorded@{op.tag}"
    return {**feats, name: make_feature(name, op.f_ex, 0.0, options)}


def _features_of_run(r: Dict[str, Any], tag: str, options: DiscoverOptions = DEFAULT
                     ) -> Optional[Tuple[Dict[str, Feature], str, SliderPath]]:
    """Features, behaviour and slider path (:data:`PATH_POINTS`) of one run of the core's runner,
    None for a run too short to classify (the slider left the beam early: a failed model, as a run
    that fails numerically)."""
    try:
        feats, behaviour = slider_features(r["t"], r["s"], r["amplitude_h"], tag=tag, options=options)
        k = max(1, len(r["t"]) // PATH_POINTS)
        return feats, behaviour, (r["t"][::k].astype(np.float32), r["s"][::k].astype(np.float32))
    except ValueError:
        return None


MODE_FEATURES = ("speed_late", "s_final", "amplitude_final_h", "s_turning")
"""Features that depend on the state a run ends in (its mode, :func:`run_mode`): the jump-up time
and the phase of a relaxation cycle at the end of a run change with perturbations the data
cannot resolve (at (124 Hz, 14 m/s²) with μ = 0.26, one start of 17 within ±0.004 of s0 has not
jumped up after 60 s: docs/results/discover/table.md), so these features are bimodal across a model's
ensemble. They are compared only with runs in the data's mode; ``speed_early`` is not."""


Mode = Tuple[bool, bool]
"""A run's mode: (ends on the high branch, has a turning point) (:func:`run_mode`)."""


class Modes(Dict[str, Optional[Mode]]):
    """The data's mode per operating-point tag (:func:`data_modes`), with the final amplitude
    ``high_h`` [h] from which a run ends high (``DiscoverOptions.high_final_h``): a model's run is
    in the data's mode when :meth:`mode_of` gives the same (docs/model.md §9, "Ensembles, modes and features")."""

    def __init__(self, modes: Any = (), high_h: float = DEFAULT.high_final_h) -> None:
        super().__init__(modes)
        self.high_h = float(high_h)

    def mode_of(self, values: Dict[str, float], tag: str) -> Optional[Mode]:
        """The mode of a run at ``tag`` (:func:`run_mode` at this ``high_h``)."""
        return run_mode(values, tag, self.high_h)


def tag_of(name: str) -> Optional[str]:
    """The operating-point tag of a slider-level feature ``<feature>@<tag>`` (None: beam level)."""
    return name.split("@", 1)[1] if "@" in name else None


def as_modes(modes: Any) -> Optional[Modes]:
    """``modes`` as :class:`Modes` (a plain mapping: at the default ``high_h``; None stays None)."""
    return modes if modes is None or isinstance(modes, Modes) else Modes(modes)


def run_mode(values: Dict[str, float], tag: str, high_h: float = DEFAULT.high_final_h) -> Optional[Mode]:
    """The mode of a run at operating point ``tag``: (ends on the high branch, has a turning
    point), from its features (``values``: name -> value); None without a final amplitude."""
    a = values.get(f"amplitude_final_h@{tag}")
    if a is None or not math.isfinite(a):
        return None
    return (a >= high_h, f"s_turning@{tag}" in values)


def data_modes(meas: Dict[str, Feature], high_h: float = DEFAULT.high_final_h) -> Modes:
    """The measured runs' modes, per operating-point tag (a run ends high from ``high_h``)."""
    vals = {k: f.value for k, f in meas.items()}
    tags = sorted({t for t in map(tag_of, meas) if t is not None})
    return Modes({t: run_mode(vals, t, high_h) for t in tags}, high_h)


def is_mode_feature(name: str) -> bool:
    """Whether ``name`` (``<feature>@<tag>``) is one of :data:`MODE_FEATURES`."""
    return "@" in name and name.split("@", 1)[0] in MODE_FEATURES


def unreached_mode_features(keys, counts: Optional[Dict[str, int]]) -> set:
    """The mode features among ``keys`` at operating points where none of the baseline's runs ends
    in the data's mode (``counts``: per tag, the baseline's runs in it; a tag not in it counts as
    reached): their changes from the baseline are a mode switch, no candidate's signature, so the
    linearised model leaves them out (docs/model.md §9.1)."""
    counts = counts or {}
    return {k for k in keys if is_mode_feature(k) and counts.get(tag_of(k) or "", 1) == 0}


def mode_penalty(k: int, runs: int) -> float:
    """−2 log of the probability of the data's mode, relative to a mode all ``runs`` runs share:
    2 log((R + ½)/(k + ½)) for ``k`` of R runs in it (the ½: Jeffreys' estimate, so that a mode
    none of the runs reached keeps a finite probability)."""
    return 2.0 * math.log((runs + 0.5) / (k + 0.5))


@dataclass
class Ensemble:
    """Features of one model over runs from s0 + ``DiscoverOptions.ensemble_s0_shifts``."""

    mean: Dict[str, float]
    """Mean of each feature over the runs that have it (at least half of them); for the features
    of :data:`MODE_FEATURES`, over the runs in the data's mode when modes are given (absent when
    none is)."""
    spread: Dict[str, float]
    """Standard deviation over those runs: the model's sensitivity to what the data cannot resolve."""
    runs: int
    behaviours: Dict[str, str]
    """Behaviour types of the unshifted run."""
    mode_counts: Dict[str, int] = field(default_factory=dict)
    """Per operating-point tag: how many of the runs end in the data's mode (:func:`run_mode`)."""
    mode_spread: Dict[str, float] = field(default_factory=dict)
    """Mode features: the standard deviation over the runs in the data's mode (at least two),
    with ``mode_counts − 1`` degrees of freedom; :attr:`spread` uses it only from
    ``DiscoverOptions.mode_min_dof`` on."""


def combine_ensemble(members: Sequence[Optional[Tuple[Dict[str, Feature], Dict[str, str]]]],
                     modes: Optional[Modes] = None, mode_min_dof: int = DEFAULT.mode_min_dof) -> Optional[Ensemble]:
    """Mean and spread of the features of one model's runs (the first: unshifted; None: failed).
    ``modes``: the data's mode per tag (:func:`data_modes`); the features of
    :data:`MODE_FEATURES` then come from the runs in that mode only, their spread from those runs
    when they give at least ``mode_min_dof`` degrees of freedom, else from all (an upper bound)."""
    if not members or members[0] is None:
        return None
    modes = as_modes(modes)
    ok = [m[0] for m in members if m is not None]
    vals = [{k: f.value for k, f in m.items()} for m in ok]
    counts: Dict[str, int] = {}
    in_mode: Dict[str, List[int]] = {}
    for tag, md in (modes or {}).items():
        if md is None:
            continue
        idx = [i for i, v in enumerate(vals) if modes.mode_of(v, tag) == md]
        in_mode[tag] = idx
        counts[tag] = len(idx)
    names = sorted({k for m in ok for k in m})
    mean, spread, mode_spread = {}, {}, {}
    for k in names:
        tag = tag_of(k)
        v_all = np.array([m[k].value for m in ok if k in m])
        sd_all = float(np.std(v_all, ddof=1)) if len(v_all) > 1 else 0.0
        if modes is not None and tag in in_mode and is_mode_feature(k):
            v = np.array([vals[i][k] for i in in_mode[tag] if k in vals[i]])
            if len(v) == 0:
                continue
            mean[k] = float(np.mean(v))
            if len(v) > 1:
                mode_spread[k] = float(np.std(v, ddof=1))
            # Few runs in the mode: their spread is unreliable; that over all runs is an upper bound.
            spread[k] = mode_spread[k] if len(v) - 1 >= mode_min_dof else sd_all
        elif 2 * len(v_all) >= len(members):
            mean[k] = float(np.mean(v_all))
            spread[k] = sd_all
    return Ensemble(mean, spread, len(ok), members[0][1], counts, mode_spread)


def ensemble_slider_features(params_list: Sequence[Union[Parameters, Model]], ops: Sequence[OperatingPoint], *,
                             threads: Optional[int] = None, on_run: Optional[Callable[[int], None]] = None,
                             central: Optional[Sequence[Optional[Tuple[Dict[str, Feature], Dict[str, str]]]]] = None,
                             modes: Optional[Modes] = None, cache: Optional[RunCache] = None,
                             options: DiscoverOptions = DEFAULT) -> List[Optional[Ensemble]]:
    """Per model, the features of its runs from s0 + ``options.ensemble_s0_shifts`` (one batch of the
    core's runner for all models): mean and spread. ``central``: the unshifted runs' features when
    already known (their runs are not repeated). ``modes``: the data's modes (:func:`combine_ensemble`).
    None for a model whose unshifted runs fail. ``cache``, ``options``: :func:`batch_slider_features`."""
    shifts = list(options.ensemble_s0_shifts) if central is None else [d for d in options.ensemble_s0_shifts if d != 0.0]
    res = batch_slider_features([p for p in params_list for _ in shifts], ops,
                                s0_shifts=[d for _ in params_list for d in shifts], threads=threads, on_run=on_run,
                                cache=cache, options=options)
    out: List[Optional[Ensemble]] = []
    for i in range(len(params_list)):
        members = list(res[i * len(shifts):(i + 1) * len(shifts)])
        if central is not None:
            members = [central[i]] + members
        out.append(combine_ensemble(members, modes, options.mode_min_dof))
    return out


def model_slider_features(params: Parameters, ops: Sequence[OperatingPoint], *, s0_shift: float = 0.0,
                          options: DiscoverOptions = DEFAULT) -> Tuple[Dict[str, Feature], Dict[str, str]]:
    """Features of free-slider runs of the model at the operating points (same code as measured);
    the runs go through the core's parallel runner (:func:`batch_slider_features`). Raises
    ``ValueError`` for invalid parameters and ``SimulationError`` when a run fails."""
    jobs = [(native(params), op.f_ex, op.a_ex, op.s0 + s0_shift, op.duration_s) for op in ops]
    res = _core.run_free_slider_batch(jobs, record_every=RUN_RECORD_EVERY, keep_every=RUN_KEEP_EVERY, window_s=1.0,
                                      detrend_s=DISPLACEMENT_DETREND_S)
    feats: Dict[str, Feature] = {}
    behaviours: Dict[str, str] = {}
    for op, r in zip(ops, res):
        if "error" in r:
            raise (ValueError if r["error_kind"] == "invalid" else _core.SimulationError)(f"{op.tag}: {r['error']}")
        fe, beh = slider_features(r["t"], r["s"], r["amplitude_h"], tag=op.tag, options=options)
        feats.update(with_recorded_frequency(fe, op, options))
        behaviours[op.tag] = beh
    return feats, behaviours


# --- naming ---------------------------------------------------------------------------------------
