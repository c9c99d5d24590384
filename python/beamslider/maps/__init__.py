"""Operating maps (docs/model.md §8, the paper's Fig. 11) and the behaviour classification.

The work is done by the Rust core (``beamslider-core``: modules ``classify`` and ``map``); this
package builds the map configuration (:mod:`.config`, the same TOML ``beamslider-batch map --config``
reads), runs and classifies (:mod:`.compute`; a map predicted by the slow flow is the predictor's,
:func:`beamslider.superslow.predicted_map`, written by the same core writer), turns the
rows of the results file (JSON lines, ``<out>/map.jsonl``) into numpy arrays (:mod:`.read`) and
draws the categorical map (:mod:`.draw`). A map started by ``beamslider map``, ``beamslider-batch
map`` or :func:`operating_map` can be resumed by any of them (same configuration, same results file).
"""

from .compute import Classification, classify, classify_result, operating_map, run_map_config, super_slow_signals
from .config import (BEHAVIOURS, LABELS, LETTERS, MIN_CLASSIFY_S, RESULTS_FILE, criteria_toml, criteria_values,
                     default_map_config, map_config, map_config_dict, map_config_toml)
from .draw import COLOURS, changed_with_s0, plot_operating_map
from .read import failures, marked_unsettled, read_map, rows_to_table, t_end_text, text_table

__all__ = [
    "BEHAVIOURS", "COLOURS", "LABELS", "LETTERS", "MIN_CLASSIFY_S", "RESULTS_FILE",
    "Classification", "changed_with_s0", "classify", "classify_result", "criteria_toml", "criteria_values", "default_map_config",
    "failures", "map_config", "map_config_dict", "marked_unsettled", "map_config_toml", "operating_map", "plot_operating_map",
    "read_map", "rows_to_table", "run_map_config", "super_slow_signals", "t_end_text", "text_table",
]
