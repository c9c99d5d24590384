"""The joint fit over beam-level (ENMA) and slider-level (free-slider runs) features
(docs/model.md §9.1): beam-level parameters fitted to the beam features, slider-level ones by the
profile fit of the runs with those held. The beam stage comes first (cheap): its selection
re-centres the surrogate's bias (:mod:`.beam`)."""

from __future__ import annotations

import math
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple

from ...params import Parameters
from ..effects import Effect, realise_effects
from ..features import Feature
from ..fitting import EnsembleMany, ModelMany, fit_candidate, profile_fit
from ..models import data_modes
from ..result import CandidateFit
from ..options import DEFAULT, DiscoverOptions
from ..stats import chi2_quantile, gap_of
from . import beam
from .common import Fitter
from .pairs import pairs_to_fit
from ..progress import progress_bar


def fit_sets_joint(cand_effects: Sequence[Effect], max_effects: int, base: Parameters,
                   meas_b: Dict[str, Feature], model_b: Callable[[Parameters], Dict[str, float]],
                   meas_s: Dict[str, Feature], model_many: ModelMany, chi2_b0: float, chi2_s0: float,
                   *, ensemble_many: Optional[EnsembleMany] = None, spread0: Optional[Dict[str, float]] = None,
                   progress: bool = False, options: DiscoverOptions = DEFAULT) -> List[CandidateFit]:
    """Joint fit over beam (ENMA) and slider (run) features, χ² = χ²_beam + χ²_slider. The beam
    features do not depend on slider-level effects (the ENMA is of the beam alone), so a set's
    beam-level parameters are fitted to the beam features (weighted least squares on the
    surrogate; they are far more precise there than in the runs), and its slider-level parameters
    by the profile fit of the runs with those beam-level values held; a set of beam-level effects
    only costs one evaluation of the runs. Returns one fit per set, as a strategy does."""

    names_s = list(meas_s)
    modes = data_modes(meas_s, options.high_final_h) if options.mode_conditioning else None

    def chi2_s_of(ps: List[Parameters]) -> List[Tuple[float, Dict[str, float], Dict[str, float]]]:
        """χ² of the runs of each model (with its ensemble's mean and spread when given)."""
        singles = model_many(ps)
        ens = ensemble_many(ps, singles) if ensemble_many is not None else [None] * len(ps)
        out = []
        for m, e in zip(singles, ens):
            if m is None:
                out.append((math.inf, {}, {}))
                continue
            mean, sp, runs = (e.mean, e.spread, e.runs) if e is not None else (m, dict(spread0 or {}), 1)
            counts = e.mode_counts if e is not None else None
            f = {k: mean[k] for k in names_s if k in mean}
            out.append((gap_of(f, meas_s, sp, runs, modes, counts)[1], mean, sp))
        return out

    n = len(meas_b) + len(meas_s)

    def fit_sets(combos: List[Tuple[Effect, ...]], bar) -> List[CandidateFit]:
        beam_fits: Dict[Tuple[str, ...], CandidateFit] = {}
        for combo in combos:
            eb = tuple(e for e in combo if e.level == "beam")
            if eb and tuple(e.name for e in eb) not in beam_fits:
                beam_fits[tuple(e.name for e in eb)] = fit_candidate(eb, base, meas_b, model_b, diff_step=None,
                                                                     max_nfev=200, options=options)
        out: List[Optional[CandidateFit]] = [None] * len(combos)
        # Sets of beam-level effects only: their runs as one batch.
        only_b = [i for i, c in enumerate(combos) if all(e.level == "beam" for e in c)]
        if only_b:
            ps = [realise_effects(base, beam_fits[tuple(e.name for e in combos[i])].values) for i in only_b]
            for i, (c2, mean, sp) in zip(only_b, chi2_s_of(ps)):
                bf = beam_fits[tuple(e.name for e in combos[i])]
                chi2 = bf.chi2 + c2
                k = len(combos[i])
                out[i] = CandidateFit(bf.effects, dict(bf.values), dict(bf.stderrs), chi2, n - k,
                                      chi2 <= chi2_quantile(n - k, options.significance), chi2 + k * math.log(n), mean, sp)
                bar.update(1)
        for i, combo in enumerate(combos):
            if out[i] is not None:
                continue
            eb = tuple(e for e in combo if e.level == "beam")
            es = [e for e in combo if e.level != "beam"]
            bf = beam_fits.get(tuple(e.name for e in eb)) if eb else None
            sf = profile_fit(es, base, meas_s, model_many=model_many, ensemble_many=ensemble_many, spread0=spread0,
                             fixed=bf.values if bf else None, options=options)
            chi2 = (bf.chi2 if bf else chi2_b0) + sf.chi2
            k = len(combo)
            values = {e.name: sf.values[e.name] for e in combo}
            stderrs = {**(bf.stderrs if bf else {}), **sf.stderrs}
            out[i] = CandidateFit(tuple(e.name for e in combo), values, stderrs, chi2, n - k,
                                  chi2 <= chi2_quantile(n - k, options.significance), chi2 + k * math.log(n), sf.predicted,
                                  sf.model_spread, sf.intervals, sf.roughness)
            bar.update(1)
        return [f for f in out if f is not None]

    bar = progress_bar(progress, len(cand_effects), "discover (joint): fits")
    fits = fit_sets([(e,) for e in cand_effects], bar)
    if max_effects >= 2:
        combos = pairs_to_fit(cand_effects, fits, max_effects, "joint", None, options.extending_pairs,
                              options.guided_pairs)
        bar.total = len(cand_effects) + len(combos)
        bar.refresh()
        fits += fit_sets(combos, bar)
    bar.close()
    return fits


def search(problem: Any, candidates: Sequence[Effect], options: DiscoverOptions) -> List[CandidateFit]:
    """The joint search (module docs): the beam stage where the beam features alone do not fit, then
    every candidate and set over both feature sets (:func:`fit_sets_joint`)."""
    beam_cands = [e for e in candidates if e.level == "beam"]
    before, meas_b, meas_s = problem.before, problem.meas_b, problem.meas_s
    chi2_b0 = gap_of({k: before[k] for k in meas_b}, meas_b)[1]
    if beam_cands and chi2_b0 > chi2_quantile(len(meas_b), options.significance):
        def fit_b(combo: Sequence[Effect], refine: Any = None, joint: Any = None) -> CandidateFit:
            return fit_candidate(combo, problem.base, meas_b, problem.model_b, diff_step=None, max_nfev=200,
                                 options=options)

        with Fitter(problem, beam_cands, "beam", fit_b, progress=False) as fit:
            fits_b = beam.fit_all(problem, fit, beam_cands, options)
        problem.refit_beam_bias(fits_b)
    chi2_s0 = gap_of({k: before[k] for k in meas_s}, meas_s, problem.spread_base, problem.runs_base, problem.modes,
                     problem.counts_base)[1]
    return fit_sets_joint(candidates, problem.max_effects, problem.base, meas_b, problem.model_b, meas_s,
                          problem.model_many, chi2_b0, chi2_s0, ensemble_many=problem.ensemble_many,
                          spread0=problem.spread_base, progress=problem.progress, options=options)
