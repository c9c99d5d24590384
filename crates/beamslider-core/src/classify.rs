//! Behaviour classification of one free-slider run (MODEL.md §8; paper, section 4 and Fig. 11)
//! from its super-slow signals: the slider position s(t) and the super-slow amplitude A(t) of
//! the beam at the laser position, A = 1-s moving average of |Hilbert(w(4L/7))| (MODEL.md §7),
//! measured in units of the beam thickness h.
//!
//! # Criteria
//!
//! Directions are taken relative to the beam's centre s = ½ (the anti-node of the first mode):
//! the *distance from the clamping* is c(s) = min(s, 1 − s), so "towards the centre" means c
//! increases and "towards the clamping" means c decreases (the beam is symmetric, so runs started
//! on either half are treated alike). Final levels come from the run's last
//! [`Criteria::steady_window_s`] = 15 s (the *final window*). Defaults in brackets.
//!
//! - **Jumps** of A: rises / falls by at least [`Criteria::jump_abs_h`] (0.2 h) *and* by a
//!   factor [`Criteria::jump_ratio`] (2) within [`Criteria::jump_window_s`] (3 s), looked for
//!   after [`Criteria::jump_after_s`] (2 s, when the beam has built up its vibration from rest).
//!   This is the image, after the 1-s moving average, of a jump between the co-existing low and
//!   high branches of the super-slow manifold (instantaneous on the super-slow time scale; the
//!   beam's amplitude settles with 1/(Dω) ≈ 1.3 s). A gradual rise along one branch while the
//!   slider travels is not a jump. Jumps of one direction closer than two windows are merged.
//! - **Turning point** (s, t): the slider first moves towards the clamping by more than
//!   [`Criteria::turn_s`] (0.005), reaches its closest approach to the clamping and then comes
//!   back towards the centre by more than [`Criteria::turn_s`].
//! - **Steady state**: over the final window s varies by less than [`Criteria::steady_s`] (0.03)
//!   and A by less than [`Criteria::steady_rel`] (30 %) of its mean plus
//!   [`Criteria::steady_abs_h`] (0.02 h).
//!
//! Decision, in this order:
//!
//! 1. **inactivity**: |s − s₀| ≤ [`Criteria::still_s`] (0.01 L = 1.4 mm) during the whole run —
//!    the slider does not move (an adapting slider travels 0.05–0.2 L).
//! 2. **relaxation oscillation**: at least [`Criteria::relax_min_cycles`] (2) cycles of a jump up
//!    followed by a jump down, or at least two jumps down without a steady state at the end — the
//!    high branch ends with a jump down and the cycle repeats (the super-slow back-and-forth of s
//!    with alternating high and low vibration).
//! 3. no steady state → `undetermined`.
//! 4. high final level, A_final ≥ [`Criteria::high_h`] (0.3 h; the adapted states of the paper's
//!    map end at 0.45–1.3 h), with the slider ending nearer the centre than s₀ and no jump down:
//!    - **signature move** if A jumped up: phase 1 on the low branch (usually moving towards the
//!      clamping: the turning point; at the edge of the range the slider may stick instead), the
//!      jump up, phase 2 back towards the centre on the high branch, phase 3 steady;
//!    - **trivial adaption** if there was no jump and the slider moved monotonically towards the
//!      centre (first dip towards the clamping ≤ [`Criteria::still_s`]) while the vibration rose.
//! 5. low final level, A_final < [`Criteria::low_h`] (0.05 h: very low, harmonic vibration, the
//!    upper contacts no longer lift off; the paper's self-damping ends at ≈ 0.01–0.02 h), with the
//!    slider ending nearer the clamping than s₀ by more than [`Criteria::still_s`]: **self-damping**
//!    (a transient jump up on the way is allowed, as in the paper's Fig. 9).
//! 6. everything else is `undetermined`, with the reason: a failed run (left the beam, diverged),
//!    a final level between the thresholds, a high branch lost once and regained, a high final
//!    level nearer the clamping, a low final level without travel towards the clamping, …

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::signal::envelope;

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
    /// None of the above could be decided (see [`Classification::reason`]).
    Undetermined,
}

