//! Runs of the model (docs/model.md §5–6, §9): one run (core `signal::run`), the PCS manifold, batches
//! of reduced free-slider runs (`signal::reduced`), the virtual ENMA and the beam's modal data.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use beamslider_core::enma::{EnmaOptions, backbone_omega2 as core_backbone, virtual_enma as core_enma};
use beamslider_core::signal::reduced::{self, Job, Reduction};
use beamslider_core::signal::run::{Output, RECORDED, RunSpec, check, run};
use beamslider_core::{Excitation, ManifoldOptions, Model, Status};
use numpy::IntoPyArray;
use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{Out, detached, kwargs, monitored, object};
use crate::error::{CoreResult, guarded, released};
use crate::params::PyParams;

fn model_of(py: Python<'_>, p: &Bound<'_, PyParams>) -> CoreResult<Model> {
    let valid = p.get().0.clone();
    released(py, || Model::of(&valid))
}

/// One run of the FS / PCS / beam-only model (docs/model.md §5–6, core `signal::run`) as a dict (`_core.pyi`).
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, s0, t_end_s, model, s_pcs=None, record_every=10, progress=None, out=None, window_s=1.0, columns=2000, on_start=None, check_only=false))]
fn simulate<'py>(
    py: Python<'py>, params: &Bound<'py, PyParams>, f_ex_hz: f64, a_ex_m_s2: f64, s0: f64, t_end_s: f64, model: &str, s_pcs: Option<f64>, record_every: usize,
    progress: Option<Py<PyAny>>, out: Option<std::path::PathBuf>, window_s: f64, columns: usize, on_start: Option<Py<PyAny>>, check_only: bool,
) -> CoreResult<Option<Bound<'py, PyDict>>> {
    let spec = guarded(|| RunSpec::recorded(model, s_pcs, s0, Excitation::new(f_ex_hz, a_ex_m_s2), t_end_s, record_every))?;
    if check_only {
        let model = model_of(py, params)?;
        return Ok(guarded(|| check(&model, &spec)).map(|()| None)?);
    }
    let valid = params.get().0.clone();
    let output = || out.as_deref().map_or(Output::Memory, |path| Output::File { path, format: None, overview: Some((columns, window_s)) });
    let r = monitored(py, progress, on_start, |m| run(&Model::of(&valid)?, &spec, output(), &mut &*m))?;
    if let Status::Interrupted { t_s } = r.summary.status {
        return Err(PyKeyboardInterrupt::new_err(format!("interrupted at t = {t_s} s")).into());
    }
    let d = PyDict::new(py);
    for ((name, _), col) in RECORDED.iter().zip(r.columns) {
        d.set_item(*name, col.into_pyarray(py))?;
    }
    let pair = |p: Option<(Vec<f64>, Vec<f64>)>| p.map(|(t, y)| (t.into_pyarray(py), y.into_pyarray(py)));
    let slow = r.super_slow.map(|x| (x.t0_s, x.dt_s, x.s.into_pyarray(py), x.amplitude_h.into_pyarray(py)));
    d.set_item("overview", r.overview.map(|o| (pair(o.w), pair(o.s), slow)))?;
    d.set_item("rows", r.rows)?;
    d.set_item("status", r.summary.status.name())?;
    d.set_item("message", r.summary.status.message())?;
    d.set_item("counters", object(py, &r.summary.counters)?)?;
    d.set_item("final_state", object(py, &r.summary.state)?)?;
    Ok(Some(d))
}

/// Default slider positions of the physical manifold sweep (docs/model.md §6).
#[pyfunction]
fn physical_manifold_grid(py: Python<'_>, params: &Bound<'_, PyParams>) -> CoreResult<Vec<f64>> {
    Ok(ManifoldOptions::physical(&model_of(py, params)?).s_values)
}

/// Super-slow manifold by PCS continuation (docs/model.md §6): the core's `Manifold` as a dict.
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, s_values, periods=100, record_periods=25, progress=None))]
fn super_slow_manifold<'py>(
    py: Python<'py>, params: &Bound<'py, PyParams>, f_ex_hz: f64, a_ex_m_s2: f64, s_values: Vec<f64>, periods: usize, record_periods: usize,
    progress: Option<Py<PyAny>>,
) -> CoreResult<Bound<'py, PyAny>> {
    let (excitation, opts) = (Excitation::new(f_ex_hz, a_ex_m_s2), ManifoldOptions { s_values, periods, record_periods });
    let valid = params.get().0.clone();
    object(py, &monitored(py, progress, None, |m| beamslider_core::super_slow_manifold(&Model::of(&valid)?, &excitation, &opts, &mut &*m))?)
}

