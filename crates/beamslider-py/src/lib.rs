//! `beamslider._core`, the PyO3 binding of `beamslider-core`: types and errors only (the Python API is `python/beamslider/`,
//! these functions' docs `_core.pyi`). Every function converts its arguments, calls one public function of the core
//! that does the whole step, and converts the result: the conversions are [`convert`]'s (keyword arguments into the
//! core's serde structs, its results out as Python data or NumPy arrays), the errors [`error`]'s (`From`, so `?`
//! everywhere; a panic becomes `SimulationError`). Long work runs with the interpreter released and Ctrl-C polled.
#![allow(clippy::too_many_arguments)]

use pyo3::prelude::*;

mod convert;
mod error;
mod formats;
mod maprun;
mod params;
mod plausibility;
mod predictor;
mod run;
mod signal;
mod study;
mod superslow;

/// The compiled core of beamslider (private: import `beamslider` instead).
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    error::register(m)?;
    m.add("RESULTS_FORMAT_VERSION", beamslider_core::results::FORMAT_VERSION)?;
    m.add("MAX_AXIS_VALUES", beamslider_core::map::MAX_POINTS)?;
    m.add("S_DN_MIN", beamslider_core::superslow::predict::S_DN_MIN)?;
    m.add("LAW_MAX_K", beamslider_core::superslow::law::MAX_K)?;
    signal::register(m)?;
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
