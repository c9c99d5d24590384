//! Layer (a) of issue 17: the super-slow manifold by harmonic balance (HB).
//!
//! On the super-slow scale the slider is taken as rigidly attached to the beam at x = sL
//! (issue 17 §2.1). A Ritz reduction with the N beam modes of docs/model.md §2 gives
//!
//! ```text
//! M(s) q̈ + C q̇ + Λ q + f_nl(q) = Γ(s) a_ex cos Ωt,
//! M(s) = I + m Φ(s)Φ(s)ᵀ + J_G Φ′(s)Φ′(s)ᵀ,  J_G = J_C + m d²,
//! Λ = diag(ωₙ²) + H₀ K,  C = diag(2Dₙωₙ),  Γ(s) = γ + m Φ(s),
//! f_nl(q) = (k_ax/2)(qᵀKq) K q,
//! ```
//!
//! with the project's extensions of docs/model.md §2: the axial preload H₀ adds H₀K to Λ, and the
//! amplitude-dependent damping D₂ (modal damping ratio D + 4D₂(w(L/2)/h)²) enters through the
//! exact first harmonic of its cubic term. The slider's weight is neglected (no static sag).
//!
//! * [`closed_form_n1`] — issue §2.2: one mode, one harmonic. With A = a², δ = ω² − M₁Ω²,
//!   c = 2DωΩ, F = (γ + mφ)a_ex, b = (k_ax/2)K₁₁²:
//!   (9/16)b²A³ + (3/2)bδA² + (δ² + c²)A − F² = 0; its real roots (all positive), the
//!   discriminant Δ, folds = zeros of Δ(s) bracketed on the s-grid and refined with Brent's
//!   method, s_res from M₁(s_res) = ω²/Ω², and the backbone Ω²M₁(s) = ω² + ¾ b a².
//! * [`hb_manifold`] — issue §2.3: N modes, one harmonic, q = Re(Q e^{iΩt}):
//!   R(Q, s) = (Λ − Ω²M(s) + iΩC)Q + (k_ax/8)[(QᵀKQ)KQ̄ + 2(QᴴKQ)KQ] − Γ(s)a_ex = 0,
//!   written in (Re Q, Im Q) with its analytic Jacobian (also ∂R/∂s), solved by
//!   pseudo-arclength continuation from s_min = B/(2L) up to 0.5 (the branch continuous with the
//!   high branch near the clamping) and from 0.5 down (the low branch, started at 0.5 by
//!   continuation in the forcing level from zero). Folds are where the s-component of the
//!   tangent changes sign, refined by Brent's method on it; a point is stable when
//!   det ∂R/∂(Re Q, Im Q) > 0 (sign between folds, issue §2.3).
//!
//! Options of issue §2.5: the equivalent damping D_eff (replaces Dₙ of all modes), a detuning
//! factor of ω₁ (for the sensitivity check of §4.6), multi-harmonic HB (`harmonics` = 3, 5, 7:
//! odd harmonics up to H) and the static sag under the slider's weight (`static_sag`, a zeroth
//! harmonic); the last two are solved by the alternating frequency–time residual of
//! [`superslow_mhb`](self) (module `superslow_mhb.rs`) with the same continuation.

#[path = "superslow_mhb.rs"]
mod mhb;

use std::cell::RefCell;

use nalgebra::{DMatrix, DVector, DVectorView};

use crate::beam::Beam;
use crate::error::{Error, Result};
use crate::params::{MAX_MODES, Params};

/// Settings of [`hb_manifold`].
#[derive(Debug, Clone, PartialEq)]
pub struct HbOptions {
    /// Retained beam modes N (1..=20; default 5).
    pub n_modes: usize,
    /// Harmonics of the HB ansatz: the odd harmonics 1, 3, …, H for H = `harmonics` ∈ {1, 3, 5, 7}
    /// (1 = single-term HB, the default; issue §2.5.2). With `static_sag`, all harmonics 0..=H.
    pub harmonics: usize,
    /// Equivalent damping ratio D_eff replacing Dₙ of all modes (issue §2.5.1); None = the
    /// parameters' damping_ratio.
    pub d_eff: Option<f64>,
    /// Factor on ω₁ (ω₁ → factor·ω₁, for the sensitivity check of issue §4.6; default 1).
    pub omega1_factor: f64,
    /// Slider positions, strictly increasing, within [B/(2L), 0.5]: the continuation runs over
    /// [s[0], s[last]] (default: 201 values from B/(2L) to 0.5).
    pub s: Option<Vec<f64>>,
    /// Cap of continuation steps per run (default 20 000).
    pub max_steps: usize,
    /// Largest arclength step in the scaled coordinates (Q/q_ref, s) (default 0.05).
    pub max_step: f64,
    /// Also solve the high and low branches exactly at every s of the grid
    /// ([`HbManifold::high_on_grid`], [`HbManifold::low_on_grid`]; default false).
    pub sample_on_grid: bool,
    /// Static sag under the slider's weight m·g at x = sL (issue §2.5.3; gravity acts on the
    /// slider only, MODEL.md §1): adds the zeroth harmonic Q₀ (default false).
    pub static_sag: bool,
    /// End the downward run at its first fold (s_up): the low branch, s_up and the high branch
    /// are the same, the middle (unstable) branch and later folds are left out (default false;
    /// the predictor uses it, about a third fewer continuation steps).
    pub low_branch_only: bool,
}

impl Default for HbOptions {
    fn default() -> Self {
        HbOptions {
            n_modes: 5,
            harmonics: 1,
            d_eff: None,
            omega1_factor: 1.0,
            s: None,
            max_steps: 20_000,
            max_step: 0.05,
            sample_on_grid: false,
            static_sag: false,
            low_branch_only: false,
        }
    }
}

