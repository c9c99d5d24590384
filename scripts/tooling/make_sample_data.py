#!/usr/bin/env python3
"""Make the sample measured file of examples/data/ with the project's synthesiser
(``beamslider.discover.synthesize_slider_runs``): a free-slider run of a "truth" model whose
friction coefficient differs from the default model's, in the published format (time [s], beam
velocity at 4L/7 [m/s], slider position s [-], every 1e-4 s, tab-separated), with white noise on
the velocity and on s, gzip-compressed. Deterministic (fixed seed).

    python3 scripts/tooling/make_sample_data.py       # writes examples/data/Time_VelBeam_..._RelSliderPosStart03.txt.gz
"""

from __future__ import annotations

import gzip
import shutil
import sys
import tempfile
from pathlib import Path

import beamslider
from beamslider.discover import synthesize_slider_runs

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "examples" / "data"

TRUTH = beamslider.Parameters(friction_coefficient=0.26)  # the hidden parameter (default model: 0.2)
POINT = (124.0, 14.0, 0.3)                                # f_ex [Hz], a_ex [m/s²], s0
DURATION_S = 20.0
SEED = 2883


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        (path,) = synthesize_slider_runs(TRUTH, operating_points=[POINT], duration_s=DURATION_S, out_dir=tmp,
                                         noise_s=0.001, noise_velocity_m_s=0.002, seed=SEED)
        OUT.mkdir(parents=True, exist_ok=True)
        target = OUT / (path.name + ".gz")
        with open(path, "rb") as src, gzip.GzipFile(target, "wb", compresslevel=9, mtime=0) as dst:
            shutil.copyfileobj(src, dst)
    m = beamslider.read_measurement(target)
    print(f"wrote {target} ({target.stat().st_size / 1e6:.2f} MB, {len(m.t)} samples, "
          f"t = {m.t[0]:g} .. {m.t[-1]:g} s, s: {m.s[0]:.3f} -> {m.s[-1]:.3f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
