"""A discover's free-slider runs as tasks of a Dask cluster (beamslider.discover.cluster,
docs/cluster.md "A discover on a cluster"): the answer and the kept runs are bitwise those of the
local run, the runner keeps the jobs' order and counts its progress, and an unreachable scheduler
or a lost cluster is one line."""

from __future__ import annotations

import json
import socket
import time

import pytest

import beamslider as bs
from beamslider import _core
from beamslider import discover as dc
from beamslider.discover import cluster as dcl
from beamslider.discover.models import RUN_BATCH
from beamslider.params import native

from conftest import run_cli

distributed = pytest.importorskip("distributed")

EFFECTS = ["friction_coefficient", "restitution"]


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """Two seconds of a run at one operating point, of a truth with a changed friction coefficient."""
    out = tmp_path_factory.mktemp("data")
    return dc.synthesize_slider_runs(bs.Parameters(friction_coefficient=0.25), operating_points=[(124, 6, 0.3)],
                                     duration_s=2, out_dir=out, seed=3, s0_offset=0.0015)


def _text(d) -> str:
    """A Discovery's JSON text but its runtime."""
    j = d.to_json()
    j.pop("runtime_s")
    return json.dumps(j, allow_nan=True)


def _free_port() -> int:
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()  # nothing listens there now
    return port


def test_a_discover_on_a_cluster_gives_the_local_answer_and_runs_bitwise(data, tmp_path, cluster, monkeypatch):
    """The same Discovery JSON text (runtime aside) and the same kept-runs file, byte for byte; on
    the cluster no run is made in this process."""
    runs = [bs.read_measurement(q) for q in data]
    kw = dict(measured=runs, effects=EFFECTS, advice_grid=[(110, 10, 0.3)])
    local = _text(dc.discover(runs_file=tmp_path / "local.jsonl", **kw))
    here, sent = [], []
    real_core, real_runner = _core.run_free_slider_batch, dcl.ClusterRunner.__call__
    monkeypatch.setattr(_core, "run_free_slider_batch", lambda jobs, **k: here.append(len(jobs)) or real_core(jobs, **k))
    monkeypatch.setattr(dcl.ClusterRunner, "__call__", lambda self, jobs, **k: sent.append(len(jobs)) or real_runner(self, jobs, **k))
    remote = _text(dc.discover(runs_file=tmp_path / "dask.jsonl", scheduler=cluster, **kw))
    assert here == [] and sum(sent) > 10
    assert remote == local
    assert (tmp_path / "dask.jsonl").read_bytes() == (tmp_path / "local.jsonl").read_bytes()
    assert RUN_BATCH.get() is None  # the local runner is back


