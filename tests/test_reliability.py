"""Reliability (docs/guide/reliability.md): bad input tried on purpose against the Python API,
the ``beamslider`` command and the file readers; faults (blow-up, solver cap, failing map
points, SIGTERM/SIGINT during a map); property tests of the readers (hypothesis); determinism.

Every bad input must give an exception of the documented class (``ValueError`` naming the
field, file or line; ``OSError`` for files that cannot be read; ``TypeError`` for a wrong kind
of object) — on the command line a one-line message, a non-zero exit and no traceback — and
must overwrite nothing."""

import json
import math
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

import beamslider
from beamslider import MeasurementFormatError, Parameters, cli, read_measurement
from beamslider.maps import RESULTS_FILE, map_config_toml, read_map
from beamslider.measurement import write_measurement
from conftest import cli_command, default_signals, run_cli, wait_for_lines

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

NAME = "Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt"

# --- the API --------------------------------------------------------------------------------

S = dict(f_ex=124.0, a_ex=14.0, t_end=0.01)  # a valid short run


def _sim(**kw):
    return lambda: beamslider.simulate(**{**S, **kw})


API_CASES = [
    # Parameters: wrong types, NaN/inf, out of range, physically impossible, unknown names
    ("length_m str", lambda: Parameters(length_m="abc"), ValueError, ["length_m"]),
    ("length_m None", lambda: Parameters(length_m=None), ValueError, ["length_m"]),
    ("length_m list", lambda: Parameters(length_m=[0.14]), ValueError, ["length_m"]),
    ("length_m nan", lambda: Parameters(length_m=math.nan), ValueError, ["length_m"]),
    ("length_m inf", lambda: Parameters(length_m=math.inf), ValueError, ["length_m"]),
    ("length_m 0", lambda: Parameters(length_m=0.0), ValueError, ["length_m"]),
    ("thickness > L", lambda: Parameters(thickness_m=0.2), ValueError, ["gap_ratio"]),
    ("spacing > L", lambda: Parameters(contact_spacing_m=0.2), ValueError, ["contact_spacing_m"]),
    ("gap_ratio < 1", lambda: Parameters(gap_ratio=0.9), ValueError, ["gap_ratio"]),
    ("restitution 1.5", lambda: Parameters(restitution=1.5), ValueError, ["restitution"]),
    ("friction < 0", lambda: Parameters(friction_coefficient=-0.1), ValueError, ["friction_coefficient"]),
    ("k_r nan", lambda: Parameters(k_r_nm_per_rad=math.nan), ValueError, ["k_r_nm_per_rad"]),
    ("slider mass -1", lambda: Parameters(slider_mass_kg=-1.0), ValueError, ["slider_mass_kg"]),
    ("n_modes 2.5", lambda: Parameters(n_modes=2.5), ValueError, ["n_modes"]),
    ("n_modes str", lambda: Parameters(n_modes="5"), ValueError, ["n_modes"]),
    ("n_modes bool", lambda: Parameters(n_modes=True), ValueError, ["n_modes"]),
    ("n_modes 0", lambda: Parameters(n_modes=0), ValueError, ["n_modes"]),
    ("n_modes 99", lambda: Parameters(n_modes=99), ValueError, ["n_modes"]),
    ("dt 0", lambda: Parameters(dt_s=0.0), ValueError, ["dt_s"]),
    ("solver name", lambda: Parameters(contact_solver="magic"), ValueError, ["contact_solver"]),
    ("solver int", lambda: Parameters(contact_solver=3), ValueError, ["contact_solver"]),
    ("solver with newline (named the next key)", lambda: Parameters(contact_solver="fast\nx"), ValueError, ["contact_solver"]),
    ("length_m newline", lambda: Parameters(length_m="\n"), ValueError, ["length_m"]),
    ("max_iter 0", lambda: Parameters(solver_max_iter=0), ValueError, ["solver_max_iter"]),
    ("unknown key", lambda: Parameters.from_dict({"lenght_m": 0.1}), ValueError, ["lenght_m"]),
    ("unknown kwarg", lambda: Parameters(lenght_m=0.1), TypeError, ["lenght_m"]),
    ("toml wrong type", lambda: Parameters.from_toml_text('length_m = "x"\n'), ValueError, ["length_m"]),
    ("toml garbled", lambda: Parameters.from_toml_text("length_m = = 1\n"), ValueError, ["line 1"]),
    ("toml unknown", lambda: Parameters.from_toml_text("bogus = 1\n"), ValueError, ["bogus"]),
    ("toml duplicate", lambda: Parameters.from_toml_text("dt_s = 1e-5\ndt_s = 1e-5\n"), ValueError, ["dt_s"]),
    ("toml missing file", lambda: Parameters.from_toml("/nonexistent/p.toml"), OSError, ["/nonexistent/p.toml"]),
    ("params wrong object", lambda: beamslider.simulate("p.toml", **S), TypeError, ["params"]),
    # simulate: excitation, positions, durations, options
    ("f_ex str", _sim(f_ex="abc"), ValueError, ["f_ex"]),
    ("f_ex None", _sim(f_ex=None), ValueError, ["f_ex"]),
    ("f_ex nan", _sim(f_ex=math.nan), ValueError, ["f_ex"]),
    ("f_ex < 0", _sim(f_ex=-1.0), ValueError, ["f_ex"]),
    ("f_ex beyond dt", _sim(f_ex=1e6), ValueError, ["f_ex", "dt_s"]),
    ("a_ex < 0", _sim(a_ex=-1.0), ValueError, ["a_ex"]),
    ("a_ex inf", _sim(a_ex=math.inf), ValueError, ["a_ex"]),
    ("s0 off the beam", _sim(s0=0.99), ValueError, ["s0"]),
    ("s0 nan", _sim(s0=math.nan), ValueError, ["s0"]),
    ("s0 list", _sim(s0=[0.3]), ValueError, ["s0"]),
    ("t_end < 0", _sim(t_end=-1.0), ValueError, ["t_end"]),
    ("t_end nan", _sim(t_end=math.nan), ValueError, ["t_end"]),
    ("t_end str", _sim(t_end="1"), ValueError, ["t_end"]),
    ("record_every 0", _sim(record_every=0), ValueError, ["record_every"]),
    ("record_every 2.5", _sim(record_every=2.5), ValueError, ["record_every"]),
    ("record_every inf", _sim(record_every=math.inf), ValueError, ["record_every"]),
    ("record_every str", _sim(record_every="10"), ValueError, ["record_every"]),
    ("model name", _sim(model="xyz"), ValueError, ["model"]),
    ("s_pcs without pcs", _sim(s_pcs=0.2), ValueError, ["s_pcs"]),
    ("s_pcs off [0, 1]", _sim(model="pcs", s_pcs=5.0), ValueError, ["s_pcs"]),
    ("dt too large", _sim(dt=1e-3), ValueError, ["dt_s", "highest"]),
    ("k_r denormal (was a hang)", lambda: beamslider.simulate(Parameters(k_r_nm_per_rad=1e-321), **S), ValueError,
     ["k_r_nm_per_rad", "too small"]),
    # manifold, envelope, classification
    ("manifold periods 0", lambda: beamslider.super_slow_manifold(f_ex=124, a_ex=14, s=[0.3], periods=0), ValueError, ["periods"]),
    ("manifold record > periods", lambda: beamslider.super_slow_manifold(f_ex=124, a_ex=14, s=[0.3], periods=2, record=5), ValueError, ["record"]),
    ("manifold empty s", lambda: beamslider.super_slow_manifold(f_ex=124, a_ex=14, s=[]), ValueError, ["s"]),
    ("manifold s decreasing", lambda: beamslider.super_slow_manifold(f_ex=124, a_ex=14, s=[0.3, 0.2]), ValueError, ["s"]),
    ("manifold s nan", lambda: beamslider.super_slow_manifold(f_ex=124, a_ex=14, s=[math.nan]), ValueError, ["s_values"]),
    ("manifold f_ex str", lambda: beamslider.super_slow_manifold(f_ex="x", a_ex=14, s=[0.3]), ValueError, ["f_ex"]),
    ("envelope lengths", lambda: beamslider.envelope([0, 1, 2], [0, 1]), ValueError, ["same length"]),
    ("envelope uneven t", lambda: beamslider.envelope([0, 1, 3], [0, 1, 2]), ValueError, ["uniformly"]),
    ("envelope window 0", lambda: beamslider.envelope([0, 1, 2], [0, 1, 2], window=0.0), ValueError, ["window"]),
    ("classify lengths", lambda: beamslider.classify([0, 1], [0.3], [0.1, 0.1]), ValueError, ["same length"]),
    # operating maps: empty grids, duplicates, NaN, impossible positions, threads
    ("map empty f_ex", lambda: beamslider.operating_map(f_ex=[], a_ex=6.0, t_end=0.1), ValueError, ["f_ex"]),
    ("map duplicate f_ex", lambda: beamslider.operating_map(f_ex=[120, 120], a_ex=6.0, t_end=0.1), ValueError, ["f_ex_hz", "twice"]),
    ("map nan a_ex", lambda: beamslider.operating_map(f_ex=120, a_ex=[math.nan], t_end=0.1), ValueError, ["a_ex_m_s2"]),
    ("map s0 off the beam", lambda: beamslider.operating_map(f_ex=120, a_ex=6.0, s0=0.99, t_end=0.1), ValueError, ["grid.s0"]),
    ("map t_end 0", lambda: beamslider.operating_map(f_ex=120, a_ex=6.0, t_end=0.0), ValueError, ["duration_s"]),
    ("map threads 0", lambda: beamslider.operating_map(f_ex=120, a_ex=6.0, t_end=0.1, threads=0), ValueError, ["threads"]),
    ("map threads 1.5", lambda: beamslider.operating_map(f_ex=120, a_ex=6.0, t_end=0.1, threads=1.5), ValueError, ["threads"]),
    ("map criteria unknown", lambda: beamslider.operating_map(f_ex=120, a_ex=6.0, t_end=0.1, criteria={"bogus": 1}), ValueError, ["bogus"]),
    ("map results missing", lambda: read_map("/nonexistent/map.jsonl"), OSError, ["/nonexistent/map.jsonl"]),
]


