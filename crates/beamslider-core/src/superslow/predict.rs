//! The reduced model of one operating point (docs/model.md §6.3: layer (a) + drift law + slow
//! flow + the map classifier) and a predicted operating map written through the map results
//! writer ([`crate::map::MapResults`]).
//!
//! * [`predict_point`] — nodes on each branch, V from the law, [`crate::superslow::slowflow::slow_flow`]
//!   and its classification (a map of them: [`super::predicted_map`]).
//!
//! Closed form: the manifold and the features (layer (a)). Fitted: V (the law's samples are PCS
//! drift tables of the training points).

use std::time::Instant;

use super::branch::HbManifold;
use super::continuation::hb_manifold;
use super::law::{DriftLaw, Features, MONO_NODES, beam_for, features_with};
pub use super::predict_options::{Drift, MapDrift, PredictArgs, PredictOptions, SDnRule, Source, TableDrift};
use super::predict_options::{dead_band, interp};
use super::slowflow::{Prediction, SlowBranch, SlowFlowOptions, SlowModel, slow_flow};
use crate::classify::Behaviour;
use crate::error::{Error, Result};
use crate::params::{Params, Valid};
use crate::physics::beam::Beam;

/// Largest change of the final s [–] under V ± `v_resolution` for which a prediction counts as
/// robust (the tolerance on the final s of a run; not applied to a relaxation
/// oscillation, whose final s is the cycle's phase at t_end).
pub const ROBUST_DS: f64 = 0.02;

/// Result of [`predict_point`].
#[derive(Debug, Clone, serde::Serialize)]
pub struct PointPrediction {
    /// The slow flow and its classification.
    pub flow: Prediction,
    /// Some node with lift-off lies outside the law's training range.
    pub extrapolated: bool,
    /// The reduced model (nodes, Â, V).
    pub model: SlowModel,
    /// Jump-up position used.
    pub s_up: Option<f64>,
    /// Where s_dn comes from: "hb" (the HB manifold's own fold), "law" (the law's forcing-ratio
    /// rule, used when the manifold has none) or "none".
    pub s_dn_source: &'static str,
    /// Jump-down position used (the HB manifold's own, else the law's).
    pub s_dn: Option<f64>,
    /// The law's monostability vote said: a single low branch ([`DriftLaw::monostable`]).
    pub monostable: bool,
    /// Wall times [s]: manifold, drift evaluation, slow flow, robustness check (two more slow flows).
    pub timings_s: [f64; 4],
    /// Whether the behaviour and the final s (within [`ROBUST_DS`]) stay the same when V is
    /// shifted by ± the law's `v_resolution` at every node that can move (Λ_g ≥ Λ_c); None when
    /// the law has no resolution or [`PredictOptions::robustness`] is off.
    pub robust: Option<bool>,
    /// The behaviours and final s under V − v_resolution and V + v_resolution (empty when
    /// `robust` is None).
    pub shifted: Vec<(Behaviour, f64)>,
    /// The features of layer (a) at the nodes of the low and the high branch (law drift and HB
    /// source; before a monostable point's single branch replaces them).
    pub features: [Vec<Features>; 2],
    /// The build-up time used [s].
    pub build_up_s: f64,
    /// Why the model differs from the one asked for (a table's jump-down below the HB jump-up).
    pub note: Option<String>,
}

fn linspace(a: f64, z: f64, n: usize) -> Vec<f64> {
    if n < 2 {
        return vec![a];
    }
    let step = (z - a) / (n - 1) as f64;
    let mut v: Vec<f64> = (0..n).map(|i| a + i as f64 * step).collect();
    v[n - 1] = z;
    v
}

/// Smallest s at which [`law_s_dn`] looks for the end of the high branch.
pub const S_DN_MIN: f64 = 0.2;

