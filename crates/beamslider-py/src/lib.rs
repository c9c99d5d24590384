//! `beamslider._core`: the thin PyO3 binding of `beamslider-core`.
//!
//! It only converts types and errors; the public Python API lives in `python/beamslider/`.
//! Parameters cross the boundary as TOML text (Python → Rust) and as a dict (Rust → Python), the
//! same format the Rust tools read. Long runs release the interpreter (`py.detach`); a monitor
//! re-attaches every few thousand steps to run pending signal handlers (Ctrl-C) and the optional
//! progress callback. Core errors map to Python exceptions: invalid parameter / TOML →
//! `ValueError`, I/O → `OSError`, numerical failure → `beamslider.SimulationError`, interrupted →
//! `KeyboardInterrupt`. Panics are caught and reported as `SimulationError`.

use std::sync::atomic::AtomicBool;

mod enma;

use beamslider_core::{
    Criteria, MapConfig, MapRow, MapRunOptions, SuperSlow,
    Channel, ColumnRecorder, Error, Excitation, FileRecorder, ManifoldOptions, Model, Monitor, OverviewRecorder, Params, Recorder,
    RunOptions, Tee, SliderModel, Status, dynamics::runner, signal,
};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::exceptions::{PyBlockingIOError, PyException, PyKeyboardInterrupt, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

mod discover;
mod maprun;
mod study;
mod superslow;

pyo3::create_exception!(
    _core,
    SimulationError,
    PyException,
    "A simulation failed numerically (e.g. no eigenvalue found, manifold run diverged)."
);

/// Map a core error to the Python exception of its class.
fn to_py(e: Error) -> PyErr {
    let msg = e.to_string();
    #[allow(unreachable_patterns)]
    match e {
        Error::InvalidParameter { .. } | Error::Toml { .. } => PyValueError::new_err(msg),
        Error::Io { source, .. } => match source.raw_os_error() {
            Some(code) => PyOSError::new_err((code, msg)),
            None => PyOSError::new_err(msg),
        },
        Error::Busy { .. } => PyBlockingIOError::new_err(msg),
        Error::Interrupted { .. } => PyKeyboardInterrupt::new_err(msg),
        Error::Numerical(_) => SimulationError::new_err(msg),
        _ => SimulationError::new_err(msg),
    }
}

/// Run `f`, turning a panic into an error (a panic must never cross into Python).
fn guarded<T>(f: impl FnOnce() -> Result<T, Error>) -> Result<T, PyErr> {
    match runner::catch_panic(f) {
        Ok(r) => r.map_err(to_py),
        Err(what) => Err(SimulationError::new_err(format!("internal error in the core: {what}"))),
    }
}

/// `threads` of a batch: None (one per core) or >= 1.
fn check_threads(threads: Option<usize>) -> PyResult<()> {
    if threads == Some(0) {
        return Err(PyValueError::new_err("invalid parameter `threads` = 0: must be >= 1"));
    }
    Ok(())
}

/// Run `work` with the interpreter released on the core's watched worker thread
/// ([`runner::watched`]); every `period_ms` the calling thread re-attaches and calls `poll(py)`
/// (pending signal handlers such as Ctrl-C, progress callbacks). An exception from `poll` sets
/// `cancel` and is raised once the work has stopped.
fn detached<T: Send>(
    py: Python<'_>,
    cancel: &AtomicBool,
    period_ms: u64,
    work: impl FnOnce() -> Result<T, Error> + Send,
    poll: impl Fn(Python<'_>) -> PyResult<()> + Sync,
) -> PyResult<T> {
    let mut err: Option<PyErr> = None;
    let outcome = py.detach(|| {
        runner::watched(cancel, std::time::Duration::from_millis(period_ms), work, || match Python::attach(&poll) {
            Ok(()) => true,
            Err(e) => {
                err = Some(e);
                false
            }
        })
    });
    if let Some(e) = err {
        return Err(e);
    }
    outcome.map_err(to_py)
}

fn parse_params(toml_text: &str) -> PyResult<Params> {
    guarded(|| Params::from_toml_str(toml_text))
}

/// Parameters as a dict of TOML keys → float / int / str.
fn params_dict<'py>(py: Python<'py>, p: &Params) -> PyResult<Bound<'py, PyDict>> {
    let table: toml::Table = toml::from_str(&p.to_toml_string())
        .map_err(|e| SimulationError::new_err(format!("internal error: {e}")))?;
    let d = PyDict::new(py);
    for (k, v) in table {
        match v {
            toml::Value::Float(x) => d.set_item(k, x)?,
            toml::Value::Integer(i) => d.set_item(k, i)?,
            toml::Value::String(s) => d.set_item(k, s)?,
            toml::Value::Boolean(b) => d.set_item(k, b)?,
            other => d.set_item(k, other.to_string())?,
        }
    }
    Ok(d)
}

