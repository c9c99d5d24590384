//! Layer (b) of docs/model.md §6.3: the slow flow ds/dt = V(s, β) on the super-slow manifold, a
//! hybrid system in the state (s, β), β ∈ {L, H}, and its classification.
//!
//! Coordinates: the half near the nearer clamping, s′ = min(s, 1 − s) ∈ [s_min, ½]; a start on
//! the far half (s₀ > ½) is integrated in s′ and mapped back (V(1 − s) = −V(s), docs/model.md §6.3).
//!
//! Each branch is given on nodes s₀ < s₁ < … covering the interval where it exists, with the
//! manifold amplitude Â and the drift velocity V at each node; V is piecewise linear between
//! the nodes. On a cell where V = v_i + b (s − s_i) the flow is integrated in closed form,
//! s(t) = z + (s_a − z) e^{b (t − t_a)} with z = s_i − v_i/b (or s_a + v_i (t − t_a) for b = 0), so
//! the cell boundaries (and the branch ends) are reached at exact times and a zero of V on the
//! way — necessarily with negative slope — is approached asymptotically (a stable equilibrium:
//! the dynamic equilibrium on H or a rest point). Events:
//!
//! - on L, reaching its lower end s_up (a fold): **jump up** to H;
//! - on H, reaching its upper end s_dn (a fold): **jump down** to L;
//! - an end that is not a fold (the clamping edge s_min, the centre ½): a **wall**, the slider
//!   stays there (at the centre V = 0 by symmetry);
//! - a zero of V approached: **equilibrium**.
//!
//! Start-branch rule (docs/model.md §6.3): on L if s₀′ lies where L exists (the coexistence interval or
//! the centre side), otherwise on the single branch H.
//!
//! The classification feeds (t, s(t), Â(t)) into the operating-map classifier
//! ([`crate::classify::classify`]) unchanged, through the same signal chain as the FS maps
//! ([`crate::signal::envelope_stream`]): samples every 0.2 s and the centred 1-s moving average of Â.

use serde::{Deserialize, Serialize};

use crate::classify::{Classification, Criteria, SuperSlow, classify};
use crate::error::{Error, Result};
use crate::signal::moving_average;
use crate::superslow::drift::BranchLabel;

/// One branch of the reduced model on its nodes (half coordinate, increasing s).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SlowBranch {
    /// Nodes s′, strictly increasing, covering the interval where the branch exists.
    pub s: Vec<f64>,
    /// Manifold amplitude Â at the nodes [h].
    pub amplitude_h: Vec<f64>,
    /// Drift velocity V at the nodes [1/s] (> 0: towards the centre).
    pub v_per_s: Vec<f64>,
}

impl SlowBranch {
    fn lo(&self) -> f64 {
        self.s[0]
    }
    fn hi(&self) -> f64 {
        self.s[self.s.len() - 1]
    }
    fn contains(&self, s: f64) -> bool {
        !self.s.is_empty() && s >= self.lo() - 1e-12 && s <= self.hi() + 1e-12
    }
    fn interp(&self, y: &[f64], s: f64) -> f64 {
        let n = self.s.len();
        if n == 1 {
            return y[0];
        }
        let s = s.clamp(self.lo(), self.hi());
        let i = match self.s.partition_point(|&x| x <= s) {
            0 => 0,
            k if k >= n => n - 2,
            k => k - 1,
        };
        let (a, b) = (self.s[i], self.s[i + 1]);
        let w = (s - a) / (b - a);
        y[i] + w * (y[i + 1] - y[i])
    }
    /// V at s′ (linear between nodes, clamped to the ends).
    pub fn v_at(&self, s: f64) -> f64 {
        self.interp(&self.v_per_s, s)
    }
    /// Â at s′.
    pub fn amplitude_at(&self, s: f64) -> f64 {
        self.interp(&self.amplitude_h, s)
    }
    fn validate(&self, name: &str) -> Result<()> {
        let n = self.s.len();
        if self.amplitude_h.len() != n || self.v_per_s.len() != n {
            return Err(Error::invalid(name, format!("{n} nodes"), "s, amplitude_h and v_per_s must have the same length"));
        }
        if self.s.iter().chain(&self.amplitude_h).chain(&self.v_per_s).any(|v| !v.is_finite()) {
            return Err(Error::invalid(name, "non-finite", "all node values must be finite"));
        }
        if self.s.windows(2).any(|w| !(w[1] > w[0])) {
            return Err(Error::invalid(name, "s", "nodes must be strictly increasing"));
        }
        Ok(())
    }
}