/// Points of one branch (or one continuation run), as arrays.
#[derive(Debug, Clone, Default, PartialEq)]
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

    fn push(&mut self, p: &PointOut) {
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
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fold {
    /// Slider position [-].
    pub s: f64,
    /// Amplitude Â there [-].
    pub amplitude_h: f64,
}

/// The HB super-slow manifold at one excitation.
#[derive(Debug, Clone, Default, PartialEq)]
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

struct PointOut {
    s: f64,
    amplitude_h: f64,
    phase_rad: f64,
    stable: bool,
    q_re: Vec<f64>,
    q_im: Vec<f64>,
    harm: Vec<f64>,
    state: Vec<f64>,
}

/// The N-mode, single-harmonic HB system with the slider rigidly attached (issue §2.3).
#[derive(Debug, Clone)]
pub struct HbSystem {
    beam: std::sync::Arc<Beam>,
    n: usize,
    length: f64,
    thickness: f64,
    omega_ex: f64,
    a_ex: f64,
    mass: f64,
    j_g: f64,
    lam: DMatrix<f64>,
    e_diag: Vec<f64>,
    kmat: DMatrix<f64>,
    k_ax: f64,
    gamma: DVector<f64>,
    d2: Option<(Vec<f64>, Vec<f64>)>,
    p47: Vec<f64>,
    q_ref: f64,
    f_ref: f64,
    /// Multi-harmonic / static-sag residual (None: single-term HB).
    mhb: Option<mhb::Mhb>,
    /// Number of real unknowns (parameter excluded): 2N for single-term HB.
    nx: usize,
}

fn check_excitation(f_ex_hz: f64, a_ex: f64) -> Result<()> {
    if !(f_ex_hz.is_finite() && f_ex_hz > 0.0) {
        return Err(Error::invalid("f_ex", f_ex_hz, "excitation frequency must be finite and > 0 Hz"));
    }
    if !(a_ex.is_finite() && a_ex > 0.0) {
        return Err(Error::invalid("a_ex", a_ex, "base-acceleration amplitude must be finite and > 0 m/s^2"));
    }
    Ok(())
}

fn check_d_eff(d_eff: Option<f64>) -> Result<()> {
    if let Some(d) = d_eff
        && !(d.is_finite() && d >= 0.0)
    {
        return Err(Error::invalid("d_eff", d, "equivalent damping ratio must be finite and >= 0"));
    }
    Ok(())
}

impl HbSystem {
    /// Build the system for `params` (its n_modes replaced by `opts.n_modes`) at (f_ex, a_ex).
    pub fn new(params: &Params, f_ex_hz: f64, a_ex: f64, opts: &HbOptions) -> Result<HbSystem> {
        check_excitation(f_ex_hz, a_ex)?;
        if !(1..=MAX_MODES).contains(&opts.n_modes) {
            return Err(Error::invalid("n_modes", opts.n_modes, "must lie in 1..=20"));
        }
        if !matches!(opts.harmonics, 1 | 3 | 5 | 7) {
            return Err(Error::invalid(
                "harmonics",
                opts.harmonics,
                "must be 1, 3, 5 or 7 (odd harmonics up to H; even harmonics alone are not excited)",
            ));
        }
        check_d_eff(opts.d_eff)?;
        if !(opts.omega1_factor.is_finite() && opts.omega1_factor > 0.0) {
            return Err(Error::invalid("omega1_factor", opts.omega1_factor, "must be finite and > 0"));
        }
        let p = Params { n_modes: opts.n_modes, ..params.clone() };
        let beam = Beam::shared(&p)?;
        let n = beam.n;
        let omega_ex = 2.0 * std::f64::consts::PI * f_ex_hz;
        let mut omega = beam.omega.clone();
        omega[0] *= opts.omega1_factor;
        let mut lam = beam.linear_stiffness();
        lam[(0, 0)] += omega[0] * omega[0] - beam.omega[0] * beam.omega[0];
        let d = opts.d_eff.unwrap_or(p.damping_ratio);
        let e_diag = omega.iter().map(|w| omega_ex * 2.0 * d * w).collect();
        let x_mid = 0.5 * p.length_m;
        let d2 = (p.damping_ratio_quadratic > 0.0).then(|| {
            let kappa = omega
                .iter()
                .map(|w| 2.0 * w * p.damping_ratio_quadratic * omega_ex / (p.thickness_m * p.thickness_m))
                .collect();
            (kappa, beam.phi_row(x_mid))
        });
        let p47 = beam.phi_row(4.0 / 7.0 * p.length_m);
        let phi_max = (0..=200)
            .map(|i| beam.phi_exact(0, p.length_m * i as f64 / 200.0).abs())
            .fold(0.0, f64::max);
        let q_ref = p.thickness_m / phi_max;
        let f_ref = omega[0] * omega[0] * q_ref;
        let mhb = (opts.harmonics > 1 || opts.static_sag)
            .then(|| mhb::Mhb::new(n, opts.harmonics, opts.static_sag, p.slider_mass_kg * p.gravity_m_s2));
        let nx = mhb.as_ref().map_or(2 * n, |m| m.nx);
        Ok(HbSystem {
            n,
            length: p.length_m,
            thickness: p.thickness_m,
            omega_ex,
            a_ex,
            mass: p.slider_mass_kg,
            j_g: p.slider_inertia_centre_kg_m2(),
            lam,
            e_diag,
            kmat: beam.k_matrix(),
            k_ax: beam.k_ax,
            gamma: DVector::from_vec(beam.gamma.clone()),
            d2,
            p47,
            q_ref,
            f_ref,
            mhb,
            nx,
            beam,
        })
    }

    /// Number of modes N.
    pub fn n_modes(&self) -> usize {
        self.n
    }

    /// The beam (N modes).
    pub fn beam(&self) -> &Beam {
        &self.beam
    }

    /// Mass matrix M(s) = I + mΦΦᵀ + J_G Φ′Φ′ᵀ.
    pub fn mass_matrix(&self, s: f64) -> DMatrix<f64> {
        let x = s * self.length;
        let phi = DVector::from_vec(self.beam.phi_row(x));
        let dphi = DVector::from_vec(self.beam.dphi_row(x));
        DMatrix::identity(self.n, self.n) + self.mass * &phi * phi.transpose() + self.j_g * &dphi * dphi.transpose()
    }

    /// Residual R(Q, s) in physical units [N kg^-½]: (Re R, Im R) of issue §2.3 for Q = u + iv,
    /// with the forcing scaled by `load` (1 = the excitation).
    pub fn residual(&self, u: &[f64], v: &[f64], s: f64, load: f64) -> (Vec<f64>, Vec<f64>) {
        let y = self.scaled_state(&[&u[..self.n], &v[..self.n]].concat(), s);
        let (r, _) = self.eval(&y, Param::S { load }, false);
        let re = (0..self.n).map(|i| r[i] * self.f_ref).collect();
        let im = (0..self.n).map(|i| r[self.n + i] * self.f_ref).collect();
        (re, im)
    }

    /// Jacobian ∂(Re R, Im R)/∂(Re Q, Im Q, s) in physical units (2N × (2N+1)).
    pub fn jacobian(&self, u: &[f64], v: &[f64], s: f64) -> DMatrix<f64> {
        self.jacobian_state(&[&u[..self.n], &v[..self.n]].concat(), s)
    }

    /// Number of real unknowns: 2N for single-term HB, more with harmonics or the static sag
    /// (layout of [`HbBranch::state`]).
    pub fn n_unknowns(&self) -> usize {
        self.nx
    }

    /// Residual of all unknowns `x` (physical units, layout of [`HbBranch::state`]; for single-term
    /// HB (Re Q, Im Q)) at s [N kg^-½].
    pub fn residual_state(&self, x: &[f64], s: f64) -> Vec<f64> {
        let y = self.scaled_state(x, s);
        let (r, _) = self.eval(&y, Param::S { load: 1.0 }, false);
        r.iter().map(|v| v * self.f_ref).collect()
    }

    /// Jacobian ∂R/∂(x, s) of [`HbSystem::residual_state`] (nx × (nx + 1), physical units).
    pub fn jacobian_state(&self, x: &[f64], s: f64) -> DMatrix<f64> {
        let y = self.scaled_state(x, s);
        let (_, j) = self.eval(&y, Param::S { load: 1.0 }, true);
        let mut out = j * self.f_ref;
        for c in 0..self.nx {
            for r in 0..self.nx {
                out[(r, c)] /= self.q_ref;
            }
        }
        out
    }

    fn scaled_state(&self, x: &[f64], s: f64) -> DVector<f64> {
        let mut y = DVector::zeros(self.nx + 1);
        for (i, v) in x.iter().take(self.nx).enumerate() {
            y[i] = v / self.q_ref;
        }
        y[self.nx] = s;
        y
    }

    /// Solve R(Q, s) = 0 at fixed s by Newton's method from a guess (u, v); returns (u, v).
    pub fn solve_point(&self, s: f64, u: &[f64], v: &[f64]) -> Result<(Vec<f64>, Vec<f64>)> {
        let mut y = DVector::zeros(self.nx + 1);
        for i in 0..self.n {
            y[i] = u[i] / self.q_ref;
            y[self.n + i] = v[i] / self.q_ref;
        }
        y[self.nx] = s;
        let y = self
            .newton_fixed(&y, Param::S { load: 1.0 })
            .ok_or_else(|| Error::Numerical(format!("HB Newton did not converge at s = {s}")))?;
        Ok(self.uv(&y))
    }

    /// Single-mode backbone with the slider (issue §2.2): Ω_bb(Â, s) =
    /// √((ω₁² + H₀K₁₁ + ¾ b a²)/M₁(s)), a = Â h/|φ₁(4L/7)| [rad/s].
    pub fn backbone_omega(&self, amplitude_h: f64, s: f64) -> f64 {
        let x = s * self.length;
        let (phi, dphi) = (self.beam.phi_exact(0, x), self.beam.dphi_exact(0, x));
        let m1 = 1.0 + self.mass * phi * phi + self.j_g * dphi * dphi;
        let a = amplitude_h * self.thickness / self.p47[0].abs();
        ((self.lam[(0, 0)] + 0.75 * self.beam.hardening_b() * a * a) / m1).sqrt()
    }

    fn uv(&self, y: &DVector<f64>) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        ((0..n).map(|i| y[i] * self.q_ref).collect(), (0..n).map(|i| y[n + i] * self.q_ref).collect())
    }

    /// Scaled residual r = R/f_ref and (optionally) the scaled Jacobian [∂r/∂x | ∂r/∂p] of the
    /// unknowns y = (Re Q/q_ref, Im Q/q_ref, p), p = s or the load factor.
    fn eval(&self, y: &DVector<f64>, par: Param, want_j: bool) -> (DVector<f64>, DMatrix<f64>) {
        let mut w = EvalWork::new(self);
        self.eval_into(y, par, want_j, &mut w);
        (w.r, if want_j { w.j } else { DMatrix::zeros(0, 0) })
    }

    /// [`HbSystem::eval`] into the buffers of `w` (`w.r`, and `w.j` when `want_j`), without
    /// allocating (single-term HB).
    fn eval_into(&self, y: &DVector<f64>, par: Param, want_j: bool, w: &mut EvalWork) {
        if let Some(m) = &self.mhb {
            let (r, j) = m.eval(self, y, par, want_j);
            w.r = r;
            if want_j {
                w.j = j;
            }
            return;
        }
        // The default five modes with N as a constant (unrolled loops, no bounds checks).
        match self.n {
            5 => self.eval_single(5, y, par, want_j, w),
            n => self.eval_single(n, y, par, want_j, w),
        }
    }

    /// Body of [`HbSystem::eval_into`] for single-term HB with N = `n` (= self.n). Matrices are
    /// read column-major as slices ((r, c) of an n-row matrix at c·n + r).
    #[inline(always)]
    fn eval_single(&self, n: usize, y: &DVector<f64>, par: Param, want_j: bool, w: &mut EvalWork) {
        let (s, load) = match par {
            Param::S { load } => (y[2 * n], load),
            Param::Load { s } => (s, y[2 * n]),
        };
        let q = self.q_ref;
        for i in 0..n {
            w.u[i] = y[i] * q;
            w.v[i] = y[n + i] * q;
        }
        let x = s * self.length;
        self.beam.shapes_exact(x, w.phi.as_mut_slice(), w.dphi.as_mut_slice(), w.ddphi.as_mut_slice());
        let om2 = self.omega_ex * self.omega_ex;
        let lam = &self.lam.as_slice()[..n * n];
        let kmat = &self.kmat.as_slice()[..n * n];
        let (gamma, e_diag) = (&self.gamma.as_slice()[..n], &self.e_diag[..n]);
        let EvalWork { u, v, phi, dphi, ddphi, gamma_s, ku, kv, zu, zv, z, r, j } = w;
        let (phi, dphi, ddphi) = (&phi.as_slice()[..n], &dphi.as_slice()[..n], &ddphi.as_slice()[..n]);
        // Z = Λ − Ω² M(s).
        let z = &mut z.as_mut_slice()[..n * n];
        for c in 0..n {
            for r in 0..n {
                let mrc = self.mass * phi[r] * phi[c] + self.j_g * dphi[r] * dphi[c] + if r == c { 1.0 } else { 0.0 };
                z[c * n + r] = lam[c * n + r] - om2 * mrc;
            }
        }
        let gamma_s = &mut gamma_s.as_mut_slice()[..n];
        for i in 0..n {
            gamma_s[i] = gamma[i] + self.mass * phi[i];
        }
        matvec(kmat, u.as_slice(), ku.as_mut_slice(), n);
        matvec(kmat, v.as_slice(), kv.as_mut_slice(), n);
        let a = u.dot(ku);
        let b = v.dot(kv);
        let p = u.dot(kv);
        let c = self.k_ax / 8.0;
        matvec(z, u.as_slice(), zu.as_mut_slice(), n);
        matvec(z, v.as_slice(), zv.as_mut_slice(), n);
        let (us, vs) = (&u.as_slice()[..n], &v.as_slice()[..n]);
        let (ku, kv, zu, zv) = (&ku.as_slice()[..n], &kv.as_slice()[..n], &zu.as_slice()[..n], &zv.as_slice()[..n]);
        let rs = &mut r.as_mut_slice()[..2 * n];
        for i in 0..n {
            rs[i] = zu[i] - e_diag[i] * vs[i] + c * ((3.0 * a + b) * ku[i] + 2.0 * p * kv[i]) - load * gamma_s[i] * self.a_ex;
            rs[n + i] = zv[i] + e_diag[i] * us[i] + c * (2.0 * p * ku[i] + (a + 3.0 * b) * kv[i]);
        }
        let (wr, wi) = match &self.d2 {
            Some((kappa, pm)) => {
                let wr = pm.iter().zip(us).map(|(a, b)| a * b).sum::<f64>();
                let wi = pm.iter().zip(vs).map(|(a, b)| a * b).sum::<f64>();
                for i in 0..n {
                    rs[i] += kappa[i] * (2.0 * wr * wi * us[i] - (3.0 * wr * wr + wi * wi) * vs[i]);
                    rs[n + i] += kappa[i] * ((wr * wr + 3.0 * wi * wi) * us[i] - 2.0 * wr * wi * vs[i]);
                }
                (wr, wi)
            }
            None => (0.0, 0.0),
        };
        for x in rs.iter_mut() {
            *x /= self.f_ref;
        }
        if !want_j {
            return;
        }
        // J: 2N rows, 2N + 1 columns, (row, col) at col·2N + row.
        let m = 2 * n;
        let j = &mut j.as_mut_slice()[..m * (m + 1)];
        for col in 0..n {
            for row in 0..n {
                let (kk, zz) = (kmat[col * n + row], z[col * n + row]);
                let juu = zz + c * ((3.0 * a + b) * kk + 6.0 * ku[row] * ku[col] + 2.0 * kv[row] * kv[col]);
                let juv = c * (2.0 * ku[row] * kv[col] + 2.0 * kv[row] * ku[col] + 2.0 * p * kk);
                let jvv = zz + c * (2.0 * ku[row] * ku[col] + (a + 3.0 * b) * kk + 6.0 * kv[row] * kv[col]);
                j[col * m + row] = juu;
                j[(n + col) * m + row] = juv;
                j[col * m + n + row] = juv;
                j[(n + col) * m + n + row] = jvv;
            }
            j[(n + col) * m + col] -= e_diag[col];
            j[col * m + n + col] += e_diag[col];
        }
        if let Some((kappa, pm)) = &self.d2 {
            for row in 0..n {
                let k = kappa[row];
                let (ur, vr) = (us[row], vs[row]);
                for col in 0..n {
                    let pj = pm[col];
                    let dl = if row == col { 1.0 } else { 0.0 };
                    j[col * m + row] += k * (2.0 * wi * pj * ur + 2.0 * wr * wi * dl - 6.0 * wr * pj * vr);
                    j[(n + col) * m + row] += k * (2.0 * wr * pj * ur - 2.0 * wi * pj * vr - (3.0 * wr * wr + wi * wi) * dl);
                    j[col * m + n + row] += k * (2.0 * wr * pj * ur + (wr * wr + 3.0 * wi * wi) * dl - 2.0 * wi * pj * vr);
                    j[(n + col) * m + n + row] += k * (6.0 * wi * pj * ur - 2.0 * wr * pj * vr - 2.0 * wr * wi * dl);
                }
            }
        }
        // Unknowns are x = u/q: ∂/∂x = q ∂/∂u; residual scaled by 1/f_ref.
        let sx = q / self.f_ref;
        for x in &mut j[..m * m] {
            *x *= sx;
        }
        // Parameter column.
        let jp = &mut j[m * m..];
        match par {
            Param::S { load } => {
                let l = self.length;
                // dM/ds w = L[m(Φ′(Φ·w) + Φ(Φ′·w)) + J_G(Φ″(Φ′·w) + Φ′(Φ″·w))], for w = u and v.
                let dot = |a: &[f64], b: &[f64]| DVectorView::from_slice(a, n).dot(&DVectorView::from_slice(b, n));
                let (pu, du, ddu) = (dot(phi, us), dot(dphi, us), dot(ddphi, us));
                let (pv, dv, ddv) = (dot(phi, vs), dot(dphi, vs), dot(ddphi, vs));
                let dm = |i: usize, pw: f64, dw: f64, ddw: f64| {
                    (self.mass * (dphi[i] * pw + phi[i] * dw) + self.j_g * (ddphi[i] * dw + dphi[i] * ddw)) * l
                };
                for i in 0..n {
                    let (dmu, dmv) = (dm(i, pu, du, ddu), dm(i, pv, dv, ddv));
                    jp[i] = (-om2 * dmu - load * l * self.mass * dphi[i] * self.a_ex) / self.f_ref;
                    jp[n + i] = -om2 * dmv / self.f_ref;
                }
            }
            Param::Load { .. } => {
                for i in 0..n {
                    jp[i] = -gamma_s[i] * self.a_ex / self.f_ref;
                    jp[n + i] = 0.0;
                }
            }
        }
    }

    /// Newton at fixed parameter (the last entry of y).
    fn newton_fixed(&self, y0: &DVector<f64>, par: Param) -> Option<DVector<f64>> {
        let n2 = self.nx;
        let mut y = y0.clone();
        let mut w = EvalWork::new(self);
        let mut lu = LuWork::new(n2);
        let mut dx = DVector::zeros(n2);
        // At a fold (singular Jacobian) Newton converges only linearly: allow many iterations
        // and accept a small residual.
        for _ in 0..60 {
            self.eval_into(&y, par, true, &mut w);
            lu.a.copy_from(&w.j.columns(0, n2));
            for i in 0..n2 {
                dx[i] = -w.r[i];
            }
            if !lu.factor_solve(&mut dx) {
                return None;
            }
            if !dx.iter().all(|d| d.is_finite()) {
                return None;
            }
            for i in 0..n2 {
                y[i] += dx[i];
            }
            if dx.amax() <= 1e-12 * (1.0 + y.rows(0, n2).amax()) {
                return Some(y);
            }
        }
        self.eval_into(&y, par, false, &mut w);
        (w.r.amax() <= 1e-10).then_some(y)
    }

    /// Complex amplitude of w(4L/7) (scaled) of the unknowns y.
    fn w47(&self, y: &DVector<f64>) -> (f64, f64) {
        let n = self.n;
        let wr: f64 = (0..n).map(|i| self.p47[i] * y[i]).sum();
        let wi: f64 = (0..n).map(|i| self.p47[i] * y[n + i]).sum();
        (wr, wi)
    }

    /// Step acceptance on the response: w(4L/7) changes its phase by at most 0.15 rad and its
    /// modulus by at most 25 %.
    fn response_close(&self, a: &DVector<f64>, b: &DVector<f64>) -> bool {
        let (ar, ai) = self.w47(a);
        let (br, bi) = self.w47(b);
        let (ma, mb) = (ar.hypot(ai), br.hypot(bi));
        if ma == 0.0 || mb == 0.0 {
            return true;
        }
        // arg(b/a) = atan2(Im(b ā), Re(b ā)).
        let dphase = (bi * ar - br * ai).atan2(br * ar + bi * ai).abs();
        dphase <= 0.15 && (mb / ma).ln().abs() <= 0.25
    }

    fn point_out(&self, y: &DVector<f64>, stable: bool) -> PointOut {
        let (u, v) = self.uv(y);
        let wr: f64 = self.p47.iter().zip(&u).map(|(a, b)| a * b).sum();
        let wi: f64 = self.p47.iter().zip(&v).map(|(a, b)| a * b).sum();
        PointOut {
            s: y[self.nx],
            amplitude_h: wr.hypot(wi) / self.thickness,
            phase_rad: -wi.atan2(wr),
            stable,
            q_re: u,
            q_im: v,
            harm: self.mhb.as_ref().map_or_else(Vec::new, |m| m.harmonic_amplitudes(self, y)),
            state: if self.mhb.is_some() { (0..self.nx).map(|i| y[i] * self.q_ref).collect() } else { Vec::new() },
        }
    }

    /// Lowest natural angular frequency of (Λ, M(s)) [rad/s].
    pub fn linear_frequency(&self, s: f64) -> f64 {
        let m = self.mass_matrix(s);
        let Some(ch) = m.cholesky() else { return f64::NAN };
        let Some(li) = ch.l().try_inverse() else { return f64::NAN };
        let a = &li * &self.lam * li.transpose();
        let a = (&a + a.transpose()) * 0.5;
        a.symmetric_eigenvalues().min().max(0.0).sqrt()
    }
}

