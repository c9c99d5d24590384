//! Layer-(a) options of docs/model.md §6.4: multi-harmonic balance and static sag.
//!
//! The reduced model of [`super`] (slider rigidly attached at x = sL),
//!
//! ```text
//! M(s) q̈ + C q̇ + Λ q + f_nl(q) + f_D₂(q, q̇) = Γ(s) a_ex cos Ωt − σ m g Φ(s),
//! ```
//!
//! with σ = 1 when the static sag is on (gravity acts on the slider only, MODEL.md §1) and 0
//! otherwise, is balanced on the ansatz
//!
//! ```text
//! q(t) = Σ_{k ∈ 𝒦} Re(Q_k e^{ikΩt}),   Q₀ real,
//! 𝒦 = {1, 3, …, H}            (odd harmonics; without sag the system is odd-symmetric),
//! 𝒦 = {0, 1, 2, …, H}          (with sag: the static part Q₀ breaks the symmetry, the quadratic
//!                                terms Q₀Q_k Q_l feed the even harmonics).
//! ```
//!
//! Residual of harmonic k (complex for k ≥ 1, real for k = 0):
//!
//! ```text
//! R_k = (Λ − k²Ω² M(s) + i kΩ C) Q_k + F_k − δ_k1 Γ(s) a_ex + δ_k0 σ m g Φ(s),
//! F_k = (2/N_t) Σ_j f(q(τ_j), q̇(τ_j)) e^{−ikτ_j}  (k ≥ 1),   F₀ = (1/N_t) Σ_j f(τ_j),
//! ```
//!
//! on N_t equidistant samples τ_j = 2πj/N_t of one period (alternating frequency–time method,
//! explicit DFT sums: the sizes are tiny). The nonlinearity f = f_nl + f_D₂ is a cubic
//! polynomial, so with N_t > 4·max 𝒦 (no aliasing onto the retained harmonics) the AFT projection
//! is the exact Galerkin projection: for 𝒦 = {1} it reproduces the closed-form first-harmonic
//! terms of [`super::HbSystem`] to rounding. The Jacobian is the AFT of the exact time-domain
//! derivatives ∂f/∂q = (k_ax/2)[(qᵀKq)K + 2Kq(Kq)ᵀ] (+ the D₂ terms), so it is exact as well.
//!
//! The unknown vector is laid out as (Re Q₁, Im Q₁, then Re Q_k, Im Q_k for the other k ≥ 1
//! ascending, then Q₀), so the first harmonic sits where the single-term solver keeps it and the
//! continuation, fold detection, stability flag (sign of det ∂R/∂x between folds; Hill's method
//! is not implemented) and branch assembly of [`super`] apply unchanged.

use nalgebra::{DMatrix, DVector};

use super::hb_terms::{HbTerms, Param};

/// The AFT harmonic-balance residual for the harmonic set 𝒦 (docs/model.md §6.4).
#[derive(Debug, Clone)]
pub(super) struct Mhb {
    /// Harmonic orders in layout order: 1, then the others ≥ 2 ascending, then 0 (with sag).
    pub(super) orders: Vec<usize>,
    /// Offset of each order's block in the unknowns (2N wide for k ≥ 1, N for k = 0).
    offsets: Vec<usize>,
    /// Number of real unknowns (parameter excluded).
    pub(super) nx: usize,
    /// Time samples per period.
    nt: usize,
    /// cos(kτ_j), sin(kτ_j) per order (index as `orders`), row-major (order, j).
    cos: Vec<f64>,
    sin: Vec<f64>,
    /// Static load σ m g (N): the slider's weight (0 without sag).
    weight: f64,
    /// Highest order H.
    kmax: usize,
    /// cos(mτ_j), sin(mτ_j) for m = 0..=2H, row-major (m, j) (Jacobian sums).
    tc: Vec<f64>,
    ts: Vec<f64>,
}

impl Mhb {
    /// Harmonic set for `harmonics` = H (odd, ≥ 1) with or without the static sag.
    pub(super) fn new(n: usize, harmonics: usize, sag: bool, slider_weight_n: f64) -> Mhb {
        let mut orders = vec![1];
        if sag {
            orders.extend(2..=harmonics);
            orders.push(0);
        } else {
            orders.extend((3..=harmonics).step_by(2));
        }
        let mut offsets = Vec::with_capacity(orders.len());
        let mut nx = 0;
        for &k in &orders {
            offsets.push(nx);
            nx += if k == 0 { n } else { 2 * n };
        }
        let kmax = harmonics;
        // Exact projection of a cubic: N_t > 4 k_max; at least 8 samples.
        let nt = (4 * kmax + 1).next_power_of_two().max(8);
        let mut cos = Vec::with_capacity(orders.len() * nt);
        let mut sin = Vec::with_capacity(orders.len() * nt);
        for &k in &orders {
            for j in 0..nt {
                let tau = 2.0 * std::f64::consts::PI * ((k * j) % nt) as f64 / nt as f64;
                cos.push(tau.cos());
                sin.push(tau.sin());
            }
        }
        let mut tc = Vec::with_capacity((2 * kmax + 1) * nt);
        let mut ts = Vec::with_capacity((2 * kmax + 1) * nt);
        for m in 0..=2 * kmax {
            for j in 0..nt {
                let tau = 2.0 * std::f64::consts::PI * ((m * j) % nt) as f64 / nt as f64;
                tc.push(tau.cos());
                ts.push(tau.sin());
            }
        }
        Mhb { orders, offsets, nx, nt, cos, sin, weight: if sag { slider_weight_n } else { 0.0 }, kmax, tc, ts }
    }

