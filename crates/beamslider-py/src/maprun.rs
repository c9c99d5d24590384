//! Operating maps (binding of core `map::session`, docs/model.md §8): `MapRun` wraps a
//! `MapSession` (results locked, checked, jobs planned) whose jobs run here or elsewhere
//! ([`run_map_chunk`] on a Dask worker); `ResultsLock` for the other results files.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use beamslider_core::map::{MapSession, WireJob, run_chunk};
use beamslider_core::{MapConfig, MapRow, MapRunOptions, ResultsLock};
use pyo3::prelude::*;

use crate::{detached, guarded};

/// The results of a map: `MapRun(config_toml, out=None, resume=False, extend=False)` checks the
/// map, takes the lock of `out` (a second writer fails at once: `BlockingIOError` naming the
/// folder and the holder's PID), cuts off a torn last line, writes the header and plans the jobs.
#[pyclass(module = "beamslider._core", frozen)]
pub struct MapRun(MapSession);

#[pymethods]
impl MapRun {
    #[new]
    #[pyo3(signature = (config_toml, *, out=None, resume=false, extend=false))]
    fn new(py: Python<'_>, config_toml: &str, out: Option<PathBuf>, resume: bool, extend: bool) -> PyResult<Self> {
        let cfg = guarded(|| MapConfig::from_toml_str(config_toml))?;
        let opts = MapRunOptions { out, resume, threads: None, extend };
        Ok(MapRun(py.detach(|| guarded(|| MapSession::open(cfg, &opts)))?))
    }

    /// Rows so far (kept and appended).
    #[getter]
    fn done(&self) -> usize {
        self.0.done()
    }

    /// The jobs still to run: (grid index, None | row JSON to continue).
    fn jobs(&self) -> Vec<WireJob> {
        self.0.wire_jobs()
    }

    /// Append rows (JSON texts of `run_map_chunk`) computed elsewhere; rows of points already in
    /// the results are skipped. Returns the number appended.
    fn append(&self, py: Python<'_>, rows: Vec<String>) -> PyResult<usize> {
        py.detach(|| guarded(|| self.0.append_json(&rows)))
    }

    /// Run the remaining jobs here on `threads` threads (default one per core), the interpreter
    /// released; `progress(done, total)` from the calling thread; Ctrl-C cancels (finished
    /// points stay in the file) and raises KeyboardInterrupt.
    #[pyo3(signature = (*, threads=None, progress=None))]
    fn run_local(&self, py: Python<'_>, threads: Option<usize>, progress: Option<Py<PyAny>>) -> PyResult<()> {
        let cancel = AtomicBool::new(false);
        let poll = |py: Python<'_>| progress.as_ref().map_or(Ok(()), |cb| cb.call1(py, (self.0.done(), self.0.total)).map(|_| ()));
        detached(py, &cancel, 100, || self.0.run_local(threads, &cancel, None), poll)
    }

    /// Close the results (release the lock) and return (rows of the grid as JSON texts sorted by
    /// index, the number of continued points). KeyboardInterrupt when points are missing.
    fn finish(&self) -> PyResult<(Vec<String>, usize)> {
        let (rows, extended) = guarded(|| self.0.finish())?;
        Ok((rows.iter().map(MapRow::to_json).collect(), extended))
    }

    /// Release the lock without collecting the rows.
    fn close(&self) {
        self.0.close();
    }
}

/// A Dask task of a map: run `jobs` (see `MapRun.jobs`) of the map `config_toml` on `threads`
/// rayon threads (default 1) with the interpreter released; returns the rows as JSON texts sorted
/// by grid index. Each row is bitwise the row the local runner writes (but `wall_time_s`).
#[pyfunction]
#[pyo3(signature = (config_toml, jobs, *, threads=1))]
pub fn run_map_chunk(py: Python<'_>, config_toml: &str, jobs: Vec<WireJob>, threads: usize) -> PyResult<Vec<String>> {
    let cfg = guarded(|| MapConfig::from_toml_str(config_toml))?;
    py.detach(|| guarded(|| run_chunk(&cfg, &jobs, threads, &AtomicBool::new(false))))
}

/// `ResultsLock(path)`: the one-writer lock of a results file (`<path>.lock`), taken at once or
/// `BlockingIOError` naming the folder and the holder's PID. `release()` or the end of a `with`
/// block frees it (as does the end of the process).
#[pyclass(module = "beamslider._core", name = "ResultsLock")]
pub struct PyResultsLock(Option<ResultsLock>);

#[pymethods]
impl PyResultsLock {
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        Ok(PyResultsLock(Some(guarded(|| ResultsLock::acquire(&path))?)))
    }

    fn release(&mut self) {
        self.0 = None;
    }

    fn __enter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    #[pyo3(signature = (*_args))]
    fn __exit__(&mut self, _args: &Bound<'_, pyo3::types::PyTuple>) -> bool {
        self.0 = None;
        false
    }
}

/// Register the map functions and classes.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<MapRun>()?;
    m.add_class::<PyResultsLock>()?;
    crate::export!(m, run_map_chunk);
    Ok(())
}
