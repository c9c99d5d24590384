"""Uncertainty studies: behaviour probabilities and sensitivities of the free slider (docs/model.md §8)
under uncertain parameters, run locally (rayon through the Rust core) or on a Dask cluster.

A study samples the uncertain parameters (distributions from TOML; Latin hypercube, scrambled
Sobol' points, Saltelli's scheme for Sobol' indices, or a full-factorial grid of levels), runs
the free-slider model at every sample and operating point (a ``duration_s`` run from rest,
classified by the core exactly as a point of an operating map) and aggregates per operating
point: the probability of each behaviour, mean / standard deviation / quantiles of the final
slider position ``s_final``, the final amplitude ``amplitude_final_h`` and the turning point
``turn_s``, and their sensitivity indices with respect to each uncertain parameter.

Execution: :func:`run_study` runs all points through the Rust core in one call (rayon, the
interpreter released) or, given a Dask scheduler address or ``distributed.Client``, submits
chunks of points as tasks (each task runs :func:`beamslider._core.run_study_chunk` on a worker,
rayon inside, the interpreter released). Either way every finished point is appended at once as
one JSON line to ``OUT/study.jsonl`` — the results-file format of the operating maps (a header
line, then one map row per point, with the extra keys ``sample``, ``point`` and ``params``) — so
a study survives a killed worker (Dask re-runs the lost chunk; no finished point is lost) and a
killed client (``resume=True`` runs only the missing points). Every point is deterministic and
independent: the rows do not depend on the executor, the number of workers or threads, or the
chunking (bitwise, apart from ``wall_time_s``).

Sensitivity indices:

- ``method = "saltelli"``: first-order ``S1`` (Saltelli et al. 2010) and total ``ST`` (Jansen 1999)
  Sobol' indices from N (D + 2) runs (matrices A, B and A with column i from B, built from a
  scrambled Sobol' sequence of dimension 2D), with bootstrap 95 % half-widths ``S1_conf``/``ST_conf``;
  the estimators are those of SALib's ``sobol.analyze`` (checked against the Ishigami function);
- ``"lhs"``/``"sobol"``: Spearman rank correlation ``rho`` of each output with each parameter;
- ``"grid"``: ``rho`` plus the main effect: the mean output at each level of each parameter.

The virtual uncertain parameter ``natural_frequency_factor`` (c) detunes the linear natural
frequencies of the beam by the factor c while holding the nonlinear coefficient b* of docs/model.md §9:
Young's modulus E and the rotational clamping stiffness k_r are scaled by c² (so the ratio
κ = k_r L/(EI), hence the mode shapes and the matrix K, are unchanged and every ωₙ scales by c
exactly, for zero axial preload), and the axial clamping stiffness k_t is changed so that
k_ax = 1/(L/(EA) + 1/k_t), hence b = (k_ax/2) K₁₁² and b*, stay as they were. With k_t = ∞ it
stays ∞ and b* scales with c² instead.

The package is split by concern: :mod:`.config` (the configuration and its TOML), :mod:`.sampling`
(designs and the list of runs), :mod:`.results` (the results file), :mod:`.run` (local and Dask
execution), :mod:`.statistics` (aggregation), :mod:`.plots` (figures) and :mod:`.outputs` (the
summary files). Everything public is re-exported here; the subcommand ``beamslider study`` lives in
:mod:`beamslider.cli.study` (the library does not import the command line).
"""

from .config import (DISTRIBUTIONS, FORMAT_VERSION, METHODS, OUTPUTS, RESULTS_FILE, VIRTUAL, StudyConfig, Uncertain,
                     read_config, sample)
from .plots import plot_behaviour_probability, plot_sensitivity
from .results import read_results
from .run import run_study
from .sampling import StudyPoint, apply_sample, detune, study_points
from .statistics import PointSummary, StudyResult, aggregate, read_study, sobol_indices
from .outputs import EXAMPLE_CONFIG, write_outputs

__all__ = [
    "DISTRIBUTIONS", "EXAMPLE_CONFIG", "FORMAT_VERSION", "METHODS", "OUTPUTS", "RESULTS_FILE", "VIRTUAL",
    "PointSummary", "StudyConfig", "StudyPoint", "StudyResult", "Uncertain",
    "aggregate", "apply_sample", "detune", "plot_behaviour_probability", "plot_sensitivity",
    "read_config", "read_results", "read_study", "run_study", "sample", "sobol_indices", "study_points",
    "write_outputs",
]

