"""
The super-slow manifold by harmonic balance
===========================================

The amplitude of the beam with the slider rigidly attached at s, for three excitation levels at
124 Hz: high, low and unstable branches, and the folds where the slider jumps (milliseconds each).
"""

import matplotlib.pyplot as plt
import beamslider

fig, ax = plt.subplots(figsize=(6, 4))
for a_ex, colour in ((8, "C0"), (11, "C1"), (14, "C2")):
    m = beamslider.hb_manifold(f_ex=124, a_ex=a_ex)
    for branch, style in ((m.high, "-"), (m.low, "-"), (m.middle, ":")):
        if branch is not None and len(branch.s):
            ax.plot(branch.s, branch.amplitude, style, color=colour)
    ax.plot([], [], color=colour, label=f"{a_ex} m/s², jump-up at s = {m.s_up:.3f}" if m.s_up else f"{a_ex} m/s²")
ax.set_xlabel("slider position s")
ax.set_ylabel("amplitude |w(4L/7)| / h")
ax.set_xlim(0, 0.5)
ax.legend()
fig.tight_layout()
