//! Beam of docs/model.md §2: linear modes of the elastically clamped Euler–Bernoulli beam,
//! modal mass normalisation, γₙ, the slope Gram matrix K and the string force
//! Fₙ(q) = (k_ax/2)(qᵀKq)(Kq)ₙ; fast tabulated evaluation of φ and φ'.
//!
//! Mode shapes are written in the well-conditioned basis
//! φ(ξ) = a₁ sin λξ + a₂ cos λξ + a₃ e^{−λξ} + a₄ e^{−λ(1−ξ)}, which spans the same space as
//! sin, cos, sinh, cosh but loses no digits for high modes. a₁ (the sine coefficient) is
//! positive, as docs/model.md's convention c₁ = +1 asks.

use super::modes::{GaussLegendre, ModeTable, TABLE_XI_MAX, TABLE_XI_MIN, dphi_basis, find_roots, null_vector, phi_basis, phi_derivative};
use crate::error::{Error, Result};
use crate::params::{Params, ParamsArg};

/// The modal beam: frequencies, shapes, γ, K and the mode table.
#[derive(Debug, Clone)]
pub struct Beam {
    /// Number of retained modes N.
    pub n: usize,
    /// Free length L [m].
    pub length_m: f64,
    /// Eigenvalues λₙ of det B(λ) = 0.
    pub lambda: Vec<f64>,
    /// Natural angular frequencies ωₙ = λₙ² √(EI/(ρA L⁴)) [rad/s].
    pub omega: Vec<f64>,
    /// γₙ = ρA ∫ φₙ dx [kg^½].
    pub gamma: Vec<f64>,
    /// K_ij = ∫ φᵢ' φⱼ' dx, row-major N×N.
    pub k: Vec<f64>,
    /// k_ax = 1/(L/(EA) + 1/k_t) [N/m].
    pub k_ax: f64,
    /// Static axial force H₀ [N] (tension positive); modal force H₀ (Kq)ₙ.
    pub preload_n: f64,
    /// Shape coefficients (a₁..a₄) of each mode, unit modal mass, in the basis above.
    pub coef: Vec<[f64; 4]>,
    /// Upper bound of |φₘ'(x)| over the tabulated range (sampled, with a 1 % margin).
    pub slope_bound: Vec<f64>,
    table: ModeTable,
}

/// A position located in the mode table.
#[derive(Debug, Clone, Copy)]
pub struct Loc {
    x: f64,
    j: usize,
    u: f64,
    inside: bool,
}

impl Loc {
    /// Inside the tabulated range?
    pub fn inside(&self) -> bool {
        self.inside
    }

    /// The located x [m].
    pub fn x(&self) -> f64 {
        self.x
    }
}

/// Beams built by [`Beam::shared`], most recent last (a handful: the reduced predictor asks for
/// the same beam at every operating point).
static SHARED: std::sync::Mutex<Vec<(Params, std::sync::Arc<Beam>)>> = std::sync::Mutex::new(Vec::new());
const SHARED_MAX: usize = 4;

