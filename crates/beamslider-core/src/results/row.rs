//! One row of a results file (docs/model.md §8): the grid point, the run's status, the
//! behaviour with its features, the counters and the end state of a completed run.

use serde::{Deserialize, Serialize};

use crate::classify::{Behaviour, Classification};
use crate::dynamics::simulation::{Checkpoint, State, Status};
use crate::dynamics::stepper::{Counters, StepperMemory};
use crate::error::{Error, Result};
use crate::signal::envelope_stream::{EnvelopeStream, hexf};

/// Status of a map row whose run failed with an error (not a run status of the core).
pub const STATUS_ERROR: &str = "error";
/// Status of a predicted map row (no FS run).
pub const STATUS_PREDICTED: &str = "predicted";

/// One operating point of the grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapPoint {
    /// Position in the grid (s₀ slowest, then a_ex, f_ex fastest).
    pub index: usize,
    /// f_ex [Hz].
    pub f_ex_hz: f64,
    /// a_ex [m/s²].
    pub a_ex_m_s2: f64,
    /// s₀.
    pub s0: f64,
}

impl MapPoint {
    pub(crate) fn key(&self) -> (u64, u64, u64) {
        (self.f_ex_hz.to_bits(), self.a_ex_m_s2.to_bits(), self.s0.to_bits())
    }
}

/// One line of the results file: the inputs, the run's status, the behaviour with its features,
/// the counters and the wall time. NaN features (no turning point) are written as `null`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MapRow {
    /// Position in the grid.
    pub index: usize,
    /// f_ex [Hz].
    pub f_ex_hz: f64,
    /// a_ex [m/s²].
    pub a_ex_m_s2: f64,
    /// s₀.
    pub s0: f64,
    /// Simulated time reached [s].
    pub t_end_s: f64,
    /// Run status: completed, left_beam, diverged.
    pub status: String,
    /// Behaviour name.
    pub behaviour: Behaviour,
    /// Reason of the decision.
    pub reason: String,
    /// Mean s over the final window.
    #[serde(deserialize_with = "nan_if_null")]
    pub s_final: f64,
    /// Mean amplitude over the final window [h].
    #[serde(deserialize_with = "nan_if_null")]
    pub amplitude_final_h: f64,
    /// Mean amplitude over t = 1…3 s [h].
    #[serde(deserialize_with = "nan_if_null")]
    pub amplitude_initial_h: f64,
    /// Largest amplitude [h].
    #[serde(deserialize_with = "nan_if_null")]
    pub amplitude_max_h: f64,
    /// Smallest s.
    #[serde(deserialize_with = "nan_if_null")]
    pub s_min: f64,
    /// Largest s.
    #[serde(deserialize_with = "nan_if_null")]
    pub s_max: f64,
    /// s_final − s₀.
    #[serde(deserialize_with = "nan_if_null")]
    pub net_travel: f64,
    /// Net travel towards the centre.
    #[serde(deserialize_with = "nan_if_null")]
    pub travel_to_centre: f64,
    /// Turning point s (null when none).
    pub turn_s: Option<f64>,
    /// Turning point t [s] (null when none).
    pub turn_t_s: Option<f64>,
    /// Jump-up times [s].
    pub jump_up_t_s: Vec<f64>,
    /// Jump-down times [s].
    pub jump_down_t_s: Vec<f64>,
    /// Steady state reached.
    pub steady: bool,
    /// Phase reached at the end of the run (see [`Classification::phase`]).
    #[serde(default)]
    pub phase: String,
    /// Whether the behaviour is final ([`Classification::settled`]); a row of a version-2 file
    /// (without the key) reads as settled when steady, or a relaxation oscillation of
    /// `relax_min_cycles` cycles (see [`MapRow::derive_settled`]).
    #[serde(default)]
    pub settled: bool,
    /// Change of s across the final drift window along its least-squares line (null when unknown:
    /// failed runs, version-2 rows).
    #[serde(default = "nan", deserialize_with = "nan_if_null")]
    pub drift_s: f64,
    /// Change of A [h] across the final drift window along its least-squares line.
    #[serde(default = "nan", deserialize_with = "nan_if_null")]
    pub drift_a_h: f64,
    /// Solver counters (without `max_residual`).
    pub counters: Counters,
    /// Wall time of the point [s] (the only field that differs between identical runs).
    pub wall_time_s: f64,
    /// End state of a completed run, to continue it (None for failed runs and study rows).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end: Option<EndState>,
    /// Further keys of the row, kept as read and written after the others (a study row's
    /// `sample`, `point` and `params`, [`crate::study::StudyResults`]).
    #[serde(flatten, default, skip_serializing_if = "serde_json::Map::is_empty")]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