#[derive(Debug, Clone, Copy)]
enum Param {
    /// Continuation parameter s; forcing scaled by `load`.
    S { load: f64 },
    /// Continuation parameter: load factor at fixed s.
    Load { s: f64 },
}

/// Buffers of [`HbSystem::eval_into`]: the residual `r`, the Jacobian `j` and the intermediates.
struct EvalWork {
    u: DVector<f64>,
    v: DVector<f64>,
    phi: DVector<f64>,
    dphi: DVector<f64>,
    ddphi: DVector<f64>,
    gamma_s: DVector<f64>,
    ku: DVector<f64>,
    kv: DVector<f64>,
    zu: DVector<f64>,
    zv: DVector<f64>,
    z: DMatrix<f64>,
    r: DVector<f64>,
    j: DMatrix<f64>,
}

impl EvalWork {
    fn new(sys: &HbSystem) -> EvalWork {
        let (n, nx) = (sys.n, sys.nx);
        let vn = || DVector::zeros(n);
        EvalWork {
            u: vn(),
            v: vn(),
            phi: vn(),
            dphi: vn(),
            ddphi: vn(),
            gamma_s: vn(),
            ku: vn(),
            kv: vn(),
            zu: vn(),
            zv: vn(),
            z: DMatrix::zeros(n, n),
            r: DVector::zeros(nx),
            j: DMatrix::zeros(nx, nx + 1),
        }
    }
}