impl Beam {
    /// [`Beam::new`], shared: the beam of equal parameters is built once per process and reused
    /// (the same value `new` returns; a small cache of the last few parameter sets).
    pub fn shared<'a>(p: impl Into<ParamsArg<'a>>) -> Result<std::sync::Arc<Beam>> {
        let p = p.into();
        let arg = p;
        let p = p.get();
        if let Ok(cache) = SHARED.lock()
            && let Some((_, b)) = cache.iter().rev().find(|(q, _)| q == p)
        {
            return Ok(b.clone());
        }
        let b = std::sync::Arc::new(Beam::new(arg)?);
        if let Ok(mut cache) = SHARED.lock() {
            if cache.len() >= SHARED_MAX {
                cache.remove(0);
            }
            cache.push((p.clone(), b.clone()));
        }
        Ok(b)
    }

    /// Modes of the beam with the parameters' geometry and clamping (k_r may be +inf).
    pub fn new<'a>(p: impl Into<ParamsArg<'a>>) -> Result<Beam> {
        let p = p.into().check()?.get();
        let n = p.n_modes;
        let l = p.length_m;
        let rho_a = p.beam_mass_kg / l;
        let ei = p.bending_stiffness();
        // ε = 1/κ = EI/(k_r L); 0 for ideal clamping.
        let eps = ei / (p.k_r_nm_per_rad * l);
        if !eps.is_finite() {
            return Err(Error::invalid(
                "k_r_nm_per_rad",
                p.k_r_nm_per_rad,
                &format!("too small: EI/(k_r L) overflows (use k_r_nm_per_rad >= {:e})", ei / l / 1e300),
            ));
        }
        let lambda = find_roots(eps, n)?;
        let scale = (ei / (rho_a * l.powi(4))).sqrt();
        let omega: Vec<f64> = lambda.iter().map(|&lam| lam * lam * scale).collect();

        let gl = GaussLegendre::new(128, 8);
        let mut coef = Vec::with_capacity(n);
        for &lam in &lambda {
            let mut a = null_vector(eps, lam)?;
            // ∫₀ᴸ ρA φ² dx = ρA L ∫₀¹ φ² dξ = 1.
            let m2 = gl.integrate(|xi| phi_basis(&a, lam, xi).powi(2));
            let s = 1.0 / (rho_a * l * m2).sqrt();
            for v in a.iter_mut() {
                *v *= s;
            }
            coef.push(a);
        }
        let gamma = coef.iter().zip(&lambda).map(|(a, &lam)| rho_a * l * gl.integrate(|xi| phi_basis(a, lam, xi))).collect();
        let mut k = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..=i {
                // φ'(x) = (1/L) dφ/dξ ; ∫₀ᴸ φᵢ'φⱼ' dx = (1/L) ∫₀¹ φᵢ,ξ φⱼ,ξ dξ.
                let v = gl.integrate(|xi| dphi_basis(&coef[i], lambda[i], xi) * dphi_basis(&coef[j], lambda[j], xi)) / l;
                k[i * n + j] = v;
                k[j * n + i] = v;
            }
        }
        if p.axial_preload_n < 0.0 {
            // Compression: diag(ω²) + H₀ K must stay positive definite (below buckling).
            let stiff = nalgebra::DMatrix::from_fn(n, n, |i, j| (if i == j { omega[i] * omega[i] } else { 0.0 }) + p.axial_preload_n * k[i * n + j]);
            if stiff.cholesky().is_none() {
                return Err(crate::error::Error::invalid(
                    "axial_preload_n",
                    p.axial_preload_n,
                    "compressive preload at or beyond the buckling load of the retained modes",
                ));
            }
        }
        let table = ModeTable::build(&coef, &lambda, l);
        let slope_bound = coef
            .iter()
            .zip(&lambda)
            .map(|(a, &lam)| {
                // Spacing λΔξ ≤ 0.05: the sampled maximum is within 3e-4 of the true one.
                let n_s = ((TABLE_XI_MAX - TABLE_XI_MIN) * lam / 0.05).ceil() as usize;
                let m = (0..=n_s)
                    .map(|i| {
                        let xi = TABLE_XI_MIN + (TABLE_XI_MAX - TABLE_XI_MIN) * i as f64 / n_s as f64;
                        dphi_basis(a, lam, xi).abs()
                    })
                    .fold(0.0, f64::max);
                1.01 * m / l
            })
            .collect();
        Ok(Beam { slope_bound, n, length_m: l, lambda, omega, gamma, k, k_ax: p.axial_stiffness(), preload_n: p.axial_preload_n, coef, table })
    }

    /// Natural frequencies fₙ = ωₙ/2π [Hz].
    pub fn frequencies_hz(&self) -> Vec<f64> {
        self.omega.iter().map(|w| w / (2.0 * std::f64::consts::PI)).collect()
    }

    /// Exact (closed-form) mode value φₘ(x), x in metres.
    pub fn phi_exact(&self, m: usize, x: f64) -> f64 {
        phi_basis(&self.coef[m], self.lambda[m], x / self.length_m)
    }

    /// Exact (closed-form) mode slope φₘ'(x) = dφₘ/dx.
    pub fn dphi_exact(&self, m: usize, x: f64) -> f64 {
        dphi_basis(&self.coef[m], self.lambda[m], x / self.length_m) / self.length_m
    }

    /// Mode values and slopes of all modes at x [m]: from the table inside its range, closed
    /// form outside (e.g. contact points beyond the clamping in the reference manifold sweep).
    #[inline]
    pub fn eval(&self, x: f64, phi: &mut [f64], dphi: &mut [f64]) {
        if !self.table.eval(x, phi, dphi) {
            for m in 0..self.n {
                phi[m] = self.phi_exact(m, x);
                dphi[m] = self.dphi_exact(m, x);
            }
        }
    }

    /// Const-size variant of [`Beam::eval`].
    #[inline(always)]
    pub fn eval_n<const N: usize>(&self, x: f64) -> ([f64; N], [f64; N]) {
        let loc = self.locate(x);
        (self.phi_n::<N>(&loc), self.dphi_n::<N>(&loc))
    }

    /// Where x lies in the mode table (for [`Beam::phi_n`] / [`Beam::dphi_n`]).
    #[inline(always)]
    pub fn locate(&self, x: f64) -> Loc {
        match self.table.locate_x(x) {
            Some((j, u)) => Loc { x, j, u, inside: true },
            None => Loc { x, j: 0, u: 0.0, inside: false },
        }
    }

    /// [`Beam::locate`] for an x on the beam, which the table (ξ from −1/4 to 5/4) always
    /// covers: no range check.
    ///
    /// # Safety
    /// 0 ≤ x ≤ L (so that the interval index is in range; not NaN).
    #[inline(always)]
    pub(crate) unsafe fn locate_on_beam(&self, x: f64) -> Loc {
        debug_assert!((0.0..=self.length_m).contains(&x));
        // SAFETY: forwarded from the caller.
        let (j, u) = unsafe { self.table.locate_covered(x) };
        Loc { x, j, u, inside: true }
    }

    /// Mode values φ₁..φ_N at a located x (table inside its range, closed form outside).
    #[inline(always)]
    pub fn phi_n<const N: usize>(&self, loc: &Loc) -> [f64; N] {
        if loc.inside { self.table.horner_n::<N>(loc.j, 0, loc.u) } else { std::array::from_fn(|m| self.phi_exact(m, loc.x)) }
    }

    /// Mode slopes φ₁'..φ_N' (x-derivatives) at a located x.
    #[inline(always)]
    pub fn dphi_n<const N: usize>(&self, loc: &Loc) -> [f64; N] {
        if loc.inside { self.table.horner_n::<N>(loc.j, 1, loc.u) } else { std::array::from_fn(|m| self.dphi_exact(m, loc.x)) }
    }

    /// Mode values at x (exact).
    pub fn phi_row(&self, x: f64) -> Vec<f64> {
        (0..self.n).map(|m| self.phi_exact(m, x)).collect()
    }

    /// Exact (closed-form) second x-derivative φₘ''(x) [kg^-½ m^-2].
    pub fn ddphi_exact(&self, m: usize, x: f64) -> f64 {
        phi_derivative(&self.coef[m], self.lambda[m], x / self.length_m, 2) / (self.length_m * self.length_m)
    }

    /// φₘ(x), φₘ'(x), φₘ''(x) of all modes at x (exact, one sin/cos and two exponentials per
    /// mode) into the three slices (each of length ≥ N).
    pub fn shapes_exact(&self, x: f64, phi: &mut [f64], dphi: &mut [f64], ddphi: &mut [f64]) {
        let l = self.length_m;
        let xi = x / l;
        for m in 0..self.n {
            let (a, lam) = (&self.coef[m], self.lambda[m]);
            let (s, c) = (lam * xi).sin_cos();
            let e0 = a[2] * (-lam * xi).exp();
            let e1 = a[3] * (-lam * (1.0 - xi)).exp();
            let (ts, tc) = (a[0] * s + a[1] * c, a[0] * c - a[1] * s);
            phi[m] = ts + e0 + e1;
            dphi[m] = lam * (tc - e0 + e1) / l;
            ddphi[m] = lam * lam * (-ts + e0 + e1) / (l * l);
        }
    }

    /// Mode slopes φₘ'(x) of all modes at x (exact).
    pub fn dphi_row(&self, x: f64) -> Vec<f64> {
        (0..self.n).map(|m| self.dphi_exact(m, x)).collect()
    }

    /// Second x-derivatives φₘ''(x) of all modes at x (exact).
    pub fn ddphi_row(&self, x: f64) -> Vec<f64> {
        (0..self.n).map(|m| self.ddphi_exact(m, x)).collect()
    }

    /// The first mode shape φ₁(x)/φ₁(L/2) at `points` + 1 equally spaced x/L = 0 … 1 (docs/model.md
    /// §9): (x/L, shape).
    pub fn mode1_shape(&self, points: usize) -> (Vec<f64>, Vec<f64>) {
        let mid = self.phi_exact(0, 0.5 * self.length_m);
        let xi: Vec<f64> = (0..=points).map(|i| i as f64 / points as f64).collect();
        let shape = xi.iter().map(|&x| self.phi_exact(0, x * self.length_m) / mid).collect();
        (xi, shape)
    }

    /// φₘ(x) of every mode m (rows) at the positions x/L of `x_over_l` (columns) (docs/model.md §2).
    pub fn phi_at(&self, x_over_l: &[f64]) -> Vec<Vec<f64>> {
        (0..self.n).map(|m| x_over_l.iter().map(|&x| self.phi_exact(m, x * self.length_m)).collect()).collect()
    }

    /// The matrix K of docs/model.md §2 as N rows.
    pub fn k_rows(&self) -> Vec<Vec<f64>> {
        self.k.chunks(self.n).map(<[f64]>::to_vec).collect()
    }

    /// The slope Gram matrix K (N×N, symmetric) as a nalgebra matrix [1/(kg m)].
    pub fn k_matrix(&self) -> nalgebra::DMatrix<f64> {
        nalgebra::DMatrix::from_row_slice(self.n, self.n, &self.k)
    }

    /// Linear modal stiffness diag(ωₙ²) + H₀ K (the axial preload's geometric stiffness) [s⁻²].
    pub fn linear_stiffness(&self) -> nalgebra::DMatrix<f64> {
        let n = self.n;
        nalgebra::DMatrix::from_fn(n, n, |i, j| (if i == j { self.omega[i] * self.omega[i] } else { 0.0 }) + self.preload_n * self.k[i * n + j])
    }

    /// Single-mode hardening coefficient b = (k_ax/2) K₁₁² of mode 1 (docs/model.md §9) [1/(kg m² s²)]:
    /// the string force of mode 1 alone is b q₁³.
    pub fn hardening_b(&self) -> f64 {
        0.5 * self.k_ax * self.k[0] * self.k[0]
    }

    /// Squared frequency of the single-mode backbone (docs/model.md §6.4, §9):
    /// ω̃² = (ω² + ¾ b a²)/M₁, with ω² the linear term, b the hardening coefficient of the
    /// amplitude a's units and M₁ the modal mass (1 without a slider). One formula for the
    /// ENMA backbone, the backbone with the slider and the fitted backbone of measured data.
    pub fn backbone_omega2(omega2: f64, b: f64, amplitude: f64, m1: f64) -> f64 {
        (omega2 + 0.75 * b * amplitude * amplitude) / m1
    }

    /// Axial (string) force Fₙ(q) = ((k_ax/2)(qᵀKq) + H₀)(Kq)ₙ into `out`.
    pub fn string_force(&self, q: &[f64], out: &mut [f64]) {
        let n = self.n;
        let mut kq = vec![0.0; n];
        for i in 0..n {
            kq[i] = (0..n).map(|j| self.k[i * n + j] * q[j]).sum();
        }
        let qkq: f64 = (0..n).map(|i| q[i] * kq[i]).sum();
        for i in 0..n {
            out[i] = (0.5 * self.k_ax * qkq + self.preload_n) * kq[i];
        }
    }

    /// Potential of the axial force, V = (k_ax/8)(qᵀKq)² + (H₀/2) qᵀKq.
    pub fn string_potential(&self, q: &[f64]) -> f64 {
        let n = self.n;
        let mut qkq = 0.0;
        for i in 0..n {
            for j in 0..n {
                qkq += q[i] * self.k[i * n + j] * q[j];
            }
        }
        0.125 * self.k_ax * qkq * qkq + 0.5 * self.preload_n * qkq
    }

    /// Single-mode hardening coefficient b* = b h²/φ₁(L/2)², b = (k_ax/2)K₁₁² (docs/model.md §9) [s⁻²].
    pub fn b_star(&self, thickness_m: f64) -> f64 {
        let phi_mid = self.phi_exact(0, 0.5 * self.length_m);
        self.hardening_b() * thickness_m.powi(2) / phi_mid.powi(2)
    }

    /// The first linear mode with the axial preload H₀: the lowest eigenpair (ω², v) of
    /// diag(ωₙ²) + H₀K (the linearised equations of motion of docs/model.md §2 with the preload), its
    /// hardening b* = (k_ax/2)(vᵀKv)² h²/ψ(L/2)² with the shape ψ(x) = Σ vₙφₙ(x) (docs/model.md §9
    /// for the preloaded mode), and the Rayleigh estimate √(ω₁² + H₀K₁₁) for comparison. Without
    /// preload v = e₁ exactly, and ω, b* are those of mode 1 bit for bit.
    pub fn first_mode(&self, thickness_m: f64) -> FirstMode {
        let n = self.n;
        let rayleigh = (self.omega[0].powi(2) + self.preload_n * self.k[0]).max(0.0).sqrt();
        if self.preload_n == 0.0 {
            let mut v = vec![0.0; n];
            v[0] = 1.0;
            return FirstMode {
                omega_rad_s: self.omega[0],
                omega_rayleigh_rad_s: rayleigh,
                b_star_per_s2: self.b_star(thickness_m),
                phi_mid: self.phi_exact(0, 0.5 * self.length_m),
                vector: v,
            };
        }
        let stiff = nalgebra::DMatrix::from_fn(n, n, |i, j| (if i == j { self.omega[i] * self.omega[i] } else { 0.0 }) + self.preload_n * self.k[i * n + j]);
        let eig = nalgebra::SymmetricEigen::new(stiff);
        let low = (0..n).min_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b])).unwrap_or(0);
        let mut v: Vec<f64> = eig.eigenvectors.column(low).iter().copied().collect();
        let mut psi_mid = self.shape(&v, 0.5 * self.length_m);
        if psi_mid < 0.0 {
            v.iter_mut().for_each(|x| *x = -*x);
            psi_mid = -psi_mid;
        }
        let vkv: f64 = (0..n).map(|i| (0..n).map(|j| v[i] * self.k[i * n + j] * v[j]).sum::<f64>()).sum();
        FirstMode {
            omega_rad_s: eig.eigenvalues[low].max(0.0).sqrt(),
            omega_rayleigh_rad_s: rayleigh,
            b_star_per_s2: 0.5 * self.k_ax * vkv * vkv * thickness_m.powi(2) / (psi_mid * psi_mid),
            phi_mid: psi_mid,
            vector: v,
        }
    }

    /// Deflection Σ vₙ φₙ(x) of the modal vector `v` at x [m] (closed form).
    pub fn shape(&self, v: &[f64], x: f64) -> f64 {
        v.iter().enumerate().map(|(m, vm)| vm * self.phi_exact(m, x)).sum()
    }
}

