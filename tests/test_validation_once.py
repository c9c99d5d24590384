"""Parameters are validated once per parameter set, in the core (docs/model.md §1), on every path:
a reader (a TOML file, keyword arguments, a command line's overrides) gives unvalidated values and
one place (the core's ``Valid::new``) validates them; runs, maps, studies and discover's candidate
models take the validated object as it is, without TOML and without a check run first. Counted
with the core's own counter of ``Params::validate``."""

import pytest

import beamslider
from beamslider import _core
from beamslider.cli import main


class Count:
    """Validations in the ``with`` block: ``.n``."""

    def __enter__(self):
        self.before = _core._validation_count()
        return self

    def __exit__(self, *exc):
        self.n = _core._validation_count() - self.before
        return False


@pytest.fixture
def params_file(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text("friction_coefficient = 0.25\nn_modes = 4\n", encoding="utf-8")
    return path


def test_the_python_constructor_validates_once():
    with Count() as c:
        beamslider.Parameters(friction_coefficient=0.3)
    assert c.n == 1
    with Count() as c:
        beamslider.Parameters.from_dict({"restitution": 0.4})
    assert c.n == 1


def test_from_toml_validates_once_with_or_without_overrides(params_file):
    with Count() as c:
        p = beamslider.Parameters.from_toml(params_file)
    assert c.n == 1 and p.friction_coefficient == 0.25
    with Count() as c:
        p = beamslider.Parameters.from_toml(params_file, dt_s=2e-6)
    assert c.n == 1 and p.dt_s == 2e-6 and p.n_modes == 4
    with Count() as c, pytest.raises(ValueError, match="dt_s"):
        beamslider.Parameters.from_toml(params_file, dt_s=-1.0)  # the override is what is validated
    assert c.n == 1


def test_simulate_command_validates_its_parameters_once(tmp_path, capsys):
    with Count() as c:
        code = main(["simulate", "--t-end", "0.2", "--no-progress", "--out", str(tmp_path)])
    assert code in (0, None), capsys.readouterr().err
    assert c.n == 1
    assert any(tmp_path.glob("*.json"))


@pytest.mark.parametrize("extra", [[], ["--dt", "2e-6"]], ids=["params", "params_and_dt"])
def test_simulate_params_validates_once(tmp_path, capsys, params_file, extra):
    with Count() as c:
        code = main(["simulate", "--params", str(params_file), *extra, "--t-end", "0.1", "--no-progress",
                     "--no-manifold", "--out", str(tmp_path)])
    assert code in (0, None), capsys.readouterr().err
    assert c.n == 1


def test_a_changed_field_is_validated_again_before_the_run():
    p = beamslider.Parameters()
    with Count() as c:
        beamslider.simulate(p, f_ex=124, a_ex=14, t_end=0.01)
    assert c.n == 0  # the object made at construction is used as is
    p.restitution = 0.4
    with Count() as c:
        beamslider.simulate(p, f_ex=124, a_ex=14, t_end=0.01)
    assert c.n == 1


def test_a_map_validates_its_parameters_once(tmp_path):
    with Count() as c:
        p = beamslider.Parameters(friction_coefficient=0.25)
        beamslider.operating_map(p, f_ex=[120, 124], a_ex=[14], t_end=0.5, threads=2, out=tmp_path / "m")
    assert c.n == 1
    with Count() as c:  # the defaults, made inside
        beamslider.operating_map(f_ex=[124], a_ex=[14], t_end=0.5)
    assert c.n == 1


def test_a_map_command_with_params_and_dt_validates_once(tmp_path, capsys, params_file):
    with Count() as c:
        code = main(["map", "--params", str(params_file), "--dt", "2e-6", "--f-ex", "124", "--a-ex", "14",
                     "--t-end", "0.5", "--no-progress", "--out", str(tmp_path / "m")])
    assert code in (0, None), capsys.readouterr().err
    assert c.n == 1


def test_a_study_validates_each_sample_once(tmp_path):
    from beamslider import study

    cfg = study.StudyConfig.from_dict({
        "duration_s": 0.5,
        "grid": {"f_ex_hz": [120.0, 124.0], "a_ex_m_s2": [14.0], "s0": 0.3},
        "study": {"method": "lhs", "samples": 3, "seed": 3},
        "uncertain": {"friction_coefficient": {"distribution": "uniform", "low": 0.22, "high": 0.31},
                      "natural_frequency_factor": {"distribution": "uniform", "low": 0.95, "high": 1.05}},
    })
    with Count() as c:
        points = study.study_points(cfg)
    assert c.n == 3 and len(points) == 6  # one parameter set per sample (detuned before the one check)
    with Count() as c:
        study.run_study(cfg, out=tmp_path / "s", threads=2)
    assert c.n == 3  # run_study makes its points: each sample once; its map configuration and runs none


def test_discover_candidate_models_validate_once():
    from beamslider.discover import OperatingPoint, realise_effects
    from beamslider.discover.models import batch_slider_features

    base = beamslider.Parameters()
    candidates = [{"friction_coefficient": 0.3}, {"clearance": 1.08}, {"natural_frequency_detuning": 1.03},
                  {"slider_mass": 0.046}]
    with Count() as c:
        models = [realise_effects(base, values) for values in candidates]
    assert c.n == len(candidates)
    with Count() as c:  # their runs take the validated objects as they are
        batch_slider_features(models, [OperatingPoint(f_ex=124.0, a_ex=14.0, s0=0.3, duration_s=0.5)], threads=2)
    assert c.n == 0


def test_the_predictor_takes_its_parameters_as_validated():
    from beamslider.superslow import predict, predicted_map

    p = beamslider.Parameters()
    predict(p, f_ex=124, a_ex=14)  # the built-in law read, the beam built
    with Count() as c:
        predict(p, f_ex=124, a_ex=14)
    assert c.n == 0
    with Count() as c:
        predicted_map(p, f_ex=[120, 122, 124, 126], a_ex=[14], threads=1)
    assert c.n == 0  # the map's configuration keeps the validated set; its points check nothing again
