//! Property tests of the local contact solvers (docs/model.md §5), with proptest.
//!
//! For random symmetric positive-definite Delassus matrices G, free velocities c and friction
//! coefficients μ, both solvers must return finite percussions that satisfy Signorini–Newton
//! complementarity and the Coulomb law to tolerance — or report non-convergence (`capped`).
//! The contact laws are checked here independently of `LocalProblem::residual`, and on 1- and
//! 2-contact problems the exact solver is compared with an independent exact enumeration of all
//! contact modes (open / stick / slide ±), each mode a dense linear system solved by nalgebra.

use beamslider_core::dynamics::solver::{ContactMode, DIM, LocalProblem, MAX_CLOSED, exact, gauss_seidel};
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

/// A random problem: G = S (A Aᵀ + δ I) S with per-row scales S over several decades
/// (modal and slider rows differ by orders of magnitude in the real problem), c scaled by 10^e.
fn problem() -> impl Strategy<Value = LocalProblem> {
    (1usize..=MAX_CLOSED)
        .prop_flat_map(|k| {
            let m = 2 * k;
            (
                Just(k),
                prop::collection::vec(-1.0f64..1.0, m * m),
                1e-4f64..1.0,
                prop::collection::vec(-2.0f64..2.0, m),
                prop::collection::vec(-1.0f64..1.0, m),
                -6i32..6,
                prop_oneof![Just(0.0), 0.0f64..2.0],
            )
        })
        .prop_map(|(k, a, delta, log_scale, c, exp_c, mu)| build(k, &a, delta, &log_scale, &c, exp_c, mu))
}

fn build(k: usize, a: &[f64], delta: f64, log_scale: &[f64], c: &[f64], exp_c: i32, mu: f64) -> LocalProblem {
    let m = 2 * k;
    let mut prob = LocalProblem::new(k, mu);
    let s: Vec<f64> = log_scale.iter().map(|e| 10f64.powf(*e)).collect();
    for i in 0..m {
        for j in 0..m {
            let aat: f64 = (0..m).map(|l| a[i * m + l] * a[j * m + l]).sum();
            prob.g[i][j] = s[i] * s[j] * (aat + if i == j { delta } else { 0.0 });
        }
        prob.c[i] = c[i] * 10f64.powi(exp_c);
    }
    prob
}

/// Scales of velocities and percussions of a problem and a solution.
fn scales(prob: &LocalProblem, p: &[f64; DIM]) -> (f64, f64) {
    let m = 2 * prob.k;
    let sv = prob.c[..m].iter().fold(1e-300f64, |a, v| a.max(v.abs()));
    let gmin = (0..m).fold(f64::INFINITY, |a, i| a.min(prob.g[i][i]));
    let sp = p[..m].iter().fold(sv / gmin, |a, v| a.max(v.abs()));
    (sv, sp)
}

/// Independent check of the contact laws: `None` when they hold to `tol` (relative), otherwise
/// which law fails.
#[allow(clippy::needless_range_loop)] // the complementarity conditions, index by index
fn violation(prob: &LocalProblem, p: &[f64; DIM], tol: f64) -> Option<String> {
    let m = 2 * prob.k;
    let mut xi = [0.0; DIM];
    for a in 0..m {
        xi[a] = prob.c[a] + (0..m).map(|b| prob.g[a][b] * p[b]).sum::<f64>();
    }
    let (sv, sp) = scales(prob, p);
    let (tv, tp) = (tol * sv, tol * sp);
    for i in 0..prob.k {
        let (pn, pt, xn, xt) = (p[2 * i], p[2 * i + 1], xi[2 * i], xi[2 * i + 1]);
        if !(pn.is_finite() && pt.is_finite()) {
            return Some(format!("contact {i}: non-finite percussion"));
        }
        if pn < -tp {
            return Some(format!("contact {i}: P_N = {pn} < 0"));
        }
        if xn < -tv {
            return Some(format!("contact {i}: xi_N = {xn} < 0 (penetrating)"));
        }
        if pn > tp && xn > tv {
            return Some(format!("contact {i}: P_N = {pn} and xi_N = {xn} both positive"));
        }
        let lim = prob.mu * pn.max(0.0);
        if pt.abs() > lim + tp {
            return Some(format!("contact {i}: |P_T| = {} outside the cone mu P_N = {lim}", pt.abs()));
        }
        // Slipping (ξ_T ≠ 0): P_T on the cone's edge, opposite to ξ_T.
        if xt.abs() > tv && (pt + xt.signum() * lim).abs() > tp {
            return Some(format!("contact {i}: slipping with xi_T = {xt} but P_T = {pt} (mu P_N = {lim})"));
        }
    }
    None
}

