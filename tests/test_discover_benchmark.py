"""Discover judged at random (docs/model.md §9.2): the cases a seed draws, the one scoring rule, the
figures, a small benchmark end to end (resumed, refused on other settings) and the advised run."""

from __future__ import annotations

import json
import math

import pytest

import beamslider as bs
from beamslider import discover as dc
from beamslider.discover import benchmark as bm
from beamslider.discover.effects import EFFECTS

from conftest import run_cli


def test_a_seed_draws_the_same_cases_and_their_sizes_lie_where_the_rule_says():
    a, b = bm.draw_cases(7), bm.draw_cases(7)
    assert a == b and a != bm.draw_cases(8)
    assert {k: sum(c.kind == k for c in a) for k in bm.KINDS} == {
        "nothing": 4, "single": 12, "pair": 6, "outside": 6, "chain+physics": 2}
    base = bs.Parameters()
    for c in a:
        assert 0.0005 <= abs(c.s0_offset) <= 0.003
        for name, v in c.effects.items():
            steps = abs(v - EFFECTS[name].baseline_value(base)) / bm.threshold(name, base)
            assert 1.5 - 1e-9 <= steps <= 6 + 1e-9, (name, v, steps)
        if c.kind == "outside":
            assert not c.effects and len(c.outside) == 1 and c.outside_kind in bm.OUTSIDE
        if c.kind == "chain+physics":
            assert [bool(EFFECTS[n].chain) for n in c.effects] == [True, False]
        if c.kind == "pair":
            assert len(set(c.effects)) == 2
    assert len({c.noise_seed for c in a}) == len(a)
    with pytest.raises(ValueError, match="unknown case kind"):
        bm.draw_cases(1, {"singles": 3})


def _answer(verdict, named=None, group=()):
    return dict(verdict=verdict, named=named or {}, group=list(group), best=[], advice=None)


def _named(value, lo, hi):
    return dict(value=value, stderr=(hi - lo) / 4, interval=[lo, hi])


def test_one_rule_scores_every_kind():
    single = bm.Case(0, "single", {"friction_coefficient": 0.25})
    assert bm.score_case(single, _answer("named", {"friction_coefficient": _named(0.251, 0.24, 0.26)}))["right"]
    missed = bm.score_case(single, _answer("named", {"friction_coefficient": _named(0.27, 0.26, 0.28)}))
    assert not missed["right"] and missed["outcome"].startswith("interval misses") and \
        missed["covered"] == {"friction_coefficient": False}
    stand_in = bm.score_case(single, _answer("named", {"com_offset": _named(0.0036, 0.0035, 0.0037)}))
    assert not stand_in["right"] and "wrong: com_offset" in stand_in["outcome"]
    extra = bm.score_case(single, _answer("named", {"friction_coefficient": _named(0.25, 0.24, 0.26),
                                                    "tilt": _named(0.003, 0.002, 0.004)}))
    assert not extra["right"]
    assert not bm.score_case(single, _answer("none"))["right"]
    assert not bm.score_case(single, _answer("confounded", group=["friction_coefficient", "com_offset"]))["right"]
    nothing = bm.Case(1, "nothing")
    assert bm.score_case(nothing, _answer("none"))["right"]
    assert bm.score_case(nothing, _answer("unexplained"))["outcome"] == "false alarm (unexplained)"
    outside = bm.Case(2, "outside", outside={"damping_ratio": 0.0015}, outside_kind="beam_damping")
    assert bm.score_case(outside, _answer("unexplained"))["right"]
    assert bm.score_case(outside, _answer("named", {"restitution": _named(0.6, 0.55, 0.65)}))["outcome"] == \
        "stand-in named: restitution"
    conf = bm.score_case(outside, _answer("confounded", group=["tilt", "clearance"]))
    assert not conf["right"] and conf["outcome"].startswith("confounded stand-ins")
    assert not bm.score_case(outside, _answer("none"))["right"]