/// The first mode of the preloaded beam ([`Beam::first_mode`]).
#[derive(Debug, Clone, PartialEq)]
pub struct FirstMode {
    /// Linear angular frequency with the preload, from the eigenvalue problem [rad/s].
    pub omega_rad_s: f64,
    /// Rayleigh-quotient estimate √(ω₁² + H₀K₁₁) with the unloaded mode 1 (an upper bound) [rad/s].
    pub omega_rayleigh_rad_s: f64,
    /// Hardening coefficient b* of the preloaded mode [s⁻²].
    pub b_star_per_s2: f64,
    /// ψ(L/2) = Σ vₙφₙ(L/2) > 0 [kg^-½].
    pub phi_mid: f64,
    /// Modal vector v (unit length, ψ(L/2) > 0).
    pub vector: Vec<f64>,
}

#[cfg(test)]
mod tests {
    /// Regression (found by the fuzzer): a denormal k_r made EI/(k_r L) infinite and nalgebra's
    /// SVD loop forever; tiny or huge stiffnesses must give modes or an error, never a hang.
    #[test]
    fn extreme_rotational_stiffness_is_an_error_or_modes_never_a_hang() {
        for k_r in [1255e-324, 1e-320, 1e-300, 1e-200, 1e-100, 1e-12, 1e12, 1e100, 1e300] {
            let p = Params { k_r_nm_per_rad: k_r, ..Params::default() };
            match Beam::new(&p) {
                Ok(b) => assert!(b.omega.iter().all(|w| w.is_finite() && *w > 0.0), "k_r = {k_r}: {:?}", b.omega),
                Err(e) => assert!(e.to_string().contains("k_r_nm_per_rad") || matches!(e, Error::Numerical(_)), "{e}"),
            }
        }
        let e = Beam::new(&Params { k_r_nm_per_rad: 1255e-324, ..Params::default() }).unwrap_err().to_string();
        assert!(e.contains("k_r_nm_per_rad"), "{e}");
    }