@pytest.mark.parametrize("name,call,exc,words", API_CASES, ids=[c[0] for c in API_CASES])
def test_api_bad_input(name, call, exc, words):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(exc) as e:
            call()
    msg = str(e.value)
    for w in words:
        assert w in msg, msg
    if not msg.startswith("cannot read parameters"):  # TOML errors quote the line with a caret under it
        assert "\n" not in msg.strip(), msg


# --- measured files -------------------------------------------------------------------------

GOOD = "".join(f"{i * 1e-4:.4f}\t{0.001 * math.sin(i / 10):.8e}\t0.3\n" for i in range(50))

MEASUREMENT_CASES = [
    ("empty", "", [": fewer than two data lines"]),
    ("header only", "Time VelBeam RelSliderPos\n", ["fewer than two"]),
    ("one line", "0 1 0.3\n", ["fewer than two"]),
    ("two columns", "0 1 0.3\n0.0001 1\n", [":2:", "3 columns"]),
    ("four columns", "0 1 0.3\n0.0001 1 0.3 7\n", [":2:", "3 columns"]),
    ("non-numeric", "0 1 0.3\n0.0001 x 0.3\n", [":2:", "non-numeric"]),
    ("nan", "0 1 0.3\n0.0001 nan 0.3\n", [":2:", "non-finite"]),
    ("inf", "0 1 0.3\n0.0001 1 inf\n", [":2:", "non-finite"]),
    ("overflow", "0 1 0.3\n0.0001 1e400 0.3\n", [":2:", "non-finite"]),
    ("velocity overflows", "0 1e308 0.3\n0.0001 1e308 0.3\n0.0002 1e308 0.3\n", ["too large"]),
    ("time decreasing", "0.0002 1 0.3\n0.0001 1 0.3\n", [":2:", "does not increase"]),
    ("time repeated", "0 1 0.3\n0.0001 1 0.3\n0.0001 1 0.3\n", [":3:", "does not increase"]),
    ("gap", GOOD + "1.0 1 0.3\n", [":51:", "sampling interval"]),
    ("garbage line", GOOD[:200] + "\x00\x01\x02garbage\n" + GOOD[200:], [":8:"]),
    ("truncated last line", GOOD + "0.0050\t1.2", [":51:", "3 columns"]),
    ("second header", "t v s\n0 1 0.3\nt v s\n", [":3:"]),
    ("tiny time step", "0 1 0.3\n5e-324 1 0.3\n1e-323 1 0.3\n", None),  # valid, must not overflow
]


