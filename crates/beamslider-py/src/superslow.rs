//! Binding of `beamslider_core::superslow` (docs/model.md §6.3–6.5): the harmonic-balance super-slow
//! manifold, its N = 1 closed form, the backbone, PCS drift tables, the drift law, the slow flow and
//! predicted maps. Types and errors only.

use beamslider_core::superslow::drift::{BranchLabel, DriftOptions, drift_table_pcs as core_drift};
use beamslider_core::superslow::slowflow::{EventKind, SlowBranch, SlowFlowOptions, SlowModel, slow_flow as core_slow_flow};
use beamslider_core::superslow::{HbOptions, backbone, closed_form_n1_scaled, hb_manifold as core_hb};
use beamslider_core::superslow::{law, predict};
use beamslider_core::superslow::law::DriftLaw;
use beamslider_core::{Criteria, Excitation, MapConfig, MapRow, MapRunOptions, Model};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use pythonize::pythonize;

use crate::params::PyParams;
use crate::{detached, guarded, json};

/// HB super-slow manifold (docs/model.md §6.4): the core's `HbManifold` as a dict (branches
/// `high`, `low`, `middle`, `up_run`, `down_run` of `s`, `amplitude_h`, `phase_rad`, `stable`,
/// `q_re`, `q_im` flat (point, mode), `harmonic_amplitude_h`, `state`; `folds` of `s` and
/// `amplitude_h`; `s_up`, `s_dn`, `s_res`, `s_range`, `n_modes`, `steps`, `warnings`, `s_grid`,
/// `high_on_grid`, `low_on_grid`, `harmonic_orders`).
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, n_modes=5, harmonics=1, d_eff=None, omega1_factor=1.0, s_values=None, max_steps=20_000, max_step=0.05, sample_on_grid=false, static_sag=false))]
#[allow(clippy::too_many_arguments)]
pub fn hb_manifold<'py>(py: Python<'py>, params: &Bound<'_, PyParams>, f_ex_hz: f64, a_ex_m_s2: f64, n_modes: usize, harmonics: usize,
    d_eff: Option<f64>, omega1_factor: f64, s_values: Option<Vec<f64>>, max_steps: usize, max_step: f64, sample_on_grid: bool,
    static_sag: bool) -> PyResult<Bound<'py, PyAny>> {
    let params = params.get().0.clone();
    let opts = HbOptions { n_modes, harmonics, d_eff, omega1_factor, s: s_values, max_steps, max_step, sample_on_grid, static_sag, low_branch_only: false };
    Ok(pythonize(py, &py.detach(|| guarded(|| core_hb(&params, f_ex_hz, a_ex_m_s2, &opts)))?)?)
}

/// N = 1 closed form (docs/model.md §6.4) on `s_values`: the core's `ClosedFormN1` as a dict (`s`,
/// `roots_h` (n rows of 3, NaN where absent), `n_roots`, `discriminant`, `folds`, `s_up`, `s_dn`,
/// `s_res`, `backbone_h`).
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, s_values, d_eff=None, omega1_factor=1.0))]
pub fn hb_closed_form_n1<'py>(py: Python<'py>, params: &Bound<'_, PyParams>, f_ex_hz: f64, a_ex_m_s2: f64, s_values: Vec<f64>,
    d_eff: Option<f64>, omega1_factor: f64) -> PyResult<Bound<'py, PyAny>> {
    let params = params.get().0.clone();
    Ok(pythonize(py, &py.detach(|| guarded(|| closed_form_n1_scaled(&params, f_ex_hz, a_ex_m_s2, &s_values, d_eff, omega1_factor)))?)?)
}

/// Single-mode backbone with the slider Ω_bb(Â, s) [rad/s] (docs/model.md §6.4) at paired values.
#[pyfunction]
#[pyo3(signature = (params, amplitude_h, s, omega1_factor=1.0))]
pub fn hb_backbone(py: Python<'_>, params: &Bound<'_, PyParams>, amplitude_h: Vec<f64>, s: Vec<f64>, omega1_factor: f64) -> PyResult<Vec<f64>> {
    let params = params.get().0.clone();
    py.detach(|| guarded(|| backbone(&params, &amplitude_h, &s, omega1_factor)))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    crate::export!(m, hb_manifold, hb_closed_form_n1, hb_backbone);
    register_b(m)?;
    Ok(())
}

