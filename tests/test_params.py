"""beamslider.Parameters (docs/model.md §1): defaults, TOML in and out, validation by the core."""

import dataclasses
import math

import pytest

import beamslider
from beamslider import Parameters, _core


def test_fields_and_defaults_are_the_cores():
    core = _core.Params().to_dict()
    assert sorted(f.name for f in dataclasses.fields(Parameters)) == sorted(core)
    assert Parameters().to_dict() == core


def test_model_md_defaults():
    p = Parameters()
    assert (p.length_m, p.thickness_m, p.n_modes, p.dt_s, p.contact_solver) == (0.14, 1e-3, 5, 2e-5, "fast")
    f = p.natural_frequencies_hz()
    assert f[0] == pytest.approx(260.2805, abs=1e-3)
    assert f[4] == pytest.approx(3500.124, abs=1e-2)


def test_toml_round_trip(tmp_path):
    p = Parameters(damping_ratio=2e-3, n_modes=3, contact_solver="reference", k_t_n_per_m=math.inf)
    path = tmp_path / "p.toml"
    p.to_toml(path)
    text = path.read_text()
    assert "k_t_n_per_m = inf" in text and 'contact_solver = "reference"' in text
    assert Parameters.from_toml(path) == p


def test_ideal_clamping_frequency():
    p = Parameters(k_r_nm_per_rad=math.inf, k_t_n_per_m=math.inf)
    assert p.natural_frequencies_hz()[0] == pytest.approx(274.187, abs=1e-3)


def test_partial_file_takes_defaults(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text('n_modes = 4\ncontact_solver = "reference"\n')
    p = Parameters.from_toml(path)
    assert p.n_modes == 4 and p.contact_solver == "reference" and p.length_m == 0.14


def test_integers_for_float_fields_and_numpy_values():
    np = pytest.importorskip("numpy")
    p = Parameters(youngs_modulus_pa=210_000_000_000, n_modes=np.int64(4), gravity_m_s2=np.float64(9.81))
    assert p.validate() is None


BAD = [
    ("length_m", 0.0, "> 0"),
    ("thickness_m", -1e-3, "> 0"),
    ("slider_mass_kg", math.nan, "finite"),
    ("youngs_modulus_pa", math.inf, "finite"),
    ("dt_s", 0.0, "> 0"),
    ("k_r_nm_per_rad", 0.0, "> 0"),
    ("k_t_n_per_m", math.nan, "> 0"),
    ("gap_ratio", 1.0, "> 1"),
    ("gap_ratio", 0.9, "> 1"),
    ("friction_coefficient", -0.1, ">= 0"),
    ("damping_ratio", math.nan, ">= 0"),
    ("restitution", 1.5, "[0, 1]"),
    ("restitution", -0.1, "[0, 1]"),
    ("n_modes", 0, "1..=20"),
    ("n_modes", 21, "1..=20"),
    ("solver_max_iter", 0, ">= 1"),
    ("contact_spacing_m", 0.2, "smaller than"),
    ("n_modes", 2.5, "expected"),
    ("length_m", "long", "expected f64"),
    ("contact_solver", "magic", "fast"),
]


@pytest.mark.parametrize("field,value,allowed", BAD, ids=[f"{f}={v!r}" for f, v, _ in BAD])
def test_invalid_values_raise_valueerror_naming_field(field, value, allowed):
    with pytest.raises(ValueError) as e:
        Parameters(**{field: value})
    msg = str(e.value)
    assert field in msg and allowed in msg, msg
    assert "\n" not in msg


def test_invalid_after_mutation_is_caught_before_a_run():
    p = Parameters()
    p.restitution = 2.0
    with pytest.raises(ValueError, match="restitution"):
        beamslider.simulate(p, f_ex=124, a_ex=14, t_end=0.01)


def test_dt_too_large_for_highest_mode():
    with pytest.raises(ValueError, match="dt_s"):
        Parameters(dt_s=1e-3).natural_frequencies_hz()


def test_bad_files(tmp_path):
    with pytest.raises(OSError):
        Parameters.from_toml(tmp_path / "missing.toml")
    unknown = tmp_path / "unknown.toml"
    unknown.write_text("lenght_m = 0.1\n")
    with pytest.raises(ValueError, match="lenght_m"):
        Parameters.from_toml(unknown)
    bad = tmp_path / "bad.toml"
    bad.write_text("restitution = 3.0\n")
    with pytest.raises(ValueError, match="restitution"):
        Parameters.from_toml(bad)
    garbled = tmp_path / "garbled.toml"
    garbled.write_text("length_m = = 1\n")
    with pytest.raises(ValueError, match="garbled.toml"):
        Parameters.from_toml(garbled)


def test_from_dict_rejects_unknown_names():
    with pytest.raises(ValueError, match="lenght_m"):
        Parameters.from_dict({"lenght_m": 0.1})
    assert Parameters.from_dict({"n_modes": 3}).n_modes == 3