/// LU factorisation with partial pivoting, in place on a reused square matrix `a`: the operations
/// of nalgebra's `LU::new`, `solve` and `determinant` in the same order (pivot = the first entry
/// of largest modulus, multipliers scaled by the pivot's reciprocal, a zero pivot column skipped,
/// the same triangular solves), so the results are bitwise equal, without allocating.
struct LuWork {
    a: DMatrix<f64>,
    swaps: Vec<(usize, usize)>,
}

impl LuWork {
    fn new(d: usize) -> LuWork {
        LuWork { a: DMatrix::zeros(d, d), swaps: Vec::with_capacity(d) }
    }

    /// a = [j; borderᵀ] (j with one row fewer than a).
    fn load_bordered(&mut self, j: &DMatrix<f64>, border: &DVector<f64>) {
        let d = self.a.nrows();
        for ((col, jc), b) in self.a.as_mut_slice().chunks_exact_mut(d).zip(j.as_slice().chunks_exact(d - 1)).zip(border.iter()) {
            col[..d - 1].copy_from_slice(jc);
            col[d - 1] = *b;
        }
    }

    /// Factorise `a` in place (L below the diagonal with a unit diagonal, U on and above it).
    fn factor(&mut self) {
        let d = self.a.nrows();
        let a = self.a.as_mut_slice();
        // The sizes of the default five modes as constants (unrolled loops).
        match d {
            10 => lu_factor(a, 10, &mut self.swaps),
            11 => lu_factor(a, 11, &mut self.swaps),
            d => lu_factor(a, d, &mut self.swaps),
        }
    }

    /// Determinant of the factorised matrix.
    fn determinant(&self) -> f64 {
        let mut det = 1.0;
        for i in 0..self.a.nrows() {
            det *= self.a[(i, i)];
        }
        det * if self.swaps.len().is_multiple_of(2) { 1.0 } else { -1.0 }
    }

    /// Solve with the factorised matrix, b overwritten by the solution; false on a zero pivot.
    fn solve(&self, b: &mut DVector<f64>) -> bool {
        for &(i, p) in &self.swaps {
            b.swap_rows(i, p);
        }
        let (a, b) = (self.a.as_slice(), b.as_mut_slice());
        match self.a.nrows() {
            10 => lu_solve(a, 10, b),
            11 => lu_solve(a, 11, b),
            d => lu_solve(a, d, b),
        }
    }

    fn factor_solve(&mut self, b: &mut DVector<f64>) -> bool {
        self.factor();
        self.solve(b)
    }
}

/// out = a·x for the n×n column-major `a`, summed as nalgebra's matrix–vector product (column
/// by column: out = a₀x₀, then out += aⱼxⱼ), so bitwise equal to it.
#[inline(always)]
fn matvec(a: &[f64], x: &[f64], out: &mut [f64], n: usize) {
    let (a, x, out) = (&a[..n * n], &x[..n], &mut out[..n]);
    for (o, aij) in out.iter_mut().zip(&a[..n]) {
        *o = aij * x[0];
    }
    for (col, xj) in a.chunks_exact(n).zip(x).skip(1) {
        for (o, aij) in out.iter_mut().zip(col) {
            *o += aij * xj;
        }
    }
}

/// Body of [`LuWork::factor`] on the column-major d×d `a` ((r, c) at c·d + r).
#[inline(always)]
fn lu_factor(a: &mut [f64], d: usize, swaps: &mut Vec<(usize, usize)>) {
    let a = &mut a[..d * d];
    swaps.clear();
    for i in 0..d {
        let col = &a[i * d..(i + 1) * d];
        let (mut piv, mut max) = (i, col[i].abs());
        for (r, x) in col.iter().enumerate().skip(i + 1) {
            if x.abs() > max {
                (piv, max) = (r, x.abs());
            }
        }
        let diag = col[piv];
        if diag == 0.0 {
            continue;
        }
        if piv != i {
            swaps.push((i, piv));
            for c in 0..d {
                a.swap(c * d + i, c * d + piv);
            }
        }
        let inv_diag = 1.0 / diag;
        for x in &mut a[i * d + i + 1..(i + 1) * d] {
            *x *= inv_diag;
        }
        let (left, right) = a.split_at_mut((i + 1) * d);
        let coeffs = &left[i * d + i + 1..];
        for col in right.chunks_exact_mut(d) {
            let p = col[i];
            for (y, l) in col[i + 1..].iter_mut().zip(coeffs) {
                *y += -p * l;
            }
        }
    }
}

/// Triangular solves of [`LuWork::solve`] (rows of b already permuted).
#[inline(always)]
fn lu_solve(a: &[f64], d: usize, b: &mut [f64]) -> bool {
    let (a, b) = (&a[..d * d], &mut b[..d]);
    for i in 0..d - 1 {
        let coeff = b[i];
        for (y, l) in b[i + 1..].iter_mut().zip(&a[i * d + i + 1..(i + 1) * d]) {
            *y += -coeff * l;
        }
    }
    for i in (0..d).rev() {
        let diag = a[i * d + i];
        if diag == 0.0 {
            return false;
        }
        let coeff = b[i] / diag;
        b[i] = coeff;
        for (y, u) in b[..i].iter_mut().zip(&a[i * d..i * d + i]) {
            *y += -coeff * u;
        }
    }
    true
}

/// Reused buffers of one continuation.
struct ContWork {
    eval: EvalWork,
    /// The bordered (nx + 1)-square systems of the corrector and the tangent.
    bordered: LuWork,
    /// ∂R/∂x alone (stability).
    jx: LuWork,
    rhs: DVector<f64>,
    diff: DVector<f64>,
}

