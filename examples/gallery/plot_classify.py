"""
Classifying a run
=================

The classifier of the operating maps (docs/classify.md) applied to one run: the behaviour, the
reason, and the features it is based on. Here the relaxation oscillation at 126 Hz, 10 m/s².
"""

import matplotlib.pyplot as plt
import beamslider

r = beamslider.simulate(f_ex=126, a_ex=10, s0=0.3, t_end=60)
c = beamslider.classify_result(r)
print(c.behaviour, "-", c.reason)
amp = beamslider.envelope(r.t, r.w, window=1.0) / beamslider.Parameters().thickness_m

fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(6, 4.5))
ax1.plot(r.t, r.s)
ax1.set_ylabel("s")
ax2.plot(r.t, amp)
ax2.set_ylabel("envelope / h")
ax2.set_xlabel("t [s]")
ax1.set_title(f"{c.behaviour}")
fig.tight_layout()