def _row(i, kind, truth, answer, right, covered, advised=None, outside_kind=""):
    r = dict(index=i, kind=kind, truth=truth, outside={}, outside_kind=outside_kind, label="x", answer=answer,
             score=dict(right=right, outcome="right" if right else "wrong", covered=covered), cpu_s=10.0 * (i + 1))
    if advised:
        r["advised"] = advised
    return r


def test_the_figures_count_coverage_false_alarms_and_the_advised_run():
    rows = [
        _row(0, "single", {"tilt": 0.006}, _answer("named", {"tilt": _named(0.005, 0.004, 0.0058)}), False,
             {"tilt": False}),
        _row(1, "single", {"tilt": 0.006}, _answer("confounded", group=["tilt", "clearance"]), False, {},
             advised=dict(point=[116, 10, 0.3], answer=_answer("named", {"tilt": _named(0.006, 0.005, 0.007)}),
                          score=dict(right=True, outcome="right", covered={"tilt": True}))),
        _row(2, "nothing", {}, _answer("named", {"restitution": _named(0.6, 0.55, 0.65)}), False, {}),
        _row(3, "nothing", {}, _answer("none"), True, {}),
        _row(4, "outside", {}, _answer("confounded", group=["tilt", "clearance"]), False, {},
             outside_kind="beam_damping"),
    ]
    s = bm.summarise(rows)
    assert s["by_kind"]["single"]["first"]["right"] == 0 and s["by_kind"]["single"]["after_advice"]["right"] == 1
    assert s["coverage"] == dict(inside=1, of=2, rate=0.5)
    assert s["false_alarms"] == dict(effects_named=1, cases=2, cases_with_alarm=1)
    assert s["confounded_stand_ins"] == 1 and s["advised_runs"] == 1
    assert s["confusion"]["tilt"] == {"tilt": 2}
    assert s["confusion"]["outside: beam_damping"] == {"confounded: clearance + tilt": 1}
    assert s["cpu_s"]["median"] == 30.0
    md = bm.summary_markdown(s, rows, seed=3, plan=bm.Plan())
    assert "| single | 0/2 (0 % ± 0) | 1/2 (50 % ± 35) |" in md


def test_a_confounded_answer_takes_the_advised_run_and_is_scored_again(monkeypatch):
    """The advised point is synthesised with the same truth and added to the case's runs."""
    calls = []

    class Fake:
        def __init__(self, verdict, named=(), advice=None):
            self.verdict, self.named_effects = verdict, list(named)
            self.parameters = {e: dict(value=0.25, stderr=0.004, interval=[0.24, 0.26]) for e in named}
            self.confounded = dict(group=["friction_coefficient", "com_offset"],
                                   advice=dict(recommended=advice)) if verdict == "confounded" else {}
            self.unresolved, self.rejected, self.features = {}, [], {"speed_early@x": {}}
            self.gap_before = self.gap_after = self.gap_excess_before = self.gap_excess_after = self.chi2_before = 1.0

    def fake(*, measured, **kw):
        calls.append(sorted((m.f_ex, m.a_ex, m.s0) for m in measured))
        if len(calls) == 1:
            return Fake("confounded", advice=dict(f_ex=116.0, a_ex=10.0, s0=0.3, duration_s=2.0, score=5.0))
        return Fake("named", ["friction_coefficient"])

    monkeypatch.setattr(dc, "discover", fake)
    plan = bm.Plan(operating_points=((124.0, 14.0, 0.3),), duration_s=2.0, candidates=("friction_coefficient",))
    row = bm.run_case(bm.Case(0, "single", {"friction_coefficient": 0.25}, noise_seed=5, s0_offset=0.001), plan)
    assert calls == [[(124.0, 14.0, 0.3)], [(116.0, 10.0, 0.3), (124.0, 14.0, 0.3)]]
    assert not row["score"]["right"] and row["advised"]["score"]["right"]
    assert row["advised"]["point"] == [116.0, 10.0, 0.3]
    assert row["truth_fit"]["n"] >= 1 and row["advised"]["truth_fit"]["n"] > row["truth_fit"]["n"]


