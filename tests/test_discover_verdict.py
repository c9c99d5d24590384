"""The typed verdict and the options of a discover (docs/model.md §9, "Naming rule"): report.md,
gap.png's title and the command line's verdict line come from :class:`beamslider.discover.Verdict`,
one test per kind; the options type refuses unknown keys and report.json records it."""

from __future__ import annotations

import dataclasses
import json
import math

import pytest

import beamslider as bs
import beamslider.discover as dc
from beamslider.discover.reasons import Reason, Why
from beamslider.discover.report import gap_title, verdict_line
from beamslider.discover.result import After, Because, CandidateFit, Discovery, Kind, Verdict


def _fit(effects, chi2, values=None):
    values = values or {e: dc.EFFECTS[e].baseline_value(bs.Parameters()) * 1.1 for e in effects}
    return CandidateFit(tuple(effects), values, {e: 0.01 for e in effects}, chi2, 10, True, chi2)


def _discovery(v: Verdict, named=(), parameters=None) -> Discovery:
    p = bs.Parameters()
    features = {"f0_hz": dict(measured=1.0, uncertainty=0.1, baseline=1.5, updated=1.0, model_spread_baseline=0.0,
                              model_spread_updated=0.0, unit="Hz", description="", z_before=5.0, z_after=0.0,
                              exceeds_uncertainty=True)}
    fits = [f for f in [v.named, v.unresolved, v.best_rejected] + v.negligible if f is not None]
    return Discovery("beam", list(named), parameters or {}, features, 5.0, 1.0, 25.0, fits, "the rule", p, p,
                     verdict=v.kind, judgment=v, options=dc.DiscoverOptions(),
                     features_off=[dict(feature="f0_hz", z=5.0)], rejected=[])


def _report(d: Discovery, tmp_path) -> str:
    pytest.importorskip("matplotlib")
    dc.write_report(d, tmp_path)
    return (tmp_path / "report.md").read_text(encoding="utf-8")


def test_named(tmp_path):
    f = _fit(["friction_coefficient"], 3.0, {"friction_coefficient": 0.26})
    v = Verdict(Kind.NAMED, Because.NAMED, named=f, after=After({}, {}, {}, {}))
    params = {"friction_coefficient": dict(field="friction_coefficient", value=0.26, stderr=0.01, unit="-",
                                           baseline=0.2, relevance="", interval=[0.24, 0.28])}
    d = _discovery(v, ["friction_coefficient"], params)
    assert d.verdict == "named" and d.to_json()["verdict"] == "named"
    assert str(d.verdict) == "named" and f"{d.verdict}" == "named"   # printed as the string it was
    assert verdict_line(d).startswith("named friction_coefficient (friction_coefficient = 0.26 ± 0.01")
    assert gap_title(d) == "named: friction_coefficient"
    md = _report(d, tmp_path)
    assert "**Named effect(s): `friction_coefficient`**" in md
    j = json.loads((tmp_path / "report.json").read_text())
    assert j["judgment"]["kind"] == "named" and j["judgment"]["named"] == ["friction_coefficient"]
    assert j["options"]["gap_ratio"] == 0.3 and j["options"]["ensemble_s0_shifts"][0] == 0.0


def test_confounded(tmp_path):
    group = dict(group=["friction_coefficient", "natural_frequency_detuning"], combination="(a) = (b)",
                 explanation="each alone fits equally")
    v = Verdict(Kind.CONFOUNDED, Because.CONFOUNDED, group=group,
                advice=dict(text="add a run at f_ex = 116 Hz", weak=False))
    d = _discovery(v)
    line = verdict_line(d)
    assert line.startswith("confounded: friction_coefficient, natural_frequency_detuning fit equally (the data "
                           "resolve (a) = (b)") and line.endswith("; to separate them, add a run at f_ex = 116 Hz")
    assert gap_title(d) == "confounded: friction_coefficient, natural_frequency_detuning (nothing named)"
    md = _report(d, tmp_path)
    assert "**Confounded: `friction_coefficient`, `natural_frequency_detuning`**" in md
    assert "Advice (the separability tool): add a run at f_ex = 116 Hz." in md