impl ContWork {
    fn new(sys: &HbSystem) -> RefCell<ContWork> {
        let d = sys.nx + 1;
        RefCell::new(ContWork {
            eval: EvalWork::new(sys),
            bordered: LuWork::new(d),
            jx: LuWork::new(sys.nx),
            rhs: DVector::zeros(d),
            diff: DVector::zeros(d),
        })
    }
}

struct Corrected {
    y: DVector<f64>,
    j: DMatrix<f64>,
    iters: usize,
}

struct Run {
    points: Vec<(DVector<f64>, bool)>,
    folds: Vec<DVector<f64>>,
    /// Index into `points` of each fold (the fold point itself is inserted into `points`).
    fold_idx: Vec<usize>,
    complete: bool,
    steps: usize,
}

/// Pseudo-arclength continuation of the HB system.
struct Continuation<'a> {
    sys: &'a HbSystem,
    par: Param,
    max_steps: usize,
    h_max: f64,
    h_min: f64,
    /// Stop (complete) right after the first fold.
    stop_at_fold: bool,
    work: RefCell<ContWork>,
}

impl Continuation<'_> {
    fn dim(&self) -> usize {
        self.sys.nx + 1
    }

    /// Newton on [R(y); tᵀ(y − y_pred)] = 0 from y_pred.
    fn correct(&self, y_pred: &DVector<f64>, t: &DVector<f64>) -> Option<Corrected> {
        self.newton(y_pred, y_pred, t, 12, 1e-11)
    }

    /// Newton on [R(y); tᵀ(y − y_pred)] = 0 from `start`, at most `max_iter` iterations, converged
    /// when the step is below `tol` · (1 + max|y|).
    fn newton(&self, start: &DVector<f64>, y_pred: &DVector<f64>, t: &DVector<f64>, max_iter: usize, tol: f64) -> Option<Corrected> {
        let d = self.dim();
        let mut y = start.clone();
        let ws = &mut *self.work.borrow_mut();
        for it in 0..max_iter {
            self.sys.eval_into(&y, self.par, true, &mut ws.eval);
            ws.bordered.load_bordered(&ws.eval.j, t);
            for i in 0..d - 1 {
                ws.rhs[i] = -ws.eval.r[i];
            }
            for i in 0..d {
                ws.diff[i] = y[i] - y_pred[i];
            }
            ws.rhs[d - 1] = -t.dot(&ws.diff);
            if !ws.bordered.factor_solve(&mut ws.rhs) {
                return None;
            }
            let dy = &ws.rhs;
            if !dy.iter().all(|v| v.is_finite()) {
                return None;
            }
            y += dy;
            if dy.amax() <= tol * (1.0 + y.amax()) {
                self.sys.eval_into(&y, self.par, true, &mut ws.eval);
                return Some(Corrected { y, j: ws.eval.j.clone(), iters: it + 1 });
            }
        }
        None
    }

    /// Unit tangent: [J; borderᵀ] t = e_last; with the stability flag det ∂R/∂x > 0, from the
    /// same factorisation (Cramer: t_p = det(∂R/∂x)/det[J; borderᵀ] before normalising).
    fn tangent_stable(&self, j: &DMatrix<f64>, border: &DVector<f64>) -> Option<(DVector<f64>, bool)> {
        let d = self.dim();
        let lu = &mut self.work.borrow_mut().bordered;
        lu.load_bordered(j, border);
        lu.factor();
        let det_a = lu.determinant();
        let mut t = DVector::zeros(d);
        t[d - 1] = 1.0;
        if !lu.solve(&mut t) {
            return None;
        }
        let nrm = t.norm();
        let stable = t[d - 1] * det_a > 0.0;
        (nrm.is_finite() && nrm > 0.0).then(|| {
            t /= nrm;
            (t, stable)
        })
    }

    fn tangent(&self, j: &DMatrix<f64>, border: &DVector<f64>) -> Option<DVector<f64>> {
        self.tangent_stable(j, border).map(|(t, _)| t)
    }

    fn stable(&self, j: &DMatrix<f64>) -> bool {
        let lu = &mut self.work.borrow_mut().jx;
        lu.a.copy_from(&j.columns(0, self.sys.nx));
        lu.factor();
        lu.determinant() > 0.0
    }

    /// Fold between (ya, ta) and yb: zero of the tangent's parameter component along the
    /// hyperplanes taᵀ(y − ya) = σ, by Brent's method in σ.
    fn refine_fold(&self, ya: &DVector<f64>, ta: &DVector<f64>, yb: &DVector<f64>) -> Option<DVector<f64>> {
        let d = self.dim();
        let sigma_b = ta.dot(&(yb - ya));
        let point = |sigma: f64| -> Option<(DVector<f64>, f64)> {
            let w = if sigma_b != 0.0 { sigma / sigma_b } else { 0.0 };
            let guess = ya + (yb - ya) * w;
            let y_pred = ya + ta * sigma;
            // Start from the chord point; the hyperplane is taᵀ(y − y_pred) = 0.
            let c = self.correct_from(&guess, &y_pred, ta)?;
            let t = self.tangent(&c.j, ta)?;
            Some((c.y, t[d - 1]))
        };
        let f = |sigma: f64| point(sigma).map(|p| p.1).unwrap_or(f64::NAN);
        let sig = brent(f, 0.0, sigma_b, 1e-14 * sigma_b.abs().max(1e-300), 100).ok()?;
        point(sig).map(|p| p.0)
    }

    fn correct_from(&self, start: &DVector<f64>, y_pred: &DVector<f64>, t: &DVector<f64>) -> Option<Corrected> {
        self.newton(start, y_pred, t, 15, 1e-13)
    }

    /// Trace from y0 in the direction of increasing (dir > 0) or decreasing parameter until it
    /// leaves [p_lo, p_hi]; the exit point is solved exactly at the bound.
    fn trace(&self, y0: DVector<f64>, dir: f64, p_lo: f64, p_hi: f64) -> Run {
        let d = self.dim();
        let mut run = Run { points: Vec::new(), folds: Vec::new(), fold_idx: Vec::new(), complete: false, steps: 0 };
        let (_, j0) = self.sys.eval(&y0, self.par, true);
        let mut border = DVector::zeros(d);
        border[d - 1] = dir;
        let Some(mut t) = self.tangent(&j0, &border) else {
            return run;
        };
        run.points.push((y0.clone(), self.stable(&j0)));
        let mut y = y0;
        let mut h = (0.25 * self.h_max).min(0.01);
        while run.steps < self.max_steps {
            run.steps += 1;
            let y_pred = &y + &t * h;
            let Some(c) = self.correct(&y_pred, &t) else {
                h *= 0.5;
                if h < self.h_min {
                    return run;
                }
                continue;
            };
            let Some((t_new, st)) = self.tangent_stable(&c.j, &t) else {
                h *= 0.5;
                if h < self.h_min {
                    return run;
                }
                continue;
            };
            if t.dot(&t_new) < 0.97 && h > 4.0 * self.h_min {
                h *= 0.5;
                continue;
            }
            // Resolve the response, not only the arclength: near a weakly forced resonance the
            // curve is flat at the arclength scale but its phase turns by π over a tiny s-range
            // (a step over it would miss a narrow fold pair).
            if matches!(self.par, Param::S { .. }) && h > 4.0 * self.h_min && !self.sys.response_close(&y, &c.y) {
                h *= 0.5;
                continue;
            }
            let p_new = c.y[d - 1];
            if p_new > p_hi || p_new < p_lo {
                let bound = if p_new > p_hi { p_hi } else { p_lo };
                let w = (bound - y[d - 1]) / (p_new - y[d - 1]);
                let mut guess = &y + (&c.y - &y) * w;
                guess[d - 1] = bound;
                if let Some(yb) = self.sys.newton_fixed(&guess, self.par) {
                    let (_, jb) = self.sys.eval(&yb, self.par, true);
                    run.points.push((yb, self.stable(&jb)));
                }
                run.complete = true;
                return run;
            }
            if t[d - 1] * t_new[d - 1] < 0.0 || t_new[d - 1] == 0.0 {
                if let Some(yf) = self.refine_fold(&y, &t, &c.y) {
                    run.fold_idx.push(run.points.len());
                    run.points.push((yf.clone(), true));
                    run.folds.push(yf);
                } else {
                    // Refinement failed: take the chord midpoint as the fold (flagged by the
                    // caller through the tolerance of its tests).
                    let ym = (&y + &c.y) * 0.5;
                    run.fold_idx.push(run.points.len());
                    run.points.push((ym.clone(), true));
                    run.folds.push(ym);
                }
                if self.stop_at_fold {
                    run.complete = true;
                    return run;
                }
            }
            run.points.push((c.y.clone(), st));
            y = c.y;
            t = t_new;
            h = if c.iters <= 3 { (h * 1.5).min(self.h_max) } else if c.iters >= 6 { h * 0.6 } else { h };
        }
        run
    }
}