/// The reduced model of one operating point: both branches with Â and V, and which branch ends
/// are folds.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SlowModel {
    /// Low branch L (continuous with the centre); empty if it does not exist.
    pub low: SlowBranch,
    /// High branch H (continuous with the clamping); empty if it does not exist.
    pub high: SlowBranch,
    /// The lower end of L is a fold (jump up there): s_up = low.s[0].
    pub low_ends_in_fold: bool,
    /// The upper end of H is a fold (jump down there): s_dn = high.s[last].
    pub high_ends_in_fold: bool,
}

impl SlowModel {
    /// Jump-up position (lower end of L when it is a fold).
    pub fn s_up(&self) -> Option<f64> {
        (self.low_ends_in_fold && !self.low.s.is_empty()).then(|| self.low.lo())
    }
    /// Jump-down position (upper end of H when it is a fold).
    pub fn s_dn(&self) -> Option<f64> {
        (self.high_ends_in_fold && !self.high.s.is_empty()).then(|| self.high.hi())
    }
    fn branch(&self, b: BranchLabel) -> &SlowBranch {
        match b {
            BranchLabel::L => &self.low,
            BranchLabel::H => &self.high,
        }
    }
    /// Check the nodes; at least one branch must exist, the nodes must lie in (0, ½].
    pub fn validate(&self) -> Result<()> {
        self.low.validate("low")?;
        self.high.validate("high")?;
        if self.low.s.is_empty() && self.high.s.is_empty() {
            return Err(Error::invalid("manifold", "empty", "at least one branch must have nodes"));
        }
        for b in [&self.low, &self.high] {
            if !b.s.is_empty() && !(b.lo() > 0.0 && b.hi() <= 0.5 + 1e-12) {
                return Err(Error::invalid("manifold", format!("[{}, {}]", b.lo(), b.hi()), "branch nodes must lie in (0, 0.5]"));
            }
        }
        Ok(())
    }
}

/// Settings of [`slow_flow`].
#[derive(Debug, Clone, PartialEq)]
pub struct SlowFlowOptions {
    /// End time [s] (default 120 s, as the maps of docs/model.md §8).
    pub t_end_s: f64,
    /// Output sample spacing [s] (the FS maps' bin length, 0.2 s).
    pub dt_out_s: f64,
    /// Moving-average window applied to Â before classification [s] (1 s as for FS runs).
    pub smooth_s: f64,
    /// Classification thresholds.
    pub criteria: Criteria,
    /// Cap on events (jumps) before the flow is stopped with a warning.
    pub max_events: usize,
    /// Build-up time [s]: a run from rest needs a few envelope time constants before the beam
    /// vibrates on the manifold; until then Â(t) is the manifold's Â times (1 − e^{−3t/t_b}) and s
    /// stays at s₀ (or drifts, with `build_up_drift`) (default 0: the flow starts on the manifold).
    pub build_up_s: f64,
    /// During the build-up the slider already drifts (as PCS and FS runs from rest show), but a
    /// jump at a fold waits until the envelope has built up (t ≥ `build_up_s`): the slider rests
    /// at the fold until then. Default false: s stays at s₀ during the build-up.
    pub build_up_drift: bool,
}

