"""An address that is not a Dask scheduler (docs/cluster.md): a service that answers ``HTTP/1.1 400``
(a dashboard port) and one that accepts the connection and never answers are each one line,
``ADDRESS is not a Dask scheduler (...)``, within the one hard timeout of the whole client start,
and leave nothing behind."""

import socket
import threading
import time

import pytest

from conftest import run_cli

pytest.importorskip("distributed")


class _Server:
    """A local TCP service on a free port: ``mode`` 'http' answers every connection with an HTTP 400
    (as a web server does to bytes it cannot parse), 'silent' accepts and never answers."""

    def __init__(self, mode: str) -> None:
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(16)
        self.port = self.sock.getsockname()[1]
        self.mode = mode
        self.conns = []
        self.stop = False
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    @property
    def address(self) -> str:
        return f"tcp://127.0.0.1:{self.port}"

    def _serve(self) -> None:
        self.sock.settimeout(0.2)
        while not self.stop:
            try:
                c, _ = self.sock.accept()
            except OSError:
                continue
            self.conns.append(c)
            if self.mode == "http":
                try:
                    c.settimeout(0.5)
                    try:
                        c.recv(65536)
                    except OSError:
                        pass
                    c.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Type: text/plain\r\nContent-Length: 11\r\n"
                              b"Connection: close\r\n\r\nBad Request")
                    c.close()
                except OSError:
                    pass

    def close(self) -> None:
        self.stop = True
        for c in self.conns:
            try:
                c.close()
            except OSError:
                pass
        self.sock.close()


@pytest.fixture(params=["http", "silent"])
def server(request):
    s = _Server(request.param)
    yield s
    s.close()


def test_the_api_says_the_address_is_not_a_scheduler(server, tmp_path):
    import beamslider
    from beamslider._dask import connect

    t0 = time.monotonic()
    with pytest.raises(ValueError, match=f"^{server.address} is not a Dask scheduler \\(.+\\)$") as e:
        connect(server.address, timeout_s=3.0)
    assert time.monotonic() - t0 < 3.0 + 2.0, "the whole client start stays within the timeout"
    assert "\n" not in str(e.value)
    with pytest.raises(ValueError, match="is not a Dask scheduler"):
        beamslider.operating_map(f_ex=120.0, a_ex=10.0, t_end=1.0, out=tmp_path / "m", scheduler=server.address)
    assert not (tmp_path / "m").exists()


def test_the_command_line_says_it_in_one_line_within_the_timeout(server, tmp_path, monkeypatch):
    monkeypatch.setenv("BEAMSLIDER_CONNECT_TIMEOUT_S", "3")
    t0 = time.monotonic()
    r = run_cli("map", "--f-ex", "120,124", "--a-ex", "14", "--t-end", "5", "--scheduler", server.address,
                "--out", "dk", cwd=tmp_path, timeout=60)
    wall = time.monotonic() - t0
    assert r.returncode == 1, (r.returncode, r.stderr[-3000:])
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert lines == [lines[0]] and lines[0].startswith(f"beamslider: error: {server.address} is not a Dask scheduler ("), r.stderr
    assert "Traceback" not in r.stderr and "MemoryError" not in r.stderr
    assert wall < 3 + 10, f"took {wall:.1f} s with a 3-s timeout (interpreter start included)"
    assert not (tmp_path / "dk").exists()


def test_a_refused_connection_is_still_unreachable(tmp_path):
    from beamslider._dask import connect

    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()  # nothing listens there now
    with pytest.raises(ValueError, match=f"cannot reach the scheduler at tcp://127.0.0.1:{port}"):
        connect(f"tcp://127.0.0.1:{port}", timeout_s=2.0)


def test_a_real_scheduler_still_connects():
    from distributed import LocalCluster

    from beamslider._dask import close_client, connect

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as cluster:
        client, own = connect(cluster.scheduler_address, timeout_s=20.0)
        try:
            assert own and client.status == "running"
            assert client.submit(lambda x: x + 1, 1).result(timeout=20) == 2
        finally:
            close_client(client)
