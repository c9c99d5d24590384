//! The configuration of an operating map (docs/model.md §8): parameters, grid, duration,
//! recording interval and classification thresholds, read from TOML.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::classify::Criteria;
use crate::dynamics::simulation::Excitation;
use crate::error::{Error, Result};
use crate::params::{Params, Valid};
use crate::results::{MapPoint, Settings};
pub use crate::signal::envelope_stream::DEFAULT_RECORD_EVERY;

/// Name of the results file inside the output folder.
pub const RESULTS_FILE: &str = "map.jsonl";
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
                    return Err(Error::invalid(
                        field,
                        format!("{{start={start}, stop={stop}, step={step}}}"),
                        &format!("gives {n:e} values; at most {MAX_POINTS}"),
                    ));
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
    /// The effective parameters as validated once ([`MapConfig::valid_params`]).
    #[serde(skip)]
    pub(crate) checked: Checked,
}

/// The validated effective parameters of a configuration, made at its first check and used while
/// they equal its effective parameters (a changed field is validated afresh). Not part of a
/// configuration's value: two configurations compare equal whatever their checks.
#[derive(Debug, Clone, Default)]
pub(crate) struct Checked(std::sync::OnceLock<Valid>);

impl PartialEq for Checked {
    fn eq(&self, _: &Checked) -> bool {
        true
    }
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
            checked: Checked::default(),
        }
    }
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

    /// A configuration of its parts (not checked: [`MapConfig::validate`]); `params` validated
    /// before, so that a map without a `dt_s` override validates no parameters again.
    pub fn of(duration_s: f64, dt_s: Option<f64>, record_every: usize, grid: Grid, params: &Valid, criteria: Criteria) -> MapConfig {
        let cfg = MapConfig { duration_s, dt_s, record_every, grid, params: params.get().clone(), criteria, checked: Checked::default() };
        if dt_s.is_none() {
            let _ = cfg.checked.0.set(params.clone());
        }
        cfg
    }

    /// The effective parameters ([`MapConfig::effective_params`]) validated (docs/model.md §1):
    /// once per configuration, what its runs take.
    pub fn valid_params(&self) -> Result<Valid> {
        let p = self.effective_params();
        match self.checked.0.get() {
            Some(v) if *v.get() == p => Ok(v.clone()),
            _ => {
                let v = Valid::new(p)?;
                let _ = self.checked.0.set(v.clone());
                Ok(v)
            }
        }
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
        self.criteria.clone().validated()?;
        let dt = self.valid_params()?.dt_s;
        crate::dynamics::simulation::step_count("duration_s", self.duration_s, dt)?;
        // The classification samples the run every record_every steps; its envelopes need a
        // sample at least every half bin (docs/model.md §8).
        let max_sample = 0.5 * crate::signal::envelope_stream::BIN_S;
        if self.record_every as f64 * dt > max_sample {
            return Err(Error::invalid(
                "record_every",
                self.record_every,
                &format!(
                    "samples every {:.3e} s at dt = {dt:e} s; the classification needs a sample at least every {max_sample} s (record_every <= {})",
                    self.record_every as f64 * dt,
                    (max_sample / dt).floor()
                ),
            ));
        }
        self.points()?;
        Ok(())
    }

    /// A point's run records more than its start state, as a run of `beamslider simulate` must
    /// (checked after the model, so that a time step too large is named first).
    pub fn check_records(&self) -> Result<()> {
        let dt = self.effective_params().dt_s;
        let steps = crate::dynamics::simulation::step_count("duration_s", self.duration_s, dt)?;
        if self.record_every as u64 > steps {
            return Err(Error::invalid(
                "duration_s",
                self.duration_s,
                &format!("{steps} time steps of dt = {dt:e} s, fewer than record_every = {}: a point would record only its start state", self.record_every),
            ));
        }
        Ok(())
    }

    /// The grid's axes' values: (f_ex [Hz], a_ex [m/s²], s₀).
    pub fn axes(&self) -> Result<(Vec<f64>, Vec<f64>, Vec<f64>)> {
        let g = &self.grid;
        Ok((g.f_ex_hz.values("grid.f_ex_hz")?, g.a_ex_m_s2.values("grid.a_ex_m_s2")?, g.s0.values("grid.s0")?))
    }

    /// All grid points (s₀ slowest, then a_ex, f_ex fastest).
    pub fn points(&self) -> Result<Vec<MapPoint>> {
        let (f, a, s) = self.axes()?;
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
