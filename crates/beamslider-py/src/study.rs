//! Uncertainty studies (core `study`, docs/model.md §8): chunks of study points, the study's results
//! file and the reader of map and study results files; sampling and statistics are Python's.

use std::sync::Mutex;
use std::sync::atomic::AtomicBool;

use beamslider_core::MapRow;
use beamslider_core::study::{PointTuple, StudyPoint, StudyResults, run_points};
use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;

use crate::{detached, guarded, maprun::PyMapConfig};

/// Run a chunk of study points in parallel (core `study::run_points`): rows as JSON texts sorted by index.
#[pyfunction]
#[pyo3(signature = (config, points, *, threads=None, on_rows=None))]
fn run_study_chunk(
    py: Python<'_>, config: &Bound<'_, PyMapConfig>, points: Vec<PointTuple>, threads: Option<usize>, on_rows: Option<Py<PyAny>>,
) -> PyResult<Vec<String>> {
    let cfg = &config.get().cfg;
    let points: Vec<StudyPoint> = points.into_iter().map(StudyPoint::from).collect();
    let (cancel, fresh) = (AtomicBool::new(false), Mutex::new(Vec::new()));
    let drain = |py: Python<'_>| {
        let batch: Vec<String> = std::mem::take(&mut *fresh.lock().unwrap_or_else(|e| e.into_inner()));
        on_rows.as_ref().filter(|_| !batch.is_empty()).map_or(Ok(()), |cb| cb.call1(py, (batch,)).map(|_| ()))
    };
    let push = |row: &MapRow| {
        fresh.lock().unwrap_or_else(|e| e.into_inner()).push(row.to_json());
        Ok(())
    };
    let rows = detached(py, &cancel, 50, || run_points(cfg, &points, threads, &cancel, push), drain)?;
    let rows = rows.ok_or_else(|| PyKeyboardInterrupt::new_err("study chunk interrupted"))?;
    Ok(rows.iter().map(MapRow::to_json).collect())
}

/// The results of a study (core `study::StudyResults`), in a file or in memory.
#[pyclass(name = "StudyResults", module = "beamslider._core")]
struct PyStudyResults(StudyResults);

#[pymethods]
impl PyStudyResults {
    #[new]
    #[pyo3(signature = (path, config, study_json, points_json, *, resume=false))]
    fn new(path: Option<std::path::PathBuf>, config: &Bound<'_, PyMapConfig>, study_json: &str, points_json: &str, resume: bool) -> PyResult<Self> {
        Ok(PyStudyResults(guarded(|| StudyResults::open_json(path.as_deref(), &config.get().cfg, study_json, points_json, resume))?))
    }

    /// Add rows (JSON texts of map rows): each gets its study keys and is appended at once.
    fn add(&mut self, rows: Vec<String>) -> PyResult<()> {
        guarded(|| self.0.add_json(&rows))
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

/// Read a results file (map or study; core `results::read_results`).
#[pyfunction]
fn read_results_file(py: Python<'_>, path: std::path::PathBuf) -> PyResult<(Option<String>, Vec<String>, u64, bool)> {
    let r = py.detach(|| guarded(|| beamslider_core::results::read_results(&path)))?;
    Ok((r.header_json(), r.rows.iter().map(MapRow::to_json).collect(), r.good_len, r.truncated))
}

/// Register the study functions in the `_core` module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    crate::export!(m, run_study_chunk, read_results_file);
    m.add_class::<PyStudyResults>()?;
    Ok(())
}
