"""Shared helpers of the Python test suite. Run from this folder against the *installed* package:
``(cd tests && python3 -m pytest -q -p no:cacheprovider .)``; data are found relative to this file."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Dict, List

import numpy as np
import pytest

REPO = Path(__file__).resolve().parent.parent

# Hypothesis keeps no example database (it would write tests/.hypothesis/): a test run leaves
# nothing behind in the tree.
try:
    from hypothesis import settings as _hyp_settings

    _hyp_settings.register_profile("beamslider", database=None)
    _hyp_settings.load_profile("beamslider")
except ImportError:  # hypothesis is part of the extra "test"; without it those tests are skipped
    pass
GOLDEN_DIR = REPO / "crates" / "beamslider-core" / "tests" / "data"


def _terminal_signals() -> None:
    """The test process itself as in a terminal: a runner started with ``nohup`` or in the
    background hands SIGINT (and SIGTERM, SIGHUP) on ignored, and Python then installs no Ctrl-C
    handler, so the tests of Ctrl-C (in-process and in children, which inherit an ignored signal)
    would test nothing. Ignored dispositions go back to Python's defaults."""
    import signal

    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    for name in ("SIGTERM", "SIGHUP"):
        sig = getattr(signal, name, None)
        if sig is not None and signal.getsignal(sig) == signal.SIG_IGN:
            signal.signal(sig, signal.SIG_DFL)


_terminal_signals()


def read_golden(name: str) -> Dict[str, np.ndarray]:
    """A reference CSV of the core's test data: '#' comments, a header line, comma-separated."""
    lines = [ln for ln in (GOLDEN_DIR / name).read_text().splitlines() if ln.strip() and not ln.startswith("#")]
    names = [n.strip() for n in lines[0].split(",")]
    data = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    return {n: data[:, i] for i, n in enumerate(names)}


def cli_command() -> List[str]:
    """The installed ``beamslider`` console script (beside this interpreter), else ``python -m``."""
    exe = Path(sys.executable).parent / ("beamslider.exe" if os.name == "nt" else "beamslider")
    if exe.exists():
        return [str(exe)]
    found = shutil.which("beamslider")
    return [found] if found else [sys.executable, "-m", "beamslider"]


def default_signals() -> None:
    """``preexec_fn`` of a child that a test signals: SIGINT, SIGTERM and SIGHUP at their defaults,
    as in a terminal (a test runner started with ``nohup`` or in the background would otherwise
    hand them on ignored, and the command rightly keeps ignoring them)."""
    import signal

    for name in ("SIGINT", "SIGTERM", "SIGHUP"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_DFL)


def run_cli(*args: str, cwd: Path, timeout: float = 120) -> subprocess.CompletedProcess:
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run([*cli_command(), *args], cwd=cwd, capture_output=True, text=True, timeout=timeout, env=env)


def is_png(path: Path) -> bool:
    return path.exists() and path.stat().st_size > 1000 and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.fixture
def golden():
    return read_golden


@pytest.fixture(scope="module")
def cluster():
    """A Dask client on a local cluster of two worker processes (one per test module; skipped
    without ``distributed``)."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  worker_dashboard_address=None) as cl, distributed.Client(cl) as client:
        yield client


def wait_for_lines(path: Path, n: int, timeout: float = 60.0) -> None:
    """Wait (at most ``timeout`` seconds) until the file ``path`` has ``n`` lines (a run writing it)."""
    t0 = time.time()
    while time.time() - t0 < timeout:
        if path.exists() and len(path.read_text().splitlines()) >= n:
            break
        time.sleep(0.005)
