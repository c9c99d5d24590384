"""§4.2–4.3 of the layer-(b) validation: V from PCS against FS s(t) slopes, the representative
runs (b1 tables and the b2 law left one point out) and their figures."""

from __future__ import annotations


import numpy as np

from beamslider import Parameters, read_map, simulate
from beamslider.superslow import fit_drift_law, hb_manifold, predict, read_drift_table

from .common import OUT, REPRESENTATIVE, ROOT, _fmt, default_law, table_path


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
