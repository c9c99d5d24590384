"""Where the predictor's design search leaves what FS confirms (docs/model.md §6.5, docs/validation/design_law.md).

    python scripts/repro/design_law_edge.py --search DIR [--bins 1.03 1.04 1.05 1.06 1.08 1.10]
        [--config docs/results/design_law/search.toml] [--work validation-out/design_law_edge]
        [--out docs/results/design_law]

DIR is a design run of the predictor (``beamslider design`` with ``evaluator = "predictor"``: its
``design.jsonl``). For each clearance bin [g, g + 0.01) of R/h, the design the predictor scored
best in that bin is run in full simulation at the nominal parameters over the search's band
(the configuration's a_ex levels, f_ex grid, s0 and t_end; FS maps resumable under --work), and
its FS adaption bandwidth is set beside the predictor's nominal bandwidth and robust score.
Writes edge.txt under --out.
"""

from __future__ import annotations

import argparse
import json
import warnings
from pathlib import Path

import numpy as np

from beamslider.design.config import read_config
from beamslider.design.objectives import adaption_bandwidth
from beamslider.maps import operating_map
from beamslider.superslow import predicted_map
from beamslider.superslow import default_law

ROOT = Path(__file__).resolve().parents[2]


def bands(rows, f_ex, a_ex, a_min_h):
    """Adaption bandwidth [Hz] per a_ex level of rows keyed by (f_ex, a_ex)."""
    return [adaption_bandwidth(f_ex, [rows[(f, a)]["behaviour"] for f in f_ex],
                               [np.nan if rows[(f, a)].get("amplitude_final_h") is None else rows[(f, a)]["amplitude_final_h"]
                                for f in f_ex], a_min_h=a_min_h) for a in a_ex]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--search", required=True, help="folder of a predictor design run (design.jsonl)")
    ap.add_argument("--config", default=str(ROOT / "docs" / "results" / "design_law" / "search.toml"))
    ap.add_argument("--bins", type=float, nargs="+", default=[1.03, 1.04, 1.05, 1.06, 1.08, 1.10])
    ap.add_argument("--work", default="validation-out/design_law_edge")
    ap.add_argument("--out", default=str(ROOT / "docs" / "results" / "design_law"))
    ap.add_argument("--threads", type=int, default=None)
    a = ap.parse_args()
    cfg = read_config(a.config)
    f_ex, a_ex, s0 = list(cfg.f_ex_hz()), list(cfg.a_ex_m_s2), cfg.s0[0]
    rows = [json.loads(l) for l in (Path(a.search) / "design.jsonl").read_text().splitlines()[1:] if l.strip()]
    pr = [r for r in rows if r.get("evaluator") == "predictor" and r.get("score") is not None]
    if not pr:
        raise SystemExit(f"no scored predictor designs in {a.search}/design.jsonl")
    law = default_law()
    lines = [f"# the predictor's best design per clearance bin of {a.search} and its FS map at the nominal parameters "
             f"(a_ex {'/'.join(f'{v:g}' for v in a_ex)} m/s^2, f_ex {f_ex[0]:g}-{f_ex[-1]:g} Hz, s0 {s0:g}, {cfg.t_end_s:g} s)",
             "# python scripts/repro/design_law_edge.py --search DIR",
             f"{'R/h bin':>8} | {'design (' + ', '.join(cfg.names) + ')':<44} | predicted robust score | "
             "predicted nominal band per level [Hz] | FS nominal band per level [Hz], mean"]
    for g in a.bins:
        inbin = [r for r in pr if g <= r["variables"]["gap_ratio"] < g + 0.01]
        if not inbin:
            lines.append(f"{g:8.2f} | no design in this bin")
            continue
        best = max(inbin, key=lambda r: r["score"])
        p = cfg.design_params(best["x"])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            pm = {(r["f_ex_hz"], r["a_ex_m_s2"]): r for r in predicted_map(p, drift=law, f_ex=f_ex, a_ex=a_ex, s0=s0,
                                                                          t_end=cfg.t_end_s)}
        d = Path(a.work) / f"gap_{g:.2f}"
        t = operating_map(p, f_ex=f_ex, a_ex=a_ex, s0=s0, t_end=cfg.t_end_s, out=d, resume=(d / "map.jsonl").exists(),
                          threads=a.threads)
        fs = {(t["f_ex_hz"][i], t["a_ex_m_s2"][i]): {"behaviour": t["behaviour"][i],
                                                     "amplitude_final_h": t["amplitude_final_h"][i]}
              for i in range(len(t["index"]))}
        bp, bf = bands(pm, f_ex, a_ex, cfg.a_min_h), bands(fs, f_ex, a_ex, cfg.a_min_h)
        lines.append(f"{g:8.2f} | {', '.join(f'{v:.4g}' for v in best['x']):<44} | {best['score']:22.2f} | "
                     f"{' / '.join(f'{v:.1f}' for v in bp):>37} | {' / '.join(f'{v:.1f}' for v in bf)}, {np.mean(bf):.1f}")
        print(lines[-1], flush=True)
    text = "\n".join(lines) + "\n"
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "edge.txt").write_text(text)
    print(text, end="")


if __name__ == "__main__":
    main()
