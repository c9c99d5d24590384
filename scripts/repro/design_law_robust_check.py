"""The predictor's robust scores against FS, sample by sample (docs/model.md §6.5).

    python scripts/repro/design_law_robust_check.py [--checks docs/results/design_law/search/fs_checks.json]
        [--heldout validation-out/design_law] [--vote 3,5,8] [--out docs/results/design_law]

The design search's FS re-checks (docs/results/design_law/search/fs_checks.json: the prototype,
the predictor's five best and the FS-only search's best, each over the search's 16 samples of
friction and natural frequency, 120 s) are predicted sample by sample, (a) with the built-in design
law (its blend of the k nearest training designs' V, docs/model.md §6.5) and (b) with a vote: the
k nearest training designs' own laws each predict the map and every point takes the behaviour of
the largest summed weight (1/d, the blend's weights), its amplitude the weighted mean over the laws
that voted for it. The held-out designs of validate_design_law.py (their FS maps under --heldout,
if present) are scored the same way. Also the predicted band of the FS-only search's best and of
the prototype against the friction coefficient. Nothing is fitted here; writes robust_check.txt.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from validate_design_law import A, ADAPTING, F, _label, _rows, bands, heldout_designs  # noqa: E402

from beamslider.design import read_config  # noqa: E402
from beamslider.superslow import predicted_map  # noqa: E402
from beamslider.study.sampling import apply_sample  # noqa: E402
from beamslider.superslow import default_law, design_params  # noqa: E402
from beamslider.superslow.design_law import design_coordinates  # noqa: E402

DL = default_law()
U = DL.unit


def _map(p, law):
    return {(q["f_ex_hz"], q["a_ex_m_s2"]): q for q in predicted_map(p, drift=law, f_ex=F, a_ex=A, s0=0.3, t_end=120.0)}


def vote_map(p, k: int):
    """The vote of the k nearest training designs' own laws (module docstring)."""
    c = design_coordinates(p)
    u = np.array([b.unit(c[b.name]) for b in DL.box])
    d = np.sqrt((((U - u) / DL.scales) ** 2).sum(axis=1))
    o = np.argsort(d, kind="stable")[:k]
    w = 1.0 / np.maximum(d[o], 1e-9)
    maps = [_map(p, DL.laws[j]) for j in o]
    out = {}
    for key in maps[0]:
        tally: dict = {}
        for m, wi in zip(maps, w):
            tally[_label(m[key])] = tally.get(_label(m[key]), 0.0) + wi
        lab = max(tally, key=tally.get)
        amps = [((m[key].get("amplitude_final_h") or 0.0), wi) for m, wi in zip(maps, w) if _label(m[key]) == lab]
        out[key] = {"behaviour": lab, "amplitude_final_h": sum(a * wi for a, wi in amps) / sum(wi for _, wi in amps)}
    return out


def predictor(how: str):
    if how == "blend":
        return lambda p: _map(p, DL)
    k = int(how.split("=")[1])
    return lambda p: vote_map(p, k)