/// Jump-down position from the forcing ratio ρ(s) = a_ex / (Ω² Â_H(s) h) on the HB high branch
/// (docs/model.md §6.4: single-mode HB ends the high branch where Â_H reaches the damping-limited peak
/// F/(2DωΩ), where ρ is proportional to the damping; the nonsmooth model's effective damping is
/// learnt as ρ_c): the first s ≥ [`S_DN_MIN`] where ρ(s) < ρ_c, linearly interpolated between the
/// branch's points; None if it never falls below ρ_c or ρ_c = 0 (as `drift_law.s_dn_forcing_ratio`).
/// With `s_p` > 0 (the law's `jump_down_s`: the PCS high branches end at one position) the high
/// branch ends at s_p if ρ(s_p) ≤ ρ_c (Â_H interpolated linearly; None if the branch does not
/// reach s_p), else it does not end.
pub fn law_s_dn_on_high(s: Vec<f64>, amplitude_h: Vec<f64>, f_ex_hz: f64, a_ex: f64, rho_c: f64, s_p: f64, thickness_m: f64) -> Result<Option<f64>> {
    if s.len() != amplitude_h.len() {
        return Err(Error::invalid("amplitude_h", amplitude_h.len(), "one per s"));
    }
    let m = HbManifold { high: super::branch::HbBranch { s, amplitude_h, ..Default::default() }, ..Default::default() };
    Ok(law_s_dn(&m, f_ex_hz, a_ex, rho_c, s_p, thickness_m))
}

/// [`law_s_dn_on_high`] on the high branch of an HB manifold.
pub fn law_s_dn(manifold: &HbManifold, f_ex_hz: f64, a_ex: f64, rho_c: f64, s_p: f64, thickness_m: f64) -> Option<f64> {
    let hb = &manifold.high;
    if hb.s.is_empty() || !(rho_c > 0.0) {
        return None;
    }
    let mut idx: Vec<usize> = (0..hb.s.len()).collect();
    idx.sort_by(|&i, &j| hb.s[i].total_cmp(&hb.s[j]));
    let omega = 2.0 * std::f64::consts::PI * f_ex_hz;
    let rho = |i: usize| a_ex / (omega * omega * hb.amplitude_h[i] * thickness_m);
    if s_p > 0.0 {
        for w in 1..idx.len() {
            let (i0, i1) = (idx[w - 1], idx[w]);
            let (s0, s1) = (hb.s[i0], hb.s[i1]);
            if s0 <= s_p && s_p <= s1 {
                let t = if s1 > s0 { (s_p - s0) / (s1 - s0) } else { 0.0 };
                let amp = hb.amplitude_h[i0] + t * (hb.amplitude_h[i1] - hb.amplitude_h[i0]);
                let r = a_ex / (omega * omega * amp * thickness_m);
                return if r <= rho_c { Some(s_p) } else { None };
            }
        }
        return None;
    }
    for w in 1..idx.len() {
        let (i0, i1) = (idx[w - 1], idx[w]);
        let (s0, s1) = (hb.s[i0], hb.s[i1]);
        let r1 = rho(i1);
        if s1 < S_DN_MIN || !(r1 < rho_c) {
            continue;
        }
        let r0 = rho(i0);
        if s0 >= S_DN_MIN && r0 >= rho_c && r0 != r1 {
            return Some(s0 + (s1 - s0) * (r0 - rho_c) / (r0 - r1));
        }
        return Some(s1);
    }
    None
}

/// The reduced model of one operating point from its HB manifold and a law: each branch
/// sampled at `nodes` points over its s-range (the high branch up to the HB manifold's s_dn, else
/// the law's, [`law_s_dn`]), Â and V there.
/// Returns the model and whether the law extrapolated.
pub fn slow_model(params: &Params, manifold: &HbManifold, law: &DriftLaw, f_ex_hz: f64, a_ex: f64, nodes: usize) -> Result<(SlowModel, bool)> {
    let beam = beam_for(params, manifold.n_modes)?;
    slow_model_with(params, &beam, manifold, law, f_ex_hz, a_ex, nodes)
}

/// [`slow_model`] with the beam of [`beam_for`] built once by the caller.
pub fn slow_model_with(
    params: &Params, beam: &Beam, manifold: &HbManifold, law: &DriftLaw, f_ex_hz: f64, a_ex: f64, nodes: usize,
) -> Result<(SlowModel, bool)> {
    slow_model_masked(params, beam, manifold, law, f_ex_hz, a_ex, nodes, SDnRule::Law).map(|b| (b.model, b.extrapolated))
}

