"""The design law at its own training designs, each left out (docs/model.md §6.5): FS maps against
maps predicted by the blend of the other training designs.

    python scripts/repro/validate_design_law_loo.py [--work DIR] [--out docs/results/design_law] [--stacked]

The held-out check (validate_design_law.py) has eight designs; this one has every training design
of the built-in design law except the prototype (64): design j's map is predicted with a design law
fitted on the others (same length scales, k_sets), so the law never saw the design's drift
tables. FS maps (a_ex 10/14 m/s², f_ex 100–130 Hz step 2, s0 0.3, 120 s) are resumable under
--work (design_<j>/). Per design: adaption bandwidth of FS and predictor (mean of the two levels)
and behaviour agreement; writes loo.txt and loo.json under --out. Beside them, two diagnostics: the
agreement on "adapting or not" (trivial adaption, signature move or relaxation oscillation against
every other label), and the same maps predicted *in sample* by the shipped law (the design's own
drift tables in the blend), which separates the error of carrying the law over to a new design from
that of the reduced model itself.

--stacked (needs scikit-learn; diagnostics, not a shipped model): a gradient-boosted classifier of
the FS behaviour from the design coordinates, (f_ex, a_ex) and the predictor's row (behaviour,
final s and amplitude, the shifted labels), scored by leave-designs-out cross-validation (8 folds
of whole designs): how much of the disagreement a learned correction of the reduced model could
remove.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from beamslider import Parameters
from beamslider.design.objectives import adaption_bandwidth
from beamslider.maps import operating_map
from beamslider.superslow import predicted_map
from beamslider.superslow import default_law, design_coordinates, design_params
from beamslider.superslow.design_law import DesignLaw

ROOT = Path(__file__).resolve().parents[2]
F = [100.0 + 2 * i for i in range(16)]
A = [10.0, 14.0]
LABELS = ("inactivity", "not_settled", "relaxation_oscillation", "self_damping", "signature_move",
          "trivial_adaption", "undetermined")


def label(r) -> str:
    return r.get("behaviour") or ("error" if r.get("status") == "error" else "none")


def by_point(rows):
    return {(r["f_ex_hz"], r["a_ex_m_s2"]): r for r in rows}


def read_rows(path: Path):
    lines = path.read_text().splitlines()[1:]
    return by_point(json.loads(l) for l in lines if l.strip())


def mean_band(rows, amp_of=None) -> float:
    out = []
    for a in A:
        beh = [label(rows[(f, a)]) for f in F]
        amp = [np.nan if rows[(f, a)].get("amplitude_final_h") is None else float(rows[(f, a)]["amplitude_final_h"])
               for f in F]
        out.append(adaption_bandwidth(F, beh, amp, a_min_h=0.3))
    return float(np.mean(out))


ADAPTING = ("trivial_adaption", "signature_move", "relaxation_oscillation")


def coarse(fs, pr) -> int:
    """Points where FS and the predictor agree on whether the slider adapts (the labels in ADAPTING)."""
    return sum((label(fs[k]) in ADAPTING) == (label(pr[k]) in ADAPTING) for k in fs)


def without(law: DesignLaw, j: int) -> DesignLaw:
    """The design law of every training design but j (the shipped length scales and k_sets)."""
    keep = [i for i in range(len(law.laws)) if i != j]
    return DesignLaw(box=law.box, base=law.base, x=[law.x[i] for i in keep], laws=[law.laws[i] for i in keep],
                     scales=law.scales, k_sets=law.k_sets, jam_gap_ratio=law.jam_gap_ratio)


def features(x, row, f, a):
    """Inputs of the stacked classifier: unit-box coordinates, the operating point, the predictor's row."""
    from beamslider.superslow.design_law import DESIGN_BOX

    u = [c.unit(x[c.name]) for c in DESIGN_BOX]
    num = [row.get(k) or 0.0 for k in ("s_final", "amplitude_final_h", "amplitude_max_h", "amplitude_initial_h",
                                       "net_travel")]
    flags = [float(bool(row.get(k))) for k in ("monostable", "robust", "extrapolated")]
    onehot = [float(label(row) == L) for L in LABELS]
    shifted = row.get("shifted") or []
    sh = [float(len(shifted) > j and shifted[j][0] == L) for j in range(2) for L in LABELS]
    return u + [f, a, f / x["natural_frequency_factor"]] + num + flags + onehot + sh


