//! Behaviour classification of one free-slider run by its phases (MODEL.md §8; paper, section 4
//! and Figs. 6–9, 11–12) from its super-slow signals: the slider position s(t) and the
//! super-slow amplitude A(t) of the beam at the laser position, A = 1-s moving average of
//! |Hilbert(w(4L/7))| (MODEL.md §7), in units of the beam thickness h.
//!
//! # Coordinates: starts on either half and on either side of the final position
//!
//! The beam is symmetric about its centre: a run started on the far half (s₀ > ½) is classified
//! in the mirrored coordinate s′ = 1 − s, otherwise s′ = s, so that s′ = 0 is the nearer clamping
//! and ½ the centre; "towards the centre" means s′ increases, "towards the clamping" s′
//! decreases. No rule compares the final position with s₀ (the net travel s_final − s₀ is a
//! feature only): a start nearer the centre than the final position and one nearer the clamping
//! are classified alike.
//!
//! # Ingredients (defaults in brackets)
//!
//! - **Jumps** of A: rises / falls by at least [`Criteria::jump_abs_h`] (0.2 h) *and* by a
//!   factor [`Criteria::jump_ratio`] (2) within [`Criteria::jump_window_s`] (3 s), looked for
//!   after [`Criteria::jump_after_s`] (2 s, when the beam has built up its vibration from rest):
//!   the image, after the 1-s moving average, of a jump between the co-existing low and high
//!   branches of the super-slow manifold. Jumps of one direction closer than two windows are
//!   merged. Jumps split the run into **branch phases**: low before the first jump up, high after
//!   a jump up, low again after a jump down.
//! - **Direction of travel** of a phase: the change of s′ over it; more than
//!   [`Criteria::still_s`] (0.01 L = 1.4 mm) is travel towards the centre / the clamping.
//! - **Turning point** (s, t): the slider first moves towards the clamping by more than
//!   [`Criteria::turn_s`] (0.005), reaches its closest approach and comes back by more than
//!   [`Criteria::turn_s`] (a feature).
//! - **Steady state** (settled): over the final [`Criteria::steady_window_s`] (15 s) s varies by
//!   less than [`Criteria::steady_s`] (0.03) and A by less than [`Criteria::steady_rel`] (30 %) of
//!   its mean plus [`Criteria::steady_abs_h`] (0.02 h), *and* neither drifts over the final
//!   [`Criteria::steady_drift_window_s`] (30 s, the super-slow time scale: longer than the
//!   fluctuations of s on a settled high branch, ≈ 10 s): the least-squares straight line through
//!   s changes by less than [`Criteria::steady_drift_s`] (0.005 = 0.7 mm) across it, the one
//!   through A by less than [`Criteria::steady_trend_rel`] (10 %) of its mean plus
//!   [`Criteria::steady_trend_abs_h`] (0.005 h). The ranges alone let a slow steady drift pass
//!   (a slider still creeping on the super-slow scale at t_end). Final levels: high ≥ [`Criteria::high_h`]
//!   (0.3 h; the adapted states of the paper's map end at 0.45–1.3 h), low < [`Criteria::low_h`]
//!   (0.05 h: harmonic vibration, the upper contacts no longer lift off).
//!
//! # The behaviours, by their phases (paper, section 4)
//!
//! 1. **inactivity**: no travel, |s − s₀| ≤ [`Criteria::still_s`] during the whole run, and
//!    settled (a slider creeping away from s₀ at t_end is not settled).
//! 2. **relaxation oscillation**: recurring jump up / jump down — at least
//!    [`Criteria::relax_min_cycles`] (2) cycles of a jump up followed by a jump down, or at least
//!    two jumps down without a steady state at the end.
//! 3. **not settled** (its own outcome): none of the above and no steady state when the run ended;
//!    the row names the phase reached (branch, direction of travel, the behaviour it is a phase
//!    of). Running longer (maps: `extend_to`) decides it.
//! 4. steady, high final level, no jump down:
//!    - **signature move**: a low-branch phase moving towards the clamping (phase 1; at the edge
//!      of the range the slider may stick instead: travel towards the centre ≤ still_s), a jump
//!      up, a high-branch phase moving back towards the centre by more than turn_s (phase 2), a
//!      steady high level (phase 3);
//!    - **trivial adaption**: the high level reached without a jump by travelling (more than
//!      still_s) to the final position — towards the centre from a start nearer the clamping,
//!      and alike from the other side. A first dip towards the clamping is reported as a feature.
//! 5. steady, low final level: **self-damping** — the slider travelled to a position with very
//!    low, harmonic vibration (paper, section 1: "move to a certain position leading to low
//!    steady-state vibrations"). From the paper's map starts that position is nearer the clamping
//!    (Fig. 9: phase 1 towards the clamping, a transient jump up, on towards the clamping while the
//!    amplitude decays); a high branch lost on the way (a jump down, then the low branch towards
//!    the clamping) is allowed. The direction of the net travel from s₀ is a feature, not a
//!    criterion (starts on either side of the final position are classified alike).
//! 6. everything else is `undetermined`, with the reason: a failed run (left the beam, diverged),
//!    a final level between the thresholds, a high branch lost once and regained, a jump up
//!    after a low-branch phase towards the centre, a jump up without the move back, …

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
pub use crate::signal::envelope_stream::SuperSlow;

