//! The transferable drift law of docs/model.md §6.3 evaluated in the core, and the local features
//! of a harmonic-balance branch it takes as inputs.
//!
//! * [`DriftLaw`] — the law file written by `beamslider.slowflow.fit_drift_law(...).save(path)`
//!   (JSON): per branch, training samples (features, V); evaluated as the distance-weighted mean
//!   of the k nearest samples of the same branch in standardised feature space,
//!   V = Σ wᵢVᵢ / Σ wᵢ with wᵢ = 1/max(dᵢ, 10⁻⁶), and V = 0 where Λ_g < Λ_c (no lift-off; Λ_c
//!   is the law's `lift_c`, learnt from the PCS tables: where their clampward drift ends; 1 in
//!   law files without it).
//! * [`features`] — the local features of docs/model.md §6.3 at s on one branch of an HB manifold, with
//!   Q interpolated linearly in s between the continuation points:
//!   ŵ_abs = a_ex/Ω² + Φ(s)ᵀQ, θ̂ = Φ′(s)ᵀQ, Λ_g = Ω²|ŵ_abs|/g, θ̂/θ_gap with θ_gap = (R − h)/B,
//!   f_slope = −(Ω²/2g) Re[ŵ_abs θ̂*], s − s_res, Â/max Â_H. The law's inputs are
//!   (Â/max Â_H, s) ([`FEATURES`]): the relative amplitude on the branch and the position (the
//!   stable zeros of V_H, where the slider stops, sit at nearly the same s over the map; chosen by
//!   the leave-one-operating-point-out error, docs/results/superslow/validation_b_features.txt); Λ_g
//!   enters through the constraint V = 0 where Λ_g < Λ_c.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::branch::{HbBranch, HbManifold, HbOptions};
use super::continuation::hb_manifold;
use crate::error::{Error, Result};
use crate::params::{Params, Valid};
use crate::physics::beam::Beam;

/// Inputs of the law, in this order (as `beamslider.drift_law.FEATURES`).
pub const FEATURES: [&str; 2] = ["amp_rel", "s"];
/// Number of inputs.
pub const NF: usize = FEATURES.len();

/// A law file's content as read (the JSON of `beamslider.superslow.law_json`, only what an evaluation
/// reads): parsed into a [`DriftLaw`] by [`DriftLaw::from_law_file`]; a design law keeps its laws'
/// files to build blended ones (docs/model.md §6.5).
#[derive(Debug, Clone, Deserialize, Serialize)]
pub struct LawFile {
    pub(super) kind: String,
    #[serde(default)]
    pub(super) version: u32,
    pub(super) features: Vec<String>,
    pub(super) k: usize,
    pub(super) x: std::collections::HashMap<String, Vec<Vec<f64>>>,
    pub(super) v: std::collections::HashMap<String, Vec<f64>>,
    pub(super) mean: Vec<f64>,
    pub(super) std: Vec<f64>,
    pub(super) lo: Vec<f64>,
    pub(super) hi: Vec<f64>,
    #[serde(default)]
    pub(super) points: Vec<Vec<f64>>,
    #[serde(default)]
    pub(super) s_up_shift: f64,
    #[serde(default)]
    pub(super) mono_x: Vec<Vec<f64>>,
    #[serde(default)]
    pub(super) mono_y: Vec<f64>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(super) mono_std: Vec<f64>,
    #[serde(default = "one")]
    pub(super) lift_c: f64,
    #[serde(default)]
    pub(super) rho_c: f64,
    #[serde(default)]
    pub(super) jump_down_s: f64,
    #[serde(default)]
    pub(super) v_resolution: f64,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(super) outside_design: Vec<String>,
}

impl LawFile {
    /// The file's JSON text.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }
}

/// The most neighbours a law may weigh (docs/model.md §6.3: the fitted laws use k = 4; a law
/// with fewer samples than k weighs them all).
pub const MAX_K: usize = 64;

pub(super) fn one() -> f64 {
    1.0
}