/// V of the law at a node's features on the high (`high`) or low branch and whether they lie
/// outside its training range, as [`DriftLaw::evaluate`] with the node's Λ_g; where the slider does
/// not lift off (Λ_g < Λ_c) V = 0 and the range does not count (such a node cannot move), so the
/// law's nearest samples are not searched there.
fn drift_at(law: &DriftLaw, high: bool, f: &Features) -> (f64, bool) {
    if f.lift_off < law.lift_c { (0.0, false) } else { law.evaluate(high, &f.x(), f.lift_off) }
}

/// Per branch (low, high) of a [`SlowModel`]: whether the node can move (Λ_g ≥ Λ_c).
type Moving = [Vec<bool>; 2];

/// A reduced model as built: the model (no dead band yet), whether the drift extrapolated,
/// which nodes can move ([`Moving`]), the features at the nodes, where s_dn comes from, the
/// monostability vote and a note.
struct Built {
    model: SlowModel,
    extrapolated: bool,
    moving: Moving,
    features: [Vec<Features>; 2],
    s_dn_source: &'static str,
    monostable: bool,
    note: Option<String>,
}

/// The s_dn source of a model with jump-down `s_dn` given the HB manifold's own.
fn s_dn_source(s_dn: Option<f64>, hb: Option<f64>, rule: SDnRule) -> &'static str {
    match (s_dn, hb, rule) {
        (None, _, _) => "none",
        (Some(_), _, SDnRule::Table) => "table",
        (Some(_), Some(_), _) => "hb",
        (Some(_), None, _) => "law",
    }
}

/// [`slow_model_with`] under a jump-down rule, also returning what [`Built`] holds.
#[allow(clippy::too_many_arguments)]
fn slow_model_masked(
    params: &Params, beam: &Beam, manifold: &HbManifold, law: &DriftLaw, f_ex_hz: f64, a_ex: f64, nodes: usize, rule: SDnRule,
) -> Result<Built> {
    let mut moving: Moving = [Vec::new(), Vec::new()];
    let mut all_feats: [Vec<Features>; 2] = [Vec::new(), Vec::new()];
    let mut extrapolated = !law.outside_design.is_empty() || law.outside_points(f_ex_hz, a_ex);
    let mut model = SlowModel { low_ends_in_fold: manifold.s_up.is_some(), ..SlowModel::default() };
    let s_dn = match rule {
        SDnRule::Law => manifold.s_dn.or_else(|| law_s_dn(manifold, f_ex_hz, a_ex, law.rho_c, law.jump_down_s, params.thickness_m)),
        SDnRule::Hb => manifold.s_dn,
        SDnRule::None => None,
        SDnRule::Table => return Err(Error::invalid("s_dn", "table", "needs a drift table as the drift")),
    };
    for high in [false, true] {
        let Some(s) = branch_nodes(manifold, high, s_dn, nodes) else { continue };
        let feats = features_with(params, beam, manifold, f_ex_hz, a_ex, high, &s)?;
        let mut br = SlowBranch { s: s.clone(), amplitude_h: Vec::with_capacity(s.len()), v_per_s: Vec::with_capacity(s.len()) };
        for f in &feats {
            let (v, outside) = drift_at(law, high, f);
            extrapolated |= outside && f.lift_off >= law.lift_c;
            br.amplitude_h.push(f.amplitude_h);
            br.v_per_s.push(v);
        }
        moving[usize::from(high)] = feats.iter().map(|f| f.lift_off >= law.lift_c).collect();
        all_feats[usize::from(high)] = feats;
        if high {
            model.high = br;
        } else {
            // The learnt s_up correction: the fold moves from s_up to s_up + shift, the branch
            // stretched linearly towards its upper end z (Â and V those of the HB node):
            // s′ = z − (z − s)(z − s_up′)/(z − s_up).
            if let Some(su) = manifold.s_up
                && law.s_up_shift != 0.0
                && br.s.len() >= 2
            {
                let z = br.s[br.s.len() - 1];
                let target = (su + law.s_up_shift).max(manifold.s_range.0);
                if z > su && z > target {
                    for x in br.s.iter_mut() {
                        *x = z - (z - *x) * (z - target) / (z - su);
                    }
                }
            }
            model.low = br;
        }
    }
    model.high_ends_in_fold = s_dn.is_some() && !model.high.s.is_empty();
    let monostable = law.monostable(manifold);
    let mut grazing: Vec<f64> = all_feats[0].iter().map(|f| f.grazing_h).collect();
    if !model.low.s.is_empty() && monostable {
        let (low_moving, low_grazing) = monostable_low(params, beam, manifold, law, f_ex_hz, a_ex, &mut model)?;
        moving = [low_moving.into_iter().chain(moving[0].iter().copied()).collect(), Vec::new()];
        grazing = low_grazing.into_iter().chain(grazing).collect();
    }
    // The low branch at grazing (docs/model.md §6.3): the slider's impacts hold the beam where
    // its acceleration at the slider is g; V stays that of the HB node (the law's inputs).
    for (a, g) in model.low.amplitude_h.iter_mut().zip(&grazing) {
        *a = a.min(*g);
    }
    let source = s_dn_source(model.s_dn(), manifold.s_dn, rule);
    Ok(Built { model, extrapolated, moving, features: all_feats, s_dn_source: source, monostable, note: None })
}

