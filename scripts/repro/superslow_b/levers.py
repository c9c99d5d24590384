"""Levers of the layer-(b) validation: cheaper training tables, the learnt s_up correction, the
choice of the law's inputs and the training sets (lattices)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from beamslider import read_map
from beamslider.superslow import predicted_map
from beamslider.superslow import drift_tables, fit_drift_law, predict, read_drift_table

from .common import MAP_DRIFT, OUT, ROOT, TABLE_OPTS, TRAINING, _score, available_tables, table_path


# §4.4/4.5 levers : cheaper training tables and the learnt s_up correction.
# Training table settings compared (all with both sweeps over [s_min, 0.5]):
CHEAP = {
    "fine": dict(ds=0.01, settle_periods=100, window_s=2.0),  # TABLE_OPTS (docs/results/superslow/drift)
    "coarse": dict(ds=0.02, settle_periods=40, window_s=1.0),  # the coarse b1 sweep
    "cheap": dict(ds=0.02, settle_periods=20, first_settle_periods=200, window_s=0.5),
}
LEVERS = Path("/tmp/beamslider_drift_levers")  # re-computable tables (not committed)


def _cheap_tables(kind, points):
    """Training tables with the settings CHEAP[kind] (resumable; computed two at a time,
    ``drift_tables``); returns (tables, wall time of the tables computed now, or None when all
    were read from disk)."""
    if kind == "fine":
        return [read_drift_table(table_path(f, a)) for f, a in points], None
    d = LEVERS / kind
    todo = [(f, a) for f, a in points if not (d / f"drift_{f:g}Hz_{a:g}ms2.jsonl").exists()]
    t0 = time.perf_counter()
    if todo:
        drift_tables(points=todo, out=d, threads=2, **CHEAP[kind])
    wall = time.perf_counter() - t0 if todo else None
    return [read_drift_table(d / f"drift_{f:g}Hz_{a:g}ms2.jsonl") for f, a in points], wall


def _loo_map(tables, f_ex, a_ex, shift, k=4):
    """The predicted map with the law fitted on all tables, but each training point predicted by
    the law fitted without its own table (leave one operating point out)."""
    law = fit_drift_law(tables, k=k, s_up_correction=shift, jump_down="median")
    rows = {(r["f_ex_hz"], r["a_ex_m_s2"]): r for r in predicted_map(drift=law, f_ex=f_ex, a_ex=a_ex, s0=0.3, t_end=120.0)}
    for j, t in enumerate(tables):
        others = [x for i, x in enumerate(tables) if i != j]
        lw = fit_drift_law(others, k=k, s_up_correction=shift, jump_down="median")
        r = predicted_map(drift=lw, f_ex=[t.f_ex], a_ex=[t.a_ex], s0=0.3, t_end=120.0)[0]
        rows[(t.f_ex, t.a_ex)] = r
    return law, rows


def stage_levers():
    """Agreement and final-s error of the b2 map for training-table settings, training sets and
    the s_up correction, with the training points predicted leave-one-out; training cost."""
    ref = read_map(ROOT / "docs" / "results" / "operating_map.jsonl")
    f_ex = sorted(set(float(x) for x in ref["f_ex_hz"]))
    a_ex = sorted(set(float(x) for x in ref["a_ex_m_s2"]))
    names = ["inactivity", "trivial_adaption", "signature_move", "relaxation_oscillation", "self_damping", "not_settled", "undetermined"]
    sets = {"12 points": TRAINING,
            "6 points": [(124.0, 14.0), (104.0, 14.0), (126.0, 10.0), (124.0, 6.0), (110.0, 8.0), (116.0, 12.0)]}
    lines = ["§4.4 levers: b2 map (s0 = 0.3, 120 s) against docs/results/operating_map.jsonl; training points predicted leave one out",
             f"{'tables':>7} {'training':>10} {'s_up shift':>10} | {'strict':>12} {'phase':>12} | {'final-s median':>14} {'90th pct':>8} {'n':>4} | {'tables wall [s]':>15}"]
    for kind in ("fine", "coarse", "cheap"):
        for sname, pts in sets.items():
            tabs, wall = _cheap_tables(kind, pts)
            for shift in (False, True):
                law, rows = _loo_map(tabs, f_ex, a_ex, shift)
                st, ph, errs = _score(rows, ref, names)
                lines.append(f"{kind:>7} {sname:>10} {('%+.4f' % law.s_up_shift) if shift else 'off':>10} | {st:3d}/112 {100 * st / 112:5.1f}% {ph:3d}/112 {100 * ph / 112:5.1f}% | "
                             f"{np.median(errs):14.4f} {np.percentile(errs, 90):8.4f} {errs.size:4d} | {'—' if wall is None else f'{wall:.1f}':>15}")
                print(lines[-1], flush=True)
    # The dead band of V (|V| <= v_dead read as rest), b1 and b2 (12 fine tables,
    # s_up correction, training points in-sample here).
    lines.append("")
    lines.append("dead band of V (predict(v_dead=...)): strict/phase agreement, final-s median and 90th percentile over points steady in both")
    b1t = {(f, a): read_drift_table(MAP_DRIFT / f"drift_{f:g}Hz_{a:g}ms2.jsonl") for f in f_ex for a in a_ex} if MAP_DRIFT.exists() else None
    law = fit_drift_law(available_tables(), jump_down="median")

    def row(r):
        c = r.classification
        return {"behaviour": r.behaviour, "reason": c["reason"], "s_final": c["s_final"], "steady": c["steady"]}

    for vd in (0.0, 2e-4, 4e-4, 6e-4, 1e-3):
        out = []
        variants = [("b2+s_up (in-sample)", lambda f, a: predict(f_ex=f, a_ex=a, drift=law, v_dead=vd))]
        if b1t is not None:
            variants.insert(0, ("b1", lambda f, a: predict(f_ex=f, a_ex=a, drift=b1t[(f, a)], s_dn="table", v_dead=vd)))
        for name, mk in variants:
            rows = {(f, a): row(mk(f, a)) for f in f_ex for a in a_ex}
            st, ph, e = _score(rows, ref, names)
            out.append(f"{name} {st}/{ph} of 112, final s {np.median(e):.4f} / {np.percentile(e, 90):.4f} (n {e.size})")
        lines.append(f"  v_dead {vd:.4f} 1/s: " + " | ".join(out))
        print(lines[-1], flush=True)
    (OUT / "validation_c_levers.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")


# Candidate input sets of the b2 law: the first candidate list, last version's, and sets with the position s.
FEATURE_SETS = [("log_lift_off", "slope_gap", "f_slope", "a_ex_g", "amplitude"),
                ("log_lift_off", "slope_gap", "f_slope", "ds_res", "amp_rel"),
                ("amp_rel", "s"), ("log_lift_off", "amp_rel", "s"), ("log_lift_off", "s"),
                ("slope_gap", "amp_rel", "s"), ("amp_rel", "s", "a_ex_g"), ("amplitude", "s"), ("amp_rel", "s", "amplitude")]


def stage_features():
    """Choice of the law's inputs by leave-one-operating-point-out validation on the training
    tables only: the V error (law.loo) and the behaviour of each training point predicted by the
    law fitted without its table. The whole map (training points leave one out) is printed too, as
    the test; it was not used for the choice."""
    import beamslider.superslow as dl

    tables = available_tables()
    ref = read_map(ROOT / "docs" / "results" / "operating_map.jsonl")
    f_ex = sorted(set(float(x) for x in ref["f_ex_hz"]))
    a_ex = sorted(set(float(x) for x in ref["a_ex_m_s2"]))
    names = ["inactivity", "trivial_adaption", "signature_move", "relaxation_oscillation", "self_damping", "not_settled", "undetermined"]
    idx = {(float(ref["f_ex_hz"][j]), float(ref["a_ex_m_s2"][j])): j for j in range(len(ref["f_ex_hz"]))}

    def row(r):
        c = r.classification
        return {"behaviour": r.behaviour, "reason": c["reason"], "s_final": c["s_final"], "steady": c["steady"]}

    saved = dl.FEATURES
    lines = ["Choice of the b2 law's inputs (docs/model.md §6.3), leave one operating point out on the "
             f"{len(tables)} training tables ({', '.join(f'({t.f_ex:g}, {t.a_ex:g})' for t in tables)}), s_up correction and monostability vote on (the defaults).",
             "Selection: V error and training points right (LOO). The map columns (all 112 points, training points LOO) are the test.",
             f"{'inputs':>52} {'k':>2} | {'V err/|V| all':>13} {'L':>6} {'H':>6} | {'training LOO':>12} | {'map strict':>10} {'phase':>6} {'final-s med':>11} {'p90':>6}"]
    try:
        for feats in FEATURE_SETS:
            for k in (4, 6):
                dl.FEATURES = feats
                law = fit_drift_law(tables, k=k, jump_down="median")
                ok = 0
                rows = {(f, a): row(predict(f_ex=f, a_ex=a, drift=law)) for f in f_ex for a in a_ex}
                for j, t in enumerate(tables):
                    lw = fit_drift_law([x for i, x in enumerate(tables) if i != j], k=k, jump_down="median")
                    r = row(predict(f_ex=t.f_ex, a_ex=t.a_ex, drift=lw))
                    rows[(t.f_ex, t.a_ex)] = r
                    ok += r["behaviour"] == ref["behaviour"][idx[(t.f_ex, t.a_ex)]]
                st, ph, errs = _score(rows, ref, names)
                agree = [abs(r["s_final"] - ref["s_final"][idx[key]]) for key, r in rows.items()
                         if r["behaviour"] == ref["behaviour"][idx[key]] and ref["steady"][idx[key]] and np.isfinite(ref["s_final"][idx[key]])]
                lo = law.loo
                lines.append(f"{', '.join(feats):>52} {k:2d} | {lo['ratio']:13.3f} {lo['rms_error_L'] / lo['typical_v_L']:6.3f} {lo['rms_error_H'] / lo['typical_v_H']:6.3f} | "
                             f"{ok:6d}/{len(tables):<5d} | {st:4d}/112 {ph:3d}/112 {np.median(agree):11.4f} {np.percentile(agree, 90):6.4f}")
                print(lines[-1], flush=True)
    finally:
        dl.FEATURES = saved
    lines.append(f"adopted: {', '.join(saved)} (k = 4); final-s columns over the agreeing points steady in FS")
    (OUT / "validation_b_features.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")


# How much the b2 map depends on which operating points train the law: regular lattices over the
# map (not chosen by looking at it), all with the default law's table settings (TABLE_OPTS).
LATTICES = {
    "default (5 representative + 7 spread)": TRAINING,
    "A: f 102/110/118/126 x a 6/10/14": [(f, a) for f in (102.0, 110.0, 118.0, 126.0) for a in (6.0, 10.0, 14.0)],
    "B: f 100/108/116/124 x a 6/10/14": [(f, a) for f in (100.0, 108.0, 116.0, 124.0) for a in (6.0, 10.0, 14.0)],
    "C: f 104/112/120/128 x a 6/10/14": [(f, a) for f in (104.0, 112.0, 120.0, 128.0) for a in (6.0, 10.0, 14.0)],
    "D: f 102/110/118/126 x a 4/8/12/16": [(f, a) for f in (102.0, 110.0, 118.0, 126.0) for a in (4.0, 8.0, 12.0, 16.0)],
    "E: f 100/106/.../130 x a 6/12": [(f, a) for f in (100.0, 106.0, 112.0, 118.0, 124.0, 130.0) for a in (6.0, 12.0)],
    "F: f 102/110/118/126 x a 5/8/11/14": [(f, a) for f in (102.0, 110.0, 118.0, 126.0) for a in (5.0, 8.0, 11.0, 14.0)],
}
LATTICE_DRIFT = Path("/tmp/beamslider_drift_lattices")  # re-computable tables (not committed)


def stage_training_sets():
    """Map agreement and final-s error of the b2 law for several training sets (tables with
    TABLE_OPTS, resumable under LATTICE_DRIFT; the default set's tables are read from
    docs/results/superslow/drift), in sample and leave one point out, and for the union of all; then the
    high-branch drift of the PCS tables at 110 Hz, where the FS runs stop at 0.38 and the law at 0.33."""
    import shutil

    ref = read_map(ROOT / "docs" / "results" / "operating_map.jsonl")
    f_ex = sorted(set(float(x) for x in ref["f_ex_hz"]))
    a_ex = sorted(set(float(x) for x in ref["a_ex_m_s2"]))
    LATTICE_DRIFT.mkdir(parents=True, exist_ok=True)
    for f, a in TRAINING:  # the committed tables (bitwise what drift_tables gives with TABLE_OPTS)
        q = LATTICE_DRIFT / table_path(f, a).name
        if not q.exists():
            shutil.copy(table_path(f, a), q)
    everything = sorted({p for pts in LATTICES.values() for p in pts})
    todo = [p for p in everything if not (LATTICE_DRIFT / f"drift_{p[0]:g}Hz_{p[1]:g}ms2.jsonl").exists()]
    t0 = time.perf_counter()
    if todo:
        drift_tables(points=todo, out=LATTICE_DRIFT, threads=2, progress=True, **TABLE_OPTS)
    print(f"{len(todo)} tables computed in {time.perf_counter() - t0:.0f} s", flush=True)
    tabs = {p: read_drift_table(LATTICE_DRIFT / f"drift_{p[0]:g}Hz_{p[1]:g}ms2.jsonl") for p in everything}
    grid = {(float(ref["f_ex_hz"][i]), float(ref["a_ex_m_s2"][i])): i for i in range(len(ref["f_ex_hz"]))}

    def agreeing_final_s(rows):
        e = [abs(r["s_final"] - ref["s_final"][grid[k]]) for k, r in rows.items()
             if r["behaviour"] == ref["behaviour"][grid[k]] and ref["steady"][grid[k]]]
        return np.asarray(e)

    lines = ["§4.4 training sets: b2 map (s0 = 0.3, 120 s) against docs/results/operating_map.jsonl, the law fitted on the PCS tables "
             f"of each set ({TABLE_OPTS}); LOO = each training point on the map predicted by the law fitted without it",
             "final s: over the agreeing points steady in FS (the §4.4 measure)",
             f"{'training set':>40} {'pts':>3} | {'strict':>7} {'LOO':>7} | {'final-s median':>14} {'90th pct':>8} {'n':>3}"]
    sets = dict(LATTICES)
    sets["union of all the above"] = everything
    for name, pts in sets.items():
        law = fit_drift_law([tabs[p] for p in pts], jump_down="median")
        rows = {(r["f_ex_hz"], r["a_ex_m_s2"]): r for r in predicted_map(drift=law, f_ex=f_ex, a_ex=a_ex, s0=0.3, t_end=120.0, threads=2)}
        st = sum(r["behaviour"] == ref["behaviour"][grid[k]] for k, r in rows.items())
        err = agreeing_final_s(rows)
        loo = dict(rows)
        for p in pts:
            if p in loo:
                lw = fit_drift_law([tabs[q] for q in pts if q != p], jump_down="median")
                loo[p] = predicted_map(drift=lw, f_ex=[p[0]], a_ex=[p[1]], s0=0.3, t_end=120.0)[0]
        st_loo = sum(r["behaviour"] == ref["behaviour"][grid[k]] for k, r in loo.items())
        lines.append(f"{name:>40} {len(pts):3d} | {st:3d}/112 {st_loo:3d}/112 | {np.median(err):14.4f} {np.percentile(err, 90):8.4f} {err.size:3d}")
        print(lines[-1], flush=True)
    lines += ["", "PCS high-branch drift V_H [1e-3 1/s] at 110 Hz (TABLE_OPTS tables) against where the FS runs stop:"]
    for a in (6.0, 10.0, 14.0):
        s_, v_, _ = tabs[(110.0, a)].branch_rows("H")
        m = (s_ > 0.3) & (s_ < 0.48)
        i = grid[(110.0, a)]
        lines.append(f"  (110, {a:g}): FS {ref['behaviour'][i]} ending at s = {ref['s_final'][i]:.3f}; V_H: "
                     + " ".join(f"{x:.2f}:{1e3 * y:+.1f}" for x, y in zip(s_, v_) if 0.3 < x < 0.48))
    (OUT / "validation_c_training_sets.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines[-4:]))


# FS reproducibility : how far the FS map itself moves when s0 moves by 1–2 mm/L.
