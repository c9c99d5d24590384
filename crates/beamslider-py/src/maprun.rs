//! Operating maps (core `map`, docs/model.md §8): `MapConfig`, `MapRun` (a core `MapSession` whose
//! jobs run here or in [`run_map_chunk`] on a Dask worker) and `ResultsLock` for other results files.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use beamslider_core::map::{DEFAULT_RECORD_EVERY, MapSession, WireJob, run_chunk};
use beamslider_core::{Axis, Criteria, Grid, MapConfig, MapRow, MapRunOptions, ResultsLock};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyType};

use crate::convert::{detached, table};
use crate::error::{CoreResult, guarded, released};
use crate::params::PyParams;

/// A map configuration (core `MapConfig`) parsed and checked once (pickled as its canonical TOML).
#[pyclass(name = "MapConfig", module = "beamslider._core", frozen)]
pub struct PyMapConfig {
    pub cfg: MapConfig,
}

#[pymethods]
impl PyMapConfig {
    /// A configuration from the text of a TOML file (`map.toml`, `beamslider map --config`).
    #[new]
    fn new(text: &str) -> CoreResult<Self> {
        Ok(PyMapConfig { cfg: guarded(|| MapConfig::from_toml_str(text))? })
    }

    /// A configuration from its parts, without TOML (`criteria`: the core's `Criteria` by name);
    /// `params` validated before are not validated again (unless `dt_s` overrides their step).
    #[staticmethod]
    #[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, s0, duration_s, record_every=DEFAULT_RECORD_EVERY, dt_s=None, criteria=None))]
    fn of(
        params: &Bound<'_, PyParams>, f_ex_hz: Vec<f64>, a_ex_m_s2: Vec<f64>, s0: Vec<f64>, duration_s: f64, record_every: usize, dt_s: Option<f64>,
        criteria: Option<&Bound<'_, PyDict>>,
    ) -> CoreResult<Self> {
        let grid = Grid { f_ex_hz: Axis::List(f_ex_hz), a_ex_m_s2: Axis::List(a_ex_m_s2), s0: Axis::List(s0) };
        let criteria: Criteria = criteria.map_or_else(|| Ok(Criteria::default()), |c| table("criteria", c.as_any()))?;
        let cfg = MapConfig::of(duration_s, dt_s, record_every, grid, &params.get().0, criteria);
        Ok(PyMapConfig { cfg: guarded(|| cfg.validate().map(|()| cfg))? })
    }

    /// This configuration for another duration (`--extend-to`), checked.
    fn with_duration(&self, duration_s: f64) -> CoreResult<Self> {
        let mut cfg = self.cfg.clone();
        cfg.duration_s = duration_s;
        Ok(PyMapConfig { cfg: guarded(|| cfg.validate().map(|()| cfg))? })
    }

    /// Simulated duration per point [s].
    #[getter]
    fn duration_s(&self) -> f64 {
        self.cfg.duration_s
    }

    /// The paper's operating map.
    #[staticmethod]
    #[pyo3(name = "default")]
    fn paper() -> CoreResult<Self> {
        let cfg = MapConfig::default();
        Ok(PyMapConfig { cfg: guarded(|| cfg.validate().map(|()| cfg))? })
    }

    /// The canonical TOML text (what `map.toml` holds).
    fn toml(&self) -> String {
        self.cfg.to_toml_string()
    }

    /// The grid's axes: (f_ex [Hz], a_ex [m/s²], s0).
    #[getter]
    fn axes(&self) -> CoreResult<(Vec<f64>, Vec<f64>, Vec<f64>)> {
        Ok(self.cfg.axes()?)
    }

    /// Check the map and its results file before anything is written (core `map::preflight`).
    #[pyo3(signature = (*, out=None, resume=false, extend=false))]
    fn check(&self, py: Python<'_>, out: Option<PathBuf>, resume: bool, extend: bool) -> CoreResult<()> {
        let opts = MapRunOptions { out, resume, threads: None, extend };
        released(py, || beamslider_core::map::preflight(&self.cfg, &opts))
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> (Bound<'py, PyType>, (String,)) {
        (slf.get_type(), (slf.get().toml(),))
    }
}

/// The results of a map (core `MapSession`: checked, locked, torn line cut, header written, jobs planned).
#[pyclass(module = "beamslider._core", frozen)]
pub struct MapRun(MapSession);

#[pymethods]
impl MapRun {
    #[new]
    #[pyo3(signature = (config, *, out=None, resume=false, extend=false))]
    fn new(py: Python<'_>, config: &Bound<'_, PyMapConfig>, out: Option<PathBuf>, resume: bool, extend: bool) -> CoreResult<Self> {
        let cfg = config.get().cfg.clone();
        let opts = MapRunOptions { out, resume, threads: None, extend };
        Ok(MapRun(released(py, || MapSession::open(cfg, &opts))?))
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

    /// Append rows (JSON texts of `run_map_chunk`) computed elsewhere: the number appended.
    fn append(&self, py: Python<'_>, rows: Vec<String>) -> CoreResult<usize> {
        released(py, || self.0.append_json(&rows))
    }

    /// Run the remaining jobs here, the interpreter released (Ctrl-C: KeyboardInterrupt, finished points kept).
    #[pyo3(signature = (*, threads=None, progress=None))]
    fn run_local(&self, py: Python<'_>, threads: Option<usize>, progress: Option<Py<PyAny>>) -> CoreResult<()> {
        let cancel = AtomicBool::new(false);
        let poll = |py: Python<'_>| progress.as_ref().map_or(Ok(()), |cb| cb.call1(py, (self.0.done(), self.0.total)).map(|_| ()));
        detached(py, &cancel, 100, || self.0.run_local(threads, &cancel, None), poll)
    }

    /// Close the results: (rows as JSON texts by index, continued points); KeyboardInterrupt when points are missing.
    fn finish(&self) -> CoreResult<(Vec<String>, usize)> {
        let (rows, extended) = guarded(|| self.0.finish())?;
        Ok((rows.iter().map(MapRow::to_json).collect(), extended))
    }

    /// Release the lock without collecting the rows.
    fn close(&self) {
        self.0.close();
    }
}

/// A Dask task of a map: its rows, as JSON texts sorted by grid index (core `map::run_chunk`).
#[pyfunction]
#[pyo3(signature = (config, jobs, *, threads=1))]
pub fn run_map_chunk(py: Python<'_>, config: &Bound<'_, PyMapConfig>, jobs: Vec<WireJob>, threads: usize) -> CoreResult<Vec<String>> {
    let cfg = &config.get().cfg;
    released(py, || run_chunk(cfg, &jobs, threads, &AtomicBool::new(false)))
}

/// The one-writer lock of a results file (core `ResultsLock`), taken at once or `BlockingIOError`.
#[pyclass(module = "beamslider._core", name = "ResultsLock")]
pub struct PyResultsLock(Option<ResultsLock>);

#[pymethods]
impl PyResultsLock {
    #[new]
    fn new(path: PathBuf) -> CoreResult<Self> {
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
    crate::convert::export!(m, run_map_chunk);
    Ok(())
}
