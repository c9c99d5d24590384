"""The problem a discover solves, built once (docs/model.md §9): the measured features and their
uncertainties, the level (beam, slider or joint), the baseline with its ensemble and its test, the
candidates, and the model side every search strategy (:mod:`.search`) and the rule (:mod:`.rule`)
evaluate: a set of parameters' features, an ensemble's, a fit of a set of effects, the linearised
model's predictions and the full simulation of an updated model."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Tuple

from .. import _core
from ..enma import EnmaData
from ..measurement import Measurement
from ..params import Parameters, resolve
from .chain import Model
from .effects import EFFECTS, Effect, realise_effects
from .features import Feature, enma_features
from .fitting import EnsembleMany, ModelMany, fit_candidate, profile_fit
from .models import (Ensemble, Modes, RunCache, batch_slider_features, data_modes,
                     ensemble_slider_features, measured_slider_features, slider_paths, unreached_mode_features)
from .options import DiscoverOptions
from .refine import step_chi2
from .result import After, CandidateFit
from .rule import best_single, judge, no_set_can_win, select
from .runstore import RunStore
from .separability import predict_singles, rank_pairs, slider_changes, slider_sensitivities
from .surrogate import beam_surrogate, levels_for, simulated_enma_features
from .stats import (baseline_test, excess, gap_of, interval_z, lrt_threshold, missing_z, right_fit_bound,
                    short_of_baseline, sigma)


@dataclass
class SearchRecord:
    """What a search records beside its fits (``report.json``: ``guided_pairs``, ``joint_refinement``)."""

    guided: List[Dict[str, Any]] = field(default_factory=list)
    refined: List[Dict[str, Any]] = field(default_factory=list)


class Problem:
    """The measured features, the baseline and the candidates of one discover (:meth:`build`), and
    the model side evaluated on them."""

    level: str
    base: Parameters
    candidates: List[Effect]
    options: DiscoverOptions
    meas: Dict[str, Feature]
    before: Dict[str, float]

    @classmethod
    def build(cls, *, enma_data: Optional[EnmaData], measured: Optional[Sequence[Measurement]],
              baseline: Optional[Parameters], effects: Optional[Sequence[str]], max_effects: int,
              threads: Optional[int], runs_file: Any, progress: Any, options: DiscoverOptions) -> "Problem":
        """Check the arguments, read the features, run the baseline (its ensemble at the slider
        level) and test it (docs/model.md §9)."""
        if threads is not None and not (isinstance(threads, int) and threads >= 1):
            raise ValueError(f"invalid threads = {threads!r}: must be an integer >= 1")
        if enma_data is None and measured is None:
            raise ValueError("give enma_data (beam level), measured runs (slider level) or both (joint fit)")
        if measured is not None and len(measured) == 0:
            raise ValueError("invalid measured = []: give at least one run")
        self = cls()
        self.level = "joint" if (enma_data is not None and measured is not None) else (
            "beam" if enma_data is not None else "slider")
        levels = {"beam", "slider"} if self.level == "joint" else {self.level}
        names = list(effects) if effects is not None else [n for n, e in EFFECTS.items() if e.level in levels]
        unknown = [n for n in names if n not in EFFECTS]
        if unknown:
            raise ValueError(f"unknown effect {unknown[0]!r}: known are {', '.join(EFFECTS)}")
        self.candidates = [EFFECTS[n] for n in names if EFFECTS[n].level in levels]
        if not self.candidates:
            raise ValueError(f"none of the effects {names} acts at the {self.level} level")
        self.base, self.options, self.max_effects = resolve(baseline), options, max_effects
        self.enma_data, self.measured, self.threads, self.progress = enma_data, measured, threads, progress
        self.record = SearchRecord()
        self.provisional: Any = None  # the reporter of the provisional answer (.provisional), set by discover
        self.run_cache: RunCache = {}
        if runs_file is not None and measured is not None:
            self.run_cache = runs_file if isinstance(runs_file, RunStore) else RunStore(runs_file)
        self.meas, self.before, self.behaviours = {}, {}, {}
        self.spread_base: Dict[str, float] = {}
        self.runs_base = len(options.ensemble_s0_shifts) if measured is not None else 0
        self.modes: Optional[Modes] = None
        self.counts_base: Dict[str, int] = {}
        self.bias: Dict[str, float] = {}
        if enma_data is not None:
            self._read_enma(enma_data)
        if measured is not None:
            self._read_runs(measured)
        test = baseline_test(self.before, self.meas, self.spread_base, self.runs_base, self.modes, self.counts_base,
                             options.significance)
        self.before, self.gap_before, self.chi2_0, self.n = test.before, test.gap, test.chi2, test.n
        self.z_worst, self.baseline_fits = test.z_worst, test.fits
        if self.level == "slider":  # the baseline fits as right models do (§9.1, "Goodness of fit")
            self.baseline_fits = test.fits and test.chi2 <= right_fit_bound(test.n, 0, options)
        self.excess_before = excess(self.chi2_0, self.n, self.n)
        self.thr_m = lrt_threshold(1, len(self.candidates), options.significance)  # the price of a parameter
        self.sig_base = ({k: sigma(self.meas[k], self.spread_base.get(k, 0.0), self.runs_base) for k in self.meas}
                         if measured is not None else {})
        self._changes: Dict[str, Dict[str, float]] = {}
        return self

    def _read_enma(self, enma_data: EnmaData) -> None:
        # The beam-level surrogate, bias-corrected by a virtual ENMA of the baseline (docs/model.md §9).
        self.meas_b = enma_features(enma_data, options=self.options)
        self.enma_levels = levels_for(enma_data, self.base)
        sim_base, _ = simulated_enma_features(self.base, self.enma_levels, options=self.options)
        sur_base = beam_surrogate(self.base)
        self.bias.update({k: sim_base[k].value - sur_base[k] for k in sim_base if k in sur_base})
        self.meas.update(self.meas_b)
        self.before.update({k: f.value for k, f in sim_base.items()})

    def _read_runs(self, measured: Sequence[Measurement]) -> None:
        self.meas_s, beh_meas, self.ops = measured_slider_features(measured, self.options)
        self.modes = data_modes(self.meas_s, self.options.high_final_h) if self.options.mode_conditioning else None
        # Baseline: an ensemble of runs from s0 + options.ensemble_s0_shifts (one batch): the mean is the
        # prediction, the spread the model's sensitivity to what the data cannot resolve; with
        # modes, the mode features' mean and spread over the runs in the data's mode.
        ens_base = ensemble_slider_features([self.base], self.ops, threads=self.threads, modes=self.modes,
                                            cache=self.run_cache, options=self.options)[0]
        if ens_base is None:
            raise _core.SimulationError("the baseline model's runs at the measured operating points failed")
        self.spread_base = {k: ens_base.spread.get(k, 0.0) for k in self.meas_s}
        self.behaviours = {"measured": beh_meas, "baseline": ens_base.behaviours}
        self.meas.update(self.meas_s)
        self.before.update(ens_base.mean)
        self.counts_base = ens_base.mode_counts

    # --- the model side ------------------------------------------------------------------------------

    @property
    def model_many(self) -> Optional[ModelMany]:
        """Slider level: the features of several models' runs from s0, one batch (None at the beam level)."""
        return self._model_many if self.measured is not None else None

    @property
    def ensemble_many(self) -> Optional[EnsembleMany]:
        """Slider level: the ensembles of several models, their unshifted runs given (None at the beam level)."""
        return self._ensemble_many if self.measured is not None else None

    def _model_many(self, ps: List[Any]) -> List[Optional[Dict[str, float]]]:
        return [None if r is None else {k: f.value for k, f in r[0].items()}
                for r in batch_slider_features(ps, self.ops, threads=self.threads, cache=self.run_cache,
                                               options=self.options)]

    def _ensemble_many(self, ps: List[Any], central: List[Optional[Dict[str, float]]]) -> List[Optional[Ensemble]]:
        cen = [None if c is None else ({k: Feature(k, v, 0.0) for k, v in c.items()}, {}) for c in central]
        return ensemble_slider_features(ps, self.ops, threads=self.threads, central=cen, modes=self.modes,
                                        cache=self.run_cache, options=self.options)

    def model_b(self, p: Parameters) -> Dict[str, float]:
        """Beam level: the surrogate's features of ``p``, bias-corrected."""
        s_ = beam_surrogate(p)
        return {k: v + self.bias.get(k, 0.0) for k, v in s_.items()}

    def model_fn(self, p: Parameters) -> Dict[str, float]:
        """The features of ``p``: the beam surrogate's and one run per operating point."""
        out: Dict[str, float] = {}
        if self.enma_data is not None:
            out.update(self.model_b(p))
        if self.model_many is not None:
            r = self.model_many([p])[0]
            if r is None:
                raise _core.SimulationError("a run of the model failed")
            out.update(r)
        return out

    def refit_beam_bias(self, fits_b: List[CandidateFit]) -> None:
        """Re-centre the surrogate's bias correction at the model the likelihood-ratio selection
        picks (the surrogate's own errors would otherwise count against adequacy)."""
        best_b, _ = select(fits_b, gap_of({k: self.before[k] for k in self.meas_b}, self.meas_b)[1], len(self.meas_b),
                           alpha=self.options.significance)
        if best_b is not None:
            chosen = realise_effects(self.base, {e: best_b.values[e] for e in best_b.effects})
            sim_c, _ = simulated_enma_features(chosen, self.enma_levels, options=self.options)
            sur_c = beam_surrogate(chosen)
            self.bias.clear()
            self.bias.update({k: sim_c[k].value - sur_c[k] for k in sim_c if k in sur_c})

    def fit(self, combo: Sequence[Effect], refine: Optional[int] = None, joint: Optional[bool] = None,
            options: Optional[DiscoverOptions] = None) -> CandidateFit:
        """One set of effects fitted (beam level: least squares on the surrogate; else the profile fit
        of the runs, ``refine`` levels, ``joint`` refinement; docs/model.md §9.1), with the problem's
        options (or ``options``)."""
        o = self.options if options is None else options
        if self.level == "beam":
            return fit_candidate(combo, self.base, self.meas, self.model_fn, diff_step=None, max_nfev=200, options=o)
        f = profile_fit(combo, self.base, self.meas, self.model_fn, model_many=self.model_many,
                        ensemble_many=self.ensemble_many, spread0=self.spread_base, refine=refine, joint=joint,
                        options=o)
        if len(combo) == 1 and self.measured is not None and self.enma_data is None:
            # One effect: the baseline's ensemble is its profile at the baseline value (§9.1, "One effect").
            e = combo[0]
            f.intervals[e.name] = short_of_baseline(f.intervals[e.name], f.values[e.name], e.baseline_value(self.base),
                                                    f.chi2, self.chi2_0, interval_z(o.interval_level))
        return f

    # --- the linearised model (docs/model.md §9.1, "Cost") ---------------------------------------------

    def resid(self) -> Dict[str, float]:
        """The data's residuals from the baseline in units of their uncertainty."""
        return {k: (self.meas[k].value - self.before[k]) / s for k, s in self.sig_base.items() if k in self.before}

    def changes(self, names: Sequence[str], steps: Optional[float] = None) -> Dict[str, Dict[str, float]]:
        """The raw feature changes of each effect moved by ``steps`` relevance thresholds (None:
        ``options.linear_steps``; :func:`.separability.slider_changes`, runs cached)."""
        return slider_changes(names, self.base, self.ops, steps=self.options.linear_steps if steps is None else steps,
                              threads=self.threads, cache=self.run_cache, options=self.options)

    def predict(self, effects: Sequence[Effect], resid: Optional[Dict[str, float]] = None) -> Dict[str, Tuple[float, float]]:
        """Each effect's best χ² and value predicted by the linearised model (:func:`.separability.predict_singles`)."""
        return predict_singles(effects, self.base, self.resid() if resid is None else resid, self.sig_base,
                               self.changes, self.counts_base, self.options.linear_steps)

    def guide(self) -> List[Tuple[Tuple[str, str], float]]:
        """Every pair of candidates with the χ² the linearised model predicts (each may fit badly
        alone, :func:`.separability.rank_pairs`); the best recorded (``guided_pairs``)."""
        sens = slider_sensitivities([e.name for e in self.candidates], self.base, self.ops, threads=self.threads,
                                    cache=self.run_cache, steps=self.options.linear_steps, options=self.options)
        ranked = rank_pairs(sens, self.resid(), unreached_mode_features(self.meas, self.counts_base))
        self.record.guided.extend(dict(pair=list(p), predicted_chi2=c) for p, c in ranked[:self.options.guided_pairs])
        return ranked

    def step(self, f: CandidateFit) -> float:
        """The χ² a Gauss–Newton step from ``f``'s point is predicted to reach (:func:`.refine.step_chi2`),
        in the fit's own uncertainties (its spread)."""
        if not self._changes:  # the linearised model's columns: the runs the pair ranking made (cached)
            self._changes.update(self.changes([e.name for e in self.candidates]))
        sig_f = {k: sigma(self.meas[k], f.model_spread.get(k, self.spread_base.get(k, 0.0)), self.runs_base)
                 for k in self.meas}
        return step_chi2(f, self._changes, self.meas, sig_f, self.base, self.modes, self.counts_base,
                         self.options.linear_steps)

    def known(self, name: str) -> bool:
        """Whether :meth:`step` has the effect's column (a run of the moved model may have failed)."""
        return bool(self._changes.get(name))

    # --- the rule's gates a search asks (docs/model.md §9.1, "Cost") ----------------------------------

    def judge(self, fits: Sequence[CandidateFit], threshold: Optional[float] = None) -> Dict:
        """The naming rule's reasons per fit (:func:`.rule.judge`)."""
        return judge(fits, self.base, self.n, self.excess_before, self.options.gap_ratio, threshold,
                     options=self.options)

    def no_set_can_win(self, singles: List[CandidateFit]) -> bool:
        """:func:`.rule.no_set_can_win` for these singles."""
        return no_set_can_win(singles, lambda fs: self.judge(fs, self.thr_m), self.options.significance)

    def best_single(self, singles: List[CandidateFit]) -> Optional[CandidateFit]:
        """The single the selection would name (:func:`.rule.best_single`)."""
        return best_single(singles, self.judge(singles, self.thr_m), self.chi2_0, self.n, self.options.significance)

    # --- the full simulation of an updated model ------------------------------------------------------

    def simulate(self, p: Model) -> After:
        """"After": the full simulation of ``p`` (not the surrogate): virtual ENMA and the ensemble of
        runs (mean, behaviours of the unshifted run, spread, runs in the data's modes)."""
        out: Dict[str, float] = {}
        beh: Dict[str, str] = {}
        sp: Dict[str, float] = {}
        counts: Dict[str, int] = {}
        if self.enma_data is not None:
            out.update({k: f.value for k, f in simulated_enma_features(p.params, self.enma_levels, options=self.options)[0].items()})
        if self.measured is not None:
            e = ensemble_slider_features([p], self.ops, threads=self.threads, modes=self.modes, cache=self.run_cache,
                                         options=self.options)[0]
            if e is not None:
                out.update(e.mean)
                beh, sp, counts = e.behaviours, e.spread, e.mode_counts
        return After(out, beh, sp, counts)

    def filled(self, f: Dict[str, float], sp: Dict[str, float], counts: Dict[str, int]) -> Dict[str, float]:
        """``f`` with each feature it lacks at :func:`.stats.missing_z` uncertainties from the data."""
        f = dict(f)
        for k in self.meas:
            if k not in f:
                f[k] = self.meas[k].value + missing_z(k, counts) * sigma(self.meas[k], sp.get(k, 0.0), self.runs_base)
        return f

    def paths(self, updated: Model) -> Dict[str, Any]:
        """The slider's paths of the baseline's and ``updated``'s runs from s0 (the report's figure;
        made by the search and the full simulation: from the run cache)."""
        if self.measured is None:
            return {}
        both = slider_paths([self.base, updated], self.ops, threads=self.threads, cache=self.run_cache,
                            options=self.options)
        return {name: {op.tag: x for op, x in zip(self.ops, row)} for name, row in zip(("baseline", "updated"), both)}

    @property
    def data(self) -> Any:
        """The data as :class:`.result.Discovery` holds them."""
        if self.level == "beam":
            return self.enma_data
        if self.level == "slider":
            return list(self.measured or [])
        return dict(enma=self.enma_data, measured=list(self.measured or []))

    @property
    def outside(self) -> List[str]:
        """The effects of the level's library left out of the candidates."""
        names = {c.name for c in self.candidates}
        return [x for x, e in EFFECTS.items() if e.level == self.level and x not in names]

    @property
    def library(self) -> List[str]:
        """The level's effects, candidates or not."""
        return [n for n, e in EFFECTS.items() if e.level == self.level]

