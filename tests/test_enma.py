"""ENMA of the beam without slider and model updating of its clamping (paper §3, docs/model.md §9)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import beamslider as bs
from beamslider import enma

from conftest import is_png, run_cli

IDEAL = dict(k_r_nm_per_rad=math.inf, k_t_n_per_m=math.inf)


@pytest.fixture(scope="module")
def default_enma():
    """Virtual ENMA of the prototype: 16 levels 0.25 … 4 m/s² up and down (31 points)."""
    return enma.virtual()


def test_virtual_enma_follows_single_mode_backbone(default_enma):
    d = default_enma
    assert len(d) == 31 and list(d.run[:16]) == ["up"] * 16 and list(d.run[16:]) == ["down"] * 15
    assert all(d.info["converged"])
    w2, bstar = enma.model_backbone(bs.Parameters())
    dev = d.frequency_hz / enma.backbone_hz(w2, bstar, d.amplitude_h) - 1
    low = d.amplitude_h <= 1.0
    assert low.sum() == len(d)  # the default levels reach a~ ≈ 0.9
    assert np.max(np.abs(dev[low])) < 0.01
    assert np.max(np.abs(dev[low])) < 2e-4  # in fact: the time discretisation's 6e-5 plus coupling
    # Up and down runs agree (no hysteresis of the beam alone).
    up, down = d.frequency_hz[:15], d.frequency_hz[16:][::-1]
    assert np.max(np.abs(up / down - 1)) < 1e-5
    # Damping estimate: D ω/ω~ for linear viscous damping; shape close to the linear mode.
    assert abs(d.damping_ratio[0] / 1e-3 - 1) < 0.01
    assert np.all(np.abs(d.shape[:, 2] - 1) < 1e-12) and np.all(d.shape[:, 0] > 0.3)


def test_fit_recovers_clamping_from_noisy_virtual_enma(default_enma):
    """0.2 % frequency noise, two repetitions of the up-and-down run (as the paper's #1–#4): k_r
    within 2 %, k_t within 5 % for every seed tried."""
    ideal = bs.Parameters(**IDEAL)
    for seed in range(5):
        data = enma.with_noise(default_enma, frequency_rel=0.002, seed=seed, repeats=2)
        assert len(data) == 62
        fit = enma.fit_backbone(data)
        upd = enma.update_clamping(ideal, fit, full_output=True)
        assert abs(upd.k_r_nm_per_rad / 125.0 - 1) < 0.02, (seed, upd)
        assert abs(upd.k_t_n_per_m / 1.93e7 - 1) < 0.05, (seed, upd)
        # The reported uncertainty is of the size of the actual error.
        assert abs(upd.k_r_nm_per_rad - 125.0) < 4 * upd.k_r_stderr
        assert abs(upd.k_t_n_per_m - 1.93e7) < 4 * upd.k_t_stderr
        assert isinstance(upd.params, bs.Parameters) and upd.params.k_r_nm_per_rad == upd.k_r_nm_per_rad
    # Noise-free data: the update is exact to the discretisation error.
    upd = enma.update_clamping(ideal, enma.fit_backbone(default_enma))
    assert abs(upd.k_r_nm_per_rad / 125 - 1) < 3e-3 and abs(upd.k_t_n_per_m / 1.93e7 - 1) < 5e-3
    assert abs(upd.damping_ratio - np.mean(default_enma.damping_ratio)) < 1e-15


def test_ideal_clamping_errors_are_those_of_model_md():
    w2, b = enma.model_backbone(bs.Parameters())
    w2_i, b_i = enma.model_backbone(bs.Parameters(**IDEAL))
    assert abs(math.sqrt(w2) / (2 * math.pi) - 260.28) < 0.01
    assert abs(math.sqrt(w2_i) / (2 * math.pi) - 274.19) < 0.01
    assert abs(1 - math.sqrt(w2 / w2_i) - 0.0507) < 5e-4
    assert abs(b / 9.52e5 - 1) < 5e-3 and abs(b_i / 2.13e6 - 1) < 5e-3
    _, b_inf = enma.model_backbone(bs.Parameters(k_t_n_per_m=math.inf))
    assert abs(1 - b / b_inf - 0.522) < 1e-3
    # k_t formula inverts b*: k_t = EA / (L (b*_inf/b* - 1)).
    k_t, b_inf2 = enma.k_t_from_b_star(bs.Parameters(), b)
    assert b_inf2 == b_inf and abs(k_t / 1.93e7 - 1) < 1e-9
    assert enma.k_t_from_b_star(bs.Parameters(), 1.01 * b_inf)[0] == math.inf
    assert abs(enma.solve_k_r(bs.Parameters(), math.sqrt(w2)) / 125 - 1) < 1e-8
    with pytest.raises(ValueError, match="exceeds the ideally clamped"):
        enma.solve_k_r(bs.Parameters(), 1.01 * math.sqrt(w2_i))


def test_write_read_round_trip(tmp_path, default_enma):
    path = tmp_path / "enma.csv"
    default_enma.write(path)
    back = enma.read(path)
    assert len(back) == len(default_enma)
    np.testing.assert_array_equal(back.frequency_hz, default_enma.frequency_hz)
    np.testing.assert_array_equal(back.shape, default_enma.shape)
    assert list(back.run) == list(default_enma.run)
    minimal = tmp_path / "min.csv"
    minimal.write_text("# measured\nfrequency_hz,amplitude_h\n260.5,0.1\n\n270,0.5\n290,0.9\n")
    m = enma.read(minimal)
    assert list(m.amplitude_h) == [0.1, 0.5, 0.9] and not m.has_damping and not m.has_shape
    fit = enma.fit_backbone(m)
    assert fit.n_points == 3 and fit.b_star > 0


@pytest.mark.parametrize("text, match", [
    ("", "empty file"),
    ("amplitude,frequency\n0.1,260\n", "lacks the column"),
    ("amplitude_h,frequency_hz\n", "no data points"),
    ("amplitude_h,frequency_hz\n0.1,260\n0.2,abc\n", "line 3, column frequency_hz: 'abc' is not a number"),
    ("amplitude_h,frequency_hz\n0.1,260\n0.2\n", "line 3: 1 cells"),
    ("amplitude_h,frequency_hz\n0.1,nan\n", "line 2: frequency_hz = nan"),
    ("amplitude_h,frequency_hz\n0.1,inf\n", "not a finite number"),
    ("amplitude_h,frequency_hz\n-0.1,260\n", "amplitude_h = -0.1 must be > 0"),
    ("amplitude_h,frequency_hz,damping_ratio\n0.1,260,-1e-3\n", "damping_ratio = -0.001 must be >= 0"),
    ("amplitude_h,amplitude_h,frequency_hz\n0.1,0.1,260\n", "duplicate column"),
])
def test_bad_files_give_clear_errors(tmp_path, text, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(enma.EnmaFormatError, match=match) as e:
        enma.read(path)
    assert str(path) in str(e.value)


def test_binary_and_missing_files(tmp_path):
    path = tmp_path / "bin.csv"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe")
    with pytest.raises(enma.EnmaFormatError, match="not a text file"):
        enma.read(path)
    with pytest.raises(OSError):
        enma.read(tmp_path / "none.csv")


def test_degenerate_data():
    with pytest.raises(ValueError, match="at least 3"):
        enma.fit_backbone(enma.make_data([0.1, 0.2], [260, 261]))
    with pytest.raises(ValueError, match="one amplitude"):
        enma.fit_backbone(enma.make_data([0.3, 0.3, 0.3], [262, 263, 262.5]))
    with pytest.raises(ValueError, match="frequency_hz has 2 values"):
        enma.make_data([0.1, 0.2, 0.3], [260, 261])
    with pytest.raises(ValueError, match="levels_m_s2"):
        enma.virtual(levels_m_s2=[])
    with pytest.raises(ValueError, match="kp_per_s"):
        enma.virtual(levels_m_s2=[1.0], kp_per_s=-1)
    with pytest.raises(ValueError, match="must be finite"):
        enma.virtual(levels_m_s2=[1.0], max_hold_s=math.nan)


def test_enma_cli_virtual_and_measured(tmp_path):
    r = run_cli("enma", "--levels", "0.5:3:0.5", "--noise-frequency", "0.002", "--repeats", "2",
                "--out", str(tmp_path / "v"), "--no-progress", cwd=tmp_path, timeout=600)
    assert r.returncode == 0, r.stderr
    out = tmp_path / "v"
    report = json.loads((out / "enma_report.json").read_text())
    assert report["data"]["points"] == 22
    assert abs(report["truth"]["k_r_error_rel"]) < 0.05
    assert report["baseline"]["fitted_vs_baseline_frequency_rel"] < -0.04
    assert is_png(out / "enma.png")
    upd = bs.Parameters.from_toml(out / "enma_updated.toml")
    assert abs(upd.k_r_nm_per_rad / 125 - 1) < 0.05
    # The written data go back in as a measured file.
    r = run_cli("enma", str(out / "enma_data.csv"), "--out", str(tmp_path / "m"), cwd=tmp_path, timeout=600)
    assert r.returncode == 0, r.stderr
    assert "k_r [N m/rad]" in r.stdout
    bad = tmp_path / "bad.csv"
    bad.write_text("amplitude_h,frequency_hz\n0.1,260\n0.2,x\n")
    r = run_cli("enma", str(bad), "--out", str(tmp_path / "b"), cwd=tmp_path)
    assert r.returncode == 1 and "Traceback" not in r.stderr and "line 3" in r.stderr
    r = run_cli("enma", "--levels", "1", "--out", str(tmp_path / "c"), "--no-progress", cwd=tmp_path)
    assert r.returncode == 1 and "at least 3" in r.stderr and "Traceback" not in r.stderr