/// Default parameters of docs/model.md §1 as a dict.
#[pyfunction]
fn default_params(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    params_dict(py, &Params::default())
}

/// Parse and validate TOML parameter text (missing keys take defaults); returns the full dict.
#[pyfunction]
fn params_from_toml<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyDict>> {
    let p = parse_params(text)?;
    params_dict(py, &p)
}

/// Read and validate a TOML parameter file; returns the full dict.
#[pyfunction]
fn read_params_file<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let p = guarded(|| Params::from_toml_file(&path))?;
    params_dict(py, &p)
}

/// Validate TOML parameter text and return the canonical TOML text the Rust tools write.
#[pyfunction]
fn canonical_toml(text: &str) -> PyResult<String> {
    Ok(parse_params(text)?.to_toml_string())
}

/// Natural frequencies f₁..f_N [Hz] of the linear beam (docs/model.md §2).
#[pyfunction]
fn natural_frequencies(py: Python<'_>, params_toml: &str) -> PyResult<Vec<f64>> {
    let p = parse_params(params_toml)?;
    py.detach(|| guarded(|| Ok(Model::new(p)?.beam.frequencies_hz())))
}

/// Monitor that re-attaches to Python every poll: pending signal handlers (Ctrl-C) and the
/// progress callback `callback(t_done, t_total)` run there; an exception stops the run.
struct PyMonitor {
    callback: Option<Py<PyAny>>,
    error: Option<PyErr>,
}

impl PyMonitor {
    fn new(callback: Option<Py<PyAny>>) -> Self {
        PyMonitor { callback, error: None }
    }
}

impl Monitor for PyMonitor {
    fn poll(&mut self, t_s: f64, t_end_s: f64) -> bool {
        if self.error.is_some() {
            return false;
        }
        Python::attach(|py| {
            let r = py.check_signals().and_then(|()| match &self.callback {
                Some(cb) => cb.call1(py, (t_s, t_end_s)).map(|_| ()),
                None => Ok(()),
            });
            match r {
                Ok(()) => true,
                Err(e) => {
                    self.error = Some(e);
                    false
                }
            }
        })
    }
}

/// Names of the recorded columns, in the order of `RECORDED`.
const RECORDED: [&str; 6] = ["t_s", "w_4L7_m", "s", "xC_m", "zC_m", "beta_rad"];

/// Rows a run records: the start state and every `record_every`-th of round(t_end/dt) steps.
#[pyfunction]
fn recorded_rows(t_end_s: f64, dt_s: f64, record_every: usize) -> u64 {
    beamslider_core::recorded_rows(t_end_s, dt_s, record_every)
}

