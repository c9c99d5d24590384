//! Free-slider runs reduced to what slider-level features need (the discrepancy workflow): t,
//! s = x_C/L and the super-slow amplitude A = envelope(w(4L/7), window)/h of docs/model.md §7,
//! every `keep_every`-th recorded sample, computed in the worker. A batch runs on the core's
//! runner ([`crate::dynamics::runner::run_batch`]: rayon workers, bitwise independent of the
//! thread count); a job whose run fails is a result with an error, not the end of the batch.

use std::sync::atomic::AtomicBool;

use crate::dynamics::record::{Channel, ColumnRecorder, Recorder};
use crate::dynamics::runner;
use crate::dynamics::simulation::{CancelFlag, Excitation, Model, RunOptions, SliderModel, Status};
use crate::error::{Error, Result};
use crate::params::Valid;
use crate::signal::filters::{EnvelopeBuffers, envelope_every, subtract_moving_average};
use crate::signal::output::recorded_rows;

/// One run: parameters, f_ex [Hz], a_ex [m/s²], s₀ [-], duration [s].
#[derive(Debug, Clone)]
pub struct Job {
    /// Parameters.
    pub params: Valid,
    /// Excitation frequency [Hz].
    pub f_ex_hz: f64,
    /// Base-acceleration amplitude [m/s²].
    pub a_ex_m_s2: f64,
    /// Initial slider position.
    pub s0: f64,
    /// Duration [s].
    pub duration_s: f64,
}

/// How a run is recorded and reduced.
#[derive(Debug, Clone, Copy)]
pub struct Reduction {
    /// Record every k-th step.
    pub record_every: usize,
    /// Keep every k-th recorded sample.
    pub keep_every: usize,
    /// Moving-average window of the envelope [s].
    pub window_s: f64,
    /// With Some(d): w minus its centred moving average over d seconds first, as the reader
    /// of measured data does to integrated velocity (§7).
    pub detrend_s: Option<f64>,
}

impl Reduction {
    /// Check the settings.
    pub fn check(&self) -> Result<()> {
        if self.record_every == 0 {
            return Err(Error::invalid("record_every", 0, "must be >= 1"));
        }
        if self.keep_every == 0 {
            return Err(Error::invalid("keep_every", 0, "must be >= 1"));
        }
        if !(self.window_s.is_finite() && self.window_s > 0.0) {
            return Err(Error::invalid("window_s", self.window_s, "must be finite and > 0"));
        }
        if let Some(d) = self.detrend_s
            && !(d.is_finite() && d > 0.0)
        {
            return Err(Error::invalid("detrend_s", d, "must be finite and > 0"));
        }
        Ok(())
    }
}

/// A reduced run: t [s], s, A/h and how the run ended.
#[derive(Debug, Clone)]
pub struct Reduced {
    /// Times [s].
    pub t: Vec<f64>,
    /// Slider position.
    pub s: Vec<f64>,
    /// Super-slow amplitude over the thickness.
    pub amplitude_h: Vec<f64>,
    /// Status of the run.
    pub status: Status,
}

/// The buffers of one worker, reused from run to run: the recorded columns and those of the
/// envelope (the same results as fresh ones; a 60-s run's arrays are tens of MB).
#[derive(Debug, Default)]
pub struct Workspace {
    columns: Vec<Vec<f64>>,
    prefix: Vec<f64>,
    envelope: EnvelopeBuffers,
}

/// Run and reduce one job; `Ok(None)` when cancelled.
pub fn run_one(job: &Job, red: &Reduction, cancel: &AtomicBool) -> Result<Option<Reduced>> {
    run_one_in(job, red, cancel, &mut Workspace::default())
}

/// [`run_one`] with the buffers of `ws`.
pub fn run_one_in(job: &Job, red: &Reduction, cancel: &AtomicBool, ws: &mut Workspace) -> Result<Option<Reduced>> {
    let h = job.params.thickness_m;
    let m = Model::of(&job.params)?;
    let excitation = Excitation::new(job.f_ex_hz, job.a_ex_m_s2);
    let start = m.start(SliderModel::Free, job.s0, &excitation)?;
    let opts = RunOptions {
        excitation,
        model: SliderModel::Free,
        duration_s: job.duration_s,
        record_every: red.record_every,
        channels: vec![Channel::Time, Channel::W4L7, Channel::S],
        audit_contacts: false,
    };
    m.check_run(&start, &opts)?;
    let rows = recorded_rows(job.duration_s, m.params.dt_s, red.record_every);
    let rows = usize::try_from(rows).map_err(|_| Error::invalid("duration", job.duration_s, "too many rows"))?;
    let mut rec = ColumnRecorder::reusing(rows, std::mem::take(&mut ws.columns));
    let summary = m.run(&start, &opts, &mut rec as &mut dyn Recorder, &mut CancelFlag(cancel))?;
    if let Status::Interrupted { .. } = summary.status {
        return Ok(None);
    }
    let mut cols = std::mem::take(&mut rec.columns).into_iter();
    let (t, mut w, s) = (cols.next().unwrap_or_default(), cols.next().unwrap_or_default(), cols.next().unwrap_or_default());
    if t.len() < 2 {
        return Err(Error::Numerical(format!("run ended after {} samples ({})", t.len(), summary.status.message())));
    }
    let dt_rec = t[1] - t[0];
    // The detrending also takes a few per cent off the amplitude (|sinc| of the window).
    if let Some(d) = red.detrend_s {
        let k = (d / dt_rec).round().max(1.0).min((2 * w.len() + 1) as f64) as usize;
        subtract_moving_average(&mut w, k, &mut ws.prefix);
    }
    let amp = envelope_every(&w, dt_rec, red.window_s, red.keep_every, &mut ws.envelope)?;
    let pick = |v: &[f64]| v.iter().step_by(red.keep_every).copied().collect::<Vec<f64>>();
    let out = Reduced { t: pick(&t), s: pick(&s), amplitude_h: amp.iter().map(|x| x * (1.0 / h)).collect(), status: summary.status };
    ws.columns = vec![t, w, s];
    Ok(Some(out))
}

