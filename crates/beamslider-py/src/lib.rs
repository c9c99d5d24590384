//! `beamslider._core`, the PyO3 binding of `beamslider-core`: types and errors only (the Python API is `python/beamslider/`,
//! these functions' docs `_core.pyi`). Long work runs with the interpreter released ([`detached`]); errors map by class
//! ([`to_py`]); a panic becomes `SimulationError` ([`guarded`]). Argument lists mirror Python's keyword signatures.
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
mod plausibility;
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

/// Run `work` on the core's watched thread ([`runner::watched`]) with the interpreter released; every `period_ms`
/// and at the end this thread runs signal handlers (Ctrl-C) and `poll(py)`. An exception sets `cancel`, raised after the work stops.
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

/// [`detached`] work reporting to a `SharedMonitor`: every 50 ms, `on_start()` once the run waits at its start
/// (inputs checked, nothing written), and `callback(done, total)` with the latest progress.
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

/// Envelope of docs/model.md §7 (core `signal::envelope_checked`, or `blocked_envelope` with `block`).
#[pyfunction]
#[pyo3(signature = (x, dt_s, window_s, *, block=None, margin=0))]
fn envelope<'py>(py: Python<'py>, x: In<'py>, dt_s: f64, window_s: f64, block: Option<usize>, margin: usize) -> PyResult<Out<'py>> {
    let x = x.as_slice()?.to_vec();
    let env = || block.map_or_else(|| signal::envelope_checked(&x, dt_s, window_s), |b| signal::blocked_envelope(&x, dt_s, window_s, b, margin));
    Ok(py.detach(|| guarded(env))?.into_pyarray(py))
}

/// The numbers of a measured file's text (core `measured::plain_numbers`), or None if a token is not a number.
#[pyfunction]
fn plain_numbers<'py>(py: Python<'py>, text: String) -> PyResult<Option<Out<'py>>> {
    Ok(py.detach(|| beamslider_core::measured::plain_numbers(&text)).map(|v| v.into_pyarray(py)))
}

/// The super-slow signals of w(4L/7) and s (core `signal::envelope_stream`, docs/model.md §7).
#[pyfunction]
fn super_slow_signals<'py>(py: Python<'py>, w: In<'py>, s: In<'py>, dt_s: f64, thickness_m: f64, window_s: f64) -> PyResult<(f64, f64, Out<'py>, Out<'py>)> {
    let (w, s) = (w.as_slice()?.to_vec(), s.as_slice()?.to_vec());
    let x = py.detach(|| guarded(|| EnvelopeStream::of_series(&w, &s, dt_s, thickness_m, window_s)))?;
    Ok((x.t0_s, x.dt_s, x.s.into_pyarray(py), x.amplitude_h.into_pyarray(py)))
}

/// Behaviour classification (docs/model.md §8) of super-slow signals: JSON text.
#[pyfunction]
#[pyo3(signature = (s, amplitude_h, dt_s, *, t0_s=0.0, criteria_toml=None))]
fn classify(py: Python<'_>, s: In<'_>, amplitude_h: In<'_>, dt_s: f64, t0_s: f64, criteria_toml: Option<&str>) -> PyResult<String> {
    let criteria = guarded(|| Criteria::from_toml_str(criteria_toml))?;
    let x = SuperSlow { t0_s, dt_s, s: s.as_slice()?.to_vec(), amplitude_h: amplitude_h.as_slice()?.to_vec() };
    json(&py.detach(|| guarded(|| beamslider_core::classify(&x, &criteria)))?)
}

/// The values of an inclusive range START:STOP:STEP (core `map::Axis`); errors name `field`.
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
    export!(m, recorded_rows, moving_average, envelope, plain_numbers, classify, super_slow_signals, range_values);
    params::register(m)?;
    run::register(m)?;
    maprun::register(m)?;
    study::register(m)?;
    superslow::register(m)?;
    formats::register(m)?;
    predictor::register(m)?;
    plausibility::register(m)?;
    Ok(())
}