/// The behaviour types of MODEL.md §8.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, PartialOrd, Ord)]
#[serde(rename_all = "snake_case")]
pub enum Behaviour {
    /// The slider does not move.
    Inactivity,
    /// s moves monotonically towards the centre; the vibration rises and stays high.
    TrivialAdaption,
    /// Away from the centre on the low branch, jump up, back towards the centre, high steady state.
    SignatureMove,
    /// Recurrent back-and-forth of s with alternating high and low vibration.
    RelaxationOscillation,
    /// s keeps moving towards the clamping; very low steady vibration.
    SelfDamping,
    /// No steady state when the run ended (and no recurrent jumps): see the phase reached.
    NotSettled,
    /// None of the above could be decided (see [`Classification::reason`]).
    Undetermined,
}

impl Behaviour {
    /// All behaviours, in the order of the paper's map legend (undetermined last).
    pub const ALL: [Behaviour; 7] = [
        Behaviour::Inactivity,
        Behaviour::TrivialAdaption,
        Behaviour::SignatureMove,
        Behaviour::RelaxationOscillation,
        Behaviour::SelfDamping,
        Behaviour::NotSettled,
        Behaviour::Undetermined,
    ];

    /// snake_case name (`inactivity`, `trivial_adaption`, …) as written in results files.
    pub fn name(&self) -> &'static str {
        match self {
            Behaviour::Inactivity => "inactivity",
            Behaviour::TrivialAdaption => "trivial_adaption",
            Behaviour::SignatureMove => "signature_move",
            Behaviour::RelaxationOscillation => "relaxation_oscillation",
            Behaviour::SelfDamping => "self_damping",
            Behaviour::NotSettled => "not_settled",
            Behaviour::Undetermined => "undetermined",
        }
    }

    /// One letter for text maps: I, T, S, R, D (self-damping), N (not settled), ? (undetermined).
    pub fn letter(&self) -> char {
        match self {
            Behaviour::Inactivity => 'I',
            Behaviour::TrivialAdaption => 'T',
            Behaviour::SignatureMove => 'S',
            Behaviour::RelaxationOscillation => 'R',
            Behaviour::SelfDamping => 'D',
            Behaviour::NotSettled => 'N',
            Behaviour::Undetermined => '?',
        }
    }

    /// Parse a name as written by [`Behaviour::name`].
    pub fn parse(name: &str) -> Result<Behaviour> {
        Behaviour::ALL.into_iter().find(|b| b.name() == name).ok_or_else(|| {
            Error::invalid(
                "behaviour",
                name,
                "one of inactivity, trivial_adaption, signature_move, relaxation_oscillation, self_damping, not_settled, undetermined",
            )
        })
    }
}

