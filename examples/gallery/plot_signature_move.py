"""
The signature move
==================

The paper's signature move at 124 Hz, 14 m/s² from s₀ = 0.3: the slider first drifts towards the
clamping on the low branch of the super-slow manifold, jumps up to the high branch and travels back
towards the centre. 30 s of physical time take about half a second.
"""

import beamslider
from beamslider.plotting import plot_operating_point

r = beamslider.simulate(f_ex=124, a_ex=14, s0=0.3, t_end=30)
print(r.status, f"final s = {r.s[-1]:.3f}")

# The harmonic-balance manifold (milliseconds) over panel (c).
m = beamslider.hb_manifold(f_ex=124, a_ex=14)
fig = plot_operating_point(r, manifold=m)
