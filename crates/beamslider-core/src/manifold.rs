//! Super-slow (invariant) manifold of docs/model.md §6: the steady-state beam amplitude as a function
//! of slider position, by sequential continuation of the pseudo-constrained slider (PCS) in s,
//! upwards and downwards from the same initial state. The two sweeps are independent, so they run
//! on two threads (the results do not depend on it: each sweep is sequential, and the counters
//! are sums and maxima); the calling thread polls the caller's monitor meanwhile
//! ([`crate::dynamics::runner::watched`]).

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use crate::dynamics::record::{Channel, MemoryRecorder, NullRecorder};
use crate::dynamics::runner;
use crate::dynamics::simulation::{Excitation, Model, Monitor, RunOptions, SliderModel, State, Status};
use crate::dynamics::stepper::Counters;
use crate::error::{Error, Result};
use crate::signal::hilbert_envelope;

/// Settings of the continuation.
#[derive(Debug, Clone, PartialEq)]
pub struct ManifoldOptions {
    /// Slider positions of the upward sweep, increasing (the downward sweep reverses them).
    pub s_values: Vec<f64>,
    /// Excitation periods simulated at each s (reference: 100; the paper: 300).
    pub periods: usize,
    /// Periods at the end of each s over which the amplitude is averaged (reference: 25).
    pub record_periods: usize,
}

impl ManifoldOptions {
    /// The reference settings: s = 0, 0.005, …, 0.5, 100 periods, last 25 recorded.
    pub fn reference() -> Self {
        ManifoldOptions { s_values: (0..=100).map(|i| i as f64 * 0.005).collect(), periods: 100, record_periods: 25 }
    }

    /// Physical sweep: the reference grid from the first s whose contact points lie on the beam.
    pub fn physical(model: &Model) -> Self {
        let s_min = 0.5 * model.params.contact_spacing_m / model.params.length_m;
        let mut o = Self::reference();
        o.s_values.retain(|&s| s >= s_min - 1e-12);
        o
    }
}

/// One sweep direction: amplitude of w(4L/7) at each s.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Branch {
    /// Slider positions in the order visited.
    pub s: Vec<f64>,
    /// Mean |Hilbert(w(4L/7))| over the recorded periods [m].
    pub amplitude_m: Vec<f64>,
}

/// Both sweeps.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Manifold {
    /// Upward sweep (increasing s).
    pub up: Branch,
    /// Downward sweep (decreasing s).
    pub down: Branch,
    /// Counters over all runs.
    pub counters: Counters,
}

/// Header of the manifold CSV.
pub const CSV_HEADER: &str = "branch,s,amplitude_m";

impl Manifold {
    /// The manifold as CSV text ([`csv_text`]).
    pub fn to_csv(&self) -> String {
        csv_text(&self.up, &self.down)
    }
}

/// The manifold CSV (docs/model.md §6): header `branch,s,amplitude_m`, then one line per
/// position, the upward sweep (`up`) then the downward one (`down`); s as the shortest decimal
/// that reads back exactly, the amplitude [m] in exponent form (also exact).
pub fn csv_text(up: &Branch, down: &Branch) -> String {
    use std::fmt::Write as _;
    let mut out = format!("{CSV_HEADER}\n");
    for (name, b) in [("up", up), ("down", down)] {
        for (s, a) in b.s.iter().zip(&b.amplitude_m) {
            let _ = writeln!(out, "{name},{s},{a:e}");
        }
    }
    out
}