impl std::fmt::Display for Behaviour {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Thresholds of the classification (see the module documentation). Amplitudes are in units of
/// the beam thickness h, positions in units of the free length L, times in seconds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Criteria {
    /// Largest excursion |s − s₀| of an inactive slider (0.01 L = 1.4 mm; an adapting slider
    /// travels 0.05–0.2 L).
    pub still_s: f64,
    /// Least travel towards the clamping and back that makes a turning point.
    pub turn_s: f64,
    /// Least rise / fall of A [h] that makes a jump.
    pub jump_abs_h: f64,
    /// Least ratio (high / low level) that makes a jump.
    pub jump_ratio: f64,
    /// Time over which a jump must happen [s] (the 1-s moving average spreads a jump over ≈ 1 s,
    /// and the beam's amplitude settles with the time constant 1/(D ω) ≈ 1.3 s).
    pub jump_window_s: f64,
    /// Jumps are looked for from this time on [s] (before, the beam builds up its vibration from
    /// rest: a rise, not a jump between branches).
    pub jump_after_s: f64,
    /// Length of the final window that decides the steady state and the final levels [s].
    pub steady_window_s: f64,
    /// Largest range of s in the final window at steady state.
    pub steady_s: f64,
    /// Largest range of A in the final window at steady state, relative to its mean.
    pub steady_rel: f64,
    /// Plus this absolute allowance [h].
    pub steady_abs_h: f64,
    /// Length of the final window over which s and A must not drift at steady state [s]
    /// (capped at the run's duration).
    pub steady_drift_window_s: f64,
    /// Largest change of s across the drift window along its least-squares line at steady state
    /// (0.005 L = 0.7 mm per 30 s: 1.4 × the largest drift of the paper's representative runs at
    /// 120 s, 0.0035 at (106 Hz, 10 m/s², s0 = 0.3); the 60-s runs of the paper's maps that
    /// later changed their label by drift drift ≥ 0.0056).
    pub steady_drift_s: f64,
    /// Largest change of A across the drift window along its least-squares line at steady
    /// state, relative to its mean (10 %: the representative runs change ≤ 2.1 % at 120 s; the
    /// drifting 60-s runs 16–80 %).
    pub steady_trend_rel: f64,
    /// Plus this absolute allowance [h] (the low, harmonic levels are 0.005–0.03 h).
    pub steady_trend_abs_h: f64,
    /// Final levels A_final ≥ this are high (successful adaption) [h].
    pub high_h: f64,
    /// Final levels A_final < this are low (self-damping) [h].
    pub low_h: f64,
    /// Jump-up / jump-down cycles that make a relaxation oscillation.
    pub relax_min_cycles: usize,
}

impl Criteria {
    /// Thresholds from TOML keys of [`Criteria`] (missing keys take their defaults); None: the defaults.
    pub fn from_toml_str(text: Option<&str>) -> Result<Self> {
        let read = |t: &str| toml::from_str(t).map_err(|e| Error::invalid("criteria", "(TOML)", e.to_string().trim_end()));
        text.map_or_else(|| Ok(Criteria::default()), read)?.validated()
    }

    /// The thresholds checked: ≥ 0 (∞ switches a rule off), the windows finite and > 0, `jump_ratio` ≥ 1, `low_h` ≤ `high_h`
    /// and `relax_min_cycles` ≥ 1 (each error names the key as `criteria.<key>`).
    pub fn validated(self) -> Result<Self> {
        let c = &self;
        let windows = [("jump_window_s", c.jump_window_s), ("steady_window_s", c.steady_window_s), ("steady_drift_window_s", c.steady_drift_window_s)];
        let others = [("still_s", c.still_s), ("turn_s", c.turn_s), ("jump_abs_h", c.jump_abs_h), ("jump_after_s", c.jump_after_s), ("steady_s", c.steady_s)];
        let more =
            [("steady_rel", c.steady_rel), ("steady_abs_h", c.steady_abs_h), ("steady_drift_s", c.steady_drift_s), ("steady_trend_rel", c.steady_trend_rel)];
        let levels = [("steady_trend_abs_h", c.steady_trend_abs_h), ("high_h", c.high_h), ("low_h", c.low_h)];
        let bad = |k: &str, v: f64, why: &str| Err(Error::invalid(&format!("criteria.{k}"), v, why));
        for (k, v) in windows {
            if !(v.is_finite() && v > 0.0) {
                return bad(k, v, "must be finite and > 0 (seconds)");
            }
        }
        for (k, v) in others.into_iter().chain(more).chain(levels) {
            if !(v >= 0.0) {
                return bad(k, v, "must be >= 0 (inf switches its rule off)");
            }
        }
        if !(c.jump_ratio >= 1.0) {
            return bad("jump_ratio", c.jump_ratio, "must be >= 1");
        }
        if c.low_h > c.high_h {
            return bad("low_h", c.low_h, &format!("must not exceed high_h = {}", c.high_h));
        }
        if c.relax_min_cycles == 0 {
            return bad("relax_min_cycles", 0.0, "must be >= 1");
        }
        Ok(self)
    }
}

