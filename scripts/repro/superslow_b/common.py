"""Shared settings and helpers of the layer-(b) validation: paths, the training points and
table settings, the PCS drift tables of the validation and the default law fitted on them."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from beamslider import read_map
from beamslider.superslow import (LAW_JUMP_DOWN_CANDIDATES, LAW_JUMP_DOWN_N, LAW_TABLE_SETTINGS, LAW_TRAINING_POINTS, drift_table, fit_drift_law, read_drift_table,
                                  refine_jump_down)

ROOT = Path(__file__).resolve().parents[3]

OUT = ROOT / "docs" / "results" / "superslow"
DRIFT = OUT / "drift"
# The four representative points of MODEL.md §8, (106, 10) for the start-position pair, (124, 8)
# of seed Fig. 4b, then points spread over the map for the transferable law (b2).
# The default law's recipe lives in the package (beamslider.superslow.LAW_*; `beamslider fit-law`).
REPRESENTATIVE = [(124.0, 14.0), (104.0, 14.0), (126.0, 10.0), (124.0, 6.0), (106.0, 10.0)]
TRAINING = list(LAW_TRAINING_POINTS)
assert TRAINING[:len(REPRESENTATIVE)] == REPRESENTATIVE


# Table settings of the validation (docs/model.md §6.3: Δs 0.01–0.02, ≥ 40 settling periods, window ≥ 1 s).
TABLE_OPTS = dict(LAW_TABLE_SETTINGS)


def table_path(f, a):
    return DRIFT / f"drift_{f:g}Hz_{a:g}ms2.jsonl"


def stage_tables(points=None):
    DRIFT.mkdir(parents=True, exist_ok=True)
    log = []
    for f, a in points or TRAINING:
        p = table_path(f, a)
        t0 = time.perf_counter()
        t = drift_table(f_ex=f, a_ex=a, **TABLE_OPTS, out=p, resume=p.exists(), progress=True)
        wall = time.perf_counter() - t0
        s_up, s_dn = t.s_jumps()
        line = f"({f:g}, {a:g}): {len(t.s)} rows, {t.computed} computed in {wall:.1f} s wall; PCS s_up = {s_up}, s_dn = {s_dn}"
        print(line, flush=True)
        log.append({"f_ex": f, "a_ex": a, "rows": int(len(t.s)), "computed": int(t.computed), "wall_s": wall})
    with open(DRIFT / "timings.jsonl", "a", encoding="utf-8") as fh:
        for r in log:
            fh.write(json.dumps(r) + "\n")


MAP_DRIFT = Path("/tmp/beamslider_drift_map")  # 112 tables (~8 MB): not committed
# The per-point b1 tables of the map: the coarse sweep (Δs 0.02, 40 settling periods, 1-s window).
MAP_TABLE_OPTS = dict(ds=0.02, settle_periods=40, window_s=1.0)


def stage_map_tables():
    """b1 drift tables at every point of the map (resumable; for the b1 map of §4.4)."""
    ref = read_map(ROOT / "docs" / "results" / "operating_map.jsonl")
    MAP_DRIFT.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    n = 0
    for f, a in sorted(set(zip(map(float, ref["f_ex_hz"]), map(float, ref["a_ex_m_s2"])))):
        p = MAP_DRIFT / f"drift_{f:g}Hz_{a:g}ms2.jsonl"
        t1 = time.perf_counter()
        t = drift_table(f_ex=f, a_ex=a, **MAP_TABLE_OPTS, out=p, resume=p.exists())
        n += t.computed
        print(f"({f:g}, {a:g}) {t.computed} rows computed in {time.perf_counter() - t1:.1f} s", flush=True)
    print(f"map tables: {n} rows in {time.perf_counter() - t0:.1f} s wall", flush=True)


def available_tables():
    out = []
    for f, a in TRAINING:
        p = table_path(f, a)
        if p.exists():
            t = read_drift_table(p)
            if (t.sweep == "up").sum() >= 3 and (t.sweep == "down").sum() >= 3:
                out.append(t)
    return out


# The default law's jump-down bracket (fit_drift_law's bracket rule): JUMP_DOWN_N tables added by
# bisection in the layer-(a) forcing ratio ρ(s_p) among the map's grid points (refine_jump_down;
# chosen by layer (a) and the PCS tables only), same settings as the training tables.
JUMP_DOWN_N = LAW_JUMP_DOWN_N
JUMP_DOWN_DIR = DRIFT / "jump_down"
MAP_GRID = list(LAW_JUMP_DOWN_CANDIDATES)


def jump_down_tables(tables, out=JUMP_DOWN_DIR, **settings):
    """The default law's bracket tables (resumable in ``out``; computed, or read back)."""
    return refine_jump_down(tables, candidates=MAP_GRID, n=JUMP_DOWN_N, out=out, threads=2, **(settings or TABLE_OPTS))


def default_law(tables=None):
    """(law, training tables, jump-down tables) of python/beamslider/data/default_law.json."""
    tables = available_tables() if tables is None else tables
    extra = jump_down_tables(tables)
    return fit_drift_law(tables, jump_down_tables=extra), tables, extra


def _fmt(x, nd=4):
    return "—" if x is None or (isinstance(x, float) and not np.isfinite(x)) else f"{x:.{nd}f}"


def _cpu():
    import resource

    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _law_text(law):
    from beamslider.superslow import law_json

    return law_json(law)


_PHASE_OF = (("phase 1 of a trivial adaption", ("trivial_adaption",)),
             ("phase 2 of a signature move", ("signature_move",)),
             ("phase 2 of self-damping", ("self_damping",)),
             ("phase 1 of a signature move or of self-damping", ("signature_move", "self_damping")))


def _phase_labels(reason):
    return next((labs for key, labs in _PHASE_OF if key in str(reason)), ())


def _agree_phase(b_ref, reason_ref, b_pred, reason_pred):
    if b_ref == b_pred:
        return True
    if b_ref == "not_settled":
        return b_pred in _phase_labels(reason_ref)
    if b_pred == "not_settled":
        return b_ref in _phase_labels(reason_pred)
    return False


def _score(rows_pred, ref, names):
    """(strict agreement, phase agreement, final-s errors over points steady in both) of predicted
    rows against the FS map."""
    grid = {(float(ref["f_ex_hz"][i]), float(ref["a_ex_m_s2"][i])): i for i in range(len(ref["f_ex_hz"]))}
    strict = phase = 0
    errs = []
    for key, r in rows_pred.items():
        i = grid[key]
        strict += r["behaviour"] == ref["behaviour"][i]
        phase += _agree_phase(ref["behaviour"][i], ref["reason"][i], r["behaviour"], r.get("reason", ""))
        if ref["steady"][i] and r["steady"]:
            errs.append(abs(r["s_final"] - ref["s_final"][i]))
    return strict, phase, np.asarray(errs)
