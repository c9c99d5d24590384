//! Free-slider runs of the discrepancy workflow (`python/beamslider/discover/`), binding side: the
//! runs of one or more χ² evaluations as one batch through the core's runner
//! ([`beamslider_core::dynamics::runner::run_batch`]: rayon workers, bitwise independent of the thread
//! count), with the interpreter released, Ctrl-C and an optional per-run callback polled from the
//! calling thread. Each job returns what the slider-level features need, reduced in the worker:
//! t, s = x_C/L and the super-slow amplitude A = envelope(w(4L/7), 1 s)/h (docs/model.md §7),
//! every `keep_every`-th recorded sample. A job whose parameters are invalid or whose run fails
//! is a result with an error, not the end of the batch (the fit counts it as a bad point).

use std::sync::Mutex;
use std::sync::atomic::AtomicBool;

use beamslider_core::{
    CancelFlag, Channel, ColumnRecorder, Error, Excitation, Model, Params, Recorder, RunOptions, SliderModel, Status,
    dynamics::runner, signal,
};
use numpy::IntoPyArray;
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::{check_threads, detached};

/// One run: (parameter TOML, f_ex [Hz], a_ex [m/s²], s₀ [-], duration [s]).
type Job = (String, f64, f64, f64, f64);

/// The reduced result of one run.
struct Reduced {
    index: usize,
    outcome: Result<(Vec<f64>, Vec<f64>, Vec<f64>, Status), Error>,
}

fn run_one(
    job: &Job,
    record_every: usize,
    keep_every: usize,
    window_s: f64,
    detrend_s: Option<f64>,
    cancel: &AtomicBool,
) -> Result<Option<(Vec<f64>, Vec<f64>, Vec<f64>, Status)>, Error> {
    let (toml, f, a, s0, duration) = job;
    let params = Params::from_toml_str(toml)?;
    let h = params.thickness_m;
    let m = Model::new(params)?;
    let excitation = Excitation::new(*f, *a);
    let start = m.start(SliderModel::Free, *s0, &excitation)?;
    let opts = RunOptions {
        excitation,
        model: SliderModel::Free,
        duration_s: *duration,
        record_every,
        channels: vec![Channel::Time, Channel::W4L7, Channel::S],
        audit_contacts: false,
    };
    m.check_run(&start, &opts)?;
    let rows = beamslider_core::recorded_rows(*duration, m.params.dt_s, record_every);
    let rows = usize::try_from(rows).map_err(|_| Error::invalid("duration", duration, "too many rows"))?;
    let mut rec = ColumnRecorder::with_rows(rows);
    let summary = m.run(&start, &opts, &mut rec as &mut dyn Recorder, &mut CancelFlag(cancel))?;
    if let Status::Interrupted { .. } = summary.status {
        return Ok(None);
    }
    let mut cols = std::mem::take(&mut rec.columns).into_iter();
    let (t, w, s) = (cols.next().unwrap_or_default(), cols.next().unwrap_or_default(), cols.next().unwrap_or_default());
    if t.len() < 2 {
        return Err(Error::Numerical(format!("run ended after {} samples ({})", t.len(), summary.status.message())));
    }
    let dt_rec = t[1] - t[0];
    // As the reader of measured data (docs/model.md §7): w minus its centred moving average over
    // `detrend_s`, which also takes a few per cent off the amplitude (|sinc| of the window).
    let w = match detrend_s {
        Some(d) => {
            let k = (d / dt_rec).round().max(1.0).min((2 * w.len() + 1) as f64) as usize;
            let mean = signal::moving_average(&w, k);
            w.iter().zip(&mean).map(|(x, m)| x - m).collect()
        }
        None => w,
    };
    let amp = signal::envelope_checked(&w, dt_rec, window_s)?;
    let pick = |v: &[f64], scale: f64| v.iter().step_by(keep_every).map(|x| x * scale).collect::<Vec<f64>>();
    Ok(Some((pick(&t, 1.0), pick(&s, 1.0), pick(&amp, 1.0 / h), summary.status)))
}

