//! Operating maps (MODEL.md §8; paper, Fig. 11): the behaviour of the free slider at every point
//! of a grid of excitation frequency f_ex, level a_ex and initial position s₀, each point a 120-s
//! run classified by [`crate::classify`].
//!
//! Points run in parallel (rayon). Each finished point is appended at once as one JSON line to a
//! results file (`map.jsonl`) and flushed, so a killed run loses only the points in flight; a
//! later run with `resume` skips the points already in the file (a truncated last line from the
//! kill is cut off first). Every point is computed independently from the same inputs, so the rows
//! do not depend on the number of threads (bitwise, apart from `wall_time_s`).
//!
//! Results file: line 1 is a header `{"beamslider_map": 2, "settings": {...}}` with everything
//! that decides a row besides the grid point (parameters, duration, recording interval,
//! classification thresholds); resuming with different settings is an error. Each further line
//! is one [`MapRow`]; a later row of the same point replaces an earlier one (extension).
//!
//! Every completed row carries its run's end state ([`EndState`]: the state, the step index, the
//! stepper's memory and the super-slow signals so far, [`crate::envelope_stream`]). A map can
//! therefore be **extended in time** ([`MapRunOptions::extend`]): the points that had not
//! settled ([`Behaviour::NotSettled`]) or got no behaviour ([`Behaviour::Undetermined`]) continue from their saved end states to the new duration,
//! bitwise as if they had run there from the start; settled points keep their rows. Memory per
//! point in flight: the binned super-slow signals and a few hundred raw samples.

use std::collections::HashSet;
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::classify::{Behaviour, Classification, Criteria, classify};
use crate::envelope_stream::{EnvelopeStream, hexf};
use crate::error::{Error, Result};
use crate::lock::ResultsLock;
use crate::params::Params;
use crate::record::{Channel, Recorder};
use crate::runner::{catch_panic, run_batch};
use crate::simulation::{CancelFlag, Checkpoint, Excitation, Model, RunOptions, SliderModel, State, Status};
use crate::stepper::{Counters, StepperMemory};

/// Name of the results file inside the output folder.
pub const RESULTS_FILE: &str = "map.jsonl";
/// Version written in the results file's header.
pub const FORMAT_VERSION: u32 = 2;
/// Versions this build reads (version 1: rows classified by the rules before the phases, without
/// end states; read for display, never resumed or extended).
pub const READABLE_VERSIONS: [u32; 2] = [1, 2];
/// Largest number of values of one grid axis and of grid points (a range with a tiny step is a
/// typing error, not a map; it would otherwise exhaust the memory).
pub const MAX_POINTS: usize = 1_000_000;

/// One grid axis: a list of values, or an inclusive range `{ start, stop, step }`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Axis {
    /// Explicit values.
    List(Vec<f64>),
    /// start, start + step, …, up to and including stop (within step/1000).
    Range {
        /// First value.
        start: f64,
        /// Last value (included when on the grid).
        stop: f64,
        /// Spacing (> 0).
        step: f64,
    },
    /// A single value.
    Value(f64),
}

impl Axis {
    /// The values of the axis (range values rounded to 1e-9 to avoid 100.00000000000001).
    pub fn values(&self, field: &str) -> Result<Vec<f64>> {
        let v = match self {
            Axis::List(v) => v.clone(),
            Axis::Value(x) => vec![*x],
            Axis::Range { start, stop, step } => {
                if !(start.is_finite() && stop.is_finite() && step.is_finite() && *step > 0.0 && stop >= start) {
                    return Err(Error::invalid(field, format!("{{start={start}, stop={stop}, step={step}}}"), "need finite start <= stop and step > 0"));
                }
                let n = ((stop - start) / step + 1e-3).floor() + 1.0;
                if !(n <= MAX_POINTS as f64) {
                    return Err(Error::invalid(field, format!("{{start={start}, stop={stop}, step={step}}}"), &format!("gives {n:e} values; at most {MAX_POINTS}")));
                }
                (0..n as usize).map(|i| ((start + i as f64 * step) * 1e9).round() / 1e9).collect()
            }
        };
        if v.is_empty() {
            return Err(Error::invalid(field, "[]", "need at least one value"));
        }
        if v.len() > MAX_POINTS {
            return Err(Error::invalid(field, format!("{} values", v.len()), &format!("at most {MAX_POINTS}")));
        }
        if let Some(x) = v.iter().find(|x| !x.is_finite()) {
            return Err(Error::invalid(field, x, "all values must be finite"));
        }
        let mut sorted = v.clone();
        sorted.sort_by(f64::total_cmp);
        if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
            return Err(Error::invalid(field, w[0], "appears twice (each grid point is run once)"));
        }
        Ok(v)
    }
}

/// The grid of operating points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Grid {
    /// Excitation frequencies f_ex [Hz].
    pub f_ex_hz: Axis,
    /// Excitation levels a_ex [m/s²].
    pub a_ex_m_s2: Axis,
    /// Initial slider positions s₀ [-].
    #[serde(default = "default_s0")]
    pub s0: Axis,
}

fn default_s0() -> Axis {
    Axis::Value(0.3)
}

