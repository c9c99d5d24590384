"""Discrepancy workflow: find where model and measurement disagree, name the physical effect the
model is missing, add it, and show the disagreement shrink.

1. **Features** (:func:`enma_features`, :func:`slider_features`): physically meaningful numbers
   with uncertainties, computed by the same code from measured data and from the model at the same
   conditions — beam level (ENMA): linear frequency ``f0_hz``, hardening ``b_star``, damping
   ``damping_0`` and its amplitude trend ``damping_2``, deflection shape ``shape_L6``/``shape_L3``;
   slider level (free-slider runs): per operating point the behaviour type, early and late slider
   speed, turning point, final position and final amplitude.
2. **Candidate effects** (:data:`EFFECTS`), each a real extension of the model with a parameter,
   bounds and the features it moves, and the measurement chain's calibrations (:mod:`.chain`,
   docs/model.md §9.1: excitation level, velocity gain, camera offset and scale, time base).
3. **Naming** (:func:`discover`: the problem, :mod:`.problem`; a search strategy, :mod:`.search`; the
   rule, :mod:`.rule`, stated once in docs/model.md §9, "Naming rule"; the tuning values,
   :class:`DiscoverOptions`): every candidate and pairs of them are fitted to the disagreement
   (weighted least squares, χ² with the feature uncertainties). Criterion: nothing is named when
   the baseline agrees (χ² ≤ the 99 % quantile of χ²(n)); otherwise forward selection by
   likelihood-ratio tests with the measurement noise: the best single effect is named if it lowers
   χ² by more than the 99 % quantile of χ²(1) corrected for picking the best of m candidates
   (Bonferroni: 1 − 0.01/m, e.g. 9.14 for m = 4), and the best pair containing it replaces it only
   if it lowers χ² by more than that again (m = the pairs that extend it, e.g. 8.61 for m = 3) —
   a simpler explanation wins unless a richer one is clearly better. A set is named only if the
   updated model is adequate, each parameter moved by a relevant amount and the gap beyond the
   noise, sqrt(max(χ² − E[χ²], 0)/n), shrinks to ≤ ``gap_ratio`` (0.3) of itself; else
   "unexplained"; and only if each parameter's 95 % interval excludes its baseline value (else
   "unexplained — best candidate X, not resolved", with advice); single candidates that fit equally
   by moving the features alike are reported as a ``confounded`` group, and so is a named set
   that a single effect of the library (a candidate or not: screened in the linearised model,
   confirmed by its full fit) fits as well (:mod:`.confounding`). Slider level: a model's features
   are the mean of an ensemble of runs from
   s0 + (0, ±0.001, ±0.002), their spread part of the uncertainty (the final state of a long run
   depends on such unresolvable perturbations). The end-state features are bimodal across such
   perturbations (jumped up yet or not, the phase of a relaxation cycle), so they are compared
   with the runs in the data's mode only (:data:`.models.MODE_FEATURES`, :func:`.models.run_mode`),
   and the mode's rarity is a term of χ² (:func:`.models.mode_penalty`).
4. **Adding it**: :func:`write_report` writes the updated TOML, ``report.json``, ``report.md`` and
   figures; the "after" features come from full simulations of the updated model.
5. **Synthesiser** (:func:`synthesize_enma`, :func:`synthesize_slider_runs`): hidden-effect data
   from any truth model, with noise and a seed.

Beam-level fits use the single-mode harmonic-balance relations of docs/model.md §9 generalised to a
preloaded first mode (eigenvector of diag(ω²) + H₀K) as a fast surrogate, bias-corrected by one
virtual ENMA of the baseline (the estimator's own small biases — time step, five-point damping
estimate, amplitude dependence of the shape — cancel); slider-level fits run the free-slider model.

Slider level, a set of effects is refined jointly after its coordinate pass (:mod:`.refine`:
Gauss–Newton on ensemble means, each step confirmed by runs); with many candidates the fits are
screened and the pairs chosen by the linearised model (docs/model.md §9.1, "Sets of effects", "Cost").

The package is split by step: :mod:`.features` (1), :mod:`.effects` and :mod:`.chain` (2),
:mod:`.models` and :mod:`.surrogate` (the model side of the features), :mod:`.workflow` (:func:`discover`), the search
:mod:`.search` with :mod:`.fitting`, :mod:`.refine` and :mod:`.spread`, the statistics :mod:`.stats`,
the rule :mod:`.rule` with :mod:`.confounding` and :mod:`.advice` (3), the result types
:mod:`.result` and :mod:`.report` (4), :mod:`.synthesize` (5), :mod:`.separability`
(identifiability), :mod:`.runstore` (the runs a discover keeps on disk), :mod:`.provisional` (the
leading candidate before the verdict) and the benchmark of hidden cases drawn at random,
:mod:`.benchmark` with :mod:`.cases` and :mod:`.scores` (docs/model.md §9.2); every public name is
re-exported here.
"""

from __future__ import annotations

from .features import DESCRIPTIONS, enma_features, Feature, FLOORS, slider_features
from .effects import CHAIN_EFFECTS, realise_effects, Effect, EFFECTS
from .chain import Model, realise_model
from .models import measured_slider_features, model_slider_features, OperatingPoint
from .surrogate import beam_surrogate, simulated_enma_features
from .options import DiscoverOptions
from .result import Because, CandidateFit, Discovery, GAP_MEASURE, Kind, Verdict
from .stats import SIGNIFICANCE
from .workflow import discover
from .provisional import StopAtProvisional
from .benchmark import BenchmarkResult, Case, detectability, draw_cases, Plan, run_benchmark
from .runstore import RunStore
from .synthesize import synthesize_enma, synthesize_slider_runs, truth_from_toml, truth_from_toml_text
from .report import fmt_value, verdict_line, write_report
from .separability import separability, slider_sensitivities

__all__ = [
    "beam_surrogate", "CandidateFit", "DESCRIPTIONS", "discover", "Discovery", "Effect", "EFFECTS",
    "enma_features", "Feature", "FLOORS", "GAP_MEASURE", "measured_slider_features", "model_slider_features",
    "OperatingPoint", "SIGNIFICANCE", "simulated_enma_features", "slider_features", "synthesize_enma",
    "synthesize_slider_runs", "truth_from_toml", "truth_from_toml_text", "write_report", "verdict_line",
    "separability", "slider_sensitivities",
    "realise_effects", "fmt_value", "StopAtProvisional", "BenchmarkResult", "Case", "detectability", "draw_cases",
    "Plan", "run_benchmark", "CHAIN_EFFECTS", "Model", "realise_model", "RunStore",
    "DiscoverOptions", "Kind", "Because", "Verdict",
]
