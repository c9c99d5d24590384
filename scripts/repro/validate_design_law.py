"""The design law on designs it never saw (docs/model.md §6.5): FS maps against predicted maps.

    python scripts/repro/validate_design_law.py [--work DIR] [--law LAW.json] [--out docs/results/design_law]

Eight designs are drawn over the design box by a fixed seed (a Latin hypercube, seed 20261126;
drawn before any law was fitted, and none of them is a training design). For each, the FS map of
the design search's band (a_ex 10 and 14 m/s², f_ex 100–130 Hz step 2, s0 0.3, 120 s; resumable
under --work) and the predicted map with the design law (the built-in one unless --law) give the
adaption bandwidth per level (beamslider.design.objectives, a_min 0.3 h) and the behaviour
agreement over the 32 points. The paper's map at the prototype (docs/results/operating_map.jsonl) is
predicted too. Writes heldout.txt, heldout.json and heldout.png under --out.

With --own-laws DIR (DIR/design_<i>/law.json, each fitted at that held-out design by
`beamslider fit-law --params`), the same maps are also predicted with each design's own law: the
ceiling of any transfer (diagnostics only; these laws are never used in fitting).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

import beamslider as bs
from beamslider.design.objectives import adaption_bandwidth
from beamslider.maps import operating_map
from beamslider.superslow import predicted_map
from beamslider.superslow import default_law, design_params, design_sample, load_law

ROOT = Path(__file__).resolve().parents[2]
F = [100.0 + 2 * i for i in range(16)]
A = [10.0, 14.0]
SEED = 20261126


def heldout_designs():
    return design_sample(8, seed=SEED, method="lhs")


def _rows(path: Path):
    lines = path.read_text().splitlines()[1:]
    return {(r["f_ex_hz"], r["a_ex_m_s2"]): r for r in (json.loads(l) for l in lines if l.strip())}


def _label(r) -> str:
    return r.get("behaviour") or ("error" if r.get("status") == "error" else "none")


ADAPTING = ("trivial_adaption", "signature_move", "relaxation_oscillation")


def bands(rows):
    out = []
    for a in A:
        beh = [_label(rows[(f, a)]) for f in F]
        amp = [np.nan if rows[(f, a)].get("amplitude_final_h") is None else float(rows[(f, a)]["amplitude_final_h"]) for f in F]
        out.append(adaption_bandwidth(F, beh, amp, a_min_h=0.3))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default="validation-out/design_law", help="FS maps of the held-out designs (resumable)")
    ap.add_argument("--law", help="a design law file (default: the built-in one)")
    ap.add_argument("--out", default=str(ROOT / "docs" / "results" / "design_law"))
    ap.add_argument("--own-laws", help="folder with design_<i>/law.json: each held-out design's own law (the ceiling)")
    a = ap.parse_args()
    law = load_law(a.law) if a.law else default_law()
    work, out = Path(a.work), Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    res = []
    for i, x in enumerate(heldout_designs()):
        p = design_params(x)
        d = work / f"design_{i}"
        # resume: completes a killed map and upgrades an older results format (rows reclassified, no re-run)
        operating_map(p, f_ex=F, a_ex=A, s0=0.3, t_end=120.0, out=d, resume=(d / "map.jsonl").exists())
        fs = _rows(d / "map.jsonl")
        pr = {(r["f_ex_hz"], r["a_ex_m_s2"]): r for r in predicted_map(p, drift=law, f_ex=F, a_ex=A, s0=0.3, t_end=120.0)}
        bf, bp = bands(fs), bands(pr)
        agree = sum(_label(fs[k]) == _label(pr[k]) for k in fs)
        coarse = sum((_label(fs[k]) in ADAPTING) == (_label(pr[k]) in ADAPTING) for k in fs)
        own = None
        if a.own_laws and (Path(a.own_laws) / f"design_{i}" / "law.json").exists():
            ol = load_law(Path(a.own_laws) / f"design_{i}" / "law.json")
            po = {(r["f_ex_hz"], r["a_ex_m_s2"]): r for r in predicted_map(p, drift=ol, f_ex=F, a_ex=A, s0=0.3, t_end=120.0)}
            own = {"bandwidth_hz": bands(po), "mean_hz": float(np.mean(bands(po))),
                   "agree": sum(_label(fs[k]) == _label(po[k]) for k in fs)}
        res.append({"design": i, "x": x, "fs_bandwidth_hz": bf, "predicted_bandwidth_hz": bp,
                    "fs_mean_hz": float(np.mean(bf)), "predicted_mean_hz": float(np.mean(bp)), "agree": agree,
                    "adapting_or_not": coarse, "points": len(fs), "own_law": own, "extrapolated": any(bool(r.get("extrapolated")) for r in pr.values()),
                    "fs": {f"{k[0]:g},{k[1]:g}": _label(v) for k, v in fs.items()},
                    "predicted": {f"{k[0]:g},{k[1]:g}": _label(v) for k, v in pr.items()}})
    paper = _rows(ROOT / "docs" / "results" / "operating_map.jsonl")
    fp = sorted({k[0] for k in paper})
    ap_ = sorted({k[1] for k in paper})
    pm = {(r["f_ex_hz"], r["a_ex_m_s2"]): r for r in predicted_map(bs.Parameters(), drift=law, f_ex=fp, a_ex=ap_)}
    paper_agree = sum(_label(paper[k]) == _label(pm[k]) for k in paper)
    within = sum(abs(r["fs_mean_hz"] - r["predicted_mean_hz"]) <= 3.0 for r in res)
    agree = sum(r["agree"] for r in res) / sum(r["points"] for r in res)
    names = [c for c in res[0]["x"]]
    what = (f"the design law ({len(law.laws)} training designs, k_sets {law.k_sets})" if hasattr(law, "laws")
            else f"the drift law {a.law} (one parameter set, used for every design)")
    lines = [f"# held-out designs (LHS seed {SEED}) against {what}; FS and predicted maps: a_ex 10/14 m/s^2, f_ex 100-130 Hz step 2, s0 0.3, 120 s",
             "# python scripts/repro/validate_design_law.py",
             "# design " + " ".join(f"{n}" for n in names),
             ]
    for r in res:
        lines.append(f"#   {r['design']}: " + " ".join(f"{r['x'][n]:.4g}" for n in names))
    lines.append("design  FS band 10/14 [Hz]  mean | predicted 10/14  mean | |diff| | behaviour agreement")
    for r in res:
        lines.append(f"{r['design']:>6}  {r['fs_bandwidth_hz'][0]:5.1f} {r['fs_bandwidth_hz'][1]:5.1f} {r['fs_mean_hz']:6.1f} | "
                     f"{r['predicted_bandwidth_hz'][0]:5.1f} {r['predicted_bandwidth_hz'][1]:5.1f} {r['predicted_mean_hz']:6.1f} | "
                     f"{abs(r['fs_mean_hz'] - r['predicted_mean_hz']):5.1f} | {r['agree']}/{r['points']}"
                     + ("  (extrapolated)" if r["extrapolated"] else ""))
    lines.append(f"within 3 Hz: {within}/{len(res)}; behaviour agreement {100 * agree:.0f} % over {sum(r['points'] for r in res)} points")
    coarse = sum(r["adapting_or_not"] for r in res) / sum(r["points"] for r in res)
    lines.append(f"adapting or not (trivial adaption, signature move, relaxation oscillation against the rest): "
                 f"agreement {100 * coarse:.0f} %")
    if all(r["own_law"] for r in res):
        w_own = sum(abs(r["fs_mean_hz"] - r["own_law"]["mean_hz"]) <= 3.0 for r in res)
        ag_own = sum(r["own_law"]["agree"] for r in res) / sum(r["points"] for r in res)
        lines.append("ceiling, each design's own law (fit-law at the held-out design; diagnostics only): mean bandwidth "
                     + ", ".join(f"{r['own_law']['mean_hz']:.1f}" for r in res)
                     + f" Hz; within 3 Hz: {w_own}/{len(res)}; behaviour agreement {100 * ag_own:.0f} %")
    lines.append(f"paper's map at the prototype (docs/results/operating_map.jsonl, s0 0.3, 120 s): {paper_agree}/{len(paper)} agree")
    labels = sorted({v for r in res for v in list(r["fs"].values()) + list(r["predicted"].values())})
    lines.append("confusion over the held-out points (rows FS, columns predicted): " + ", ".join(labels))
    for lf in labels:
        counts = [sum(1 for r in res for k in r["fs"] if r["fs"][k] == lf and r["predicted"][k] == lp) for lp in labels]
        lines.append(f"  {lf:>24} " + " ".join(f"{c:4d}" for c in counts))
    text = "\n".join(lines) + "\n"
    (out / "heldout.txt").write_text(text)
    (out / "heldout.json").write_text(json.dumps({"designs": res, "within_3hz": within, "agreement": agree,
                                                  "adapting_or_not": coarse,
                                                  "paper_map_agree": paper_agree, "paper_map_points": len(paper)}, indent=1))
    print(text, end="")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    fig, ax = plt.subplots(figsize=(4.6, 4.4))
    fs_m = [r["fs_mean_hz"] for r in res]
    pr_m = [r["predicted_mean_hz"] for r in res]
    ax.fill_between([0, 30], [-3, 27], [3, 33], color="0.9", label="±3 Hz")
    ax.plot([0, 30], [0, 30], color="0.5", lw=0.8)
    ax.scatter(fs_m, pr_m, color="k", zorder=3)
    at: dict = {}
    for r in res:  # designs at the same point share one label
        at.setdefault((r["fs_mean_hz"], r["predicted_mean_hz"]), []).append(str(r["design"]))
    for xy, names_ in at.items():
        ax.annotate(", ".join(names_), xy, textcoords="offset points", xytext=(4, 3))
    ax.set_xlim(-1, 31)
    ax.set_ylim(-1, 31)
    ax.set_xlabel("FS adaption bandwidth [Hz] (mean of 10 and 14 m/s²)")
    ax.set_ylabel("predicted adaption bandwidth [Hz]")
    ax.set_title(f"held-out designs: {within}/8 within 3 Hz")
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(out / "heldout.png", dpi=120)


if __name__ == "__main__":
    main()