    /// Amplitudes |Φ(4L/7)ᵀQ_k| / h per order (for k = 0: the signed static value) of the scaled
    /// unknowns y.
    pub(super) fn harmonic_amplitudes(&self, sys: &HbTerms, y: &DVector<f64>) -> Vec<f64> {
        let n = sys.n;
        let scale = sys.q_ref / sys.thickness;
        self.orders
            .iter()
            .zip(&self.offsets)
            .map(|(&k, &o)| {
                let wr: f64 = (0..n).map(|i| sys.p47[i] * y[o + i]).sum();
                if k == 0 {
                    wr * scale
                } else {
                    let wi: f64 = (0..n).map(|i| sys.p47[i] * y[o + n + i]).sum();
                    wr.hypot(wi) * scale
                }
            })
            .collect()
    }

    /// Scaled residual r = R/f_ref and (optionally) the scaled Jacobian [∂r/∂x | ∂r/∂p], as
    /// `HbSystem::eval` for the single-term system.
    pub(super) fn eval(&self, sys: &HbTerms, y: &DVector<f64>, par: Param, want_j: bool) -> (DVector<f64>, DMatrix<f64>) {
        let n = sys.n;
        let nx = self.nx;
        let nt = self.nt;
        let (s, load) = match par {
            Param::S { load } => (y[nx], load),
            Param::Load { s } => (s, y[nx]),
        };
        let qs = sys.q_ref;
        let x = s * sys.length;
        let mut phi = DVector::zeros(n);
        let mut dphi = DVector::zeros(n);
        let mut ddphi = DVector::zeros(n);
        sys.beam.shapes_exact(x, phi.as_mut_slice(), dphi.as_mut_slice(), ddphi.as_mut_slice());
        let om2 = sys.omega_ex * sys.omega_ex;
        let mass = DMatrix::identity(n, n) + sys.mass * &phi * phi.transpose() + sys.j_g * &dphi * dphi.transpose();
        let gamma_s = &sys.gamma + sys.mass * &phi;
        // Physical unknowns per block.
        let blk = |o: usize, len: usize| DVector::from_fn(len, |i, _| y[o + i] * qs);

        // Linear part and forcing.
        let mut r = DVector::zeros(nx);
        for (h, &k) in self.orders.iter().enumerate() {
            let o = self.offsets[h];
            if k == 0 {
                let q0 = blk(o, n);
                let lq = &sys.lam * &q0;
                for i in 0..n {
                    r[o + i] = lq[i] + load * self.weight * phi[i];
                }
                continue;
            }
            let kf = k as f64;
            let u = blk(o, n);
            let v = blk(o + n, n);
            let z = &sys.lam - (kf * kf * om2) * &mass;
            let zu = &z * &u;
            let zv = &z * &v;
            for i in 0..n {
                r[o + i] = zu[i] - kf * sys.e_diag[i] * v[i];
                r[o + n + i] = zv[i] + kf * sys.e_diag[i] * u[i];
            }
            if k == 1 {
                for i in 0..n {
                    r[o + i] -= load * gamma_s[i] * sys.a_ex;
                }
            }
        }

        // Time samples of q and q̇/Ω.
        let mut qt = vec![DVector::<f64>::zeros(n); nt];
        let mut qd = vec![DVector::<f64>::zeros(n); nt];
        for (h, &k) in self.orders.iter().enumerate() {
            let o = self.offsets[h];
            let (c, sn) = (&self.cos[h * nt..(h + 1) * nt], &self.sin[h * nt..(h + 1) * nt]);
            let kf = k as f64;
            for j in 0..nt {
                for i in 0..n {
                    if k == 0 {
                        qt[j][i] += y[o + i] * qs;
                    } else {
                        let (u, v) = (y[o + i] * qs, y[o + n + i] * qs);
                        qt[j][i] += u * c[j] - v * sn[j];
                        qd[j][i] += -kf * (u * sn[j] + v * c[j]);
                    }
                }
            }
        }
        let cax = sys.k_ax / 2.0;
        // D₂ term 8D₂ωᵢ(w(L/2)/h)² q̇ᵢ = 4κᵢ w² (q̇ᵢ/Ω), κᵢ = 2ωᵢD₂Ω/h² (as the single-term solver).
        let d2 = sys.d2.as_ref();
        let nn = n * n;
        let mmax = 2 * self.kmax;
        // Fourier sums of the time-domain Jacobians: C_m = Σ_j J_j cos mτ_j, S_m = Σ_j J_j sin mτ_j
        // (m ≤ 2 k_max), and the same for the diagonal q̇-derivative of the D₂ term.
        let (mut cm, mut sm) = (vec![0.0; if want_j { (mmax + 1) * nn } else { 0 }], vec![0.0; if want_j { (mmax + 1) * nn } else { 0 }]);
        let (mut cdm, mut sdm) = (vec![0.0; (mmax + 1) * n], vec![0.0; (mmax + 1) * n]);
        let mut jj = vec![0.0; nn];
        let mut dd = vec![0.0; n];
        let mut kq = DVector::zeros(n);
        for j in 0..nt {
            kq.gemv(1.0, &sys.kmat, &qt[j], 0.0);
            let e = qt[j].dot(&kq);
            let mut wm = 0.0;
            if let Some((_, pm)) = d2 {
                wm = pm.iter().zip(qt[j].iter()).map(|(a, b)| a * b).sum::<f64>();
            }
            // Residual: project f(τ_j) onto every retained harmonic.
            for i in 0..n {
                let mut f = cax * e * kq[i];
                if let Some((kappa, _)) = d2 {
                    f += 4.0 * kappa[i] * wm * wm * qd[j][i];
                }
                for (h, &k) in self.orders.iter().enumerate() {
                    let o = self.offsets[h];
                    if k == 0 {
                        r[o + i] += f / nt as f64;
                    } else {
                        r[o + i] += 2.0 / nt as f64 * self.cos[h * nt + j] * f;
                        r[o + n + i] -= 2.0 / nt as f64 * self.sin[h * nt + j] * f;
                    }
                }
            }
            if !want_j {
                continue;
            }
            // J_j = (k_ax/2)[(qᵀKq)K + 2Kq(Kq)ᵀ] (+ D₂: ∂/∂q of 4κᵢw²q̇ᵢ), row-major.
            for a in 0..n {
                for b in 0..n {
                    jj[a * n + b] = cax * (e * sys.kmat[(a, b)] + 2.0 * kq[a] * kq[b]);
                }
            }
            if let Some((kappa, pm)) = d2 {
                for a in 0..n {
                    for b in 0..n {
                        jj[a * n + b] += 8.0 * kappa[a] * wm * pm[b] * qd[j][a];
                    }
                    dd[a] = 4.0 * kappa[a] * wm * wm;
                }
            }
            for m in 0..=mmax {
                let (c, s) = (self.tc[m * nt + j], self.ts[m * nt + j]);
                let (cmm, smm) = (&mut cm[m * nn..(m + 1) * nn], &mut sm[m * nn..(m + 1) * nn]);
                for e2 in 0..nn {
                    cmm[e2] += c * jj[e2];
                    smm[e2] += s * jj[e2];
                }
                if d2.is_some() {
                    for a in 0..n {
                        cdm[m * n + a] += c * dd[a];
                        sdm[m * n + a] += s * dd[a];
                    }
                }
            }
        }
        r /= sys.f_ref;
        if !want_j {
            return (r, DMatrix::zeros(0, 0));
        }

        let mut jac = DMatrix::zeros(nx, nx + 1);
        // Linear blocks.
        for (h, &k) in self.orders.iter().enumerate() {
            let o = self.offsets[h];
            if k == 0 {
                jac.view_mut((o, o), (n, n)).copy_from(&sys.lam);
                continue;
            }
            let kf = k as f64;
            let z = &sys.lam - (kf * kf * om2) * &mass;
            jac.view_mut((o, o), (n, n)).copy_from(&z);
            jac.view_mut((o + n, o + n), (n, n)).copy_from(&z);
            for i in 0..n {
                jac[(o + i, o + n + i)] -= kf * sys.e_diag[i];
                jac[(o + n + i, o + i)] += kf * sys.e_diag[i];
            }
        }
        // Nonlinear blocks: ∂F_(row)/∂x_(col) = w_row Σ_j f_row(kτ_j) [J_j g_col(lτ_j) + J^d_j h_col(lτ_j)],
        // with the products of trigonometric functions reduced to the sums C_m, S_m:
        // cos k cos l = ½(C_|k−l| + C_k+l), sin k sin l = ½(C_|k−l| − C_k+l),
        // sin k cos l = ½(S_k+l + sgn(k−l) S_|k−l|), cos k sin l = ½(S_k+l − sgn(k−l) S_|k−l|).
        let combo = |row_sin: bool, k: usize, col_sin: bool, l: usize| -> [(f64, bool, usize); 2] {
            let (dm, sp) = (k.abs_diff(l), k + l);
            let sg = match k.cmp(&l) {
                std::cmp::Ordering::Greater => 1.0,
                std::cmp::Ordering::Less => -1.0,
                std::cmp::Ordering::Equal => 0.0,
            };
            match (row_sin, col_sin) {
                (false, false) => [(0.5, false, dm), (0.5, false, sp)],
                (true, true) => [(0.5, false, dm), (-0.5, false, sp)],
                (true, false) => [(0.5 * sg, true, dm), (0.5, true, sp)],
                (false, true) => [(-0.5 * sg, true, dm), (0.5, true, sp)],
            }
        };
        let parts = |h: usize| if self.orders[h] == 0 { 1 } else { 2 };
        for h in 0..self.orders.len() {
            let k = self.orders[h];
            for part in 0..parts(h) {
                let ro = self.offsets[h] + part * n;
                let (rw, row_sin) = if k == 0 {
                    (1.0 / nt as f64, false)
                } else if part == 0 {
                    (2.0 / nt as f64, false)
                } else {
                    (-2.0 / nt as f64, true)
                };
                for (l, &kl) in self.orders.iter().enumerate() {
                    for cpart in 0..parts(l) {
                        let co = self.offsets[l] + cpart * n;
                        // q-derivative: cos lτ (Re), −sin lτ (Im); q̇/Ω-derivative: −l sin lτ, −l cos lτ.
                        let (gq, q_sin) = if cpart == 0 { (1.0, false) } else { (-1.0, true) };
                        for (cf, is_sin, m) in combo(row_sin, k, q_sin, kl) {
                            if cf == 0.0 {
                                continue;
                            }
                            let src = if is_sin { &sm[m * nn..(m + 1) * nn] } else { &cm[m * nn..(m + 1) * nn] };
                            let f = rw * gq * cf;
                            for a in 0..n {
                                for b in 0..n {
                                    jac[(ro + a, co + b)] += f * src[a * n + b];
                                }
                            }
                        }
                        if d2.is_some() && kl > 0 {
                            let (gd, d_sin) = if cpart == 0 { (-(kl as f64), true) } else { (-(kl as f64), false) };
                            for (cf, is_sin, m) in combo(row_sin, k, d_sin, kl) {
                                if cf == 0.0 {
                                    continue;
                                }
                                let src = if is_sin { &sdm[m * n..(m + 1) * n] } else { &cdm[m * n..(m + 1) * n] };
                                let f = rw * gd * cf;
                                for a in 0..n {
                                    jac[(ro + a, co + a)] += f * src[a];
                                }
                            }
                        }
                    }
                }
            }
        }
        let sx = qs / sys.f_ref;
        for col in 0..nx {
            for row in 0..nx {
                jac[(row, col)] *= sx;
            }
        }
        // Parameter column.
        match par {
            Param::S { load } => {
                let l = sys.length;
                let dm = |w: &DVector<f64>| -> DVector<f64> {
                    let (pw, dw, ddw) = (phi.dot(w), dphi.dot(w), ddphi.dot(w));
                    (sys.mass * (&dphi * pw + &phi * dw) + sys.j_g * (&ddphi * dw + &dphi * ddw)) * l
                };
                for (h, &k) in self.orders.iter().enumerate() {
                    let o = self.offsets[h];
                    if k == 0 {
                        for i in 0..n {
                            jac[(o + i, nx)] = load * self.weight * l * dphi[i] / sys.f_ref;
                        }
                        continue;
                    }
                    let k2 = (k * k) as f64 * om2;
                    let dmu = dm(&blk(o, n));
                    let dmv = dm(&blk(o + n, n));
                    for i in 0..n {
                        let force = if k == 1 { load * l * sys.mass * dphi[i] * sys.a_ex } else { 0.0 };
                        jac[(o + i, nx)] = (-k2 * dmu[i] - force) / sys.f_ref;
                        jac[(o + n + i, nx)] = -k2 * dmv[i] / sys.f_ref;
                    }
                }
            }
            Param::Load { .. } => {
                for (h, &k) in self.orders.iter().enumerate() {
                    let o = self.offsets[h];
                    for i in 0..n {
                        if k == 1 {
                            jac[(o + i, nx)] = -gamma_s[i] * sys.a_ex / sys.f_ref;
                        } else if k == 0 {
                            jac[(o + i, nx)] = self.weight * phi[i] / sys.f_ref;
                        }
                    }
                }
            }
        }
        (r, jac)
    }
}
