//! Uncertainty studies (core `study`, docs/model.md §8): chunks of study points, the study's results
//! file and the reader of map and study results files; sampling and statistics are Python's.

use std::sync::Mutex;
use std::sync::atomic::AtomicBool;

use beamslider_core::MapRow;
use beamslider_core::study::{StudyPoint, StudyResults, run_points};
use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;

use crate::convert::{detached, table};
use crate::error::{CoreResult, guarded, released};
use crate::{maprun::PyMapConfig, params::PyParams};

/// A study point as Python gives it: (index, parameters, f_ex [Hz], a_ex [m/s²], s₀, duration [s]).
type Point<'py> = (usize, Bound<'py, PyParams>, f64, f64, f64, f64);

/// Run a chunk of study points in parallel (core `study::run_points`), each with its validated parameters:
/// rows as JSON texts sorted by index (the lines of the results file).
#[pyfunction]
#[pyo3(signature = (config, points, *, threads=None, on_rows=None))]
fn run_study_chunk(
    py: Python<'_>, config: &Bound<'_, PyMapConfig>, points: Vec<Point<'_>>, threads: Option<usize>, on_rows: Option<Py<PyAny>>,
) -> CoreResult<Vec<String>> {
    let cfg = &config.get().cfg;
    let points: Vec<StudyPoint> = points.into_iter().map(|(i, p, f, a, s0, d)| StudyPoint::from((i, p.get().0.clone(), f, a, s0, d))).collect();
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
    /// `study`: the study's header (a dict); `points`: per point a dict of index, f_ex_hz, a_ex_m_s2, s0,
    /// sample, point and params (the uncertain values).
    #[new]
    #[pyo3(signature = (path, config, study, points, *, resume=false))]
    fn new(
        path: Option<std::path::PathBuf>, config: &Bound<'_, PyMapConfig>, study: &Bound<'_, PyAny>, points: &Bound<'_, PyAny>, resume: bool,
    ) -> CoreResult<Self> {
        let (study, points) = (table("study", study)?, table("points", points)?);
        Ok(PyStudyResults(guarded(|| StudyResults::open_values(path.as_deref(), &config.get().cfg, study, points, resume))?))
    }

    /// Add rows (JSON texts of map rows): each gets its study keys and is appended at once.
    fn add(&mut self, rows: Vec<String>) -> CoreResult<()> {
        Ok(guarded(|| self.0.add_json(&rows))?)
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
fn read_results_file(py: Python<'_>, path: std::path::PathBuf) -> CoreResult<(Option<String>, Vec<String>, u64, bool)> {
    let r = released(py, || beamslider_core::results::read_results(&path))?;
    Ok((r.header_json(), r.rows.iter().map(MapRow::to_json).collect(), r.good_len, r.truncated))
}

/// Register the study functions in the `_core` module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    crate::convert::export!(m, run_study_chunk, read_results_file);
    m.add_class::<PyStudyResults>()?;
    Ok(())
}
