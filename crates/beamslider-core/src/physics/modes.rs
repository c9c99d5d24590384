//! The modal basis of the beam of docs/model.md §2.1: mode shapes in the well-conditioned
//! exponential basis, their eigenvalues, Gauss–Legendre quadrature and the piecewise Taylor
//! table of φ and φ'.

use nalgebra::{Matrix4, SVD};

use crate::arith::fma;
use crate::error::{Error, Result};

/// Degree of the local Taylor polynomials of the mode table.
pub const TABLE_DEGREE: usize = 4;
/// Coefficients per polynomial.
pub const TABLE_NCOEF: usize = TABLE_DEGREE + 1;
/// Tabulated range of ξ = x/L (beyond the beam, for the reference manifold sweep at s = 0).
pub const TABLE_XI_MIN: f64 = -0.25;
/// Upper end of the tabulated range of ξ.
pub const TABLE_XI_MAX: f64 = 1.25;

/// Piecewise Taylor table of φ and φ' (x-derivative) of all modes.
///
/// Layout: `data[((j * 2 + f) * NCOEF + k) * n + m]` for interval j, function f (0 = φ, 1 = φ'),
/// power k of the local variable u ∈ [−1, 1], mode m — modes contiguous for vectorised Horner.
#[derive(Debug, Clone)]
pub struct ModeTable {
    pub(super) n: usize,
    /// 1/(L · interval width) and the offset −ξ_min/width: r = x · scale + offset.
    pub(super) x_scale: f64,
    pub(super) x_offset: f64,
    pub(super) intervals_f: f64,
    pub(super) data: Vec<f64>,
}

/// φ in the exponential basis at ξ (not normalised by anything).
pub(super) fn phi_basis(a: &[f64; 4], lam: f64, xi: f64) -> f64 {
    let (s, c) = (lam * xi).sin_cos();
    a[0] * s + a[1] * c + a[2] * (-lam * xi).exp() + a[3] * (-lam * (1.0 - xi)).exp()
}

/// dφ/dξ in the exponential basis.
pub(super) fn dphi_basis(a: &[f64; 4], lam: f64, xi: f64) -> f64 {
    let (s, c) = (lam * xi).sin_cos();
    lam * (a[0] * c - a[1] * s - a[2] * (-lam * xi).exp() + a[3] * (-lam * (1.0 - xi)).exp())
}

/// k-th ξ-derivative of φ at ξ.
pub(super) fn phi_derivative(a: &[f64; 4], lam: f64, xi: f64, k: usize) -> f64 {
    let (s, c) = (lam * xi).sin_cos();
    // d^k sin = λ^k sin(λξ + kπ/2), d^k cos = λ^k cos(λξ + kπ/2), exactly by cycling.
    let (sk, ck) = match k % 4 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    };
    let sign = if k.is_multiple_of(2) { 1.0 } else { -1.0 };
    lam.powi(k as i32) * (a[0] * sk + a[1] * ck + sign * a[2] * (-lam * xi).exp() + a[3] * (-lam * (1.0 - xi)).exp())
}

/// Boundary matrix B(λ) of docs/model.md §2 in the exponential basis, rows scaled by 1/(κλ)
/// so that ε = 1/κ = 0 (ideal clamping) is regular.
pub(super) fn boundary_matrix(eps: f64, lam: f64) -> Matrix4<f64> {
    let e = (-lam).exp();
    let (s, c) = lam.sin_cos();
    let el = eps * lam;
    Matrix4::new(
        0.0,
        1.0,
        1.0,
        e, // φ(0) = 0
        -1.0,
        -el,
        el + 1.0,
        (el - 1.0) * e, // ε φ''(0)/λ² − φ'(0)/λ = 0
        s,
        c,
        e,
        1.0, // φ(1) = 0
        -el * s + c,
        -el * c - s,
        (el - 1.0) * e,
        el + 1.0, // ε φ''(1)/λ² + φ'(1)/λ = 0
    )
}

/// The first n roots of det B(λ) = 0 (bracketed on a grid, refined by bisection).
pub(super) fn find_roots(eps: f64, n: usize) -> Result<Vec<f64>> {
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
            return Err(Error::Numerical(format!("found only {} of {} beam eigenvalues", roots.len(), n)));
        }
    }
    Ok(roots)
}

/// Null vector of B(λ) with positive sine coefficient (largest-magnitude entry 1 before normalising).
pub(super) fn null_vector(eps: f64, lam: f64) -> Result<[f64; 4]> {
    let b = boundary_matrix(eps, lam);
    // nalgebra's `SVD::new` iterates without a cap and never returns on non-finite input.
    if !b.iter().all(|v| v.is_finite()) {
        return Err(Error::Numerical(format!("non-finite boundary matrix at lambda = {lam}")));
    }
    let svd = SVD::try_new(b, false, true, 5.0 * f64::EPSILON, 10_000) // the tolerance of `SVD::new`
        .ok_or_else(|| Error::Numerical("SVD of the boundary matrix did not converge".into()))?;
    let v_t = svd.v_t.ok_or_else(|| Error::Numerical("SVD of the boundary matrix failed".into()))?;
    let (imin, _) = svd.singular_values.iter().enumerate().fold((0, f64::INFINITY), |acc, (i, &s)| if s < acc.1 { (i, s) } else { acc });
    let mut a = [v_t[(imin, 0)], v_t[(imin, 1)], v_t[(imin, 2)], v_t[(imin, 3)]];
    if a[0] < 0.0 {
        for v in a.iter_mut() {
            *v = -*v;
        }
    }
    Ok(a)
}

/// Composite Gauss–Legendre rule on [0, 1].
pub(super) struct GaussLegendre {
    pub(super) nodes: Vec<f64>,
    pub(super) weights: Vec<f64>,
}

impl GaussLegendre {
    pub(super) fn new(panels: usize, order: usize) -> Self {
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

    pub(super) fn integrate(&self, f: impl Fn(f64) -> f64) -> f64 {
        self.nodes.iter().zip(&self.weights).map(|(&x, &w)| w * f(x)).sum()
    }
}

impl ModeTable {
    pub(super) fn build(coef: &[[f64; 4]], lambda: &[f64], length_m: f64) -> ModeTable {
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
        ModeTable { n, x_scale: 1.0 / (width * length_m), x_offset: -TABLE_XI_MIN / width, intervals_f: intervals as f64, data }
    }

    /// Locate x [m] (no division): interval index and local variable u ∈ [−1, 1].
    #[inline(always)]
    pub(super) fn locate_x(&self, x: f64) -> Option<(usize, f64)> {
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
    pub(super) unsafe fn locate_covered(&self, x: f64) -> (usize, f64) {
        let r = fma(x, self.x_scale, self.x_offset);
        debug_assert!(r >= 0.0 && r < self.intervals_f);
        // u from ⌊r⌋ in floating point (short chain), the index from it in parallel; for
        // 0 ≤ r < 2³¹ both are the same as truncation.
        let fl = r.floor();
        // SAFETY: 0 ≤ x ≤ L gives 0 < r < intervals, so the truncation fits in i32.
        let ji = unsafe { fl.to_int_unchecked::<i32>() };
        (ji as usize, fma(2.0, r - fl, -1.0))
    }

    pub(super) fn eval(&self, x: f64, phi: &mut [f64], dphi: &mut [f64]) -> bool {
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
    pub(super) fn horner_n<const N: usize>(&self, j: usize, f: usize, u: f64) -> [f64; N] {
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
