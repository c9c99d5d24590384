"""Sobol' indices of the adaption bandwidth over the design box, on the predictor (docs/model.md §6.5).

    python scripts/repro/design_law_sobol.py [--n 4096] [--seed 0] [--workers 2] [--out docs/results/design_law]

Inputs: the nine coordinates of the design box (uniform in the box's unit coordinates; the damping
factor on a log scale). Output: the adaption bandwidth [Hz] of the design search's band (mean of
a_ex 10 and 14 m/s², f_ex 100–130 Hz step 2, s0 0.3, 120 s; a_min 0.3 h) predicted with the built-in
design law. A Saltelli design of N base samples (N (D + 2) designs), first-order and total
indices with bootstrap 95 % intervals (beamslider.study.statistics.sobol_indices, the estimators
of SALib). Designs outside what the law covers (the jam zone R/h < 1.03) are kept, and counted.
Writes sobol.txt and sobol.json; the predictions are cached per chunk of 256 designs under --work
(an interrupted run resumes).
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
F = [100.0 + 2 * i for i in range(16)]
A = [10.0, 14.0]


def _band(u_rows):
    from beamslider.design.objectives import adaption_bandwidth
    from beamslider.superslow import predicted_map
    from beamslider.superslow import DESIGN_BOX, default_law, design_params

    law = default_law()
    out = []
    for u in u_rows:
        x = {c.name: c.value(float(ui)) for c, ui in zip(DESIGN_BOX, u)}
        p = design_params(x)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rows = predicted_map(p, drift=law, f_ex=F, a_ex=A, s0=0.3, t_end=120.0, threads=1)
        by = {(r["f_ex_hz"], r["a_ex_m_s2"]): r for r in rows}
        bw = []
        for a in A:
            beh = [by[(f, a)]["behaviour"] for f in F]
            amp = [np.nan if by[(f, a)].get("amplitude_final_h") is None else by[(f, a)]["amplitude_final_h"] for f in F]
            bw.append(adaption_bandwidth(F, beh, amp, a_min_h=0.3))
        out.append((float(np.mean(bw)), bool(law.outside(p))))
    return out


def main() -> None:
    from beamslider.study.config import _saltelli_matrices
    from beamslider.study.statistics import sobol_indices
    from beamslider.superslow import DESIGN_BOX

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=4096)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--work", default="validation-out/design_law_sobol")
    ap.add_argument("--out", default=str(ROOT / "docs" / "results" / "design_law"))
    a = ap.parse_args()
    d = len(DESIGN_BOX)
    ua, ub = _saltelli_matrices(d, a.n, a.seed)
    rows = [ua, ub] + [np.where(np.arange(d) == i, ub, ua) for i in range(d)]
    u = np.concatenate(rows)
    work = Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    # One file per chunk of designs, written as each chunk finishes: an interrupted run resumes
    # where it stopped (a chunk's file is written to a temporary name, then renamed).
    cdir = work / f"sobol_y_n{a.n}_seed{a.seed}"
    cdir.mkdir(exist_ok=True)
    chunks = np.array_split(np.arange(len(u)), max(1, -(-len(u) // 256)))
    todo = [k for k in range(len(chunks)) if not (cdir / f"{k:05d}.npy").exists()]
    t0 = time.perf_counter()
    if todo:
        from tqdm import tqdm

        with ProcessPoolExecutor(max_workers=a.workers) as ex:
            futs = {ex.submit(_band, u[chunks[k]]): k for k in todo}
            for fut in tqdm(as_completed(futs), total=len(futs), desc="designs (chunks of 256)"):
                k = futs[fut]
                tmp = cdir / f"{k:05d}.tmp.npy"
                np.save(tmp, np.array(fut.result(), dtype=float))
                tmp.replace(cdir / f"{k:05d}.npy")
    res = np.concatenate([np.load(cdir / f"{k:05d}.npy") for k in range(len(chunks))])
    wall = time.perf_counter() - t0
    y, extrap = res[:, 0], res[:, 1] > 0.5
    si = sobol_indices(y, a.n, d, bootstrap=1000, seed=a.seed)
    names = [c.name for c in DESIGN_BOX]
    lines = [f"# Sobol' indices of the predicted adaption bandwidth over the design box: N = {a.n} base samples, "
             f"D = {d}, {len(y)} designs ({int(extrap.sum())} outside what the law covers, kept), "
             f"{wall:.0f} s wall on {a.workers} processes",
             "# python scripts/repro/design_law_sobol.py" + (f" --n {a.n}" if a.n != 4096 else ""),
             f"bandwidth [Hz]: mean {np.mean(y):.2f}, std {np.std(y):.2f}, min {np.min(y):.1f}, max {np.max(y):.1f}",
             f"{'coordinate':>26}  {'S1':>7} {'±95%':>6}  {'ST':>7} {'±95%':>6}"]
    for i, n in enumerate(names):
        lines.append(f"{n:>26}  {si['S1'][i]:+7.3f} {si['S1_conf'][i]:6.3f}  {si['ST'][i]:+7.3f} {si['ST_conf'][i]:6.3f}")
    text = "\n".join(lines) + "\n"
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "sobol.txt").write_text(text)
    (out / "sobol.json").write_text(json.dumps({
        "n": a.n, "d": d, "names": names, "seed": a.seed, "wall_s": wall, "bandwidth_mean_hz": float(np.mean(y)),
        "outside": int(extrap.sum()), **{k: [float(v) for v in si[k]] for k in ("S1", "ST", "S1_conf", "ST_conf")}}, indent=1))
    print(text, end="")


if __name__ == "__main__":
    main()