@pytest.mark.parametrize("name,text,words", MEASUREMENT_CASES, ids=[c[0] for c in MEASUREMENT_CASES])
def test_measurement_bad_files(tmp_path, name, text, words):
    path = tmp_path / NAME
    path.write_text(text, encoding="utf-8")
    if words is None:
        m = read_measurement(path)
        assert np.all(np.isfinite(m.w))
        return
    with pytest.raises(MeasurementFormatError) as e:
        read_measurement(path)
    msg = str(e.value)
    assert str(path) in msg
    for w in words:
        assert w in msg, msg


def test_measurement_unreadable_and_binary(tmp_path):
    with pytest.raises(OSError):
        read_measurement(tmp_path / "missing.txt")
    with pytest.raises(OSError):
        read_measurement(tmp_path)  # a folder
    path = tmp_path / "binary.txt"
    path.write_bytes(bytes(range(256)) * 8)
    with pytest.raises(MeasurementFormatError):
        read_measurement(path)


def test_measurement_bom_crlf_and_tabs_are_read(tmp_path):
    path = tmp_path / NAME
    path.write_bytes(("\ufeff" + GOOD.replace("\n", "\r\n")).encode("utf-8"))
    m = read_measurement(path)
    assert len(m.t) == 50 and m.dt == pytest.approx(1e-4)