/// All solutions of a 1- or 2-contact problem by enumerating the 4^k contact modes; each mode
/// gives a 2k×2k linear system (open: P = 0; stick: ξ = 0; slide ±: ξ_N = 0, P_T = ∓μ P_N).
fn enumerate_all(prob: &LocalProblem, tol: f64) -> Vec<[f64; DIM]> {
    let k = prob.k;
    let m = 2 * k;
    let mut sols = Vec::new();
    for code in 0..4usize.pow(k as u32) {
        let mut a = DMatrix::<f64>::zeros(m, m);
        let mut b = DVector::<f64>::zeros(m);
        let mut c = code;
        for i in 0..k {
            let (n, t) = (2 * i, 2 * i + 1);
            match c % 4 {
                0 => {
                    // open: P_N = 0, P_T = 0
                    a[(n, n)] = 1.0;
                    a[(t, t)] = 1.0;
                }
                1 => {
                    // stick: ξ_N = 0, ξ_T = 0
                    for j in 0..m {
                        a[(n, j)] = prob.g[n][j];
                        a[(t, j)] = prob.g[t][j];
                    }
                    b[n] = -prob.c[n];
                    b[t] = -prob.c[t];
                }
                sel => {
                    // slide: ξ_N = 0, P_T + σ μ P_N = 0 (σ = +1 for ξ_T > 0)
                    let sigma = if sel == 2 { 1.0 } else { -1.0 };
                    for j in 0..m {
                        a[(n, j)] = prob.g[n][j];
                    }
                    b[n] = -prob.c[n];
                    a[(t, t)] = 1.0;
                    a[(t, n)] = sigma * prob.mu;
                }
            }
            c /= 4;
        }
        let Some(x) = a.clone().lu().solve(&b) else { continue };
        let scale = a.abs().row_sum().max() * x.amax() + b.amax() + 1e-300;
        if !x.iter().all(|v| v.is_finite()) || (&a * &x - &b).amax() > 1e-10 * scale {
            continue; // (near-)singular pattern
        }
        let mut p = [0.0; DIM];
        p[..m].copy_from_slice(x.as_slice());
        if violation(prob, &p, tol).is_none() {
            sols.push(p);
        }
    }
    sols
}

fn distance(prob: &LocalProblem, a: &[f64; DIM], b: &[f64; DIM]) -> f64 {
    let (_, sp) = scales(prob, a);
    (0..2 * prob.k).fold(0.0f64, |d, i| d.max((a[i] - b[i]).abs())) / sp
}