/// Training samples of one branch, sorted by the last standardised feature (s) so that
/// [`DriftLaw::evaluate`] finds the k nearest by a sweep outwards from the query's s.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LawBranch {
    /// Standardised features, one row per sample (sorted by `z[NF - 1]`).
    pub z: Vec<[f64; NF]>,
    /// V [1/s] (towards the centre positive).
    pub v: Vec<f64>,
}

/// A fitted transferable drift law (docs/model.md §6.3), as written by the Python package.
#[derive(Debug, Clone, PartialEq)]
pub struct DriftLaw {
    /// Neighbours.
    pub k: usize,
    /// Low-branch samples.
    pub low: LawBranch,
    /// High-branch samples.
    pub high: LawBranch,
    /// Feature means (standardisation).
    pub mean: [f64; NF],
    /// Feature standard deviations.
    pub std: [f64; NF],
    /// Training range (min) of the features.
    pub lo: [f64; NF],
    /// Training range (max).
    pub hi: [f64; NF],
    /// Training operating points (f_ex, a_ex).
    pub points: Vec<(f64, f64)>,
    /// Learnt shift of the HB jump-up position (median of s_up(PCS) − s_up(HB) over the training
    /// tables; 0: none): the low branch's fold is moved by it ([`slow_model`]).
    pub s_up_shift: f64,
    /// Monostability samples, one per training point with an HB fold: (ln Â_L at the fold,
    /// s_up of HB) and whether its PCS sweeps show no jump-up ([`DriftLaw::monostable`]).
    pub mono: Vec<([f64; 2], bool)>,
    /// Standardisation of the monostability inputs.
    pub mono_std: [f64; 2],
    /// Lift-off threshold Λ_c: V = 0 where Λ_g < Λ_c (learnt from the PCS tables by
    /// `fit_drift_law`; 1, the constraint of docs/model.md §6.3, in law files without it).
    pub lift_c: f64,
    /// Forcing ratio ρ_c at which the nonsmooth model's high branch ends ([`law_s_dn`]; learnt
    /// from the PCS tables' jump-downs by `fit_drift_law`; 0: none, the HB manifold's own s_dn only).
    pub rho_c: f64,
    /// Position s_p at which the PCS high branches end (learnt by `fit_drift_law`'s bracket rule):
    /// when > 0 the high branch ends at s_p if ρ(s_p) ≤ ρ_c, else it does not end ([`law_s_dn`]);
    /// 0 (law files without it): the first s where ρ(s) < ρ_c.
    pub jump_down_s: f64,
    /// Resolution of V [1/s]: the median standard error of the training rows' V (0: unknown).
    /// [`predict_point`] re-runs the slow flow with V shifted by ± this much to tell a robust
    /// prediction from one that hinges on V within its measurement error ([`ROBUST_DS`]).
    pub v_resolution: f64,
    /// Why the design this law was blended for lies outside its design law's box (docs/model.md
    /// §6.5; empty inside): every prediction with the law is then extrapolated.
    pub outside_design: Vec<String>,
    /// Fingerprint of the samples (FNV-1a over the bits of k, the samples and the scaling):
    /// written to a predicted map's header and compared on resume.
    pub fingerprint: String,
}

pub(super) fn arr(name: &str, v: &[f64]) -> Result<[f64; NF]> {
    if v.len() != NF || v.iter().any(|x| !x.is_finite()) {
        return Err(Error::invalid("law", name, &format!("needs {NF} finite values")));
    }
    Ok(std::array::from_fn(|i| v[i]))
}

impl DriftLaw {
    /// Parse the JSON text of a law file (checks its kind, features and shapes).
    pub fn from_json_str(text: &str) -> Result<DriftLaw> {
        let f: LawFile = serde_json::from_str(text).map_err(|e| Error::invalid("law", "file", &format!("not a beamslider drift law file ({e})")))?;
        DriftLaw::from_law_file(f)
    }

