"""Table of a design run's evaluations for docs/validation/design.md: every FS re-check and the
predictor-vs-FS disagreement at the prototype and the best designs.

    python scripts/repro/design_report.py docs/results/design/fs docs/results/design/predictor
"""

import sys

from beamslider.design import read_design_file


def line(r):
    var = ", ".join(f"{k} = {v:.4g}" for k, v in r["variables"].items())
    per = ""
    if len(r.get("samples", [])) == 1:
        per = " | " + ", ".join(f"{l['a_ex_m_s2']:g}: {l['bandwidth_hz']:.2f} Hz / {l['harvest']:.3f}"
                                for l in r["samples"][0]["lines"])
    else:
        per = " | per sample bandwidth " + ", ".join(f"{s['bandwidth_hz']:.2f}" for s in r.get("samples", []))
        per += f"; mean {r.get('bandwidth_mean_hz', float('nan')):.2f} Hz, q{r.get('quantile', 0):g} " \
               f"{r.get('bandwidth_quantile_hz', float('nan')):.2f} Hz; harvest mean {r.get('harvest_mean', float('nan')):.3f}"
    return (f"{r['evaluator']:>9} {r['mode']:>7} {r['t_end_s']:>5g} s  {var}: bandwidth {r['bandwidth_hz']:.2f} Hz, "
            f"harvest {r['harvest']:.3f}{per}")


def main(folders):
    for d in folders:
        h, recs, _ = read_design_file(d)
        cfg = h["config"]
        print(f"== {d}: {len(recs)} evaluations; evaluator {cfg['evaluator']}, variables {cfg['design']}")
        search = [r for r in recs if r["evaluator"] == cfg["evaluator"] and r["t_end_s"] == cfg["band"]["t_end_s"]
                  and r["mode"] == ("nominal" if cfg["objective"]["robust"] == "none" else "robust")]
        feas = sorted((r for r in search if r["feasible"]), key=lambda r: -r["score"])
        print(f"search: {len(search)} designs, {len(feas)} feasible, {sum(r.get('runs', 0) for r in search)} runs")
        print("top 5 of the search:")
        for r in feas[:5]:
            print("  " + line(r))
        print("all other evaluations (re-checks):")
        for r in recs:
            if r not in search:
                print("  " + line(r))


if __name__ == "__main__":
    main(sys.argv[1:])
