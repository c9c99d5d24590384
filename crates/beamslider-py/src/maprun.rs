//! Operating maps (binding side, docs/model.md §8): the results file of a map as an object
//! (`MapRun`: locked, validated, jobs planned; rows appended one write each) that runs its jobs
//! here on rayon threads or receives the rows of jobs run elsewhere (chunks on a Dask cluster,
//! [`run_map_chunk`]); `ResultsLock` for the other results files (study.jsonl).

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use beamslider_core::map::{Job, MapResults, run_jobs};
use beamslider_core::{Error, MapConfig, MapRow, MapRunOptions, ResultsLock};
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;

use crate::guarded;

/// A job as it crosses to Python and to Dask workers: (grid index, None) for a run from rest,
/// (grid index, row JSON with its end state) for a continuation.
type JobTuple = (usize, Option<String>);

fn row_json(r: &MapRow) -> String {
    MapRow::to_json(r)
}

fn job_tuple(j: &Job) -> JobTuple {
    match j {
        Job::Fresh(p) => (p.index, None),
        Job::Continue(p, row) => (p.index, Some(row_json(row))),
    }
}

fn parse_row(text: &str) -> Result<MapRow, Error> {
    serde_json::from_str(text).map_err(|e| Error::invalid("row", "JSON", &format!("not a map row: {e}")))
}

/// The results of a map: `MapRun(config_toml, out=None, resume=False, extend=False)` checks the
/// map, takes the lock of `out` (a second writer fails at once: `BlockingIOError` naming the
/// folder and the holder's PID), cuts off a torn last line, writes the header and plans the jobs.
#[pyclass(module = "beamslider._core")]
pub struct MapRun {
    cfg: MapConfig,
    inner: Option<MapResults>,
    jobs: Vec<Job>,
}

impl MapRun {
    fn inner(&mut self) -> PyResult<&mut MapResults> {
        self.inner.as_mut().ok_or_else(|| PyValueError::new_err("the map's results are closed"))
    }
}

#[pymethods]
impl MapRun {
    #[new]
    #[pyo3(signature = (config_toml, *, out=None, resume=false, extend=false))]
    fn new(py: Python<'_>, config_toml: &str, out: Option<PathBuf>, resume: bool, extend: bool) -> PyResult<Self> {
        let cfg = guarded(|| MapConfig::from_toml_str(config_toml))?;
        let opts = MapRunOptions { out, resume, threads: None, extend };
        let mut inner = py.detach(|| guarded(|| MapResults::open(&cfg, &opts)))?;
        let jobs = std::mem::take(&mut inner.jobs);
        Ok(MapRun { cfg, inner: Some(inner), jobs })
    }

    /// Points in the grid.
    #[getter]
    fn total(&self) -> usize {
        self.inner.as_ref().map_or(0, |r| r.total)
    }

    /// Not-settled points continued from their end states.
    #[getter]
    fn extended(&self) -> usize {
        self.inner.as_ref().map_or(0, |r| r.extended)
    }

    /// Rows so far (kept and appended).
    #[getter]
    fn done(&self) -> usize {
        self.inner.as_ref().map_or(0, |r| r.rows.len())
    }

    /// The jobs still to run: (grid index, None | row JSON to continue).
    fn jobs(&self) -> Vec<JobTuple> {
        self.jobs.iter().map(job_tuple).collect()
    }

    /// Append rows (JSON texts of `run_map_chunk`) computed elsewhere; rows of points already in
    /// the results are skipped (a chunk re-run after a lost worker). Returns the number appended.
    fn append(&mut self, py: Python<'_>, rows: Vec<String>) -> PyResult<usize> {
        let inner = self.inner()?;
        py.detach(|| {
            guarded(|| {
                let mut n = 0;
                for text in &rows {
                    let row = parse_row(text)?;
                    if inner.rows.iter().any(|r| r.index == row.index) {
                        continue;
                    }
                    inner.append(row)?;
                    n += 1;
                }
                Ok(n)
            })
        })
    }