    /// [`DriftLaw::from_json_str`] of a law file's content already parsed (a front end's table).
    pub fn from_json_value(value: serde_json::Value) -> Result<DriftLaw> {
        let f: LawFile = serde_json::from_value(value).map_err(|e| Error::invalid("law", "file", &format!("not a beamslider drift law file ({e})")))?;
        DriftLaw::from_law_file(f)
    }

    /// Check a law file's content (kind, features, shapes, scalars) and build the law.
    pub fn from_law_file(f: LawFile) -> Result<DriftLaw> {
        if f.kind != "beamslider drift law" {
            return Err(Error::invalid("law", &f.kind, "not a beamslider drift law file (kind)"));
        }
        if f.version > 1 {
            return Err(Error::invalid("law", f.version, "format version newer than this build (1)"));
        }
        if f.features != FEATURES {
            return Err(Error::invalid("law", format!("{:?}", f.features), &format!("this build's features are {FEATURES:?}")));
        }
        if f.k == 0 {
            return Err(Error::invalid("law", "k = 0", "k must be >= 1"));
        }
        let mean = arr("mean", &f.mean)?;
        let std = arr("std", &f.std)?;
        if std.iter().any(|&s| s <= 0.0) {
            return Err(Error::invalid("law", "std", "standard deviations must be > 0"));
        }
        let lo = arr("lo", &f.lo)?;
        let hi = arr("hi", &f.hi)?;
        if !(f.s_up_shift.is_finite() && f.s_up_shift.abs() < 0.5) {
            return Err(Error::invalid("law", "s_up_shift", "must be finite, |shift| < 0.5"));
        }
        if !(f.lift_c.is_finite() && f.lift_c > 0.0 && f.lift_c <= 2.0) {
            return Err(Error::invalid("law", "lift_c", "must be finite, 0 < lift_c <= 2"));
        }
        let mut hash = Fnv::new();
        hash.add(f.k as f64);
        hash.add(f.s_up_shift);
        if f.lift_c != 1.0 {
            hash.add(f.lift_c);
        }
        if !(f.rho_c.is_finite() && f.rho_c >= 0.0) {
            return Err(Error::invalid("law", "rho_c", "must be finite and >= 0"));
        }
        if f.rho_c != 0.0 {
            hash.add(f.rho_c);
        }
        if !(f.jump_down_s.is_finite() && (0.0..=0.5).contains(&f.jump_down_s)) {
            return Err(Error::invalid("law", "jump_down_s", "must be finite, 0 <= jump_down_s <= 0.5"));
        }
        if f.jump_down_s != 0.0 {
            hash.add(f.jump_down_s);
        }
        for x in mean.iter().chain(&std) {
            hash.add(*x);
        }
        let mut branch = |name: &str| -> Result<LawBranch> {
            let x = f.x.get(name).map(Vec::as_slice).unwrap_or(&[]);
            let v = f.v.get(name).map(Vec::as_slice).unwrap_or(&[]);
            if x.len() != v.len() {
                return Err(Error::invalid("law", format!("branch {name}"), "x and v must have the same number of samples"));
            }
            let mut out = LawBranch::default();
            for (row, &vi) in x.iter().zip(v) {
                let r = arr(&format!("x[{name}]"), row)?;
                if !vi.is_finite() {
                    return Err(Error::invalid("law", format!("v[{name}]"), "values must be finite"));
                }
                for x in r.iter().chain(std::iter::once(&vi)) {
                    hash.add(*x);
                }
                out.z.push(std::array::from_fn(|i| (r[i] - mean[i]) / std[i]));
                out.v.push(vi);
            }
            // Sorted by s for the k-nearest sweep (stable: ties keep the file's order).
            let mut idx: Vec<usize> = (0..out.v.len()).collect();
            idx.sort_by(|&a, &b| out.z[a][NF - 1].total_cmp(&out.z[b][NF - 1]));
            out.z = idx.iter().map(|&i| out.z[i]).collect();
            out.v = idx.iter().map(|&i| out.v[i]).collect();
            Ok(out)
        };
        let low = branch("L")?;
        let high = branch("H")?;
        if low.v.is_empty() && high.v.is_empty() {
            return Err(Error::invalid("law", "samples", "the law has no training samples"));
        }
        if f.k > MAX_K {
            return Err(Error::invalid("law", format!("k = {}", f.k), &format!("at most {MAX_K} neighbours (a fitted law weighs a handful)")));
        }
        let points = f.points.iter().filter(|p| p.len() == 2).map(|p| (p[0], p[1])).collect();
        if f.mono_x.len() != f.mono_y.len() || f.mono_x.iter().any(|r| r.len() != 2 || r.iter().any(|x| !x.is_finite())) {
            return Err(Error::invalid("law", "mono_x", "one row of 2 finite values per mono_y"));
        }
        let mono_std = match f.mono_std.as_slice() {
            [] => [1.0, 1.0],
            &[a, b] if a > 0.0 && b > 0.0 && a.is_finite() && b.is_finite() => [a, b],
            _ => return Err(Error::invalid("law", "mono_std", "two finite values > 0")),
        };
        let mono: Vec<([f64; 2], bool)> = f.mono_x.iter().zip(&f.mono_y).map(|(r, &y)| ([r[0], r[1]], y > 0.5)).collect();
        for (x, y) in &mono {
            hash.add(x[0]);
            hash.add(x[1]);
            hash.add(if *y { 1.0 } else { 0.0 });
        }
        if !(f.v_resolution.is_finite() && (0.0..0.1).contains(&f.v_resolution)) {
            return Err(Error::invalid("law", "v_resolution", "must be finite, 0 <= v_resolution < 0.1 1/s"));
        }
        if f.v_resolution != 0.0 {
            hash.add(f.v_resolution);
        }
        Ok(DriftLaw {
            k: f.k,
            low,
            high,
            mean,
            std,
            lo,
            hi,
            points,
            s_up_shift: f.s_up_shift,
            mono,
            mono_std,
            lift_c: f.lift_c,
            rho_c: f.rho_c,
            jump_down_s: f.jump_down_s,
            v_resolution: f.v_resolution,
            outside_design: f.outside_design,
            fingerprint: format!("{:016x}", hash.0),
        })
    }