/// The end state of a completed run: everything needed to continue it bitwise (see
/// [`Checkpoint`]) and the super-slow signals so far (the classification of the continued run
/// sees the whole run). The f64 values are written as hexadecimal bit patterns (exact).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EndState {
    /// Steps since the start.
    pub step: u64,
    /// t_origin, t, q (N), u (N), slider q (3), slider u (3), warm-start percussions (8), last
    /// percussions (8), excitation clock (3), largest audited residual.
    #[serde(with = "hexf")]
    pub x: Vec<f64>,
    /// Last contact pattern per contact.
    pub modes: [u8; 4],
    /// Steps since the clock's last re-synchronisation.
    pub clock_count: u32,
    /// Counters (max_residual is in `x`).
    pub counters: Counters,
    /// Super-slow signals so far.
    pub signals: EnvelopeStream,
}

impl EndState {
    pub(crate) fn new(cp: &Checkpoint, signals: EnvelopeStream) -> EndState {
        let m = &cp.memory;
        let mut x = vec![cp.t_origin_s, cp.state.t_s];
        x.extend_from_slice(&cp.state.q);
        x.extend_from_slice(&cp.state.u);
        x.extend_from_slice(&cp.state.slider_q);
        x.extend_from_slice(&cp.state.slider_u);
        x.extend(m.warm.iter().flatten());
        x.extend(m.last_p.iter().flatten());
        x.extend_from_slice(&m.clock);
        x.push(m.counters.max_residual);
        EndState { step: cp.step, x, modes: m.modes, clock_count: m.clock_count, counters: m.counters, signals }
    }

    /// The checkpoint and the signals, checked against the model (number of modes) and the
    /// recording interval.
    pub(crate) fn restore(&self, n_modes: usize, sample_dt_s: f64) -> Result<(Checkpoint, EnvelopeStream)> {
        let n = n_modes;
        if self.x.len() != 2 + 2 * n + 6 + 8 + 8 + 3 + 1 {
            return Err(Error::invalid("end state", format!("{} values", self.x.len()), &format!("does not fit a model with {n} modes")));
        }
        let x = &self.x;
        let mut k = 2;
        let mut take = |m: usize| {
            let v = x[k..k + m].to_vec();
            k += m;
            v
        };
        let q = take(n);
        let u = take(n);
        let sq = take(3);
        let su = take(3);
        let warm = take(8);
        let last = take(8);
        let clock = take(3);
        let pair = |v: &[f64], i: usize| [v[2 * i], v[2 * i + 1]];
        let counters = Counters { max_residual: x[x.len() - 1], ..self.counters };
        let cp = Checkpoint {
            t_origin_s: x[0],
            step: self.step,
            state: State { t_s: x[1], q, u, slider_q: [sq[0], sq[1], sq[2]], slider_u: [su[0], su[1], su[2]] },
            memory: StepperMemory {
                warm: std::array::from_fn(|i| pair(&warm, i)),
                modes: self.modes,
                last_p: std::array::from_fn(|i| pair(&last, i)),
                counters,
                clock: [clock[0], clock[1], clock[2]],
                clock_count: self.clock_count,
            },
        };
        let mut signals = self.signals.clone();
        signals.validate(sample_dt_s)?;
        Ok((cp, signals))
    }
}

