"""Drift tables and drift laws are checked as maps are (docs/model.md §6.3, §8): a table without
rows, a newer version, a table made with other parameters than the run's, a row off the beam and a
law with an impossible neighbour count are each refused in one line, by the core's readers (one
per format) and, for the parameters, by the predictor."""

import json
from pathlib import Path

import pytest

import beamslider
from beamslider import _core
from beamslider.superslow import DEFAULT_LAW_PATH, load_drift_law, predict, read_drift_table
from conftest import run_cli

TABLE = Path(__file__).resolve().parent.parent / "docs" / "results" / "superslow" / "drift" / "drift_114Hz_4ms2.jsonl"


def _table(tmp_path, *, header=None, rows=None, name="t.jsonl"):
    lines = TABLE.read_text(encoding="utf-8").splitlines()
    h = json.loads(lines[0])
    h.update(header or {})
    body = lines[1:] if rows is None else rows(lines[1:])
    path = tmp_path / name
    path.write_text("\n".join([json.dumps(h)] + body) + "\n", encoding="utf-8")
    return path


def _one_line_error(r, *words):
    assert r.returncode == 1, (r.returncode, r.stderr[-2000:])
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])


def test_the_shipped_table_still_reads():
    t = read_drift_table(TABLE)
    assert len(t.s) > 10 and t.f_ex == 114.0


def test_a_table_without_rows_is_refused(tmp_path):
    path = _table(tmp_path, rows=lambda rows: [])
    with pytest.raises(ValueError, match="no rows"):
        read_drift_table(path)
    r = run_cli("predict", "--drift", str(path), "--f-ex", "114", "--a-ex", "4", "--out", "p", cwd=tmp_path)
    _one_line_error(r, "no rows")


def test_a_newer_table_version_is_refused(tmp_path):
    path = _table(tmp_path, header={"version": 7})
    with pytest.raises(ValueError, match="version 7: newer than this build"):
        read_drift_table(path)


def test_a_table_of_other_parameters_than_the_runs_is_refused(tmp_path):
    t = read_drift_table(TABLE)
    assert predict(f_ex=114, a_ex=4, s0=0.3, drift=t, build_up=0).behaviour  # the table's own model
    other = beamslider.Parameters(friction_coefficient=0.3)
    with pytest.raises(ValueError, match="friction_coefficient = 0.2"):
        predict(other, f_ex=114, a_ex=4, s0=0.3, drift=t)
    finer = beamslider.Parameters(dt_s=beamslider.Parameters().dt_s / 2)  # how a run is computed, not its model
    assert predict(finer, f_ex=114, a_ex=4, s0=0.3, drift=t, build_up=0).behaviour
    (tmp_path / "p.toml").write_text("friction_coefficient = 0.3\n", encoding="utf-8")
    r = run_cli("predict", "--drift", str(TABLE), "--params", "p.toml", "--f-ex", "114", "--a-ex", "4", "--out", "p",
                cwd=tmp_path)
    _one_line_error(r, "friction_coefficient")


def test_a_row_off_the_beam_is_refused(tmp_path):
    def off(rows):
        r = json.loads(rows[3])
        r["s"] = 5.0
        return rows[:3] + [json.dumps(r)] + rows[4:]

    path = _table(tmp_path, rows=off)
    with pytest.raises(ValueError, match=r"line 5: s = 5 lies off the beam"):
        read_drift_table(path)


def test_a_law_with_an_impossible_neighbour_count_is_refused(tmp_path):
    d = json.loads(DEFAULT_LAW_PATH.read_text(encoding="utf-8"))
    d["k"] = 1000000
    path = tmp_path / "law.json"
    path.write_text(json.dumps(d), encoding="utf-8")
    with pytest.raises(ValueError, match="k = 1000000"):
        load_drift_law(path)
    with pytest.raises(ValueError, match="at most 64 neighbours"):
        _core.DriftLaw(d)
    r = run_cli("predict", "--law", str(path), "--f-ex", "124", "--a-ex", "14", "--out", "p", cwd=tmp_path)
    _one_line_error(r, "k = 1000000")