    use super::*;

    fn beam(p: &Params) -> Beam {
        Beam::new(p).unwrap()
    }

    /// ω₁ with preload from the eigenvalue problem: equal to mode 1 bit for bit without preload;
    /// with preload below the Rayleigh estimate by its known second-order error
    /// ω_R² − ω² ≈ Σ_{j>1} (H₀K₁ⱼ)²/(ωⱼ² − ω₁²), for tension and compression.
    #[test]
    fn first_mode_with_preload_is_the_eigenvalue_and_rayleigh_errs_by_second_order() {
        let p = Params::default();
        let b = beam(&p);
        let m = b.first_mode(p.thickness_m);
        assert_eq!(m.omega_rad_s.to_bits(), b.omega[0].to_bits());
        assert_eq!(m.b_star_per_s2.to_bits(), b.b_star(p.thickness_m).to_bits());
        for h0 in [40.0, -15.0, 150.0] {
            let q = Params { axial_preload_n: h0, ..Params::default() };
            let b = beam(&q);
            let m = b.first_mode(q.thickness_m);
            let n = b.n;
            let pert: f64 = (1..n).map(|j| (h0 * b.k[j]).powi(2) / (b.omega[j].powi(2) - b.omega[0].powi(2))).sum();
            let err = m.omega_rayleigh_rad_s.powi(2) - m.omega_rad_s.powi(2);
            assert!(err > 0.0, "H0 = {h0}: Rayleigh must be an upper bound");
            // The next term is of third order: the mismatch shrinks in proportion to H₀
            // (6.5 % at 150 N with the defaults).
            let tol = 0.1 * h0.abs() / 150.0 + 1e-3;
            assert!((err / pert - 1.0).abs() < tol, "H0 = {h0}: error {err} vs second-order {pert}");
            // The eigenpair solves the problem.
            let r: f64 = (0..n)
                .map(|i| {
                    let kv: f64 = (0..n).map(|j| h0 * b.k[i * n + j] * m.vector[j]).sum();
                    (b.omega[i].powi(2) * m.vector[i] + kv - m.omega_rad_s.powi(2) * m.vector[i]).abs()
                })
                .fold(0.0, f64::max);
            assert!(r < 1e-9 * m.omega_rad_s.powi(2), "H0 = {h0}: residual {r}");
            assert!(m.phi_mid > 0.0 && m.b_star_per_s2 > 0.0);
        }
    }

