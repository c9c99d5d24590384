#!/usr/bin/env python3
"""Regenerate the README's main figure, docs/figures/signature_move.png, with the current code: exactly
what `beamslider simulate --manifold pcs` draws — 124 Hz, 14 m/s², s0 = 0.3, 60 s, the PCS manifold
with 100 periods per s-step. Needs the package with the plot extra (pip install ".[plot]").

    python3 scripts/tooling/make_readme_figures.py            # about 10-20 s
"""

from __future__ import annotations

import sys
from pathlib import Path

import beamslider
from beamslider.plotting import plot_operating_point

ROOT = Path(__file__).resolve().parents[2]


def main() -> int:
    r = beamslider.simulate(f_ex=124, a_ex=14, s0=0.3, t_end=60, record_every=10, progress=True)
    m = beamslider.super_slow_manifold(f_ex=124, a_ex=14, periods=100, record=25, progress=True)
    target = ROOT / "docs" / "figures" / "signature_move.png"
    plot_operating_point(r, manifold=m, window=1.0, path=target)
    print(f"wrote {target} (status {r.status}, final s = {r.s[-1]:.4f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