impl Default for Criteria {
    fn default() -> Self {
        Criteria {
            still_s: 0.01,
            turn_s: 0.005,
            jump_abs_h: 0.2,
            jump_ratio: 2.0,
            jump_window_s: 3.0,
            jump_after_s: 2.0,
            steady_window_s: 15.0,
            steady_s: 0.03,
            steady_rel: 0.3,
            steady_abs_h: 0.02,
            steady_drift_window_s: 30.0,
            steady_drift_s: 0.005,
            steady_trend_rel: 0.1,
            steady_trend_abs_h: 0.005,
            high_h: 0.3,
            low_h: 0.05,
            relax_min_cycles: 2,
        }
    }
}

/// The decision and the features behind it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Classification {
    /// The behaviour.
    pub behaviour: Behaviour,
    /// Why (one sentence; for `undetermined` the reason no behaviour fits).
    pub reason: String,
    /// Initial slider position s₀.
    pub s_initial: f64,
    /// Mean s over the final window.
    pub s_final: f64,
    /// Mean A over the final window [h].
    pub amplitude_final_h: f64,
    /// Mean A over the first 2 s after the start transient (t₀ + 1 … 3 s) [h].
    pub amplitude_initial_h: f64,
    /// Largest A [h].
    pub amplitude_max_h: f64,
    /// Smallest and largest s over the run.
    pub s_min: f64,
    /// Largest s over the run.
    pub s_max: f64,
    /// Net slider travel s_final − s₀ (positive = towards larger s).
    pub net_travel: f64,
    /// Net travel towards the centre: c(s_final) − c(s₀), c(s) = min(s, 1 − s).
    pub travel_to_centre: f64,
    /// Turning point (s, t) — the closest approach to the clamping before the slider came back —
    /// or NaN when there is none.
    pub turn_s: f64,
    /// Time of the turning point [s] (NaN when none).
    pub turn_t_s: f64,
    /// Times of the jumps up of A [s].
    pub jump_up_t_s: Vec<f64>,
    /// Times of the jumps down of A [s].
    pub jump_down_t_s: Vec<f64>,
    /// Whether s and A are steady over the final window.
    pub steady: bool,
    /// The phase reached at the end of the run: `steady_high`, `steady_low`,
    /// `steady_intermediate`, `still` (inactivity), `cycling` (relaxation oscillation), or for a
    /// run that has not settled `<branch>_<travel>` with branch `low` / `high` (after the last
    /// jump, or by the level A ≥ high_h when there was none) and travel `towards_centre` / `towards_clamping` / `still` over the final
    /// window (see the reason for the behaviour it is a phase of).
    #[serde(default)]
    pub phase: String,
    /// Whether the behaviour is final (docs/model.md §8, "Settled"): the steady state reached
    /// (`steady`), or for a relaxation oscillation at least [`Criteria::relax_min_cycles`]
    /// cycles. False for `not_settled`, and for a trivial adaption, signature move or
    /// self-damping whose phases are complete but whose slider or amplitude still drifts at the
    /// end of the run (see `drift_s`, `drift_a_h`).
    #[serde(default)]
    pub settled: bool,
    /// Change of s across the final drift window ([`Criteria::steady_drift_window_s`]) along its
    /// least-squares line (positive = towards larger s).
    #[serde(default = "nan")]
    pub drift_s: f64,
    /// Change of A [h] across the final drift window along its least-squares line.
    #[serde(default = "nan")]
    pub drift_a_h: f64,
}