def _measurement_text(data):
    return "".join(f"{a!r}\t{b!r}\t{c!r}\n" for a, b, c in data)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(blob=st.one_of(
    st.binary(max_size=400),
    st.text(alphabet=st.sampled_from(list("0123456789.eE+-,; \t\n#%naifNAIF")), max_size=400).map(str.encode),
    st.lists(st.tuples(st.floats(), st.floats(), st.floats()), max_size=12).map(_measurement_text).map(str.encode),
))
def test_measurement_reader_never_fails_unexpectedly(tmp_path, blob):
    """Any bytes: a Measurement with finite, consistent arrays or MeasurementFormatError."""
    path = tmp_path / "fuzz.txt"
    path.write_bytes(blob)
    try:
        m = read_measurement(path)
    except MeasurementFormatError as e:
        assert str(path) in str(e)
        return
    n = len(m.t)
    assert n >= 2 and len(m.velocity) == len(m.s) == len(m.w) == n
    assert np.all(np.diff(m.t) > 0)
    assert np.all(np.isfinite(m.t)) and np.all(np.isfinite(m.velocity)) and np.all(np.isfinite(m.s))
    assert np.all(np.isfinite(m.w))


@settings(max_examples=150, deadline=None)
@given(st.dictionaries(
    st.sampled_from([f.name for f in __import__("dataclasses").fields(Parameters)] + ["bogus"]),
    st.one_of(st.floats(), st.integers(-2**70, 2**70), st.text(max_size=5), st.booleans(), st.none()),
    max_size=4,
))
def test_parameters_accept_valid_or_raise_valueerror(values):
    """Random field values: valid Parameters (which round-trip through TOML) or a one-line
    ValueError naming one of the fields given."""
    try:
        p = Parameters.from_dict(values)
    except ValueError as e:
        msg = str(e)
        assert "\n" not in msg.strip() and any(k in msg for k in values), msg
        return
    assert Parameters.from_toml_text(p.toml_text()) == p


