"""The build-up time of a run from rest, the drift just before the fold and how fast a PCS sweep
may move s (layer-(b) validation)."""

from __future__ import annotations


import numpy as np

from beamslider import Parameters, read_map, simulate
from beamslider.superslow import drift_table, hb_manifold, load_drift_law, predict, read_drift_table

from .common import OUT, ROOT, TABLE_OPTS, TRAINING, _cpu, table_path
from .ensemble import _first_by_point
from .levers import CHEAP


def stage_build_up():
    """How long a run from rest waits before its slider drifts (the slow flow's ``build_up``):
    measured in PCS runs from rest at s0 = 0.3 (x_C(t) = L V (t − t_d) fitted on t ≥ 3τ,
    τ = 1/(DΩ)), and the first jump-up time of the whole FS map against the default law's slow
    flow for several build-up times. No law or default is changed by this stage."""
    p = Parameters()
    tau = lambda f: 1.0 / (p.damping_ratio * 2 * np.pi * f)  # noqa: E731
    lines = ["Build-up time of a run from rest (target: jump-up time within ±30 %); τ = 1/(D Ω) = 1.26 s at 126 Hz",
             "", "1. PCS runs from rest at s = 0.3, 7τ, x_C(t) fitted as L V (t − t_d) on t ≥ 3τ (the training points)",
             f"{'point':>12} {'V [1/s]':>10} {'t_d [s]':>8} {'t_d/τ':>6}"]
    ratios = []
    for f, a in TRAINING:
        r = simulate(p, f_ex=f, a_ex=a, s0=0.3, t_end=7 * tau(f), model="pcs", record_every=50)
        t, x = np.asarray(r.t), np.asarray(r.x_c) / p.length_m
        m = t >= 3 * tau(f)
        v, c = np.polyfit(t[m], x[m], 1)
        td = -c / v
        ratios.append(td / tau(f))
        lines.append(f"{f'({f:g}, {a:g})':>12} {v:10.2e} {td:8.2f} {td / tau(f):6.2f}")
    lines.append(f"median t_d/τ = {np.median(ratios):.2f} (range {min(ratios):.2f} … {max(ratios):.2f}): the PCS slider drifts at once; "
                 "the transient's overshoot makes up for the envelope's build-up")
    lines += ["", "2. s(t) from rest, FS against PCS at s0 = 0.3 (the PCS slider's x_C/L added to s0)"]
    for f, a in [(124.0, 14.0), (126.0, 10.0)]:
        fs = simulate(p, f_ex=f, a_ex=a, s0=0.3, t_end=10.0, model="fs", record_every=50)
        pc = simulate(p, f_ex=f, a_ex=a, s0=0.3, t_end=10.0, model="pcs", record_every=50)
        idx = [int(np.searchsorted(fs.t, x)) for x in np.arange(0.0, 10.01, 1.0)]
        lines.append(f"({f:g}, {a:g})  t   " + " ".join(f"{fs.t[i]:6.1f}" for i in idx))
        lines.append("            FS  " + " ".join(f"{fs.s[i]:6.3f}" for i in idx))
        lines.append("            PCS " + " ".join(f"{0.3 + pc.x_c[i] / p.length_m:6.3f}" for i in idx))
    law = load_drift_law(OUT / "law.json")
    ref = read_map(ROOT / "docs" / "results" / "operating_map.jsonl")
    R = _first_by_point(ref)
    lines += ["", "3. First jump-up time, default law's slow flow against the FS map (points where both jump up), and the map (§4.4)",
              f"{'build-up':>22} | {'n':>3} {'median |err|':>12} {'within ±30 %':>12} {'median err a ≤ 10':>17} {'a > 10':>7} | "
              f"{'strict':>7} final s p50  p90 | jump-up time b2 / PCS table alone: (124, 14), (126, 10), (106, 10; s0 0.4)"]
    fs_runs = {(124.0, 14.0, 0.3): 8.6, (126.0, 10.0, 0.3): 7.6, (106.0, 10.0, 0.4): 17.8}
    # The slider drifts from t = 0 and a jump waits for the build-up (build_up_drift, the default);
    # "held": s stays at s0 during the build-up (the rule before).
    variants = [("3τ (the default)", 3.0, True), ("1.5τ", 1.5, True), ("τ", 1.0, True), ("0.5τ", 0.5, True),
                (f"PCS-measured {np.median(ratios):.2f}τ", max(np.median(ratios), 0.0), True),
                ("3τ held (before)", 3.0, False), ("1.5τ held", 1.5, False), ("0.5τ held", 0.5, False)]
    for name, k, drifting in variants:
        errs, lo, hi, agree, fe = [], [], [], 0, []
        for key, i in R.items():
            f, a = key
            pr = predict(f_ex=f, a_ex=a, s0=0.3, drift=law, build_up=k * tau(f), build_up_drift=drifting)
            b = ref["behaviour"][i]
            agree += pr.behaviour == b
            if pr.behaviour == b and ref["steady"][i] and np.isfinite(ref["s_final"][i]):
                fe.append(abs(pr.s_final - ref["s_final"][i]))
            ju = [e for e in pr.events if e[0] == "jump_up"]
            t_fs = ref["jump_up_t_s"][i]
            if ju and t_fs is not None and len(t_fs):
                e = ju[0][1] / t_fs[0] - 1
                errs.append(e)
                (lo if a <= 10 else hi).append(e)
        rep = []
        for (f, a, s0), t_fs in fs_runs.items():
            got = []
            for kw in (dict(drift=law), dict(drift=read_drift_table(table_path(f, a)), s_dn="table", source="table")):
                ju = [e for e in predict(f_ex=f, a_ex=a, s0=s0, build_up=k * tau(f), build_up_drift=drifting, **kw).events if e[0] == "jump_up"]
                got.append(f"{ju[0][1] / t_fs - 1:+.0%}" if ju else "none")
            rep.append(" / ".join(got))
        errs = np.asarray(errs)
        lines.append(f"{name:>22} | {len(errs):3d} {np.median(np.abs(errs)):12.2f} {int(np.sum(np.abs(errs) <= 0.3)):12d} {np.median(lo):+17.2f} {np.median(hi):+7.2f} | "
                     f"{agree:3d}/112 {np.median(fe):.4f} {np.percentile(fe, 90):.4f} | {rep[0]:>11} {rep[1]:>11} {rep[2]:>11}")
        print(lines[-1], flush=True)
    (OUT / "validation_c_build_up.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")