/// The reduced model with a PCS drift table (b1): on the HB manifold's branches (V linear
/// between the table's rows) or, with [`Source::Table`] or when the table's jump-down lies below
/// the HB jump-up (no coexistence in the combined model), the table's own branches.
#[allow(clippy::too_many_arguments)]
fn table_slow_model(
    params: &Params, beam: &Beam, manifold: Option<&HbManifold>, table: &TableDrift, f_ex_hz: f64, a_ex: f64, opts: &PredictOptions,
) -> Result<Built> {
    let own = |note: Option<String>| {
        let src = if table.own.high_ends_in_fold { "table" } else { "none" };
        Built {
            model: table.own.clone(),
            extrapolated: false,
            moving: [Vec::new(), Vec::new()],
            features: [Vec::new(), Vec::new()],
            s_dn_source: src,
            monostable: false,
            note,
        }
    };
    let Some(manifold) = manifold else { return Ok(own(None)) };
    let s_dn = match opts.s_dn {
        SDnRule::Law => return Err(Error::invalid("s_dn", "law", "needs a drift law as the drift")),
        SDnRule::Hb => manifold.s_dn,
        SDnRule::Table => table.s_dn,
        SDnRule::None => None,
    };
    if opts.s_dn == SDnRule::Table
        && let (Some(sd), Some(su)) = (s_dn, manifold.s_up)
        && sd <= su
    {
        let note = format!(
            "PCS s_dn = {sd:.4} lies below the HB s_up = {su:.4}: no coexistence in the combined model; the PCS table's own branches and jumps are used"
        );
        return Ok(own(Some(note)));
    }
    let mut model = SlowModel { low_ends_in_fold: manifold.s_up.is_some(), ..SlowModel::default() };
    let mut all_feats: [Vec<Features>; 2] = [Vec::new(), Vec::new()];
    for high in [false, true] {
        let Some(s) = branch_nodes(manifold, high, s_dn, opts.nodes) else { continue };
        let feats = features_with(params, beam, manifold, f_ex_hz, a_ex, high, &s)?;
        let (ts, tv) = &table.rows[usize::from(high)];
        let br = SlowBranch { amplitude_h: feats.iter().map(|f| f.amplitude_h).collect(), v_per_s: s.iter().map(|&x| interp(x, ts, tv)).collect(), s };
        all_feats[usize::from(high)] = feats;
        if high {
            model.high = br;
        } else {
            model.low = br;
        }
    }
    model.high_ends_in_fold = s_dn.is_some() && !model.high.s.is_empty();
    let source = s_dn_source(model.s_dn(), manifold.s_dn, opts.s_dn);
    Ok(Built { model, extrapolated: false, moving: [Vec::new(), Vec::new()], features: all_feats, s_dn_source: source, monostable: false, note: None })
}