/// Integrate the FS / PCS / beam-only model (docs/model.md §5–6) and return a dict with the recorded
/// columns (numpy arrays keyed by `t_s`, `w_4L7_m`, `s`, `xC_m`, `zC_m`, `beta_rad`), `status`,
/// `message`, `counters` (dict), `final_state` (dict) and `rows`. With `out` (a `.npz` or `.csv`
/// path) the rows are streamed into that file instead (written under a temporary name, renamed
/// when the run ends; an interrupted run leaves nothing) and no columns are returned; instead
/// `overview` holds what a summary and a figure need, gathered as the rows stream (core module
/// `overview`): `w_t`, `w`, `s_t`, `s` (min/max decimation to `columns` pixel columns, or None)
/// and `super_slow` = (t0 [s], bin spacing [s], s per bin, amplitude/h per bin; `window_s`
/// moving average), or None.
#[pyfunction]
#[pyo3(signature = (params_toml, *, f_ex_hz, a_ex_m_s2, s0, t_end_s, model, s_pcs=None, record_every=10, progress=None, out=None, window_s=1.0, columns=2000))]
#[allow(clippy::too_many_arguments)]
fn simulate<'py>(
    py: Python<'py>,
    params_toml: &str,
    f_ex_hz: f64,
    a_ex_m_s2: f64,
    s0: f64,
    t_end_s: f64,
    model: &str,
    s_pcs: Option<f64>,
    record_every: usize,
    progress: Option<Py<PyAny>>,
    out: Option<std::path::PathBuf>,
    window_s: f64,
    columns: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let params = parse_params(params_toml)?;
    let slider_model = match model {
        "fs" => SliderModel::Free,
        "pcs" => SliderModel::PseudoConstrained { s: s_pcs.unwrap_or(s0) },
        "beam" => SliderModel::BeamOnly,
        other => {
            return Err(PyValueError::new_err(format!(
                "invalid parameter `model` = {other:?}: must be one of \"fs\" (free slider), \"pcs\" (pseudo-constrained slider), \"beam\" (beam only)"
            )));
        }
    };
    let excitation = Excitation::new(f_ex_hz, a_ex_m_s2);
    let mut monitor = PyMonitor::new(progress);
    let outcome = py.detach(|| {
        guarded(|| {
            let m = Model::new(params)?;
            let start = m.start(slider_model, s0, &excitation)?;
            let opts = RunOptions {
                excitation,
                model: slider_model,
                duration_s: t_end_s,
                record_every,
                channels: vec![
                    Channel::Time,
                    Channel::W4L7,
                    Channel::S,
                    Channel::XC,
                    Channel::ZC,
                    Channel::Beta,
                ],
                audit_contacts: false,
            };
            m.check_run(&start, &opts)?;
            match &out {
                Some(path) => {
                    let expected = beamslider_core::recorded_rows(opts.duration_s, m.params.dt_s, record_every);
                    let mut rec = FileRecorder::create(path, expected)?;
                    let mut ov = OverviewRecorder::new(expected, columns, m.params.dt_s, record_every);
                    let summary = m.run(&start, &opts, &mut Tee(&mut rec, &mut ov), &mut monitor)?;
                    if let Status::Interrupted { .. } = summary.status {
                        return Ok((summary, Vec::new(), 0, None)); // the recorder removes its files
                    }
                    let rows = rec.commit()?;
                    let ov = ov.finish();
                    let signals = ov.signals.as_ref().map(|st| st.super_slow(m.params.thickness_m, window_s));
                    Ok((summary, Vec::new(), rows, Some((ov, signals))))
                }
                None => {
                    let rows = beamslider_core::recorded_rows(opts.duration_s, m.params.dt_s, record_every);
                    let rows = usize::try_from(rows).map_err(|_| Error::invalid("t_end", t_end_s, "too many rows to record in memory"))?;
                    let mut rec = ColumnRecorder::with_rows(rows);
                    let summary = m.run(&start, &opts, &mut rec as &mut dyn Recorder, &mut monitor)?;
                    let n = rec.columns.first().map_or(0, Vec::len) as u64;
                    let mut columns = std::mem::take(&mut rec.columns);
                    // RECORDED is the channel order above.
                    columns.truncate(RECORDED.len());
                    Ok((summary, columns, n, None))
                }
            }
        })
    });
    if let Some(e) = monitor.error.take() {
        return Err(e);
    }
    let (summary, columns, rows, overview) = outcome?;
    if let Status::Interrupted { t_s } = summary.status {
        return Err(PyKeyboardInterrupt::new_err(format!("interrupted at t = {t_s} s")));
    }
    let d = PyDict::new(py);
    for (name, col) in RECORDED.iter().zip(columns) {
        d.set_item(*name, col.into_pyarray(py))?;
    }
    d.set_item("rows", rows)?;
    if let Some((ov, signals)) = overview {
        let o = PyDict::new(py);
        let (w_t, w) = ov.w.map_or((None, None), |(t, y)| (Some(t.into_pyarray(py)), Some(y.into_pyarray(py))));
        let (s_t, s) = ov.s.map_or((None, None), |(t, y)| (Some(t.into_pyarray(py)), Some(y.into_pyarray(py))));
        o.set_item("w_t", w_t)?;
        o.set_item("w", w)?;
        o.set_item("s_t", s_t)?;
        o.set_item("s", s)?;
        o.set_item("super_slow", signals.map(|x| (x.t0_s, x.dt_s, x.s.into_pyarray(py), x.amplitude_h.into_pyarray(py))))?;
        d.set_item("overview", o)?;
    }
    d.set_item("status", summary.status.name())?;
    d.set_item("message", summary.status.message())?;
    d.set_item("counters", counters_dict(py, &summary.counters)?)?;
    let st = PyDict::new(py);
    st.set_item("t_s", summary.state.t_s)?;
    st.set_item("q", summary.state.q.clone())?;
    st.set_item("u", summary.state.u.clone())?;
    st.set_item("slider_q", summary.state.slider_q.to_vec())?;
    st.set_item("slider_u", summary.state.slider_u.to_vec())?;
    d.set_item("final_state", st)?;
    Ok(d)
}

