//! Core `superslow` (docs/model.md §6.3–6.4): the harmonic-balance super-slow manifold, its N = 1
//! closed form, the backbone and PCS drift tables (the predictor: `predictor.rs`).

use beamslider_core::dynamics::runner::SharedMonitor;
use beamslider_core::superslow::drift::{DriftOptions, drift_table_pcs as core_drift};
use beamslider_core::superslow::{HbOptions, backbone, closed_form_n1_scaled, hb_manifold as core_hb};
use beamslider_core::{Excitation, Model};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{kwargs, monitored, object};
use crate::error::{CoreResult, released};
use crate::params::PyParams;

/// HB super-slow manifold (docs/model.md §6.4) as a dict; `options`: the core's `HbOptions`.
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, **options))]
pub fn hb_manifold<'py>(
    py: Python<'py>, params: &Bound<'_, PyParams>, f_ex_hz: f64, a_ex_m_s2: f64, options: Option<&Bound<'_, PyDict>>,
) -> CoreResult<Bound<'py, PyAny>> {
    let (params, opts): (_, HbOptions) = (params.get().0.clone(), kwargs(py, options)?);
    object(py, &released(py, || core_hb(&params, f_ex_hz, a_ex_m_s2, &opts))?)
}

/// N = 1 closed form (docs/model.md §6.4) on `s_values`: the core's `ClosedFormN1` as a dict.
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, s_values, d_eff=None, omega1_factor=1.0))]
pub fn hb_closed_form_n1<'py>(
    py: Python<'py>, params: &Bound<'_, PyParams>, f_ex_hz: f64, a_ex_m_s2: f64, s_values: Vec<f64>, d_eff: Option<f64>, omega1_factor: f64,
) -> CoreResult<Bound<'py, PyAny>> {
    let params = params.get().0.clone();
    object(py, &released(py, || closed_form_n1_scaled(&params, f_ex_hz, a_ex_m_s2, &s_values, d_eff, omega1_factor))?)
}

/// Single-mode backbone with the slider Ω_bb(Â, s) [rad/s] (docs/model.md §6.4) at paired values.
#[pyfunction]
#[pyo3(signature = (params, amplitude_h, s, omega1_factor=1.0))]
pub fn hb_backbone(py: Python<'_>, params: &Bound<'_, PyParams>, amplitude_h: Vec<f64>, s: Vec<f64>, omega1_factor: f64) -> CoreResult<Vec<f64>> {
    let params = params.get().0.clone();
    released(py, || backbone(&params, &amplitude_h, &s, omega1_factor))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    crate::convert::export!(m, hb_manifold, hb_closed_form_n1, hb_backbone, drift_table_pcs, read_drift_table);
    Ok(())
}

/// PCS drift table V(s, branch) (docs/model.md §6.4, core `drift_table_pcs`); `options`: the core's `DriftOptions`;
/// (header, rows, points computed) with the header and rows as dicts.
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, out=None, resume=false, progress=None, **options))]
pub fn drift_table_pcs<'py>(
    py: Python<'py>, params: &Bound<'_, PyParams>, f_ex_hz: f64, a_ex_m_s2: f64, out: Option<std::path::PathBuf>, resume: bool, progress: Option<Py<PyAny>>,
    options: Option<&Bound<'py, PyDict>>,
) -> CoreResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, usize)> {
    let (params, opts): (_, DriftOptions) = (params.get().0.clone(), kwargs(py, options)?);
    let exc = Excitation::new(f_ex_hz, a_ex_m_s2);
    let work = |m: &SharedMonitor| core_drift(&Model::of(&params)?, &exc, &opts, out.as_deref(), resume, m.cancel(), &|d, t| m.report(d as f64, t as f64));
    let table = monitored(py, progress, None, work)?;
    Ok((object(py, &table.header)?, object(py, &table.rows)?, table.computed))
}

/// Read a drift-table file (the core's one reader): (header, rows) as dicts.
#[pyfunction]
pub fn read_drift_table<'py>(py: Python<'py>, path: std::path::PathBuf) -> CoreResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let (h, rows) = released(py, || beamslider_core::superslow::drift::read_drift_table(&path))?;
    Ok((object(py, &h)?, object(py, &rows)?))
}