    /// Run the remaining jobs here on `threads` threads (default one per core), the interpreter
    /// released; `progress(done, total)` from the calling thread; Ctrl-C cancels (finished
    /// points stay in the file) and raises KeyboardInterrupt.
    #[pyo3(signature = (*, threads=None, progress=None))]
    fn run_local(&mut self, py: Python<'_>, threads: Option<usize>, progress: Option<Py<PyAny>>) -> PyResult<()> {
        crate::check_threads(threads)?;
        let jobs = std::mem::take(&mut self.jobs);
        let cfg = self.cfg.clone();
        let inner = self.inner()?;
        let total = inner.total;
        let done = AtomicUsize::new(inner.rows.len());
        let sink = Mutex::new(inner);
        let cancel = AtomicBool::new(false);
        let poll = |py: Python<'_>| -> PyResult<()> {
            py.check_signals()?;
            match &progress {
                Some(cb) => cb.call1(py, (done.load(Ordering::Relaxed), total)).map(|_| ()),
                None => Ok(()),
            }
        };
        crate::detached(
            py,
            &cancel,
            100,
            || {
                run_jobs(&cfg, &jobs, threads, &cancel, &|row| {
                    let mut g = sink.lock().unwrap_or_else(|e| e.into_inner());
                    g.append(row)?;
                    done.store(g.rows.len(), Ordering::Relaxed);
                    Ok(())
                })
            },
            &poll,
        )?;
        poll(py)?;
        if cancel.load(Ordering::Relaxed) {
            return Err(PyKeyboardInterrupt::new_err("map interrupted"));
        }
        Ok(())
    }

    /// Close the results (release the lock) and return (rows of the grid as JSON texts sorted by
    /// index, the number of continued points). KeyboardInterrupt when points are missing.
    fn finish(&mut self) -> PyResult<(Vec<String>, usize)> {
        let inner = self.inner.take().ok_or_else(|| PyValueError::new_err("the map's results are closed"))?;
        let outcome = inner.finish();
        if outcome.cancelled {
            return Err(PyKeyboardInterrupt::new_err("map interrupted"));
        }
        Ok((outcome.rows.iter().map(row_json).collect(), outcome.extended))
    }

    /// Release the lock without collecting the rows.
    fn close(&mut self) {
        self.inner = None;
    }
}

/// A Dask task of a map: run `jobs` (see `MapRun.jobs`) of the map `config_toml` on `threads`
/// rayon threads (default 1) with the interpreter released; returns the rows as JSON texts sorted
/// by grid index. Each row is bitwise the row the local runner writes (but `wall_time_s`).
#[pyfunction]
#[pyo3(signature = (config_toml, jobs, *, threads=1))]
pub fn run_map_chunk(py: Python<'_>, config_toml: &str, jobs: Vec<JobTuple>, threads: usize) -> PyResult<Vec<String>> {
    if threads == 0 {
        return Err(PyValueError::new_err("invalid parameter `threads` = 0: must be >= 1"));
    }
    let cfg = guarded(|| MapConfig::from_toml_str(config_toml))?;
    let cancel = AtomicBool::new(false);
    py.detach(|| {
        guarded(|| {
            let points: HashMap<usize, beamslider_core::MapPoint> = cfg.points()?.into_iter().map(|p| (p.index, p)).collect();
            let jobs: Vec<Job> = jobs
                .iter()
                .map(|(i, row)| {
                    let p = *points.get(i).ok_or_else(|| Error::invalid("jobs", i, "not a grid index of this map"))?;
                    Ok(match row {
                        None => Job::Fresh(p),
                        Some(text) => Job::Continue(p, Box::new(parse_row(text)?)),
                    })
                })
                .collect::<Result<_, Error>>()?;
            let mut rows: Vec<MapRow> = Vec::with_capacity(jobs.len());
            run_jobs(&cfg, &jobs, Some(threads), &cancel, |row| {
                rows.push(row);
                Ok(())
            })?;
            rows.sort_by_key(|r| r.index);
            Ok(rows.iter().map(row_json).collect())
        })
    })
}

/// `ResultsLock(path)`: the one-writer lock of a results file (`<path>.lock`), taken at once or
/// `BlockingIOError` naming the folder and the holder's PID. `release()` or the end of a `with`
/// block frees it (as does the end of the process).
#[pyclass(module = "beamslider._core", name = "ResultsLock")]
pub struct PyResultsLock {
    lock: Option<ResultsLock>,
}

#[pymethods]
impl PyResultsLock {
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        Ok(PyResultsLock { lock: Some(guarded(|| ResultsLock::acquire(&path))?) })
    }

    fn release(&mut self) {
        self.lock = None;
    }

    fn __enter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    #[pyo3(signature = (*_args))]
    fn __exit__(&mut self, _args: &Bound<'_, pyo3::types::PyTuple>) -> bool {
        self.lock = None;
        false
    }
}

/// Register the map functions and classes.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<MapRun>()?;
    m.add_class::<PyResultsLock>()?;
    m.add_function(wrap_pyfunction!(run_map_chunk, m)?)?;
    Ok(())
}