def stage_fold():
    """The drift just before the fold: PCS down sweeps with Δs = 0.0025 from s0 to the jump-up at
    the three representative points with a jump-up, their V_L beside the s(t) slopes of the FS run,
    and the time the table's own flow takes from s0 to its fold with no build-up delay against
    the FS jump-up time. Not used by the law (its tables have Δs = 0.01)."""
    fs4 = read_map(ROOT / "docs" / "results" / "operating_map_s0.4.jsonl")
    ref = read_map(ROOT / "docs" / "results" / "operating_map.jsonl")
    lines = ["Drift on the low branch just before the fold (Δs = 0.0025 PCS down sweeps from s0; LAW_TABLE_SETTINGS otherwise)",
             "V_L [1e-3 1/s] ± standard error; FS: slope of s(t) of the FS run from rest over the 1 s around its passage through that s (before its jump)"]
    for f, a, s0 in [(124.0, 14.0, 0.3), (126.0, 10.0, 0.3), (106.0, 10.0, 0.4)]:
        m = hb_manifold(f_ex=f, a_ex=a)
        lo = round((m.s_up - 0.03) / 0.0025) * 0.0025
        grid = np.round(np.arange(lo, s0 + 1e-9, 0.0025), 6)
        t = drift_table(f_ex=f, a_ex=a, s=grid, settle_periods=TABLE_OPTS["settle_periods"], window_s=TABLE_OPTS["window_s"])
        sl, vl, se = t.branch_rows("L")
        fs = simulate(f_ex=f, a_ex=a, s0=s0, t_end=25.0, record_every=20)
        r = ref if s0 == 0.3 else fs4
        i = [k for k in range(len(r["f_ex_hz"])) if r["f_ex_hz"][k] == f and r["a_ex_m_s2"][k] == a][0]
        t_up = r["jump_up_t_s"][i][0]
        k_up = int(np.searchsorted(fs.t, t_up))
        lines += ["", f"({f:g}, {a:g}), s0 = {s0}: PCS fold (Δs 0.0025) {t.s_up_pcs:.4f}, HB fold {m.s_up:.4f}, FS jump-up at {t_up:.1f} s"]
        for x, v, e in zip(sl, vl, se):
            if x < t.s_up_pcs:
                continue
            # FS slope where the FS run (before its jump) passes x
            k = int(np.argmin(np.abs(fs.s[:k_up] - x))) if k_up > 0 else 0
            a0 = int(np.searchsorted(fs.t, fs.t[k] - 0.5))
            a1 = min(int(np.searchsorted(fs.t, fs.t[k] + 0.5)), len(fs.t) - 1)
            vfs = (fs.s[a1] - fs.s[a0]) / (fs.t[a1] - fs.t[a0]) if a1 > a0 else float("nan")
            near = abs(fs.s[k] - x) < 0.002
            lines.append(f"   s = {x:.4f}  V_L {1e3 * v:+6.2f} ± {1e3 * e:4.2f}   FS {('%+6.2f' % (1e3 * vfs)) if near else '     —'}")
        ss = np.linspace(t.s_up_pcs, s0, 20001)
        vv = np.interp(ss, sl, vl)
        t_flow = float(np.sum(0.5 * (1 / np.abs(vv[1:]) + 1 / np.abs(vv[:-1])) * np.diff(ss)))
        lines.append(f"   flow of this table from s0 to its fold, no delay: {t_flow:.1f} s against FS {t_up:.1f} s ({t_flow / t_up - 1:+.0%})")
        print("\n".join(lines[-3:]), flush=True)
    (OUT / "validation_c_fold.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")