def stacked(res, seed: int = 0):
    from sklearn.ensemble import GradientBoostingClassifier
    from sklearn.model_selection import GroupKFold

    X, y, g, where = [], [], [], []
    for gi, r in enumerate(res):
        for k, fr in r["fs_rows"].items():
            if label(fr) == "error":
                continue
            X.append(features(r["x"], r["pr_rows"][k], *k))
            y.append(label(fr))
            g.append(gi)
            where.append((gi, k))
    X, y, g = np.array(X), np.array(y), np.array(g)
    pred = np.empty(len(y), dtype=object)
    for tr, te in GroupKFold(n_splits=8).split(X, y, g):
        m = GradientBoostingClassifier(n_estimators=150, max_depth=3, subsample=0.8, random_state=seed).fit(X[tr], y[tr])
        pred[te] = m.predict(X[te])
    agree = float(np.mean(pred == y))
    within = 0
    for gi, r in enumerate(res):
        rows = {k: dict(v) for k, v in r["pr_rows"].items()}
        for (gj, k), p in zip(where, pred):
            if gj == gi:
                rows[k]["behaviour"] = p
                if p in ("trivial_adaption", "signature_move") and (rows[k].get("amplitude_final_h") or 0.0) < 0.3:
                    rows[k]["amplitude_final_h"] = rows[k].get("amplitude_max_h")
        within += abs(mean_band(rows) - r["fs_mean_hz"]) <= 3.0
    return within, agree, len(y)