def load_checks(path: Path, out=None):
    """FS records of a search: from fs_checks.json, or extracted from its design.jsonl (bandwidths per
    sample only; written to ``out`` when given)."""
    if path.suffix != ".jsonl":
        return json.loads(path.read_text())["records"]
    from beamslider.design import read_design_file

    _header, records, _n = read_design_file(path)
    recs = [{"mode": r["mode"], "t_end_s": r["t_end_s"], "x": r["x"], "variables": r["variables"],
             "bandwidth_hz": r["bandwidth_hz"],
             "samples": [{"values": s["values"], "bandwidth_hz": s["bandwidth_hz"]} for s in r.get("samples", [])]}
            for r in records if r["evaluator"] == "fs"]
    if out:
        Path(out).write_text(json.dumps({"what": "FS re-checks of the predictor search of docs/results/design_law/search.toml "
                                                 "(120 s; each sample's bandwidth [Hz], mean of 10 and 14 m/s^2), extracted "
                                                 "from its design.jsonl by scripts/repro/design_law_robust_check.py",
                                         "records": recs}) + "\n")
    return recs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--checks", default=str(ROOT / "docs/results/design_law/search/fs_checks.json"),
                    help="the FS re-checks: fs_checks.json, or a search's design.jsonl (its FS records are then "
                         "written to --checks-out)")
    ap.add_argument("--checks-out", help="with a design.jsonl: where to write the compact fs_checks.json")
    ap.add_argument("--heldout", default="validation-out/design_law", help="FS maps of the held-out designs (design_<i>/map.jsonl)")
    ap.add_argument("--vote", default="3,5,8", help="k of the votes, comma-separated")
    ap.add_argument("--out", default=str(ROOT / "docs/results/design_law"))
    a = ap.parse_args()
    cfg = read_config(ROOT / "docs/results/design_law/search.toml")
    recs = [r for r in load_checks(Path(a.checks), a.checks_out) if r["mode"] == "robust"]
    ho = [(x, Path(a.heldout) / f"design_{i}" / "map.jsonl") for i, x in enumerate(heldout_designs())]
    ho = [(x, _rows(f)) for x, f in ho if f.exists()]
    hows = ["blend"] + [f"vote k={k}" for k in a.vote.split(",") if k.strip()]
    lines = ["# the predictor's robust scores against FS sample by sample: the design search's FS re-checks (16 samples of friction",
             "# 0.22-0.31 and natural frequency x0.95-1.05, 120 s; band = mean of the adaption bandwidths at 10 and 14 m/s^2, 100-130 Hz)",
             "# python scripts/repro/design_law_robust_check.py",
             "designs (R/h, slider mass [g], B [mm], com offset [mm]): " + "; ".join(
                 f"{r['x'][0]:.4f}, {1e3 * r['x'][1]:.1f}, {1e3 * r['x'][2]:.1f}, {1e3 * r['x'][3]:.2f}" for r in recs)]
    for how in hows:
        pred = predictor(how)
        err, rob = [], []
        for r in recs:
            x = np.array(r["x"])
            pb = [float(np.mean(bands(pred(apply_sample(cfg.design_params(x), s["values"]))))) for s in r["samples"]]
            fb = [s["bandwidth_hz"] for s in r["samples"]]
            err += list(np.array(pb) - np.array(fb))
            rob.append((np.mean(pb), np.mean(fb)))
        e = np.array(err)
        line = (f"{how:>10}: per sample ({len(e)}): bias {e.mean():+.2f} Hz, RMS {np.sqrt((e ** 2).mean()):.2f} Hz; "
                "robust mean predicted/FS: " + ", ".join(f"{p:.1f}/{f:.1f}" for p, f in rob))
        if ho:
            within = agree = coarse = n = 0
            for x, fs in ho:
                pr = pred(design_params(x))
                within += abs(np.mean(bands(fs)) - np.mean(bands(pr))) <= 3.0
                agree += sum(_label(fs[q]) == _label(pr[q]) for q in fs)
                coarse += sum((_label(fs[q]) in ADAPTING) == (_label(pr[q]) in ADAPTING) for q in fs)
                n += len(fs)
            line += (f"; held-out: within 3 Hz {within}/{len(ho)}, behaviour agreement {agree}/{n} = {100 * agree / n:.0f} %, "
                     f"adapting or not {100 * coarse / n:.0f} %")
        lines.append(line)
        print(line, flush=True)
    lines.append("predicted band [Hz] against the friction coefficient at the nominal natural frequency (blend | vote k=8):")
    named = [("prototype", cfg.prototype_x())] + [(f"reference {n}", cfg.reference_x(v)) for n, v in cfg.reference.items()]
    for name, x in named:
        row = []
        for mu in (0.22, 0.24, 0.25, 0.26, 0.28, 0.31):
            p = apply_sample(cfg.design_params(x), {"friction_coefficient": mu})
            row.append(f"μ {mu:.2f}: {np.mean(bands(_map(p, DL))):.1f} | {np.mean(bands(vote_map(p, 8))):.1f}")
        lines.append(f"  {name} ({x[0]:.4f}, {1e3 * x[1]:.1f} g): " + "; ".join(row))
    text = "\n".join(lines) + "\n"
    Path(a.out).mkdir(parents=True, exist_ok=True)
    (Path(a.out) / "robust_check.txt").write_text(text)
    print(text, end="")


if __name__ == "__main__":
    main()