impl Behaviour {
    /// All behaviours, in the order of the paper's map legend (undetermined last).
    pub const ALL: [Behaviour; 6] = [
        Behaviour::Inactivity,
        Behaviour::TrivialAdaption,
        Behaviour::SignatureMove,
        Behaviour::RelaxationOscillation,
        Behaviour::SelfDamping,
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
            Behaviour::Undetermined => "undetermined",
        }
    }

    /// One letter for text maps: I, T, S, R, D (self-damping), ? (undetermined).
    pub fn letter(&self) -> char {
        match self {
            Behaviour::Inactivity => 'I',
            Behaviour::TrivialAdaption => 'T',
            Behaviour::SignatureMove => 'S',
            Behaviour::RelaxationOscillation => 'R',
            Behaviour::SelfDamping => 'D',
            Behaviour::Undetermined => '?',
        }
    }

    /// Parse a name as written by [`Behaviour::name`].
    pub fn parse(name: &str) -> Result<Behaviour> {
        Behaviour::ALL
            .into_iter()
            .find(|b| b.name() == name)
            .ok_or_else(|| Error::invalid("behaviour", name, "one of inactivity, trivial_adaption, signature_move, relaxation_oscillation, self_damping, undetermined"))
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
    /// Final levels A_final ≥ this are high (successful adaption) [h].
    pub high_h: f64,
    /// Final levels A_final < this are low (self-damping) [h].
    pub low_h: f64,
    /// Jump-up / jump-down cycles that make a relaxation oscillation.
    pub relax_min_cycles: usize,
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
            high_h: 0.3,
            low_h: 0.05,
            relax_min_cycles: 2,
        }
    }
}

/// The super-slow signals of one run, sampled uniformly.
#[derive(Debug, Clone, PartialEq)]
pub struct SuperSlow {
    /// Time of the first sample [s].
    pub t0_s: f64,
    /// Sample spacing [s].
    pub dt_s: f64,
    /// Slider position s = x_C/L.
    pub s: Vec<f64>,
    /// Super-slow amplitude of w(4L/7) in units of h.
    pub amplitude_h: Vec<f64>,
}

impl SuperSlow {
    /// From a recorded displacement w(4L/7) [m] and s, sampled every `dt_s`: A = 1-s (`window_s`)
    /// moving average of |Hilbert(w)|, divided by the thickness `h_m` (MODEL.md §7).
    pub fn from_displacement(t0_s: f64, dt_s: f64, w_m: &[f64], s: &[f64], h_m: f64, window_s: f64) -> Result<SuperSlow> {
        if w_m.len() != s.len() {
            return Err(Error::invalid("w", w_m.len(), "w and s must have the same length"));
        }
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(Error::invalid("dt_s", dt_s, "must be finite and > 0"));
        }
        let amplitude_h = envelope(w_m, dt_s, window_s).into_iter().map(|a| a / h_m).collect();
        Ok(SuperSlow { t0_s, dt_s, s: s.to_vec(), amplitude_h })
    }

    fn t(&self, i: usize) -> f64 {
        self.t0_s + i as f64 * self.dt_s
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
}

fn centre_distance(s: f64) -> f64 {
    s.min(1.0 - s)
}