/// serde_json writes NaN as `null`; read it back as NaN (a point that failed early has no
/// features).
fn nan_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

fn nan() -> f64 {
    f64::NAN
}

fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

impl MapRow {
    pub(crate) fn new(p: &MapPoint, t_end_s: f64, status: &Status, c: &Classification, counters: &Counters, wall: f64, end: Option<EndState>) -> MapRow {
        MapRow::from_classification(p, t_end_s, status.name(), c, Counters { max_residual: 0.0, ..*counters }, wall, end)
    }

    /// A row from a classification (FS runs, and the predictor's slow flows with status
    /// `predicted`); no extra keys.
    pub fn from_classification(p: &MapPoint, t_end_s: f64, status: &str, c: &Classification, counters: Counters, wall: f64, end: Option<EndState>) -> MapRow {
        MapRow {
            index: p.index,
            f_ex_hz: p.f_ex_hz,
            a_ex_m_s2: p.a_ex_m_s2,
            s0: p.s0,
            t_end_s,
            status: status.to_string(),
            behaviour: c.behaviour,
            reason: c.reason.clone(),
            s_final: c.s_final,
            amplitude_final_h: c.amplitude_final_h,
            amplitude_initial_h: c.amplitude_initial_h,
            amplitude_max_h: c.amplitude_max_h,
            s_min: c.s_min,
            s_max: c.s_max,
            net_travel: c.net_travel,
            travel_to_centre: c.travel_to_centre,
            turn_s: finite(c.turn_s),
            turn_t_s: finite(c.turn_t_s),
            jump_up_t_s: c.jump_up_t_s.clone(),
            jump_down_t_s: c.jump_down_t_s.clone(),
            steady: c.steady,
            phase: c.phase.clone(),
            settled: c.settled,
            drift_s: c.drift_s,
            drift_a_h: c.drift_a_h,
            counters,
            wall_time_s: wall,
            end,
            extra: serde_json::Map::new(),
        }
    }

    /// The row as one JSON line (no trailing newline).
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("row serialises")
    }

    pub(crate) fn key(&self) -> (u64, u64, u64) {
        (self.f_ex_hz.to_bits(), self.a_ex_m_s2.to_bits(), self.s0.to_bits())
    }

    /// A completed row that has not settled (`settled` false: `not_settled`, or a behaviour still
    /// creeping) or is undetermined (settled at a level between the thresholds, which a longer
    /// run may still leave), with an end state before `t_end_s`: continued by an extension.
    pub fn continuable(&self, t_end_s: f64) -> bool {
        (!self.settled || matches!(self.behaviour, Behaviour::NotSettled | Behaviour::Undetermined))
            && self.status == Status::Completed.name()
            && self.end.is_some()
            && self.t_end_s < t_end_s
    }

    /// The `settled` flag of a row written before the flag existed (format version 2): settled
    /// when steady, or a relaxation oscillation with at least `relax_min_cycles` jump-up →
    /// jump-down cycles in its jump times (the rule of [`Classification::settled`]).
    pub fn derive_settled(&mut self, relax_min_cycles: usize) {
        let mut events: Vec<(f64, bool)> = self.jump_up_t_s.iter().map(|&t| (t, true)).chain(self.jump_down_t_s.iter().map(|&t| (t, false))).collect();
        events.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (mut cycles, mut last_up) = (0, false);
        for (_, up) in events {
            if up {
                last_up = true;
            } else if std::mem::take(&mut last_up) {
                cycles += 1;
            }
        }
        self.settled = match self.behaviour {
            Behaviour::NotSettled => false,
            Behaviour::RelaxationOscillation => self.steady || cycles >= relax_min_cycles,
            _ => self.steady && self.status == Status::Completed.name(),
        };
    }

    pub(crate) fn point(&self) -> MapPoint {
        MapPoint { index: self.index, f_ex_hz: self.f_ex_hz, a_ex_m_s2: self.a_ex_m_s2, s0: self.s0 }
    }
}
