"""§4.5 of the layer-(b) validation: wall and CPU times of the predictor against the FS map."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from beamslider import Parameters, read_map, simulate
from beamslider.params import native
from beamslider.superslow import predicted_map
from beamslider.superslow import drift_tables, fit_drift_law, load_drift_law, predict, read_drift_table

from .common import OUT, ROOT, TABLE_OPTS, TRAINING, _cpu, _law_text, _score, jump_down_tables, table_path
from .levers import CHEAP, LEVERS, _cheap_tables


def _fs_map_time(f_ex, a_ex):
    """(wall, CPU) seconds of the FS map itself on this machine: the grid at s0 = 0.3, 120 s, 2
    threads, written to a temporary folder."""
    import tempfile

    from beamslider import operating_map

    with tempfile.TemporaryDirectory() as tmp:
        c0, t0 = _cpu(), time.perf_counter()
        operating_map(f_ex=f_ex, a_ex=a_ex, s0=0.3, t_end=120.0, threads=2, out=tmp)
        return time.perf_counter() - t0, _cpu() - c0


def stage_speed(training="cheap", training_set="12 points"):
    """§4.5: wall and CPU times on this machine (shared: the CPU times are the load-independent
    figures). Per point: the core's prediction (manifold + law + slow flow + classifier) against a
    120-s FS run; whole map: the training tables (settings CHEAP[training]) + fit + the core's
    predicted map on 2 threads, against 112 FS runs on 2 threads."""
    from beamslider import _core

    pts = [(124.0, 14.0), (126.0, 10.0), (104.0, 14.0)]
    lines = [f"§4.5  Speed (this machine, shared by other jobs; CPU = user + system time of this process, all its threads); core prediction = "
             "_core.predict from Python, parsing the law file on each call, with the robustness check; the core alone: "
             "cargo bench -p beamslider-core --bench predict"]
    law_all = load_drift_law(OUT / "law.json")
    text = _law_text(law_all)
    fs_wall, fs_cpu, pr_wall = [], [], []
    for f, a in pts:
        ta, td, tf, tr = [], [], [], []
        for _ in range(5):
            r = predict(f_ex=f, a_ex=a, drift=law_all)
            ta.append(r.timings_s["manifold"])
            td.append(r.timings_s["drift"])
            tf.append(r.timings_s["slow_flow"])
            tr.append(r.timings_s["robustness"])
        tc = []
        for _ in range(5):
            t0 = time.perf_counter()
            _core.predict(native(Parameters()), law=_core.DriftLaw(text), f_ex_hz=f, a_ex_m_s2=a, s0=0.3, t_end_s=120.0)
            tc.append(time.perf_counter() - t0)
        c0, t0 = _cpu(), time.perf_counter()
        simulate(f_ex=f, a_ex=a, s0=0.3, t_end=120.0, record_every=1000)
        fs_wall.append(time.perf_counter() - t0)
        fs_cpu.append(_cpu() - c0)
        pr_wall.append(min(tc))
        lines.append(f"({f:g}, {a:g}): core prediction {1e3 * min(tc):.2f} ms (predict() timings: manifold {1e3 * min(ta):.2f} ms, V {1e3 * min(td):.2f} ms, "
                     f"slow flow + classifier {1e3 * min(tf):.3f} ms, robustness check {1e3 * min(tr):.2f} ms); FS 120-s run {fs_wall[-1]:.2f} s wall, {fs_cpu[-1]:.2f} s CPU "
                     f"→ {fs_wall[-1] / min(tc):.0f}× per point")
    pts_train = {"12 points": TRAINING, "6 points": [(124.0, 14.0), (104.0, 14.0), (126.0, 10.0), (124.0, 6.0), (110.0, 8.0), (116.0, 12.0)]}[training_set]
    # Training tables from scratch (removed first), timed.
    d = LEVERS / training
    for f, a in pts_train:
        q = d / f"drift_{f:g}Hz_{a:g}ms2.jsonl"
        if q.exists():
            q.unlink()
    import tempfile

    c0, t0 = _cpu(), time.perf_counter()
    tabs, _ = _cheap_tables(training, pts_train)
    with tempfile.TemporaryDirectory() as tmp:
        extra = jump_down_tables(tabs, out=tmp, **CHEAP[training])
    tab_wall, tab_cpu = time.perf_counter() - t0, _cpu() - c0
    c0, t0 = _cpu(), time.perf_counter()
    law = fit_drift_law(tabs, jump_down_tables=extra)
    fit_wall, fit_cpu = time.perf_counter() - t0, _cpu() - c0
    ref = read_map(ROOT / "docs" / "results" / "operating_map.jsonl")
    f_ex = sorted(set(float(x) for x in ref["f_ex_hz"]))
    a_ex = sorted(set(float(x) for x in ref["a_ex_m_s2"]))
    c0, t0 = _cpu(), time.perf_counter()
    rows = predicted_map(drift=law, f_ex=f_ex, a_ex=a_ex, s0=0.3, t_end=120.0, threads=2)
    map_wall, map_cpu = time.perf_counter() - t0, _cpu() - c0
    n = len(rows)
    fs_map_wall, fs_map_cpu = _fs_map_time(f_ex, a_ex)
    tot_wall = tab_wall + fit_wall + map_wall
    tot_cpu = tab_cpu + fit_cpu + map_cpu
    st, ph, errs = _score({(r["f_ex_hz"], r["a_ex_m_s2"]): r for r in rows}, ref, None)
    lines += [
        f"training (b2): {len(pts_train)} PCS tables with {CHEAP[training]} + {len(extra)} jump-down tables — {tab_wall:.1f} s wall (two tables at a time, each with its two sweeps on two threads), {tab_cpu:.1f} s CPU; fit {fit_wall:.2f} s",
        f"predicted map (core, 2 threads): {n} points in {map_wall:.2f} s wall, {map_cpu:.2f} s CPU ({1e3 * map_cpu / n:.1f} ms CPU per point); "
        f"agreement of this map {st}/{n} strict, {ph}/{n} phase (training points in-sample here)",
        f"FS map (measured: operating_map, same grid, 2 threads): {fs_map_wall:.1f} s wall, {fs_map_cpu:.1f} s CPU "
        f"({fs_map_cpu / n:.2f} s CPU per point)",
        f"whole map including training: predictor {tot_wall:.2f} s wall, {tot_cpu:.2f} s CPU → {fs_map_wall / tot_wall:.1f}× (wall), "
        f"{fs_map_cpu / tot_cpu:.1f}× (CPU) (bar 20×)",
    ]
    # The same with the default law's own training tables (TABLE_OPTS, docs/results/superslow/drift):
    # recomputed into a temporary folder (rows bitwise those committed), two tables at a time.
    with tempfile.TemporaryDirectory() as tmp:
        c0, t0 = _cpu(), time.perf_counter()
        fine = drift_tables(points=TRAINING, out=tmp, threads=2, **TABLE_OPTS)
        extra_f = jump_down_tables(fine, out=Path(tmp) / "jump_down")
        fine_wall, fine_cpu = time.perf_counter() - t0, _cpu() - c0
    same = all(np.array_equal(x.v, read_drift_table(table_path(x.f_ex, x.a_ex)).v) for x in fine)
    c0, t0 = _cpu(), time.perf_counter()
    law_f = fit_drift_law(fine, jump_down_tables=extra_f)
    rows_f = predicted_map(drift=law_f, f_ex=f_ex, a_ex=a_ex, s0=0.3, t_end=120.0, threads=2)
    rest_wall, rest_cpu = time.perf_counter() - t0, _cpu() - c0
    st_f, ph_f, _ = _score({(r["f_ex_hz"], r["a_ex_m_s2"]): r for r in rows_f}, ref, None)
    lines += [
        f"with the default law's training tables ({len(TRAINING)} × {TABLE_OPTS} + {len(extra_f)} jump-down tables; rows bitwise equal to docs/results/superslow/drift: {same}): "
        f"tables {fine_wall:.1f} s wall, {fine_cpu:.1f} s CPU; fit + map {rest_wall:.2f} s wall; agreement {st_f}/{n} strict, {ph_f}/{n} phase; "
        f"whole map including training {fs_map_wall / (fine_wall + rest_wall):.1f}× (wall), {fs_map_cpu / (fine_cpu + rest_cpu):.1f}× (CPU)",
    ]
    (OUT / "validation_b_speed.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))