/// Solution at fixed s by continuation in the load factor from 0 to its first arrival at 1
/// (the lowest-amplitude solution reached from rest).
fn solve_from_rest(sys: &HbSystem, s: f64, opts: &HbOptions) -> Result<DVector<f64>> {
    let n2 = sys.nx;
    let cont = Continuation { sys, par: Param::Load { s }, max_steps: opts.max_steps, h_max: opts.max_step * 5.0, h_min: 1e-10, stop_at_fold: false, work: ContWork::new(sys) };
    let y0 = DVector::zeros(n2 + 1);
    let run = cont.trace(y0, 1.0, -1.0, 1.0);
    if !run.complete {
        return Err(Error::Numerical(format!(
            "HB: continuation in the excitation level at s = {s} did not reach a_ex within {} steps",
            run.steps
        )));
    }
    let (y, _) = run.points.last().cloned().ok_or_else(|| Error::Numerical("HB: empty load continuation".into()))?;
    if (y[n2] - 1.0).abs() > 1e-12 {
        return Err(Error::Numerical(format!("HB: load continuation at s = {s} ended at load {}", y[n2])));
    }
    let mut out = y;
    out[n2] = s;
    Ok(out)
}

fn check_grid(s: &[f64], lo: f64, hi: f64) -> Result<()> {
    if s.len() < 2 {
        return Err(Error::invalid("s", format!("{} values", s.len()), "need at least two slider positions"));
    }
    if s.iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid("s", "non-finite", "all slider positions must be finite"));
    }
    if s.windows(2).any(|w| w[1] <= w[0]) {
        return Err(Error::invalid("s", "unsorted", "slider positions must be strictly increasing"));
    }
    let tol = 1e-12;
    if s[0] < lo - tol || s[s.len() - 1] > hi + tol {
        return Err(Error::invalid(
            "s",
            format!("[{}, {}]", s[0], s[s.len() - 1]),
            &format!("slider positions must lie in [B/(2L), {hi}] = [{lo}, {hi}]"),
        ));
    }
    Ok(())
}

/// Default grid: `count` values from B/(2L) to 0.5.
pub fn default_grid(params: &Params, count: usize) -> Vec<f64> {
    let lo = params.s_min();
    let count = count.max(2);
    (0..count).map(|i| lo + (0.5 - lo) * i as f64 / (count - 1) as f64).collect()
}

/// The HB super-slow manifold (issue 17 §2.3–2.4) at (f_ex [Hz], a_ex [m/s²]).
pub fn hb_manifold(params: &Params, f_ex_hz: f64, a_ex: f64, opts: &HbOptions) -> Result<HbManifold> {
    params.validate()?;
    let sys = HbSystem::new(params, f_ex_hz, a_ex, opts)?;
    let grid = opts.s.clone().unwrap_or_else(|| default_grid(params, 201));
    check_grid(&grid, params.s_min(), 0.5)?;
    if opts.max_steps == 0 {
        return Err(Error::invalid("max_steps", 0, "must be >= 1"));
    }
    if !(opts.max_step.is_finite() && opts.max_step > 0.0) {
        return Err(Error::invalid("max_step", opts.max_step, "must be finite and > 0"));
    }
    let (s_lo, s_hi) = (grid[0], grid[grid.len() - 1]);
    let n2 = sys.nx;
    let cont = Continuation { sys: &sys, par: Param::S { load: 1.0 }, max_steps: opts.max_steps, h_max: opts.max_step, h_min: 1e-10, stop_at_fold: false, work: ContWork::new(&sys) };
    let mut out = HbManifold {
        s_range: (s_lo, s_hi),
        n_modes: sys.n,
        harmonic_orders: sys.mhb.as_ref().map_or_else(Vec::new, |m| m.orders.clone()),
        ..Default::default()
    };

    let y_lo = solve_from_rest(&sys, s_lo, opts)?;
    let up = cont.trace(y_lo, 1.0, s_lo, s_hi);
    let y_hi = solve_from_rest(&sys, s_hi, opts)?;
    let down = Continuation { stop_at_fold: opts.low_branch_only, ..cont }.trace(y_hi, -1.0, s_lo, s_hi);
    out.steps = up.steps + down.steps;
    for (name, run) in [("upward", &up), ("downward", &down)] {
        if !run.complete {
            out.warnings.push(format!(
                "{name} continuation stopped after {} steps before leaving [{s_lo}, {s_hi}] (max_steps = {})",
                run.steps, opts.max_steps
            ));
        }
    }
    let to_branch = |pts: &[(DVector<f64>, bool)]| {
        let mut b = HbBranch::default();
        for (y, st) in pts {
            b.push(&sys.point_out(y, *st));
        }
        b
    };
    out.up_run = to_branch(&up.points);
    out.down_run = to_branch(&down.points);
    let first = |run: &Run| run.fold_idx.first().copied();
    match first(&up) {
        Some(k) => {
            out.high = to_branch(&up.points[..=k]);
            out.s_dn = Some(up.points[k].0[n2]);
            let end = up.fold_idx.get(1).copied().unwrap_or(up.points.len() - 1);
            out.middle = to_branch(&up.points[k..=end]);
        }
        None => out.high = to_branch(&up.points),
    }
    match first(&down) {
        Some(k) => {
            out.low = to_branch(&down.points[..=k]);
            out.s_up = Some(down.points[k].0[n2]);
            if out.middle.is_empty() {
                let end = down.fold_idx.get(1).copied().unwrap_or(down.points.len() - 1);
                out.middle = to_branch(&down.points[k..=end]);
            }
        }
        None => out.low = to_branch(&down.points),
    }
    let mut folds: Vec<Fold> = up
        .folds
        .iter()
        .chain(down.folds.iter())
        .map(|y| {
            let p = sys.point_out(y, true);
            Fold { s: p.s, amplitude_h: p.amplitude_h }
        })
        .collect();
    folds.sort_by(|a, b| a.s.total_cmp(&b.s));
    folds.dedup_by(|a, b| (a.s - b.s).abs() < 1e-7 && (a.amplitude_h - b.amplitude_h).abs() < 1e-6 * (1.0 + b.amplitude_h));
    out.folds = folds;
    if opts.sample_on_grid {
        out.s_grid = grid.clone();
        out.high_on_grid = grid.iter().map(|&x| sample_branch(&sys, &out.high, x)).collect();
        out.low_on_grid = grid.iter().map(|&x| sample_branch(&sys, &out.low, x)).collect();
    }
    // Linear resonance positions on a 26-point grid, refined by Brent.
    let g = |s: f64| sys.linear_frequency(s) - sys.omega_ex;
    out.s_res = bracket_zeros(&g, s_lo, s_hi, 26, 1e-13);
    Ok(out)
}

/// Â of a branch (monotone in s) at s: Newton at fixed s from Q interpolated between the
/// neighbouring continuation points (the interpolated Â if Newton fails); NaN outside the branch.
fn sample_branch(sys: &HbSystem, b: &HbBranch, s: f64) -> f64 {
    if sys.mhb.is_some() {
        return sample_branch_state(sys, b, s);
    }
    let n = sys.n;
    for i in 0..b.len().saturating_sub(1) {
        let (a, c) = (b.s[i], b.s[i + 1]);
        let (lo, hi) = if a <= c { (a, c) } else { (c, a) };
        if s < lo || s > hi {
            continue;
        }
        let w = if c != a { (s - a) / (c - a) } else { 0.0 };
        let lerp = |v: &[f64], k: usize| v[i * n + k] + w * (v[(i + 1) * n + k] - v[i * n + k]);
        let u: Vec<f64> = (0..n).map(|k| lerp(&b.q_re, k)).collect();
        let v: Vec<f64> = (0..n).map(|k| lerp(&b.q_im, k)).collect();
        return match sys.solve_point(s, &u, &v) {
            Ok((u, v)) => {
                let wr: f64 = sys.p47.iter().zip(&u).map(|(a, b)| a * b).sum();
                let wi: f64 = sys.p47.iter().zip(&v).map(|(a, b)| a * b).sum();
                wr.hypot(wi) / sys.thickness
            }
            Err(_) => b.amplitude_h[i] + w * (b.amplitude_h[i + 1] - b.amplitude_h[i]),
        };
    }
    f64::NAN
}

/// [`sample_branch`] for the multi-harmonic / sag system: Newton at fixed s on all unknowns.
fn sample_branch_state(sys: &HbSystem, b: &HbBranch, s: f64) -> f64 {
    let nx = sys.nx;
    for i in 0..b.len().saturating_sub(1) {
        let (a, c) = (b.s[i], b.s[i + 1]);
        let (lo, hi) = if a <= c { (a, c) } else { (c, a) };
        if s < lo || s > hi {
            continue;
        }
        let w = if c != a { (s - a) / (c - a) } else { 0.0 };
        let mut y = DVector::zeros(nx + 1);
        for k in 0..nx {
            y[k] = (b.state[i * nx + k] + w * (b.state[(i + 1) * nx + k] - b.state[i * nx + k])) / sys.q_ref;
        }
        y[nx] = s;
        return match sys.newton_fixed(&y, Param::S { load: 1.0 }) {
            Some(y) => sys.point_out(&y, true).amplitude_h,
            None => b.amplitude_h[i] + w * (b.amplitude_h[i + 1] - b.amplitude_h[i]),
        };
    }
    f64::NAN
}

