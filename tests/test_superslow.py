"""beamslider.superslow: the harmonic-balance super-slow manifold (docs/model.md §6.4). Fast."""

import math

import numpy as np
import pytest

import beamslider
from beamslider.params import native
from beamslider import Parameters
from beamslider.superslow import backbone, closed_form_n1, hb_manifold


def test_n1_hb_equals_closed_form():
    m = hb_manifold(f_ex=124, a_ex=14, n_modes=1)
    cf = closed_form_n1(f_ex=124, a_ex=14, s=np.unique(m.up_run.s))
    for s, a in zip(m.up_run.s, m.up_run.amplitude):
        if np.any(np.abs(m.folds_s - s) < 1e-9):
            continue
        roots = cf.roots[np.searchsorted(cf.s, s)]
        assert np.nanmin(np.abs(roots - a) / a) < 1e-10
    assert m.s_up == pytest.approx(cf.s_up, abs=1e-6)
    assert m.s_dn is None and cf.s_dn is None


def test_manifold_fields_units_and_branches():
    m = beamslider.hb_manifold(f_ex=124, a_ex=14)
    assert m.n_modes == 5 and m.harmonics == 1 and not m.warnings
    assert m.s_range[0] == pytest.approx(0.5 * 10e-3 / 0.14) and m.s_range[1] == 0.5
    for b in (m.high, m.low, m.middle):
        assert b.q.shape == (len(b), 5) and b.q.dtype == complex
        assert b.stable.dtype == bool
        assert np.all(np.isfinite(b.amplitude)) and np.all(b.amplitude > 0)
    assert m.high.stable.all() and m.low.stable.all()
    assert m.s_up is not None and 0.1 < m.s_up < 0.45
    assert m.s_dn is None  # docs/model.md §6.4: single-term HB keeps the high branch to the centre
    # High branch above the low branch where both exist; amplitude within the paper's range.
    s = np.linspace(m.s_up + 0.01, 0.5, 10)
    assert np.all(m.high.amplitude_at(s) > m.low.amplitude_at(s))
    assert 0.2 < m.high.amplitude_at([0.5])[0] < 2.0
    assert np.isnan(m.low.amplitude_at([m.s_up - 0.01])[0])
    # Amplitude from Q: Â = |Φ(4L/7)ᵀQ| / h.
    phi47 = np.asarray(beamslider._core.beam_properties(native(Parameters()), [4 / 7])["phi"])[:, 0]
    np.testing.assert_allclose(np.abs(m.high.q @ phi47) / 1e-3, m.high.amplitude, rtol=1e-12)
    # The backbone through a high-branch point beyond resonance is near Ω (damping is small).
    k = int(np.argmin(np.abs(m.high.s - 0.45)))
    om = m.backbone([m.high.amplitude[k]], [m.high.s[k]])[0]
    assert om == pytest.approx(2 * math.pi * 124, rel=0.05)


def test_equivalent_damping_ends_the_high_branch():
    assert hb_manifold(f_ex=124, a_ex=8).s_dn is None
    m = hb_manifold(f_ex=124, a_ex=8, d_eff=0.02)
    assert m.s_dn is not None and m.s_dn < 0.5
    assert m.d_eff == 0.02


def test_backbone_without_slider_is_model_section_9():
    p = Parameters(slider_mass_kg=1e-15, slider_inertia_kg_m2=1e-21, com_offset_m=0.0)
    props = beamslider._core.beam_properties(native(p), [0.5, 4 / 7])
    w, bs = props["omega_rad_s"][0], props["b_star_per_s2"]
    phi_mid, phi47 = props["phi"][0]
    a47 = np.array([0.1, 0.5, 1.0])
    a_tilde = a47 * abs(phi_mid / phi47)
    np.testing.assert_allclose(backbone(p, amplitude=a47, s=0.3) ** 2, w**2 + 0.75 * bs * a_tilde**2, rtol=1e-9)


def test_no_coexistence_and_grid_options():
    m = hb_manifold(f_ex=60, a_ex=14, n_modes=2, s=[0.1, 0.2, 0.5])
    assert m.s_up is None and m.s_dn is None and m.folds_s.size == 0
    assert m.s_range == (0.1, 0.5)
    cf = closed_form_n1(f_ex=60, a_ex=14)
    assert cf.folds.size == 0 and np.all(cf.n_roots == 1) and cf.roots.shape == (201, 3)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(f_ex=-1.0), "f_ex"),
        (dict(f_ex="fast"), "f_ex"),
        (dict(a_ex=0.0), "a_ex"),
        (dict(n_modes=0), "n_modes"),
        (dict(n_modes=21), "n_modes"),
        (dict(harmonics=2), "harmonics"),
        (dict(harmonics=9), "harmonics"),
        (dict(static_sag="yes"), "static_sag"),
        (dict(d_eff=-0.1), "d_eff"),
        (dict(s=[0.3, 0.2]), "s"),
        (dict(s=[0.2, 0.7]), "s"),
        (dict(s=[0.3]), "s"),
    ],
)
def test_bad_inputs(kwargs, match):
    args = dict(f_ex=124.0, a_ex=14.0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        hb_manifold(**args)


def test_cli_hb_manifold(tmp_path, capsys):
    from beamslider.cli import main

    assert main(["hb-manifold", "--f-ex", "124", "--a-ex", "14", "--n-modes", "2", "--out", str(tmp_path)]) == 0
    stem = "hb_manifold_124Hz_14ms2_N2"
    for ext in ("csv", "json", "png"):
        assert (tmp_path / f"{stem}.{ext}").exists()
    rows = (tmp_path / f"{stem}.csv").read_text().splitlines()
    assert rows[0] == "branch,s,amplitude_h,phase_rad,stable" and len(rows) > 50
    assert "s_up = 0." in capsys.readouterr().out
    # A second run refuses to overwrite (the outputs carry N in their names) unless --force.
    before = (tmp_path / f"{stem}.csv").read_bytes()
    assert main(["hb-manifold", "--f-ex", "124", "--a-ex", "14", "--n-modes", "2", "--out", str(tmp_path)]) != 0
    assert "--force" in capsys.readouterr().err
    assert (tmp_path / f"{stem}.csv").read_bytes() == before
    assert main(["hb-manifold", "--f-ex", "124", "--a-ex", "14", "--n-modes", "2", "--out", str(tmp_path),
                 "--force"]) == 0
