//! `beamslider._core`: the thin PyO3 binding of `beamslider-core`.
//!
//! It only converts types and errors; the public Python API lives in `python/beamslider/`.
//! Parameters cross the boundary as the core's validated object (`Params`, module `params`).
//! Long runs release the interpreter (`py.detach`); a monitor re-attaches every few thousand
//! steps to run pending signal handlers (Ctrl-C) and the optional progress callback. Core errors
//! map to Python exceptions: invalid parameter / TOML → `ValueError`, I/O → `OSError`, numerical
//! failure → `beamslider.SimulationError`, interrupted → `KeyboardInterrupt`. Panics are caught
//! and reported as `SimulationError`. The functions mirror Python's keyword signatures (their
//! argument lists are the API, hence the crate-wide `too_many_arguments`).
#![allow(clippy::too_many_arguments)]

use std::sync::atomic::AtomicBool;

use beamslider_core::dynamics::runner::{self, SharedMonitor};
use beamslider_core::signal::{self, envelope_stream::EnvelopeStream};
use beamslider_core::{Criteria, Error, SuperSlow};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::exceptions::{PyBlockingIOError, PyException, PyKeyboardInterrupt, PyOSError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

mod formats;
mod maprun;
mod params;
mod predictor;
mod run;
mod study;
mod superslow;

pyo3::create_exception!(_core, SimulationError, PyException, "A simulation failed numerically (e.g. no eigenvalue found, manifold run diverged).");

/// Add `#[pyfunction]`s to a module.
#[macro_export]
macro_rules! export {
    ($m:expr, $($f:ident),+ $(,)?) => {
        $($m.add_function(pyo3::wrap_pyfunction!($f, $m)?)?;)+
    };
}

/// A core result as JSON text (the form rows and tables take to Python).
fn json<T: serde::Serialize>(value: &T) -> PyResult<String> {
    serde_json::to_string(value).map_err(|e| SimulationError::new_err(format!("internal error: {e}")))
}

/// Keyword arguments as the core's settings `T` (missing keys: its defaults; unknown or mistyped: `TypeError`).
fn kwargs<T: serde::de::DeserializeOwned>(py: Python<'_>, options: Option<&Bound<'_, PyDict>>) -> PyResult<T> {
    pythonize::depythonize(&options.cloned().unwrap_or_else(|| PyDict::new(py))).map_err(|e| PyTypeError::new_err(format!("invalid keyword argument: {e}")))
}

/// Map a core error to the Python exception of its class.
fn to_py(e: Error) -> PyErr {
    let msg = e.to_string();
    #[allow(unreachable_patterns)]
    match e {
        _ if e.is_input() => PyValueError::new_err(msg),
        Error::Io { source, .. } => match source.raw_os_error() {
            Some(code) => PyOSError::new_err((code, msg)),
            None => PyOSError::new_err(msg),
        },
        Error::Busy { .. } => PyBlockingIOError::new_err(msg),
        Error::Interrupted { .. } => PyKeyboardInterrupt::new_err(msg),
        _ => SimulationError::new_err(msg), // numerical failures
    }
}

/// Run `f`, turning a panic into an error (a panic must never cross into Python).
fn guarded<T>(f: impl FnOnce() -> Result<T, Error>) -> Result<T, PyErr> {
    match runner::catch_panic(f) {
        Ok(r) => r.map_err(to_py),
        Err(what) => Err(SimulationError::new_err(format!("internal error in the core: {what}"))),
    }
}

/// Run `work` with the interpreter released on the core's watched worker thread
/// ([`runner::watched`]); every `period_ms`, and once more at the end, the calling thread
/// re-attaches, runs pending signal handlers (Ctrl-C) and calls `poll(py)` (progress callbacks).
/// An exception there sets `cancel` and is raised once the work has stopped.
fn detached<T: Send>(
    py: Python<'_>, cancel: &AtomicBool, period_ms: u64, work: impl FnOnce() -> Result<T, Error> + Send, poll: impl Fn(Python<'_>) -> PyResult<()> + Sync,
) -> PyResult<T> {
    let poll = |py: Python<'_>| py.check_signals().and_then(|()| poll(py));
    let mut err: Option<PyErr> = None;
    let period = std::time::Duration::from_millis(period_ms);
    let outcome = py.detach(|| runner::watched(cancel, period, work, || Python::attach(poll).map_err(|e| err = Some(e)).is_ok()));
    if let Some(e) = err {
        return Err(e);
    }
    let out = outcome.map_err(to_py)?;
    poll(py)?;
    Ok(out)
}

/// Run `work` with the interpreter released, reporting to the core's `SharedMonitor` (a run's
/// monitor, or counts of points): every 50 ms the calling thread ([`detached`]) calls `on_start()`
/// once a run waits at its start (inputs checked, nothing written) and `callback(done, total)`
/// with the latest progress.
fn monitored<T: Send>(
    py: Python<'_>, callback: Option<Py<PyAny>>, on_start: Option<Py<PyAny>>, work: impl FnOnce(&SharedMonitor) -> Result<T, Error> + Send,
) -> PyResult<T> {
    let cancel = AtomicBool::new(false);
    let shared = SharedMonitor::new(&cancel, on_start.is_some());
    let poll = |py: Python<'_>| {
        if let Some(f) = on_start.as_ref().filter(|_| shared.waiting()) {
            f.call0(py)?;
            shared.open();
        }
        callback.as_ref().zip(shared.take_progress()).map_or(Ok(()), |(cb, p)| cb.call1(py, p).map(drop))
    };
    detached(py, &cancel, 50, || work(&shared), poll)
}

