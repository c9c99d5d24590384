"""Validation of layer (b), docs/model.md §6.3: drift law, slow flow and the predicted map.

Not part of the fast test suite (PCS drift tables take minutes per operating point).

    python scripts/repro/validate_superslow_b.py tables      # PCS drift tables (resumable) -> docs/results/superslow/drift/
    python scripts/repro/validate_superslow_b.py slopes      # §4.2: V from PCS against s(t) slopes of short FS runs
    python scripts/repro/validate_superslow_b.py runs        # §4.3: representative runs (b1 tables and b2 LOO law)
    python scripts/repro/validate_superslow_b.py map         # §4.4: predicted map (b2) against docs/results/operating_map.jsonl
    python scripts/repro/validate_superslow_b.py speed       # §4.5: timings
    python scripts/repro/validate_superslow_b.py features    # choice of the b2 law's inputs (leave one point out)
    python scripts/repro/validate_superslow_b.py training_sets  # the b2 map for several training sets (lattices)
    python scripts/repro/validate_superslow_b.py fs_ensemble # the FS map against FS runs from s0 ± 0.001, 0.002
    python scripts/repro/validate_superslow_b.py stops       # narrow PCS zeros of V_H at the FS stops; refined laws
    python scripts/repro/validate_superslow_b.py cheap_settings  # training-table settings near the speed bar
    python scripts/repro/validate_superslow_b.py build_up    # the build-up time of a run from rest: PCS-measured, and map-wide jump-up times
    python scripts/repro/validate_superslow_b.py ramp        # how fast a PCS sweep may move s and still find the folds
    python scripts/repro/validate_superslow_b.py fold        # the drift just before the fold (Δs 0.0025 PCS sweeps)
    python scripts/repro/validate_superslow_b.py all

Everything is written to docs/results/superslow/ (validation_b*.txt, figures, drift/*.jsonl, law.json).
The stages live in scripts/repro/superslow_b/, one module per concern (see its __init__.py).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "python"))

from superslow_b.common import stage_map_tables, stage_tables  # noqa: E402
from superslow_b.dynamics import stage_build_up, stage_fold, stage_ramp  # noqa: E402
from superslow_b.ensemble import stage_cheap_settings, stage_fs_ensemble, stage_stops  # noqa: E402
from superslow_b.levers import stage_features, stage_levers, stage_training_sets  # noqa: E402
from superslow_b.maps import stage_map  # noqa: E402
from superslow_b.runs import stage_runs, stage_slopes  # noqa: E402
from superslow_b.speed import stage_speed  # noqa: E402


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("stage", choices=["tables", "map_tables", "slopes", "runs", "map", "speed", "levers", "features", "training_sets", "fs_ensemble", "stops", "cheap_settings", "build_up", "ramp", "fold", "all"])
    ap.add_argument("--points", help="tables: only these points, e.g. 124:14,126:10")
    ap.add_argument("--training", default="cheap", choices=["coarse", "cheap"], help="speed: training table settings (timed from scratch)")
    ap.add_argument("--training-set", default="12 points", choices=["12 points", "6 points"], help="speed: training points")
    args = ap.parse_args()
    pts = None
    if args.points:
        pts = [tuple(float(x) for x in p.split(":")) for p in args.points.split(",")]
    if args.stage in ("tables", "all"):
        stage_tables(pts)
    if args.stage in ("map_tables", "all"):
        stage_map_tables()
    if args.stage in ("slopes", "all"):
        stage_slopes()
    if args.stage in ("runs", "all"):
        stage_runs()
    if args.stage in ("map", "all"):
        stage_map()
    if args.stage in ("speed", "all"):
        stage_speed(args.training, args.training_set)
    single = {"levers": stage_levers, "features": stage_features, "training_sets": stage_training_sets,
              "fs_ensemble": stage_fs_ensemble, "stops": stage_stops, "cheap_settings": stage_cheap_settings,
              "build_up": stage_build_up, "ramp": stage_ramp, "fold": stage_fold}
    if args.stage in single:
        single[args.stage]()