/// The single low branch of a monostable point ([`DriftLaw::monostable`]): below the (possibly
/// shifted) fold s_up′ the low branch continues along the HB branch that reaches the clamping, on
/// [`MONO_NODES`] nodes s_min + (s_up′ − s_min)·i/MONO_NODES, with the amplitude capped at the low
/// branch's amplitude at the fold (no jump) and V from the law's low-branch samples; no high branch.
/// Returns which of the prepended nodes can move (Λ_g ≥ Λ_c) and their grazing amplitudes
/// ([`Features::grazing_h`]).
fn monostable_low(
    params: &Params, beam: &Beam, manifold: &HbManifold, law: &DriftLaw, f_ex_hz: f64, a_ex: f64, model: &mut SlowModel,
) -> Result<(Vec<bool>, Vec<f64>)> {
    let (su, a_su) = (model.low.s[0], model.low.amplitude_h[0]);
    let lo = if manifold.high.is_empty() { su } else { manifold.high.s.iter().copied().fold(f64::INFINITY, f64::min) };
    model.high = SlowBranch::default();
    model.low_ends_in_fold = false;
    model.high_ends_in_fold = false;
    if !(lo < su) {
        return Ok((Vec::new(), Vec::new()));
    }
    let s: Vec<f64> = (0..MONO_NODES).map(|i| lo + (su - lo) * i as f64 / MONO_NODES as f64).collect();
    let feats = features_with(params, beam, manifold, f_ex_hz, a_ex, true, &s)?;
    let a_max = manifold.high.amplitude_h.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut br =
        SlowBranch { s: s.clone(), amplitude_h: Vec::with_capacity(s.len() + model.low.s.len()), v_per_s: Vec::with_capacity(s.len() + model.low.s.len()) };
    for f in &feats {
        let amp = f.amplitude_h.min(a_su);
        let capped = Features { amp_rel: amp / a_max, amplitude_h: amp, ..*f };
        let (v, _) = drift_at(law, false, &capped);
        br.amplitude_h.push(amp);
        br.v_per_s.push(v);
    }
    br.s.extend_from_slice(&model.low.s);
    br.amplitude_h.extend_from_slice(&model.low.amplitude_h);
    br.v_per_s.extend_from_slice(&model.low.v_per_s);
    model.low = br;
    Ok((feats.iter().map(|f| f.lift_off >= law.lift_c).collect(), feats.iter().map(|f| f.grazing_h).collect()))
}

/// `model` with V + `dv` at the nodes that can move.
fn shifted_model(model: &SlowModel, moving: &Moving, dv: f64) -> SlowModel {
    let mut m = model.clone();
    for (br, mv) in [(&mut m.low, &moving[0]), (&mut m.high, &moving[1])] {
        for (i, v) in br.v_per_s.iter_mut().enumerate() {
            if mv.get(i).copied().unwrap_or(true) {
                *v += dv;
            }
        }
    }
    m
}

/// Predict one operating point with the reduced model (docs/model.md §6.3): HB manifold, V from the
/// law, slow flow from s₀ for `t_end_s` seconds, classified by the map classifier unchanged.
pub fn predict_point(params: &Valid, law: &DriftLaw, f_ex_hz: f64, a_ex: f64, s0: f64, t_end_s: f64, opts: &PredictOptions) -> Result<PointPrediction> {
    let beam = beam_for(params, opts.hb.n_modes)?;
    predict_point_with(params, &beam, law, f_ex_hz, a_ex, s0, t_end_s, opts)
}

/// [`predict_point`] with the beam of [`beam_for`] (`opts.hb.n_modes` modes) built once by the caller.
#[allow(clippy::too_many_arguments)]
pub fn predict_point_with(
    params: &Valid, beam: &Beam, law: &DriftLaw, f_ex_hz: f64, a_ex: f64, s0: f64, t_end_s: f64, opts: &PredictOptions,
) -> Result<PointPrediction> {
    predict_drift(params, beam, Drift::Law(law), f_ex_hz, a_ex, s0, t_end_s, opts)
}

