//! The binding's one error policy (as polars' `PyPolarsErr`): a core error converts with `From` into
//! the Python exception of its class, so `?` works on every core call; a panic in the core becomes
//! `SimulationError` and never crosses into Python ([`guarded`]).

use beamslider_core::Error;
use beamslider_core::dynamics::runner;
use pyo3::exceptions::{PyBlockingIOError, PyException, PyKeyboardInterrupt, PyOSError, PyValueError};
use pyo3::prelude::*;

pyo3::create_exception!(_core, SimulationError, PyException, "A simulation failed numerically (e.g. no eigenvalue found, manifold run diverged).");

/// An error of a binding function: the core's (converted by class) or Python's (passed on).
#[derive(Debug)]
pub enum PyCoreError {
    /// An error of the core.
    Core(Error),
    /// An error raised in Python (a callback, an argument's conversion).
    Python(PyErr),
}

/// What every binding function returns.
pub type CoreResult<T> = Result<T, PyCoreError>;

impl From<Error> for PyCoreError {
    fn from(e: Error) -> Self {
        PyCoreError::Core(e)
    }
}

impl From<PyErr> for PyCoreError {
    fn from(e: PyErr) -> Self {
        PyCoreError::Python(e)
    }
}

impl From<pythonize::PythonizeError> for PyCoreError {
    fn from(e: pythonize::PythonizeError) -> Self {
        PyCoreError::Python(e.into())
    }
}

impl From<numpy::AsSliceError> for PyCoreError {
    fn from(e: numpy::AsSliceError) -> Self {
        PyCoreError::Python(e.into())
    }
}

impl From<PyCoreError> for PyErr {
    /// The class of a core error: invalid input → `ValueError`, I/O → `OSError` (with its errno),
    /// a results file another process writes → `BlockingIOError`, interrupted → `KeyboardInterrupt`,
    /// numerical failure → `SimulationError`.
    fn from(e: PyCoreError) -> PyErr {
        let e = match e {
            PyCoreError::Python(e) => return e,
            PyCoreError::Core(e) => e,
        };
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
}

/// Run `f`, a panic becoming a core error (`SimulationError`: a panic must never cross into Python).
pub fn guarded<T>(f: impl FnOnce() -> Result<T, Error>) -> Result<T, Error> {
    runner::catch_panic(f).unwrap_or_else(|what| Err(Error::Numerical(format!("internal error in the core: {what}"))))
}

/// Run `f` with the interpreter released ([`guarded`]): the short calls of the core.
pub fn released<T: Send>(py: Python<'_>, f: impl FnOnce() -> Result<T, Error> + Send) -> CoreResult<T> {
    Ok(py.detach(|| guarded(f))?)
}

/// The `SimulationError` class, for the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SimulationError", m.py().get_type::<SimulationError>())
}