    /// Read a law file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<DriftLaw> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| Error::Io { path: path.display().to_string(), source: e })?;
        DriftLaw::from_json_str(&text).map_err(|e| match e {
            Error::InvalidParameter { field, value: _, allowed } => Error::InvalidParameter { field, value: path.display().to_string(), allowed },
            e => e,
        })
    }

    fn branch(&self, high: bool) -> &LawBranch {
        if high { &self.high } else { &self.low }
    }

    /// Training samples on the high (`high`) or low branch.
    pub fn branch_len(&self, high: bool) -> usize {
        self.branch(high).v.len()
    }

    /// Whether the operating point has a single (low) branch in the nonsmooth model although
    /// single-term HB has a fold: the label of the nearest training point in standardised
    /// (ln Â_L(s_up), s_up) of the HB manifold (label: its PCS sweeps show no jump-up). False
    /// without an HB fold or without samples.
    pub fn monostable(&self, manifold: &HbManifold) -> bool {
        mono_x(manifold).is_some_and(|x| self.monostable_at(&x))
    }

    /// The monostability vote at `x` = (ln Â_L at the HB fold, s_up) (the inputs of
    /// [`DriftLaw::monostable`]): the label of the nearest sample; false without samples.
    pub fn monostable_at(&self, x: &[f64; 2]) -> bool {
        let d = |m: &[f64; 2]| ((m[0] - x[0]) / self.mono_std[0]).powi(2) + ((m[1] - x[1]) / self.mono_std[1]).powi(2);
        let mut best: Option<(f64, bool)> = None;
        for (m, y) in &self.mono {
            let dm = d(m);
            if best.is_none_or(|(b, _)| dm < b) {
                best = Some((dm, *y));
            }
        }
        best.is_some_and(|(_, y)| y)
    }

    /// Whether (f_ex, a_ex) lies outside the box of the training operating points (the law's
    /// inputs are bounded everywhere, so the operating point is the range a law is used outside of).
    pub fn outside_points(&self, f_ex_hz: f64, a_ex: f64) -> bool {
        if self.points.is_empty() {
            return false;
        }
        let (mut f0, mut f1, mut a0, mut a1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for &(f, a) in &self.points {
            (f0, f1, a0, a1) = (f0.min(f), f1.max(f), a0.min(a), a1.max(a));
        }
        !(f_ex_hz >= f0 - 1e-9 && f_ex_hz <= f1 + 1e-9 && a_ex >= a0 - 1e-9 && a_ex <= a1 + 1e-9)
    }

    /// [`DriftLaw::evaluate`] per row of `x` with its Λ_g in `lift_off`: (V, outside) per row.
    pub fn evaluate_rows(&self, high: bool, x: &[[f64; NF]], lift_off: &[f64]) -> Result<(Vec<f64>, Vec<bool>)> {
        if x.len() != lift_off.len() {
            return Err(Error::invalid("x", x.len(), "one lift_off per row"));
        }
        Ok(x.iter().zip(lift_off).map(|(r, &l)| self.evaluate(high, r, l)).unzip())
    }

    /// V at the features `x` (law inputs, [`FEATURES`]) on the high (`high`) or low branch, and
    /// whether `x` lies outside the training range. `lift_off` = Λ_g (V = 0 where < Λ_c).
    pub fn evaluate(&self, high: bool, x: &[f64; NF], lift_off: f64) -> (f64, bool) {
        let outside = (0..NF).any(|i| x[i] < self.lo[i] - 1e-9 || x[i] > self.hi[i] + 1e-9);
        let b = self.branch(high);
        if b.v.is_empty() {
            return (0.0, true);
        }
        let z: [f64; NF] = std::array::from_fn(|i| (x[i] - self.mean[i]) / self.std[i]);
        let best = nearest(&b.z, &z, self.k);
        let (mut sw, mut swv) = (0.0, 0.0);
        for &(d2, j) in &best {
            let w = 1.0 / d2.sqrt().max(1e-6);
            sw += w;
            swv += w * b.v[j];
        }
        let v = if lift_off < self.lift_c { 0.0 } else { swv / sw };
        (v, outside)
    }
}

