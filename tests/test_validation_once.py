"""Parameters are validated once per run, in the core (docs/model.md §1): ``beamslider simulate``
hands the core's validated object to the run and to the manifold beside it, without TOML and
without a check run first."""

from beamslider import _core
from beamslider.cli import main


def test_simulate_command_validates_its_parameters_once(tmp_path, capsys):
    before = _core._validation_count()
    code = main(["simulate", "--t-end", "0.2", "--no-progress", "--out", str(tmp_path)])
    assert code in (0, None), capsys.readouterr().err
    assert _core._validation_count() - before == 1
    assert (tmp_path / "fs_124Hz_14ms2_s0.3.json").exists() or any(tmp_path.glob("*.json"))


def test_a_changed_field_is_validated_again_before_the_run():
    import beamslider

    p = beamslider.Parameters()
    before = _core._validation_count()
    beamslider.simulate(p, f_ex=124, a_ex=14, t_end=0.01)
    assert _core._validation_count() == before  # the object made at construction is used as is
    p.restitution = 0.4
    beamslider.simulate(p, f_ex=124, a_ex=14, t_end=0.01)
    assert _core._validation_count() == before + 1
