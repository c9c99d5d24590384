//! Core `signal` and `classify` (docs/model.md §7–8): filters, envelopes, the super-slow signals of
//! a run and their classification, the numbers of a measured file, a map axis's values.

use beamslider_core::signal::{self, envelope_stream::EnvelopeStream};
use beamslider_core::{Criteria, SuperSlow};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{In, Out, object, table};
use crate::error::{CoreResult, released};

/// Rows a run records: the start state and every `record_every`-th of round(t_end/dt) steps.
#[pyfunction]
fn recorded_rows(t_end_s: f64, dt_s: f64, record_every: usize) -> u64 {
    beamslider_core::recorded_rows(t_end_s, dt_s, record_every)
}

/// Centred moving average over `window` samples, shrinking at the ends (as MATLAB's movmean).
#[pyfunction]
fn moving_average<'py>(py: Python<'py>, x: In<'py>, window: usize) -> CoreResult<Out<'py>> {
    let x = x.as_slice()?.to_vec();
    Ok(released(py, || Ok(signal::moving_average(&x, window)))?.into_pyarray(py))
}

/// Envelope of docs/model.md §7 (core `signal::envelope_checked`, or `blocked_envelope` with `block`).
#[pyfunction]
#[pyo3(signature = (x, dt_s, window_s, *, block=None, margin=0))]
fn envelope<'py>(py: Python<'py>, x: In<'py>, dt_s: f64, window_s: f64, block: Option<usize>, margin: usize) -> CoreResult<Out<'py>> {
    let x = x.as_slice()?.to_vec();
    let env = || block.map_or_else(|| signal::envelope_checked(&x, dt_s, window_s), |b| signal::blocked_envelope(&x, dt_s, window_s, b, margin));
    Ok(released(py, env)?.into_pyarray(py))
}

/// The numbers of a measured file's text (core `measured::plain_numbers`), or None if a token is not a number.
#[pyfunction]
fn plain_numbers<'py>(py: Python<'py>, text: String) -> CoreResult<Option<Out<'py>>> {
    Ok(released(py, || Ok(beamslider_core::measured::plain_numbers(&text)))?.map(|v| v.into_pyarray(py)))
}

/// The super-slow signals of w(4L/7) and s (core `signal::envelope_stream`, docs/model.md §7).
#[pyfunction]
fn super_slow_signals<'py>(py: Python<'py>, w: In<'py>, s: In<'py>, dt_s: f64, thickness_m: f64, window_s: f64) -> CoreResult<(f64, f64, Out<'py>, Out<'py>)> {
    let (w, s) = (w.as_slice()?.to_vec(), s.as_slice()?.to_vec());
    let x = released(py, || EnvelopeStream::of_series(&w, &s, dt_s, thickness_m, window_s))?;
    Ok((x.t0_s, x.dt_s, x.s.into_pyarray(py), x.amplitude_h.into_pyarray(py)))
}

/// Behaviour classification (docs/model.md §8) of super-slow signals: the core's `Classification` as a dict;
/// `criteria`: the core's `Criteria` by key (missing keys: the defaults).
#[pyfunction]
#[pyo3(signature = (s, amplitude_h, dt_s, *, t0_s=0.0, criteria=None))]
fn classify<'py>(py: Python<'py>, s: In<'_>, amplitude_h: In<'_>, dt_s: f64, t0_s: f64, criteria: Option<&Bound<'_, PyDict>>) -> CoreResult<Bound<'py, PyAny>> {
    let criteria: Criteria = criteria.map_or_else(|| Ok(Criteria::default()), |c| table("criteria", c.as_any()))?.validated()?;
    let x = SuperSlow { t0_s, dt_s, s: s.as_slice()?.to_vec(), amplitude_h: amplitude_h.as_slice()?.to_vec() };
    object(py, &released(py, || beamslider_core::classify(&x, &criteria))?)
}

/// The values of an inclusive range START:STOP:STEP (core `map::Axis`); errors name `field`.
#[pyfunction]
fn range_values(field: &str, start: f64, stop: f64, step: f64) -> CoreResult<Vec<f64>> {
    Ok(beamslider_core::Axis::Range { start, stop, step }.values(field)?)
}

/// Register the signal functions.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    crate::convert::export!(m, recorded_rows, moving_average, envelope, plain_numbers, classify, super_slow_signals, range_values);
    Ok(())
}
