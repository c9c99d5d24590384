//! Uncertainty studies (binding side): run a *chunk* of study points — each its own parameter set,
//! operating point (f_ex, a_ex, s₀) and duration — in parallel with rayon, the interpreter
//! released, and return the rows in the operating-map row format (`beamslider_core::map::MapRow`,
//! docs/model.md §8). Each point is the core's `map::run_point` (a free-slider run from rest,
//! classified by `classify`), so a study row is bitwise the map row of the same inputs.
//!
//! The sampling, the results file and the distribution over a Dask cluster live in
//! `python/beamslider/study.py`; a Dask task calls [`run_study_chunk`] on a worker.

use std::collections::HashMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use beamslider_core::{Error, MapConfig, MapPoint, MapRow, Model, Params, map};
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use rayon::prelude::*;

use crate::{SimulationError, guarded};

/// One point of a chunk: (index, parameter TOML, f_ex [Hz], a_ex [m/s²], s₀, duration [s]).
type ChunkPoint = (usize, String, f64, f64, f64, f64);

/// The settings of a map configuration (what decides a row besides its point) as JSON text: the
/// `settings` object of a results file's header line.
#[pyfunction]
fn map_settings_json(config_toml: &str) -> PyResult<String> {
    let cfg = guarded(|| MapConfig::from_toml_str(config_toml))?;
    serde_json::to_string(&cfg.settings()).map_err(|e| SimulationError::new_err(format!("internal error: {e}")))
}

/// Run a chunk of study points in parallel (rayon; `threads` workers, default one per core) with
/// the interpreter released. `config_toml` is a map configuration (record_every, dt_s, criteria;
/// its grid and parameters are not used); each point brings its own full parameter TOML, operating
/// point and duration. Points with the same parameter text share one `Model`.
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
    if threads == Some(0) {
        return Err(PyValueError::new_err("invalid parameter `threads` = 0: must be >= 1"));
    }
    let cfg = guarded(|| MapConfig::from_toml_str(config_toml))?;
    for (i, p) in points.iter().enumerate() {
        if !(p.5.is_finite() && p.5 > 0.0) {
            return Err(PyValueError::new_err(format!("invalid parameter `duration_s` = {} (point {i}): must be finite and > 0", p.5)));
        }
    }
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
    let (outcome, err) = py.detach(|| {
        std::thread::scope(|sc| {
            let worker = sc.spawn(|| guarded(|| run_chunk(&cfg, &points, threads, &cancel, &fresh)));
            let mut err: Option<PyErr> = None;
            while !worker.is_finished() {
                std::thread::sleep(std::time::Duration::from_millis(50));
                if err.is_none()
                    && let Err(e) = Python::attach(|py| drain(py))
                {
                    cancel.store(true, Ordering::Relaxed);
                    err = Some(e);
                }
            }
            let outcome = worker.join().unwrap_or_else(|_| Err(SimulationError::new_err("internal error: study worker panicked")));
            (outcome, err)
        })
    });
    if let Some(e) = err {
        return Err(e);
    }
    let rows = outcome?;
    drain(py)?;
    match rows {
        Some(rows) => Ok(rows),
        None => Err(PyKeyboardInterrupt::new_err("study chunk interrupted")),
    }
}

/// The chunk in the core: `None` when cancelled before all points were done.
fn run_chunk(cfg: &MapConfig, points: &[ChunkPoint], threads: Option<usize>, cancel: &AtomicBool, fresh: &Mutex<Vec<String>>) -> Result<Option<Vec<String>>, Error> {
    // One model per distinct parameter text (the configuration's dt_s override applies).
    let mut texts: Vec<&str> = points.iter().map(|p| p.1.as_str()).collect();
    texts.sort_unstable();
    texts.dedup();
    let work = || -> Result<Option<Vec<String>>, Error> {
        let models: Vec<Model> = texts
            .par_iter()
            .map(|t| {
                let mut p = Params::from_toml_str(t)?;
                if let Some(dt) = cfg.dt_s {
                    p.dt_s = dt;
                }
                Model::new(p)
            })
            .collect::<Result<_, Error>>()?;
        let by_text: HashMap<&str, &Model> = texts.iter().copied().zip(models.iter()).collect();
        let rows: Mutex<Vec<(usize, String)>> = Mutex::new(Vec::with_capacity(points.len()));
        let error: Mutex<Option<Error>> = Mutex::new(None);
        points.par_iter().with_max_len(1).for_each(|pt| {
            if cancel.load(Ordering::Relaxed) {
                return;
            }
            let (index, text, f_ex_hz, a_ex_m_s2, s0, duration_s) = pt;
            let model = by_text[text.as_str()];
            let mut c = cfg.clone();
            c.duration_s = *duration_s;
            let p = MapPoint { index: *index, f_ex_hz: *f_ex_hz, a_ex_m_s2: *a_ex_m_s2, s0: *s0 };
            match map::run_point(model, &c, &p, cancel) {
                Ok(Some(mut row)) => {
                    // A study keeps the classification, not the end state (not extended).
                    row.end = None;
                    let json = MapRow::to_json(&row);
                    fresh.lock().unwrap_or_else(|e| e.into_inner()).push(json.clone());
                    rows.lock().unwrap_or_else(|e| e.into_inner()).push((*index, json));
                }
                Ok(None) => {}
                Err(e) => {
                    error.lock().unwrap_or_else(|e| e.into_inner()).get_or_insert(e);
                    cancel.store(true, Ordering::Relaxed);
                }
            }
        });
        if let Some(e) = error.into_inner().unwrap_or_else(|e| e.into_inner()) {
            return Err(e);
        }
        let mut rows = rows.into_inner().unwrap_or_else(|e| e.into_inner());
        if rows.len() < points.len() {
            return Ok(None);
        }
        rows.sort_by_key(|r| r.0);
        Ok(Some(rows.into_iter().map(|r| r.1).collect()))
    };
    match threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()
            .map_err(|e| Error::Numerical(format!("cannot start {n} threads: {e}")))?
            .install(work),
        None => work(),
    }
}

/// Register the study functions in the `_core` module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(map_settings_json, m)?)?;
    m.add_function(wrap_pyfunction!(run_study_chunk, m)?)?;
    Ok(())
}