def test_a_small_benchmark_runs_resumes_and_refuses_other_settings(tmp_path):
    out = tmp_path / "bench"
    args = ["discover-benchmark", "--seed", "3", "--cases", "nothing=1,single=1", "--points", "124,14,0.3",
            "--duration", "4", "--effects", "excitation_gain", "--out", str(out)]
    r = run_cli(*args, cwd=tmp_path, timeout=300)
    assert r.returncode == 0, r.stderr
    rows = [json.loads(l) for l in (out / "cases.jsonl").read_text().splitlines()]
    assert sorted(r["kind"] for r in rows) == ["nothing", "single"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["cases"] == 2 and set(summary["by_kind"]) == {"nothing", "single"}
    assert all(math.isfinite(r["cpu_s"]) for r in rows)
    assert "| kind | right (first answer)" in (out / "summary.md").read_text()
    again = run_cli(*args, cwd=tmp_path)
    assert again.returncode == 0 and "case " not in again.stdout  # every case kept: none run again
    assert (out / "cases.jsonl").read_text().count("\n") == 2
    other = run_cli(*[a if a != "4" else "5" for a in args], cwd=tmp_path)
    assert other.returncode != 0 and "other settings" in other.stderr


def _judged(rows):
    return sorted((json.dumps({k: v for k, v in r.items() if k not in ("cpu_s", "wall_s")}, sort_keys=True)
                   for r in rows))


def test_a_benchmark_on_a_dask_cluster_gives_the_local_rows(tmp_path, cluster):
    """Cases as tasks of a two-worker cluster: the same rows as the local run (times aside)."""
    plan = bm.Plan(operating_points=((124.0, 14.0, 0.3),), duration_s=3.0, candidates=("excitation_gain",))
    counts = {"nothing": 1, "single": 2}
    local = bm.run_benchmark(4, counts=counts, plan=plan, out_dir=tmp_path / "local")
    remote = bm.run_benchmark(4, counts=counts, plan=plan, out_dir=tmp_path / "dask", scheduler=cluster)
    assert _judged(local.rows) == _judged(remote.rows)
    assert len((tmp_path / "dask" / "cases.jsonl").read_text().splitlines()) == 3
    assert json.loads((tmp_path / "dask" / "summary.json").read_text())["cases"] == 3


def test_an_outside_change_the_runs_do_not_show_is_counted_apart():
    """An outside case answered "none" because the baseline passes its test is not visible in the
    plan's runs: listed apart, and the outside figure is also given over the visible ones."""
    rows = [_row(0, "outside", {}, dict(_answer("none"), because="BASELINE_FITS"), False, {}, outside_kind="beam_damping"),
            _row(1, "outside", {}, dict(_answer("none"), because="NEGLIGIBLE_CHANGE"), False, {}, outside_kind="beam_damping"),
            _row(2, "outside", {}, _answer("unexplained"), True, {}, outside_kind="axial_stiffness")]
    s = bm.summarise(rows)
    assert s["outside_not_visible"] == [0]
    assert s["by_kind"]["outside"]["after_advice"]["right"] == 1 and s["by_kind"]["outside"]["after_advice"]["of"] == 3
    assert s["by_kind"]["outside"]["visible"]["right"] == 1 and s["by_kind"]["outside"]["visible"]["of"] == 2
    assert "not visible in the plan's runs" in bm.summary_markdown(s, rows)


def test_a_wrong_answer_is_discovers_miss_only_where_the_truth_fits_clearly_better():
    a = dict(_answer("named", {"com_offset": _named(0.0036, 0.0035, 0.0037)}), n=17, chi2_after=40.0, gap_before=3.0)
    close = dict(a, chi2_after=12.0)
    rows = [_row(0, "single", {"friction_coefficient": 0.22}, a, False, {}),
            _row(1, "single", {"friction_coefficient": 0.22}, close, False, {})]
    for r in rows:
        r["truth_fit"] = dict(chi2=8.0, gap=0.7, z_worst=1.5, n=17)
    s = bm.summarise(rows)
    assert s["wrong_where_the_truth_fits_better"] == [0] and s["wrong_where_the_data_cannot_tell"] == [1]
    # "unexplained": what it offers is the best fit the search made (else the baseline's χ² 153).
    un = dict(_answer("unexplained"), n=17, chi2_after=153.0, gap_before=3.0,
              fits=[dict(effects=["tilt", "excitation_gain"], values={}, chi2=9.0, screened=False, why=[])])
    rows = [_row(2, "single", {"excitation_gain": 1.07}, un, False, {}),
            _row(3, "single", {"excitation_gain": 1.07}, dict(un, fits=[]), False, {})]
    for r in rows:
        r["truth_fit"] = dict(chi2=3.8, gap=0.5, z_worst=1.3, n=17)
    s = bm.summarise(rows)
    assert s["wrong_where_the_data_cannot_tell"] == [2] and s["wrong_where_the_truth_fits_better"] == [3]
    assert s["by_kind"]["single"]["right_or_cannot_tell"]["right"] == 1
    assert s["by_kind"]["single"]["right_or_cannot_tell"]["of"] == 2
    assert "right, or the data cannot tell" in bm.summary_markdown(s, rows)
    # Where the data can tell: the right ones and discover's misses, not the cases they cannot tell.
    right = _row(4, "single", {"excitation_gain": 1.07}, _answer("unexplained"), True, {})
    s = bm.summarise(rows + [right])
    tell = s["by_kind"]["single"]["where_the_data_can_tell"]
    assert (tell["right"], tell["of"], tell["cases"]) == (1, 2, 3), tell
    assert "they tell in 2 of 3 cases" in bm.summary_markdown(s, rows + [right])


def _counting_run_case(calls, judge):
    """A stand-in of ``run_case`` that records the cases it is asked for and answers "none" as ``judge``."""
    def fake_run_case(case, plan, **kw):
        calls.append(case.index)
        return dict(index=case.index, kind=case.kind, truth={}, outside={}, outside_kind="", label="x",
                    answer=_answer("none"), score=dict(right=True, outcome="right", covered={}), cpu_s=1.0,
                    judge=judge)

    return fake_run_case


def test_rows_of_another_judge_are_judged_again_on_resume(tmp_path, monkeypatch):
    plan = bm.Plan(operating_points=((124.0, 14.0, 0.3),), duration_s=2.0, candidates=("excitation_gain",))
    calls = []
    monkeypatch.setattr(bm, "run_case", _counting_run_case(calls, bm.judge_fingerprint()))
    bm.run_benchmark(1, counts={"nothing": 2}, plan=plan, out_dir=tmp_path)
    bm.run_benchmark(1, counts={"nothing": 2}, plan=plan, out_dir=tmp_path)
    assert calls == [0, 1]
    lines = (tmp_path / "cases.jsonl").read_text().splitlines()
    (tmp_path / "cases.jsonl").write_text(lines[0].replace(bm.judge_fingerprint(), "0" * 16) + "\n" + lines[1] + "\n")
    bm.run_benchmark(1, counts={"nothing": 2}, plan=plan, out_dir=tmp_path)
    assert calls == [0, 1, 0]


def test_the_figure_over_cases_that_show_each_change_reads_the_left_out_fits():
    """A change whose absence raises the truth's χ² by no more than CLEARLY_BETTER is not shown on top
    of the others: the per-kind figure over the cases that show each change leaves such cases out."""
    fit = dict(n=17, chi2_after=12.0, gap_before=3.0)
    named = dict(_answer("named", {"tilt": _named(0.006, 0.005, 0.007), "restitution": _named(0.4, 0.38, 0.42)}), **fit)
    tilt_alone = dict(_answer("named", {"tilt": _named(0.006, 0.005, 0.007)}), **fit)
    rows = [_row(0, "pair", {"tilt": 0.006, "restitution": 0.4}, named, True, {"tilt": True, "restitution": True}),
            _row(1, "pair", {"tilt": 0.006, "restitution": 0.39}, tilt_alone, False, {"tilt": True}),
            _row(2, "pair", {"tilt": 0.006, "restitution": 0.39}, dict(_answer("none"), **fit), False, {})]
    rows[0]["truth_fit"] = dict(chi2=10.0, without=dict(tilt=900.0, restitution=40.0))
    rows[1]["truth_fit"] = dict(chi2=10.0, without=dict(tilt=900.0, restitution=10.0 + bm.CLEARLY_BETTER))
    rows[2]["truth_fit"] = dict(chi2=10.0)  # judged before the record: not counted either way
    assert [bm.each_change_shows(r) for r in rows] == [True, False, None]
    s = bm.summarise(rows)["by_kind"]["pair"]
    assert (s["after_advice"]["right"], s["after_advice"]["of"]) == (1, 3)
    assert (s["each_change_shows"]["right"], s["each_change_shows"]["of"], s["each_change_shows"]["cases"]) == (1, 1, 2)
    # After an advised run the final data decide.
    rows[1]["advised"] = dict(answer=rows[1]["answer"], score=rows[1]["score"],
                              truth_fit=dict(chi2=12.0, without=dict(tilt=950.0, restitution=30.0)))
    assert bm.each_change_shows(rows[1]) is True
    assert "right where each change shows" in bm.summary_markdown(bm.summarise(rows), rows)


def test_the_truth_left_out_of_a_single_is_the_baseline_discover_tested(tmp_path):
    """Independent reference: for one hidden effect, the truth with it left out is the baseline, so
    its χ² equals the χ² of the baseline's test that discover made on the same data; and a row
    completed later from runs synthesised again gives the same truth's χ², bitwise."""
    plan = bm.Plan(operating_points=((124.0, 14.0, 0.3),), duration_s=3.0, candidates=("excitation_gain",))
    case = bm.Case(0, "single", {"excitation_gain": 1.15}, noise_seed=5, s0_offset=0.001)
    row = bm.run_case(case, plan, advice=False)
    tf = row["truth_fit"]
    assert set(tf["without"]) == {"excitation_gain"}
    assert tf["without"]["excitation_gain"] == pytest.approx(row["answer"]["chi2_before"], rel=1e-9)
    assert tf["without"]["excitation_gain"] - tf["chi2"] > bm.CLEARLY_BETTER
    old = json.loads(json.dumps(row))
    del old["truth_fit"]["without"]
    again = bm._with_left_out(old, case, plan)
    assert again["truth_fit"] == tf and again["answer"] == row["answer"]


def test_rows_of_a_judge_entered_in_the_lineage_are_kept(tmp_path, monkeypatch):
    """A row of an older judge that the lineage enters as judging the same (checked by judging rows
    again) is kept on resume; an unlisted judge's row is judged again."""
    from beamslider.discover import lineage

    plan = bm.Plan(operating_points=((124.0, 14.0, 0.3),), duration_s=2.0, candidates=("excitation_gain",))
    calls = []
    monkeypatch.setattr(bm, "run_case", _counting_run_case(calls, "0" * 16))
    bm.run_benchmark(1, counts={"nothing": 2}, plan=plan, out_dir=tmp_path)
    assert calls == [0, 1]
    bm.run_benchmark(1, counts={"nothing": 2}, plan=plan, out_dir=tmp_path)
    assert calls == [0, 1, 0, 1]
    monkeypatch.setattr(lineage, "JUDGES", {bm.judge_fingerprint(): ("0" * 16, "checked")})
    bm.run_benchmark(1, counts={"nothing": 2}, plan=plan, out_dir=tmp_path)
    assert calls == [0, 1, 0, 1]