impl Default for SlowFlowOptions {
    fn default() -> Self {
        SlowFlowOptions {
            t_end_s: 120.0,
            dt_out_s: 0.2,
            smooth_s: 1.0,
            criteria: Criteria::default(),
            max_events: 100_000,
            build_up_s: 0.0,
            build_up_drift: false,
        }
    }
}

/// Kind of slow-flow event.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EventKind {
    /// Jump from L to H at s_up.
    JumpUp,
    /// Jump from H to L at s_dn.
    JumpDown,
    /// A stable zero of V is approached (time: when its cell was entered).
    Equilibrium,
    /// A branch end that is not a fold was reached (clamping edge or centre).
    Wall,
}

/// One event of the slow flow.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// What happened.
    pub kind: EventKind,
    /// When [s].
    pub t_s: f64,
    /// Where (global s; for an equilibrium the zero of V).
    pub s: f64,
}

/// Result of [`slow_flow`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Prediction {
    /// Sample times [s] (0, dt_out, …, ≤ t_end).
    pub t_s: Vec<f64>,
    /// s(t) (global coordinate).
    pub s: Vec<f64>,
    /// Â(t) read from the manifold on the current branch [h] (not smoothed).
    pub amplitude_h: Vec<f64>,
    /// Branch at each sample.
    pub branch: Vec<BranchLabel>,
    /// Events in time order.
    pub events: Vec<Event>,
    /// s at t_end.
    pub s_final: f64,
    /// Â at t_end [h].
    pub amplitude_final_h: f64,
    /// Branch at t_end.
    pub branch_final: BranchLabel,
    /// Start branch.
    pub branch_initial: BranchLabel,
    /// The classifier's decision on (t, s, smoothed Â).
    pub classification: Classification,
    /// Anything unusual (degenerate cycles, event cap, a jump onto a missing branch).
    pub warnings: Vec<String>,
}

/// A piece of trajectory on one branch: s(t) = z + (s_a − z) e^{b (t − t_a)} (b ≠ 0) or
/// s_a + v (t − t_a) (b = 0; v = 0 for rest).
#[derive(Debug, Clone, Copy)]
struct Segment {
    t_a: f64,
    t_b: f64,
    s_a: f64,
    b: f64,
    z: f64,
    v: f64,
    branch: BranchLabel,
}

impl Segment {
    fn at(&self, t: f64) -> f64 {
        let dt = t - self.t_a;
        if self.b == 0.0 { self.s_a + self.v * dt } else { self.z + (self.s_a - self.z) * (self.b * dt).exp() }
    }
}

const V_ZERO: f64 = 1e-14;