def test_unexplained_not_resolved(tmp_path):
    u = _fit(["tilt"], 8.0, {"tilt": 0.0022})
    why = [Reason(Why.NOT_RESOLVED, "not resolved: the interval [-0.002, 0.0066] of tilt_rad contains the baseline 0",
                  "tilt")]
    v = Verdict(Kind.UNEXPLAINED, Because.NOT_RESOLVED, unresolved=u, reasons={u.effects: why},
                advice=dict(text="add a run at f_ex = 104 Hz"))
    d = _discovery(v)
    assert verdict_line(d) == ("unexplained discrepancy (gap 5) - best candidate tilt (tilt_rad = 0.0022 ± 0.01), "
                               "not resolved by these runs (the interval [-0.002, 0.0066] of tilt_rad contains the "
                               "baseline 0); to resolve it, add a run at f_ex = 104 Hz")
    assert gap_title(d).startswith("unexplained: nothing named")
    assert "**Unexplained discrepancy** — the baseline does not fit the data" in _report(d, tmp_path)


def test_unexplained_outside_the_candidates(tmp_path):
    group = dict(group=["tilt", "com_offset"], sets=[["tilt"], ["com_offset"]], not_candidates=["com_offset"],
                 combination="(x) = (y)", explanation="the set tilt fits as well as com_offset")
    v = Verdict(Kind.UNEXPLAINED, Because.OUTSIDE_CANDIDATES, group=group)
    d = _discovery(v)
    assert verdict_line(d).startswith("unexplained discrepancy (gap 5) - the best set tilt fits as well as com_offset, "
                                      "not among the candidates")
    assert "the candidates do not establish the change" in _report(d, tmp_path)


def test_unexplained_poor_fit(tmp_path):
    f = _fit(["natural_frequency_detuning"], 12.0, {"natural_frequency_detuning": 1.0111})
    poor = dict(effects=["natural_frequency_detuning"], values={"natural_frequency_detuning": 1.0111},
                stderrs={"natural_frequency_detuning": 0.0023}, chi2=28.7, gap=1.30, bound=21.8, gap_bound=1.13)
    v = Verdict(Kind.UNEXPLAINED, Because.POOR_FIT, best_rejected=f, poor_fit=poor,
                reasons={f.effects: [Reason(Why.POOR_FIT, "does not fit as right models do")]})
    d = _discovery(v)
    assert verdict_line(d) == ("unexplained discrepancy (gap 5) - best candidate natural_frequency_detuning "
                               "(natural_frequency_factor = 1.0111 ± 0.0023) does not fit as right models do: its "
                               "full simulation leaves gap 1.3 > 1.13")
    assert gap_title(d) == "unexplained: nothing named (the best set does not fit as right models do)"
    md = _report(d, tmp_path)
    assert "the full simulation of the model with it leaves chi2 = 28.7 (gap 1.3)" in md
    j = json.loads((tmp_path / "report.json").read_text())
    assert j["judgment"]["kind"] == "unexplained" and j["judgment"]["poor_fit"]["bound"] == 21.8


def test_unexplained_no_set_passes(tmp_path):
    f = _fit(["clearance"], 40.0)
    v = Verdict(Kind.UNEXPLAINED, Because.NO_SET_PASSES, best_rejected=f,
                reasons={f.effects: [Reason(Why.NOT_ADEQUATE, "not adequate: chi2 = 40 > chi2_0.99(10) = 23.2")]})
    d = _discovery(v)
    assert verdict_line(d) == ("unexplained discrepancy (gap 5; off: f0_hz z = +5.0); best candidate clearance "
                               "rejected: not adequate: chi2 = 40 > chi2_0.99(10) = 23.2")
    assert "no candidate effect passes the naming rule" in _report(d, tmp_path)


def test_none_by_a_negligible_change(tmp_path):
    f = _fit(["friction_coefficient"], 9.0, {"friction_coefficient": 0.203})
    v = Verdict(Kind.NONE, Because.NEGLIGIBLE_CHANGE, negligible=[f],
                reasons={f.effects: [Reason(Why.NEGLIGIBLE, "negligible change of friction_coefficient: 0.003 < 0.01",
                                            "friction_coefficient")]})
    d = _discovery(v)
    assert verdict_line(d) == ("none (gap 5 closed by a negligible change: friction_coefficient, negligible change "
                               "of friction_coefficient: 0.003 < 0.01)")
    assert gap_title(d) == "named: nothing (only a negligible change is needed)"
    assert "a change smaller than the candidates' relevance thresholds" in _report(d, tmp_path)


def test_none_the_baseline_fits(tmp_path):
    d = _discovery(Verdict(Kind.NONE, Because.BASELINE_FITS))
    assert verdict_line(d) == "none (the baseline fits: gap 5)"
    assert gap_title(d) == "named: nothing (model agrees within uncertainty)"
    assert "the baseline agrees with the data within the measurement uncertainty" in _report(d, tmp_path)


