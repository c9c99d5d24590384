"""
Model against a measured run
============================

The sample measured file (synthetic, in the published format; its hidden friction coefficient is
0.26) against the default model at the operating point named in the file.
"""

from pathlib import Path

import beamslider
from beamslider.plotting import plot_operating_point

name = "Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt.gz"
here = Path.cwd().resolve()  # the docs build runs the example in examples/gallery/
data = next(d / "examples" / "data" for d in (here, *here.parents) if (d / "examples" / "data" / name).exists())
path = data / name
meas = beamslider.read_measurement(path)
r = beamslider.simulate(f_ex=meas.f_ex, a_ex=meas.a_ex, s0=meas.s0, t_end=float(meas.t[-1]))
print(f"final s: model {r.s[-1]:.3f}, measured {meas.s[-1]:.3f}")
fig = plot_operating_point(r, measurement=meas)