fn counters_dict<'py>(py: Python<'py>, c: &beamslider_core::Counters) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("steps", c.steps)?;
    d.set_item("contact_steps", c.contact_steps)?;
    d.set_item("closed_histogram", c.closed_histogram.to_vec())?;
    d.set_item("solver_iterations", c.solver_iterations)?;
    d.set_item("max_iterations", c.max_iterations)?;
    d.set_item("cap_hits", c.cap_hits)?;
    d.set_item("first_guess_hits", c.first_guess_hits)?;
    d.set_item("linear_solves", c.linear_solves)?;
    d.set_item("enumerations", c.enumerations)?;
    d.set_item("fallbacks", c.fallbacks)?;
    d.set_item("max_residual", c.max_residual)?;
    Ok(d)
}

/// Default slider positions of the physical manifold sweep (docs/model.md §6): the reference grid
/// s = 0, 0.005, …, 0.5 from the first s whose contact points lie on the beam.
#[pyfunction]
fn physical_manifold_grid(py: Python<'_>, params_toml: &str) -> PyResult<Vec<f64>> {
    let p = parse_params(params_toml)?;
    py.detach(|| guarded(|| Ok(ManifoldOptions::physical(&Model::new(p)?).s_values)))
}

/// Super-slow manifold by PCS continuation (docs/model.md §6). Returns a dict with `up_s`,
/// `up_amplitude_m`, `down_s`, `down_amplitude_m` (numpy arrays) and `counters`.
/// `progress(points_done, points_total)` is called after every s.
#[pyfunction]
#[pyo3(signature = (params_toml, *, f_ex_hz, a_ex_m_s2, s_values, periods=100, record_periods=25, progress=None))]
#[allow(clippy::too_many_arguments)]
fn super_slow_manifold<'py>(
    py: Python<'py>,
    params_toml: &str,
    f_ex_hz: f64,
    a_ex_m_s2: f64,
    s_values: Vec<f64>,
    periods: usize,
    record_periods: usize,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let params = parse_params(params_toml)?;
    let excitation = Excitation::new(f_ex_hz, a_ex_m_s2);
    let opts = ManifoldOptions { s_values, periods, record_periods };
    let mut monitor = PyMonitor::new(progress);
    let outcome = py.detach(|| {
        guarded(|| {
            let m = Model::new(params)?;
            beamslider_core::super_slow_manifold(&m, &excitation, &opts, &mut monitor)
        })
    });
    if let Some(e) = monitor.error.take() {
        return Err(e);
    }
    let man = outcome?;
    let d = PyDict::new(py);
    d.set_item("up_s", man.up.s.into_pyarray(py))?;
    d.set_item("up_amplitude_m", man.up.amplitude_m.into_pyarray(py))?;
    d.set_item("down_s", man.down.s.into_pyarray(py))?;
    d.set_item("down_amplitude_m", man.down.amplitude_m.into_pyarray(py))?;
    d.set_item("counters", counters_dict(py, &man.counters)?)?;
    Ok(d)
}

