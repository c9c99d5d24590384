"""beamslider.simulate (docs/model.md §5–6): golden trajectories, results, errors, GIL, progress."""

import threading
import time

import numpy as np
import pytest

import beamslider
from beamslider import Parameters, simulate
from conftest import read_golden

REFERENCE = dict(contact_solver="reference")


def _rel(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


def test_golden_free_slider():
    """The authors' reference trajectory (FS, 124 Hz, 14 m/s², s0 = 0.3, 0.2 s) with the reference solver."""
    gold = read_golden("golden_fs_124Hz_14ms2_s03.csv")
    r = simulate(Parameters(**REFERENCE), f_ex=124, a_ex=14, s0=0.3, t_end=0.2, record_every=10)
    assert r.status == "completed"
    assert len(r.t) == len(gold["t_s"])
    np.testing.assert_allclose(r.t, gold["t_s"], rtol=0, atol=1e-12)
    assert _rel(r.w, gold["w_4L7_m"]) <= 1e-6
    assert np.max(np.abs(r.x_c - gold["xC_m"])) <= 1e-9
    assert np.max(np.abs(r.z_c - gold["zC_m"])) <= 1e-9
    assert np.max(np.abs(r.beta - gold["beta_rad"])) <= 1e-7
    np.testing.assert_allclose(r.s, r.x_c / 0.14, rtol=1e-12)


def test_golden_pcs():
    gold = read_golden("golden_pcs_124Hz_14ms2_s025.csv")
    r = simulate(Parameters(**REFERENCE), f_ex=124, a_ex=14, t_end=0.2, model="pcs", s_pcs=0.25)
    assert r.status == "completed" and len(r.t) == len(gold["t_s"])
    assert _rel(r.w, gold["w_4L7_m"]) <= 1e-6
    assert np.max(np.abs(r.x_c - gold["xC_m"])) <= 1e-9
    assert np.max(np.abs(r.z_c - gold["zC_m"])) <= 1e-9
    assert np.all(r.s == 0.25)


def test_result_arrays_and_counters():
    r = simulate(f_ex=124, a_ex=14, t_end=0.1, record_every=5)
    n = round(0.1 / 2e-5) // 5 + 1
    for name in ("t", "w", "s", "x_c", "z_c", "beta"):
        a = getattr(r, name)
        assert isinstance(a, np.ndarray) and a.dtype == np.float64 and a.shape == (n,), name
    assert r.t[0] == 0 and r.t[-1] == pytest.approx(0.1)
    assert r.s[0] == pytest.approx(0.3)
    assert r.counters["steps"] == 5000
    assert 0 < r.counters["contact_steps"] <= 5000
    assert sum(r.counters["closed_histogram"]) == 5000
    assert r.counters["cap_hits"] == 0
    assert r.final_state["t_s"] == pytest.approx(0.1)
    assert r.final_state["slider_q"][0] == pytest.approx(r.x_c[-1])
    assert r.dt_record == pytest.approx(1e-4)
    assert r.completed and r.message == "completed"


def test_fast_and_reference_solvers_agree_over_a_short_run():
    a = simulate(f_ex=124, a_ex=14, t_end=0.01)
    b = simulate(Parameters(**REFERENCE), f_ex=124, a_ex=14, t_end=0.01)
    assert _rel(a.w, b.w) < 1e-2  # docs/model.md §5: the reference stop rule leaves ~0.2 % differences


def test_beam_only_has_no_slider_motion_and_dt_override():
    r = simulate(f_ex=124, a_ex=14, t_end=0.05, model="beam", dt=1e-5, record_every=1)
    assert len(r.t) == 5001 and r.counters["contact_steps"] == 0
    assert np.max(np.abs(r.w)) > 0


@pytest.mark.parametrize(
    "kwargs,field",
    [
        (dict(s0=0.01), "s0"),
        (dict(s0=0.99), "s0"),
        (dict(f_ex=0.0), "f_ex"),
        (dict(a_ex=-1.0), "a_ex"),
        (dict(t_end=-1.0), "duration_s"),
        (dict(t_end=float("nan")), "duration_s"),
        (dict(model="free"), "model"),
        (dict(record_every=0), "record_every"),
        (dict(record_every=2.5), "record_every"),
        (dict(dt=1e-3), "dt_s"),
        (dict(dt=0.0), "dt_s"),
        (dict(s_pcs=0.2), "s_pcs"),
    ],
)
def test_bad_run_inputs_raise_valueerror(kwargs, field):
    args = dict(f_ex=124.0, a_ex=14.0, t_end=0.01)
    args.update(kwargs)
    with pytest.raises(ValueError, match=field):
        simulate(**args)


def test_params_must_be_parameters():
    with pytest.raises(TypeError):
        simulate("defaults", f_ex=124, a_ex=14, t_end=0.01)
    assert simulate({"n_modes": 3}, f_ex=124, a_ex=14, t_end=0.01).params.n_modes == 3


def test_gil_is_released_during_a_run():
    """Another Python thread keeps running while the core integrates."""
    done = threading.Event()
    out = {}

    def work():
        out["r"] = simulate(f_ex=124, a_ex=14, t_end=4.0, record_every=1000)
        done.set()

    th = threading.Thread(target=work)
    th.start()
    ticks = 0
    t0 = time.perf_counter()
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    th.join()
    assert out["r"].completed
    # Held GIL would freeze this loop for the whole run; released, it ticks throughout.
    assert ticks > 0.3 * (time.perf_counter() - t0) / 0.001 * 0.2


def test_progress_bar(capsys):
    simulate(f_ex=124, a_ex=14, t_end=0.2, progress=True)
    err = capsys.readouterr().err
    assert "100%" in err and "0.20/0.20 s" in err
