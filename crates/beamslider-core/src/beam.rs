//! Beam of docs/model.md §2: linear modes of the elastically clamped Euler–Bernoulli beam,
//! modal mass normalisation, γₙ, the slope Gram matrix K and the string force
//! Fₙ(q) = (k_ax/2)(qᵀKq)(Kq)ₙ; fast tabulated evaluation of φ and φ'.
//!
//! Mode shapes are written in the well-conditioned basis
//! φ(ξ) = a₁ sin λξ + a₂ cos λξ + a₃ e^{−λξ} + a₄ e^{−λ(1−ξ)}, which spans the same space as
//! sin, cos, sinh, cosh but loses no digits for high modes. a₁ (the sine coefficient) is
//! positive, as docs/model.md's convention c₁ = +1 asks.

use nalgebra::{Matrix4, SVD};

use crate::arith::fma;
use crate::error::{Error, Result};
use crate::params::Params;

/// Degree of the local Taylor polynomials of the mode table.
pub const TABLE_DEGREE: usize = 4;
/// Coefficients per polynomial.
pub const TABLE_NCOEF: usize = TABLE_DEGREE + 1;
/// Tabulated range of ξ = x/L (beyond the beam, for the reference manifold sweep at s = 0).
pub const TABLE_XI_MIN: f64 = -0.25;
/// Upper end of the tabulated range of ξ.
pub const TABLE_XI_MAX: f64 = 1.25;

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

/// Piecewise Taylor table of φ and φ' (x-derivative) of all modes.
///
/// Layout: `data[((j * 2 + f) * NCOEF + k) * n + m]` for interval j, function f (0 = φ, 1 = φ'),
/// power k of the local variable u ∈ [−1, 1], mode m — modes contiguous for vectorised Horner.
#[derive(Debug, Clone)]
pub struct ModeTable {
    n: usize,
    /// 1/(L · interval width) and the offset −ξ_min/width: r = x · scale + offset.
    x_scale: f64,
    x_offset: f64,
    intervals_f: f64,
    data: Vec<f64>,
}

/// Beams built by [`Beam::shared`], most recent last (a handful: the reduced predictor asks for
/// the same beam at every operating point).
static SHARED: std::sync::Mutex<Vec<(Params, std::sync::Arc<Beam>)>> = std::sync::Mutex::new(Vec::new());
const SHARED_MAX: usize = 4;

impl Beam {
    /// [`Beam::new`], shared: the beam of equal parameters is built once per process and reused
    /// (the same value `new` returns; a small cache of the last few parameter sets).
    pub fn shared(p: &Params) -> Result<std::sync::Arc<Beam>> {
        if let Ok(cache) = SHARED.lock()
            && let Some((_, b)) = cache.iter().rev().find(|(q, _)| q == p)
        {
            return Ok(b.clone());
        }
        let b = std::sync::Arc::new(Beam::new(p)?);
        if let Ok(mut cache) = SHARED.lock() {
            if cache.len() >= SHARED_MAX {
                cache.remove(0);
            }
            cache.push((p.clone(), b.clone()));
        }
        Ok(b)
    }

    /// Modes of the beam with the parameters' geometry and clamping (k_r may be +inf).
    pub fn new(p: &Params) -> Result<Beam> {
        p.validate()?;
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
        let gamma = coef
            .iter()
            .zip(&lambda)
            .map(|(a, &lam)| rho_a * l * gl.integrate(|xi| phi_basis(a, lam, xi)))
            .collect();
        let mut k = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..=i {
                // φ'(x) = (1/L) dφ/dξ ; ∫₀ᴸ φᵢ'φⱼ' dx = (1/L) ∫₀¹ φᵢ,ξ φⱼ,ξ dξ.
                let v = gl.integrate(|xi| {
                    dphi_basis(&coef[i], lambda[i], xi) * dphi_basis(&coef[j], lambda[j], xi)
                }) / l;
                k[i * n + j] = v;
                k[j * n + i] = v;
            }
        }
        if p.axial_preload_n < 0.0 {
            // Compression: diag(ω²) + H₀ K must stay positive definite (below buckling).
            let stiff = nalgebra::DMatrix::from_fn(n, n, |i, j| {
                (if i == j { omega[i] * omega[i] } else { 0.0 }) + p.axial_preload_n * k[i * n + j]
            });
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
        Ok(Beam {
            slope_bound,
            n,
            length_m: l,
            lambda,
            omega,
            gamma,
            k,
            k_ax: p.axial_stiffness(),
            preload_n: p.axial_preload_n,
            coef,
            table,
        })
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
        if loc.inside {
            self.table.horner_n::<N>(loc.j, 0, loc.u)
        } else {
            std::array::from_fn(|m| self.phi_exact(m, loc.x))
        }
    }