fn default_duration() -> f64 {
    120.0
}

/// Steps between the samples a map keeps for the classifier (its default `record_every`).
pub const DEFAULT_RECORD_EVERY: usize = 20;

fn default_record_every() -> usize {
    DEFAULT_RECORD_EVERY
}

/// A map: parameters, grid, duration, recording interval and classification thresholds. As TOML:
///
/// ```toml
/// duration_s = 120.0          # simulated time per point [s]
/// # dt_s = 2e-5               # time step; overrides params.dt_s
/// # record_every = 20         # steps between the samples kept for the classifier
/// [grid]
/// f_ex_hz = { start = 100.0, stop = 130.0, step = 2.0 }
/// a_ex_m_s2 = [4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0]
/// s0 = 0.3
/// [params]                    # any keys of `beamslider-batch params` (defaults otherwise)
/// friction_coefficient = 0.2
/// [criteria]                  # classification thresholds (defaults otherwise)
/// high_h = 0.3
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapConfig {
    /// Simulated duration per point [s].
    #[serde(default = "default_duration")]
    pub duration_s: f64,
    /// Time step [s]; overrides `params.dt_s` when given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dt_s: Option<f64>,
    /// Keep every k-th step of w(4L/7) and s for the classifier.
    #[serde(default = "default_record_every")]
    pub record_every: usize,
    /// The grid.
    pub grid: Grid,
    /// Model parameters.
    #[serde(default)]
    pub params: Params,
    /// Classification thresholds.
    #[serde(default)]
    pub criteria: Criteria,
}

impl Default for MapConfig {
    /// The paper's map (Fig. 11): f_ex = 100, 102, …, 130 Hz, a_ex = 4, 6, …, 16 m/s², s₀ = 0.3,
    /// 120 s, default parameters.
    fn default() -> Self {
        MapConfig {
            duration_s: 120.0,
            dt_s: None,
            record_every: default_record_every(),
            grid: Grid {
                f_ex_hz: Axis::Range { start: 100.0, stop: 130.0, step: 2.0 },
                a_ex_m_s2: Axis::Range { start: 4.0, stop: 16.0, step: 2.0 },
                s0: default_s0(),
            },
            params: Params::default(),
            criteria: Criteria::default(),
        }
    }
}

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
    fn key(&self) -> (u64, u64, u64) {
        (self.f_ex_hz.to_bits(), self.a_ex_m_s2.to_bits(), self.s0.to_bits())
    }
}

/// What decides a row besides the grid point: written to the results header, compared on resume.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    /// Parameters as canonical TOML text (dt_s included).
    pub params_toml: String,
    /// Simulated duration per point [s].
    pub duration_s: f64,
    /// Recording interval in steps.
    pub record_every: usize,
    /// Classification thresholds.
    pub criteria: Criteria,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Header {
    beamslider_map: u32,
    settings: Settings,
    /// A study's configuration (study results files only, [`crate::study::StudyResults`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    study: Option<serde_json::Value>,
    /// The reduced predictor of a predicted map ([`crate::predictor::run_predicted_map`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    predictor: Option<serde_json::Value>,
}

impl MapConfig {
    /// Parse TOML text and validate.
    pub fn from_toml_str(text: &str) -> Result<MapConfig> {
        let c: MapConfig = toml::from_str(text).map_err(|e| Error::Toml { path: None, message: e.to_string().trim_end().to_string() })?;
        c.validate()?;
        Ok(c)
    }