/// The `k` nearest rows of `z` (sorted by the last column) to `q` in Euclidean distance, as
/// (squared distance, index) in ascending order: a sweep outwards from q's position in the last
/// column that stops once that column alone is farther than the k-th best (exact).
pub(super) fn nearest(z: &[[f64; NF]], q: &[f64; NF], k: usize) -> Vec<(f64, usize)> {
    let k = k.min(z.len());
    let mut best: Vec<(f64, usize)> = Vec::with_capacity(k + 1);
    let a = NF - 1;
    let start = z.partition_point(|r| r[a] < q[a]);
    let (mut left, mut right) = (start, start);
    loop {
        let dl = (left > 0).then(|| (q[a] - z[left - 1][a]).powi(2));
        let dr = (right < z.len()).then(|| (z[right][a] - q[a]).powi(2));
        let (j, da) = match (dl, dr) {
            (Some(l), Some(r)) if l <= r => (left - 1, l),
            (Some(l), None) => (left - 1, l),
            (_, Some(r)) => (right, r),
            (None, None) => break,
        };
        if best.len() == k && da > best[k - 1].0 {
            break;
        }
        if j < start {
            left -= 1;
        } else {
            right += 1;
        }
        let d2: f64 = (0..NF).map(|i| (z[j][i] - q[i]).powi(2)).sum();
        if best.len() < k || d2 < best[k - 1].0 {
            let pos = best.partition_point(|e| e.0 <= d2);
            best.insert(pos, (d2, j));
            best.truncate(k);
        }
    }
    best
}