    /// Mode slopes φ₁'..φ_N' (x-derivatives) at a located x.
    #[inline(always)]
    pub fn dphi_n<const N: usize>(&self, loc: &Loc) -> [f64; N] {
        if loc.inside {
            self.table.horner_n::<N>(loc.j, 1, loc.u)
        } else {
            std::array::from_fn(|m| self.dphi_exact(m, loc.x))
        }
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

    /// The slope Gram matrix K (N×N, symmetric) as a nalgebra matrix [1/(kg m)].
    pub fn k_matrix(&self) -> nalgebra::DMatrix<f64> {
        nalgebra::DMatrix::from_row_slice(self.n, self.n, &self.k)
    }

    /// Linear modal stiffness diag(ωₙ²) + H₀ K (the axial preload's geometric stiffness) [s⁻²].
    pub fn linear_stiffness(&self) -> nalgebra::DMatrix<f64> {
        let n = self.n;
        nalgebra::DMatrix::from_fn(n, n, |i, j| {
            (if i == j { self.omega[i] * self.omega[i] } else { 0.0 }) + self.preload_n * self.k[i * n + j]
        })
    }

    /// Single-mode hardening coefficient b = (k_ax/2) K₁₁² of mode 1 (docs/model.md §9) [1/(kg m² s²)]:
    /// the string force of mode 1 alone is b q₁³.
    pub fn hardening_b(&self) -> f64 {
        0.5 * self.k_ax * self.k[0] * self.k[0]
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
        let stiff = nalgebra::DMatrix::from_fn(n, n, |i, j| {
            (if i == j { self.omega[i] * self.omega[i] } else { 0.0 }) + self.preload_n * self.k[i * n + j]
        });
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

/// φ in the exponential basis at ξ (not normalised by anything).
fn phi_basis(a: &[f64; 4], lam: f64, xi: f64) -> f64 {
    let (s, c) = (lam * xi).sin_cos();
    a[0] * s + a[1] * c + a[2] * (-lam * xi).exp() + a[3] * (-lam * (1.0 - xi)).exp()
}

/// dφ/dξ in the exponential basis.
fn dphi_basis(a: &[f64; 4], lam: f64, xi: f64) -> f64 {
    let (s, c) = (lam * xi).sin_cos();
    lam * (a[0] * c - a[1] * s - a[2] * (-lam * xi).exp() + a[3] * (-lam * (1.0 - xi)).exp())
}

/// k-th ξ-derivative of φ at ξ.
fn phi_derivative(a: &[f64; 4], lam: f64, xi: f64, k: usize) -> f64 {
    let (s, c) = (lam * xi).sin_cos();
    // d^k sin = λ^k sin(λξ + kπ/2), d^k cos = λ^k cos(λξ + kπ/2), exactly by cycling.
    let (sk, ck) = match k % 4 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    };
    let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
    lam.powi(k as i32)
        * (a[0] * sk + a[1] * ck + sign * a[2] * (-lam * xi).exp() + a[3] * (-lam * (1.0 - xi)).exp())
}

/// Boundary matrix B(λ) of docs/model.md §2 in the exponential basis, rows scaled by 1/(κλ)
/// so that ε = 1/κ = 0 (ideal clamping) is regular.
fn boundary_matrix(eps: f64, lam: f64) -> Matrix4<f64> {
    let e = (-lam).exp();
    let (s, c) = lam.sin_cos();
    let el = eps * lam;
    Matrix4::new(
        0.0, 1.0, 1.0, e, // φ(0) = 0
        -1.0, -el, el + 1.0, (el - 1.0) * e, // ε φ''(0)/λ² − φ'(0)/λ = 0
        s, c, e, 1.0, // φ(1) = 0
        -el * s + c, -el * c - s, (el - 1.0) * e, el + 1.0, // ε φ''(1)/λ² + φ'(1)/λ = 0
    )
}

/// The first n roots of det B(λ) = 0 (bracketed on a grid, refined by bisection).
fn find_roots(eps: f64, n: usize) -> Result<Vec<f64>> {
    let det = |lam: f64| boundary_matrix(eps, lam).determinant();
    let mut roots = Vec::with_capacity(n);
    let step = 0.02;
    let mut a = 1.0;
    let mut fa = det(a);
    while roots.len() < n {
        let b = a + step;
        let fb = det(b);
        if fa == 0.0 {
            roots.push(a);
        } else if fa.signum() != fb.signum() {
            let (mut lo, mut hi, mut flo) = (a, b, fa);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                let fm = det(mid);
                if fm == 0.0 {
                    lo = mid;
                    hi = mid;
                    break;
                }
                if fm.signum() == flo.signum() {
                    lo = mid;
                    flo = fm;
                } else {
                    hi = mid;
                }
            }
            roots.push(0.5 * (lo + hi));
        }
        a = b;
        fa = fb;
        if a > 10.0 * (n as f64 + 2.0) * std::f64::consts::PI {
            return Err(Error::Numerical(format!(
                "found only {} of {} beam eigenvalues",
                roots.len(),
                n
            )));
        }
    }
    Ok(roots)
}

/// Null vector of B(λ) with positive sine coefficient (largest-magnitude entry 1 before normalising).
fn null_vector(eps: f64, lam: f64) -> Result<[f64; 4]> {
    let b = boundary_matrix(eps, lam);
    // nalgebra's `SVD::new` iterates without a cap and never returns on non-finite input.
    if !b.iter().all(|v| v.is_finite()) {
        return Err(Error::Numerical(format!("non-finite boundary matrix at lambda = {lam}")));
    }
    let svd = SVD::try_new(b, false, true, 5.0 * f64::EPSILON, 10_000) // the tolerance of `SVD::new`
        .ok_or_else(|| Error::Numerical("SVD of the boundary matrix did not converge".into()))?;
    let v_t = svd
        .v_t
        .ok_or_else(|| Error::Numerical("SVD of the boundary matrix failed".into()))?;
    let (imin, _) = svd
        .singular_values
        .iter()
        .enumerate()
        .fold((0, f64::INFINITY), |acc, (i, &s)| if s < acc.1 { (i, s) } else { acc });
    let mut a = [v_t[(imin, 0)], v_t[(imin, 1)], v_t[(imin, 2)], v_t[(imin, 3)]];
    if a[0] < 0.0 {
        for v in a.iter_mut() {
            *v = -*v;
        }
    }
    Ok(a)
}

/// Composite Gauss–Legendre rule on [0, 1].
struct GaussLegendre {
    nodes: Vec<f64>,
    weights: Vec<f64>,
}

impl GaussLegendre {
    fn new(panels: usize, order: usize) -> Self {
        // Nodes of P_order on [-1, 1] by Newton's method.
        let mut x_ref = Vec::new();
        let mut w_ref = Vec::new();
        for i in 0..order {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (order as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=order {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = order as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            x_ref.push(x);
            w_ref.push(2.0 / ((1.0 - x * x) * dp * dp));
        }
        let h = 1.0 / panels as f64;
        let mut nodes = Vec::with_capacity(panels * order);
        let mut weights = Vec::with_capacity(panels * order);
        for p in 0..panels {
            let c = (p as f64 + 0.5) * h;
            for (x, w) in x_ref.iter().zip(&w_ref) {
                nodes.push(c + 0.5 * h * x);
                weights.push(0.5 * h * w);
            }
        }
        GaussLegendre { nodes, weights }
    }

    fn integrate(&self, f: impl Fn(f64) -> f64) -> f64 {
        self.nodes.iter().zip(&self.weights).map(|(&x, &w)| w * f(x)).sum()
    }
}

impl ModeTable {
    fn build(coef: &[[f64; 4]], lambda: &[f64], length_m: f64) -> ModeTable {
        let n = coef.len();
        let lam_max = lambda.iter().cloned().fold(0.0, f64::max);
        let span = TABLE_XI_MAX - TABLE_XI_MIN;
        // Half-width hw with λ_max hw ≤ 1/64: Taylor remainder (λ hw)^5/5! ≈ 1e-11 of the amplitude.
        let intervals = ((span * lam_max * 32.0).ceil() as usize).max(16);
        let width = span / intervals as f64;
        let hw = 0.5 * width;
        let mut data = vec![0.0; intervals * 2 * TABLE_NCOEF * n];
        let mut fact = [1.0; TABLE_NCOEF + 1];
        for k in 1..=TABLE_NCOEF {
            fact[k] = fact[k - 1] * k as f64;
        }
        for j in 0..intervals {
            let xc = TABLE_XI_MIN + (j as f64 + 0.5) * width;
            for m in 0..n {
                for k in 0..TABLE_NCOEF {
                    let hk = hw.powi(k as i32) / fact[k];
                    let d0 = phi_derivative(&coef[m], lambda[m], xc, k);
                    let d1 = phi_derivative(&coef[m], lambda[m], xc, k + 1) / length_m;
                    data[((j * 2) * TABLE_NCOEF + k) * n + m] = d0 * hk;
                    data[((j * 2 + 1) * TABLE_NCOEF + k) * n + m] = d1 * hk;
                }
            }
        }
        ModeTable {
            n,
            x_scale: 1.0 / (width * length_m),
            x_offset: -TABLE_XI_MIN / width,
            intervals_f: intervals as f64,
            data,
        }
    }

    /// Locate x [m] (no division): interval index and local variable u ∈ [−1, 1].
    #[inline(always)]
    fn locate_x(&self, x: f64) -> Option<(usize, f64)> {
        let r = fma(x, self.x_scale, self.x_offset);
        if !(r >= 0.0 && r < self.intervals_f) {
            return None;
        }
        // SAFETY: 0 ≤ r < intervals (checked above), so the truncation fits in i32.
        let ji = unsafe { r.to_int_unchecked::<i32>() };
        Some((ji as usize, fma(2.0, r - ji as f64, -1.0)))
    }

    /// [`ModeTable::locate_x`] for an x the table covers; the same (j, u).
    ///
    /// # Safety
    /// 0 ≤ x ≤ L.
    #[inline(always)]
    unsafe fn locate_covered(&self, x: f64) -> (usize, f64) {
        let r = fma(x, self.x_scale, self.x_offset);
        debug_assert!(r >= 0.0 && r < self.intervals_f);
        // u from ⌊r⌋ in floating point (short chain), the index from it in parallel; for
        // 0 ≤ r < 2³¹ both are the same as truncation.
        let fl = r.floor();
        // SAFETY: 0 ≤ x ≤ L gives 0 < r < intervals, so the truncation fits in i32.
        let ji = unsafe { fl.to_int_unchecked::<i32>() };
        (ji as usize, fma(2.0, r - fl, -1.0))
    }

    fn eval(&self, x: f64, phi: &mut [f64], dphi: &mut [f64]) -> bool {
        let Some((j, u)) = self.locate_x(x) else {
            return false;
        };
        let n = self.n;
        let base = j * 2 * TABLE_NCOEF * n;
        for m in 0..n {
            let mut p = 0.0;
            let mut d = 0.0;
            for k in (0..TABLE_NCOEF).rev() {
                p = p * u + self.data[base + k * n + m];
                d = d * u + self.data[base + (TABLE_NCOEF + k) * n + m];
            }
            phi[m] = p;
            dphi[m] = d;
        }
        true
    }

    /// Evaluation of function f (0 = φ, 1 = φ') of all N modes in interval j at u
    /// (Estrin's scheme for the quartic with fused multiply-adds:
    /// (c₀ + c₁u) + u²((c₂ + c₃u) + u² c₄), short dependency chain).
    #[inline(always)]
    fn horner_n<const N: usize>(&self, j: usize, f: usize, u: f64) -> [f64; N] {
        debug_assert_eq!(N, self.n);
        const _: () = assert!(TABLE_NCOEF == 5);
        let base = (j * 2 + f) * TABLE_NCOEF * N;
        let block = &self.data[base..base + TABLE_NCOEF * N];
        let (c0, rest) = block.split_at(N);
        let (c1, rest) = rest.split_at(N);
        let (c2, rest) = rest.split_at(N);
        let (c3, c4) = rest.split_at(N);
        let u2 = u * u;
        let mut p = [0.0; N];
        for m in 0..N {
            p[m] = fma(u2, fma(u2, c4[m], fma(c3[m], u, c2[m])), fma(c1[m], u, c0[m]));
        }
        p
    }
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
            let pert: f64 =
                (1..n).map(|j| (h0 * b.k[j]).powi(2) / (b.omega[j].powi(2) - b.omega[0].powi(2))).sum();
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
        let p = Params {
            k_r_nm_per_rad: f64::INFINITY,
            k_t_n_per_m: f64::INFINITY,
            ..Params::default()
        };
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
                let m = rho_a * p.length_m
                    * gl.integrate(|xi| b.phi_exact(i, xi * p.length_m) * b.phi_exact(j, xi * p.length_m));
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
                let amp: Vec<f64> = (0..n_modes)
                    .map(|m| (0..200).map(|i| b.phi_exact(m, i as f64 * l / 199.0).abs()).fold(0.0, f64::max))
                    .collect();
                let damp: Vec<f64> = (0..n_modes)
                    .map(|m| (0..200).map(|i| b.dphi_exact(m, i as f64 * l / 199.0).abs()).fold(0.0, f64::max))
                    .collect();
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