    /// Read and validate a TOML file.
    pub fn from_toml_file(path: impl AsRef<Path>) -> Result<MapConfig> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.display().to_string(), source })?;
        Self::from_toml_str(&text).map_err(|e| match e {
            Error::Toml { message, .. } => Error::Toml { path: Some(path.display().to_string()), message },
            other => other,
        })
    }

    /// TOML text of this configuration.
    pub fn to_toml_string(&self) -> String {
        toml::to_string(self).expect("plain struct of numbers and strings always serialises")
    }

    /// The parameters with the `dt_s` override applied.
    pub fn effective_params(&self) -> Params {
        let mut p = self.params.clone();
        if let Some(dt) = self.dt_s {
            p.dt_s = dt;
        }
        p
    }

    /// Check the settings and the grid.
    pub fn validate(&self) -> Result<()> {
        if !(self.duration_s.is_finite() && self.duration_s > 0.0) {
            return Err(Error::invalid("duration_s", self.duration_s, "must be finite and > 0"));
        }
        if self.record_every == 0 {
            return Err(Error::invalid("record_every", 0, "must be >= 1"));
        }
        self.effective_params().validate()?;
        self.points()?;
        Ok(())
    }

    /// All grid points (s₀ slowest, then a_ex, f_ex fastest).
    pub fn points(&self) -> Result<Vec<MapPoint>> {
        let f = self.grid.f_ex_hz.values("grid.f_ex_hz")?;
        let a = self.grid.a_ex_m_s2.values("grid.a_ex_m_s2")?;
        let s = self.grid.s0.values("grid.s0")?;
        for &x in &f {
            Excitation::new(x, 1.0).validate()?;
        }
        for &x in &a {
            Excitation::new(1.0, x).validate()?;
        }
        let p = self.effective_params();
        if let Some(x) = f.iter().find(|&&x| x * p.dt_s > 0.1) {
            return Err(Error::invalid("grid.f_ex_hz", x, &format!("too high for dt_s = {:e} s (need 10 steps per excitation period)", p.dt_s)));
        }
        let half = 0.5 * p.contact_spacing_m / p.length_m;
        if let Some(x) = s.iter().find(|&&x| !(x - half >= 0.0 && x + half <= 1.0)) {
            return Err(Error::invalid("grid.s0", x, &format!("the slider's contact points must lie on the beam: {half:.4} <= s0 <= {:.4}", 1.0 - half)));
        }
        if f.len() * a.len() * s.len() > MAX_POINTS {
            return Err(Error::invalid("grid", format!("{} points", f.len() * a.len() * s.len()), &format!("at most {MAX_POINTS}")));
        }
        let mut pts = Vec::with_capacity(f.len() * a.len() * s.len());
        for &s0 in &s {
            for &a_ex in &a {
                for &f_ex in &f {
                    pts.push(MapPoint { index: pts.len(), f_ex_hz: f_ex, a_ex_m_s2: a_ex, s0 });
                }
            }
        }
        Ok(pts)
    }

    /// The settings that decide a row besides the point.
    pub fn settings(&self) -> Settings {
        Settings {
            params_toml: self.effective_params().to_toml_string(),
            duration_s: self.duration_s,
            record_every: self.record_every,
            criteria: self.criteria.clone(),
        }
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
    fn new(cp: &Checkpoint, signals: EnvelopeStream) -> EndState {
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
    fn restore(&self, n_modes: usize, sample_dt_s: f64) -> Result<(Checkpoint, EnvelopeStream)> {
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

fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

impl MapRow {
    fn new(p: &MapPoint, t_end_s: f64, status: &Status, c: &Classification, counters: &Counters, wall: f64, end: Option<EndState>) -> MapRow {
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

    fn key(&self) -> (u64, u64, u64) {
        (self.f_ex_hz.to_bits(), self.a_ex_m_s2.to_bits(), self.s0.to_bits())
    }

    /// A completed row without a behaviour (not settled, or undetermined: settled at a level
    /// between the thresholds, which a longer run may still leave) with an end state before
    /// `t_end_s`: continued by an extension.
    pub fn continuable(&self, t_end_s: f64) -> bool {
        matches!(self.behaviour, Behaviour::NotSettled | Behaviour::Undetermined) && self.status == Status::Completed.name() && self.end.is_some() && self.t_end_s < t_end_s
    }

    fn point(&self) -> MapPoint {
        MapPoint { index: self.index, f_ex_hz: self.f_ex_hz, a_ex_m_s2: self.a_ex_m_s2, s0: self.s0 }
    }
}

/// Feeds w(4L/7) and s of every recorded row (channels [W4L7, S]) into the super-slow stream.
struct StreamRecorder<'a>(&'a mut EnvelopeStream);

impl Recorder for StreamRecorder<'_> {
    fn begin(&mut self, _: &[String]) -> Result<()> {
        Ok(())
    }
    fn push(&mut self, row: &[f64]) -> Result<()> {
        self.0.push(row[0], row[1]);
        Ok(())
    }
}

fn run_options(cfg: &MapConfig, p: &MapPoint) -> RunOptions {
    RunOptions {
        excitation: Excitation::new(p.f_ex_hz, p.a_ex_m_s2),
        model: SliderModel::Free,
        duration_s: cfg.duration_s,
        record_every: cfg.record_every,
        channels: vec![Channel::W4L7, Channel::S],
        audit_contacts: false,
    }
}

/// Run and classify one point from rest. `None` when cancelled.
pub fn run_point(model: &Model, cfg: &MapConfig, p: &MapPoint, cancel: &AtomicBool) -> Result<Option<MapRow>> {
    let t0 = Instant::now();
    let exc = Excitation::new(p.f_ex_hz, p.a_ex_m_s2);
    let start = model.initial_state(p.s0, &exc)?;
    let opts = run_options(cfg, p);
    let mut stream = EnvelopeStream::new(model.params.dt_s * cfg.record_every as f64)?;
    let (sum, cp) = model.run_checkpointed(&start, &opts, &mut StreamRecorder(&mut stream), &mut CancelFlag(cancel))?;
    finish_point(model, cfg, p, sum.status, &sum.counters, cp, stream, t0)
}

/// Continue a not-settled point from the end state of its row to `cfg.duration_s` and classify
/// the whole run: bitwise the row of a run from rest to `cfg.duration_s` (but the wall time).
/// `None` when cancelled.
pub fn continue_point(model: &Model, cfg: &MapConfig, row: &MapRow, cancel: &AtomicBool) -> Result<Option<MapRow>> {
    let t0 = Instant::now();
    let end = row.end.as_ref().ok_or_else(|| Error::invalid("extend_to", row.index, "this row has no saved end state (map written by an older version?)"))?;
    let (cp, mut stream) = end.restore(model.beam.n, model.params.dt_s * cfg.record_every as f64)?;
    let p = row.point();
    let opts = run_options(cfg, &p);
    let (sum, cp) = model.run_from(&cp, &opts, &mut StreamRecorder(&mut stream), &mut CancelFlag(cancel))?;
    finish_point(model, cfg, &p, sum.status, &sum.counters, cp, stream, t0)
}

#[allow(clippy::too_many_arguments)]
fn finish_point(model: &Model, cfg: &MapConfig, p: &MapPoint, status: Status, counters: &Counters, cp: Checkpoint, stream: EnvelopeStream, t0: Instant) -> Result<Option<MapRow>> {
    if let Status::Interrupted { .. } = status {
        return Ok(None);
    }
    let dt = model.params.dt_s * cfg.record_every as f64;
    let t_end = (stream.len().saturating_sub(1)) as f64 * dt;
    let x = stream.super_slow(model.params.thickness_m, 1.0);
    let c = if x.s.len() >= 2 {
        let mut c = classify(&x, &cfg.criteria)?;
        if status != Status::Completed {
            c.behaviour = Behaviour::Undetermined;
            c.reason = status.message();
            c.phase = "failed".into();
        }
        c
    } else if status != Status::Completed {
        no_classification(p, status.message())
    } else {
        no_classification(p, format!("too short to classify: the super-slow signals need two {} s bins", crate::envelope_stream::BIN_S))
    };
    let end = (status == Status::Completed).then(|| EndState::new(&cp, stream));
    Ok(Some(MapRow::new(p, t_end, &status, &c, counters, t0.elapsed().as_secs_f64(), end)))
}

/// The classification of a point that has no super-slow signals (failed or stopped at once).
fn no_classification(p: &MapPoint, reason: String) -> Classification {
    Classification {
        behaviour: Behaviour::Undetermined,
        reason,
        s_initial: p.s0,
        s_final: f64::NAN,
        amplitude_final_h: f64::NAN,
        amplitude_initial_h: f64::NAN,
        amplitude_max_h: f64::NAN,
        s_min: f64::NAN,
        s_max: f64::NAN,
        net_travel: f64::NAN,
        travel_to_centre: f64::NAN,
        turn_s: f64::NAN,
        turn_t_s: f64::NAN,
        jump_up_t_s: vec![],
        jump_down_t_s: vec![],
        steady: false,
        phase: "failed".into(),
    }
}

/// Status of a map row whose run failed with an error (not a run status of the core).
pub const STATUS_ERROR: &str = "error";

/// What to compute for one grid point: a run from rest, or the continuation of a not-settled
/// row from its end state.
#[derive(Debug, Clone)]
pub enum Job {
    /// A run from rest.
    Fresh(MapPoint),
    /// The continuation of a not-settled row (the grid point, the row with its end state).
    Continue(MapPoint, Box<MapRow>),
}

impl Job {
    /// The grid point of the job.
    pub fn point(&self) -> &MapPoint {
        match self {
            Job::Fresh(p) | Job::Continue(p, _) => p,
        }
    }
}

/// Run one job; an error or a panic of the run becomes a row with status `error` and the
/// message as reason, so that one failing point does not stop the map. `None` when cancelled.
pub fn run_job(model: &Model, cfg: &MapConfig, job: &Job, cancel: &AtomicBool) -> Option<MapRow> {
    run_point_guarded(model, cfg, job, cancel)
}

fn run_point_guarded(model: &Model, cfg: &MapConfig, job: &Job, cancel: &AtomicBool) -> Option<MapRow> {
    let t0 = Instant::now();
    let p = match job {
        Job::Fresh(p) | Job::Continue(p, _) => p,
    };
    let r = catch_panic(|| match job {
        Job::Fresh(p) => run_point(model, cfg, p, cancel),
        Job::Continue(p, row) => continue_point(model, cfg, row, cancel).map(|r| {
            r.map(|mut r| {
                r.index = p.index;
                r
            })
        }),
    });
    let message = match r {
        Ok(Ok(row)) => return row,
        Ok(Err(e)) => e.to_string(),
        Err(what) => format!("internal error: {what}"),
    };
    Some(error_row(p, &message, t0))
}

/// The row of a point that failed with `message` (status `error`; started at `t0`).
pub fn error_row(p: &MapPoint, message: &str, t0: Instant) -> MapRow {
    let c = no_classification(p, message.to_string());
    let mut row = MapRow::new(p, f64::NAN, &Status::Completed, &c, &Counters::default(), t0.elapsed().as_secs_f64(), None);
    row.status = STATUS_ERROR.to_string();
    row.t_end_s = 0.0;
    row
}

/// Contents of an existing results file.
#[derive(Debug, Clone, Default)]
pub struct ResultsFile {
    /// Settings from the header (None for an empty file).
    pub settings: Option<Settings>,
    /// Complete rows in file order (an extended map has a later row for each continued point:
    /// see [`latest`]).
    pub rows: Vec<MapRow>,
    /// Byte length of the complete part (a truncated last line starts here).
    pub good_len: u64,
    /// Whether the file ended in an incomplete line.
    pub truncated: bool,
    /// Format version of the header (0 for an empty file).
    pub version: u32,
    /// The study configuration of the header (a study results file), as JSON.
    pub study: Option<serde_json::Value>,
    /// The predictor of the header (a predicted map, [`crate::predictor`]), as JSON.
    pub predictor: Option<serde_json::Value>,
}

pub(crate) fn io_err(path: &Path, source: std::io::Error) -> Error {
    Error::Io { path: path.display().to_string(), source }
}

impl ResultsFile {
    /// The header line as read (version, settings and, for a study, its configuration) as JSON
    /// text; None for a file without a header.
    pub fn header_json(&self) -> Option<String> {
        let s = self.settings.as_ref()?;
        Some(serde_json::to_string(&Header { beamslider_map: self.version, settings: s.clone(), study: self.study.clone(), predictor: self.predictor.clone() }).expect("header serialises"))
    }
}

/// Read a results file. Only lines ending in a newline count; an incomplete last line (a run
/// killed while writing) is reported as `truncated` and ignored; a complete line that is not a
/// row (or the header, on line 1) is an error naming the line.
pub fn read_results(path: &Path) -> Result<ResultsFile> {
    let f = File::open(path).map_err(|e| io_err(path, e))?;
    let mut r = BufReader::new(f);
    let mut out = ResultsFile::default();
    let mut line = String::new();
    let mut lineno = 0;
    let mut pending_bad: Option<usize> = None;
    loop {
        line.clear();
        let n = r.read_line(&mut line).map_err(|e| io_err(path, e))?;
        if n == 0 {
            break;
        }
        lineno += 1;
        if let Some(bad) = pending_bad {
            return Err(Error::invalid("results file", format!("{}:{bad}", path.display()), "a line in the middle of the file is not a complete result row"));
        }
        if !line.ends_with('\n') {
            out.truncated = true;
            break;
        }
        let text = line.trim_end();
        let ok = if lineno == 1 {
            // The version first: another version may have other settings.
            if let Some(v) = serde_json::from_str::<serde_json::Value>(text).ok().and_then(|v| v.get("beamslider_map").cloned())
                && !READABLE_VERSIONS.iter().any(|r| v == serde_json::json!(r))
            {
                return Err(Error::invalid("results file", path.display(), &format!("format version {v} (this build reads {FORMAT_VERSION})")));
            }
            match serde_json::from_str::<Header>(text) {
                Ok(h) => {
                    if !READABLE_VERSIONS.contains(&h.beamslider_map) {
                        return Err(Error::invalid("results file", path.display(), &format!("format version {} (this build reads {FORMAT_VERSION})", h.beamslider_map)));
                    }
                    out.version = h.beamslider_map;
                    out.settings = Some(h.settings);
                    out.study = h.study;
                    out.predictor = h.predictor;
                    true
                }
                Err(_) => false,
            }
        } else if text.is_empty() {
            true
        } else {
            match serde_json::from_str::<MapRow>(text) {
                Ok(row) => {
                    out.rows.push(row);
                    true
                }
                Err(_) => false,
            }
        };
        if ok {
            out.good_len += n as u64;
        } else {
            pending_bad = Some(lineno);
        }
    }
    if let Some(bad) = pending_bad {
        // A kill while writing leaves a line without its newline (handled above); a complete
        // line that does not parse is damage, and cutting it off would lose data.
        return Err(Error::invalid("results file", format!("{}:{bad}", path.display()), "this line is not a result row (nor the header on line 1)"));
    }
    Ok(out)
}

/// The rows of a map's results file as they stand: a later row of the same point (an extended
/// run) replaces the earlier one.
pub fn latest(rows: Vec<MapRow>) -> Vec<MapRow> {
    let mut seen = HashSet::new();
    let mut rows: Vec<MapRow> = rows.into_iter().rev().filter(|r| seen.insert(r.key())).collect();
    rows.reverse();
    rows
}

/// Progress of a map: called after every finished point with (points done, points total, row).
pub type Progress<'a> = &'a (dyn Fn(usize, usize, &MapRow) + Sync);

/// Outcome of [`run_map`].
#[derive(Debug, Clone)]
pub struct MapOutcome {
    /// All rows of the grid present in the results (resumed and new), sorted by grid index.
    pub rows: Vec<MapRow>,
    /// Points skipped because they were already in the results file.
    pub resumed: usize,
    /// Points computed by this call (from rest or continued).
    pub computed: usize,
    /// Not-settled and undetermined points continued from their saved end states by this call.
    pub extended: usize,
    /// Whether the run was cancelled before all points were done.
    pub cancelled: bool,
}

impl MapOutcome {
    /// Rows whose run did not complete (status `left_beam`, `diverged` or `error`), by index.
    pub fn failures(&self) -> Vec<&MapRow> {
        self.rows.iter().filter(|r| r.status != Status::Completed.name()).collect()
    }
}

/// How to run a map.
#[derive(Debug, Clone, Default)]
pub struct MapRunOptions {
    /// Results file (JSON lines); `None` keeps the rows in memory only.
    pub out: Option<PathBuf>,
    /// Continue an existing results file: skip its points (otherwise an existing file is an error).
    pub resume: bool,
    /// Worker threads (None = rayon's default: one per core).
    pub threads: Option<usize>,
    /// Extend the map in `out` to `cfg.duration_s`: the results file must exist with the same
    /// settings but a shorter (or, when resuming an interrupted extension, the same) duration;
    /// its not-settled points continue from their end states, the others keep their rows.
    pub extend: bool,
}

/// Everything [`run_map`] checks before it computes or writes anything: the configuration, the
/// model (Δt against the highest mode) and the results file (exists without `resume`, written
/// with other settings, unreadable). Front ends call it before they write files of their own
/// (`map.toml`), so that a refused map overwrites nothing.
pub fn preflight(cfg: &MapConfig, opts: &MapRunOptions) -> Result<()> {
    cfg.validate()?;
    Model::new(cfg.effective_params())?;
    if opts.extend && opts.out.is_none() {
        return Err(Error::invalid("extend_to", cfg.duration_s, "needs the results file of the map to extend (out)"));
    }
    if let Some(path) = &opts.out {
        existing_results(cfg, opts, path, None)?;
    }
    Ok(())
}

/// The results file `path` of the map to run, read and checked (None when absent or empty): an
/// existing file needs `resume` or `extend` and the same settings ([`check_settings`]); `extend`
/// needs one.
fn existing_results(cfg: &MapConfig, opts: &MapRunOptions, path: &Path, predictor: Option<&serde_json::Value>) -> Result<Option<ResultsFile>> {
    let exists = path.exists() && std::fs::metadata(path).map(|m| m.len() > 0).unwrap_or(false);
    if exists && !opts.resume && !opts.extend {
        return Err(Error::invalid("out", path.display(), "the results file exists: resume it, or choose another output"));
    }
    if opts.extend && !exists {
        return Err(Error::invalid("extend_to", path.display(), "no results file to extend"));
    }
    if !exists {
        return Ok(None);
    }
    let old = read_results(path)?;
    check_settings(cfg, opts, path, &old, predictor)?;
    Ok(Some(old))
}

/// The settings of an existing results file against the map to run (resume: equal; extend:
/// equal but for a duration ≤ the new one, and end states saved for the not-settled points).
fn check_settings(cfg: &MapConfig, opts: &MapRunOptions, path: &Path, old: &ResultsFile, predictor: Option<&serde_json::Value>) -> Result<()> {
    let new = cfg.settings();
    if old.settings.is_some() && old.version != FORMAT_VERSION {
        let what = if opts.extend { "extend_to" } else { "resume" };
        return Err(Error::invalid(what, path.display(), &format!("the results file has format version {} (rows classified by older rules, no end states); start a new map", old.version)));
    }
    let Some(s) = &old.settings else {
        if opts.extend {
            return Err(Error::invalid("extend_to", path.display(), "the results file has no map to extend"));
        }
        return Ok(());
    };
    if opts.extend {
        let mut same = s.clone();
        same.duration_s = new.duration_s;
        if same != new {
            return Err(Error::invalid("extend_to", path.display(), "the results file was written with other settings (parameters, record_every or criteria); only the duration may change"));
        }
        if s.duration_s > new.duration_s {
            return Err(Error::invalid("extend_to", new.duration_s, &format!("must exceed the map's t_end ({} s)", s.duration_s)));
        }
        if let Some(r) = old.rows.iter().find(|r| matches!(r.behaviour, Behaviour::NotSettled | Behaviour::Undetermined) && r.status == Status::Completed.name() && r.end.is_none()) {
            return Err(Error::invalid("extend_to", path.display(), &format!("point #{} (f_ex = {} Hz, a_ex = {} m/s^2, s0 = {}) has no saved end state", r.index, r.f_ex_hz, r.a_ex_m_s2, r.s0)));
        }
        return Ok(());
    }
    if *s != new {
        return Err(Error::invalid("resume", path.display(), "the results file was written with other settings (parameters, duration, record_every or criteria); only the grid may change"));
    }
    if old.predictor.as_ref() != predictor {
        let what = match (&old.predictor, predictor) {
            (Some(_), None) => "the results file is a predicted map (reduced predictor), not FS runs",
            (None, Some(_)) => "the results file holds FS runs, not a predicted map",
            _ => "the results file was predicted with another drift law or predictor settings",
        };
        return Err(Error::invalid("resume", path.display(), what));
    }
    Ok(())
}

/// The results of a map being run: the rows kept from an existing results file, the jobs still
/// to do, and — with a results file — the file, locked for this process ([`ResultsLock`]: a
/// second writer fails at once naming the holder) and opened for appending (O_APPEND, one write
/// per row). Shared by the local runner ([`run_map`]) and front ends that run the jobs
/// elsewhere (a Dask cluster) and append the rows here.
#[derive(Debug)]
pub struct MapResults {
    file: Option<(File, PathBuf, ResultsLock)>,
    /// Rows of the grid so far: kept from the file, then appended.
    pub rows: Vec<MapRow>,
    /// Points still to compute (continuations first, then runs from rest).
    pub jobs: Vec<Job>,
    /// Points in the grid.
    pub total: usize,
    /// Points kept from the results file.
    pub resumed: usize,
    /// Not-settled points to be continued from their end states.
    pub extended: usize,
}

/// Open a results file for appending (O_APPEND: every row lands at the end in one write), after
/// cutting it to `good_len` (a torn last line from a killed writer; we hold the lock).
pub(crate) fn open_append(path: &Path, good_len: u64) -> Result<File> {
    OpenOptions::new().write(true).open(path).and_then(|f| f.set_len(good_len)).map_err(|e| io_err(path, e))?;
    OpenOptions::new().append(true).open(path).map_err(|e| io_err(path, e))
}

impl MapResults {
    /// Check the map (as [`preflight`]), take the results file's lock, cut off a torn last line,
    /// write the header of a new file and plan the jobs.
    pub fn open(cfg: &MapConfig, opts: &MapRunOptions) -> Result<MapResults> {
        MapResults::open_with(cfg, opts, None)
    }

    /// As [`MapResults::open`] for a map predicted by the reduced model ([`crate::predictor`]):
    /// the header also holds `predictor`, and a resumed file must hold the same one.
    pub fn open_predicted(cfg: &MapConfig, opts: &MapRunOptions, predictor: &serde_json::Value) -> Result<MapResults> {
        MapResults::open_with(cfg, opts, Some(predictor))
    }

    fn open_with(cfg: &MapConfig, opts: &MapRunOptions, predictor: Option<&serde_json::Value>) -> Result<MapResults> {
        cfg.validate()?;
        let points = cfg.points()?;
        let settings = cfg.settings();
        Model::new(cfg.effective_params())?;
        if opts.extend && opts.out.is_none() {
            return Err(Error::invalid("extend_to", cfg.duration_s, "needs the results file of the map to extend (out)"));
        }
        let mut existing: Vec<MapRow> = Vec::new();
        let file = match &opts.out {
            None => None,
            Some(path) => {
                if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                    std::fs::create_dir_all(dir).map_err(|e| io_err(dir, e))?;
                }
                let lock = ResultsLock::acquire(path)?;
                let old = existing_results(cfg, opts, path, predictor)?;
                let exists = old.is_some();
                if let Some(old) = old
                    && old.settings.as_ref().is_some_and(|s| *s != settings)
                {
                    // Extension: the header takes the new duration. Write the new file beside the
                    // old one and swap them, so that a kill loses nothing.
                    let tmp = path.with_extension("jsonl.extend-tmp");
                    let mut text = header_line_predictor(&settings, predictor);
                    text.push('\n');
                    for r in &latest(old.rows) {
                        text.push_str(&r.to_json());
                        text.push('\n');
                    }
                    std::fs::write(&tmp, text).map_err(|e| io_err(&tmp, e))?;
                    std::fs::rename(&tmp, path).map_err(|e| io_err(path, e))?;
                }
                let f = if exists {
                    let old = read_results(path)?;
                    let mut f = open_append(path, old.good_len)?;
                    if old.settings.is_none() {
                        write_line(&mut f, path, &header_line_predictor(&settings, predictor))?;
                    }
                    existing = latest(old.rows);
                    f
                } else {
                    let mut f = OpenOptions::new().create(true).truncate(true).write(true).open(path).map_err(|e| io_err(path, e))?;
                    write_line(&mut f, path, &header_line_predictor(&settings, predictor))?;
                    drop(f);
                    OpenOptions::new().append(true).open(path).map_err(|e| io_err(path, e))?
                };
                Some((f, path.clone(), lock))
            }
        };
        // Points already done (by inputs, not by index: the grid may have changed).
        let done_keys: HashSet<_> = existing.iter().map(MapRow::key).collect();
        let mut kept: Vec<MapRow> = Vec::new();
        let mut seen = HashSet::new();
        for p in &points {
            if done_keys.contains(&p.key())
                && seen.insert(p.key())
                && let Some(r) = existing.iter().find(|r| r.key() == p.key())
            {
                let mut r = r.clone();
                r.index = p.index;
                kept.push(r);
            }
        }
        // Not-settled and undetermined rows that end before the map's duration continue from their end states.
        let (cont, kept): (Vec<MapRow>, Vec<MapRow>) = kept.into_iter().partition(|r| r.continuable(cfg.duration_s));
        let extended = cont.len();
        let mut jobs: Vec<Job> = cont.into_iter().map(|r| Job::Continue(r.point(), Box::new(r))).collect();
        jobs.extend(points.iter().filter(|p| !done_keys.contains(&p.key())).map(|p| Job::Fresh(*p)));
        let resumed = kept.len();
        Ok(MapResults { file, rows: kept, jobs, total: points.len(), resumed, extended })
    }

    /// Append a finished row: one line, one write to the file opened with O_APPEND.
    pub fn append(&mut self, row: MapRow) -> Result<()> {
        if let Some((f, path, _)) = &mut self.file {
            write_line(f, path, &row.to_json())?;
        }
        self.rows.push(row);
        Ok(())
    }

    /// The outcome: all rows sorted by grid index (releases the lock).
    pub fn finish(self) -> MapOutcome {
        let mut rows = self.rows;
        rows.sort_by_key(|r| r.index);
        let computed = rows.len() - self.resumed;
        MapOutcome { cancelled: rows.len() < self.total, rows, resumed: self.resumed, computed, extended: self.extended }
    }
}

/// Run `jobs` in parallel (the core's batch runner, [`run_batch`]: `threads` workers or one per
/// core), handing each finished row to `on_row`; an error of `on_row` cancels the rest.
pub fn run_jobs(cfg: &MapConfig, jobs: &[Job], threads: Option<usize>, cancel: &AtomicBool, mut on_row: impl FnMut(MapRow) -> Result<()> + Send) -> Result<()> {
    let model = Model::new(cfg.effective_params())?;
    run_batch(jobs, threads, cancel, |job| Ok(run_point_guarded(&model, cfg, job, cancel)), |row: &MapRow| on_row(row.clone()))?;
    Ok(())
}

/// Run the grid of `cfg` in parallel, appending each finished point to the results file.
/// Setting `cancel` stops the map: points in flight are abandoned, finished ones are kept.
pub fn run_map(cfg: &MapConfig, opts: &MapRunOptions, cancel: &AtomicBool, progress: Progress<'_>) -> Result<MapOutcome> {
    let mut results = MapResults::open(cfg, opts)?;
    let jobs = std::mem::take(&mut results.jobs);
    let total = results.total;
    run_jobs(cfg, &jobs, opts.threads, cancel, |row| {
        results.append(row)?;
        if let Some(last) = results.rows.last() {
            progress(results.rows.len(), total, last);
        }
        Ok(())
    })?;
    Ok(results.finish())
}

/// The header line of a results file (without the newline); `study`: a study's configuration.
pub(crate) fn header_line_with(s: &Settings, study: Option<&serde_json::Value>) -> String {
    serde_json::to_string(&Header { beamslider_map: FORMAT_VERSION, settings: s.clone(), study: study.cloned(), predictor: None }).expect("header serialises")
}

fn header_line_predictor(s: &Settings, predictor: Option<&serde_json::Value>) -> String {
    serde_json::to_string(&Header { beamslider_map: FORMAT_VERSION, settings: s.clone(), study: None, predictor: predictor.cloned() }).expect("header serialises")
}

/// Append one line and flush it to the operating system.
pub(crate) fn write_line(f: &mut File, path: &Path, line: &str) -> Result<()> {
    let mut buf = String::with_capacity(line.len() + 1);
    buf.push_str(line);
    buf.push('\n');
    f.write_all(buf.as_bytes()).map_err(|e| io_err(path, e))?;
    f.flush().map_err(|e| io_err(path, e))
}

/// "t_end = 120 s", or for an extended map "t_end = 120 s (settled points kept from 60 s)".
fn t_end_text(rows: &[&MapRow]) -> String {
    let ok: Vec<f64> = rows.iter().filter(|r| r.status == Status::Completed.name() || r.status == crate::predictor::STATUS_PREDICTED).map(|r| r.t_end_s).collect();
    let hi = ok.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let lo = ok.iter().copied().fold(f64::INFINITY, f64::min);
    if ok.is_empty() {
        "t_end = -".into()
    } else if lo == hi {
        format!("t_end = {} s", round3(hi))
    } else {
        format!("t_end = {} s (settled points kept from {} s)", round3(hi), round3(lo))
    }
}

fn round3(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
}

/// The map as text: one row per a_ex (highest first, as in the paper's figure), one column per
/// f_ex, one letter per behaviour ([`Behaviour::letter`]); one block per s₀.
pub fn text_table(rows: &[MapRow]) -> String {
    use std::fmt::Write as _;
    let mut s0s: Vec<f64> = rows.iter().map(|r| r.s0).collect();
    s0s.sort_by(f64::total_cmp);
    s0s.dedup();
    let mut out = String::new();
    for s0 in s0s {
        let sub: Vec<&MapRow> = rows.iter().filter(|r| r.s0 == s0).collect();
        let mut fs: Vec<f64> = sub.iter().map(|r| r.f_ex_hz).collect();
        fs.sort_by(f64::total_cmp);
        fs.dedup();
        let mut as_: Vec<f64> = sub.iter().map(|r| r.a_ex_m_s2).collect();
        as_.sort_by(f64::total_cmp);
        as_.dedup();
        let _ = writeln!(
            out,
            "s0 = {s0}, {}; rows a_ex [m/s^2], columns f_ex [Hz]; I inactivity, T trivial adaption, S signature move, R relaxation oscillation, D self-damping, N not settled, ? undetermined, . not run",
            t_end_text(&sub)
        );
        let _ = write!(out, "{:>6} ", "a\\f");
        for f in &fs {
            let _ = write!(out, "{:>4}", format!("{f}"));
        }
        out.push('\n');
        for a in as_.iter().rev() {
            let _ = write!(out, "{:>6} ", format!("{a}"));
            for f in &fs {
                let c = sub.iter().find(|r| r.f_ex_hz == *f && r.a_ex_m_s2 == *a).map_or('.', |r| r.behaviour.letter());
                let _ = write!(out, "{c:>4}");
            }
            out.push('\n');
        }
    }
    out
}
