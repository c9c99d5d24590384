"""beamslider.super_slow_manifold (docs/model.md §6) on a coarse grid."""

import numpy as np
import pytest

from beamslider import Parameters, manifold_grid, super_slow_manifold


def test_default_grid_is_the_physical_reference_grid():
    g = manifold_grid()
    assert g[0] == pytest.approx(0.04) and g[-1] == pytest.approx(0.5)
    assert np.allclose(np.diff(g), 0.005)


def test_coarse_manifold_branches():
    m = super_slow_manifold(f_ex=124, a_ex=14, s=[0.2, 0.3, 0.4], periods=20, record=5)
    np.testing.assert_allclose(m.up_s, [0.2, 0.3, 0.4])
    np.testing.assert_allclose(m.down_s, [0.4, 0.3, 0.2])
    for a in (m.up_amplitude, m.down_amplitude):
        assert a.shape == (3,) and np.all(np.isfinite(a)) and np.all(a > 0) and np.all(a < 5e-3)
    steps_per_point = round(20 / 124 / 2e-5)
    assert m.counters["steps"] == pytest.approx(6 * steps_per_point, abs=12)


def test_manifold_matches_pcs_simulation_at_one_point():
    """The first upward point is a PCS run from the PCS initial state."""
    import scipy.signal

    from beamslider import simulate

    m = super_slow_manifold(f_ex=124, a_ex=14, s=[0.25], periods=10, record=5)
    n_total, n_rec = round(10 / 124 / 2e-5), round(5 / 124 / 2e-5)
    r = simulate(f_ex=124, a_ex=14, t_end=n_total * 2e-5, model="pcs", s_pcs=0.25, record_every=1)
    amp = np.mean(np.abs(scipy.signal.hilbert(r.w[-n_rec:])))  # |analytic signal| by an independent FFT
    assert m.up_amplitude[0] == pytest.approx(amp, rel=1e-6)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(s=[]), "s"),
        (dict(s=[0.3, 0.2]), "increasing"),
        (dict(periods=0), "periods"),
        (dict(record=30, periods=20), "record"),
        (dict(f_ex=-1.0), "f_ex"),
    ],
)
def test_bad_manifold_inputs(kwargs, match):
    args = dict(f_ex=124.0, a_ex=14.0, s=[0.3], periods=4, record=2)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        super_slow_manifold(**args)


def test_manifold_progress(capsys):
    super_slow_manifold(Parameters(), f_ex=124, a_ex=14, s=[0.3], periods=4, record=2, progress=True)
    assert "2/2 pts" in capsys.readouterr().err
