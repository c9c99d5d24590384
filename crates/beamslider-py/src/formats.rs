//! The core's formats and formulas: the manifold CSV, the map's letter table, the backbone and JSON-lines results files.

use std::path::PathBuf;

use beamslider_core::map::table_of_columns;
use beamslider_core::{Beam, Branch, manifold, results};
use pyo3::prelude::*;

use crate::guarded;

/// The manifold CSV of two sweeps (s, amplitude [m] each), as the core writes it.
#[pyfunction]
fn manifold_csv(up_s: Vec<f64>, up_amplitude_m: Vec<f64>, down_s: Vec<f64>, down_amplitude_m: Vec<f64>) -> String {
    manifold::csv_text(&Branch { s: up_s, amplitude_m: up_amplitude_m }, &Branch { s: down_s, amplitude_m: down_amplitude_m })
}

type Columns = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, Vec<String>, Vec<String>, Vec<bool>);

/// The letter table of a map and its "t_end = … s" text, from its columns (core `map::table_of_columns`).
#[pyfunction]
fn map_text_table(columns: Columns) -> PyResult<(String, String)> {
    let (s0, f, a, t, status, behaviour, settled) = columns;
    guarded(|| table_of_columns(&s0, &f, &a, &t, &status, &behaviour, &settled))
}

/// Squared backbone frequencies (ω² + ¾ b a²)/M₁ at the amplitudes a.
#[pyfunction]
fn backbone_omega2(omega2: f64, b: f64, amplitude: Vec<f64>, m1: f64) -> Vec<f64> {
    amplitude.iter().map(|&a| Beam::backbone_omega2(omega2, b, a, m1)).collect()
}

/// The complete lines of a JSON-lines results file (core `results::read_json_lines`).
#[pyfunction]
fn read_json_lines(py: Python<'_>, path: PathBuf, key: &str, version: u64) -> PyResult<(Vec<String>, u64, bool)> {
    let r = py.detach(|| guarded(|| results::read_json_lines(&path, key, version)))?;
    Ok((r.lines, r.good_len, r.truncated))
}

/// Append lines to a JSON-lines results file, after cutting it to `good_len` when given.
#[pyfunction]
#[pyo3(signature = (path, lines, good_len = None))]
fn append_json_lines(py: Python<'_>, path: PathBuf, lines: Vec<String>, good_len: Option<u64>) -> PyResult<()> {
    py.detach(|| guarded(|| results::append_json_lines(&path, good_len, &lines)))
}

/// Register the format functions in the `_core` module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    crate::export!(m, manifold_csv, map_text_table, backbone_omega2, read_json_lines, append_json_lines);
    Ok(())
}