fn nan() -> f64 {
    f64::NAN
}

fn centre_distance(s: f64) -> f64 {
    s.min(1.0 - s)
}

fn mean(x: &[f64]) -> f64 {
    if x.is_empty() { f64::NAN } else { x.iter().sum::<f64>() / x.len() as f64 }
}

/// Change across the samples `x` (spaced uniformly) of their least-squares straight line:
/// slope · (n − 1) in units of the sample index.
fn fitted_change(x: &[f64]) -> f64 {
    let n = x.len();
    if n < 2 {
        return 0.0;
    }
    let ic = 0.5 * (n - 1) as f64;
    let xm = mean(x);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (i, &v) in x.iter().enumerate() {
        let d = i as f64 - ic;
        sxy += d * (v - xm);
        sxx += d * d;
    }
    sxy / sxx * (n - 1) as f64
}

fn range(x: &[f64]) -> (f64, f64) {
    x.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)))
}

/// Jump times of A: regions where A(t + τ) − A(t) exceeds the thresholds (up) or falls below
/// their negatives (down), τ = `jump_window_s`; one time per region, at its steepest rise / fall.
fn jumps(x: &SuperSlow, c: &Criteria) -> (Vec<f64>, Vec<f64>) {
    let a = &x.amplitude_h;
    let n = a.len();
    let k = ((c.jump_window_s / x.dt_s).round() as usize).max(1);
    let mut up = Vec::new();
    let mut down = Vec::new();
    if n <= k {
        return (up, down);
    }
    // Skip the start: the beam builds up its vibration from rest.
    let skip = ((c.jump_after_s / x.dt_s).round() as usize).min(n - k);
    // state: 0 none, 1 in an up region, -1 in a down region; (best value, index)
    let mut state = 0i8;
    let mut best = (0.0f64, 0usize);
    let close = |state: i8, best: (f64, usize), up: &mut Vec<f64>, down: &mut Vec<f64>| {
        let t = x.t(best.1) + 0.5 * k as f64 * x.dt_s;
        if state > 0 {
            up.push(t);
        } else if state < 0 {
            down.push(t);
        }
    };
    for i in skip..n - k {
        let (lo, hi) = (a[i], a[i + k]);
        let d = hi - lo;
        let now = if d >= c.jump_abs_h && hi >= c.jump_ratio * lo {
            1
        } else if -d >= c.jump_abs_h && lo >= c.jump_ratio * hi {
            -1
        } else {
            0
        };
        if now != state {
            close(state, best, &mut up, &mut down);
            state = now;
            best = (d.abs(), i);
        } else if now != 0 && d.abs() > best.0 {
            best = (d.abs(), i);
        }
    }
    close(state, best, &mut up, &mut down);
    // One jump per branch change: drop a jump that follows another of the same direction within
    // two jump windows with no jump of the other direction in between (a jump in two stages).
    let mut events: Vec<(f64, bool)> = up.iter().map(|&t| (t, true)).chain(down.iter().map(|&t| (t, false))).collect();
    events.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut kept: Vec<(f64, bool)> = Vec::with_capacity(events.len());
    for e in events {
        match kept.last() {
            Some(&(t, dir)) if dir == e.1 && e.0 - t < 2.0 * c.jump_window_s => {}
            _ => kept.push(e),
        }
    }
    let up = kept.iter().filter(|e| e.1).map(|e| e.0).collect();
    let down = kept.iter().filter(|e| !e.1).map(|e| e.0).collect();
    (up, down)
}