# --- the command line -----------------------------------------------------------------------

SENTINEL = "KEEP: an earlier result\n"

CLI_CASES = [
    (["simulate", "--f-ex", "nan"], ["--f-ex"]),
    (["simulate", "--f-ex", "abc"], ["--f-ex"]),
    (["simulate", "--f-ex", "1e6"], ["f_ex_hz"]),
    (["simulate", "--a-ex", "-1"], ["a_ex_m_s2"]),
    (["simulate", "--a-ex", "inf"], ["a_ex_m_s2"]),
    (["simulate", "--s0", "0.99"], ["s0"]),
    (["simulate", "--s0", "nan"], ["s0"]),
    (["simulate", "--t-end", "-1"], ["--t-end"]),
    (["simulate", "--t-end", "nan"], ["--t-end"]),
    (["simulate", "--record-every", "0"], ["--record-every"]),
    (["simulate", "--record-every", "2.5"], ["--record-every"]),
    (["simulate", "--dt", "1e-3"], ["dt_s"]),
    (["simulate", "--model", "pcs", "--s-pcs", "5"], ["s_pcs"]),
    (["simulate", "--model", "xyz"], ["--model"]),
    (["simulate", "--solver", "magic"], ["--solver"]),
    (["simulate", "--window", "0"], ["--window"]),
    (["simulate", "--bogus"], ["--bogus"]),
    (["manifold", "--manifold-s", "0.3,0.2"], ["s"]),
    (["manifold", "--manifold-s", "a:b"], ["--manifold-s"]),
    (["manifold", "--manifold-periods", "2", "--manifold-record", "5"], ["record"]),
    (["map", "--f-ex", "120,120"], ["f_ex_hz", "twice"]),
    (["map", "--f-ex", ""], ["--f-ex"]),
    (["map", "--f-ex", "130:100:2"], ["--f-ex"]),
    (["map", "--f-ex", "100:130:1e-12"], ["--f-ex", "at most"]),
    (["manifold", "--manifold-s", "0.1:0.5:1e-15"], ["--manifold-s", "at most"]),
    (["map", "--s0", "0.99"], ["grid.s0"]),
    (["map", "--a-ex", "nan"], ["a_ex_m_s2"]),
    (["map", "--threads", "0"], ["--threads"]),
    (["map", "--config", "/nonexistent/map.toml"], ["/nonexistent/map.toml"]),
    (["map", "--config", "{cfg}", "--f-ex", "120"], ["--config"]),
    (["compare", "{missing}"], ["missing.txt"]),
    (["plot"], ["nothing to plot"]),
    (["plot", "{garbled_json}"], ["garbled.json"]),
    (["plot", "{list_json}"], ["list.json"]),
    (["plot", "{typed_json}"], ["typed.json", "params_toml"]),
    (["plot", "{garbled_csv}"], ["badcols.csv"]),
    (["plot", "--measurement", "{bad_meas}"], ["bad.txt:2"]),
]

PARAM_FILES = {
    "gap_ratio = 0.9\n": ["gap_ratio"],
    'length_m = "long"\n': ["length_m"],
    "lenght_m = 0.14\n": ["lenght_m"],
    "n_modes = 2.5\n": ["n_modes"],
    "length_m = = 1\n": ["line 1"],
    "dt_s = 1e-3\n": ["dt_s"],
    "\xff\xfe garbage": ["p.toml"],
}