proptest! {
    // 2000 cases each by default (well under a second); PROPTEST_CASES=100000 for a long search.
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(2000),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// The exact solver: finite, satisfies the contact laws, or reports non-convergence.
    #[test]
    fn exact_solver_satisfies_contact_laws_or_reports(prob in problem(), guess in 0usize..256) {
        let mut modes = [ContactMode::Stick; MAX_CLOSED];
        let all = [ContactMode::Open, ContactMode::Stick, ContactMode::SlidePos, ContactMode::SlideNeg];
        for (i, mode) in modes.iter_mut().enumerate() {
            *mode = all[(guess >> (2 * i)) % 4];
        }
        let mut p = [0.0; DIM];
        let info = exact(&prob, &mut modes, &mut p, 100_000);
        prop_assert!(p.iter().all(|v| v.is_finite()), "NaN/inf percussion: {p:?}");
        if !info.capped {
            let tol = if info.fallback { 1e-6 } else { 1e-8 };
            prop_assert!(violation(&prob, &p, tol).is_none(), "{:?}: {:?}", info, violation(&prob, &p, tol));
        }
    }

    /// The reference Gauss–Seidel: finite; converged runs satisfy the laws to its tolerance,
    /// otherwise the cap is reported.
    #[test]
    fn gauss_seidel_satisfies_contact_laws_or_reports_cap(prob in problem(), cap in prop_oneof![Just(3u32), Just(20_000u32)]) {
        let mut p = [0.0; DIM];
        let info = gauss_seidel(&prob, &mut p, 1e-12, 1e-300, cap);
        prop_assert!(p.iter().all(|v| v.is_finite()), "NaN/inf percussion: {p:?}");
        prop_assert!(info.iterations <= cap);
        if !info.capped {
            // GS stops on a small change (1e-12 relative); on badly conditioned G a small change
            // is a somewhat larger residual, hence the looser tolerance.
            prop_assert!(violation(&prob, &p, 1e-4).is_none(), "{:?}: {:?}", info, violation(&prob, &p, 1e-4));
            for i in 0..prob.k {
                prop_assert!(p[2 * i] >= 0.0 && p[2 * i + 1].abs() <= prob.mu * p[2 * i] * (1.0 + 1e-15));
            }
        } else {
            prop_assert_eq!(info.iterations, cap);
        }
    }

    /// On 1 and 2 contacts the exact solver finds one of the solutions of an independent
    /// enumeration of all contact modes (there is at least one), and the only one when unique.
    #[test]
    fn exact_solver_matches_independent_enumeration(
        k in 1usize..=2,
        a in prop::collection::vec(-1.0f64..1.0, 16),
        delta in 1e-3f64..1.0,
        log_scale in prop::collection::vec(-1.5f64..1.5, 4),
        c in prop::collection::vec(-1.0f64..1.0, 4),
        exp_c in -4i32..4,
        mu in prop_oneof![Just(0.0), 0.0f64..1.5],
    ) {
        let m = 2 * k;
        let prob = build(k, &a[..m * m], delta, &log_scale[..m], &c[..m], exp_c, mu);
        let sols = enumerate_all(&prob, 1e-8);
        prop_assert!(!sols.is_empty(), "enumeration found no solution");
        let mut modes = [ContactMode::Stick; MAX_CLOSED];
        let mut p = [0.0; DIM];
        let info = exact(&prob, &mut modes, &mut p, 100_000);
        prop_assert!(!info.fallback, "exact solver fell back to Gauss-Seidel");
        let d = sols.iter().map(|s| distance(&prob, &p, s)).fold(f64::INFINITY, f64::min);
        prop_assert!(d < 1e-7, "exact {:?} not among {:?} (distance {d})", &p[..m], sols.iter().map(|s| s[..m].to_vec()).collect::<Vec<_>>());
        // All enumerated solutions coincide when the problem has a unique solution (μ = 0: the
        // LCP of an SPD matrix).
        if mu == 0.0 {
            for s in &sols {
                prop_assert!(distance(&prob, &p, s) < 1e-7, "mu = 0 but two solutions {:?} {:?}", &p[..m], &s[..m]);
            }
        }
    }
}

/// Degenerate inputs: c = 0 gives P = 0; a zero-friction contact never carries P_T.
#[test]
fn degenerate_problems() {
    for k in 1..=MAX_CLOSED {
        let mut prob = LocalProblem::new(k, 0.3);
        for i in 0..2 * k {
            prob.g[i][i] = 1.0 + i as f64;
        }
        let mut modes = [ContactMode::Stick; MAX_CLOSED];
        let mut p = [1.0; DIM];
        exact(&prob, &mut modes, &mut p, 100);
        assert!(p[..2 * k].iter().all(|v| *v == 0.0), "{p:?}");
        let mut p = [0.0; DIM];
        let info = gauss_seidel(&prob, &mut p, 1e-5, 1e-7, 100);
        assert!(!info.capped && p.iter().all(|v| *v == 0.0));
        prob.mu = 0.0;
        prob.c[0] = -1.0;
        prob.c[1] = 5.0;
        let mut p = [0.0; DIM];
        exact(&prob, &mut modes, &mut p, 100);
        assert_eq!(p[1], 0.0);
        assert!((p[0] - 1.0).abs() < 1e-15);
    }
}