/// Classify one run's super-slow signals by its phases (see the module documentation).
pub fn classify(x: &SuperSlow, c: &Criteria) -> Result<Classification> {
    c.clone().validated()?;
    let n = x.s.len();
    if n != x.amplitude_h.len() {
        return Err(Error::invalid("amplitude_h", x.amplitude_h.len(), "s and A must have the same length"));
    }
    if n < 2 || !(x.dt_s > 0.0) {
        return Err(Error::invalid("s", n, "need at least two samples with dt_s > 0"));
    }
    if x.s.iter().chain(&x.amplitude_h).any(|v| !v.is_finite()) {
        return Err(Error::invalid("s", "non-finite", "all samples must be finite"));
    }
    let duration = (n - 1) as f64 * x.dt_s;
    let nw = (((c.steady_window_s / x.dt_s).round() as usize).max(1)).min(n);
    let (s_tail, a_tail) = (&x.s[n - nw..], &x.amplitude_h[n - nw..]);
    let s0 = x.s[0];
    let s_final = mean(s_tail);
    let a_final = mean(a_tail);
    let i1 = ((1.0 / x.dt_s).round() as usize).min(n - 1);
    let i3 = ((3.0 / x.dt_s).round() as usize).clamp(i1 + 1, n);
    let a_initial = mean(&x.amplitude_h[i1..i3]);
    let (s_min, s_max) = range(&x.s);
    let (_, a_max) = range(&x.amplitude_h);
    let (st_lo, st_hi) = range(s_tail);
    let (at_lo, at_hi) = range(a_tail);
    // Drift across the final drift window along the least-squares lines (s in L, A in h).
    let nd = (((c.steady_drift_window_s / x.dt_s).round() as usize).max(2)).min(n);
    let drift_s = fitted_change(&x.s[n - nd..]);
    let a_drift = &x.amplitude_h[n - nd..];
    let trend_a = fitted_change(a_drift);
    // The ranges of the final window hold: at most creeping (docs/classify.md, "Settled").
    let in_range = duration >= c.steady_window_s && st_hi - st_lo < c.steady_s && at_hi - at_lo < c.steady_rel * a_final + c.steady_abs_h;
    let steady = in_range && drift_s.abs() < c.steady_drift_s && trend_a.abs() < c.steady_trend_rel * mean(a_drift) + c.steady_trend_abs_h;
    let still = x.s.iter().all(|s| (s - s0).abs() <= c.still_s);

    // s′: distance from the nearer clamping of the start's half (mirrored on the far half).
    let mirrored = s0 > 0.5;
    let sp: Vec<f64> = x.s.iter().map(|&s| if mirrored { 1.0 - s } else { s }).collect();
    let sp0 = sp[0];
    let sp_final = mean(&sp[n - nw..]);
    let sp_at = |t: f64| sp[(((t - x.t0_s) / x.dt_s).round().max(0.0) as usize).min(n - 1)];

    // Turning point (a feature): the first closest approach to the clamping followed by a
    // return towards the centre, each by more than turn_s.
    let mut turn: Option<usize> = None;
    {
        let mut i_min = 0;
        for i in 1..n {
            if sp[i] < sp[i_min] {
                i_min = i;
            }
            if sp0 - sp[i_min] > c.turn_s && sp[i] - sp[i_min] > c.turn_s {
                turn = Some(i_min);
                break;
            }
        }
    }
    let (jump_up, jump_down) = jumps(x, c);
    let mut events: Vec<(f64, bool)> = jump_up.iter().map(|&t| (t, true)).chain(jump_down.iter().map(|&t| (t, false))).collect();
    events.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Jump-up → jump-down cycles.
    let mut cycles = 0;
    {
        let mut last_up: Option<f64> = None;
        for &(t, is_up) in &events {
            if is_up {
                last_up = Some(t);
            } else if last_up.take().is_some() {
                cycles += 1;
            }
        }
    }
    let travel_to_centre = centre_distance(s_final) - centre_distance(s0);
    let mut out = Classification {
        behaviour: Behaviour::Undetermined,
        reason: String::new(),
        s_initial: s0,
        s_final,
        amplitude_final_h: a_final,
        amplitude_initial_h: a_initial,
        amplitude_max_h: a_max,
        s_min,
        s_max,
        net_travel: s_final - s0,
        travel_to_centre,
        turn_s: turn.map_or(f64::NAN, |i| x.s[i]),
        turn_t_s: turn.map_or(f64::NAN, |i| x.t(i)),
        jump_up_t_s: jump_up.clone(),
        jump_down_t_s: jump_down.clone(),
        steady,
        phase: String::new(),
        settled: false,
        drift_s,
        drift_a_h: trend_a,
    };
    let travel = |d: f64| {
        if d >= c.steady_drift_s {
            "towards_centre"
        } else if d <= -c.steady_drift_s {
            "towards_clamping"
        } else {
            "still"
        }
    };
    // The behaviour by the level at the end and the phases (rules 4–6), whether or not the run
    // has settled; `steady_*` names the final phase of a settled run.
    let steady_word = if steady { "steady " } else { "" };
    let by_level = || -> (Behaviour, &'static str, String) {
        if a_final >= c.high_h {
            let dip = sp0 - sp.iter().copied().fold(f64::INFINITY, f64::min);
            if !jump_down.is_empty() {
                (
                    Behaviour::Undetermined,
                    "steady_high",
                    format!(
                        "high final level {a_final:.2} h, but the high branch was lost once (jump down at t = {:.1} s) and regained without recurrence",
                        jump_down[0]
                    ),
                )
            } else if let Some(&tj) = jump_up.first() {
                // Phase 1: the low branch up to the jump; phase 2: after the jump, back towards the
                // centre from the closest approach to the clamping around the jump.
                let ij = (((tj - x.t0_s) / x.dt_s).round().max(0.0) as usize).min(n - 1);
                let k = ((c.jump_window_s / x.dt_s).round() as usize).max(1);
                let d1 = sp_at(tj) - sp0;
                let low_after = sp[ij.saturating_sub(k)..].iter().copied().fold(f64::INFINITY, f64::min);
                let back = sp_final - low_after;
                let how = match turn {
                    Some(_) => format!("turning point at s = {:.3} (t = {:.1} s)", out.turn_s, out.turn_t_s),
                    None => "no turning point".into(),
                };
                if d1 > c.still_s {
                    (
                        Behaviour::Undetermined,
                        "steady_high",
                        format!(
                            "jump up at t = {tj:.1} s after a low-branch phase towards the centre ({d1:+.3}), high final level {a_final:.2} h: neither signature move (phase 1 towards the clamping) nor trivial adaption (no jump)"
                        ),
                    )
                } else if back <= c.turn_s {
                    (
                        Behaviour::Undetermined,
                        "steady_high",
                        format!("jump up at t = {tj:.1} s to a high final level {a_final:.2} h, but no high-branch phase back towards the centre ({back:+.3})"),
                    )
                } else {
                    let p1 =
                        if d1 < -c.still_s { format!("low branch towards the clamping ({d1:+.3})") } else { format!("low branch, slider stuck ({d1:+.3})") };
                    (
                        Behaviour::SignatureMove,
                        "steady_high",
                        format!(
                            "phases: {p1}, jump up at t = {tj:.1} s, {how}, high branch back towards the centre ({back:+.3}), {steady_word}high level {a_final:.2} h"
                        ),
                    )
                }
            } else if (sp_final - sp0).abs() > c.still_s {
                let side = if sp_final > sp0 { "towards the centre" } else { "towards the clamping, from a start nearer the centre than the final position" };
                let dip_note = if dip > c.still_s && sp_final > sp0 { format!(" after a first dip of {dip:.3} towards the clamping") } else { String::new() };
                (
                    Behaviour::TrivialAdaption,
                    "steady_high",
                    format!("high level {a_final:.2} h reached without a jump, travelling {side} ({:+.3}){dip_note}", sp_final - sp0),
                )
            } else {
                (Behaviour::Undetermined, "steady_high", format!("high final level {a_final:.2} h without a jump and without net travel"))
            }
        } else if a_final < c.low_h {
            let side = if sp_final < sp0 { "towards the clamping" } else { "towards the centre" };
            // The last phase: since the last jump (a lost high branch, or the transient jump up of
            // the paper's Fig. 9), reported as a feature.
            let last = match events.last() {
                Some(&(t, up)) => {
                    let d = sp_final - sp_at(t);
                    format!(
                        ", since the jump {} at t = {t:.1} s {} ({d:+.3})",
                        if up { "up" } else { "down" },
                        if d < 0.0 { "towards the clamping" } else { "towards the centre" }
                    )
                }
                None => String::new(),
            };
            (
                Behaviour::SelfDamping,
                "steady_low",
                format!("travelled {side} ({:+.3}{last}) to a {steady_word}low, harmonic level {a_final:.3} h", sp_final - sp0),
            )
        } else {
            (
                Behaviour::Undetermined,
                "steady_intermediate",
                format!("final level {a_final:.3} h between the low ({}) and high ({}) thresholds", c.low_h, c.high_h),
            )
        }
    };
    let (b, phase, reason, settled): (Behaviour, String, String, bool) = if still && steady {
        (Behaviour::Inactivity, "still".into(), format!("no travel: the slider stays within {} of s0", c.still_s), true)
    } else if cycles >= c.relax_min_cycles || (jump_down.len() >= 2 && !steady) {
        (
            Behaviour::RelaxationOscillation,
            "cycling".into(),
            format!("recurring jump up / jump down: {} cycles ({} up, {} down); s between {s_min:.3} and {s_max:.3}", cycles, jump_up.len(), jump_down.len()),
            cycles >= c.relax_min_cycles,
        )
    } else if steady {
        let (b, phase, reason) = by_level();
        (b, phase.into(), reason, true)
    } else {
        // Not settled: the phase reached when the run ended: branch (from the jumps, else the
        // level) and the travel over the final drift window.
        let (branch, since) = match events.last() {
            Some(&(t, true)) => ("high", format!(" after the jump up at t = {t:.1} s")),
            Some(&(t, false)) => ("low", format!(" after the jump down at t = {t:.1} s")),
            None => {
                let a_end = x.amplitude_h[n - 1];
                (if a_end >= c.high_h { "high" } else { "low" }, " (no jump)".to_string())
            }
        };
        // Travel over the final window: the change along the least-squares line of s′ (a drift
        // of steady_drift_s or more is travel; the end points alone are noisy).
        let d = if mirrored { -drift_s } else { drift_s };
        let tr = travel(d);
        let what = match tr {
            "towards_centre" => "moving towards the centre",
            "towards_clamping" => "moving towards the clamping",
            _ => "nearly still",
        };
        // The window's length to 0.1 s (19.6 s, not the 19.599999999999994 of 98 bins of 0.2 s).
        let window_s = ((nd - 1) as f64 * x.dt_s * 10.0).round() / 10.0;
        let drift_text = format!("{what} ({:+.4} in the last {window_s} s, A {:+.3} h)", drift_s, trend_a);
        // A run at its final level whose phases already make a behaviour keeps it, unsettled,
        // while it only creeps (the ranges of the final window hold, the drift rule fails) the
        // way of its last phase: a trivial adaption on towards its final position, a signature
        // move not back towards the clamping, a self-damping slider that has travelled to a low,
        // harmonic level.
        let (cand, _, cand_reason) = by_level();
        let keeps = in_range
            && match cand {
                Behaviour::TrivialAdaption => d * (sp_final - sp0).signum() > -c.steady_drift_s,
                Behaviour::SignatureMove => d > -c.steady_drift_s,
                Behaviour::SelfDamping => !still,
                _ => false,
            };
        if keeps {
            (cand, format!("{branch}_{tr}"), format!("{cand_reason}; not settled at t = {:.1} s: {drift_text}", x.t(n - 1)), false)
        } else {
            let of = match (branch, tr, events.last().map(|e| e.1)) {
                ("low", "towards_clamping", None) => "phase 1 of a signature move or of self-damping",
                ("high", "towards_centre", Some(true)) => "phase 2 of a signature move",
                ("high", "towards_clamping", Some(true)) => "phase 2 of self-damping (or a high branch not yet turned)",
                (_, "towards_centre", None) => "phase 1 of a trivial adaption",
                (_, "still", _) => "no drift of s, but s or the amplitude still varies",
                _ => "no phase of a single behaviour",
            };
            (
                Behaviour::NotSettled,
                format!("{branch}_{tr}"),
                format!("not settled at t = {:.1} s: {branch} {}{since}, {drift_text}: {of}", x.t(n - 1), if events.is_empty() { "level" } else { "branch" }),
                false,
            )
        }
    };
    out.behaviour = b;
    out.settled = settled;
    out.phase = phase;
    out.reason = reason;
    Ok(out)
}