/// Free-slider runs reduced in the core (`signal::reduced`), in parallel: one dict per job (`_core.pyi`);
/// a job that failed carries its error as the exception it converts to (`error`, one policy with every
/// other call) and that exception's kind (`error_kind`: "invalid" for a `ValueError`, else "numerical").
#[pyfunction]
#[pyo3(signature = (jobs, *, record_every=5, keep_every=5, window_s=1.0, detrend_s=None, threads=None, on_done=None))]
#[allow(clippy::type_complexity)]
fn run_free_slider_batch<'py>(
    py: Python<'py>, jobs: Vec<(Bound<'py, PyParams>, f64, f64, f64, f64)>, record_every: usize, keep_every: usize, window_s: f64, detrend_s: Option<f64>,
    threads: Option<usize>, on_done: Option<Py<PyAny>>,
) -> CoreResult<Vec<Reduced<'py>>> {
    let red = Reduction { record_every, keep_every, window_s, detrend_s };
    let jobs: Vec<Job> =
        jobs.into_iter().map(|(p, f_ex_hz, a_ex_m_s2, s0, duration_s)| Job { params: p.get().0.clone(), f_ex_hz, a_ex_m_s2, s0, duration_s }).collect();
    let (cancel, fresh) = (AtomicBool::new(false), AtomicUsize::new(0));
    let poll = |py: Python<'_>| {
        let n = fresh.swap(0, Ordering::Relaxed);
        on_done.as_ref().filter(|_| n > 0).map_or(Ok(()), |cb| cb.call1(py, (n,)).map(|_| ()))
    };
    let on_one = || {
        fresh.fetch_add(1, Ordering::Relaxed);
    };
    let outcome = detached(py, &cancel, 50, || reduced::run_batch(&jobs, &red, threads, &cancel, on_one), poll)?;
    let results = outcome.ok_or_else(|| PyKeyboardInterrupt::new_err("discover runs interrupted"))?;
    Ok(results
        .into_iter()
        .map(|r| match r {
            Ok(x) => Reduced::Done { t: x.t.into_pyarray(py), s: x.s.into_pyarray(py), amplitude_h: x.amplitude_h.into_pyarray(py), status: x.status.name() },
            Err(e) => {
                let kind = if e.is_input() { "invalid" } else { "numerical" };
                Reduced::Failed { error_kind: kind, error: PyErr::from(crate::error::PyCoreError::from(e)).into_value(py) }
            }
        })
        .collect())
}

/// One job of [`run_free_slider_batch`] as a dict: its reduced signals and status, or its error.
#[derive(IntoPyObject)]
enum Reduced<'py> {
    Done { t: Out<'py>, s: Out<'py>, amplitude_h: Out<'py>, status: &'static str },
    Failed { error_kind: &'static str, error: Py<pyo3::exceptions::PyBaseException> },
}

/// Virtual ENMA (docs/model.md §9); `options`: the core's `EnmaOptions`; the core's `EnmaResult` as a dict.
#[pyfunction]
#[pyo3(signature = (params, *, progress=None, **options))]
fn virtual_enma<'py>(
    py: Python<'py>, params: &Bound<'_, PyParams>, progress: Option<Py<PyAny>>, options: Option<&Bound<'_, PyDict>>,
) -> CoreResult<Bound<'py, PyAny>> {
    let opts: EnmaOptions = kwargs(py, options)?;
    let valid = params.get().0.clone();
    object(py, &monitored(py, progress, None, |m| core_enma(&Model::of(&valid)?, &opts, &mut &*m))?)
}

/// Modal data of the linear beam (core `Model::beam_properties`, docs/model.md §2, §9) as a dict.
#[pyfunction]
#[pyo3(signature = (params, x_over_l=Vec::new()))]
fn beam_properties<'py>(py: Python<'py>, params: &Bound<'py, PyParams>, x_over_l: Vec<f64>) -> CoreResult<Bound<'py, PyAny>> {
    object(py, &model_of(py, params)?.beam_properties(&x_over_l))
}

/// Squared backbone frequencies (ω² + ¾ b a²)/M₁ at the amplitudes a (core `enma::backbone_omega2`).
#[pyfunction]
fn backbone_omega2(omega2: f64, b: f64, amplitude: Vec<f64>, m1: f64) -> Vec<f64> {
    core_backbone(omega2, b, &amplitude, m1)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    crate::convert::export!(m, simulate, physical_manifold_grid, super_slow_manifold, run_free_slider_batch, virtual_enma, beam_properties, backbone_omega2);
    Ok(())
}
