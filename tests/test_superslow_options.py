"""Layer-(a) options, docs/model.md §6.4: multi-harmonic HB and static sag. Fast."""

import json

import numpy as np
import pytest

from beamslider import Parameters
from beamslider.superslow import hb_manifold


def test_harmonics_one_is_the_default_and_has_no_extra_orders():
    m = hb_manifold(f_ex=124.0, a_ex=14.0, n_modes=2)
    assert m.harmonic_orders == () and m.high.harmonic_amplitude.size == 0 and not m.static_sag


def test_multi_harmonic_orders_small_and_converging():
    ms = {h: hb_manifold(f_ex=124.0, a_ex=14.0, n_modes=5, harmonics=h, sample=True) for h in (1, 3, 5)}
    m5 = ms[5]
    assert m5.harmonic_orders == (1, 3, 5)
    ha = m5.high.harmonic_amplitude
    assert ha.shape == (len(m5.high), 3)
    np.testing.assert_allclose(ha[:, 0], m5.high.amplitude, rtol=1e-12)
    r3, r5 = ha[:, 1] / ha[:, 0], ha[:, 2] / ha[:, 0]
    assert 0 < r3.max() < 0.05 and r5.max() < 0.2 * r3.max()
    sel = m5.s_grid <= 0.3
    d13 = np.nanmax(np.abs(ms[1].high_on_grid[sel] - ms[3].high_on_grid[sel]))
    d35 = np.nanmax(np.abs(ms[3].high_on_grid[sel] - ms[5].high_on_grid[sel]))
    assert d35 < 0.2 * d13


def test_harmonics_one_through_aft_equals_single_term():
    # The static sag with g = 0 runs the AFT solver with orders {1, 0} and Q0 = 0.
    p = Parameters(gravity_m_s2=0.0)
    a = hb_manifold(p, f_ex=124.0, a_ex=14.0, n_modes=5, sample=True)
    b = hb_manifold(p, f_ex=124.0, a_ex=14.0, n_modes=5, sample=True, static_sag=True)
    assert b.harmonic_orders == (1, 0)
    assert abs(a.s_up - b.s_up) <= 1e-10
    np.testing.assert_allclose(a.high_on_grid, b.high_on_grid, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(a.low_on_grid, b.low_on_grid, rtol=1e-10, atol=1e-12)


def test_static_sag_is_down_and_small():
    m = hb_manifold(f_ex=124.0, a_ex=14.0, n_modes=5, static_sag=True)
    assert m.static_sag and m.harmonic_orders == (1, 0)
    w0 = m.high.harmonic_amplitude[:, 1]
    assert np.all(w0 < 0) and np.all(np.abs(w0) < 0.1)


def test_cli_options(tmp_path, capsys):
    from beamslider.cli import main

    assert main(["hb-manifold", "--f-ex", "124", "--a-ex", "14", "--n-modes", "2", "--harmonics", "3",
                 "--static-sag", "--out", str(tmp_path)]) == 0
    stem = "hb_manifold_124Hz_14ms2_N2_H3_sag"
    meta = json.loads((tmp_path / f"{stem}.json").read_text())
    assert meta["harmonic_orders"] == [1, 2, 3, 0] and meta["static_sag"] is True
    assert "H=3 +sag" in capsys.readouterr().out
    with pytest.raises(SystemExit) as e:
        main(["hb-manifold", "--f-ex", "124", "--a-ex", "14", "--harmonics", "2", "--out", str(tmp_path)])
    assert e.value.code == 2
    assert "--harmonics" in capsys.readouterr().err