/// Drift table V(s, branch) from the PCS model (docs/model.md §6.4). Returns
/// (header JSON, rows as JSON texts in production order, rows computed now). Rows are appended
/// to `out` as produced; `resume` continues an existing file with the same settings.
/// `progress(done, total)` is called from the calling thread; Ctrl-C stops both sweeps (rows
/// written so far stay in the file) and raises KeyboardInterrupt.
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, s_values, settle_periods=40, first_settle_periods=400, window_s=1.0, sub_windows=4, mirror=false, out=None, resume=false, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn drift_table_pcs(py: Python<'_>, params: &Bound<'_, PyParams>, f_ex_hz: f64, a_ex_m_s2: f64, s_values: Vec<f64>,
    settle_periods: usize, first_settle_periods: usize, window_s: f64, sub_windows: usize, mirror: bool, out: Option<std::path::PathBuf>,
    resume: bool, progress: Option<Py<PyAny>>) -> PyResult<(String, Vec<String>, usize)> {
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering::Relaxed};
    let params = params.get().0.clone();
    let opts = DriftOptions { s_values, settle_periods, first_settle_periods, window_s, sub_windows, mirror };
    let exc = Excitation::new(f_ex_hz, a_ex_m_s2);
    let (cancel, done, total) = (AtomicBool::new(false), AtomicUsize::new(0), AtomicUsize::new(0));
    let poll = |py: Python<'_>| {
        let t = total.load(Relaxed);
        progress.as_ref().filter(|_| t > 0).map_or(Ok(()), |cb| cb.call1(py, (done.load(Relaxed), t)).map(|_| ()))
    };
    let progress_of = |d, t| {
        done.store(d, Relaxed);
        total.store(t, Relaxed);
    };
    let table = detached(py, &cancel, 100, || core_drift(&Model::of(&params)?, &exc, &opts, out.as_deref(), resume, &cancel, &progress_of), poll)?;
    Ok((json(&table.header)?, table.rows.iter().map(json).collect::<PyResult<_>>()?, table.computed))
}

/// Read a drift-table file: (header JSON, rows as JSON texts; a truncated last line is dropped).
#[pyfunction]
pub fn read_drift_table(py: Python<'_>, path: std::path::PathBuf) -> PyResult<(String, Vec<String>)> {
    let (h, rows) = py.detach(|| guarded(|| beamslider_core::superslow::drift::read_drift_table(&path)))?;
    Ok((json(&h)?, rows.iter().map(json).collect::<PyResult<_>>()?))
}

/// Slow flow (docs/model.md §6.4) on branches given by their nodes
/// (half coordinate s′ ∈ (0, ½], increasing): `low` / `high` = (s, amplitude_h, v_per_s). Returns a
/// dict: `t_s`, `s`, `amplitude_h`, `branch` (0 = L, 1 = H), `events` (list of (kind, t_s, s)),
/// `s_final`, `amplitude_final_h`, `branch_final`, `branch_initial` ("L"/"H"),
/// `classification` (JSON text), `warnings`.
#[pyfunction]
#[pyo3(signature = (low, high, *, low_ends_in_fold, high_ends_in_fold, s0, t_end_s=120.0, dt_out_s=0.2, smooth_s=1.0, build_up_s=0.0, build_up_drift=false, criteria_json=None))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn slow_flow<'py>(
    py: Python<'py>,
    low: (Vec<f64>, Vec<f64>, Vec<f64>),
    high: (Vec<f64>, Vec<f64>, Vec<f64>),
    low_ends_in_fold: bool,
    high_ends_in_fold: bool,
    s0: f64,
    t_end_s: f64,
    dt_out_s: f64,
    smooth_s: f64,
    build_up_s: f64,
    build_up_drift: bool,
    criteria_json: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let criteria: Criteria = match criteria_json {
        Some(t) => serde_json::from_str(t).map_err(|e| pyo3::exceptions::PyValueError::new_err(format!("invalid parameter `criteria`: {e}")))?,
        None => Criteria::default(),
    };
    let mk = |b: (Vec<f64>, Vec<f64>, Vec<f64>)| SlowBranch { s: b.0, amplitude_h: b.1, v_per_s: b.2 };
    let model = SlowModel { low: mk(low), high: mk(high), low_ends_in_fold, high_ends_in_fold };
    let opts = SlowFlowOptions { t_end_s, dt_out_s, smooth_s, criteria, build_up_s, build_up_drift, ..SlowFlowOptions::default() };
    let p = py.detach(|| guarded(|| core_slow_flow(&model, s0, &opts)))?;
    let lab = |b: BranchLabel| if b == BranchLabel::L { "L" } else { "H" };
    let d = PyDict::new(py);
    d.set_item("t_s", p.t_s.into_pyarray(py))?;
    d.set_item("s", p.s.into_pyarray(py))?;
    d.set_item("amplitude_h", p.amplitude_h.into_pyarray(py))?;
    d.set_item("branch", p.branch.iter().map(|&b| (b == BranchLabel::H) as u8).collect::<Vec<u8>>().into_pyarray(py))?;
    let kind = |k: EventKind| match k {
        EventKind::JumpUp => "jump_up",
        EventKind::JumpDown => "jump_down",
        EventKind::Equilibrium => "equilibrium",
        EventKind::Wall => "wall",
    };
    d.set_item("events", p.events.iter().map(|e| (kind(e.kind), e.t_s, e.s)).collect::<Vec<_>>())?;
    d.set_item("s_final", p.s_final)?;
    d.set_item("amplitude_final_h", p.amplitude_final_h)?;
    d.set_item("branch_final", lab(p.branch_final))?;
    d.set_item("branch_initial", lab(p.branch_initial))?;
    d.set_item("classification", serde_json::to_string(&p.classification).map_err(|e| crate::SimulationError::new_err(format!("internal error: {e}")))?)?;
    d.set_item("warnings", p.warnings)?;
    Ok(d)
}