/// One operating point by the reduced model (docs/model.md §6.3–6.4) as a front end asks for it: the
/// drift given as a law or a table (exactly one), the options as [`PredictArgs`] (the whole step:
/// the beam of the options' modes, the drift, [`predict_drift`]).
#[allow(clippy::too_many_arguments)]
pub fn predict(
    params: &Valid, law: Option<&DriftLaw>, table: Option<&TableDrift>, f_ex_hz: f64, a_ex: f64, s0: f64, t_end_s: f64, args: &PredictArgs,
) -> Result<PointPrediction> {
    let opts = args.options()?;
    let drift = Drift::one_of(law, table)?;
    predict_drift(params, &*beam_for(params, args.n_modes)?, drift, f_ex_hz, a_ex, s0, t_end_s, &opts)
}

/// [`predict_point_with`] with either kind of drift ([`Drift`]): a law (b2) or a PCS table (b1,
/// also with [`Source::Table`]); the options' jump-down rule, dead band and build-up apply.
#[allow(clippy::too_many_arguments)]
pub fn predict_drift(
    params: &Valid, beam: &Beam, drift: Drift<'_>, f_ex_hz: f64, a_ex: f64, s0: f64, t_end_s: f64, opts: &PredictOptions,
) -> Result<PointPrediction> {
    let lo = params.s_min();
    if !(s0.is_finite() && s0 >= lo - 1e-12 && s0 <= 1.0 - lo + 1e-12) {
        return Err(Error::invalid("s0", s0, &format!("must lie on the beam, {lo:.4} <= s0 <= {:.4}", 1.0 - lo)));
    }
    if !(t_end_s.is_finite() && t_end_s > 0.0) {
        return Err(Error::invalid("t_end", t_end_s, "must be > 0"));
    }
    if !(opts.v_dead.is_finite() && opts.v_dead >= 0.0) {
        return Err(Error::invalid("v_dead", opts.v_dead, "must be finite and >= 0"));
    }
    if let Some(t) = opts.build_up_s
        && !(t.is_finite() && t >= 0.0)
    {
        return Err(Error::invalid("build_up", t, "must be finite and >= 0"));
    }
    let t0 = Instant::now();
    let (built, t1) = match drift {
        Drift::Law(law) => {
            if opts.source == Source::Table {
                return Err(Error::invalid("source", "table", "needs a drift table as the drift"));
            }
            let manifold = hb_manifold(params, f_ex_hz, a_ex, &opts.hb)?;
            let t1 = Instant::now();
            let b = slow_model_masked(params, beam, &manifold, law, f_ex_hz, a_ex, opts.nodes, opts.s_dn)?;
            (b, t1)
        }
        Drift::Table(table) => {
            let manifold = if opts.source == Source::Hb { Some(hb_manifold(params, f_ex_hz, a_ex, &opts.hb)?) } else { None };
            let t1 = Instant::now();
            (table_slow_model(params, beam, manifold.as_ref(), table, f_ex_hz, a_ex, opts)?, t1)
        }
    };
    let t2 = Instant::now();
    let build_up = match opts.build_up_s {
        Some(t) => t,
        None => {
            let d = opts.hb.d_eff.unwrap_or(params.damping_ratio);
            if d > 0.0 { 3.0 / (d * 2.0 * std::f64::consts::PI * f_ex_hz) } else { 0.0 }
        }
    };
    let fo = SlowFlowOptions {
        t_end_s,
        criteria: opts.criteria.clone(),
        build_up_s: build_up.min(t_end_s),
        build_up_drift: opts.build_up_drift,
        ..SlowFlowOptions::default()
    };
    let model = dead_band(&built.model, opts.v_dead);
    let flow = slow_flow(&model, s0, &fo)?;
    let t3 = Instant::now();
    let mut shifted = Vec::new();
    let mut robust = None;
    if let Drift::Law(law) = drift
        && opts.robustness
        && law.v_resolution > 0.0
    {
        for dv in [-law.v_resolution, law.v_resolution] {
            let f = slow_flow(&dead_band(&shifted_model(&built.model, &built.moving, dv), opts.v_dead), s0, &fo)?;
            shifted.push((f.classification.behaviour, f.s_final));
        }
        let b = flow.classification.behaviour;
        // A relaxation oscillation's final s is the cycle's phase at t_end: only its behaviour counts.
        let cycle = b == Behaviour::RelaxationOscillation;
        robust = Some(shifted.iter().all(|&(bs, sf)| bs == b && (cycle || (sf - flow.s_final).abs() <= ROBUST_DS)));
    }
    let t4 = Instant::now();
    Ok(PointPrediction {
        s_up: model.s_up(),
        s_dn: model.s_dn(),
        s_dn_source: built.s_dn_source,
        monostable: built.monostable,
        flow,
        extrapolated: built.extrapolated,
        model,
        timings_s: [(t1 - t0).as_secs_f64(), (t2 - t1).as_secs_f64(), (t3 - t2).as_secs_f64(), (t4 - t3).as_secs_f64()],
        robust,
        shifted,
        features: built.features,
        build_up_s: build_up.min(t_end_s),
        note: built.note,
    })
}