/// |analytic signal| of x (discrete Hilbert transform via FFT, docs/model.md §7).
#[pyfunction]
fn hilbert_envelope<'py>(py: Python<'py>, x: PyReadonlyArray1<'py, f64>) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let x = x.as_slice()?.to_vec();
    let e = py.detach(|| signal::hilbert_envelope(&x));
    Ok(e.into_pyarray(py))
}

/// Centred moving average over `window` samples, shrinking at the ends (as MATLAB's movmean).
#[pyfunction]
fn moving_average<'py>(
    py: Python<'py>,
    x: PyReadonlyArray1<'py, f64>,
    window: usize,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let x = x.as_slice()?.to_vec();
    let e = py.detach(|| signal::moving_average(&x, window));
    Ok(e.into_pyarray(py))
}

/// Envelope of docs/model.md §7: |Hilbert(x)|, then a moving average over `window_s` seconds of
/// samples spaced `dt_s`.
#[pyfunction]
fn envelope<'py>(
    py: Python<'py>,
    x: PyReadonlyArray1<'py, f64>,
    dt_s: f64,
    window_s: f64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let x = x.as_slice()?.to_vec();
    let e = py.detach(|| guarded(|| signal::envelope_checked(&x, dt_s, window_s)))?;
    Ok(e.into_pyarray(py))
}

/// The super-slow signals a map point is classified from (core module `envelope_stream`,
/// docs/model.md §7): w(4L/7) [m] and s sampled every `dt_s` from a run from rest, binned over 0.2 s;
/// A = `window_s` moving average of the binned |analytic signal| divided by `thickness_m`.
/// Returns (t0 of the first bin [s], bin spacing [s], s per bin, A per bin [h]).
#[pyfunction]
fn super_slow_signals<'py>(
    py: Python<'py>,
    w: PyReadonlyArray1<'py, f64>,
    s: PyReadonlyArray1<'py, f64>,
    dt_s: f64,
    thickness_m: f64,
    window_s: f64,
) -> PyResult<(f64, f64, Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>)> {
    let (w, s) = (w.as_slice()?.to_vec(), s.as_slice()?.to_vec());
    let x = py.detach(|| guarded(|| beamslider_core::signal::envelope_stream::EnvelopeStream::of_series(&w, &s, dt_s, thickness_m, window_s)))?;
    Ok((x.t0_s, x.dt_s, x.s.into_pyarray(py), x.amplitude_h.into_pyarray(py)))
}

/// Behaviour classification (docs/model.md §8) of super-slow signals sampled every `dt_s`: slider
/// position `s` and amplitude `amplitude_h` (1-s moving average of |Hilbert(w(4L/7))| / h).
/// `criteria_toml`: thresholds as TOML keys of the core's `Criteria` (missing keys take defaults).
/// Returns the classification as JSON text (the fields of a map row).
#[pyfunction]
#[pyo3(signature = (s, amplitude_h, dt_s, *, t0_s=0.0, criteria_toml=None))]
fn classify<'py>(
    py: Python<'py>,
    s: PyReadonlyArray1<'py, f64>,
    amplitude_h: PyReadonlyArray1<'py, f64>,
    dt_s: f64,
    t0_s: f64,
    criteria_toml: Option<&str>,
) -> PyResult<String> {
    let criteria: Criteria = match criteria_toml {
        Some(text) => toml::from_str(text).map_err(|e| PyValueError::new_err(format!("cannot read criteria: {}", e.to_string().trim_end())))?,
        None => Criteria::default(),
    };
    let x = SuperSlow { t0_s, dt_s, s: s.as_slice()?.to_vec(), amplitude_h: amplitude_h.as_slice()?.to_vec() };
    let c = py.detach(|| guarded(|| beamslider_core::classify(&x, &criteria)))?;
    serde_json::to_string(&c).map_err(|e| SimulationError::new_err(format!("internal error: {e}")))
}

/// The default map configuration (the paper's operating map) as TOML text.
#[pyfunction]
fn default_map_config() -> String {
    MapConfig::default().to_toml_string()
}