fn parse_law(law_json: &str) -> PyResult<DriftLaw> {
    guarded(|| DriftLaw::from_json_str(law_json))
}

/// The fitted drift law (JSON text of a law file) evaluated by the core: V and the
/// outside-training-range flag at law inputs `x` (rows of FEATURES) with Λ_g `lift_off`, on the
/// high (`high=True`) or low branch.
#[pyfunction]
#[pyo3(signature = (law_json, *, high, x, lift_off))]
pub fn drift_law_evaluate(law_json: &str, high: bool, x: Vec<Vec<f64>>, lift_off: Vec<f64>) -> PyResult<(Vec<f64>, Vec<bool>)> {
    let law = parse_law(law_json)?;
    if x.len() != lift_off.len() || x.iter().any(|r| r.len() != law::NF) {
        return Err(pyo3::exceptions::PyValueError::new_err(format!("invalid parameter `x`: rows of {} features, one lift_off per row", law::NF)));
    }
    let (mut v, mut out) = (Vec::with_capacity(x.len()), Vec::with_capacity(x.len()));
    for (r, &l) in x.iter().zip(&lift_off) {
        let (vi, oi) = law.evaluate(high, &std::array::from_fn(|i| r[i]), l);
        v.push(vi);
        out.push(oi);
    }
    Ok((v, out))
}

/// Layer-(a) features of docs/model.md §6.4 computed by the core at `s` on one branch (`high`) of
/// the HB manifold: dict of arrays lift_off, slope_gap, f_slope, ds_res, amp_rel, amplitude, s.
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, high, s, n_modes=5, d_eff=None))]
#[allow(clippy::too_many_arguments)]
pub fn hb_features<'py>(py: Python<'py>, params: &Bound<'_, PyParams>, f_ex_hz: f64, a_ex_m_s2: f64, high: bool, s: Vec<f64>,
    n_modes: usize, d_eff: Option<f64>) -> PyResult<Bound<'py, PyDict>> {
    let params = params.get().0.clone();
    let opts = HbOptions { n_modes, d_eff, ..HbOptions::default() };
    let f = py.detach(|| {
        guarded(|| {
            let m = core_hb(&params, f_ex_hz, a_ex_m_s2, &opts)?;
            law::features(&params, &m, f_ex_hz, a_ex_m_s2, high, &s)
        })
    })?;
    let d = PyDict::new(py);
    let col = |g: fn(&law::Features) -> f64| f.iter().map(g).collect::<Vec<f64>>();
    d.set_item("lift_off", col(|x| x.lift_off).into_pyarray(py))?;
    d.set_item("slope_gap", col(|x| x.slope_gap).into_pyarray(py))?;
    d.set_item("f_slope", col(|x| x.f_slope).into_pyarray(py))?;
    d.set_item("ds_res", col(|x| x.ds_res).into_pyarray(py))?;
    d.set_item("amp_rel", col(|x| x.amp_rel).into_pyarray(py))?;
    d.set_item("amplitude", col(|x| x.amplitude_h).into_pyarray(py))?;
    d.set_item("s", col(|x| x.s).into_pyarray(py))?;
    Ok(d)
}