/// The slow flow's nodes on one branch of the HB manifold (docs/model.md §6.4): `nodes` values
/// spaced evenly over the branch's s range, the high branch cut at the jump-down s_dn; None when
/// the branch is empty or has no extent.
fn branch_nodes(manifold: &HbManifold, high: bool, s_dn: Option<f64>, nodes: usize) -> Option<Vec<f64>> {
    let b = if high { &manifold.high } else { &manifold.low };
    if b.is_empty() {
        return None;
    }
    let a = b.s.iter().copied().fold(f64::INFINITY, f64::min);
    let mut z = b.s.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if high && let Some(sd) = s_dn {
        z = z.min(sd);
    }
    (z > a).then(|| linspace(a, z, nodes.max(2)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::superslow::law::{FEATURES, NF, nearest};

    proptest::proptest! {
        /// The sweep finds the same k nearest distances as a brute-force search (ties may pick
        /// other rows at an equal distance), in ascending order.
        #[test]
        fn nearest_matches_brute_force(pts in proptest::collection::vec((-3.0f64..3.0, -3.0f64..3.0), 1..60),
                                       q in (-4.0f64..4.0, -4.0f64..4.0), k in 1usize..8, coarse in proptest::bool::ANY) {
            // `coarse`: coordinates on a grid of 0.5, so that ties occur.
            let r = |x: f64| if coarse { (2.0 * x).round() / 2.0 } else { x };
            let mut z: Vec<[f64; NF]> = pts.iter().map(|&(a, b)| [r(a), r(b)]).collect();
            z.sort_by(|a, b| a[NF - 1].total_cmp(&b[NF - 1]));
            let q = [r(q.0), r(q.1)];
            let got = nearest(&z, &q, k);
            let mut all: Vec<f64> = z.iter().map(|p| (0..NF).map(|i| (p[i] - q[i]).powi(2)).sum()).collect();
            all.sort_by(f64::total_cmp);
            proptest::prop_assert_eq!(got.len(), k.min(z.len()));
            for (n, &(d2, j)) in got.iter().enumerate() {
                proptest::prop_assert_eq!(d2, all[n]);
                let dj: f64 = (0..NF).map(|i| (z[j][i] - q[i]).powi(2)).sum();
                proptest::prop_assert_eq!(dj, d2);
            }
            let mut js: Vec<usize> = got.iter().map(|e| e.1).collect();
            js.sort_unstable();
            js.dedup();
            proptest::prop_assert_eq!(js.len(), got.len());
        }
    }

    fn law_text(k: usize) -> String {
        serde_json::json!({
            "kind": "beamslider drift law", "version": 1, "features": FEATURES, "k": k,
            "x": {"L": [[0.0, 0.0], [1.0, 0.0]], "H": [[0.0, 1.0]]},
            "v": {"L": [1.0, 3.0], "H": [-2.0]},
            "mean": [0.0, 0.0], "std": [1.0, 1.0],
            "lo": [0.0, 0.0], "hi": [1.0, 1.0], "points": [[124.0, 14.0], [120.0, 10.0]]
        })
        .to_string()
    }

    #[test]
    fn knn_is_inverse_distance_weighted_and_zero_without_lift_off() {
        let law = DriftLaw::from_json_str(&law_text(2)).unwrap();
        // Distances 0.25 and 0.75: weights 4 and 4/3 → (4·1 + 4/3·3)/(16/3) = 1.5.
        let (v, out) = law.evaluate(false, &[0.25, 0.0], 2.0);
        assert!((v - 1.5).abs() < 1e-12 && !out);
        let (v, _) = law.evaluate(false, &[0.25, 0.0], 0.9);
        assert_eq!(v, 0.0);
        let (v, out) = law.evaluate(true, &[5.0, 0.0], 2.0);
        assert_eq!(v, -2.0);
        assert!(out);
    }

    #[test]
    fn operating_points_outside_the_training_box_are_reported() {
        let law = DriftLaw::from_json_str(&law_text(2)).unwrap();
        assert!(!law.outside_points(122.0, 12.0) && !law.outside_points(124.0, 10.0));
        assert!(law.outside_points(118.0, 12.0) && law.outside_points(122.0, 16.0));
    }

    #[test]
    fn bad_law_files_are_clear_errors() {
        for bad in ["", "{}", "[1, 2]", r#"{"kind": "other"}"#] {
            assert!(DriftLaw::from_json_str(bad).is_err(), "{bad}");
        }
        let wrong_features = law_text(2).replace("amp_rel", "slope_mu");
        let e = DriftLaw::from_json_str(&wrong_features).unwrap_err().to_string();
        assert!(e.contains("features"), "{e}");
        let zero_k = law_text(0);
        assert!(DriftLaw::from_json_str(&zero_k).is_err());
        let short = law_text(1).replace("\"L\":[1.0,3.0]", "\"L\":[1.0]");
        assert_ne!(short, law_text(1));
        assert!(DriftLaw::from_json_str(&short).is_err());
        let e = DriftLaw::from_file("/nonexistent/law.json").unwrap_err();
        assert!(matches!(e, Error::Io { .. }));
    }

    /// A law file with the scalar `key` = `good` reads, changes the fingerprint, and each of `bad`
    /// is refused with an error naming `key`.
    fn scalar_is_read_and_checked(key: &str, good: &str, bad: &[&str]) -> DriftLaw {
        let with = |x: &str| law_text(2).replacen("\"kind\"", &format!("\"{key}\": {x}, \"kind\""), 1);
        let law = DriftLaw::from_json_str(&with(good)).unwrap();
        assert_ne!(law.fingerprint, DriftLaw::from_json_str(&law_text(2)).unwrap().fingerprint);
        for b in bad {
            let e = DriftLaw::from_json_str(&with(b)).unwrap_err().to_string();
            assert!(e.contains(key), "{e}");
        }
        law
    }

    #[test]
    fn jump_down_position_is_read_and_checked() {
        let law = scalar_is_read_and_checked("jump_down_s", "0.32", &["0.7", "-0.1"]);
        assert_eq!(law.jump_down_s, 0.32);
        assert_eq!(DriftLaw::from_json_str(&law_text(2)).unwrap().jump_down_s, 0.0);
    }

    #[test]
    fn v_resolution_is_read_checked_and_shifts_only_moving_nodes() {
        let law = scalar_is_read_and_checked("v_resolution", "0.0003", &["-0.001", "0.5"]);
        assert_eq!(law.v_resolution, 0.0003);
        let br = |v: Vec<f64>| SlowBranch { s: (0..v.len()).map(|i| 0.1 * i as f64).collect(), amplitude_h: vec![0.5; v.len()], v_per_s: v };
        let model = SlowModel { low: br(vec![0.0, -1e-3, -2e-3]), high: br(vec![0.0, 0.0, 1e-3]), ..SlowModel::default() };
        let moving: Moving = [vec![false, true, true], vec![false, true, true]];
        let m = shifted_model(&model, &moving, 1e-4);
        assert_eq!(m.low.v_per_s, vec![0.0, -1e-3 + 1e-4, -2e-3 + 1e-4]);
        assert_eq!(m.high.v_per_s, vec![0.0, 1e-4, 1e-3 + 1e-4]);
        assert_eq!(m.low.s, model.low.s);
    }
}