def _complete(path: Path) -> bool:
    """Whether an FS map under --work holds every point of the band (a map.txt is not needed)."""
    return path.exists() and len(read_rows(path)) == len(F) * len(A)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default="validation-out/design_law_loo", help="FS maps of the training designs (resumable)")
    ap.add_argument("--out", default=str(ROOT / "docs" / "results" / "design_law"))
    ap.add_argument("--stacked", action="store_true", help="also the stacked classifier's cross-validation (scikit-learn)")
    ap.add_argument("--only-computed", action="store_true",
                    help="only the designs whose FS map under --work is complete (every point of the band); no FS runs")
    a = ap.parse_args()
    law = default_law()
    x0 = design_coordinates(Parameters())
    work, out = Path(a.work), Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    res = []
    for j, x in enumerate(law.x):
        if all(abs(x[k] - x0[k]) <= 1e-12 * max(1.0, abs(x0[k])) for k in x0):
            continue  # the prototype: its map is the paper's (validate_design_law.py)
        p = design_params(x)
        d = work / f"design_{j:02d}"
        if a.only_computed and not _complete(d / "map.jsonl"):
            continue
        operating_map(p, f_ex=F, a_ex=A, s0=0.3, t_end=120.0, out=d, resume=(d / "map.jsonl").exists())
        fs = read_rows(d / "map.jsonl")
        pr = by_point(predicted_map(p, drift=without(law, j), f_ex=F, a_ex=A, s0=0.3, t_end=120.0))
        own = by_point(predicted_map(p, drift=law, f_ex=F, a_ex=A, s0=0.3, t_end=120.0))
        res.append({"design": j, "x": x, "fs_mean_hz": mean_band(fs), "predicted_mean_hz": mean_band(pr),
                    "agree": sum(label(fs[k]) == label(pr[k]) for k in fs), "points": len(fs),
                    "coarse": coarse(fs, pr), "in_sample_mean_hz": mean_band(own),
                    "in_sample_agree": sum(label(fs[k]) == label(own[k]) for k in fs), "in_sample_coarse": coarse(fs, own),
                    "fs_rows": fs, "pr_rows": pr})
        print(f"design {j}: FS {res[-1]['fs_mean_hz']:.1f} Hz, predicted {res[-1]['predicted_mean_hz']:.1f} Hz, "
              f"agreement {res[-1]['agree']}/{len(fs)}", flush=True)
    within = sum(abs(r["fs_mean_hz"] - r["predicted_mean_hz"]) <= 3.0 for r in res)
    agree = sum(r["agree"] for r in res) / sum(r["points"] for r in res)
    if not res:
        raise SystemExit("no training design with a complete FS map under --work")
    lines = [f"# the design law's training designs, each predicted by the law of the others (leave one design out); "
             f"FS and predicted maps: a_ex 10/14 m/s^2, f_ex 100-130 Hz step 2, s0 0.3, 120 s",
             "# python scripts/repro/validate_design_law_loo.py" + (" --stacked" if a.stacked else "")
             + (f"  ({len(res)} of {len(law.x) - 1} designs: --only-computed)" if a.only_computed else ""),
             "design  FS band mean [Hz] | predicted | |diff| | behaviour agreement"]
    for r in res:
        lines.append(f"{r['design']:>6}  {r['fs_mean_hz']:6.1f} | {r['predicted_mean_hz']:6.1f} | "
                     f"{abs(r['fs_mean_hz'] - r['predicted_mean_hz']):5.1f} | {r['agree']}/{r['points']}")
    lines.append(f"within 3 Hz: {within}/{len(res)} ({100 * within / len(res):.0f} %); behaviour agreement "
                 f"{100 * agree:.0f} % over {sum(r['points'] for r in res)} points")
    n = sum(r["points"] for r in res)
    co = sum(r["coarse"] for r in res) / n
    w_in = sum(abs(r["fs_mean_hz"] - r["in_sample_mean_hz"]) <= 3.0 for r in res)
    ag_in = sum(r["in_sample_agree"] for r in res) / n
    co_in = sum(r["in_sample_coarse"] for r in res) / n
    lines.append(f"adapting or not (trivial adaption, signature move, relaxation oscillation against the rest): "
                 f"agreement {100 * co:.0f} %")
    lines.append(f"in sample (diagnostics: the shipped law, each design's own drift tables in the blend): within 3 Hz "
                 f"{w_in}/{len(res)} ({100 * w_in / len(res):.0f} %), behaviour agreement {100 * ag_in:.0f} %, "
                 f"adapting or not {100 * co_in:.0f} %")
    labels = sorted({label(v) for r in res for v in list(r["fs_rows"].values()) + list(r["pr_rows"].values())})
    lines.append("confusion (rows FS, columns predicted): " + ", ".join(labels))
    for lf in labels:
        counts = [sum(1 for r in res for k in r["fs_rows"] if label(r["fs_rows"][k]) == lf and label(r["pr_rows"][k]) == lp)
                  for lp in labels]
        lines.append(f"  {lf:>24} " + " ".join(f"{c:4d}" for c in counts))
    summary = {"within_3hz": within, "designs": len(res), "agreement": agree, "adapting_or_not": co,
               "in_sample": {"within_3hz": w_in, "agreement": ag_in, "adapting_or_not": co_in}}
    if a.stacked:
        w, ag, n = stacked(res)
        lines.append(f"stacked classifier (diagnostics; 8-fold leave-designs-out CV over {n} points): within 3 Hz "
                     f"{w}/{len(res)} ({100 * w / len(res):.0f} %), behaviour agreement {100 * ag:.0f} %")
        summary["stacked"] = {"within_3hz": w, "agreement": ag}
    text = "\n".join(lines) + "\n"
    (out / "loo.txt").write_text(text)
    (out / "loo.json").write_text(json.dumps({**summary, "per_design": [
        {k: r[k] for k in ("design", "x", "fs_mean_hz", "predicted_mean_hz", "agree", "points", "coarse",
                            "in_sample_mean_hz", "in_sample_agree", "in_sample_coarse")} for r in res]}, indent=1))
    print(text, end="")


if __name__ == "__main__":
    main()