/// The values of an inclusive range START:STOP:STEP (core `map::Axis`: STOP included when within
/// STEP/1000 of the grid, values rounded to 1e-9, at most a million); errors name `field`.
#[pyfunction]
fn range_values(field: &str, start: f64, stop: f64, step: f64) -> PyResult<Vec<f64>> {
    guarded(|| beamslider_core::Axis::Range { start, stop, step }.values(field))
}

/// Validate map configuration TOML; returns (canonical TOML, f_ex list, a_ex list, s0 list).
#[pyfunction]
fn map_config(text: &str) -> PyResult<(String, Vec<f64>, Vec<f64>, Vec<f64>)> {
    let cfg = guarded(|| MapConfig::from_toml_str(text))?;
    let g = &cfg.grid;
    let axes = guarded(|| Ok((g.f_ex_hz.values("grid.f_ex_hz")?, g.a_ex_m_s2.values("grid.a_ex_m_s2")?, g.s0.values("grid.s0")?)))?;
    Ok((cfg.to_toml_string(), axes.0, axes.1, axes.2))
}

/// Check a map before anything is written: configuration, Δt, and the results file `out`
/// (exists without `resume`, other settings; with `extend`: the map to extend to the config's
/// duration). Raises what `run_map` would raise.
#[pyfunction]
#[pyo3(signature = (config_toml, *, out=None, resume=false, extend=false))]
fn check_map(py: Python<'_>, config_toml: &str, out: Option<std::path::PathBuf>, resume: bool, extend: bool) -> PyResult<()> {
    let cfg = guarded(|| MapConfig::from_toml_str(config_toml))?;
    let opts = MapRunOptions { out, resume, threads: None, extend };
    py.detach(|| guarded(|| beamslider_core::map::preflight(&cfg, &opts)))
}

/// Read a map results file (JSON lines): (settings as JSON text or None, rows as JSON texts,
/// whether the last line was truncated).
#[pyfunction]
fn read_map_results(py: Python<'_>, path: std::path::PathBuf) -> PyResult<(Option<String>, Vec<String>, bool)> {
    let r = py.detach(|| guarded(|| beamslider_core::results::read_results(&path)))?;
    let settings = r.settings.map(|s| serde_json::to_string(&s).unwrap_or_default());
    Ok((settings, r.rows.iter().map(MapRow::to_json).collect(), r.truncated))
}

/// The compiled core of beamslider (private: import `beamslider` instead).
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SimulationError", m.py().get_type::<SimulationError>())?;
    m.add("RESULTS_FORMAT_VERSION", beamslider_core::results::FORMAT_VERSION)?;
    m.add("MAX_AXIS_VALUES", beamslider_core::map::MAX_POINTS)?;
    m.add_function(wrap_pyfunction!(default_params, m)?)?;
    m.add_function(wrap_pyfunction!(params_from_toml, m)?)?;
    m.add_function(wrap_pyfunction!(read_params_file, m)?)?;
    m.add_function(wrap_pyfunction!(canonical_toml, m)?)?;
    m.add_function(wrap_pyfunction!(natural_frequencies, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(physical_manifold_grid, m)?)?;
    m.add_function(wrap_pyfunction!(super_slow_manifold, m)?)?;
    m.add_function(wrap_pyfunction!(hilbert_envelope, m)?)?;
    m.add_function(wrap_pyfunction!(moving_average, m)?)?;
    m.add_function(wrap_pyfunction!(envelope, m)?)?;
    m.add_function(wrap_pyfunction!(classify, m)?)?;
    m.add_function(wrap_pyfunction!(super_slow_signals, m)?)?;
    m.add_function(wrap_pyfunction!(default_map_config, m)?)?;
    m.add_function(wrap_pyfunction!(map_config, m)?)?;
    m.add_function(wrap_pyfunction!(range_values, m)?)?;
    m.add_function(wrap_pyfunction!(read_map_results, m)?)?;
    maprun::register(m)?;
    m.add_function(wrap_pyfunction!(recorded_rows, m)?)?;
    m.add_function(wrap_pyfunction!(enma::virtual_enma, m)?)?;
    m.add_function(wrap_pyfunction!(enma::beam_properties, m)?)?;
    study::register(m)?;
    discover::register(m)?;
    superslow::register(m)?;
    m.add_function(wrap_pyfunction!(check_map, m)?)?;
    Ok(())
}