def test_options_refuse_unknown_keys_and_bad_values():
    with pytest.raises(ValueError, match="unknown option 'tier_kept'"):
        dc.DiscoverOptions.of({"tier_kept": 3})
    with pytest.raises(TypeError):
        dc.DiscoverOptions(tier_kept=3)  # type: ignore[call-arg]
    with pytest.raises(ValueError, match="gap_ratio"):
        dc.DiscoverOptions(gap_ratio=1.5)
    o = dc.DiscoverOptions.of({"tier_keep": 3}, gap_ratio=0.4, advice_grid=None)
    assert (o.tier_keep, o.gap_ratio, o.significance) == (3, 0.4, 0.01)
    with pytest.raises(dataclasses.FrozenInstanceError):
        o.tier_keep = 5  # type: ignore[misc]
    # how the runs are read: validated as the others
    for bad in (dict(ensemble_s0_shifts=(0.001, 0.0)), dict(ensemble_s0_shifts=(0.0,)), dict(mode_min_dof=0),
                dict(high_final_h=-1.0), dict(recorded_segments=1), dict(turning_smooth_s=float("nan")),
                dict(feature_floors=(("f0_hz", "log", 1e-4),))):
        with pytest.raises(ValueError, match=next(iter(bad))):
            dc.DiscoverOptions(**bad)
    o = dc.DiscoverOptions(ensemble_s0_shifts=[0, 0.001, -0.001])
    assert o.ensemble_s0_shifts == (0.0, 0.001, -0.001) and o.to_json()["ensemble_s0_shifts"] == [0.0, 0.001, -0.001]
    # discover refuses them before any run
    with pytest.raises(ValueError, match="unknown option"):
        dc.discover(enma_data=dc.synthesize_enma(bs.Parameters(), seed=1), options={"nope": 1})


def test_every_option_states_its_meaning_and_section():
    """Each field of the options type has a docstring that cites its section of docs/model.md (§9 or §9.1)."""
    import ast
    import inspect

    body = ast.parse(inspect.getsource(dc.DiscoverOptions)).body[0].body  # type: ignore[attr-defined]
    fields = [f.name for f in dataclasses.fields(dc.DiscoverOptions)]
    docs = {a.target.id: b.value.value for a, b in zip(body, body[1:])
            if isinstance(a, ast.AnnAssign) and isinstance(b, ast.Expr) and isinstance(b.value, ast.Constant)}
    assert sorted(docs) == sorted(fields)
    assert all("§9" in text for text in docs.values()), [k for k, v in docs.items() if "§9" not in v]


def test_the_baseline_case_records_its_verdict_and_options():
    """A real discover (the beam level's data of the baseline itself): the verdict typed, the options recorded."""
    d = dc.discover(enma_data=dc.synthesize_enma(bs.Parameters(), seed=1), effects=["axial_preload"],
                    options=dict(significance=0.01))
    assert d.judgment.kind is d.verdict and d.verdict in ("none", "named", "unexplained", "confounded")
    assert d.options == dc.DiscoverOptions() and d.to_json()["options"]["significance"] == 0.01


def test_cli_option_refuses_an_unknown_key(tmp_path, capsys):
    """``beamslider discover --option KEY=VALUE``: an unknown key is an error before any fit."""
    from beamslider.cli import main

    assert main(["discover", "--option", "tier_kept=3", "--out", str(tmp_path / "out")]) != 0
    assert "unknown option 'tier_kept'" in capsys.readouterr().err
    assert not (tmp_path / "out" / "report.json").exists()


def test_every_figure_states_the_reports_verdict(tmp_path, monkeypatch):
    """gap.png's title and slider.png's (and backbone.png's) overall title are the verdict of the report."""
    pytest.importorskip("matplotlib")
    import matplotlib.figure

    from beamslider.discover.synthesize import synthesize_slider_runs

    titles = {}
    real = matplotlib.figure.Figure.savefig

    def savefig(fig, path, *a, **kw):
        sup = fig._suptitle.get_text() if fig._suptitle is not None else ""
        titles[str(path).rsplit("/", 1)[-1]] = sup or fig.axes[0].get_title()
        return real(fig, path, *a, **kw)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", savefig)
    (run,) = synthesize_slider_runs(bs.Parameters(), operating_points=[(124.0, 14.0, 0.3)], duration_s=1.0,
                                    out_dir=tmp_path / "data")
    group = dict(group=["friction_coefficient", "com_offset"], combination="(a) = (b)", explanation="alike")
    v = Verdict(Kind.CONFOUNDED, Because.CONFOUNDED, group=group)
    d = _discovery(v)
    d.level, d.data = "slider", [bs.read_measurement(run)]
    dc.write_report(d, tmp_path / "out")
    assert titles["gap.png"] == titles["slider.png"] == gap_title(d) == \
        "confounded: friction_coefficient, com_offset (nothing named)"


