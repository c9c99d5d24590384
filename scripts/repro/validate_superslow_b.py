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
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "python"))

from beamslider import Parameters, read_map, simulate  # noqa: E402
from beamslider.params import native
from beamslider.maps import predicted_map  # noqa: E402
from beamslider.superslow import (drift_table, drift_tables, fit_drift_law, hb_manifold, load_drift_law, predict,  # noqa: E402
                                  read_drift_table, refine_jump_down, save_drift_law)
from beamslider.superslow import (LAW_JUMP_DOWN_CANDIDATES, LAW_JUMP_DOWN_N, LAW_TABLE_SETTINGS,  # noqa: E402
                                  LAW_TRAINING_POINTS, MONO_RISE_H)

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


def stage_slopes(t_run=40.0):
    """§4.2: FS s(t) slopes in 2-s windows, binned by s and branch, against the PCS table."""
    lines = ["§4.2  Drift law: V from PCS (b1 table) against s(t) slopes of FS runs (2-s windows)",
             "branch of a window: the PCS branch whose window amplitude at that s is nearest (log) to the FS envelope; windows within 1.5 s of an FS jump skipped; V_PCS interpolated at the window's mean s",
             f"{'point':>12} {'s0':>5} {'br':>3} {'n':>3} {'mean s':>7} {'V_FS':>9} {'V_PCS':>9} {'|diff|/se':>9}"]
    from beamslider.maps import classify_result

    summary = []
    for (f, a), s0 in (((124.0, 14.0), 0.3), ((126.0, 10.0), 0.3), ((104.0, 14.0), 0.3), ((124.0, 6.0), 0.3)):
        p = table_path(f, a)
        if not p.exists():
            continue
        tab = read_drift_table(p)
        r = simulate(f_ex=f, a_ex=a, s0=s0, t_end=t_run, record_every=50)
        c = classify_result(r)
        t, s = np.asarray(r.t), np.asarray(r.s)
        env = np.asarray(r.envelope(1.0))
        h = 1e-3
        ups = list(c.features.get("jump_up_t_s", []))
        downs = list(c.features.get("jump_down_t_s", []))
        w = 2.0
        for k in range(int(2.0 / w), int(t_run / w)):
            m = (t >= k * w) & (t < (k + 1) * w)
            if m.sum() < 10:
                continue
            tm = 0.5 * (2 * k + 1) * w
            # branch of the window: the PCS branch whose amplitude at the window's mean s is nearest
            # (in log) to the FS envelope there; windows within 1.5 s of a jump are skipped
            ev = sorted(ups + downs)
            if any(k * w - 1.5 <= x <= (k + 1) * w + 1.5 for x in ev):
                continue
            a_fs = float(np.mean(env[m])) / h
            sm0 = float(np.mean(s[m]))
            best, br = np.inf, None
            for cand in ("L", "H"):
                mm = tab.branch == cand
                cs = np.where(tab.s[mm] > 0.5, 1 - tab.s[mm], tab.s[mm])
                if cs.size < 2 or not (cs.min() - 0.011 <= sm0 <= cs.max() + 0.011):
                    continue
                o = np.argsort(cs)
                d = abs(np.log(max(a_fs, 1e-6)) - np.log(max(float(np.interp(sm0, cs[o], tab.amplitude[mm][o])), 1e-6)))
                if d < best:
                    best, br = d, cand
            if br is None:
                continue
            slope = np.polyfit(t[m], s[m], 1)[0]
            sm = float(np.mean(s[m]))
            ts, tv, te = tab.branch_rows(br)
            if ts.size < 2 or not (ts[0] - 0.011 <= sm <= ts[-1] + 0.011):
                continue
            vp = float(np.interp(sm, ts, tv))
            ep = float(np.interp(sm, ts, te))
            summary.append((br, slope, vp, ep))
            lines.append(f"({f:g}, {a:g}) {s0:5.2f} {br:>3} {int(m.sum()):3d} {sm:7.4f} {slope:9.5f} {vp:9.5f} {abs(slope - vp) / max(ep, 1e-9):9.2f}")
    if summary:
        fs = np.array([x[1] for x in summary])
        pc = np.array([x[2] for x in summary])
        typ = float(np.sqrt(np.mean(fs ** 2)))
        lines.append(f"windows: {len(summary)}; RMS(V_FS − V_PCS) = {np.sqrt(np.mean((fs - pc) ** 2)):.5f} 1/s; typical |V_FS| (RMS) = {typ:.5f} 1/s; "
                     f"sign agreement {np.mean(np.sign(fs) == np.sign(pc)) * 100:.0f} %; correlation {np.corrcoef(fs, pc)[0, 1]:.2f}")
    (OUT / "validation_b_slopes.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


def _fmt(x, nd=4):
    return "—" if x is None or (isinstance(x, float) and not np.isfinite(x)) else f"{x:.{nd}f}"


def stage_runs():
    """§4.3: representative runs, b1 (own PCS table) and b2 (law fitted without this point)."""
    fs = {(r_f, r_a): i for i, (r_f, r_a) in enumerate(zip(*[read_map(ROOT / "docs" / "results" / "operating_map.jsonl")[k] for k in ("f_ex_hz", "a_ex_m_s2")]))}
    ref03 = read_map(ROOT / "docs" / "results" / "operating_map.jsonl")
    ref04 = read_map(ROOT / "docs" / "results" / "operating_map_s0.4.jsonl")
    law_all, tables, extra = default_law()
    lines = ["§4.3  Representative runs: predictor against the FS map rows (120 s)",
             "b1: V from the point's own PCS drift table (Δs 0.01, 100 settling periods, 2-s windows) on the HB N = 5 manifold, s_dn from the table; "
             "PCS: table alone (its Â, V, s_up, s_dn); b2: the default law fitted on all training points (python/beamslider/data/default_law.json); b2-LOO: the law fitted "
             "on the other training points (leave one out); both with the learnt jump-down (s_dn='law': the bracket rule with the jump-down tables), Λ_c and monostable vote",
             "FS columns from docs/results/operating_map.jsonl (s0 = 0.3) and docs/results/operating_map_s0.4.jsonl: t_up = first jump-up time, turn = turning point s, T = mean jump-up interval",
             f"{'point':>11} {'s0':>4} {'src':>6} | {'FS behaviour':>22} {'pred behaviour':>22} | {'FS s_f':>6} {'pr s_f':>6} | "
             f"{'FS t_up':>7} {'pr t_up':>7} | {'FS turn':>7} {'pr s_up':>7} | {'FS s-range':>13} {'pr s-range':>13} | {'FS T':>5} {'pr T':>5}"]
    for (f, a), s0 in [(pt, 0.3) for pt in REPRESENTATIVE] + [((106.0, 10.0), 0.4)]:
        ref = ref03 if s0 == 0.3 else ref04
        idx = [i for i in range(len(ref["f_ex_hz"])) if ref["f_ex_hz"][i] == f and ref["a_ex_m_s2"][i] == a]
        if not idx:
            continue
        i = idx[0]
        fsr = {k: ref[k][i] for k in ref}
        own = [t for t in tables if (t.f_ex, t.a_ex) == (f, a)]
        variants = []
        if own:
            variants.append(("b1", own[0], "table", "hb"))
            variants.append(("PCS", own[0], "table", "table"))
        others = [t for t in tables if (t.f_ex, t.a_ex) != (f, a)]
        variants.append(("b2", law_all, "law", "hb"))
        if len(others) >= 2 and own:
            variants.append(("b2-LOO", fit_drift_law(others, jump_down_tables=extra), "law", "hb"))
        for name, drift, sdn, source in variants:
            r = predict(f_ex=f, a_ex=a, s0=s0, drift=drift, s_dn=sdn, source=source)
            ups = [e for e in r.events if e[0] == "jump_up"]
            downs = [e for e in r.events if e[0] == "jump_down"]
            fs_ups = list(fsr["jump_up_t_s"]) if fsr["jump_up_t_s"] is not None else []
            period_fs = float(np.mean(np.diff(fs_ups))) if len(fs_ups) >= 2 else None
            pu = [e[1] for e in ups]
            period_pr = float(np.mean(np.diff(pu))) if len(pu) >= 2 else None
            lines.append(
                f"({f:g}, {a:g}) {s0:4.1f} {name:>6} | {fsr['behaviour']:>22} {r.behaviour:>22} | {_fmt(fsr['s_final'])} {_fmt(r.s_final)} | "
                f"{_fmt(fs_ups[0] if fs_ups else None, 1):>7} {_fmt(pu[0] if pu else None, 1):>7} | {_fmt(fsr['turn_s']):>7} {_fmt(ups[0][2] if ups else None):>7} | "
                f"{_fmt(fsr['s_min'], 3)}–{_fmt(fsr['s_max'], 3)} {_fmt(float(np.min(r.s)), 3)}–{_fmt(float(np.max(r.s)), 3)} | "
                f"{_fmt(period_fs, 1):>5} {_fmt(period_pr, 1):>5}" + ("  [extrapolated]" if r.extrapolated else "") + (f"  jumps down: {len(downs)}" if downs else ""))
            if (f, a, s0) == (124.0, 14.0, 0.3) and name == "b1":
                _figure_signature(r, f, a)
    (OUT / "validation_b_runs.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))
    del fs
    _figure_runs(law_all)


# Seed Figs. 6f, 8, 9 and 12 : the FS run and the slow flow of the default law.
FIGURE_RUNS = [((124.0, 14.0), 0.3, "signature move"), ((126.0, 10.0), 0.3, "relaxation oscillation"), ((124.0, 6.0), 0.3, "self-damping"),
               ((104.0, 14.0), 0.3, "trivial adaption"), ((106.0, 10.0), 0.4, "signature move from s0 = 0.4")]


def _figure_runs(law):
    """s(t) and Â(t) of 120-s FS runs against the slow flow of the default law (b2), with the
    predicted jump-up (▲) and jump-down (▼) events."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    h = Parameters().thickness_m
    fig, axes = plt.subplots(2, len(FIGURE_RUNS), figsize=(3.6 * len(FIGURE_RUNS), 5.4), sharex=True)
    for col, ((f, a), s0, name) in enumerate(FIGURE_RUNS):
        fs = simulate(f_ex=f, a_ex=a, s0=s0, t_end=120.0, record_every=20)
        r = predict(f_ex=f, a_ex=a, s0=s0, drift=law)
        ax_s, ax_a = axes[0, col], axes[1, col]
        ax_s.plot(fs.t, fs.s, color="0.55", lw=1.0, label="FS model")
        ax_s.plot(r.t, r.s, color="k", lw=1.2, label="slow flow (b2 law)")
        ax_a.plot(fs.t, fs.display_envelope() / h, color="0.55", lw=1.0)
        ax_a.plot(r.t, r.amplitude, color="k", lw=1.2)
        for kind, te, se in r.events:
            if kind in ("jump_up", "jump_down"):
                ax_s.plot([te], [se], marker="^" if kind == "jump_up" else "v", color="tab:red" if kind == "jump_up" else "tab:blue", ms=5, ls="none")
        robust = "" if r.robust is None else (", robust" if r.robust else ", not robust")
        ax_s.set_title(f"({f:g} Hz, {a:g} m/s²): {name}\npredicted: {r.behaviour.replace('_', ' ')}{robust}", fontsize=8)
        ax_a.set_xlabel("t [s]")
    axes[0, 0].set_ylabel("s")
    axes[1, 0].set_ylabel("Â = |w(4L/7)|/h")
    axes[0, 0].legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(OUT / "runs_predicted_vs_fs.png", dpi=110)
    plt.close(fig)


def _figure_signature(r, f, a):
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    m = hb_manifold(f_ex=f, a_ex=a)
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for b, c in ((m.high, "tab:red"), (m.low, "tab:blue"), (m.middle, "0.6")):
        ax.plot(b.s, b.amplitude, color=c, lw=1)
    ax.plot(r.s, r.amplitude, "k.", ms=2, label="slow flow (b1)")
    for k, t, s in r.events:
        if k == "jump_up":
            ax.axvline(s, color="k", ls=":", lw=0.8)
    ax.set_xlabel("s")
    ax.set_ylabel("Â")
    ax.set_xlim(0.2, 0.5)
    ax.set_title(f"predicted signature move on the HB manifold ({f:g} Hz, {a:g} m/s², s0 = 0.3)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(OUT / "signature_move_predicted.png", dpi=120)
    plt.close(fig)


def _b1_map(f_ex, a_ex, source):
    rows = {}
    for a in a_ex:
        for f in f_ex:
            p = MAP_DRIFT / f"drift_{f:g}Hz_{a:g}ms2.jsonl"
            if not p.exists():
                return None
            tab = read_drift_table(p)
            t0 = time.perf_counter()
            r = predict(f_ex=f, a_ex=a, s0=0.3, t_end=120.0, drift=tab, source=source, s_dn="table")
            c = r.classification
            rows[(f, a)] = {"behaviour": r.behaviour, "reason": c["reason"], "s_final": c["s_final"], "steady": c["steady"], "extrapolated": False,
                            "wall_time_s": time.perf_counter() - t0}
    return rows


# How a not_settled row is compared (§4.4 against the FS map with the stricter settled rule):
# strictly, not_settled agrees only with not_settled. The "phase" count also accepts the
# behaviour whose phase the run had reached at t_end, as the classifier's reason names it
# ("phase 1 of a trivial adaption" -> trivial_adaption, ...); "no phase of a single behaviour"
# accepts nothing. Both counts are printed; the strict one is the headline.
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


def _compare(title, pred, grid_ref, ref, train, f_ex, a_ex, names):
    letter = dict(zip(names, "ITSRDN?"))
    conf = np.zeros((7, 7), int)
    agree, dis, errs, errs_all = 0, [], [], []
    agree_phase = 0
    idx = {(float(ref["f_ex_hz"][j]), float(ref["a_ex_m_s2"][j])): j for j in range(len(ref["f_ex_hz"]))}
    for key, b_ref in grid_ref.items():
        r = pred[key]
        i = idx[key]
        conf[names.index(b_ref), names.index(r["behaviour"])] += 1
        if ref["steady"][i] and r["steady"]:
            errs_all.append(abs(r["s_final"] - ref["s_final"][i]))
        if _agree_phase(b_ref, ref["reason"][i], r["behaviour"], r.get("reason", "")):
            agree_phase += 1
        if r["behaviour"] == b_ref:
            agree += 1
            if ref["steady"][i] and np.isfinite(ref["s_final"][i]):
                errs.append(abs(r["s_final"] - ref["s_final"][i]))
        else:
            f, a = key
            neigh = [grid_ref.get((f + df, a + da)) for df, da in ((2, 0), (-2, 0), (0, 2), (0, -2))]
            border = any(nb is not None and nb != b_ref for nb in neigh)
            dis.append(f"  ({f:g}, {a:g}): FS {b_ref}, predicted {r['behaviour']}; {'on a class border' if border else 'inside a region'}"
                       + (" [training point]" if key in train else "") + (" [extrapolated]" if r.get("extrapolated") else ""))
    n = len(grid_ref)
    on_border = sum("on a class border" in d for d in dis)
    lines = ["", title, f"agreement: {agree}/{n} = {100 * agree / n:.1f} % (bar 80 %, stretch 90 %); disagreements on a class border of the FS map: {on_border} of {len(dis)}",
             f"agreement counting a not_settled row as the behaviour whose phase it reached (see _PHASE_OF): {agree_phase}/{n} = {100 * agree_phase / n:.1f} %",
             "confusion matrix (rows FS, columns predicted): " + " ".join(letter[x] for x in names)]
    for k, nm in enumerate(names):
        lines.append(f"  {letter[nm]} {nm:>22}: " + " ".join(f"{v:3d}" for v in conf[k]))
    if errs:
        lines.append(f"final-s error over agreeing points steady in FS (n = {len(errs)}): median {np.median(errs):.4f}, 90th percentile {np.percentile(errs, 90):.4f} (targets 0.015 / 0.04)")
    if errs_all:
        lines.append(f"final-s error over all points steady in both (n = {len(errs_all)}): median {np.median(errs_all):.4f}, 90th percentile {np.percentile(errs_all, 90):.4f}")
    flags = [(key, pred[key].get("robust")) for key in grid_ref]
    if any(fl is not None for _, fl in flags):
        # The robustness flag (V ± the law's v_resolution): how the predictions it marks robust
        # compare with the others.
        for want, name in ((True, "robust (V ± v_resolution changes neither the behaviour nor the final s by > 0.02)"),
                           (False, "not robust (V ± v_resolution changes the behaviour or the final s by > 0.02)")):
            ks = [key for key, fl in flags if fl is want]
            ok = [key for key in ks if pred[key]["behaviour"] == grid_ref[key]]
            e = [abs(pred[key]["s_final"] - ref["s_final"][idx[key]]) for key in ok if ref["steady"][idx[key]] and np.isfinite(ref["s_final"][idx[key]])]
            lines.append(f"{name}: {len(ks)} points, agreement {len(ok)}/{len(ks)}"
                         + (f" = {100 * len(ok) / len(ks):.1f} %" if ks else "")
                         + (f"; final-s error over its agreeing points steady in FS (n = {len(e)}): median {np.median(e):.4f}, 90th percentile {np.percentile(e, 90):.4f}" if e else ""))
    lines.append("text map (FS | predicted), rows a_ex, columns f_ex " + " ".join(f"{f:g}" for f in f_ex))
    for a in sorted(a_ex, reverse=True):
        lines.append(f"  {a:4g}  " + " ".join(letter[grid_ref[(f, a)]] for f in f_ex) + "  |  " + " ".join(letter[pred[(f, a)]["behaviour"]] for f in f_ex))
    lines.append("disagreements:")
    lines.extend(dis)
    return lines


def _loo_rows(tables, f_ex, a_ex, s_dn="law", **kw):
    """The b2 map with the law fitted on all tables, each training point predicted by the law
    fitted without its own table (leave one operating point out)."""
    law = fit_drift_law(tables, **kw)
    rows = {(r["f_ex_hz"], r["a_ex_m_s2"]): r for r in predicted_map(drift=law, f_ex=f_ex, a_ex=a_ex, s0=0.3, t_end=120.0, s_dn=s_dn)}
    for j, t in enumerate(tables):
        lw = fit_drift_law([x for i, x in enumerate(tables) if i != j], **kw)
        rows[(t.f_ex, t.a_ex)] = predicted_map(drift=lw, f_ex=[t.f_ex], a_ex=[t.a_ex], s0=0.3, t_end=120.0, s_dn=s_dn)[0]
    return law, rows


def stage_map():
    """§4.4: the map by the predictor (b2 law; b1 per-point tables) against the FS map."""
    tables = available_tables()
    extra = jump_down_tables(tables)
    t0 = time.perf_counter()
    law_c = fit_drift_law(tables, jump_down_tables=extra)
    t_fit = time.perf_counter() - t0
    save_drift_law(law_c, OUT / "law.json")
    save_drift_law(law_c, ROOT / "python" / "beamslider" / "data" / "default_law.json")  # the package's built-in law
    ref = read_map(ROOT / "docs" / "results" / "operating_map.jsonl")
    f_ex = sorted(set(float(x) for x in ref["f_ex_hz"]))
    a_ex = sorted(set(float(x) for x in ref["a_ex_m_s2"]))
    t0 = time.perf_counter()
    rows_c = predicted_map(drift=law_c, f_ex=f_ex, a_ex=a_ex, s0=0.3, t_end=120.0, out=OUT / "predicted_map", force=True)
    t_map = time.perf_counter() - t0
    pred_c = {(r["f_ex_hz"], r["a_ex_m_s2"]): r for r in rows_c}
    names = ["inactivity", "trivial_adaption", "signature_move", "relaxation_oscillation", "self_damping", "not_settled", "undetermined"]
    grid_ref = {(float(ref["f_ex_hz"][i]), float(ref["a_ex_m_s2"][i])): ref["behaviour"][i] for i in range(len(ref["f_ex_hz"]))}
    train = {(t.f_ex, t.a_ex) for t in tables}
    n = len(grid_ref)
    lines = [f"§4.4  Whole map (7 × 16, s0 = 0.3, 120 s) against the FS map docs/results/operating_map.jsonl",
             f"b2 law: kNN (k = {law_c.k}) on features {', '.join(law_features())}, fitted on {len(tables)} PCS tables "
             + ", ".join(f"({f:g}, {a:g})" for f, a in sorted(train))
             + f"; leave-one-point-out V error {law_c.loo['rms_error']:.5f} 1/s = {law_c.loo['ratio']:.2f} × typical |V| ({law_c.loo['typical_v']:.5f} 1/s)",
             f"timing b2: fit {t_fit:.2f} s (layer-(a) manifolds of the training points included), map {t_map:.2f} s ({1e3 * t_map / n:.1f} ms per point); "
             f"extrapolated points: {sum(r['extrapolated'] for r in rows_c)} of {n}",
             "",
             "What the law learns from the PCS tables (no FS run enters the law; the FS map is only the reference):",
             f"- s_up shift (median s_up(PCS) − s_up(HB)): {law_c.s_up_shift:+.4f}; leave one out: "
             + "; ".join(f"({r['f_ex']:g}, {r['a_ex']:g}) HB {_fmt(r['s_up_hb'], 3)} PCS {_fmt(r['s_up_pcs'], 3)} corrected {_fmt(r['s_up_corrected_loo'], 3)}" for r in law_c.loo_s_up),
             f"- lift-off threshold Λ_c = {law_c.lift_c:.3f} (median of the tables where the clampward drift ends: "
             + ", ".join(f"({r['f_ex']:g}, {r['a_ex']:g}) {r['lift_c']:.3f}" for r in law_c.lift_c_per_point) + "; the rigid-attachment constraint is Λ_c = 1)",
             f"- jump-down: the PCS high branches end at s_p = {law_c.jump_down_s:.4f} (median of the tables' jump-downs) where the forcing ratio "
             f"ρ(s_p) = a_ex/(Ω² Â_H(s_p) h) ≤ ρ_c = {law_c.rho_c:.5f}, the geometric midpoint of the bracket "
             f"({law_c.rho_bracket.get('lo') or 0:.5f}, {law_c.rho_bracket.get('hi') or 0:.5f}) between the tables whose high branch ends there and those "
             f"whose high branch passes it; jump-down tables (bisection in ρ(s_p), V not used): "
             + ", ".join(f"({r['f_ex']:g}, {r['a_ex']:g}) {r['side']}" for r in law_c.rho_bracket["tables"][len(tables):]) + "; "
             "s_dn leave one out: " + "; ".join(f"({r['f_ex']:g}, {r['a_ex']:g}) PCS {_fmt(r['s_dn_pcs'], 3)} law {_fmt(r['s_dn_law'], 3)}" for r in law_c.loo_s_dn),
             "- monostable labels (PCS down sweep without jump-up that stays below "
             f"{MONO_RISE_H:g} h on the clamping side of the HB fold): "
             + ", ".join(f"({tables[g].f_ex:g}, {tables[g].a_ex:g})" for g, y in zip(law_c.mono_groups, law_c.mono_y) if y > 0.5)]
    lines += _compare("b2 (the default law of fit_drift_law; python/beamslider/data/default_law.json, predicted_map/map.jsonl; training points predicted with "
                      "the law that includes their own PCS table)", pred_c, grid_ref, ref, train, f_ex, a_ex, names)
    _, pred_loo = _loo_rows(tables, f_ex, a_ex, jump_down_tables=extra)
    lines += _compare("b2, training points predicted leave one operating point out (their own PCS table left out of the law)",
                      pred_loo, grid_ref, ref, train, f_ex, a_ex, names)
    # What each learnt piece adds (training points leave one out).
    lines += ["", "Ablations (training points leave one out): strict / phase agreement, final-s error over agreeing points steady in FS (median, 90th percentile)"]
    for title, s_dn, kw in (("default", "law", {"jump_down_tables": extra}),
                            ("the jump-down bracket without the jump-down tables", "law", {}),
                            ("the median jump-down rule (before)", "law", {"jump_down": "median"}),
                            ("without the learnt jump-down (s_dn='hb')", "hb", {}),
                            ("with Λ_c = 1 (the rigid-attachment constraint)", "law", {"lift_off_threshold": 1.0, "jump_down_tables": extra}),
                            ("without the s_up shift", "law", {"s_up_correction": False, "jump_down_tables": extra}),
                            ("without the monostable vote", "law", {"monostable_vote": False, "jump_down_tables": extra}),
                            ("none of the four (s_dn='hb', Λ_c = 1, no shift, no vote)", "hb",
                             {"lift_off_threshold": 1.0, "s_up_correction": False, "monostable_vote": False})):
        _, rows = _loo_rows(tables, f_ex, a_ex, s_dn=s_dn, **kw)
        strict, phase, _ = _score(rows, ref, names)
        errs = [abs(rows[k]["s_final"] - ref["s_final"][i]) for k, i in
                (((float(ref["f_ex_hz"][i]), float(ref["a_ex_m_s2"][i])), i) for i in range(n))
                if rows[k]["behaviour"] == ref["behaviour"][i] and ref["steady"][i]]
        lines.append(f"  {title:<58} {strict:3d}/{n} {phase:3d}/{n}  {np.median(errs):.4f} {np.percentile(errs, 90):.4f} (n {len(errs)})")
    preds = {"b2": pred_c, "b2 LOO": pred_loo}
    for source, title in (("hb", "b1 (per-point PCS table Δs 0.02: V; HB N = 5 branches and s_up; s_dn from the PCS table)"),
                          ("table", "b1-PCS (per-point PCS table only: V, Â, s_up and s_dn from its sweeps; no layer (a))")):
        b1 = _b1_map(f_ex, a_ex, source)
        if b1 is None:
            lines.append(f"\n{title}: tables missing (run the map_tables stage)")
            continue
        preds[f"b1-{source}"] = b1
        lines += _compare(title, b1, grid_ref, ref, set(), f_ex, a_ex, names)
    (OUT / "validation_b_map.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))
    _figure_maps(grid_ref, preds, f_ex, a_ex, names)


def law_features():
    from beamslider.superslow import FEATURES

    return FEATURES


def _figure_maps(grid_ref, preds, f_ex, a_ex, names):
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.colors import ListedColormap
    except ImportError:
        return
    colours = ["0.6", "tab:green", "tab:blue", "tab:orange", "tab:red", "tab:purple", "k"]
    cmap = ListedColormap(colours)
    panels = [("FS model (120 s)", grid_ref, {})] + [(f"predictor {k}", {q: v["behaviour"] for q, v in p.items()},
                                                    {q: v.get("robust") for q, v in p.items()}) for k, p in preds.items()]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.8), sharey=True)
    for ax, (title, src, robust) in zip(axes, panels):
        z = np.array([[names.index(src[(f, a)]) for f in f_ex] for a in a_ex])
        ax.imshow(z, origin="lower", cmap=cmap, vmin=-0.5, vmax=6.5, aspect="auto",
                  extent=(f_ex[0] - 1, f_ex[-1] + 1, a_ex[0] - 1, a_ex[-1] + 1))
        # Predictions that V ± the law's resolution changes (robust False): a white cross.
        weak = [q for q, r in robust.items() if r is False]
        if weak:
            ax.scatter([q[0] for q in weak], [q[1] for q in weak], marker="x", s=18, c="w", linewidths=1.0)
        agree = sum(src[q] == grid_ref[q] for q in grid_ref)
        ax.set_title(title if title.startswith("FS") else f"{title}: {agree}/{len(grid_ref)}", fontsize=10)
        ax.set_xlabel("f_ex [Hz]")
    axes[0].set_ylabel("a_ex [m/s²]")
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in colours]
    fig.legend(handles, names, loc="lower center", ncol=7, fontsize=8)
    if any(v.get("robust") is False for p in preds.values() for v in p.values()):
        fig.text(0.995, 0.005, "×: not robust (V ± the law's resolution changes the prediction)", ha="right", va="bottom", fontsize=7)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    fig.savefig(OUT / "map_predicted_vs_fs.png", dpi=110)
    plt.close(fig)


def _cpu():
    import resource

    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


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
            _core.predict(native(Parameters()), law_json=text, f_ex_hz=f, a_ex_m_s2=a, s0=0.3, t_end_s=120.0)
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


def _law_text(law):
    from beamslider.superslow import law_json

    return law_json(law)


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
FS_ENSEMBLE = Path("/tmp/beamslider_fs_ensemble")  # 448 FS runs (~3 min on 2 cores): not committed
ENSEMBLE_S0 = [0.298, 0.299, 0.301, 0.302]


def _by_point(m):
    out = {}
    for j in range(len(m["f_ex_hz"])):
        out.setdefault((float(m["f_ex_hz"][j]), float(m["a_ex_m_s2"][j])), []).append(j)
    return out


def _first_by_point(m):
    return {k: v[0] for k, v in _by_point(m).items()}


def stage_fs_ensemble():
    """The FS map at s0 = 0.3 against FS runs started 0.001 and 0.002 off it (same grid, 120 s):
    the agreement and final-s error the FS model itself reaches, the ceiling of any reduced model;
    then the predictor's map (docs/results/superslow/predicted_map) against that ensemble."""
    from beamslider import operating_map

    ref = read_map(ROOT / "docs" / "results" / "operating_map.jsonl")
    f_ex = sorted(set(float(x) for x in ref["f_ex_hz"]))
    a_ex = sorted(set(float(x) for x in ref["a_ex_m_s2"]))
    had = len(read_map(FS_ENSEMBLE / "map.jsonl")["f_ex_hz"]) if (FS_ENSEMBLE / "map.jsonl").exists() else 0
    t0 = time.perf_counter()
    operating_map(f_ex=f_ex, a_ex=a_ex, s0=ENSEMBLE_S0, out=FS_ENSEMBLE, resume=had > 0, threads=2, progress=True)
    wall = time.perf_counter() - t0
    ens = read_map(FS_ENSEMBLE / "map.jsonl")
    ran = len(ens["f_ex_hz"]) - had
    pred = read_map(OUT / "predicted_map" / "map.jsonl")
    R, E, P = _first_by_point(ref), _by_point(ens), _first_by_point(pred)
    agree, err = [], []
    for k, i in R.items():
        for j in E[k]:
            agree.append(ens["behaviour"][j] == ref["behaviour"][i])
            if agree[-1] and ref["steady"][i] and np.isfinite(ref["s_final"][i]):
                err.append(abs(ens["s_final"][j] - ref["s_final"][i]))
    n_pt = sum(all(ens["behaviour"][j] == ref["behaviour"][i] for j in E[k]) for k, i in R.items())
    maj = any_ = 0
    e_map, e_med, spread = [], [], []
    for k, i in R.items():
        b = pred["behaviour"][P[k]]
        bs = [ref["behaviour"][i]] + [ens["behaviour"][j] for j in E[k]]
        vals, cnt = np.unique(bs, return_counts=True)
        maj += b == vals[np.argmax(cnt)]
        any_ += b in bs
        if b == ref["behaviour"][i] and ref["steady"][i] and np.isfinite(ref["s_final"][i]):
            e_map.append(abs(pred["s_final"][P[k]] - ref["s_final"][i]))
            same = [ens["s_final"][j] for j in E[k] if ens["behaviour"][j] == b and ens["steady"][j]] + [ref["s_final"][i]]
            e_med.append(abs(pred["s_final"][P[k]] - float(np.median(same))))
            # The spread of the final s over the five FS runs (any behaviour): the reference's own
            # reproducibility at this point.
            spread.append(float(np.ptp([ref["s_final"][i]] + [ens["s_final"][j] for j in E[k]])))
    spread = np.asarray(spread)
    n_pred = sum(pred["behaviour"][P[k]] == ref["behaviour"][i] for k, i in R.items())
    lines = [
        "§4.4 FS reproducibility: the FS map (s0 = 0.3, docs/results/operating_map.jsonl) against FS runs from s0 = "
        + ", ".join(f"{x:g}" for x in ENSEMBLE_S0) + f" (same grid, 120 s; {len(ens['f_ex_hz'])} runs; "
        + (f"{ran} run in this call, {wall:.0f} s wall on 2 threads)" if ran else f"read back from {FS_ENSEMBLE})"),
        f"FS vs FS: behaviour agrees in {sum(agree)}/{len(agree)} runs = {100 * np.mean(agree):.1f} %; "
        f"all four perturbed runs agree with the map at {n_pt}/112 points",
        f"FS vs FS final s over agreeing runs steady in the map (n = {len(err)}): median {np.median(err):.4f}, 90th percentile {np.percentile(err, 90):.4f}",
        f"predictor (docs/results/superslow/predicted_map, the default law): agrees with the FS map at {n_pred}/112, with the majority of the five FS runs at {maj}/112, "
        f"with at least one of them at {any_}/112",
        f"predictor final s over points agreeing with the map, steady in FS (n = {len(e_map)}): against the map median {np.median(e_map):.4f}, "
        f"90th percentile {np.percentile(e_map, 90):.4f}; against the median of the FS runs of that behaviour {np.median(e_med):.4f} / {np.percentile(e_med, 90):.4f}",
    ]
    em = np.asarray(e_map)
    for tol in (0.01, 0.02):
        keep = spread <= tol
        lines.append(f"predictor final s at the points where the five FS runs end within {tol:g} of each other ({int(keep.sum())} of those {em.size}): "
                     f"median {np.median(em[keep]):.4f}, 90th percentile {np.percentile(em[keep], 90):.4f}; at the other {int((~keep).sum())}: "
                     f"median {np.median(em[~keep]):.4f}, 90th percentile {np.percentile(em[~keep], 90):.4f}")
    lines.append("per point (FS map | the four perturbed FS runs | predictor), final s, where the five FS runs do not all agree:")
    for k, i in sorted(R.items()):
        bs = [ens["behaviour"][j] for j in E[k]]
        if any(b != ref["behaviour"][i] for b in bs):
            lines.append(f"  ({k[0]:g}, {k[1]:g}): {ref['behaviour'][i][:4]} {ref['s_final'][i]:.3f} | "
                         + " ".join(f"{ens['behaviour'][j][:4]} {ens['s_final'][j]:.3f}" for j in E[k])
                         + f" | {pred['behaviour'][P[k]][:4]} {pred['s_final'][P[k]]:.3f}")
    (OUT / "validation_c_fs_ensemble.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


# Narrow zeros of the PCS high-branch drift where the FS runs stop (final s).
STOP_WINDOWS = [(110.0, 10.0, 0.36, 0.40), (108.0, 10.0, 0.37, 0.45), (112.0, 10.0, 0.37, 0.40), (114.0, 12.0, 0.37, 0.40),
                (116.0, 12.0, 0.37, 0.40),
                # the pocket near s = 0.335 (where the FS runs at 116–130 Hz stop, and at 110 Hz linger)
                (108.0, 10.0, 0.31, 0.36), (110.0, 10.0, 0.31, 0.36), (112.0, 10.0, 0.31, 0.36), (116.0, 12.0, 0.31, 0.36),
                (118.0, 10.0, 0.31, 0.36)]
STOP_TABLES = Path("/tmp/beamslider_drift_stops")  # re-computable (not committed)


def _fine_grid(lo=0.33, hi=0.46, ds=0.01, fine=0.0025):
    """Δs = ds over [B/(2L) rounded, 0.5] with Δs = fine inside [lo, hi]."""
    return np.unique(np.round(np.concatenate([np.arange(0.04, 0.5001, ds), np.arange(lo, hi + 1e-9, fine)]), 5))


def stage_stops():
    """(1) PCS V_H with Δs = 0.0025 around where the FS runs at 108 and 110 Hz stop (0.442 and
    0.382, while the default law stops at 0.33); (2) the b2 map with training tables refined to
    Δs = 0.0025 on [0.33, 0.46], with the layer-(a) input s − s_res added and training points
    added at 108–114 Hz (Python path; training points in-sample and leave one out)."""
    from beamslider import drift_law
    from beamslider.maps.compute import _predicted_rows_python

    lines = ["§4.4 final s: narrow zeros of the PCS high-branch drift where the FS runs stop (TABLE_OPTS settle/window, Δs 0.0025 in the window)"]
    STOP_TABLES.mkdir(parents=True, exist_ok=True)
    ref = read_map(ROOT / "docs" / "results" / "operating_map.jsonl")
    R = _first_by_point(ref)
    for f, a, lo, hi in STOP_WINDOWS:
        s = np.unique(np.round(np.concatenate([np.arange(0.04, lo, 0.02), np.arange(lo, hi + 1e-9, 0.0025), np.arange(hi, 0.5001, 0.02)]), 5))
        p = STOP_TABLES / f"window_{f:g}Hz_{a:g}ms2_{lo:g}-{hi:g}.jsonl"
        t = drift_table(f_ex=f, a_ex=a, s=s, settle_periods=100, window_s=2.0, out=p, resume=p.exists())
        h = [i for i in range(len(t.s)) if t.branch[i] == "H" and lo - 1e-9 <= t.s[i] <= hi + 1e-9]
        lines.append(f"  ({f:g}, {a:g}), FS map stops at s = {ref['s_final'][R[(f, a)]]:.3f}; V_H [1e-3 1/s] ± se: "
                     + " ".join(f"{t.s[i]:.4f}:{1e3 * t.v[i]:+.2f}±{1e3 * t.v_se[i]:.2f}" for i in h))
    lines.append("FS s(t) at (110, 10): the slider lingers in the pocket near 0.335 and may escape to the stop at 0.382")
    for s0 in (0.299, 0.3, 0.301):
        r = simulate(f_ex=110.0, a_ex=10.0, s0=s0, t_end=120.0, record_every=200)
        tt, ss = np.asarray(r.t), np.asarray(r.s)
        lines.append(f"  s0 = {s0:g}: " + " ".join(f"t {x:g} s: {ss[min(np.searchsorted(tt, x), ss.size - 1)]:.3f}" for x in (10, 20, 40, 60, 90, 120)))
    f_ex = sorted(set(float(x) for x in ref["f_ex_hz"]))
    a_ex = sorted(set(float(x) for x in ref["a_ex_m_s2"]))
    extra = [(108.0, 12.0), (112.0, 12.0), (110.0, 12.0), (114.0, 10.0), (108.0, 8.0)]
    lines += ["", "b2 map with refined training tables (Δs 0.01, 0.0025 on [0.33, 0.46]; 100 settling periods, 2-s windows):",
              f"{'inputs':>22} {'k':>2} {'training':>12} | {'in-sample strict':>16} {'phase':>6} {'final s p50':>11} {'p90':>6} {'n':>3} | {'LOO strict':>10} {'phase':>6} {'p50':>6} {'p90':>6} {'n':>3} | tables computed in this call [s]"]
    saved = drift_law.FEATURES
    try:
        for name, pts in (("12 points", TRAINING), ("17 points", TRAINING + extra), ("18 points", TRAINING + extra + [(112.0, 8.0)])):
            t0 = time.perf_counter()
            tabs = []
            for f, a in pts:
                p = STOP_TABLES / f"refined_{f:g}Hz_{a:g}ms2.jsonl"
                tabs.append(drift_table(f_ex=f, a_ex=a, s=_fine_grid(), settle_periods=100, window_s=2.0, out=p, resume=p.exists()))
            wall = time.perf_counter() - t0
            for feats in (("amp_rel", "s"), ("amp_rel", "s", "ds_res")):
                for k in (3, 4, 6):
                    drift_law.FEATURES = feats
                    law = fit_drift_law(tabs, k=k, jump_down="median")
                    rows = {(r["f_ex_hz"], r["a_ex_m_s2"]): r for r in _predicted_rows_python(Parameters(), law, f_ex, a_ex, 0.3, 120.0, "law", None, 5)}
                    res = [_score_agreeing(rows, ref)]
                    for j, t in enumerate(tabs):
                        lw = fit_drift_law([x for i, x in enumerate(tabs) if i != j], k=k, jump_down="median")
                        rows[(t.f_ex, t.a_ex)] = _predicted_rows_python(Parameters(), lw, [t.f_ex], [t.a_ex], 0.3, 120.0, "law", None, 5)[0]
                    res.append(_score_agreeing(rows, ref))
                    lines.append(f"{','.join(feats):>22} {k:2d} {name:>12} | " + " | ".join(
                        f"{st:10d}/112 {ph:6d} {np.median(e):11.4f} {np.percentile(e, 90):6.4f} {e.size:3d}" for st, ph, e in res)
                        + f" | {wall:.1f}")
                    print(lines[-1], flush=True)
    finally:
        drift_law.FEATURES = saved
    (OUT / "validation_c_stops.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")


# Training-table settings near the speed bar (whole map including training ≥ 20× the FS map).
CHEAP_VARIANTS = [
    ("cheap (CHEAP['cheap'])", dict(ds=0.02, settle_periods=20, first_settle_periods=200, window_s=0.5)),
    ("0.7-s windows", dict(ds=0.02, settle_periods=20, first_settle_periods=200, window_s=0.7)),
    ("40 settling periods", dict(ds=0.02, settle_periods=40, first_settle_periods=200, window_s=0.5)),
    ("Δs 0.015", dict(ds=0.015, settle_periods=20, first_settle_periods=200, window_s=0.5)),
    ("Δs 0.025, 0.8-s windows", dict(ds=0.025, settle_periods=20, first_settle_periods=200, window_s=0.8)),
    ("10 settling periods, 0.6-s windows", dict(ds=0.02, settle_periods=10, first_settle_periods=200, window_s=0.6)),
    ("100 first settling periods, 0.6-s windows", dict(ds=0.02, settle_periods=20, first_settle_periods=100, window_s=0.6)),
]


def stage_cheap_settings():
    """The b2 map (default law inputs, 12 training points in-sample) for training-table settings
    that cost about as much as the cheap ones, timed from scratch two tables at a time, against
    the FS map's measured wall time: does any reach the 80 % bar at ≥ 20× robustly?"""
    import tempfile

    ref = read_map(ROOT / "docs" / "results" / "operating_map.jsonl")
    f_ex = sorted(set(float(x) for x in ref["f_ex_hz"]))
    a_ex = sorted(set(float(x) for x in ref["a_ex_m_s2"]))
    fs_wall, _ = _fs_map_time(f_ex, a_ex)
    lines = [f"§4.5 training-table settings near the speed bar: FS map {fs_wall:.1f} s wall on 2 threads (measured now); 12 training points "
             "(TRAINING), in-sample; the predicted map by the core on 2 threads",
             f"{'settings':>42} {'jump-down rule':>26} | {'tables [s]':>10} {'fit+map [s]':>11} {'ratio':>6} | {'strict':>7} {'phase':>6} | final s p50  p90"]
    for name, opts in CHEAP_VARIANTS:
        for rule in ("median", "bracket + jump-down tables"):
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                tabs = drift_tables(points=TRAINING, out=tmp, threads=2, **opts)
                extra = jump_down_tables(tabs, out=Path(tmp) / "jump_down", **opts) if rule != "median" else []
                tw = time.perf_counter() - t0
            t0 = time.perf_counter()
            law = fit_drift_law(tabs, jump_down_tables=extra) if rule != "median" else fit_drift_law(tabs, jump_down="median")
            rows = {(r["f_ex_hz"], r["a_ex_m_s2"]): r for r in predicted_map(drift=law, f_ex=f_ex, a_ex=a_ex, s0=0.3, t_end=120.0, threads=2)}
            mw = time.perf_counter() - t0
            st, ph, e = _score_agreeing(rows, ref)
            lines.append(f"{name:>42} {rule:>26} | {tw:10.2f} {mw:11.2f} {fs_wall / (tw + mw):5.1f}× | {st:3d}/112 {ph:3d}/112 | "
                         f"{np.median(e):.4f} {np.percentile(e, 90):.4f}")
            print(lines[-1], flush=True)
    (OUT / "validation_c_cheap_settings.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")


def _score_agreeing(rows, ref):
    """(strict, phase, final-s errors over the points agreeing with the FS map and steady in it):
    the §4.4 measure."""
    R = _first_by_point(ref)
    st, ph, _ = _score(rows, ref, None)
    e = [abs(r["s_final"] - ref["s_final"][R[k]]) for k, r in rows.items()
         if r["behaviour"] == ref["behaviour"][R[k]] and ref["steady"][R[k]] and np.isfinite(ref["s_final"][R[k]])]
    return st, ph, np.asarray(e)


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