def test_the_runner_keeps_the_jobs_order_and_counts_each_chunk(cluster):
    """Results in the jobs' order, bitwise the core's (a failed job's error too), on_done with each
    chunk's runs; an empty batch is an empty list."""
    p, q = native(bs.Parameters()), native(bs.Parameters(friction_coefficient=0.3))
    jobs = [(p if i % 2 else q, 120.0 + i, 6.0, 0.3, 0.2) for i in range(9)] + [(p, 124.0, 6.0, 5.0, 0.2)]
    settings = dict(record_every=5, keep_every=5, window_s=1.0, detrend_s=0.05)
    local = _core.run_free_slider_batch(jobs, **settings)
    done = []
    with dcl.on_cluster(cluster) as runner:
        assert RUN_BATCH.get() is runner
        got = runner(jobs, threads=4, on_done=done.append, **settings)
        assert runner([], **settings) == []
    assert RUN_BATCH.get() is None
    assert sum(done) == len(jobs) and len(done) == -(-len(jobs) // dcl.chunk_size(len(jobs), 2))
    assert len(got) == len(local)
    for a, b in zip(got, local):
        assert a.keys() == b.keys()
        if "error" in b:
            assert (type(a["error"]), str(a["error"]), a["error_kind"]) == (type(b["error"]), str(b["error"]), b["error_kind"])
            continue
        assert a["status"] == b["status"]
        for k in ("t", "s", "amplitude_h"):
            assert a[k].dtype == b[k].dtype and a[k].tobytes() == b[k].tobytes()


def test_an_unreachable_scheduler_or_both_given_is_one_line_before_anything_is_written(data, tmp_path):
    runs = [bs.read_measurement(q) for q in data]
    port = _free_port()
    t0 = time.monotonic()
    with pytest.raises(ValueError, match=f"^cannot reach the scheduler at tcp://127.0.0.1:{port}: ") as e:
        dc.discover(measured=runs, effects=EFFECTS, runs_file=tmp_path / "runs.jsonl", scheduler=f"tcp://127.0.0.1:{port}")
    assert time.monotonic() - t0 < 10 and "\n" not in str(e.value)
    with pytest.raises(ValueError, match="not both"):
        dc.discover(measured=runs, effects=EFFECTS, runs_file=tmp_path / "runs.jsonl", scheduler="tcp://127.0.0.1:1",
                    scheduler_file=str(tmp_path / "sched.json"))
    assert not (tmp_path / "runs.jsonl").exists()
    r = run_cli("discover", "--measured", *map(str, data), "--effects", ",".join(EFFECTS), "--advice-grid", "none",
                "--no-progress", "--scheduler", f"tcp://127.0.0.1:{port}", "--out", "o", cwd=tmp_path, timeout=60)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert r.returncode == 1 and len(lines) == 1 and "cannot reach the scheduler at" in lines[0], r.stderr
    assert not (tmp_path / "o").exists()


def test_a_cluster_without_workers_is_lost_in_one_line_naming_the_scheduler(data, tmp_path, monkeypatch):
    """No worker for longer than the timeout: one line naming the scheduler and what is kept, from
    the API and the command (exit 1, no traceback)."""
    monkeypatch.setenv("BEAMSLIDER_CLUSTER_TIMEOUT_S", "1")
    runs = [bs.read_measurement(q) for q in data]
    with distributed.LocalCluster(n_workers=0, processes=False, protocol="tcp://", dashboard_address=":0") as empty:
        address = empty.scheduler_address
        t0 = time.monotonic()
        with pytest.raises(ConnectionError, match=f"^the scheduler at {address}: the Dask cluster is lost "
                                                  r"\(no worker for 1 s\): .*runs file") as e:
            dc.discover(measured=runs, effects=EFFECTS, runs_file=tmp_path / "runs.jsonl", scheduler=address)
        assert time.monotonic() - t0 < 30 and "\n" not in str(e.value)
        r = run_cli("discover", "--measured", *map(str, data), "--effects", ",".join(EFFECTS), "--advice-grid", "none",
                    "--no-progress", "--scheduler", address, "--out", "o", cwd=tmp_path, timeout=120)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert r.returncode == 1 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert lines[0].startswith(f"beamslider: error: the scheduler at {address}: the Dask cluster is lost"), r.stderr
    assert "runs made kept in o/runs.jsonl" in lines[0], r.stderr


def test_the_command_takes_a_scheduler_or_a_scheduler_file_and_refuses_both(data, tmp_path, cluster):
    """--scheduler runs the discover on the cluster (the local command's report and runs);
    --scheduler with --scheduler-file, or without --measured, is one line."""
    base = ["discover", "--measured", *map(str, data), "--effects", "friction_coefficient", "--advice-grid", "none",
            "--no-progress"]
    r = run_cli(*base, "--out", "local", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    (tmp_path / "sched.json").write_text(json.dumps({"address": cluster.scheduler.address}))
    r = run_cli(*base, "--out", "dask", "--scheduler-file", "sched.json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    reports = [json.loads((tmp_path / o / "report.json").read_text()) for o in ("local", "dask")]
    for j in reports:
        j.pop("runtime_s")
    assert reports[0] == reports[1]
    assert (tmp_path / "local" / "runs.jsonl").read_bytes() == (tmp_path / "dask" / "runs.jsonl").read_bytes()
    r = run_cli(*base, "--out", "x", "--scheduler", "tcp://127.0.0.1:1", "--scheduler-file", "sched.json", cwd=tmp_path)
    assert r.returncode == 1 and "not both" in r.stderr and "Traceback" not in r.stderr, r.stderr
    r = run_cli("discover", "--out", "y", "--scheduler", "tcp://127.0.0.1:1", cwd=tmp_path)
    assert r.returncode == 1 and "only with --measured" in r.stderr, r.stderr
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()