fn mean(x: &[f64]) -> f64 {
    if x.is_empty() { f64::NAN } else { x.iter().sum::<f64>() / x.len() as f64 }
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

/// Classify one run's super-slow signals (see the module documentation for the criteria).
pub fn classify(x: &SuperSlow, c: &Criteria) -> Result<Classification> {
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
    let steady = duration >= c.steady_window_s
        && st_hi - st_lo < c.steady_s
        && at_hi - at_lo < c.steady_rel * a_final + c.steady_abs_h;
    let still = x.s.iter().all(|s| (s - s0).abs() <= c.still_s);

    // Turning point: closest approach to the clamping (smallest c) such that the slider first
    // moved towards the clamping by more than turn_s and afterwards came back by more than turn_s.
    let cd: Vec<f64> = x.s.iter().map(|&s| centre_distance(s)).collect();
    let c0 = cd[0];
    let mut turn: Option<usize> = None;
    {
        // running minimum of c; the first minimum followed by a rise > turn_s
        let mut i_min = 0;
        for i in 1..n {
            if cd[i] < cd[i_min] {
                i_min = i;
            }
            if c0 - cd[i_min] > c.turn_s && cd[i] - cd[i_min] > c.turn_s {
                turn = Some(i_min);
                break;
            }
        }
    }
    let (jump_up, jump_down) = jumps(x, c);
    // Jump-up → jump-down cycles.
    let mut cycles = 0;
    {
        let mut last_up: Option<f64> = None;
        let mut events: Vec<(f64, bool)> = jump_up.iter().map(|&t| (t, true)).chain(jump_down.iter().map(|&t| (t, false))).collect();
        events.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (t, is_up) in events {
            if is_up {
                last_up = Some(t);
            } else if last_up.take().is_some() {
                cycles += 1;
            }
        }
    }
    let travel_to_centre = centre_distance(s_final) - c0;
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
    };
    let (b, reason) = if still {
        (Behaviour::Inactivity, format!("the slider stays within {} of s0 (|s - s0| <= {})", c.still_s, c.still_s))
    } else if cycles >= c.relax_min_cycles || (jump_down.len() >= 2 && !steady) {
        (
            Behaviour::RelaxationOscillation,
            format!("{} jump-up/jump-down cycles of the amplitude ({} up, {} down); s between {s_min:.3} and {s_max:.3}", cycles, jump_up.len(), jump_down.len()),
        )
    } else if !steady {
        (Behaviour::Undetermined, format!("no steady state in the last {} s and no recurrent jumps", c.steady_window_s))
    } else if a_final >= c.high_h {
        let dip = c0 - cd.iter().copied().fold(f64::INFINITY, f64::min);
        if !jump_down.is_empty() {
            (Behaviour::Undetermined, format!("high final level {a_final:.2} h, but the high branch was lost once (jump down at t = {:.1} s) and regained without recurrence", jump_down[0]))
        } else if travel_to_centre <= 0.0 {
            (Behaviour::Undetermined, format!("high final level {a_final:.2} h, but the slider ended nearer the clamping ({travel_to_centre:+.3})"))
        } else if !jump_up.is_empty() {
            let how = match turn {
                Some(_) => format!("turning point at s = {:.3} (t = {:.1} s)", out.turn_s, out.turn_t_s),
                None => "no turning point (the slider stuck on the low branch instead of moving towards the clamping)".into(),
            };
            (Behaviour::SignatureMove, format!("jump up from the low branch at t = {:.1} s, {how}, then towards the centre; high final level {a_final:.2} h", jump_up[0]))
        } else if dip <= c.still_s {
            (Behaviour::TrivialAdaption, format!("moves towards the centre ({travel_to_centre:+.3}) without a jump, monotonically within {} (first dip {dip:.3}); high final level {a_final:.2} h", c.still_s))
        } else {
            (Behaviour::Undetermined, format!("high final level {a_final:.2} h without a jump, but the slider first moved {dip:.3} towards the clamping"))
        }
    } else if a_final < c.low_h {
        if travel_to_centre < -c.still_s {
            (Behaviour::SelfDamping, format!("moved towards the clamping ({travel_to_centre:+.3}) and stays there; low final level {a_final:.3} h"))
        } else {
            (Behaviour::Undetermined, format!("low final level {a_final:.3} h but the slider did not end nearer the clamping"))
        }
    } else {
        (Behaviour::Undetermined, format!("final level {a_final:.3} h between the low ({}) and high ({}) thresholds", c.low_h, c.high_h))
    };
    out.behaviour = b;
    out.reason = reason;
    Ok(out)
}