# Module-level names of the discover package that are not tuning values, each with why: the
# definitions of the data and the benchmark, registries, file names and formats, derived views.
NOT_TUNING = {
    "CASES_FILE", "SETTINGS_FILE", "FORMAT", "RUN_SOURCES",  # files, formats, what a digest covers
    "PAPER_POINTS", "SLIDER_CANDIDATES", "KINDS", "DEFAULT_COUNTS", "SIZE_RANGE", "S0_OFFSET_RANGE", "OUTSIDE",
    "CLEARLY_BETTER",  # the benchmark's definition and scoring (docs/model.md §9.2), not discover's
    "EFFECTS", "CHAIN_EFFECTS", "STRATEGIES", "DESCRIPTIONS", "MODE_FEATURES",  # registries, definitions
    "RUN_RECORD_EVERY", "RUN_KEEP_EVERY",  # a model run sampled as the measured format is (1e-4 s)
    "PATH_POINTS", "PLOT_POINTS", "GAP_MEASURE", "GAP_EXCESS_MEASURE", "LOST_HINT",  # figures, texts
    "CHUNKS_PER_THREAD", "TASK_THREADS",  # a cluster's task sizes (results do not depend on them)
    "RUN_BATCH", "RUN_PROGRESS",  # context variables
    "DEFAULT", "SIGNIFICANCE", "FLOORS",  # the options' defaults and views of them
    "RUNS", "JUDGES", "_FINGERPRINT",  # the lineage of kept results, a digest computed once
    "_SLIDER", "_X5",  # the slider-level feature names, the points along the beam of a mode's shape
}


def test_no_tuning_value_of_discover_lives_outside_its_options():
    """Every module-level constant of the discover package is a definition, a registry, a file's
    name or a view of the options (the list above, each with its reason); a tuning value is a field
    of DiscoverOptions. A new constant fails here until it is one or is listed with its reason."""
    import ast
    from pathlib import Path

    root = Path(dc.__file__).resolve().parent
    found = set()
    for f in root.rglob("*.py"):
        for node in ast.parse(f.read_text(encoding="utf-8")).body:
            targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(node, ast.AnnAssign) else []
            found |= {t.id for t in targets if isinstance(t, ast.Name) and t.id.lstrip("_").isupper()
                      and t.id not in ("__all__",)}
    assert found - NOT_TUNING == set(), sorted(found - NOT_TUNING)


def test_a_single_interval_stops_short_of_a_baseline_that_fits_clearly_worse():
    """The baseline's ensemble is the profile at the baseline value: where it fits worse than the fit
    by more than z², the interval's end on its side is the parabolic crossing (docs/model.md §9.1,
    "One effect"); otherwise the interval stands."""
    from beamslider.discover.stats import short_of_baseline

    z = 1.96
    lo, hi = short_of_baseline((0.99989, 1.15), 1.0375, 1.0, 3.8, 3.8 + 148.5, z)
    assert hi == 1.15 and lo == pytest.approx(1.0375 - 0.0375 * z / math.sqrt(148.5)) and lo > 1.0
    # a parabola through the fit and the baseline crosses Δχ² = z² there
    a = 148.5 / 0.0375 ** 2
    assert a * (lo - 1.0375) ** 2 == pytest.approx(z * z)
    # the baseline above the fit: the upper end moves
    assert short_of_baseline((0.9, 1.01), 0.96, 1.0, 2.0, 102.0, z) == (0.9, pytest.approx(0.96 + 0.04 * z / 10))
    # within z², or an interval that excludes the baseline already, or the fit at the baseline: unchanged
    assert short_of_baseline((0.99, 1.1), 1.03, 1.0, 3.0, 6.0, z) == (0.99, 1.1)
    assert short_of_baseline((1.01, 1.1), 1.03, 1.0, 3.0, 100.0, z) == (1.01, 1.1)
    assert short_of_baseline((0.95, 1.05), 1.0, 1.0, 3.0, 100.0, z) == (0.95, 1.05)
