"""Interrupted extensions and overwrites (docs/guide/reliability.md, "Signals and overwrites"): a map's
settings change only when its extension completes, and the same --extend-to finishes an interrupted
one; ``simulate`` keeps an earlier run's files until the new ones are complete, takes the folder's
one-writer lock, removes what killed runs left half-written, and keeps a consistent folder when its
manifold fails; ``map``, ``study`` and ``design`` refuse an earlier run's results naming --resume
and --force, and --force replaces them; the messages say what was kept and how to go on."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import beamslider
from beamslider import _toml
from beamslider.maps import read_map
from conftest import cli_command, default_signals, run_cli


def _err_line(r):
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, r.stderr
    return lines[0]


# --- maps: extension, resume and force -----------------------------------------------------------


def _rows(folder):
    got = {}
    for ln in (folder / "map.jsonl").read_text().splitlines()[1:]:
        d = json.loads(ln)
        d.pop("wall_time_s")
        got[d["index"]] = d
    return got


def test_an_interrupted_extension_changes_no_settings_and_the_same_extend_to_finishes_it(tmp_path, monkeypatch):
    grid = ["--f-ex", "120,124", "--a-ex", "14", "-j", "1"]
    for name in ("ex", "part"):
        r = run_cli("map", *grid, "--t-end", "1", "--out", name, cwd=tmp_path)
        assert r.returncode == 0, r.stderr
    out = tmp_path / "ex"
    toml_before = (out / "map.toml").read_text()
    # Ctrl-C during the extension (as the progress callback sees it): map.toml keeps its duration.
    import beamslider.maps.compute as compute

    def stop_at_once(results, bar):
        def watch(done, total):
            raise KeyboardInterrupt
        return watch

    monkeypatch.setattr(compute, "_watching", stop_at_once)
    cfg = _toml.loads(toml_before)
    cfg["duration_s"] = 4.0
    with pytest.raises(KeyboardInterrupt):
        compute.run_map_config(_toml.dumps(cfg), out=out, extend=True, threads=1, report=False)
    monkeypatch.undo()
    assert (out / "map.toml").read_text() == toml_before, "map.toml changes only when the extension completes"
    r = run_cli("map", "--out", "ex", "--extend-to", "4", "-j", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert float(_toml.loads((out / "map.toml").read_text())["duration_s"]) == 4.0
    # Bitwise the rows of a 4-s map from rest (but the wall time).
    assert run_cli("map", *grid, "--t-end", "4", "--out", "ref", cwd=tmp_path).returncode == 0
    assert _rows(out) == _rows(tmp_path / "ref")
    # A map killed after the first of its two continuations (the results file as the core leaves
    # it: the header of the extension, the 1-s rows, one 4-s row; map.toml of the 1-s map).
    part = tmp_path / "part"
    lines = (part / "map.jsonl").read_text().splitlines()
    header = (out / "map.jsonl").read_text().splitlines()[0]
    first = next(ln for ln in (out / "map.jsonl").read_text().splitlines()[1:] if json.loads(ln)["index"] == 0
                 and json.loads(ln)["t_end_s"] > 3)
    (part / "map.jsonl").write_text("\n".join([header, *lines[1:], first]) + "\n")
    r = run_cli("map", *grid, "--t-end", "1", "--out", "part", "--resume", cwd=tmp_path)
    assert r.returncode == 1 and "--extend-to 4" in _err_line(r), r.stderr
    r = run_cli("map", "--out", "part", "--extend-to", "4", "-j", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert _rows(part) == _rows(tmp_path / "ref")


def test_an_earlier_map_is_refused_naming_resume_and_force(tmp_path):
    args = ["map", "--f-ex", "120,124", "--a-ex", "14", "--t-end", "1", "--out", "m", "-j", "1"]
    assert run_cli(*args, cwd=tmp_path).returncode == 0
    before = (tmp_path / "m" / "map.jsonl").read_bytes()
    r = run_cli(*args, cwd=tmp_path)
    line = _err_line(r)
    assert r.returncode == 1 and "--resume" in line and "--force" in line and "2 of 2 points" in line, line
    assert (tmp_path / "m" / "map.jsonl").read_bytes() == before
    r = run_cli(*args, "--force", "--t-end", "0.5", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert read_map(tmp_path / "m")["t_end_s"].max() < 0.6
    r = run_cli(*args, "--force", "--resume", cwd=tmp_path)
    assert r.returncode == 1 and "--force" in _err_line(r)


def test_a_resumed_map_says_how_many_points_it_kept(tmp_path):
    out = tmp_path / "m"
    cfg = beamslider.maps.map_config_toml(beamslider.Parameters(), f_ex=[120.0], a_ex=[14.0], s0=[0.3], t_end=1.0)
    beamslider.maps.run_map_config(cfg, out=out, threads=1)
    r = run_cli("map", "--f-ex", "120,124", "--a-ex", "14", "--t-end", "1", "--out", "m", "--resume", "-j", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "1 of 2 points kept" in r.stdout, r.stdout


def test_ctrl_c_says_how_many_points_are_kept_and_to_resume(tmp_path):
    proc = subprocess.Popen([*cli_command(), "map", "--f-ex", "100:130:2", "--a-ex", "14", "--t-end", "3", "--out", "m",
                             "-j", "1", "--no-progress"], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, preexec_fn=default_signals, env=dict(os.environ, MPLBACKEND="Agg"))
    results = tmp_path / "m" / "map.jsonl"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (results.exists() and len(results.read_text().splitlines()) >= 2):
        time.sleep(0.1)
    proc.send_signal(signal.SIGINT)
    _out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    line = _err_line(subprocess.CompletedProcess([], 130, "", err))
    assert "of 16 points kept; run again with --resume" in line, line


def test_a_map_shorter_than_one_recorded_sample_is_refused_as_simulate_refuses_it(tmp_path):
    r = run_cli("map", "--f-ex", "124", "--a-ex", "14", "--t-end", "1e-5", "--out", "m", cwd=tmp_path)
    assert r.returncode == 1 and "duration_s" in _err_line(r) and "record_every" in _err_line(r), r.stderr
    assert not (tmp_path / "m").exists()
    r = run_cli("simulate", "--t-end", "1e-5", "--out", "s", cwd=tmp_path)
    assert r.returncode == 1 and "record_every" in _err_line(r)


# --- study and design: --force -------------------------------------------------------------------


def test_study_and_design_have_force_and_refuse_without_it(tmp_path):
    from beamslider.study import StudyConfig, Uncertain, run_study

    cfg = StudyConfig(uncertain=[Uncertain("friction_coefficient", "uniform", low=0.22, high=0.31)],
                      f_ex_hz=[120.0], a_ex_m_s2=[10.0], method="lhs", samples=2, seed=1, duration_s=0.5)
    run_study(cfg, out=tmp_path / "s", threads=1)
    with pytest.raises(ValueError, match="--resume.*--force"):
        run_study(cfg, out=tmp_path / "s", threads=1)
    run_study(cfg, out=tmp_path / "s", threads=1, force=True)
    (tmp_path / "study.toml").write_text(cfg.to_toml_text())
    r = run_cli("study", "--config", "study.toml", "--out", "s", "-j", "1", cwd=tmp_path)
    assert r.returncode == 1 and "--force" in _err_line(r)
    r = run_cli("study", "--config", "study.toml", "--out", "s", "-j", "1", "--force", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    from beamslider.cli import build_parser

    for cmd in ("map", "study", "design"):
        ns = build_parser(cmd).parse_args([cmd, "--force"] + (["--config", "x.toml"] if cmd != "map" else []))
        assert ns.force is True


def test_the_reliability_guide_names_the_overwrite_option_of_every_command_that_has_one():
    from beamslider.cli import COMMANDS, build_parser

    guide = (Path(__file__).resolve().parent.parent / "docs" / "guide" / "reliability.md").read_text(encoding="utf-8")
    with_force = []
    for cmd in COMMANDS:
        sub = build_parser(cmd)._subparsers._group_actions[0].choices[cmd]
        if any("--force" in a.option_strings for a in sub._actions):
            with_force.append(cmd)
    assert {"map", "study", "design", "simulate"} <= set(with_force)
    para = guide.split("**Signals and overwrites.**", 1)[1].split("\n\n", 1)[0]
    for cmd in ("map", "study", "design"):
        assert f"`{cmd}`" in para, cmd


# --- simulate: old pair kept, lock, partial files, failing manifold ------------------------------


def _sim(tmp_path, *extra, t_end="0.3"):
    return run_cli("simulate", "--t-end", t_end, "--no-figure", "--out", "o", *extra, cwd=tmp_path)


def test_an_interrupted_force_keeps_the_earlier_pair(tmp_path):
    assert _sim(tmp_path).returncode == 0
    out = tmp_path / "o"
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    proc = subprocess.Popen([*cli_command(), "simulate", "--t-end", "60", "--no-figure", "--force", "--out", "o",
                             "--no-progress"], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=default_signals, env=dict(os.environ, MPLBACKEND="Agg"))
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not any(p.name.startswith(".") and "partial" in p.name for p in out.iterdir()):
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=60)
    assert proc.returncode == 130
    after = {p.name: p.read_bytes() for p in out.iterdir()}
    assert after == before, "the earlier run's files stay whole and nothing else is left"
    assert run_cli("plot", str(out / "fs_124Hz_14ms2_s0_0p3.json"), "--out", "p", cwd=tmp_path).returncode == 0


def test_two_simulates_into_one_folder_do_not_both_write(tmp_path):
    procs = [subprocess.Popen([*cli_command(), "simulate", "--t-end", "3", "--no-figure", "--no-manifold", "--out", "o",
                               "--no-progress"], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              env=dict(os.environ, MPLBACKEND="Agg")) for _ in range(2)]
    results = [p.communicate(timeout=120) + (p.returncode,) for p in procs]
    codes = sorted(r[2] for r in results)
    assert codes == [0, 1], results
    refused = next(r for r in results if r[2] == 1)
    assert "being written by another process" in refused[1] or "exists from an earlier run" in refused[1], refused[1]
    assert "wrote" not in refused[0]


def test_partial_files_of_dead_processes_go_when_the_folder_is_next_used(tmp_path):
    assert _sim(tmp_path).returncode == 0
    out = tmp_path / "o"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    junk = [out / f".fs_124Hz_14ms2_s0_0p3.npz.partial-{dead.pid}", out / f".fs_124Hz_14ms2_s0_0p3.json.partial-{dead.pid}",
            out / f".other.csv.partial-{dead.pid}"]
    for p in junk:
        p.write_bytes(b"x" * 1000)
    alive = out / f".other.csv.partial-{os.getpid()}"  # a running process's file stays
    alive.write_bytes(b"y")
    assert _sim(tmp_path, "--force").returncode == 0
    assert not any(p.exists() for p in junk)
    assert alive.exists()


def test_a_failing_manifold_keeps_a_consistent_folder_and_a_short_message(tmp_path):
    r = _sim(tmp_path, "--a-ex", "1e300")
    out = tmp_path / "o"
    summary = json.loads(next(out.glob("*.json")).read_text())
    assert summary["complete"] is True and "manifold_error" in summary
    assert next(out.glob("*.npz")).exists()
    assert r.returncode == 3 and not any(len(tok) > 40 for tok in r.stderr.split()), r.stderr
    (tmp_path / "long.toml").write_text("length_m = 1e300\n")
    env = dict(os.environ, BEAMSLIDER_ALLOW_IMPLAUSIBLE="1", MPLBACKEND="Agg")
    r = subprocess.run([*cli_command(), "simulate", "--params", "long.toml", "--t-end", "0.2", "--no-figure", "--out", "l"],
                       cwd=tmp_path, capture_output=True, text=True, env=env, timeout=120)
    assert not any(len(tok) > 40 for tok in r.stderr.split()), r.stderr
    summary = json.loads(next((tmp_path / "l").glob("*.json")).read_text())
    assert summary["complete"] is True


# --- --out on a virtual file system ---------------------------------------------------------------


@pytest.mark.skipif(not Path("/proc/self").exists(), reason="needs /proc")
def test_an_output_folder_under_proc_is_not_blamed_on_t_end(tmp_path):
    r = run_cli("simulate", "--t-end", "1", "--out", "/proc/foo", cwd=tmp_path)
    line = _err_line(r)
    assert r.returncode == 1 and "t_end" not in line and "/proc" in line, line