    #[test]
    fn modal_frequencies_match_model_md() {
        let f = beam(&Params::default()).frequencies_hz();
        let expect = [260.2805, 719.0106, 1412.324, 2338.976, 3500.124];
        for (a, b) in f.iter().zip(expect) {
            // docs/model.md gives 7 significant digits; our values must agree to 1e-6 relative.
            assert!(((a - b) / b).abs() < 1e-6, "{a} vs {b}");
        }
    }

    #[test]
    fn clamped_limit() {
        let p = Params { k_r_nm_per_rad: f64::INFINITY, k_t_n_per_m: f64::INFINITY, ..Params::default() };
        let b = beam(&p);
        assert!((b.lambda[0] - 4.730041).abs() < 5e-7, "{}", b.lambda[0]);
        assert!((b.frequencies_hz()[0] - 274.187).abs() < 1e-3);
        // Clamped: zero slope at both ends.
        for m in 0..b.n {
            assert!(b.dphi_exact(m, 0.0).abs() < 1e-9 * b.dphi_exact(m, 0.3 * b.length_m).abs().max(1.0));
        }
        // Very stiff finite springs approach the clamped limit.
        let q = Params { k_r_nm_per_rad: 1e9, ..p };
        assert!((beam(&q).lambda[0] - 4.730041).abs() < 1e-5);
    }

