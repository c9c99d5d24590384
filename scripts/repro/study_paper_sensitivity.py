#!/usr/bin/env python3
"""The paper's sensitivity statements (section 5.5) as uncertainty studies at (124 Hz, 14 m/s², s0 = 0.3),
120-s free-slider runs:

1. natural frequency: grid study of ``natural_frequency_factor`` c ∈ {0.95, 0.975, 1, 1.025, 1.05}
   (E and k_r scaled by c², k_t adjusted to hold b*; see ``beamslider.study``) at μ = 0.2:
   the shift of the turning point s (paper: ±0.013 for ±5 %);
2. friction: grid study of μ ∈ {0.20, 0.22, 0.24, 0.26, 0.28, 0.31} (measured range [0.22, 0.31]):
   the final slider position;
3. both uncertain (μ ~ U[0.22, 0.31], c ~ U[0.95, 1.05]): Sobol' indices from a Saltelli design;
4. a small map (f_ex 118/124/130 Hz × a_ex 6/10/14 m/s², the same two uncertain inputs, 8 Latin
   hypercube samples): the most probable behaviour and its probability;
5. the paper's own check: the PCS super-slow manifold (100 periods per s) for c = 0.95, 1, 1.05 —
   the turning point of its low branch (where the downward sweep jumps up) and the largest amplitude.

Writes DIR/<study>/{study.jsonl,summary.*,*.png} (resumable: re-run the script to continue) and
DIR/study_sensitivity.txt. Usage: python3 scripts/repro/study_paper_sensitivity.py [--out docs/study] [-j N]
[--scheduler ADDRESS]
"""

import argparse
import time
from pathlib import Path

import numpy as np

from beamslider import Parameters
from beamslider.study import StudyConfig, Uncertain, run_study, write_outputs

MU = Uncertain("friction_coefficient", "uniform", low=0.22, high=0.31)
FREQ = Uncertain("natural_frequency_factor", "uniform", low=0.95, high=1.05)


def studies():
    p = Parameters()
    return {
        "frequency": StudyConfig(uncertain=[Uncertain("natural_frequency_factor", "uniform", low=0.95, high=1.05,
                                                      levels=[0.95, 0.975, 1.0, 1.025, 1.05])],
                                 method="grid", params=p),
        "friction": StudyConfig(uncertain=[Uncertain("friction_coefficient", "uniform", low=0.2, high=0.31,
                                                     levels=[0.20, 0.22, 0.24, 0.26, 0.28, 0.31])],
                                method="grid", params=p),
        "sobol": StudyConfig(uncertain=[MU, FREQ], method="saltelli", samples=64, seed=2023, params=p),
        "map": StudyConfig(uncertain=[MU, FREQ], method="lhs", samples=8, seed=7, params=p,
                           f_ex_hz=[118.0, 124.0, 130.0], a_ex_m_s2=[6.0, 10.0, 14.0]),
    }


def manifold_turning_points() -> str:
    """Turning point of the low branch of the PCS manifold (downward sweep) for c = 0.95, 1, 1.05."""
    from beamslider import super_slow_manifold
    from beamslider.study import apply_sample

    lines = ["PCS manifold (124 Hz, 14 m/s^2, 100 periods per s): low-branch turning point and largest amplitude",
             "factor  turning s  d turning s  max w(4L/7)/h  d max"]
    ref = None
    for c in (0.95, 1.0, 1.05):
        p = apply_sample(Parameters(), {"natural_frequency_factor": c})
        m = super_slow_manifold(p, f_ex=124.0, a_ex=14.0)
        a = m.down_amplitude / p.thickness_m
        k = next((i for i in range(1, len(a)) if a[i] > 2.0 * a[i - 1] and a[i] - a[i - 1] > 0.1), None)
        turn = float(m.down_s[k - 1]) if k is not None else float("nan")
        amax = float(max(a.max(), (m.up_amplitude / p.thickness_m).max()))
        if c == 1.0:
            ref = (turn, amax)
        lines.append((c, turn, amax))
    out = lines[:2]
    for c, turn, amax in lines[2:]:
        out.append(f"{c:6.3f}  {turn:.4f}     {turn - ref[0]:+.4f}       {amax:.3f}          {amax - ref[1]:+.3f}")
    return "\n".join(out) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/results/study")
    ap.add_argument("-j", "--threads", type=int)
    ap.add_argument("--scheduler")
    ap.add_argument("--only", nargs="*", help="run only these studies")
    args = ap.parse_args()
    out = Path(args.out)
    report = []
    for name, cfg in studies().items():
        if args.only and name not in args.only:
            continue
        t0 = time.perf_counter()
        res = run_study(cfg, out=out / name, resume=True, threads=args.threads, scheduler=args.scheduler,
                        progress=True)
        wall = time.perf_counter() - t0
        write_outputs(res, out / name)
        report.append(f"== {name}: {len(res.table['index'])} runs x {cfg.duration_s:g} s, {wall:.0f} s wall "
                      f"(resumed points are not re-run)\n" + res.text())
        if name == "frequency":
            t = res.table
            c = t["param_natural_frequency_factor"]
            f1 = [Parameters(**{**Parameters().to_dict(), **__import__("beamslider.study", fromlist=["detune"]).detune(Parameters(), x)}).natural_frequencies_hz()[0] for x in sorted(set(c))]
            nominal = t["turn_s"][c == 1.0][0]
            lines = ["factor  f1 [Hz]   turn_s    d turn_s   s_final   amplitude_final_h  behaviour"]
            for x, f in zip(sorted(set(c)), f1):
                k = np.flatnonzero(c == x)[0]
                lines.append(f"{x:6.3f}  {f:8.3f}  {t['turn_s'][k]:.4f}   {t['turn_s'][k] - nominal:+.4f}    "
                             f"{t['s_final'][k]:.4f}    {t['amplitude_final_h'][k]:.3f}          {t['behaviour'][k]}")
            report.append("\n".join(lines) + "\n")
        print(report[-1], flush=True)
    if not args.only or "manifold" in args.only:
        report.append(manifold_turning_points())
        print(report[-1], flush=True)
    if not args.only:
        (out / "study_sensitivity.txt").write_text("\n".join(report), encoding="utf-8")
        print(f"wrote {out / 'study_sensitivity.txt'}")


if __name__ == "__main__":
    main()