RAMP_VARIANTS = [dict(ds=0.005, settle_periods=10, first_settle_periods=200, window_s=0.1, sub_windows=2),
                 dict(ds=0.005, settle_periods=40, first_settle_periods=200, window_s=0.1, sub_windows=2),
                 dict(ds=0.005, settle_periods=120, first_settle_periods=200, window_s=0.1, sub_windows=2),
                 dict(CHEAP["cheap"])]


def stage_ramp():
    """How fast a PCS sweep may move s and still find the folds of the fine tables: the jump
    positions of sweeps at several ramp rates Δs / (settle + window) against the default law's
    tables (Δs 0.01, 100 settling periods, 2-s windows: 0.0036 1/s). Bounds the training cost."""
    lines = ["PCS sweep ramp rate against the jump positions (s_up: down sweep leaves L; s_dn: up sweep leaves H)",
             f"{'point':>10} {'settings':>44} {'ramp [1/s]':>10} {'s_up':>7} {'s_dn':>7} {'CPU [s]':>8}"]
    fmt = lambda x: "none" if x is None else f"{x:.4f}"  # noqa: E731
    for f, a in [(124.0, 14.0), (126.0, 10.0)]:
        fine = read_drift_table(table_path(f, a))
        per = TABLE_OPTS["settle_periods"] / f + TABLE_OPTS["window_s"]
        lines.append(f"{f'({f:g}, {a:g})':>10} {'default tables (committed)':>44} {TABLE_OPTS['ds'] / per:10.4f} {fmt(fine.s_up_pcs):>7} {fmt(fine.s_dn_pcs):>7} {'':>8}")
        for o in RAMP_VARIANTS:
            c0 = _cpu()
            t = drift_table(f_ex=f, a_ex=a, **o)
            cpu = _cpu() - c0
            ramp = o["ds"] / (o["settle_periods"] / f + o["window_s"])
            name = f"Δs {o['ds']:g}, {o['settle_periods']} periods, {o['window_s']:g}-s windows"
            lines.append(f"{'':>10} {name:>44} {ramp:10.4f} {fmt(t.s_up_pcs):>7} {fmt(t.s_dn_pcs):>7} {cpu:8.2f}")
            print(lines[-1], flush=True)
    (OUT / "validation_c_ramp.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")
