"""§4.4 of the layer-(b) validation: the predicted map (b1 and b2) against the FS map, phase by
phase, and its figures."""

from __future__ import annotations

import time

import numpy as np

from beamslider import read_map
from beamslider.superslow import predicted_map
from beamslider.superslow import MONO_RISE_H, fit_drift_law, predict, read_drift_table, save_drift_law

from .common import MAP_DRIFT, OUT, ROOT, _agree_phase, _fmt, _score, available_tables, jump_down_tables


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
