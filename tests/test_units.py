"""Units and plausibility (docs/model.md §1, "Units and plausibility"): parameter values orders of
magnitude from every beam and slider of this kind, pairs of parameters that describe one quantity
and disagree, and ENMA and measured files far from anything the model can produce, each refused
in one line naming the field (or file) and the likely unit; BEAMSLIDER_ALLOW_IMPLAUSIBLE lets a
meant value through."""

import gzip
from pathlib import Path

import numpy as np
import pytest

import beamslider
from beamslider import enma
from beamslider.measurement import MeasurementFormatError, read_measurement, write_measurement
from conftest import run_cli

ROOT = Path(__file__).resolve().parent.parent
SAMPLE = ROOT / "examples" / "data" / "Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt.gz"
OVERRIDE = "BEAMSLIDER_ALLOW_IMPLAUSIBLE"


@pytest.fixture(autouse=True)
def _no_override(monkeypatch):
    monkeypatch.delenv(OVERRIDE, raising=False)


def _one_line(r, *words):
    assert r.returncode == 1, (r.returncode, r.stdout[-1000:], r.stderr[-2000:])
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("beamslider: error:"), r.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


@pytest.mark.parametrize("field, value, unit", [
    ("length_m", 140.0, "mm"),               # mm for m: the beam would swing at 2,538 h
    ("slider_mass_kg", 46.2, "g"),           # g for kg
    ("youngs_modulus_pa", 210.0, "GPa"),
    ("density_kg_m3", 7.683, "g/cm³"),
    ("gap_ratio", 105.0, "per cent"),
    ("damping_ratio", 5.0, "per cent"),
    ("gravity_m_s2", 981.0, "cm/s²"),
])
def test_a_value_in_the_wrong_unit_is_refused_naming_the_unit(field, value, unit):
    with pytest.raises(ValueError, match=f"`{field}`") as e:
        beamslider.Parameters(**{field: value})
    assert f"in {unit}?" in str(e.value) and OVERRIDE in str(e.value)


@pytest.mark.parametrize("change, field, unit", [
    ({"beam_mass_kg": 15.1}, "beam_mass_kg", "g"),                    # rho*A*L against the beam's mass
    ({"slider_inertia_kg_m2": 3.15}, "slider_inertia_kg_m2", "kg mm²"),  # J_C against the slider's mass
    ({"com_offset_m": 4.1}, "com_offset_m", "mm"),
])
def test_two_parameters_of_one_quantity_must_agree(change, field, unit):
    with pytest.raises(ValueError, match=f"`{field}`") as e:
        beamslider.Parameters(**change)
    assert f"in {unit}?" in str(e.value)


def test_rho_a_l_of_a_beam_with_a_length_in_mm_disagrees_with_its_mass(monkeypatch):
    # The width the beam's mass implies: 14 mm for the prototype, 14 µm at L = 140 (mm as m).
    monkeypatch.setenv(OVERRIDE, "1")
    p = beamslider.Parameters(length_m=140.0)
    monkeypatch.delenv(OVERRIDE)
    from beamslider import _core

    found = [f for f, _v, _w in _core.plausibility_findings(beamslider.params.native(p))]
    assert found[:2] == ["length_m", "beam_mass_kg"]


def test_the_override_lets_a_meant_value_through(monkeypatch):
    monkeypatch.setenv(OVERRIDE, "1")
    p = beamslider.Parameters(length_m=140.0)
    assert p.length_m == 140.0
    monkeypatch.setenv(OVERRIDE, "0")
    with pytest.raises(ValueError, match="length_m"):
        beamslider.Parameters(length_m=140.0)


def test_every_prototype_like_design_stays_plausible():
    # The corners of the design box (docs/model.md §6.5) and the defaults pass.
    beamslider.Parameters()
    for change in ({"gap_ratio": 1.02}, {"gap_ratio": 1.3}, {"slider_mass_kg": 0.02}, {"slider_mass_kg": 0.07},
                   {"contact_spacing_m": 0.007, "slider_inertia_kg_m2": 3.15e-6 * 0.49},
                   {"com_offset_m": 0.0}, {"com_offset_m": 0.008}, {"friction_coefficient": 0.4},
                   {"restitution": 0.2}, {"damping_ratio": 0.002}, {"gravity_m_s2": 0.0}):
        beamslider.Parameters(**change)


def test_the_command_line_refuses_a_parameter_file_in_mm(tmp_path):
    (tmp_path / "mm.toml").write_text("length_m = 140\n")
    r = run_cli("simulate", "--params", "mm.toml", "--t-end", "1", "--out", "o", cwd=tmp_path)
    _one_line(r, "length_m", "in mm?")
    assert not (tmp_path / "o").exists()
    (tmp_path / "g.toml").write_text("slider_mass_kg = 46.2\n")
    r = run_cli("map", "--params", "g.toml", "--f-ex", "124", "--a-ex", "14", "--t-end", "1", "--out", "m", cwd=tmp_path)
    _one_line(r, "slider_mass_kg", "in g?")
    assert not (tmp_path / "m").exists()


# --- ENMA files -------------------------------------------------------------------------------


def test_enma_amplitudes_a_thousand_times_too_large_are_refused(tmp_path):
    path = tmp_path / "enma.csv"
    path.write_text("amplitude_h,frequency_hz\n" + "".join(f"{a * 1000:g},{115 + 2 * a:g}\n" for a in (0.2, 0.5, 1.0, 1.5)))
    with pytest.raises(enma.EnmaFormatError, match=r"enma.csv, line 2, column amplitude_h") as e:
        enma.read(path)
    assert "thickness" in str(e.value) and "1000" in str(e.value)
    r = run_cli("enma", str(path), "--out", "e", cwd=tmp_path)
    _one_line(r, "amplitude_h")
    ok = tmp_path / "ok.csv"
    ok.write_text("amplitude_h,frequency_hz\n" + "".join(f"{a:g},{115 + 2 * a:g}\n" for a in (0.2, 0.5, 1.0, 1.5)))
    assert len(enma.read(ok)) == 4


# --- measured files ---------------------------------------------------------------------------


def _sample_rows(n=40000):
    with gzip.open(SAMPLE, "rt") as f:
        data = np.loadtxt(f, max_rows=n)
    return data[:, 0], data[:, 1], data[:, 2]


def test_a_measured_velocity_in_mm_per_s_is_refused_naming_the_unit(tmp_path):
    t, v, s = _sample_rows()
    good = tmp_path / "Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt"
    write_measurement(good, t, v, s)
    read_measurement(good)
    bad = tmp_path / "mm" / good.name
    bad.parent.mkdir()
    write_measurement(bad, t, v * 1000, s)
    with pytest.raises(MeasurementFormatError, match="mm/s") as e:
        read_measurement(bad)
    assert str(bad) in str(e.value)
    r = run_cli("compare", str(bad), "--no-manifold", "--out", "c", cwd=tmp_path)
    _one_line(r, "mm/s")
    assert not (tmp_path / "c").exists()


def test_a_measured_time_in_ms_is_refused(tmp_path):
    t, v, s = _sample_rows(5000)
    path = tmp_path / "Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt"
    write_measurement(path, t * 1000, v, s)
    with pytest.raises(MeasurementFormatError, match="ms"):
        read_measurement(path)
