//! The binding's one conversion per direction: keyword arguments and tables into the core's serde
//! structs ([`kwargs`], [`table`]), the core's serde results out as Python objects ([`object`]),
//! NumPy arrays both ways ([`In`], [`Out`]); and long work run with the interpreter released,
//! Ctrl-C and progress polled ([`detached`], [`monitored`]).

use std::sync::atomic::AtomicBool;

use beamslider_core::Error;
use beamslider_core::dynamics::runner::{self, SharedMonitor};
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::error::CoreResult;

/// Add `#[pyfunction]`s to a module.
macro_rules! export {
    ($m:expr, $($f:ident),+ $(,)?) => {
        $($m.add_function(pyo3::wrap_pyfunction!($f, $m)?)?;)+
    };
}
pub(crate) use export;

/// A NumPy array in (copied) and out.
pub type In<'py> = PyReadonlyArray1<'py, f64>;
/// A NumPy array out.
pub type Out<'py> = Bound<'py, PyArray1<f64>>;

/// Keyword arguments as the core's settings `T` (missing keys: its defaults; unknown or mistyped: `TypeError`).
pub fn kwargs<T: serde::de::DeserializeOwned>(py: Python<'_>, options: Option<&Bound<'_, PyDict>>) -> PyResult<T> {
    pythonize::depythonize(&options.cloned().unwrap_or_else(|| PyDict::new(py))).map_err(|e| PyTypeError::new_err(format!("invalid keyword argument: {e}")))
}

/// A Python table (dict, list, numbers, text) as the core's value `T`; a mismatch is an invalid `name`.
pub fn table<T: serde::de::DeserializeOwned>(name: &str, value: &Bound<'_, PyAny>) -> CoreResult<T> {
    pythonize::depythonize(value).map_err(|e| Error::invalid(name, "table", &format!("not valid: {e}")).into())
}

/// A core result (a serde struct) as Python data: dicts, lists, numbers, text, None.
pub fn object<'py, T: serde::Serialize>(py: Python<'py>, value: &T) -> CoreResult<Bound<'py, PyAny>> {
    Ok(pythonize::pythonize(py, value)?)
}

/// Run `work` on the core's watched thread ([`runner::watched`]) with the interpreter released; every `period_ms`
/// and at the end this thread runs signal handlers (Ctrl-C) and `poll(py)`. An exception sets `cancel`, raised after the work stops.
pub fn detached<T: Send>(
    py: Python<'_>, cancel: &AtomicBool, period_ms: u64, work: impl FnOnce() -> Result<T, Error> + Send, poll: impl Fn(Python<'_>) -> PyResult<()> + Sync,
) -> CoreResult<T> {
    let poll = |py: Python<'_>| py.check_signals().and_then(|()| poll(py));
    let mut err: Option<PyErr> = None;
    let period = std::time::Duration::from_millis(period_ms);
    let outcome = py.detach(|| runner::watched(cancel, period, work, || Python::attach(poll).map_err(|e| err = Some(e)).is_ok()));
    if let Some(e) = err {
        return Err(e.into());
    }
    let out = outcome?;
    poll(py)?;
    Ok(out)
}

/// [`detached`] work reporting to a `SharedMonitor`: every 50 ms, `on_start()` once the run waits at its start
/// (inputs checked, nothing written), and `callback(done, total)` with the latest progress.
pub fn monitored<T: Send>(
    py: Python<'_>, callback: Option<Py<PyAny>>, on_start: Option<Py<PyAny>>, work: impl FnOnce(&SharedMonitor) -> Result<T, Error> + Send,
) -> CoreResult<T> {
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
