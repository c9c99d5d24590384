//! The harmonic-balance system of docs/model.md §6.4: residual, analytic Jacobian and stability
//! of the beam with the slider rigidly attached at s.

use nalgebra::{DMatrix, DVector, DVectorView};

use super::hb_terms::{HbTerms, Param};
use super::lu::{LuWork, matvec};
use super::mhb;
use crate::error::{Error, Result};
use crate::params::{MAX_MODES, Params, ParamsArg};
use crate::physics::beam::Beam;

pub(super) struct PointOut {
    pub(super) s: f64,
    pub(super) amplitude_h: f64,
    pub(super) phase_rad: f64,
    pub(super) stable: bool,
    pub(super) q_re: Vec<f64>,
    pub(super) q_im: Vec<f64>,
    pub(super) harm: Vec<f64>,
    pub(super) state: Vec<f64>,
}

/// Settings of [`super::hb_manifold`] and of the system it continues ([`HbSystem`]); read from
/// keyword arguments by the binding (missing fields take their defaults).
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HbOptions {
    /// Retained beam modes N (1..=20; default 5).
    pub n_modes: usize,
    /// Harmonics of the HB ansatz: the odd harmonics 1, 3, …, H for H = `harmonics` ∈ {1, 3, 5, 7}
    /// (1 = single-term HB, the default; docs/model.md §6.4). With `static_sag`, all harmonics 0..=H.
    pub harmonics: usize,
    /// Equivalent damping ratio D_eff replacing Dₙ of all modes (docs/model.md §6.4); None = the
    /// parameters' damping_ratio.
    pub d_eff: Option<f64>,
    /// Factor on ω₁ (ω₁ → factor·ω₁, for a sensitivity check; default 1).
    pub omega1_factor: f64,
    /// Slider positions, strictly increasing, within [B/(2L), 0.5]: the continuation runs over
    /// [s[0], s[last]] (default: 201 values from B/(2L) to 0.5).
    #[serde(alias = "s_values")]
    pub s: Option<Vec<f64>>,
    /// Cap of continuation steps per run (default 20 000).
    pub max_steps: usize,
    /// Largest arclength step in the scaled coordinates (Q/q_ref, s) (default 0.05).
    pub max_step: f64,
    /// Also solve the high and low branches exactly at every s of the grid
    /// ([`super::HbManifold::high_on_grid`], [`super::HbManifold::low_on_grid`]; default false).
    pub sample_on_grid: bool,
    /// Static sag under the slider's weight m·g at x = sL (docs/model.md §6.4; gravity acts on the
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

/// The N-mode, single-harmonic HB system with the slider rigidly attached (docs/model.md §6.4):
/// its coefficients ([`HbTerms`], read through `Deref`) and the multi-harmonic residual.
#[derive(Debug, Clone)]
pub struct HbSystem {
    pub(super) terms: HbTerms,
    /// Multi-harmonic / static-sag residual (None: single-term HB).
    pub(super) mhb: Option<mhb::Mhb>,
    /// Number of real unknowns (parameter excluded): 2N for single-term HB.
    pub(super) nx: usize,
}

impl std::ops::Deref for HbSystem {
    type Target = HbTerms;
    fn deref(&self) -> &HbTerms {
        &self.terms
    }
}

pub(super) fn check_excitation(f_ex_hz: f64, a_ex: f64) -> Result<()> {
    if !(f_ex_hz.is_finite() && f_ex_hz > 0.0) {
        return Err(Error::invalid("f_ex", f_ex_hz, "excitation frequency must be finite and > 0 Hz"));
    }
    if !(a_ex.is_finite() && a_ex > 0.0) {
        return Err(Error::invalid("a_ex", a_ex, "base-acceleration amplitude must be finite and > 0 m/s^2"));
    }
    Ok(())
}

pub(super) fn check_d_eff(d_eff: Option<f64>) -> Result<()> {
    if let Some(d) = d_eff
        && !(d.is_finite() && d >= 0.0)
    {
        return Err(Error::invalid("d_eff", d, "equivalent damping ratio must be finite and >= 0"));
    }
    Ok(())
}

impl HbSystem {
    /// Build the system for `params` (its n_modes replaced by `opts.n_modes`) at (f_ex, a_ex).
    pub fn new<'a>(params: impl Into<ParamsArg<'a>>, f_ex_hz: f64, a_ex: f64, opts: &HbOptions) -> Result<HbSystem> {
        let params = params.into().check()?.get();
        check_excitation(f_ex_hz, a_ex)?;
        if !(1..=MAX_MODES).contains(&opts.n_modes) {
            return Err(Error::invalid("n_modes", opts.n_modes, "must lie in 1..=20"));
        }
        if !matches!(opts.harmonics, 1 | 3 | 5 | 7) {
            return Err(Error::invalid("harmonics", opts.harmonics, "must be 1, 3, 5 or 7 (odd harmonics up to H; even harmonics alone are not excited)"));
        }
        check_d_eff(opts.d_eff)?;
        if !(opts.omega1_factor.is_finite() && opts.omega1_factor > 0.0) {
            return Err(Error::invalid("omega1_factor", opts.omega1_factor, "must be finite and > 0"));
        }
        let p = Params { n_modes: opts.n_modes, ..params.clone() };
        // Only n_modes changed, within 1..=MAX_MODES: still valid.
        let beam = Beam::shared(ParamsArg::derived(&p))?;
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
            let kappa = omega.iter().map(|w| 2.0 * w * p.damping_ratio_quadratic * omega_ex / (p.thickness_m * p.thickness_m)).collect();
            (kappa, beam.phi_row(x_mid))
        });
        let p47 = beam.phi_row(4.0 / 7.0 * p.length_m);
        let phi_max = (0..=200).map(|i| beam.phi_exact(0, p.length_m * i as f64 / 200.0).abs()).fold(0.0, f64::max);
        let q_ref = p.thickness_m / phi_max;
        let f_ref = omega[0] * omega[0] * q_ref;
        let mhb = (opts.harmonics > 1 || opts.static_sag).then(|| mhb::Mhb::new(n, opts.harmonics, opts.static_sag, p.slider_mass_kg * p.gravity_m_s2));
        let nx = mhb.as_ref().map_or(2 * n, |m| m.nx);
        let terms = HbTerms {
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
            beam,
        };
        Ok(HbSystem { terms, mhb, nx })
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

    /// Residual R(Q, s) in physical units [N kg^-½]: (Re R, Im R) of docs/model.md §6.4 for Q = u + iv,
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

    pub(super) fn scaled_state(&self, x: &[f64], s: f64) -> DVector<f64> {
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
            .ok_or_else(|| Error::Numerical(format!("HB Newton did not converge at s = {}", crate::error::short_number(s))))?;
        Ok(self.uv(&y))
    }

    /// Single-mode backbone with the slider (docs/model.md §6.4): Ω_bb(Â, s) =
    /// √((ω₁² + H₀K₁₁ + ¾ b a²)/M₁(s)), a = Â h/|φ₁(4L/7)| [rad/s].
    pub fn backbone_omega(&self, amplitude_h: f64, s: f64) -> f64 {
        let x = s * self.length;
        let (phi, dphi) = (self.beam.phi_exact(0, x), self.beam.dphi_exact(0, x));
        let m1 = 1.0 + self.mass * phi * phi + self.j_g * dphi * dphi;
        let a = amplitude_h * self.thickness / self.p47[0].abs();
        crate::physics::Beam::backbone_omega2(self.lam[(0, 0)], self.beam.hardening_b(), a, m1).sqrt()
    }

    pub(super) fn uv(&self, y: &DVector<f64>) -> (Vec<f64>, Vec<f64>) {
        let n = self.n;
        ((0..n).map(|i| y[i] * self.q_ref).collect(), (0..n).map(|i| y[n + i] * self.q_ref).collect())
    }

    /// Scaled residual r = R/f_ref and (optionally) the scaled Jacobian [∂r/∂x | ∂r/∂p] of the
    /// unknowns y = (Re Q/q_ref, Im Q/q_ref, p), p = s or the load factor.
    pub(super) fn eval(&self, y: &DVector<f64>, par: Param, want_j: bool) -> (DVector<f64>, DMatrix<f64>) {
        let mut w = EvalWork::new(self);
        self.eval_into(y, par, want_j, &mut w);
        (w.r, if want_j { w.j } else { DMatrix::zeros(0, 0) })
    }

    /// [`HbSystem::eval`] into the buffers of `w` (`w.r`, and `w.j` when `want_j`), without
    /// allocating (single-term HB).
    pub(super) fn eval_into(&self, y: &DVector<f64>, par: Param, want_j: bool, w: &mut EvalWork) {
        if let Some(m) = &self.mhb {
            let (r, j) = m.eval(&self.terms, y, par, want_j);
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
    pub(super) fn eval_single(&self, n: usize, y: &DVector<f64>, par: Param, want_j: bool, w: &mut EvalWork) {
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
                let dm = |i: usize, pw: f64, dw: f64, ddw: f64| (self.mass * (dphi[i] * pw + phi[i] * dw) + self.j_g * (ddphi[i] * dw + dphi[i] * ddw)) * l;
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
    pub(super) fn newton_fixed(&self, y0: &DVector<f64>, par: Param) -> Option<DVector<f64>> {
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
    pub(super) fn w47(&self, y: &DVector<f64>) -> (f64, f64) {
        let n = self.n;
        let wr: f64 = (0..n).map(|i| self.p47[i] * y[i]).sum();
        let wi: f64 = (0..n).map(|i| self.p47[i] * y[n + i]).sum();
        (wr, wi)
    }

    /// Step acceptance on the response: w(4L/7) changes its phase by at most 0.15 rad and its
    /// modulus by at most 25 %.
    pub(super) fn response_close(&self, a: &DVector<f64>, b: &DVector<f64>) -> bool {
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

    pub(super) fn point_out(&self, y: &DVector<f64>, stable: bool) -> PointOut {
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
            harm: self.mhb.as_ref().map_or_else(Vec::new, |m| m.harmonic_amplitudes(&self.terms, y)),
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

/// Buffers of [`HbSystem::eval_into`]: the residual `r`, the Jacobian `j` and the intermediates.
pub(super) struct EvalWork {
    pub(super) u: DVector<f64>,
    pub(super) v: DVector<f64>,
    pub(super) phi: DVector<f64>,
    pub(super) dphi: DVector<f64>,
    pub(super) ddphi: DVector<f64>,
    pub(super) gamma_s: DVector<f64>,
    pub(super) ku: DVector<f64>,
    pub(super) kv: DVector<f64>,
    pub(super) zu: DVector<f64>,
    pub(super) zv: DVector<f64>,
    pub(super) z: DMatrix<f64>,
    pub(super) r: DVector<f64>,
    pub(super) j: DMatrix<f64>,
}

impl EvalWork {
    pub(super) fn new(sys: &HbSystem) -> EvalWork {
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
