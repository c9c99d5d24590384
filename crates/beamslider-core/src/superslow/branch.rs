//! Results of the harmonic-balance manifold (docs/model.md §6.4): branches, folds (its
//! settings, [`HbOptions`], live with the system in `hb`).

pub use super::hb::HbOptions;
use super::hb::PointOut;

/// Points of one branch (or one continuation run), as arrays.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct HbBranch {
    /// Slider position s = x/L [-].
    pub s: Vec<f64>,
    /// Manifold amplitude Â = |Φ(4L/7)ᵀQ| / h [-].
    pub amplitude_h: Vec<f64>,
    /// Phase lag ϑ of w(4L/7) behind the inertial forcing a_ex cos Ωt (= −ẅ₀) [rad], in (−π, π].
    pub phase_rad: Vec<f64>,
    /// Stability flag: det ∂R/∂(Re Q, Im Q) > 0.
    pub stable: Vec<bool>,
    /// Re Qₙ, row-major (point, mode) [m kg^½].
    pub q_re: Vec<f64>,
    /// Im Qₙ, row-major (point, mode) [m kg^½].
    pub q_im: Vec<f64>,
    /// Multi-harmonic / sag runs only: |Φ(4L/7)ᵀQ_k| / h per harmonic order of
    /// [`HbManifold::harmonic_orders`] (for k = 0 the signed static value), row-major (point, order).
    pub harmonic_amplitude_h: Vec<f64>,
    /// Multi-harmonic / sag runs only: all unknowns in physical units (Re Q₁, Im Q₁, Re Q_k, Im Q_k
    /// for the other k ≥ 1 ascending, Q₀), row-major (point, unknown) [m kg^½].
    pub state: Vec<f64>,
}

impl HbBranch {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.s.len()
    }

    /// No points?
    pub fn is_empty(&self) -> bool {
        self.s.is_empty()
    }

    /// Amplitude Â at s by linear interpolation between the branch's points (None outside its
    /// s-range; the branch must be monotone in s, as the stable branches are between folds).
    pub fn amplitude_at(&self, s: f64) -> Option<f64> {
        let n = self.s.len();
        if n == 0 {
            return None;
        }
        for i in 0..n.saturating_sub(1) {
            let (a, b) = (self.s[i], self.s[i + 1]);
            let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
            if s >= lo && s <= hi {
                if hi == lo {
                    return Some(self.amplitude_h[i]);
                }
                let w = (s - a) / (b - a);
                return Some(self.amplitude_h[i] + w * (self.amplitude_h[i + 1] - self.amplitude_h[i]));
            }
        }
        if n == 1 && self.s[0] == s {
            return Some(self.amplitude_h[0]);
        }
        None
    }

    pub(super) fn push(&mut self, p: &PointOut) {
        self.s.push(p.s);
        self.amplitude_h.push(p.amplitude_h);
        self.phase_rad.push(p.phase_rad);
        self.stable.push(p.stable);
        self.q_re.extend_from_slice(&p.q_re);
        self.q_im.extend_from_slice(&p.q_im);
        self.harmonic_amplitude_h.extend_from_slice(&p.harm);
        self.state.extend_from_slice(&p.state);
    }
}

/// A fold (turning point) of the manifold.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Fold {
    /// Slider position [-].
    pub s: f64,
    /// Amplitude Â there [-].
    pub amplitude_h: f64,
}

/// The HB super-slow manifold at one excitation.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct HbManifold {
    /// High branch: from s[0] (near the clamping) up to its end (s_dn) or s[last].
    pub high: HbBranch,
    /// Low branch: from s[last] (the centre) down to its end (s_up) or s[0].
    pub low: HbBranch,
    /// Unstable middle branch between the folds (empty without coexistence).
    pub middle: HbBranch,
    /// The whole run from s[0] upwards (all folds included).
    pub up_run: HbBranch,
    /// The whole run from s[last] downwards.
    pub down_run: HbBranch,
    /// All folds found (both runs, duplicates removed), sorted by s.
    pub folds: Vec<Fold>,
    /// Jump-up position: where the low branch ends (None if it reaches s[0]).
    pub s_up: Option<f64>,
    /// Jump-down position: where the high branch ends (None if it reaches s[last]).
    pub s_dn: Option<f64>,
    /// Linear resonance positions: the lowest frequency of (Λ, M(s)) equals Ω.
    pub s_res: Vec<f64>,
    /// Range of the continuation [s[0], s[last]].
    pub s_range: (f64, f64),
    /// Retained modes.
    pub n_modes: usize,
    /// Continuation steps taken (both runs, fold refinement excluded).
    pub steps: usize,
    /// Anything that went wrong without making the result unusable (step caps, ...).
    pub warnings: Vec<String>,
    /// The grid s (with `sample_on_grid`).
    pub s_grid: Vec<f64>,
    /// Â of the high branch solved at each grid s (NaN where the branch does not exist).
    pub high_on_grid: Vec<f64>,
    /// Â of the low branch solved at each grid s (NaN where the branch does not exist).
    pub low_on_grid: Vec<f64>,
    /// Harmonic orders of the ansatz in the layout of [`HbBranch::harmonic_amplitude_h`]
    /// (empty for single-term HB).
    pub harmonic_orders: Vec<usize>,
}
