//! The fast (exact) contact solver against the tightly converged reference solver (issue: the
//! golden trajectory is a property of the reference stop rule; an exact solver is compared with
//! Gauss–Seidel at 1e-12 / 1e-16 N s instead).

use crate::common::*;
use beamslider_core::*;

/// The reference solver converged tightly (1e-12 relative, 1e-16 N s).
fn tight_reference() -> Params {
    Params { contact_solver: ContactSolver::Reference, solver_tol_rel: 1e-12, solver_tol_abs: 1e-16, solver_max_iter: 1_000_000, ..Params::default() }
}

#[test]
fn fast_matches_tight_reference_over_golden_case() {
    let tight = tight_reference();
    let (r_ref, s_ref) = run(tight, SliderModel::Free, 124.0, 14.0, 0.3, 0.2, 10);
    let (r_fast, s_fast) = run_audit(Params::default(), SliderModel::Free, 124.0, 14.0, 0.3, 0.2, 10, true);
    // (1) every local solution satisfies Signorini–Newton and Coulomb to round-off.
    assert!(s_fast.counters.max_residual < 1e-9, "residual {}", s_fast.counters.max_residual);
    let w_ref = r_ref.column("w_4L7_m").unwrap();
    let dw = max_diff(&r_fast.column("w_4L7_m").unwrap(), &w_ref) / max_abs(&w_ref);
    let dx = max_diff(&r_fast.column("xC_m").unwrap(), &r_ref.column("xC_m").unwrap());
    eprintln!("fast vs tight reference: dw/max|w| = {dw:.3e}, dxC = {dx:.3e} m");
    eprintln!("tight reference counters: {:?}", s_ref.counters);
    eprintln!("fast counters: {:?}", s_fast.counters);
    assert_eq!(s_ref.counters.cap_hits, 0);
    assert_eq!(s_fast.counters.fallbacks, 0);
    assert!(dw <= 1e-6, "{dw:e}");
    assert!(dx <= 1e-9, "{dx:e}");
}

#[test]
fn fast_matches_tight_reference_pcs() {
    let tight = tight_reference();
    let m = SliderModel::PseudoConstrained { s: 0.25 };
    let (r_ref, _) = run(tight, m, 124.0, 14.0, 0.25, 0.2, 10);
    let (r_fast, _) = run(Params::default(), m, 124.0, 14.0, 0.25, 0.2, 10);
    let w_ref = r_ref.column("w_4L7_m").unwrap();
    let dw = max_diff(&r_fast.column("w_4L7_m").unwrap(), &w_ref) / max_abs(&w_ref);
    eprintln!("PCS fast vs tight reference: dw/max|w| = {dw:.3e}");
    assert!(dw <= 1e-6, "{dw:e}");
}

#[test]
fn simd_and_plain_builds_are_bitwise_identical() {
    let _switch = SIMD_SWITCH.lock().unwrap_or_else(|e| e.into_inner());
    for solver in [ContactSolver::Fast, ContactSolver::Reference] {
        let p = Params { contact_solver: solver, ..Params::default() };
        set_simd(false);
        let (a, _) = run(p.clone(), SliderModel::Free, 124.0, 14.0, 0.3, 0.2, 10);
        set_simd(true);
        let (b, _) = run(p, SliderModel::Free, 124.0, 14.0, 0.3, 0.2, 10);
        assert!(a.data.iter().zip(&b.data).all(|(x, y)| x.to_bits() == y.to_bits()), "{solver}");
    }
}
