//! Operating maps (binding of core `map`, docs/model.md §8): `MapConfig`, a configuration parsed
//! and checked once; `MapRun` wraps a `MapSession` (results locked, checked, jobs planned) whose
//! jobs run here or elsewhere ([`run_map_chunk`] on a Dask worker); `ResultsLock` for the other
//! results files.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use beamslider_core::map::{DEFAULT_RECORD_EVERY, MapSession, WireJob, run_chunk};
use beamslider_core::{Axis, Criteria, Grid, MapConfig, MapRow, MapRunOptions, ResultsLock};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyType};
use pythonize::depythonize;

use crate::params::PyParams;
use crate::{detached, guarded};

/// A map configuration (core `MapConfig`) parsed and checked once: `MapConfig(toml_text)`; the
/// map, study and predictor functions take it as it is (pickled as its canonical TOML).
#[pyclass(name = "MapConfig", module = "beamslider._core", frozen)]
pub struct PyMapConfig {
    pub cfg: MapConfig,
    axes: (Vec<f64>, Vec<f64>, Vec<f64>),
}

#[pymethods]
impl PyMapConfig {
    #[new]
    fn new(text: &str) -> PyResult<Self> {
        Self::checked(guarded(|| MapConfig::from_toml_str(text))?)
    }

    /// A configuration from its parts, without TOML: the parameters `params` (a `Params`), the
    /// grid's axes as lists, the duration [s], the recording interval, Δt [s] (None: the
    /// parameters') and the criteria (thresholds of the core's `Criteria` by name; None: defaults).
    #[staticmethod]
    #[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, s0, duration_s, record_every=DEFAULT_RECORD_EVERY, dt_s=None, criteria=None))]
    fn of(
        params: &Bound<'_, PyParams>, f_ex_hz: Vec<f64>, a_ex_m_s2: Vec<f64>, s0: Vec<f64>, duration_s: f64, record_every: usize, dt_s: Option<f64>,
        criteria: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let grid = Grid { f_ex_hz: Axis::List(f_ex_hz), a_ex_m_s2: Axis::List(a_ex_m_s2), s0: Axis::List(s0) };
        let (params, criteria) = (
            params.get().0.get().clone(),
            criteria.map_or(Ok(Criteria::default()), |c| depythonize(c)).map_err(|e| PyValueError::new_err(format!("invalid parameter `criteria`: {e}")))?,
        );
        let cfg = MapConfig { duration_s, dt_s, record_every, grid, params, criteria };
        Self::checked(guarded(|| cfg.validate().map(|()| cfg))?)
    }

    /// The paper's operating map.
    #[staticmethod]
    #[pyo3(name = "default")]
    fn paper() -> PyResult<Self> {
        Self::new(&MapConfig::default().to_toml_string())
    }

    /// The canonical TOML text (what `map.toml` holds).
    fn toml(&self) -> String {
        self.cfg.to_toml_string()
    }

    /// The grid's axes: (f_ex [Hz], a_ex [m/s²], s0).
    #[getter]
    fn axes(&self) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        self.axes.clone()
    }

    /// Check the map before anything is written: Δt and the results file `out` (exists without
    /// `resume`, other settings; with `extend`: the map to extend to the configuration's
    /// duration). Raises what `MapRun` would raise.
    #[pyo3(signature = (*, out=None, resume=false, extend=false))]
    fn check(&self, py: Python<'_>, out: Option<PathBuf>, resume: bool, extend: bool) -> PyResult<()> {
        let opts = MapRunOptions { out, resume, threads: None, extend };
        py.detach(|| guarded(|| beamslider_core::map::preflight(&self.cfg, &opts)))
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> (Bound<'py, PyType>, (String,)) {
        (slf.get_type(), (slf.get().toml(),))
    }
}

impl PyMapConfig {
    /// A checked configuration with its axes' values.
    fn checked(cfg: MapConfig) -> PyResult<Self> {
        Ok(PyMapConfig { axes: guarded(|| cfg.axes())?, cfg })
    }
}

/// The results of a map: `MapRun(config, out=None, resume=False, extend=False)` checks the
/// map, takes the lock of `out` (a second writer fails at once: `BlockingIOError` naming the
/// folder and the holder's PID), cuts off a torn last line, writes the header and plans the jobs.
#[pyclass(module = "beamslider._core", frozen)]
pub struct MapRun(MapSession);

#[pymethods]
impl MapRun {
    #[new]
    #[pyo3(signature = (config, *, out=None, resume=false, extend=false))]
    fn new(py: Python<'_>, config: &Bound<'_, PyMapConfig>, out: Option<PathBuf>, resume: bool, extend: bool) -> PyResult<Self> {
        let cfg = config.get().cfg.clone();
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

/// A Dask task of a map: run `jobs` (see `MapRun.jobs`) of the map `config` on `threads`
/// rayon threads (default 1) with the interpreter released; returns the rows as JSON texts sorted
/// by grid index. Each row is bitwise the row the local runner writes (but `wall_time_s`).
#[pyfunction]
#[pyo3(signature = (config, jobs, *, threads=1))]
pub fn run_map_chunk(py: Python<'_>, config: &Bound<'_, PyMapConfig>, jobs: Vec<WireJob>, threads: usize) -> PyResult<Vec<String>> {
    let cfg = &config.get().cfg;
    py.detach(|| guarded(|| run_chunk(cfg, &jobs, threads, &AtomicBool::new(false))))
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
    m.add_class::<PyMapConfig>()?;
    m.add_class::<MapRun>()?;
    m.add_class::<PyResultsLock>()?;
    crate::export!(m, run_map_chunk);
    Ok(())
}
