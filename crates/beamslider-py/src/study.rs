//! Uncertainty studies (binding side): converts a chunk of study points to the core's
//! [`beamslider_core::study::run_points`] (the one batch runner; rows in the operating-map row
//! format, docs/model.md §8) and the rows back to JSON text. The interpreter is released while
//! the chunk runs; finished rows are handed to `on_rows` from the calling thread.
//!
//! The sampling, the statistics and the distribution over a Dask cluster live in
//! `python/beamslider/study/`; a Dask task calls [`run_study_chunk`] on a worker.

use std::collections::HashMap;
use std::sync::Mutex;
use std::sync::atomic::AtomicBool;

use beamslider_core::study::{RowInfo, StudyPoint, StudyResults, run_points};
use beamslider_core::{MapConfig, MapRow};
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;

use crate::{detached, guarded};

/// One point of a chunk: (index, parameter TOML, f_ex [Hz], a_ex [m/s²], s₀, duration [s]).
type ChunkPoint = (usize, String, f64, f64, f64, f64);

/// Run a chunk of study points in parallel (`threads` workers, default one per core) with the
/// interpreter released. `config_toml` is a map configuration (record_every, dt_s, criteria; its
/// grid and parameters are not used); each point brings its own full parameter TOML, operating
/// point and duration.
///
/// Returns the rows as JSON texts (the map row format, `index` = the point's index), sorted by
/// index. `on_rows(list_of_json)` is called from the calling thread with the rows finished since
/// the last call (at most every 50 ms; streaming to a results file); Ctrl-C (in the main thread)
/// or an exception in `on_rows` cancels the chunk.
#[pyfunction]
#[pyo3(signature = (config_toml, points, *, threads=None, on_rows=None))]
fn run_study_chunk(
    py: Python<'_>,
    config_toml: &str,
    points: Vec<ChunkPoint>,
    threads: Option<usize>,
    on_rows: Option<Py<PyAny>>,
) -> PyResult<Vec<String>> {
    let cfg = guarded(|| MapConfig::from_toml_str(config_toml))?;
    let points: Vec<StudyPoint> = points
        .into_iter()
        .map(|(index, params_toml, f_ex_hz, a_ex_m_s2, s0, duration_s)| StudyPoint { index, params_toml, f_ex_hz, a_ex_m_s2, s0, duration_s })
        .collect();
    let cancel = AtomicBool::new(false);
    let fresh: Mutex<Vec<String>> = Mutex::new(Vec::new());
    let drain = |py: Python<'_>| -> PyResult<()> {
        py.check_signals()?;
        let batch: Vec<String> = std::mem::take(&mut *fresh.lock().unwrap_or_else(|e| e.into_inner()));
        match &on_rows {
            Some(cb) if !batch.is_empty() => cb.call1(py, (batch,)).map(|_| ()),
            _ => Ok(()),
        }
    };
    let push = |row: &MapRow| {
        fresh.lock().unwrap_or_else(|e| e.into_inner()).push(row.to_json());
        Ok(())
    };
    let rows = detached(py, &cancel, 50, || run_points(&cfg, &points, threads, &cancel, push), drain)?;
    drain(py)?;
    match rows {
        Some(rows) => Ok(rows.iter().map(MapRow::to_json).collect()),
        None => Err(PyKeyboardInterrupt::new_err("study chunk interrupted")),
    }
}

/// One point's row keys: (index, f_ex [Hz], a_ex [m/s²], s₀, sample, point, parameter values as JSON).
type PointInfo = (usize, f64, f64, f64, usize, usize, String);

fn json(text: &str, what: &str) -> PyResult<serde_json::Value> {
    serde_json::from_str(text).map_err(|e| PyValueError::new_err(format!("invalid parameter `{what}`: not JSON ({e})")))
}

/// The results of a study (core `study::StudyResults`): the file `path` (None: in memory only),
/// opened for the map configuration `config_toml`, the study configuration `study_json` (header)
/// and the points `points`; `resume` keeps the rows of an existing file of the same study.
#[pyclass(name = "StudyResults", module = "beamslider._core")]
struct PyStudyResults(StudyResults);

#[pymethods]
impl PyStudyResults {
    #[new]
    #[pyo3(signature = (path, config_toml, study_json, points, *, resume=false))]
    fn new(path: Option<std::path::PathBuf>, config_toml: &str, study_json: &str, points: Vec<PointInfo>, resume: bool) -> PyResult<Self> {
        let cfg = guarded(|| MapConfig::from_toml_str(config_toml))?;
        let study = json(study_json, "study_json")?;
        let mut info = HashMap::with_capacity(points.len());
        for (index, f_ex_hz, a_ex_m_s2, s0, sample, point, params) in points {
            info.insert(index, RowInfo { f_ex_hz, a_ex_m_s2, s0, sample, point, params: json(&params, "points")? });
        }
        Ok(PyStudyResults(guarded(|| StudyResults::open(path.as_deref(), &cfg, study, info, resume))?))
    }

    /// Add rows (JSON texts of map rows): each gets its study keys and is appended at once.
    fn add(&mut self, rows: Vec<String>) -> PyResult<()> {
        for text in rows {
            let row: MapRow = serde_json::from_str(&text).map_err(|e| PyValueError::new_err(format!("invalid parameter `rows`: not a map row ({e})")))?;
            guarded(|| self.0.add(row))?;
        }
        Ok(())
    }

    /// Whether point `index` has its row.
    fn __contains__(&self, index: usize) -> bool {
        self.0.contains(index)
    }

    fn __len__(&self) -> usize {
        self.0.len()
    }

    /// The rows as JSON texts, sorted by index.
    fn rows(&self) -> Vec<String> {
        self.0.rows().map(MapRow::to_json).collect()
    }

    /// Close the file.
    fn close(&mut self) {
        self.0.close();
    }
}

/// Read a results file (map or study): (header as JSON text or None, rows as JSON texts with
/// all their keys, byte length of the complete part, whether the last line was truncated).
#[pyfunction]
fn read_results_file(py: Python<'_>, path: std::path::PathBuf) -> PyResult<(Option<String>, Vec<String>, u64, bool)> {
    let r = py.detach(|| guarded(|| beamslider_core::results::read_results(&path)))?;
    let header = r.header_json();
    Ok((header, r.rows.iter().map(MapRow::to_json).collect(), r.good_len, r.truncated))
}

/// Register the study functions in the `_core` module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(run_study_chunk, m)?)?;
    m.add_function(wrap_pyfunction!(read_results_file, m)?)?;
    m.add_class::<PyStudyResults>()?;
    Ok(())
}
