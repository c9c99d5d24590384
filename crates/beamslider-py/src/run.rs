//! Runs of the model (docs/model.md §5–6, §9): one run (core `signal::run`), the PCS manifold,
//! batches of reduced free-slider runs (core `signal::reduced`), the virtual ENMA and the beam's
//! modal data. Types and errors only.

use std::sync::Mutex;
use std::sync::atomic::AtomicBool;

use beamslider_core::enma::{EnmaOptions, virtual_enma as core_enma};
use beamslider_core::signal::reduced::{self, Job, Reduction};
use beamslider_core::signal::run::{Output, RunSpec, run};
use beamslider_core::{Channel, Error, Excitation, ManifoldOptions, Model, SliderModel, Status};
use numpy::IntoPyArray;
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::params::PyParams;
use crate::{PyMonitor, check_threads, counters_dict, detached, guarded};

/// Names of the recorded columns and their channels.
const RECORDED: [(&str, Channel); 6] =
    [("t_s", Channel::Time), ("w_4L7_m", Channel::W4L7), ("s", Channel::S), ("xC_m", Channel::XC), ("zC_m", Channel::ZC), ("beta_rad", Channel::Beta)];

fn model_of(py: Python<'_>, p: &Bound<'_, PyParams>) -> PyResult<Model> {
    let valid = p.get().0.clone();
    py.detach(|| guarded(|| Model::of(&valid)))
}

/// Natural frequencies f₁..f_N [Hz] of the linear beam (docs/model.md §2).
#[pyfunction]
fn natural_frequencies(py: Python<'_>, params: &Bound<'_, PyParams>) -> PyResult<Vec<f64>> {
    Ok(model_of(py, params)?.beam.frequencies_hz())
}

/// Integrate the FS / PCS / beam-only model (docs/model.md §5–6) and return a dict with the recorded
/// columns (numpy arrays keyed by `t_s`, `w_4L7_m`, `s`, `xC_m`, `zC_m`, `beta_rad`), `status`,
/// `message`, `counters` (dict), `final_state` (dict) and `rows`. With `out` (a `.npz` or `.csv`
/// path) the rows are streamed into that file instead (temporary name, renamed when the run ends;
/// an interrupted run leaves nothing) and `overview` holds `w_t`, `w`, `s_t`, `s` (min/max
/// decimation to `columns` pixel columns, or None) and `super_slow` = (t0 [s], bin spacing [s], s
/// per bin, amplitude/h per bin; `window_s` moving average), or None. `on_start()` is called once
/// the inputs are checked, before the first step.
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, s0, t_end_s, model, s_pcs=None, record_every=10, progress=None, out=None, window_s=1.0, columns=2000, on_start=None))]
#[allow(clippy::too_many_arguments)]
fn simulate<'py>(
    py: Python<'py>,
    params: &Bound<'py, PyParams>,
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
    on_start: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let slider = match model {
        "fs" => SliderModel::Free,
        "pcs" => SliderModel::PseudoConstrained { s: s_pcs.unwrap_or(s0) },
        "beam" => SliderModel::BeamOnly,
        other => {
            return Err(PyValueError::new_err(format!(
                "invalid parameter `model` = {other:?}: must be one of \"fs\" (free slider), \"pcs\" (pseudo-constrained slider), \"beam\" (beam only)"
            )));
        }
    };
    let spec = RunSpec { model: slider, s0, excitation: Excitation::new(f_ex_hz, a_ex_m_s2), duration_s: t_end_s, record_every, channels: RECORDED.map(|c| c.1).to_vec() };
    let valid = params.get().0.clone();
    let mut monitor = PyMonitor { on_start, ..PyMonitor::new(progress) };
    let outcome = py.detach(|| {
        guarded(|| {
            let output = match &out {
                Some(path) => Output::File { path, format: None, overview: Some((columns, window_s)) },
                None => Output::Memory,
            };
            run(&Model::of(&valid)?, &spec, output, &mut monitor)
        })
    });
    let r = monitor.outcome(outcome)?;
    if let Status::Interrupted { t_s } = r.summary.status {
        return Err(PyKeyboardInterrupt::new_err(format!("interrupted at t = {t_s} s")));
    }
    let d = PyDict::new(py);
    for ((name, _), col) in RECORDED.iter().zip(r.columns) {
        d.set_item(*name, col.into_pyarray(py))?;
    }
    d.set_item("rows", r.rows)?;
    if let Some(ov) = r.overview {
        let o = PyDict::new(py);
        for (key, pair) in [("w", ov.w), ("s", ov.s)] {
            let (t, y) = pair.map_or((None, None), |(t, y)| (Some(t.into_pyarray(py)), Some(y.into_pyarray(py))));
            o.set_item(format!("{key}_t"), t)?;
            o.set_item(key, y)?;
        }
        o.set_item("super_slow", r.super_slow.map(|x| (x.t0_s, x.dt_s, x.s.into_pyarray(py), x.amplitude_h.into_pyarray(py))))?;
        d.set_item("overview", o)?;
    }
    let summary = r.summary;
    d.set_item("status", summary.status.name())?;
    d.set_item("message", summary.status.message())?;
    d.set_item("counters", counters_dict(py, &summary.counters)?)?;
    let st = PyDict::new(py);
    st.set_item("t_s", summary.state.t_s)?;
    st.set_item("q", summary.state.q)?;
    st.set_item("u", summary.state.u)?;
    st.set_item("slider_q", summary.state.slider_q.to_vec())?;
    st.set_item("slider_u", summary.state.slider_u.to_vec())?;
    d.set_item("final_state", st)?;
    Ok(d)
}