def _files(tmp_path):
    (tmp_path / "garbled.json").write_text("{not json")
    (tmp_path / "list.json").write_text("[1, 2]")
    (tmp_path / "typed.json").write_text('{"kind": "simulation", "params_toml": 5}')
    (tmp_path / "badcols.csv").write_text("t_s,w_4L7_m,s,xC_m,zC_m,beta_rad\n0,1,2\n")
    (tmp_path / "bad.txt").write_text("0 1 0.3\n0.0001 x 0.3\n")
    (tmp_path / "cfg.toml").write_text("[grid]\nf_ex_hz = 120.0\na_ex_m_s2 = 6.0\n")
    return {"missing": str(tmp_path / "missing.txt"), "garbled_json": str(tmp_path / "garbled.json"),
            "list_json": str(tmp_path / "list.json"),
            "typed_json": str(tmp_path / "typed.json"), "garbled_csv": str(tmp_path / "badcols.csv"),
            "bad_meas": str(tmp_path / "bad.txt"), "cfg": str(tmp_path / "cfg.toml")}


def _main(argv, capsys):
    """Run the command in-process; argparse errors exit with status 2."""
    try:
        code = cli.main(argv)
    except SystemExit as e:
        code = e.code
    err = capsys.readouterr().err
    return code, err


