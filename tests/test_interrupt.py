"""Ctrl-C interrupts a long run within a second (the binding polls signals every 4096 steps)."""

import _thread
import signal
import subprocess
import sys
import threading
import time

import pytest

import beamslider


def _interrupted(call):
    """Run ``call`` with Ctrl-C (interrupt_main) 0.3 s in: it must raise KeyboardInterrupt; the
    seconds it took."""
    timer = threading.Timer(0.3, _thread.interrupt_main)
    t0 = time.perf_counter()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            call()
    finally:
        timer.cancel()
    return time.perf_counter() - t0


def test_interrupt_main_raises_keyboardinterrupt_promptly():
    assert _interrupted(lambda: beamslider.simulate(f_ex=124, a_ex=14, t_end=10_000.0, record_every=1000)) < 1.5


def test_interrupted_manifold_raises_keyboardinterrupt():
    _interrupted(lambda: beamslider.super_slow_manifold(f_ex=124, a_ex=14, periods=2000, record=25))


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_sigint_to_a_long_run_in_a_subprocess():
    code = (
        "import sys, beamslider\n"
        "print('ready', flush=True)\n"
        "beamslider.simulate(f_ex=124, a_ex=14, t_end=10_000.0, record_every=1000, progress=False)\n"
        "print('finished', flush=True)\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "ready"
        time.sleep(0.5)  # well inside the run (which would take minutes)
        t0 = time.perf_counter()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=20)
        elapsed = time.perf_counter() - t0
    finally:
        proc.kill()
    assert "finished" not in out
    assert "KeyboardInterrupt" in err
    assert proc.returncode != 0
    assert elapsed < 2.0