/// Run free-slider jobs `(params_toml, f_ex_hz, a_ex_m_s2, s0, duration_s)` in parallel (`threads`
/// workers, default one per core) with the interpreter released. Each run records t, w(4L/7), s
/// every `record_every` steps; the worker computes A = envelope(w, `window_s`)/h and keeps every
/// `keep_every`-th sample; with `detrend_s` (the measured data's 0.1 s), w minus its centred moving
/// average over that time first, as the reader does to integrated measured velocity. Returns one dict per job, in job order: `t`, `s`, `amplitude_h`
/// (arrays) and `status` ("completed", "left_beam", "diverged"), or `error` (message) and
/// `error_kind` ("invalid": bad parameters; "numerical"). `on_done(n)` is called from the calling
/// thread with the number of runs finished since the last call; Ctrl-C or an exception in it
/// cancels the batch.
#[pyfunction]
#[pyo3(signature = (jobs, *, record_every=5, keep_every=5, window_s=1.0, detrend_s=None, threads=None, on_done=None))]
fn run_free_slider_batch<'py>(
    py: Python<'py>,
    jobs: Vec<Job>,
    record_every: usize,
    keep_every: usize,
    window_s: f64,
    detrend_s: Option<f64>,
    threads: Option<usize>,
    on_done: Option<Py<PyAny>>,
) -> PyResult<Vec<Bound<'py, PyDict>>> {
    check_threads(threads)?;
    if record_every == 0 {
        return Err(PyValueError::new_err("invalid parameter `record_every` = 0: must be >= 1"));
    }
    if keep_every == 0 {
        return Err(PyValueError::new_err("invalid parameter `keep_every` = 0: must be >= 1"));
    }
    if !(window_s.is_finite() && window_s > 0.0) {
        return Err(PyValueError::new_err(format!("invalid parameter `window_s` = {window_s}: must be finite and > 0")));
    }
    if let Some(d) = detrend_s {
        if !(d.is_finite() && d > 0.0) {
            return Err(PyValueError::new_err(format!("invalid parameter `detrend_s` = {d}: must be finite and > 0")));
        }
    }
    let indexed: Vec<(usize, Job)> = jobs.into_iter().enumerate().collect();
    let cancel = AtomicBool::new(false);
    let fresh = Mutex::new(0usize);
    let poll = |py: Python<'_>| -> PyResult<()> {
        py.check_signals()?;
        let n = std::mem::take(&mut *fresh.lock().unwrap_or_else(|e| e.into_inner()));
        match &on_done {
            Some(cb) if n > 0 => cb.call1(py, (n,)).map(|_| ()),
            _ => Ok(()),
        }
    };
    let work = || {
        runner::run_batch(
            &indexed,
            threads,
            &cancel,
            |(i, job)| {
                // A failed job is a result (the fit's bad point); a panic is one too.
                let r = runner::catch_panic(|| run_one(job, record_every, keep_every, window_s, detrend_s, &cancel))
                    .unwrap_or_else(|what| Err(Error::Numerical(format!("internal error: {what}"))));
                Ok(match r {
                    Ok(Some(v)) => Some(Reduced { index: *i, outcome: Ok(v) }),
                    Ok(None) => None,
                    Err(e) => Some(Reduced { index: *i, outcome: Err(e) }),
                })
            },
            |_| {
                *fresh.lock().unwrap_or_else(|e| e.into_inner()) += 1;
                Ok(())
            },
        )
    };
    let outcome = detached(py, &cancel, 50, work, poll)?;
    poll(py)?;
    if outcome.cancelled {
        return Err(PyKeyboardInterrupt::new_err("discover runs interrupted"));
    }
    let mut results = outcome.results;
    results.sort_by_key(|r| r.index);
    let mut out = Vec::with_capacity(results.len());
    for r in results {
        let d = PyDict::new(py);
        match r.outcome {
            Ok((t, s, a, status)) => {
                d.set_item("t", t.into_pyarray(py))?;
                d.set_item("s", s.into_pyarray(py))?;
                d.set_item("amplitude_h", a.into_pyarray(py))?;
                d.set_item("status", status.name())?;
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

/// Register the discover functions in the `_core` module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(run_free_slider_batch, m)?)?;
    Ok(())
}