/// Default slider positions of the physical manifold sweep (docs/model.md §6): the reference grid
/// s = 0, 0.005, …, 0.5 from the first s whose contact points lie on the beam.
#[pyfunction]
fn physical_manifold_grid(py: Python<'_>, params: &Bound<'_, PyParams>) -> PyResult<Vec<f64>> {
    Ok(ManifoldOptions::physical(&model_of(py, params)?).s_values)
}

/// Super-slow manifold by PCS continuation (docs/model.md §6). Returns a dict with `up_s`,
/// `up_amplitude_m`, `down_s`, `down_amplitude_m` (numpy arrays) and `counters`.
/// `progress(points_done, points_total)` is called after every s.
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, s_values, periods=100, record_periods=25, progress=None))]
#[allow(clippy::too_many_arguments)]
fn super_slow_manifold<'py>(
    py: Python<'py>,
    params: &Bound<'py, PyParams>,
    f_ex_hz: f64,
    a_ex_m_s2: f64,
    s_values: Vec<f64>,
    periods: usize,
    record_periods: usize,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let excitation = Excitation::new(f_ex_hz, a_ex_m_s2);
    let opts = ManifoldOptions { s_values, periods, record_periods };
    let valid = params.get().0.clone();
    let mut monitor = PyMonitor::new(progress);
    let outcome = py.detach(|| guarded(|| beamslider_core::super_slow_manifold(&Model::of(&valid)?, &excitation, &opts, &mut monitor)));
    let man = monitor.outcome(outcome)?;
    let d = PyDict::new(py);
    d.set_item("up_s", man.up.s.into_pyarray(py))?;
    d.set_item("up_amplitude_m", man.up.amplitude_m.into_pyarray(py))?;
    d.set_item("down_s", man.down.s.into_pyarray(py))?;
    d.set_item("down_amplitude_m", man.down.amplitude_m.into_pyarray(py))?;
    d.set_item("counters", counters_dict(py, &man.counters)?)?;
    Ok(d)
}

/// Free-slider jobs `(params, f_ex_hz, a_ex_m_s2, s0, duration_s)` reduced in the core
/// (`signal::reduced`: t, s and A = envelope(w, `window_s`)/h every `keep_every`-th of the samples
/// recorded every `record_every` steps; with `detrend_s`, w minus its moving average first), in
/// parallel on `threads` workers with the interpreter released. Returns one dict per job, in job
/// order: `t`, `s`, `amplitude_h`, `status`, or `error` and `error_kind` ("invalid",
/// "numerical"). `on_done(n)` gets the runs finished since the last call; Ctrl-C or an exception
/// in it cancels the batch.
#[pyfunction]
#[pyo3(signature = (jobs, *, record_every=5, keep_every=5, window_s=1.0, detrend_s=None, threads=None, on_done=None))]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn run_free_slider_batch<'py>(
    py: Python<'py>,
    jobs: Vec<(Bound<'py, PyParams>, f64, f64, f64, f64)>,
    record_every: usize,
    keep_every: usize,
    window_s: f64,
    detrend_s: Option<f64>,
    threads: Option<usize>,
    on_done: Option<Py<PyAny>>,
) -> PyResult<Vec<Bound<'py, PyDict>>> {
    check_threads(threads)?;
    let red = Reduction { record_every, keep_every, window_s, detrend_s };
    guarded(|| red.check())?;
    let jobs: Vec<Job> = jobs.into_iter().map(|(p, f_ex_hz, a_ex_m_s2, s0, duration_s)| Job { params: p.get().0.clone(), f_ex_hz, a_ex_m_s2, s0, duration_s }).collect();
    let cancel = AtomicBool::new(false);
    let fresh = Mutex::new(0usize);
    let poll = |py: Python<'_>| -> PyResult<()> {
        py.check_signals()?;
        let n = std::mem::take(&mut *fresh.lock().unwrap_or_else(|e| e.into_inner()));
        on_done.as_ref().filter(|_| n > 0).map_or(Ok(()), |cb| cb.call1(py, (n,)).map(|_| ()))
    };
    let on_one = || *fresh.lock().unwrap_or_else(|e| e.into_inner()) += 1;
    let outcome = detached(py, &cancel, 50, || reduced::run_batch(&jobs, &red, threads, &cancel, on_one), poll)?;
    poll(py)?;
    let results = outcome.ok_or_else(|| PyKeyboardInterrupt::new_err("discover runs interrupted"))?;
    let mut out = Vec::with_capacity(results.len());
    for r in results {
        let d = PyDict::new(py);
        match r {
            Ok(x) => {
                d.set_item("t", x.t.into_pyarray(py))?;
                d.set_item("s", x.s.into_pyarray(py))?;
                d.set_item("amplitude_h", x.amplitude_h.into_pyarray(py))?;
                d.set_item("status", x.status.name())?;
            }
            Err(e) => {
                let kind = if matches!(e, Error::InvalidParameter { .. } | Error::Toml { .. }) { "invalid" } else { "numerical" };
                d.set_item("error", e.to_string())?;
                d.set_item("error_kind", kind)?;
            }
        }
        out.push(d);
    }
    Ok(out)
}