/// Compute the super-slow manifold at one excitation.
pub fn super_slow_manifold(model: &Model, excitation: &Excitation, opts: &ManifoldOptions, monitor: &mut dyn Monitor) -> Result<Manifold> {
    excitation.validate()?;
    if opts.s_values.is_empty() {
        return Err(Error::invalid("s_values", "[]", "need at least one slider position"));
    }
    if opts.s_values.iter().any(|s| !s.is_finite()) {
        return Err(Error::invalid("s_values", "non-finite", "all s must be finite"));
    }
    if opts.record_periods == 0 || opts.record_periods > opts.periods {
        return Err(Error::invalid("record_periods", opts.record_periods, "must lie in 1..=periods"));
    }
    let start = model.initial_state_pcs(excitation)?;
    let down: Vec<f64> = opts.s_values.iter().rev().copied().collect();
    let total = 2 * opts.s_values.len();
    let cancel = AtomicBool::new(false);
    // Positions done per sweep (fractional within a position), as f64 bits.
    let done = [AtomicU64::new(0), AtomicU64::new(0)];
    let sweep = |k: usize, grid: &[f64]| -> Result<(Branch, Counters)> {
        let mut state = start.clone();
        let mut branch = Branch::default();
        let mut counters = Counters::default();
        for (i, &s) in grid.iter().enumerate() {
            let mut sub = SubMonitor { cancel: &cancel, done: &done[k], base: i as f64, t0: state.t_s, span: 1.0 };
            let r = one_point(model, excitation, opts, s, &state, &mut sub);
            let (amp, next, c) = match r {
                Ok(x) => x,
                Err(e) => {
                    cancel.store(true, Ordering::Relaxed); // the other sweep stops too
                    return Err(e);
                }
            };
            counters.add(&c);
            state = next;
            branch.s.push(s);
            branch.amplitude_m.push(amp);
            done[k].store(((i + 1) as f64).to_bits(), Ordering::Relaxed);
            if cancel.load(Ordering::Relaxed) && i + 1 < grid.len() {
                return Err(Error::Interrupted { t_s: state.t_s });
            }
        }
        Ok((branch, counters))
    };
    let progress = || f64::from_bits(done[0].load(Ordering::Relaxed)) + f64::from_bits(done[1].load(Ordering::Relaxed));
    let both =
        runner::watched(
            &cancel,
            std::time::Duration::from_millis(10),
            || {
                std::thread::scope(|sc| {
                    let dn = sc.spawn(|| runner::catch_panic(|| sweep(1, &down)));
                    let up = runner::catch_panic(|| sweep(0, &opts.s_values));
                    let dn = dn.join().unwrap_or_else(|p| Err(runner::panic_message(p.as_ref())));
                    let internal = |what: String| Error::Numerical(format!("internal error: {what}"));
                    match (up.unwrap_or_else(|w| Err(internal(w))), dn.unwrap_or_else(|w| Err(internal(w)))) {
                        (Ok(u), Ok(d)) => Ok((u, d)),
                        // the error that stopped the other sweep, not the other's interruption
                        (Err(e @ Error::Interrupted { .. }), Err(f)) | (Err(f), Err(e @ Error::Interrupted { .. })) => {
                            if matches!(f, Error::Interrupted { .. }) { Err(e) } else { Err(f) }
                        }
                        (Err(e), _) | (_, Err(e)) => Err(e),
                    }
                })
            },
            || monitor.poll(progress(), total as f64),
        );
    let ((up, cu), (dn, cd)) = both?;
    if cancel.load(Ordering::Relaxed) {
        return Err(Error::Interrupted { t_s: 0.0 });
    }
    let mut counters = cu;
    counters.add(&cd);
    if !monitor.poll(total as f64, total as f64) {
        return Err(Error::Interrupted { t_s: 0.0 });
    }
    Ok(Manifold { up, down: dn, counters })
}

/// The monitor of the runs at one slider position: records the progress of its sweep (in units
/// of positions) for the polling thread, and stops the run once the batch is cancelled.
struct SubMonitor<'a> {
    cancel: &'a AtomicBool,
    done: &'a AtomicU64,
    base: f64,
    t0: f64,
    span: f64,
}

impl Monitor for SubMonitor<'_> {
    fn poll(&mut self, t_s: f64, _t_end_s: f64) -> bool {
        let frac = ((t_s - self.t0) / self.span).clamp(0.0, 1.0);
        self.done.store((self.base + frac).to_bits(), Ordering::Relaxed);
        !self.cancel.load(Ordering::Relaxed)
    }
}

fn one_point(
    model: &Model, excitation: &Excitation, opts: &ManifoldOptions, s: f64, start: &State, monitor: &mut SubMonitor,
) -> Result<(f64, State, Counters)> {
    let dt = model.params.dt_s;
    let period = excitation.period_s();
    let n_total = (opts.periods as f64 * period / dt).round() as u64;
    let n_rec = (opts.record_periods as f64 * period / dt).round() as u64;
    let model_kind = SliderModel::PseudoConstrained { s };
    monitor.span = (n_total as f64 * dt).max(1e-300);
    let settle = RunOptions {
        excitation: *excitation,
        model: model_kind,
        duration_s: (n_total - n_rec) as f64 * dt,
        record_every: usize::MAX,
        channels: vec![],
        audit_contacts: false,
    };
    let a = model.run(start, &settle, &mut NullRecorder, monitor)?;
    check(&a.status, s)?;
    let rec_opts = RunOptions { duration_s: n_rec as f64 * dt, record_every: 1, channels: vec![Channel::W4L7], ..settle };
    let mut rec = MemoryRecorder::new();
    let b = model.run(&a.state, &rec_opts, &mut rec, monitor)?;
    check(&b.status, s)?;
    // Rows: the start sample and n_rec steps; drop the start (it belongs to the settling run).
    let w = &rec.data[1..];
    let env = hilbert_envelope(w);
    let amp = env.iter().sum::<f64>() / env.len().max(1) as f64;
    let mut c = a.counters;
    c.add(&b.counters);
    Ok((amp, b.state, c))
}

fn check(status: &Status, s: f64) -> Result<()> {
    match status {
        Status::Completed => Ok(()),
        Status::Interrupted { t_s } => Err(Error::Interrupted { t_s: *t_s }),
        other => Err(Error::Numerical(format!("manifold at s = {}: {}", crate::error::short_number(s), other.message()))),
    }
}