/// Run `jobs` in parallel on `threads` workers (None: one per core); `on_done()` after each
/// finished job. Returns one result per job in job order, or None when cancelled.
pub fn run_batch(
    jobs: &[Job], red: &Reduction, threads: Option<usize>, cancel: &AtomicBool, on_done: impl Fn() + Send + Sync,
) -> Result<Option<Vec<Result<Reduced>>>> {
    runner::check_threads(threads)?;
    red.check()?;
    let indexed: Vec<(usize, &Job)> = jobs.iter().enumerate().collect();
    // At most one workspace per worker running at once, dropped with the batch.
    let spare: std::sync::Mutex<Vec<Workspace>> = std::sync::Mutex::new(Vec::new());
    let outcome = runner::run_batch(
        &indexed,
        threads,
        cancel,
        |(i, job)| {
            // A failed job is a result (the fit's bad point); a panic is one too.
            let mut ws = spare.lock().unwrap_or_else(|e| e.into_inner()).pop().unwrap_or_default();
            let r =
                runner::catch_panic(|| run_one_in(job, red, cancel, &mut ws)).unwrap_or_else(|what| Err(Error::Numerical(format!("internal error: {what}"))));
            spare.lock().unwrap_or_else(|e| e.into_inner()).push(ws);
            Ok(match r {
                Ok(Some(v)) => Some((*i, Ok(v))),
                Ok(None) => None,
                Err(e) => Some((*i, Err(e))),
            })
        },
        |_| {
            on_done();
            Ok(())
        },
    )?;
    if outcome.cancelled {
        return Ok(None);
    }
    let mut results = outcome.results;
    results.sort_by_key(|r| r.0);
    Ok(Some(results.into_iter().map(|r| r.1).collect()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Params;
    use crate::signal::filters::{envelope_checked, moving_average};

    #[test]
    fn reused_buffers_give_a_fresh_runs_results() {
        // Three runs of different lengths through one workspace, as a batch's worker makes them:
        // bitwise the reduction of a fresh run, and that is the whole-signal envelope's every
        // k-th sample (docs/model.md §7).
        let params = Valid::new(Params::default()).unwrap();
        let red = Reduction { record_every: 5, keep_every: 5, window_s: 0.05, detrend_s: Some(0.1) };
        let cancel = AtomicBool::new(false);
        let mut ws = Workspace::default();
        for (s0, duration_s) in [(0.3, 0.4), (0.31, 0.25), (0.3, 0.4)] {
            let job = Job { params: params.clone(), f_ex_hz: 124.0, a_ex_m_s2: 14.0, s0, duration_s };
            let reused = run_one_in(&job, &red, &cancel, &mut ws).unwrap().unwrap();
            let fresh = run_one(&job, &red, &cancel).unwrap().unwrap();
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
            assert_eq!(bits(&reused.t), bits(&fresh.t));
            assert_eq!(bits(&reused.s), bits(&fresh.s));
            assert_eq!(bits(&reused.amplitude_h), bits(&fresh.amplitude_h));
            // The envelope of the whole recorded (detrended) signal, then every k-th sample.
            let m = Model::of(&params).unwrap();
            let exc = Excitation::new(124.0, 14.0);
            let start = m.start(SliderModel::Free, s0, &exc).unwrap();
            let opts = RunOptions {
                excitation: exc,
                model: SliderModel::Free,
                duration_s,
                record_every: 5,
                channels: vec![Channel::Time, Channel::W4L7, Channel::S],
                audit_contacts: false,
            };
            let mut rec = ColumnRecorder::with_rows(0);
            m.run(&start, &opts, &mut rec as &mut dyn Recorder, &mut ()).unwrap();
            let (t, w) = (&rec.columns[0], &rec.columns[1]);
            let dt = t[1] - t[0];
            let mean = moving_average(w, (0.1 / dt).round() as usize);
            let w: Vec<f64> = w.iter().zip(&mean).map(|(x, m)| x - m).collect();
            let whole: Vec<f64> = envelope_checked(&w, dt, 0.05).unwrap().iter().step_by(5).map(|a| a * (1.0 / params.thickness_m)).collect();
            assert_eq!(bits(&whole), bits(&reused.amplitude_h));
        }
    }
}