/// Virtual ENMA of the beam of `params`; `options_json` holds the fields of the core's
/// `EnmaOptions` (missing ones take defaults). Returns the result as JSON text.
#[pyfunction]
#[pyo3(signature = (params, options_json, progress=None))]
fn virtual_enma(py: Python<'_>, params: &Bound<'_, PyParams>, options_json: &str, progress: Option<Py<PyAny>>) -> PyResult<String> {
    let opts: EnmaOptions = serde_json::from_str(options_json).map_err(|e| PyValueError::new_err(format!("invalid ENMA options: {e}")))?;
    let valid = params.get().0.clone();
    let mut monitor = PyMonitor::new(progress);
    let out = py.detach(|| {
        guarded(|| {
            let r = core_enma(&Model::of(&valid)?, &opts, &mut monitor)?;
            serde_json::to_string(&r).map_err(|e| Error::Numerical(e.to_string()))
        })
    });
    monitor.outcome(out)
}

/// Modal data of the linear beam (core `physics::beam`, docs/model.md §2 and §9): `omega_rad_s`,
/// `gamma`, `k11_per_m`, `k_ax_n_per_m`, `phi_mid` (φ₁(L/2)), `b_star_per_s2`, the first mode with
/// the axial preload (`omega1_preload_rad_s`, `omega1_rayleigh_rad_s`, `b_star_preload_per_s2`,
/// `mode1_vector`), `ei_n_m2`, `ea_n`, φ₁/φ₁(L/2) at x/L = 0, 0.01, …, 1 (`shape_x_over_l`,
/// `shape_phi1`), K (`k_matrix`, N rows), φₘ at `x_over_l` (`phi`, N rows) and `preload_n`.
#[pyfunction]
#[pyo3(signature = (params, x_over_l=Vec::new()))]
fn beam_properties<'py>(py: Python<'py>, params: &Bound<'py, PyParams>, x_over_l: Vec<f64>) -> PyResult<Bound<'py, PyDict>> {
    let model = model_of(py, params)?;
    let (b, p) = (&model.beam, &model.params);
    let first = b.first_mode(p.thickness_m);
    let (xi, shape) = b.mode1_shape(100);
    let d = PyDict::new(py);
    d.set_item("omega_rad_s", b.omega.clone())?;
    d.set_item("gamma", b.gamma.clone())?;
    d.set_item("k11_per_m", b.k[0])?;
    d.set_item("k_ax_n_per_m", b.k_ax)?;
    d.set_item("phi_mid", b.phi_exact(0, 0.5 * p.length_m))?;
    d.set_item("b_star_per_s2", b.b_star(p.thickness_m))?;
    d.set_item("omega1_preload_rad_s", first.omega_rad_s)?;
    d.set_item("omega1_rayleigh_rad_s", first.omega_rayleigh_rad_s)?;
    d.set_item("b_star_preload_per_s2", first.b_star_per_s2)?;
    d.set_item("mode1_vector", first.vector)?;
    d.set_item("ei_n_m2", p.bending_stiffness())?;
    d.set_item("ea_n", p.youngs_modulus_pa * p.area_m2())?;
    d.set_item("shape_x_over_l", xi)?;
    d.set_item("shape_phi1", shape)?;
    d.set_item("k_matrix", b.k_rows())?;
    d.set_item("phi", b.phi_at(&x_over_l))?;
    d.set_item("preload_n", b.preload_n)?;
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(natural_frequencies, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(physical_manifold_grid, m)?)?;
    m.add_function(wrap_pyfunction!(super_slow_manifold, m)?)?;
    m.add_function(wrap_pyfunction!(run_free_slider_batch, m)?)?;
    m.add_function(wrap_pyfunction!(virtual_enma, m)?)?;
    m.add_function(wrap_pyfunction!(beam_properties, m)?)?;
    Ok(())
}