/// Rows a run records: the start state and every `record_every`-th of round(t_end/dt) steps.
#[pyfunction]
fn recorded_rows(t_end_s: f64, dt_s: f64, record_every: usize) -> u64 {
    beamslider_core::recorded_rows(t_end_s, dt_s, record_every)
}

/// A NumPy array in (copied) and out.
type In<'py> = PyReadonlyArray1<'py, f64>;
type Out<'py> = Bound<'py, PyArray1<f64>>;

/// Centred moving average over `window` samples, shrinking at the ends (as MATLAB's movmean).
#[pyfunction]
fn moving_average<'py>(py: Python<'py>, x: In<'py>, window: usize) -> PyResult<Out<'py>> {
    let x = x.as_slice()?.to_vec();
    Ok(py.detach(|| signal::moving_average(&x, window)).into_pyarray(py))
}

/// Envelope of docs/model.md §7 (`window_s` moving average of |analytic signal| of samples spaced
/// `dt_s`); with `block`, the analytic signal by overlapping FFT blocks (`margin` samples each side).
#[pyfunction]
#[pyo3(signature = (x, dt_s, window_s, *, block=None, margin=0))]
fn envelope<'py>(py: Python<'py>, x: In<'py>, dt_s: f64, window_s: f64, block: Option<usize>, margin: usize) -> PyResult<Out<'py>> {
    let x = x.as_slice()?.to_vec();
    let env = || block.map_or_else(|| signal::envelope_checked(&x, dt_s, window_s), |b| signal::blocked_envelope(&x, dt_s, window_s, b, margin));
    Ok(py.detach(|| guarded(env))?.into_pyarray(py))
}

/// The super-slow signals a map point is classified from (core `signal::envelope_stream`,
/// docs/model.md §7) of w(4L/7) [m] and s sampled every `dt_s`: (t0 of the first 0.2-s bin [s],
/// bin spacing [s], s per bin, A per bin: `window_s` moving average of |analytic signal| / h).
#[pyfunction]
fn super_slow_signals<'py>(py: Python<'py>, w: In<'py>, s: In<'py>, dt_s: f64, thickness_m: f64, window_s: f64) -> PyResult<(f64, f64, Out<'py>, Out<'py>)> {
    let (w, s) = (w.as_slice()?.to_vec(), s.as_slice()?.to_vec());
    let x = py.detach(|| guarded(|| EnvelopeStream::of_series(&w, &s, dt_s, thickness_m, window_s)))?;
    Ok((x.t0_s, x.dt_s, x.s.into_pyarray(py), x.amplitude_h.into_pyarray(py)))
}

/// Behaviour classification (docs/model.md §8) of super-slow signals sampled every `dt_s` (slider
/// position `s`, amplitude `amplitude_h`); `criteria_toml`: thresholds as TOML keys of the core's
/// `Criteria` (missing keys take defaults). Returns the classification as JSON text.
#[pyfunction]
#[pyo3(signature = (s, amplitude_h, dt_s, *, t0_s=0.0, criteria_toml=None))]
fn classify(py: Python<'_>, s: In<'_>, amplitude_h: In<'_>, dt_s: f64, t0_s: f64, criteria_toml: Option<&str>) -> PyResult<String> {
    let criteria = guarded(|| Criteria::from_toml_str(criteria_toml))?;
    let x = SuperSlow { t0_s, dt_s, s: s.as_slice()?.to_vec(), amplitude_h: amplitude_h.as_slice()?.to_vec() };
    json(&py.detach(|| guarded(|| beamslider_core::classify(&x, &criteria)))?)
}

/// The values of an inclusive range START:STOP:STEP (core `map::Axis`: STOP included when within
/// STEP/1000 of the grid, values rounded to 1e-9, at most a million); errors name `field`.
#[pyfunction]
fn range_values(field: &str, start: f64, stop: f64, step: f64) -> PyResult<Vec<f64>> {
    guarded(|| beamslider_core::Axis::Range { start, stop, step }.values(field))
}

/// The compiled core of beamslider (private: import `beamslider` instead).
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SimulationError", m.py().get_type::<SimulationError>())?;
    m.add("RESULTS_FORMAT_VERSION", beamslider_core::results::FORMAT_VERSION)?;
    m.add("MAX_AXIS_VALUES", beamslider_core::map::MAX_POINTS)?;
    m.add("S_DN_MIN", beamslider_core::superslow::predict::S_DN_MIN)?;
    export!(m, recorded_rows, moving_average, envelope, classify, super_slow_signals, range_values);
    params::register(m)?;
    run::register(m)?;
    maprun::register(m)?;
    study::register(m)?;
    superslow::register(m)?;
    formats::register(m)?;
    predictor::register(m)?;
    Ok(())
}
