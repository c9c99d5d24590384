//! Binding of `beamslider_core::superslow` (docs/model.md §6.3–6.4): the harmonic-balance super-slow
//! manifold, its N = 1 closed form, the backbone and PCS drift tables (the predictor: `predictor.rs`).
//! Types and errors only.

use beamslider_core::superslow::drift::{DriftOptions, drift_table_pcs as core_drift};
use beamslider_core::superslow::{HbBranch, HbOptions, HbSystem, closed_form_n1_scaled, hb_manifold as core_hb};
use beamslider_core::{Excitation, Model};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::params::PyParams;
use crate::{detached, guarded};

fn branch_dict<'py>(py: Python<'py>, b: &HbBranch) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("s", b.s.clone().into_pyarray(py))?;
    d.set_item("amplitude_h", b.amplitude_h.clone().into_pyarray(py))?;
    d.set_item("phase_rad", b.phase_rad.clone().into_pyarray(py))?;
    d.set_item("stable", b.stable.clone().into_pyarray(py))?;
    d.set_item("q_re", b.q_re.clone().into_pyarray(py))?;
    d.set_item("q_im", b.q_im.clone().into_pyarray(py))?;
    d.set_item("harmonic_amplitude_h", b.harmonic_amplitude_h.clone().into_pyarray(py))?;
    d.set_item("state", b.state.clone().into_pyarray(py))?;
    Ok(d)
}

/// HB super-slow manifold (docs/model.md §6.4). Returns a dict: branches `high`, `low`, `middle`,
/// `up_run`, `down_run` (dicts of arrays `s`, `amplitude_h`, `phase_rad`, `stable`, `q_re`,
/// `q_im` flat (point, mode)), `folds_s`, `folds_amplitude_h`, `s_up`, `s_dn` (None when absent),
/// `s_res`, `s_range`, `n_modes`, `steps`, `warnings`, and with `sample_on_grid` the branches
/// solved on the grid: `s_grid`, `high_on_grid`, `low_on_grid` (NaN where absent). With
/// `harmonics` > 1 or `static_sag` (docs/model.md §6.4), `harmonic_orders` and per branch
/// `harmonic_amplitude_h` (flat (point, order)) and `state` (flat (point, unknown)).
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, n_modes=5, harmonics=1, d_eff=None, omega1_factor=1.0, s_values=None, max_steps=20_000, max_step=0.05, sample_on_grid=false, static_sag=false))]
#[allow(clippy::too_many_arguments)]
pub fn hb_manifold<'py>(
    py: Python<'py>,
    params: &Bound<'_, PyParams>,
    f_ex_hz: f64,
    a_ex_m_s2: f64,
    n_modes: usize,
    harmonics: usize,
    d_eff: Option<f64>,
    omega1_factor: f64,
    s_values: Option<Vec<f64>>,
    max_steps: usize,
    max_step: f64,
    sample_on_grid: bool,
    static_sag: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let params = params.get().0.clone();
    let opts = HbOptions { n_modes, harmonics, d_eff, omega1_factor, s: s_values, max_steps, max_step, sample_on_grid, static_sag, low_branch_only: false };
    let m = py.detach(|| guarded(|| core_hb(&params, f_ex_hz, a_ex_m_s2, &opts)))?;
    let d = PyDict::new(py);
    d.set_item("high", branch_dict(py, &m.high)?)?;
    d.set_item("low", branch_dict(py, &m.low)?)?;
    d.set_item("middle", branch_dict(py, &m.middle)?)?;
    d.set_item("up_run", branch_dict(py, &m.up_run)?)?;
    d.set_item("down_run", branch_dict(py, &m.down_run)?)?;
    d.set_item("folds_s", m.folds.iter().map(|f| f.s).collect::<Vec<_>>().into_pyarray(py))?;
    d.set_item("folds_amplitude_h", m.folds.iter().map(|f| f.amplitude_h).collect::<Vec<_>>().into_pyarray(py))?;
    d.set_item("s_up", m.s_up)?;
    d.set_item("s_dn", m.s_dn)?;
    d.set_item("s_res", m.s_res.into_pyarray(py))?;
    d.set_item("s_range", m.s_range)?;
    d.set_item("n_modes", m.n_modes)?;
    d.set_item("steps", m.steps)?;
    d.set_item("warnings", m.warnings)?;
    d.set_item("s_grid", m.s_grid.into_pyarray(py))?;
    d.set_item("high_on_grid", m.high_on_grid.into_pyarray(py))?;
    d.set_item("low_on_grid", m.low_on_grid.into_pyarray(py))?;
    d.set_item("harmonic_orders", m.harmonic_orders)?;
    Ok(d)
}