def test_cli_bad_input_in_process(tmp_path, capsys, monkeypatch):
    """Every case: non-zero exit, one-line message naming the field/file/line, no traceback, and
    an earlier result in the output folder left as it was."""
    monkeypatch.chdir(tmp_path)
    files = _files(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    keep = out / "fs_124Hz_14ms2_s0_0p3.csv"
    cases = [([a.format(**files) for a in args], words) for args, words in CLI_CASES]
    for i, (body, words) in enumerate(PARAM_FILES.items()):
        pfile = tmp_path / f"p{i}.toml"
        pfile.write_bytes(body.encode("latin-1"))
        words = [w.replace("p.toml", pfile.name) for w in words]
        cases.append((["simulate", "--params", str(pfile)], words))
        cases.append((["map", "--params", str(pfile), "--f-ex", "120", "--a-ex", "6"], words))
    for args, words in cases:
        keep.write_text(SENTINEL)
        short = ["--t-end", "0.01"] if args[0] in ("simulate", "map") and "--config" not in args else []
        code, err = _main([*args, "--out", str(out), "--no-progress", *short], capsys)
        assert code not in (0, None), (args, err)
        assert "Traceback" not in err, (args, err)
        last = [ln for ln in err.splitlines() if ln.strip()][-1]
        for w in words:
            assert w in last, (args, last)
        assert keep.read_text() == SENTINEL, args
        assert not (out / RESULTS_FILE).exists() and not (out / "map.toml").exists(), args


def test_cli_bad_input_in_a_subprocess(tmp_path):
    """The real console script: exit status 1 (2 for argparse) and no traceback."""
    for args, code in ((["simulate", "--s0", "0.99", "--t-end", "0.01"], 1), (["simulate", "--t-end", "x"], 2),
                       (["map", "--f-ex", "120,120"], 1)):
        p = run_cli(*args, "--out", str(tmp_path / "o"), cwd=tmp_path)
        assert p.returncode == code, p.stderr
        assert "Traceback" not in p.stderr


def test_cli_map_refusal_overwrites_nothing(tmp_path, capsys):
    out = tmp_path / "m"
    args = ["map", "--f-ex", "120", "--a-ex", "6", "--t-end", "0.2", "--no-progress", "--out", str(out)]
    assert _main(args, capsys)[0] == 0
    results, toml = (out / RESULTS_FILE).read_text(), (out / "map.toml").read_text()
    code, err = _main(args, capsys)  # exists, no --resume
    assert code == 1 and "exists" in err
    code, err = _main([*args[:-2], "--t-end", "0.3", "--resume", "--out", str(out)], capsys)  # other settings
    assert code == 1 and "other settings" in err
    (out / RESULTS_FILE).write_text(results + "garbled line\n")
    code, err = _main([*args, "--resume"], capsys)
    assert code == 1 and f"{RESULTS_FILE}:3" in err
    assert (out / RESULTS_FILE).read_text() == results + "garbled line\n"
    assert (out / "map.toml").read_text() == toml


# --- faults ---------------------------------------------------------------------------------


def test_blow_up_stops_with_status_and_time():
    with pytest.warns(RuntimeWarning, match="stopped at t ="):
        r = beamslider.simulate(f_ex=124, a_ex=1e6, t_end=0.5)
    assert r.status in ("diverged", "left_beam")
    assert 0 < r.t[-1] < 0.5 and f"{r.final_state['t_s']:.6f}" in r.message or "stopped at t" in r.message
    assert np.all(np.isfinite(r.w)) and np.all(np.isfinite(r.s))


def test_solver_cap_hits_are_reported():
    p = Parameters(contact_solver="reference", solver_max_iter=1)
    with pytest.warns(RuntimeWarning, match="iteration cap"):
        r = beamslider.simulate(p, f_ex=124, a_ex=14, t_end=0.2)
    assert r.counters["cap_hits"] > 0 and r.completed


def test_map_with_failing_points_finishes_the_others(tmp_path, capsys):
    t = beamslider.operating_map(f_ex=[120.0, 124.0], a_ex=[6.0, 1e6], t_end=0.3, out=tmp_path / "api")
    assert list(t["status"][:2]) == ["completed"] * 2
    assert set(t["status"][2:]) <= {"diverged", "left_beam"}
    assert all(t["behaviour"][2:] == "undetermined")
    assert len(beamslider.maps.failures(t)) == 2
    # NaN features of the failed rows are read back from the results file.
    again = read_map(tmp_path / "api")
    assert list(again["status"]) == list(t["status"])
    code, err = _main(["map", "--f-ex", "120,124", "--a-ex", "6,1e6", "--t-end", "0.3", "--no-progress",
                       "--out", str(tmp_path / "cli")], capsys)
    assert code == cli.EXIT_FAULT, err
    assert "2 of 4 points failed" in err and "#2 f_ex = 120 Hz, a_ex = 1e+06" in err


def _rows(path):
    rows = [json.loads(ln) for ln in Path(path).read_text().splitlines()[1:] if ln.strip().endswith("}")]
    for r in rows:
        r.pop("wall_time_s")
    return sorted(rows, key=lambda r: r["index"])


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT, signal.SIGHUP, signal.SIGKILL])
def test_signal_during_cli_map_then_resume(tmp_path, sig):
    """Kill a real `beamslider map` with SIGTERM / SIGINT (Ctrl-C) / SIGHUP / SIGKILL, resume: every
    point exactly once, the same rows as an uninterrupted map, no partial file."""
    grid = ["--f-ex", "110:130:2", "--a-ex", "6,14", "--t-end", "3", "--no-progress"]
    full = tmp_path / "full"
    beamslider.operating_map(f_ex=list(np.arange(110.0, 131.0, 2.0)), a_ex=[6.0, 14.0], t_end=3.0, out=full, threads=2)
    out = tmp_path / "killed"
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.Popen([*cli_command(), "map", *grid, "-j", "1", "--out", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env, text=True, preexec_fn=default_signals)
    results = out / RESULTS_FILE
    wait_for_lines(results, 4)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode != 0
    assert "Traceback" not in err
    before = _rows(results)
    assert 0 < len(before) < 22
    assert not [f for f in out.iterdir() if "partial" in f.name]
    r = run_cli("map", *grid, "-j", "2", "--resume", "--out", str(out), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    after = _rows(results)
    assert [x["index"] for x in after] == list(range(22))
    assert after == _rows(full / RESULTS_FILE)


# --- determinism ----------------------------------------------------------------------------


def test_identical_inputs_give_bitwise_identical_results():
    a = beamslider.simulate(f_ex=124, a_ex=14, t_end=0.3, record_every=3)
    b = beamslider.simulate(f_ex=124, a_ex=14, t_end=0.3, record_every=3)
    for name, col in a.columns().items():
        assert col.tobytes() == b.columns()[name].tobytes(), name
    assert a.counters == b.counters and a.final_state == b.final_state
