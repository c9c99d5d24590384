"""beamslider.envelope (docs/model.md §7): |Hilbert| then a moving average."""

import numpy as np
import pytest

from beamslider import envelope


def test_envelope_of_amplitude_modulated_signal():
    dt = 1e-4
    t = np.arange(0, 20, dt)
    a = 1.0 + 0.5 * np.sin(2 * np.pi * 0.05 * t)  # slow modulation (period 20 s)
    x = a * np.cos(2 * np.pi * 124 * t)
    e = envelope(t, x, window=0.2)
    inner = slice(int(1 / dt), int(19 / dt))
    assert np.max(np.abs(e[inner] - a[inner])) < 2e-3


def test_window_smooths_fast_modulation():
    dt = 1e-4
    t = np.arange(0, 10, dt)
    x = (1.0 + 0.3 * np.cos(2 * np.pi * 5 * t)) * np.sin(2 * np.pi * 200 * t)
    e = envelope(t, x, window=1.0)  # whole modulation periods averaged away
    assert np.max(np.abs(e[int(1 / dt):int(9 / dt)] - 1.0)) < 2e-3
    raw = envelope(t, x, window=dt)
    assert raw.max() == pytest.approx(1.3, abs=5e-3)


def test_constant_amplitude_sine_and_lists():
    t = np.arange(0, 2, 1e-3).tolist()
    x = (2.5 * np.sin(2 * np.pi * 50 * np.asarray(t))).tolist()
    e = envelope(t, x, window=0.1)
    assert np.allclose(e[200:-200], 2.5, atol=1e-2)


@pytest.mark.parametrize(
    "t,w,window,match",
    [
        (np.arange(10.0), np.zeros(9), 1.0, "same length"),
        (np.array([0.0, 1.0, 3.0, 4.0]), np.zeros(4), 1.0, "uniformly"),
        (np.array([0.0]), np.zeros(1), 1.0, "two samples"),
        (np.arange(10.0), np.zeros(10), 0.0, "window"),
        (np.arange(10.0), np.zeros(10), float("nan"), "window"),
    ],
)
def test_bad_envelope_inputs(t, w, window, match):
    with pytest.raises(ValueError, match=match):
        envelope(t, w, window=window)