/// One operating point predicted entirely in the core (HB manifold, the law, slow flow,
/// classification): the map row as JSON text (status `predicted`).
#[pyfunction]
#[pyo3(signature = (params, law_json, *, f_ex_hz, a_ex_m_s2, s0=0.3, t_end_s=120.0, n_modes=5, d_eff=None))]
#[allow(clippy::too_many_arguments)]
pub fn predict_point(py: Python<'_>, params: &Bound<'_, PyParams>, law_json: &str, f_ex_hz: f64, a_ex_m_s2: f64, s0: f64, t_end_s: f64,
    n_modes: usize, d_eff: Option<f64>) -> PyResult<String> {
    let params = params.get().0.clone();
    let law = parse_law(law_json)?;
    let opts = predict::PredictOptions { hb: HbOptions { n_modes, d_eff, ..predict::PredictOptions::default().hb }, ..predict::PredictOptions::default() };
    py.detach(|| {
        guarded(|| {
            let t0 = std::time::Instant::now();
            let p = predict::predict_point(&params, &law, f_ex_hz, a_ex_m_s2, s0, t_end_s, &opts)?;
            Ok(predict::predicted_row(0, f_ex_hz, a_ex_m_s2, s0, t_end_s, &p, t0.elapsed().as_secs_f64()).to_json())
        })
    })
}

/// A map predicted by the core with a drift law (`beamslider-batch map --predictor`): the map
/// configuration (TOML), the law (JSON text), the results file `out` (None: in memory) written
/// through the map results writer (lock, header with the predictor, resume). Runs on `threads`
/// threads with the interpreter released; Ctrl-C stops it (finished rows stay in the file).
/// Returns the rows (JSON texts, grid order).
#[pyfunction]
#[pyo3(signature = (config_toml, law_json, *, out=None, resume=false, threads=None, n_modes=5, d_eff=None, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn predicted_map(
    py: Python<'_>,
    config_toml: &str,
    law_json: &str,
    out: Option<std::path::PathBuf>,
    resume: bool,
    threads: Option<usize>,
    n_modes: usize,
    d_eff: Option<f64>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Vec<String>> {
    crate::check_threads(threads)?;
    let cfg = guarded(|| MapConfig::from_toml_str(config_toml))?;
    let law = parse_law(law_json)?;
    let popts = predict::PredictOptions { hb: HbOptions { n_modes, d_eff, ..predict::PredictOptions::default().hb }, ..predict::PredictOptions::default() };
    let opts = MapRunOptions { out, resume, threads, extend: false };
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let done = std::sync::atomic::AtomicUsize::new(0);
    let total = guarded(|| cfg.points())?.len();
    let poll = |py: Python<'_>| -> PyResult<()> {
        py.check_signals()?;
        match &progress {
            Some(cb) => cb.call1(py, (done.load(std::sync::atomic::Ordering::Relaxed), total)).map(|_| ()),
            None => Ok(()),
        }
    };
    let prog = |n: usize, _t: usize, _r: &MapRow| done.store(n, std::sync::atomic::Ordering::Relaxed);
    let outcome = detached(py, &cancel, 100, || predict::run_predicted_map(&cfg, &law, &popts, &opts, &cancel, &prog), &poll)?;
    poll(py)?;
    if outcome.cancelled || cancel.load(std::sync::atomic::Ordering::Relaxed) {
        return Err(pyo3::exceptions::PyKeyboardInterrupt::new_err("map interrupted"));
    }
    Ok(outcome.rows.iter().map(MapRow::to_json).collect())
}

pub fn register_b(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(drift_law_evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(hb_features, m)?)?;
    m.add_function(wrap_pyfunction!(predict_point, m)?)?;
    m.add_function(wrap_pyfunction!(predicted_map, m)?)?;
    m.add_function(wrap_pyfunction!(drift_table_pcs, m)?)?;
    m.add_function(wrap_pyfunction!(read_drift_table, m)?)?;
    m.add_function(wrap_pyfunction!(slow_flow, m)?)?;
    Ok(())
}