/// (ln Â_L at the HB fold, s_up), None without a fold (inputs of [`DriftLaw::monostable`]).
pub(super) fn mono_x(manifold: &HbManifold) -> Option<[f64; 2]> {
    let su = manifold.s_up?;
    let lo = &manifold.low;
    let i = (0..lo.len()).min_by(|&i, &j| lo.s[i].total_cmp(&lo.s[j]))?;
    Some([lo.amplitude_h[i].max(1e-12).ln(), su])
}

/// Nodes of the single low branch of a monostable point below its fold.
pub(super) const MONO_NODES: usize = 40;

/// FNV-1a, 64 bit, over f64 bit patterns.
pub(super) struct Fnv(u64);
impl Fnv {
    fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn add(&mut self, x: f64) {
        for b in x.to_bits().to_le_bytes() {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

/// The local features of docs/model.md §6.3 at one s on one branch.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Features {
    /// Λ_g = Ω²|ŵ_abs|/g.
    pub lift_off: f64,
    /// θ̂/θ_gap.
    pub slope_gap: f64,
    /// f_slope = −(Ω²/2g) Re[ŵ_abs θ̂*].
    pub f_slope: f64,
    /// s − s_res (s_res: the first linear-resonance position; 0.5 if none).
    pub ds_res: f64,
    /// Â / max Â of the high branch.
    pub amp_rel: f64,
    /// Â.
    pub amplitude_h: f64,
    /// s (half coordinate).
    pub s: f64,
    /// Â_g: the amplitude along this node's HB shape Q at which the slider's absolute acceleration
    /// amplitude is g (Λ_g = 1, grazing lift-off), the largest such amplitude; ∞ when every
    /// positive amplitude lifts off (docs/model.md §6.3, "Low branch at grazing").
    pub grazing_h: f64,
}

impl Features {
    /// The law's inputs ([`FEATURES`]).
    pub fn x(&self) -> [f64; NF] {
        [self.amp_rel, self.s]
    }
}

/// A branch's points sorted by s: (s, Â, Re Q, Im Q) with Q row-major (point, mode).
pub(super) struct Sorted {
    pub(super) s: Vec<f64>,
    pub(super) a: Vec<f64>,
    pub(super) qr: Vec<f64>,
    pub(super) qi: Vec<f64>,
    pub(super) n: usize,
}

impl Sorted {
    fn new(b: &HbBranch, n: usize) -> Sorted {
        let mut o: Vec<usize> = (0..b.len()).collect();
        o.sort_by(|&i, &j| b.s[i].total_cmp(&b.s[j]));
        let pick = |v: &[f64], m: usize| o.iter().flat_map(|&i| v[i * m..(i + 1) * m].iter().copied()).collect::<Vec<f64>>();
        Sorted { s: pick(&b.s, 1), a: pick(&b.amplitude_h, 1), qr: pick(&b.q_re, n), qi: pick(&b.q_im, n), n }
    }
    /// Cell and weight of s for linear interpolation as numpy.interp (clamped at the ends).
    fn at(&self, s: f64) -> (usize, usize, f64) {
        let m = self.s.len();
        if m == 1 || s <= self.s[0] {
            return (0, 0, 0.0);
        }
        if s >= self.s[m - 1] {
            return (m - 1, m - 1, 0.0);
        }
        let j = self.s.partition_point(|&x| x <= s).clamp(1, m - 1);
        let (a, b) = (self.s[j - 1], self.s[j]);
        (j - 1, j, if b > a { (s - a) / (b - a) } else { 0.0 })
    }
    fn lerp(&self, y: &[f64], stride: usize, k: usize, s: f64) -> f64 {
        let (i, j, w) = self.at(s);
        let (a, b) = (y[i * stride + k], y[j * stride + k]);
        if w == 0.0 { a } else { a + w * (b - a) }
    }
}

/// Features of docs/model.md §6.3 at positions `s` (half coordinate, within the branch) on the high
/// (`high`) or low branch of `manifold` (computed with `params` and `n_modes` modes).
pub fn features(params: &Params, manifold: &HbManifold, f_ex_hz: f64, a_ex: f64, high: bool, s: &[f64]) -> Result<Vec<Features>> {
    let beam = beam_for(params, manifold.n_modes)?;
    features_with(params, &beam, manifold, f_ex_hz, a_ex, high, s)
}

/// Features of docs/model.md §6.3 at positions `s` on one branch of the single-term HB manifold of
/// `params` at (f_ex, a_ex) computed with `opts` (the whole step: the manifold, then [`features`]).
pub fn features_at(params: &Valid, f_ex_hz: f64, a_ex: f64, opts: &HbOptions, high: bool, s: &[f64]) -> Result<Vec<Features>> {
    features(params, &hb_manifold(params, f_ex_hz, a_ex, opts)?, f_ex_hz, a_ex, high, s)
}

/// The beam with `n_modes` modes (the mode shapes of the features).
pub fn beam_for(params: &Params, n_modes: usize) -> Result<std::sync::Arc<Beam>> {
    let mut p = params.clone();
    p.n_modes = n_modes;
    Beam::shared(&p)
}

/// [`features`] with the beam of [`beam_for`] built once by the caller.
pub fn features_with(params: &Params, beam: &Beam, manifold: &HbManifold, f_ex_hz: f64, a_ex: f64, high: bool, s: &[f64]) -> Result<Vec<Features>> {
    let b = if high { &manifold.high } else { &manifold.low };
    if b.is_empty() {
        return Err(Error::invalid("branch", if high { "H" } else { "L" }, "the manifold has no such branch"));
    }
    let n = manifold.n_modes;
    if beam.n != n {
        return Err(Error::invalid("beam", beam.n, &format!("the manifold has {n} modes")));
    }
    let p = params;
    let sorted = Sorted::new(b, n);
    let omega = 2.0 * std::f64::consts::PI * f_ex_hz;
    let g = p.gravity_m_s2;
    let theta_gap = (p.gap_ratio * p.thickness_m - p.thickness_m) / p.contact_spacing_m;
    let s_res = manifold.s_res.first().copied().unwrap_or(0.5);
    let a_max = if manifold.high.is_empty() { 1.0 } else { manifold.high.amplitude_h.iter().copied().fold(f64::NEG_INFINITY, f64::max) };
    let (mut phi, mut dphi) = (vec![0.0; n], vec![0.0; n]);
    let mut out = Vec::with_capacity(s.len());
    for &si in s {
        let x = si * p.length_m;
        for m in 0..n {
            phi[m] = beam.phi_exact(m, x);
            dphi[m] = beam.dphi_exact(m, x);
        }
        let (mut wr, mut wi, mut tr, mut ti) = (a_ex / (omega * omega), 0.0, 0.0, 0.0);
        let mut rel = 0.0; // Re Φ(s)ᵀQ, the relative displacement (Im Φ(s)ᵀQ is wi)
        for m in 0..n {
            let qr = sorted.lerp(&sorted.qr, n, m, si);
            let qi = sorted.lerp(&sorted.qi, n, m, si);
            wr += phi[m] * qr;
            rel += phi[m] * qr;
            wi += phi[m] * qi;
            tr += dphi[m] * qr;
            ti += dphi[m] * qi;
        }
        let amp = sorted.lerp(&sorted.a, 1, 0, si);
        let grazing_h = amp * grazing_factor(a_ex / (omega * omega), g / (omega * omega), rel, wi);
        out.push(Features {
            lift_off: omega * omega * wr.hypot(wi) / g,
            slope_gap: tr.hypot(ti) / theta_gap,
            f_slope: -(omega * omega / (2.0 * g)) * (wr * tr + wi * ti),
            ds_res: si - s_res,
            amp_rel: amp / a_max,
            amplitude_h: amp,
            s: si,
            grazing_h,
        });
    }
    let _ = sorted.n;
    Ok(out)
}

/// The largest factor r > 0 on the relative displacement w (complex, at the slider) at which the
/// absolute displacement amplitude |c₀ + r w| equals `c_g` (c₀ = a_ex/Ω² the base's, c_g = g/Ω²):
/// the larger root of |w|²r² + 2c₀ Re(w) r + c₀² − c_g² = 0; ∞ when there is no positive root
/// (every amplitude lifts off the slider, or w = 0).
pub fn grazing_factor(c0: f64, c_g: f64, w_re: f64, w_im: f64) -> f64 {
    let w2 = w_re * w_re + w_im * w_im;
    let b = c0 * w_re;
    let disc = b * b - w2 * (c0 * c0 - c_g * c_g);
    if w2 <= 0.0 || disc < 0.0 {
        return f64::INFINITY;
    }
    let r = (-b + disc.sqrt()) / w2;
    if r > 0.0 { r } else { f64::INFINITY }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grazing_factor_is_the_largest_root_of_unit_lift_off() {
        let lift = |c0: f64, cg: f64, wr: f64, wi: f64, r: f64| (c0 + r * wr).hypot(r * wi) / cg;
        // in phase with the base: |c0 + r w| = c_g at r = (c_g − c0)/w
        assert!((grazing_factor(0.5, 1.0, 2.0, 0.0) - 0.25).abs() < 1e-15);
        // general phase: the root is exact and above it the slider lifts off
        for &(c0, cg, wr, wi) in &[(0.3, 1.0, -0.7, 0.4), (1.4, 1.0, -2.0, 0.3), (0.9, 1.0, 0.1, -3.0)] {
            let r = grazing_factor(c0, cg, wr, wi);
            assert!(r.is_finite() && r > 0.0);
            assert!((lift(c0, cg, wr, wi, r) - 1.0).abs() < 1e-12);
            assert!(lift(c0, cg, wr, wi, 1.01 * r) > 1.0);
        }
        // the base alone lifts off and the relative motion only adds: no grazing level
        assert_eq!(grazing_factor(1.4, 1.0, 1.0, 0.0), f64::INFINITY);
        // the relative motion never brings |c0 + r w| down to c_g (discriminant < 0)
        assert_eq!(grazing_factor(1.4, 1.0, 0.0, 1.0), f64::INFINITY);
        assert_eq!(grazing_factor(0.5, 1.0, 0.0, 0.0), f64::INFINITY);
    }

    fn law(mono_x: &str, mono_y: &str) -> DriftLaw {
        let text = format!(
            r#"{{"kind": "beamslider drift law", "version": 1, "features": ["amp_rel", "s"], "k": 1,
            "x": {{"L": [[0.5, 0.3]], "H": []}}, "v": {{"L": [0.01], "H": []}}, "mean": [0.5, 0.3], "std": [1.0, 1.0],
            "lo": [0.0, 0.0], "hi": [1.0, 0.5], "rho_c": 0.0, "mono_x": {mono_x}, "mono_y": {mono_y}, "mono_std": [1.0, 0.1]}}"#
        );
        DriftLaw::from_json_str(&text).unwrap()
    }

    #[test]
    fn monostable_vote_is_the_label_of_the_nearest_sample_in_standardised_inputs() {
        let l = law("[[-3.0, 0.30], [-1.0, 0.40]]", "[1.0, 0.0]");
        assert!(l.monostable_at(&[-2.9, 0.31]));
        assert!(!l.monostable_at(&[-1.1, 0.39]));
        // Standardised by mono_std = [1, 0.1]: nearer the first sample (1.21 against 1.81),
        // although the second is nearer in raw units (0.82 against 1.21).
        assert!(l.monostable_at(&[-1.9, 0.30]));
        assert!(!law("[]", "[]").monostable_at(&[-3.0, 0.30]));
    }
}
