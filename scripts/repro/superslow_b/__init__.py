"""The stages of ``scripts/repro/validate_superslow_b.py`` (layer-(b) validation, docs/model.md §6.3)
by concern: ``common`` (paths, tables, the default law, shared helpers), ``runs`` (§4.2–4.3),
``maps`` (§4.4), ``speed`` (§4.5), ``levers`` (training tables, inputs, training sets),
``ensemble`` (FS reproducibility, stops, cheap settings), ``dynamics`` (build-up, fold, ramp)."""