/// N = 1 closed form (docs/model.md §6.4) on `s_values`. Returns a dict: `s`, `roots_h` (n×3, NaN where
/// absent), `n_roots`, `discriminant`, `folds`, `s_up`, `s_dn`, `s_res`, `backbone_h`.
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, s_values, d_eff=None, omega1_factor=1.0))]
pub fn hb_closed_form_n1<'py>(
    py: Python<'py>,
    params: &Bound<'_, PyParams>,
    f_ex_hz: f64,
    a_ex_m_s2: f64,
    s_values: Vec<f64>,
    d_eff: Option<f64>,
    omega1_factor: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let params = params.get().0.clone();
    let c = py.detach(|| guarded(|| closed_form_n1_scaled(&params, f_ex_hz, a_ex_m_s2, &s_values, d_eff, omega1_factor)))?;
    let d = PyDict::new(py);
    d.set_item("s", c.s.into_pyarray(py))?;
    d.set_item("roots_h", c.roots_h.iter().flatten().copied().collect::<Vec<f64>>().into_pyarray(py))?;
    d.set_item("n_roots", c.n_roots.into_pyarray(py))?;
    d.set_item("discriminant", c.discriminant.into_pyarray(py))?;
    d.set_item("folds", c.folds.into_pyarray(py))?;
    d.set_item("s_up", c.s_up)?;
    d.set_item("s_dn", c.s_dn)?;
    d.set_item("s_res", c.s_res.into_pyarray(py))?;
    d.set_item("backbone_h", c.backbone_h.into_pyarray(py))?;
    Ok(d)
}

/// Single-mode backbone with the slider Ω_bb(Â, s) [rad/s] (docs/model.md §6.4) at paired values.
#[pyfunction]
#[pyo3(signature = (params, amplitude_h, s, omega1_factor=1.0))]
pub fn hb_backbone(py: Python<'_>, params: &Bound<'_, PyParams>, amplitude_h: Vec<f64>, s: Vec<f64>, omega1_factor: f64) -> PyResult<Vec<f64>> {
    let params = params.get().0.clone();
    if amplitude_h.len() != s.len() {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "invalid parameter `s`: {} values for {} amplitudes (must be the same length)",
            s.len(),
            amplitude_h.len()
        )));
    }
    py.detach(|| {
        guarded(|| {
            let opts = HbOptions { n_modes: 1, omega1_factor, ..HbOptions::default() };
            let sys = HbSystem::new(&params, 100.0, 1.0, &opts)?;
            Ok(amplitude_h.iter().zip(&s).map(|(&a, &x)| sys.backbone_omega(a, x)).collect())
        })
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(hb_manifold, m)?)?;
    m.add_function(wrap_pyfunction!(hb_closed_form_n1, m)?)?;
    m.add_function(wrap_pyfunction!(hb_backbone, m)?)?;
    m.add_function(wrap_pyfunction!(drift_table_pcs, m)?)?;
    m.add_function(wrap_pyfunction!(read_drift_table, m)?)?;
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
pub fn drift_table_pcs(
    py: Python<'_>,
    params: &Bound<'_, PyParams>,
    f_ex_hz: f64,
    a_ex_m_s2: f64,
    s_values: Vec<f64>,
    settle_periods: usize,
    first_settle_periods: usize,
    window_s: f64,
    sub_windows: usize,
    mirror: bool,
    out: Option<std::path::PathBuf>,
    resume: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<(String, Vec<String>, usize)> {
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
    let params = params.get().0.clone();
    let opts = DriftOptions { s_values, settle_periods, first_settle_periods, window_s, sub_windows, mirror };
    let exc = Excitation::new(f_ex_hz, a_ex_m_s2);
    let cancel = AtomicBool::new(false);
    let done = AtomicUsize::new(0);
    let total = AtomicUsize::new(0);
    let poll = |py: Python<'_>| -> PyResult<()> {
        py.check_signals()?;
        let (d, t) = (done.load(Ordering::Relaxed), total.load(Ordering::Relaxed));
        match &progress {
            Some(cb) if t > 0 => cb.call1(py, (d, t)).map(|_| ()),
            _ => Ok(()),
        }
    };
    let progress_of = |d, t| {
        done.store(d, Ordering::Relaxed);
        total.store(t, Ordering::Relaxed);
    };
    let work = || core_drift(&Model::of(&params)?, &exc, &opts, out.as_deref(), resume, &cancel, &progress_of);
    let table = detached(py, &cancel, 100, work, poll)?;
    poll(py)?;
    let js = |e: serde_json::Error| crate::SimulationError::new_err(format!("internal error: {e}"));
    let header = serde_json::to_string(&table.header).map_err(js)?;
    let rows = table.rows.iter().map(|r| serde_json::to_string(r).map_err(js)).collect::<PyResult<Vec<_>>>()?;
    Ok((header, rows, table.computed))
}

/// Read a drift-table file: (header JSON, rows as JSON texts; a truncated last line is dropped).
#[pyfunction]
pub fn read_drift_table(py: Python<'_>, path: std::path::PathBuf) -> PyResult<(String, Vec<String>)> {
    let (h, rows) = py.detach(|| guarded(|| beamslider_core::superslow::drift::read_drift_table(&path)))?;
    let js = |e: serde_json::Error| crate::SimulationError::new_err(format!("internal error: {e}"));
    Ok((serde_json::to_string(&h).map_err(js)?, rows.iter().map(|r| serde_json::to_string(r).map_err(js)).collect::<PyResult<Vec<_>>>()?))
}