/// Zeros of f on [lo, hi], bracketed on `count` uniform points and refined by Brent.
/// Exact zeros at grid points are reported once.
fn bracket_zeros(f: &dyn Fn(f64) -> f64, lo: f64, hi: f64, count: usize, tol: f64) -> Vec<f64> {
    let grid: Vec<f64> = (0..count).map(|i| lo + (hi - lo) * i as f64 / (count - 1) as f64).collect();
    zeros_on_grid(f, &grid, tol)
}

fn zeros_on_grid(f: &dyn Fn(f64) -> f64, grid: &[f64], tol: f64) -> Vec<f64> {
    let vals: Vec<f64> = grid.iter().map(|&s| f(s)).collect();
    zeros_from_values(f, grid, &vals, tol)
}

fn zeros_from_values(f: &dyn Fn(f64) -> f64, grid: &[f64], vals: &[f64], tol: f64) -> Vec<f64> {
    let mut out = Vec::new();
    for i in 0..grid.len() {
        if vals[i] == 0.0 {
            out.push(grid[i]);
            continue;
        }
        if i + 1 < grid.len() && vals[i + 1] != 0.0 && vals[i].signum() != vals[i + 1].signum()
            && vals[i].is_finite() && vals[i + 1].is_finite()
            && let Ok(z) = brent(f, grid[i], grid[i + 1], tol, 200)
        {
            out.push(z);
        }
    }
    out
}

/// Brent's method (Brent 1973, as in Numerical Recipes' `zbrent`): a zero of f in [a, b] with
/// f(a) f(b) ≤ 0, to an absolute tolerance `tol`, at most `max_iter` iterations. A NaN value of
/// f is an error.
pub fn brent(f: impl Fn(f64) -> f64, a: f64, b: f64, tol: f64, max_iter: usize) -> Result<f64> {
    let (mut a, mut b) = (a, b);
    let (mut fa, mut fb) = (f(a), f(b));
    if fa.is_nan() || fb.is_nan() {
        return Err(Error::Numerical("brent: NaN at the bracket".into()));
    }
    if fa == 0.0 {
        return Ok(a);
    }
    if fb == 0.0 {
        return Ok(b);
    }
    if fa.signum() == fb.signum() {
        return Err(Error::Numerical("brent: the interval does not bracket a zero".into()));
    }
    let (mut c, mut fc) = (b, fb);
    let (mut d, mut e) = (b - a, b - a);
    for _ in 0..max_iter {
        if fb.signum() == fc.signum() {
            c = a;
            fc = fa;
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        let tol1 = 2.0 * f64::EPSILON * b.abs() + 0.5 * tol;
        let xm = 0.5 * (c - b);
        if xm.abs() <= tol1 || fb == 0.0 {
            return Ok(b);
        }
        if e.abs() >= tol1 && fa.abs() > fb.abs() {
            let s = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * xm * s;
                q = 1.0 - s;
            } else {
                let qq = fa / fc;
                let r = fb / fc;
                p = s * (2.0 * xm * qq * (qq - r) - (b - a) * (r - 1.0));
                q = (qq - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            }
            p = p.abs();
            let min1 = 3.0 * xm * q - (tol1 * q).abs();
            let min2 = (e * q).abs();
            if 2.0 * p < min1.min(min2) {
                e = d;
                d = p / q;
            } else {
                d = xm;
                e = d;
            }
        } else {
            d = xm;
            e = d;
        }
        a = b;
        fa = fb;
        b += if d.abs() > tol1 { d } else { tol1.copysign(xm) };
        fb = f(b);
        if fb.is_nan() {
            return Err(Error::Numerical("brent: NaN inside the bracket".into()));
        }
    }
    Err(Error::Numerical(format!("brent: no convergence in {max_iter} iterations")))
}

/// The single-mode closed form of issue §2.2 on an s-grid.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ClosedFormN1 {
    /// Slider positions [-].
    pub s: Vec<f64>,
    /// Â = |φ₁(4L/7)| a / h of the real roots, ascending (low, middle, high); NaN where absent.
    /// With one root it is the first entry.
    pub roots_h: Vec<[f64; 3]>,
    /// Number of real (all positive) roots: 1 or 3 (2 only at a fold exactly on the grid).
    pub n_roots: Vec<usize>,
    /// Discriminant Δ of the cubic in the scaled unknown x = A b/ω² (sign as Δ).
    pub discriminant: Vec<f64>,
    /// Folds: zeros of Δ(s), bracketed on the grid and refined by Brent's method, ascending.
    pub folds: Vec<f64>,
    /// Jump-up position: the first fold (the low branch ends there).
    pub s_up: Option<f64>,
    /// Jump-down position: the second fold (None if the high branch reaches the grid's end).
    pub s_dn: Option<f64>,
    /// Linear resonance: M₁(s_res) = ω²/Ω² (with the preload, ω² → ω² + H₀K₁₁).
    pub s_res: Vec<f64>,
    /// High-branch estimate away from its end, a_H = √(4(M₁Ω² − ω²)/(3b)), as Â (NaN where
    /// M₁Ω² ≤ ω²).
    pub backbone_h: Vec<f64>,
}

/// Coefficients of the scaled cubic (9/16)x³ + β x² + γ x − κ = 0 at s, and the scale
/// Â per √x.
struct Cubic {
    beta: f64,
    gamma: f64,
    kappa: f64,
}

struct N1<'a> {
    omega2: f64,
    b: f64,
    c: f64,
    gamma1: f64,
    mass: f64,
    j_g: f64,
    om2: f64,
    a_ex: f64,
    length: f64,
    amp_scale: f64,
    beam: &'a Beam,
}

impl N1<'_> {
    fn m1(&self, s: f64) -> (f64, f64) {
        let x = s * self.length;
        let phi = self.beam.phi_exact(0, x);
        let dphi = self.beam.dphi_exact(0, x);
        (1.0 + self.mass * phi * phi + self.j_g * dphi * dphi, phi)
    }

    fn cubic(&self, s: f64) -> Cubic {
        let (m1, phi) = self.m1(s);
        let delta = (self.omega2 - m1 * self.om2) / self.omega2;
        let cc = self.c / self.omega2;
        let f = (self.gamma1 + self.mass * phi) * self.a_ex;
        Cubic { beta: 1.5 * delta, gamma: delta * delta + cc * cc, kappa: f * f * self.b / self.omega2.powi(3) }
    }
}

fn discriminant(c: &Cubic) -> f64 {
    // Δ = 18αβγκ' − 4β³κ' + β²γ² − 4αγ³ − 27α²κ'² for αx³ + βx² + γx + κ', κ' = −κ.
    let (al, be, ga, ka) = (9.0 / 16.0, c.beta, c.gamma, -c.kappa);
    18.0 * al * be * ga * ka - 4.0 * be.powi(3) * ka + be * be * ga * ga - 4.0 * al * ga.powi(3) - 27.0 * al * al * ka * ka
}

/// Real roots of (9/16)x³ + βx² + γx − κ, ascending, each polished by Newton's method.
fn cubic_roots(c: &Cubic) -> Vec<f64> {
    let al = 9.0 / 16.0;
    let (a2, a1, a0) = (c.beta / al, c.gamma / al, -c.kappa / al);
    // Depressed cubic x = t − a2/3: t³ + pt + q = 0.
    let p = a1 - a2 * a2 / 3.0;
    let q = 2.0 * a2.powi(3) / 27.0 - a2 * a1 / 3.0 + a0;
    let shift = -a2 / 3.0;
    let disc = (q / 2.0).powi(2) + (p / 3.0).powi(3);
    let mut roots = if disc > 0.0 {
        let sq = disc.sqrt();
        let u = (-q / 2.0 + sq).cbrt();
        let v = (-q / 2.0 - sq).cbrt();
        vec![u + v + shift]
    } else if p == 0.0 {
        vec![(-q).cbrt() + shift]
    } else {
        let r = (-p / 3.0).sqrt();
        let arg = (3.0 * q / (2.0 * p * r)).clamp(-1.0, 1.0);
        let th = arg.acos() / 3.0;
        (0..3).map(|k| 2.0 * r * (th - 2.0 * std::f64::consts::PI * k as f64 / 3.0).cos() + shift).collect()
    };
    let poly = |x: f64| ((al * x + c.beta) * x + c.gamma) * x - c.kappa;
    let dpoly = |x: f64| (3.0 * al * x + 2.0 * c.beta) * x + c.gamma;
    for x in roots.iter_mut() {
        for _ in 0..3 {
            let d = dpoly(*x);
            if d == 0.0 {
                break;
            }
            let nx = *x - poly(*x) / d;
            if !nx.is_finite() {
                break;
            }
            *x = nx;
        }
    }
    roots.sort_by(f64::total_cmp);
    roots
}

