"""Long runs of the behaviours of docs/model.md §8 (slow: deselected by default, run with ``-m slow``)."""

import numpy as np
import pytest

import beamslider

pytestmark = pytest.mark.slow


def test_signature_move_124hz_14ms2():
    """Low vibration, s moves towards the clamping, the amplitude jumps up, s turns back."""
    r = beamslider.simulate(f_ex=124, a_ex=14, s0=0.3, t_end=60.0)
    env = r.envelope() / r.params.thickness_m
    i_min = int(np.argmin(r.s))
    assert r.s[i_min] < 0.29 and r.t[i_min] > 1.0
    assert r.s[-1] > r.s[i_min] + 0.03
    assert env[r.t < 1.0].mean() < 0.3 and env[-1] > 0.8


def test_self_damping_124hz_6ms2():
    """s keeps moving towards the clamping, the vibration stays low."""
    r = beamslider.simulate(f_ex=124, a_ex=6, s0=0.3, t_end=60.0)
    env = r.envelope() / r.params.thickness_m
    assert r.s[-1] < 0.28
    assert env[-1] < 0.3