/// Integrate the slow flow from s₀ (global coordinate, within [s_min, 1 − s_min] of the model's
/// nodes) to `opts.t_end_s` and classify it (see the module documentation).
pub fn slow_flow(model: &SlowModel, s0: f64, opts: &SlowFlowOptions) -> Result<Prediction> {
    model.validate()?;
    if !(opts.t_end_s.is_finite() && opts.t_end_s > 0.0 && opts.t_end_s <= 1e6) {
        return Err(Error::invalid("t_end_s", opts.t_end_s, "must lie in (0, 1e6]"));
    }
    if !(opts.dt_out_s.is_finite() && opts.dt_out_s > 0.0 && opts.t_end_s / opts.dt_out_s <= 1e7) {
        return Err(Error::invalid("dt_out_s", opts.dt_out_s, "must be > 0 with at most 1e7 samples"));
    }
    if !(opts.build_up_s.is_finite() && opts.build_up_s >= 0.0) {
        return Err(Error::invalid("build_up_s", opts.build_up_s, "must be finite and >= 0"));
    }
    if !(opts.smooth_s.is_finite() && opts.smooth_s >= 0.0) {
        return Err(Error::invalid("smooth_s", opts.smooth_s, "must be finite and >= 0"));
    }
    let mirrored = s0 > 0.5;
    let sp0 = if mirrored { 1.0 - s0 } else { s0 };
    let lo_all = [&model.low, &model.high].iter().filter(|b| !b.s.is_empty()).map(|b| b.lo()).fold(f64::INFINITY, f64::min);
    if !(s0.is_finite() && sp0 >= lo_all - 1e-12) {
        return Err(Error::invalid("s0", s0, &format!("must lie on the modelled range [{lo_all:.4}, {:.4}]", 1.0 - lo_all)));
    }
    let glob = |x: f64| if mirrored { 1.0 - x } else { x };
    // Start-branch rule (docs/model.md §6.3).
    let start = if model.low.contains(sp0) {
        BranchLabel::L
    } else if model.high.contains(sp0) {
        BranchLabel::H
    } else {
        return Err(Error::invalid("s0", s0, "no branch of the manifold exists there (a gap between the branches)"));
    };
    let mut warnings = Vec::new();
    let mut events: Vec<Event> = Vec::new();
    let mut segs: Vec<Segment> = Vec::new();
    let t_end = opts.t_end_s;
    let t_b = opts.build_up_s.min(t_end);
    let (mut t, mut s, mut beta) = (if opts.build_up_drift { 0.0 } else { t_b }, sp0, start);
    if t_b > 0.0 && !opts.build_up_drift {
        segs.push(Segment { t_a: 0.0, t_b, s_a: sp0, b: 0.0, z: sp0, v: 0.0, branch: start });
    }
    let mut zero_time_events = 0usize;
    let rest = |t: f64, s: f64, beta: BranchLabel| Segment { t_a: t, t_b: t_end, s_a: s, b: 0.0, z: s, v: 0.0, branch: beta };
    while t < t_end {
        if events.len() >= opts.max_events {
            warnings.push(format!("stopped after {} events (max_events)", opts.max_events));
            segs.push(rest(t, s, beta));
            break;
        }
        let br = model.branch(beta);
        let v = br.v_at(s);
        if v.abs() <= V_ZERO {
            segs.push(rest(t, s, beta));
            break;
        }
        let up = v > 0.0;
        let at_end = if up { s >= br.hi() - 1e-13 } else { s <= br.lo() + 1e-13 };
        if at_end {
            let fold = match (beta, up) {
                (BranchLabel::L, false) => model.low_ends_in_fold,
                (BranchLabel::H, true) => model.high_ends_in_fold,
                _ => false,
            };
            if !fold {
                events.push(Event { kind: EventKind::Wall, t_s: t, s: glob(s) });
                segs.push(rest(t, s, beta));
                break;
            }
            if t < t_b {
                // The envelope is still building up: the jump waits at the fold.
                segs.push(Segment { t_a: t, t_b, s_a: s, b: 0.0, z: s, v: 0.0, branch: beta });
                t = t_b;
                continue;
            }
            let (kind, to) = if beta == BranchLabel::L { (EventKind::JumpUp, BranchLabel::H) } else { (EventKind::JumpDown, BranchLabel::L) };
            events.push(Event { kind, t_s: t, s: glob(s) });
            if !model.branch(to).contains(s) {
                warnings.push(format!(
                    "{} at s = {:.4}: the other branch does not exist there; the slider stays",
                    if kind == EventKind::JumpUp { "jump up" } else { "jump down" },
                    glob(s)
                ));
                segs.push(rest(t, s, beta));
                break;
            }
            let last_t = events.iter().rev().nth(1).map(|e| e.t_s);
            if last_t == Some(t) {
                zero_time_events += 1;
                if zero_time_events >= 2 {
                    warnings.push(format!("degenerate jump cycle at s = {:.4} (both folds at the same s); the slider stays", glob(s)));
                    segs.push(rest(t, s, to));
                    break;
                }
            } else {
                zero_time_events = 0;
            }
            beta = to;
            s = s.clamp(model.branch(to).lo(), model.branch(to).hi());
            continue;
        }
        // The cell in the direction of motion.
        let n = br.s.len();
        let i = if up { br.s.partition_point(|&x| x <= s).saturating_sub(1).min(n - 2) } else { br.s.partition_point(|&x| x < s).saturating_sub(1).min(n - 2) };
        let (sa, sb) = (br.s[i], br.s[i + 1]);
        let (va, vb) = (br.v_per_s[i], br.v_per_s[i + 1]);
        let b = (vb - va) / (sb - sa);
        let x = if up { sb } else { sa };
        let vx = br.v_at(x);
        let (seg_b, z) = if b.abs() * (sb - sa) <= 1e-12 * v.abs().max(V_ZERO) { (0.0, s) } else { (b, sa - va / b) };
        if vx * v <= 0.0 {
            // A zero of V between s and x: approached asymptotically (stable: V changes sign
            // against the motion).
            let zz = if seg_b == 0.0 { x } else { z };
            events.push(Event { kind: EventKind::Equilibrium, t_s: t, s: glob(zz) });
            if seg_b == 0.0 {
                // V ≡ 0 only at x (constant-V cell cannot change sign): reach it and stay.
                let dt = (x - s) / v;
                segs.push(Segment { t_a: t, t_b: (t + dt).min(t_end), s_a: s, b: 0.0, z: s, v, branch: beta });
                t += dt;
                s = x;
                if t < t_end {
                    segs.push(rest(t, s, beta));
                }
            } else {
                segs.push(Segment { t_a: t, t_b: t_end, s_a: s, b: seg_b, z, v, branch: beta });
            }
            break;
        }
        let dt = if seg_b == 0.0 { (x - s) / v } else { ((x - z) / (s - z)).ln() / seg_b };
        let dt = if dt.is_finite() && dt >= 0.0 { dt } else { 0.0 };
        if t + dt >= t_end {
            segs.push(Segment { t_a: t, t_b: t_end, s_a: s, b: seg_b, z, v, branch: beta });
            break;
        }
        segs.push(Segment { t_a: t, t_b: t + dt, s_a: s, b: seg_b, z, v, branch: beta });
        t += dt;
        s = x;
    }
    if segs.is_empty() {
        segs.push(rest(t_end, s, beta));
    }
    // Sample.
    let n_out = (t_end / opts.dt_out_s + 1e-9).floor() as usize + 1;
    let mut ts = Vec::with_capacity(n_out);
    let mut ss = Vec::with_capacity(n_out);
    let mut aa = Vec::with_capacity(n_out);
    let mut bb = Vec::with_capacity(n_out);
    let mut k = 0;
    for j in 0..n_out {
        let tj = j as f64 * opts.dt_out_s;
        while k + 1 < segs.len() && tj > segs[k].t_b {
            k += 1;
        }
        let seg = &segs[k];
        let br = model.branch(seg.branch);
        let sj = seg.at(tj.clamp(seg.t_a, seg.t_b)).clamp(br.lo(), br.hi());
        ts.push(tj);
        ss.push(glob(sj));
        let ramp = if tj < t_b { 1.0 - (-3.0 * tj / t_b).exp() } else { 1.0 };
        aa.push(ramp * br.amplitude_at(sj));
        bb.push(seg.branch);
    }
    let last = segs[segs.len() - 1];
    let br = model.branch(last.branch);
    let s_end = last.at(t_end).clamp(br.lo(), br.hi());
    let win = ((opts.smooth_s / opts.dt_out_s).round() as usize).max(1);
    let signals = SuperSlow { t0_s: 0.0, dt_s: opts.dt_out_s, s: ss.clone(), amplitude_h: moving_average(&aa, win) };
    let classification = classify(&signals, &opts.criteria)?;
    Ok(Prediction {
        t_s: ts,
        s: ss,
        amplitude_h: aa,
        branch: bb,
        events,
        s_final: glob(s_end),
        amplitude_final_h: br.amplitude_at(s_end),
        branch_final: last.branch,
        branch_initial: start,
        classification,
        warnings,
    })
}