/// The N = 1 closed form (issue §2.2) on the grid `s` (strictly increasing, within
/// [B/(2L), 1 − B/(2L)]). Requires damping_ratio_quadratic = 0 (the cubic assumes linear damping).
pub fn closed_form_n1(params: &Params, f_ex_hz: f64, a_ex: f64, s: &[f64], d_eff: Option<f64>) -> Result<ClosedFormN1> {
    closed_form_n1_scaled(params, f_ex_hz, a_ex, s, d_eff, 1.0)
}

/// [`closed_form_n1`] with ω₁ → `omega1_factor`·ω₁.
pub fn closed_form_n1_scaled(
    params: &Params,
    f_ex_hz: f64,
    a_ex: f64,
    s: &[f64],
    d_eff: Option<f64>,
    omega1_factor: f64,
) -> Result<ClosedFormN1> {
    params.validate()?;
    check_excitation(f_ex_hz, a_ex)?;
    check_d_eff(d_eff)?;
    if params.damping_ratio_quadratic != 0.0 {
        return Err(Error::invalid(
            "damping_ratio_quadratic",
            params.damping_ratio_quadratic,
            "the N = 1 closed form assumes linear damping (use hb_manifold with n_modes = 1)",
        ));
    }
    check_grid(s, params.s_min(), 1.0 - params.s_min())?;
    let beam = Beam::new(&Params { n_modes: 1, ..params.clone() })?;
    closed_form_n1_with_beam(&beam, params, f_ex_hz, a_ex, s, d_eff, omega1_factor)
}

/// [`closed_form_n1_scaled`] with the beam's modes given (computed once per parameter set:
/// `Beam::new` costs more than the closed form itself). `beam` must come from `params`.
pub fn closed_form_n1_with_beam(
    beam: &Beam,
    params: &Params,
    f_ex_hz: f64,
    a_ex: f64,
    s: &[f64],
    d_eff: Option<f64>,
    omega1_factor: f64,
) -> Result<ClosedFormN1> {
    check_excitation(f_ex_hz, a_ex)?;
    check_d_eff(d_eff)?;
    if params.damping_ratio_quadratic != 0.0 {
        return Err(Error::invalid(
            "damping_ratio_quadratic",
            params.damping_ratio_quadratic,
            "the N = 1 closed form assumes linear damping (use hb_manifold with n_modes = 1)",
        ));
    }
    check_grid(s, params.s_min(), 1.0 - params.s_min())?;
    let n1 = n1_model(beam, params, f_ex_hz, a_ex, d_eff, omega1_factor)?;
    let mut out = ClosedFormN1 { s: s.to_vec(), ..Default::default() };
    out.roots_h.reserve(s.len());
    for &si in s {
        let c = n1.cubic(si);
        let d = discriminant(&c);
        let r = cubic_roots(&c);
        let mut row = [f64::NAN; 3];
        let mut k = 0;
        for x in r.iter().filter(|x| **x > 0.0) {
            row[k] = n1.amp_scale * x.sqrt();
            k += 1;
        }
        out.n_roots.push(k);
        out.roots_h.push(row);
        out.discriminant.push(d);
        let (m1, _) = n1.m1(si);
        let x_h = 4.0 * (m1 * n1.om2 - n1.omega2) / (3.0 * n1.b);
        out.backbone_h.push(if x_h > 0.0 { n1.amp_scale * (x_h * n1.b / n1.omega2).sqrt() } else { f64::NAN });
    }
    let f = |x: f64| discriminant(&n1.cubic(x));
    out.folds = zeros_from_values(&f, s, &out.discriminant, 1e-14);
    out.folds.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    out.s_up = out.folds.first().copied();
    out.s_dn = out.folds.get(1).copied();
    let g = |x: f64| n1.m1(x).0 * n1.om2 - n1.omega2;
    out.s_res = zeros_on_grid(&g, s, 1e-14);
    Ok(out)
}

fn n1_model<'a>(beam: &'a Beam, params: &Params, f_ex_hz: f64, a_ex: f64, d_eff: Option<f64>, omega1_factor: f64) -> Result<N1<'a>> {
    if !(omega1_factor.is_finite() && omega1_factor > 0.0) {
        return Err(Error::invalid("omega1_factor", omega1_factor, "must be finite and > 0"));
    }
    let p = params;
    let om = 2.0 * std::f64::consts::PI * f_ex_hz;
    let w1 = beam.omega[0] * omega1_factor;
    let omega2 = w1 * w1 + beam.preload_n * beam.k[0];
    let d = d_eff.unwrap_or(p.damping_ratio);
    let b = beam.hardening_b();
    let p47 = beam.phi_exact(0, 4.0 / 7.0 * p.length_m).abs();
    Ok(N1 {
        omega2,
        b,
        c: 2.0 * d * w1 * om,
        gamma1: beam.gamma[0],
        mass: p.slider_mass_kg,
        j_g: p.slider_inertia_centre_kg_m2(),
        om2: om * om,
        a_ex,
        length: p.length_m,
        // Â = |φ₁(4L/7)| √A / h with A = x ω²/b.
        amp_scale: p47 * (omega2 / b).sqrt() / p.thickness_m,
        beam,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn brent_finds_simple_roots_and_respects_endpoints() {
        let r = brent(|x| x * x - 2.0, 0.0, 2.0, 1e-15, 100).unwrap();
        assert!((r - 2f64.sqrt()).abs() < 1e-14);
        assert_eq!(brent(|x| x - 1.0, 1.0, 3.0, 1e-15, 100).unwrap(), 1.0);
        assert!(brent(|x| x * x + 1.0, -1.0, 1.0, 1e-12, 100).is_err());
        assert!(brent(|_| f64::NAN, -1.0, 1.0, 1e-12, 100).is_err());
        // Cap: never loops forever.
        assert!(brent(|x| x.powi(3), -1.0, 2.0, 0.0, 3).is_err());
    }

    #[test]
    fn lu_work_and_matvec_are_bitwise_nalgebra() {
        // Pseudo-random matrices of the sizes in use (10, 11) and others, some singular (a zero
        // column, a repeated row): factors, determinant and solution equal nalgebra's LU bit for
        // bit, and `matvec` equals nalgebra's matrix–vector product.
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let bits = |m: &[f64]| m.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for d in [1, 2, 3, 5, 7, 10, 11, 12, 21] {
            for case in 0..12 {
                let mut m = DMatrix::from_fn(d, d, |_, _| rnd());
                if d > 1 && case == 1 {
                    m.column_mut(d / 2).fill(0.0);
                }
                if d > 1 && case == 2 {
                    let r = m.row(0).into_owned();
                    m.row_mut(d - 1).copy_from(&r);
                }
                let b = DVector::from_fn(d, |_, _| rnd());
                let reference = m.clone().lu();
                let mut lu = LuWork::new(d);
                lu.a.copy_from(&m);
                lu.factor();
                let mut l = lu.a.lower_triangle();
                l.fill_diagonal(1.0);
                assert_eq!(bits(l.as_slice()), bits(reference.l().as_slice()), "L, d = {d}, case {case}");
                assert_eq!(bits(lu.a.upper_triangle().as_slice()), bits(reference.u().as_slice()), "U, d = {d}, case {case}");
                assert_eq!(lu.determinant().to_bits(), reference.determinant().to_bits(), "det, d = {d}, case {case}");
                let mut x = b.clone();
                let solved = lu.solve(&mut x);
                match reference.solve(&b) {
                    Some(xr) => assert!(solved && bits(x.as_slice()) == bits(xr.as_slice()), "solve, d = {d}, case {case}"),
                    None => assert!(!solved, "solve, d = {d}, case {case}"),
                }
                let mut y = DVector::zeros(d);
                matvec(m.as_slice(), b.as_slice(), y.as_mut_slice(), d);
                assert_eq!(bits(y.as_slice()), bits((&m * &b).as_slice()), "matvec, d = {d}, case {case}");
            }
        }
    }

    #[test]
    fn cubic_roots_satisfy_the_polynomial() {
        for (beta, gamma, kappa) in [(-1.5, 1.0, 0.01), (1.5, 1.0, 0.3), (-3.0, 4.0, 0.5), (0.0, 1e-9, 1e-12)] {
            let c = Cubic { beta, gamma, kappa };
            let r = cubic_roots(&c);
            let d = discriminant(&c);
            assert_eq!(r.len(), if d > 0.0 { 3 } else { 1 }, "{beta} {gamma} {kappa}: {r:?} Δ = {d}");
            for x in r {
                let v = ((9.0 / 16.0 * x + beta) * x + gamma) * x - kappa;
                assert!(v.abs() < 1e-12 * (1.0 + kappa.abs()), "{x}: {v}");
                assert!(x > 0.0, "real roots are positive");
            }
        }
    }
}
