//! The core's formats: the manifold CSV, the map's letter table and JSON-lines results files.

use std::path::PathBuf;

use beamslider_core::map::table_of_columns;
use beamslider_core::{Branch, manifold, results};
use pyo3::prelude::*;

use crate::error::{CoreResult, released};

/// The manifold CSV of two sweeps (s, amplitude [m] each), as the core writes it.
#[pyfunction]
fn manifold_csv(up_s: Vec<f64>, up_amplitude_m: Vec<f64>, down_s: Vec<f64>, down_amplitude_m: Vec<f64>) -> String {
    manifold::csv_text(&Branch { s: up_s, amplitude_m: up_amplitude_m }, &Branch { s: down_s, amplitude_m: down_amplitude_m })
}

type Columns = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>, Vec<String>, Vec<String>, Vec<bool>);

/// The letter table of a map and its "t_end = … s" text, from its columns (core `map::table_of_columns`).
#[pyfunction]
fn map_text_table(py: Python<'_>, columns: Columns) -> CoreResult<(String, String)> {
    let (s0, f, a, t, status, behaviour, settled) = columns;
    released(py, || table_of_columns(&s0, &f, &a, &t, &status, &behaviour, &settled))
}

/// The complete lines of a JSON-lines results file (core `results::read_json_lines`).
#[pyfunction]
fn read_json_lines(py: Python<'_>, path: PathBuf, key: &str, version: u64) -> CoreResult<(Vec<String>, u64, bool)> {
    let r = released(py, || results::read_json_lines(&path, key, version))?;
    Ok((r.lines, r.good_len, r.truncated))
}

/// Append lines to a JSON-lines results file, after cutting it to `good_len` when given.
#[pyfunction]
#[pyo3(signature = (path, lines, good_len = None))]
fn append_json_lines(py: Python<'_>, path: PathBuf, lines: Vec<String>, good_len: Option<u64>) -> CoreResult<()> {
    released(py, || results::append_json_lines(&path, good_len, &lines))
}

/// Register the format functions in the `_core` module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    crate::convert::export!(m, manifold_csv, map_text_table, read_json_lines, append_json_lines);
    Ok(())
}
