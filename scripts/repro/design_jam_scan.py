"""Where does the slider jam? FS runs of the prototype with a tighter opening R/h at a few
operating points of the design band (the R/h constraint of the design search). Prints one line per run:
R/h, f_ex, a_ex, behaviour, slider travel s_max - s_min, final amplitude.

    python scripts/repro/design_jam_scan.py [--t-end 40] [--threads 1]
"""

import argparse
import time

from beamslider import Parameters
from beamslider.maps import operating_map


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-end", type=float, default=40.0)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--gap-ratios", type=float, nargs="+", default=[1.002, 1.005, 1.01, 1.02, 1.03])
    a = ap.parse_args()
    t0 = time.perf_counter()
    print(f"# FS runs of {a.t_end:g} s from s0 = 0.3; travel = s_max - s_min [L]")
    print(f"{'R/h':>6} {'f_ex':>5} {'a_ex':>5} {'behaviour':<24} {'travel':>7} {'A_final/h':>9}")
    for g in a.gap_ratios:
        t = operating_map(Parameters(gap_ratio=g), f_ex=[110.0, 124.0], a_ex=[10.0, 14.0], s0=0.3, t_end=a.t_end,
                          threads=a.threads)
        for i in range(len(t["index"])):
            print(f"{g:>6g} {t['f_ex_hz'][i]:>5g} {t['a_ex_m_s2'][i]:>5g} {t['behaviour'][i]:<24} "
                  f"{t['s_max'][i] - t['s_min'][i]:>7.3f} {t['amplitude_final_h'][i]:>9.3f}")
    print(f"# wall time {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
