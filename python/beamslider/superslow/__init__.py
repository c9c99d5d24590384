"""The super-slow layer (docs/model.md §6.3–§6.4): the HB manifold, PCS drift tables, the fitted drift law and the slow-flow predictor.

Modules by concern: :mod:`.manifold` (the super-slow manifold by harmonic balance, in milliseconds),
:mod:`.tables` (drift tables V(s, branch) measured in the PCS model), :mod:`.law` (the local
features, the drift law, its file and the built-in default law), :mod:`.fit` (fitting the law on
drift tables), :mod:`.design_law` (drift laws over a box of designs, blended for any design: the
built-in law), :mod:`.slowflow` (:func:`predict`, the core's reduced model of one operating point) and
:mod:`.predicted_map` (:func:`predicted_map`, the operating map by the predictor, written by the maps'
core writer). Every public name is importable from here.
"""

from .manifold import (ClosedFormN1, HbBranch, HbManifold, backbone, closed_form_n1, hb_manifold)
from .tables import (DriftTable, drift_table, drift_tables, read_drift_table)
from .law import (DEFAULT_LAW_PATH, DriftLaw, FEATURES, LAW_JUMP_DOWN_CANDIDATES, LAW_JUMP_DOWN_N,
    LAW_TABLE_SETTINGS, LAW_TRAINING_POINTS, S_DN_MIN, default_drift_law, features, forcing_ratio,
    law_dict, law_from_dict, law_inputs, law_json, load_drift_law, monostable_inputs, move_fold, s_dn_forcing_ratio,
    save_drift_law)
from .fit import (JD_WINDOW, LIFT_V_EPS, MONO_RISE_H, ON_BRANCH_RATIO, fit_drift_law, jump_down_bracket,
    learn_lift_off_threshold, refine_jump_down)
from .design_law import (BUILTIN_LAW_NOTE, DEFAULT_DESIGN_LAW_PATH, DESIGN_BOX, DESIGN_KIND, JAM_GAP_RATIO,
    BoxCoordinate, DesignLaw, builtin_law, default_law, design_coordinates, design_params, design_sample,
    fit_design_law, load_design_law, load_law, loo_design_error, save_design_law)
from .slowflow import MONO_NODES, Prediction, ROBUST_DS, predict, table_model
from .predicted_map import predicted_map

__all__ = [
    "ClosedFormN1", "HbBranch", "HbManifold", "backbone", "closed_form_n1", "hb_manifold", "DriftTable",
    "drift_table", "drift_tables", "read_drift_table", "BUILTIN_LAW_NOTE", "DEFAULT_LAW_PATH", "DriftLaw",
    "FEATURES", "LAW_JUMP_DOWN_CANDIDATES", "LAW_JUMP_DOWN_N", "LAW_TABLE_SETTINGS", "LAW_TRAINING_POINTS",
    "S_DN_MIN", "builtin_law", "default_drift_law", "features", "forcing_ratio", "law_dict", "law_from_dict", "law_inputs", "law_json",
    "load_drift_law", "monostable_inputs", "move_fold", "s_dn_forcing_ratio", "save_drift_law",
    "JD_WINDOW", "LIFT_V_EPS", "MONO_RISE_H", "ON_BRANCH_RATIO", "fit_drift_law", "jump_down_bracket",
    "learn_lift_off_threshold", "refine_jump_down", "MONO_NODES", "Prediction", "ROBUST_DS",
    "predict", "predicted_map", "table_model", "DEFAULT_DESIGN_LAW_PATH", "DESIGN_BOX", "DESIGN_KIND",
    "JAM_GAP_RATIO", "BoxCoordinate", "DesignLaw", "default_law", "design_coordinates", "design_params",
    "design_sample", "fit_design_law", "load_design_law", "load_law", "loo_design_error", "save_design_law",
]
