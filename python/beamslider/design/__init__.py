"""Slider design optimisation for broadband self-adaption (docs/model.md §8 for the classifier it scores with).

A designer chooses the slider (and clamping) that adapts to high vibration over the widest band
of excitation frequencies. :func:`optimise` searches the design variables of a
:class:`DesignConfig` (any :class:`beamslider.Parameters` fields with bounds, TOML ``[design]``)
with ``scipy.optimize.differential_evolution``; each design is run over a band of operating
points (f_ex × a_ex × s0) and classified by the core's classifier (docs/model.md §8), and scored by

- the *adaption bandwidth* [Hz]: the length of the frequency set where the behaviour is trivial
  adaption or signature move with final amplitude ≥ ``a_min_h`` (edges interpolated, see
  :mod:`.objectives`), averaged over the levels and start positions;
- the *harvestable level* mean((A/h)²) over the band (a proxy of the power a transducer could take
  out, not a harvester model);
- optionally their *robust* versions: mean or low quantile over a FIXED sample of uncertain inputs
  (:class:`beamslider.study.Uncertain`, e.g. μ ~ U(0.22, 0.31), natural-frequency factor
  U(0.95, 1.05)), so that the optimiser sees a deterministic function.

Evaluators: ``fs`` (free-slider runs; a whole generation in one batch through the core's runner,
or on Dask with ``scheduler=``) and ``predictor`` (the reduced super-slow predictor with a fitted
drift law; the best designs are re-checked with FS). Results: ``design.jsonl`` (one line per
evaluated design, written at once; ``resume=True``), :class:`DesignResult` with the Pareto front
of bandwidth vs slider mass, and figures (:mod:`.plots`). The command is ``beamslider design``.
"""

from .config import EVALUATORS, EXAMPLE_TOML, RESULTS_FILE, DesignConfig, Variable, read_config
from .objectives import (ADAPTIVE, adaption_bandwidth, adapted_intervals, harvestable_level, robust_value,
                         sample_objectives)
from .optimise import optimise
from .plots import plot_amplitude, plot_maps, plot_pareto, write_outputs
from .results import DesignRecords, DesignResult, pareto_front, read_design_file, read_designs

__all__ = [
    "ADAPTIVE", "EVALUATORS", "EXAMPLE_TOML", "RESULTS_FILE", "DesignConfig", "DesignRecords", "DesignResult", "Variable",
    "adaption_bandwidth", "adapted_intervals", "harvestable_level", "optimise", "pareto_front", "plot_amplitude",
    "plot_maps", "plot_pareto", "read_config", "read_design_file", "read_designs", "robust_value", "sample_objectives",
    "write_outputs",
]