    #[test]
    fn unit_modal_mass_and_orthogonality() {
        let p = Params::default();
        let b = beam(&p);
        let gl = GaussLegendre::new(256, 8);
        let rho_a = p.beam_mass_kg / p.length_m;
        for i in 0..b.n {
            for j in 0..b.n {
                let m = rho_a * p.length_m * gl.integrate(|xi| b.phi_exact(i, xi * p.length_m) * b.phi_exact(j, xi * p.length_m));
                let expect = if i == j { 1.0 } else { 0.0 };
                assert!((m - expect).abs() < 1e-10, "M[{i}{j}] = {m}");
            }
            assert!(b.coef[i][0] > 0.0, "sine coefficient positive");
        }
    }

    #[test]
    fn k_symmetric_positive_definite() {
        let b = beam(&Params { n_modes: 8, ..Params::default() });
        let n = b.n;
        let km = nalgebra::DMatrix::from_row_slice(n, n, &b.k);
        assert!((km.clone() - km.transpose()).abs().max() < 1e-12 * km.abs().max());
        let eig = km.symmetric_eigen();
        assert!(eig.eigenvalues.iter().all(|&e| e > 0.0), "{:?}", eig.eigenvalues);
    }

    #[test]
    fn table_matches_closed_form() {
        for n_modes in [5, 20] {
            for k_r in [125.0, f64::INFINITY, 1.0] {
                let b = beam(&Params { n_modes, k_r_nm_per_rad: k_r, ..Params::default() });
                let l = b.length_m;
                let mut phi = vec![0.0; n_modes];
                let mut dphi = vec![0.0; n_modes];
                let amp: Vec<f64> = (0..n_modes).map(|m| (0..200).map(|i| b.phi_exact(m, i as f64 * l / 199.0).abs()).fold(0.0, f64::max)).collect();
                let damp: Vec<f64> = (0..n_modes).map(|m| (0..200).map(|i| b.dphi_exact(m, i as f64 * l / 199.0).abs()).fold(0.0, f64::max)).collect();
                let mut worst: f64 = 0.0;
                for i in 0..=20011 {
                    let x = l * (-0.2 + 1.4 * i as f64 / 20011.0);
                    b.eval(x, &mut phi, &mut dphi);
                    for m in 0..n_modes {
                        // Relative to the in-beam amplitude (beyond the ends, to the value itself).
                        let (pe, de) = (b.phi_exact(m, x), b.dphi_exact(m, x));
                        worst = worst.max((phi[m] - pe).abs() / amp[m].max(pe.abs()));
                        worst = worst.max((dphi[m] - de).abs() / damp[m].max(de.abs()));
                    }
                }
                eprintln!("N={n_modes} k_r={k_r}: worst relative table error {worst:.2e}");
                assert!(worst < 1e-10, "N={n_modes} k_r={k_r}: {worst}");
                // The const-size path of the time loop gives the same values.
                if n_modes == 5 {
                    for i in 0..997 {
                        let x = l * (-0.2 + 1.4 * i as f64 / 997.0);
                        b.eval(x, &mut phi, &mut dphi);
                        let (p5, d5) = b.eval_n::<5>(x);
                        for m in 0..5 {
                            assert!((p5[m] - phi[m]).abs() <= 1e-13 * amp[m].max(phi[m].abs()));
                            assert!((d5[m] - dphi[m]).abs() <= 1e-13 * damp[m].max(dphi[m].abs()));
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn b_star_and_ideal_clamping_ratios() {
        let p = Params::default();
        let b = beam(&p);
        let bs = b.b_star(p.thickness_m);
        assert!((bs / 9.52e5 - 1.0).abs() < 5e-3, "b* = {bs}");
        let ideal = Params { k_r_nm_per_rad: f64::INFINITY, k_t_n_per_m: f64::INFINITY, ..p.clone() };
        let bi = beam(&ideal);
        assert!((bi.b_star(p.thickness_m) / 2.13e6 - 1.0).abs() < 5e-3);
        let drop = 1.0 - b.frequencies_hz()[0] / bi.frequencies_hz()[0];
        assert!((drop - 0.0507).abs() < 5e-4, "{drop}");
        let kt_inf = beam(&Params { k_t_n_per_m: f64::INFINITY, ..p.clone() });
        let ratio = 1.0 - bs / kt_inf.b_star(p.thickness_m);
        assert!((ratio - 0.522).abs() < 1e-3, "{ratio}");
    }
}
