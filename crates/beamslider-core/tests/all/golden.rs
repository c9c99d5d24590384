//! Reproduction of the reference trajectories (docs/model.md §5–6) with the reference contact solver.

use crate::common::*;
use beamslider_core::*;

fn reference_params() -> Params {
    Params { contact_solver: ContactSolver::Reference, ..Params::default() }
}

#[test]
fn golden_free_slider_124hz_14ms2_s03() {
    let gold = read_reference("golden_fs_124Hz_14ms2_s03.csv");
    let (rec, sum) = run(reference_params(), SliderModel::Free, 124.0, 14.0, 0.3, 0.2, 10);
    assert_eq!(sum.status, Status::Completed);
    assert_eq!(rec.rows(), gold.rows.len());
    let wg = gold.col("w_4L7_m");
    let w = rec.column("w_4L7_m").unwrap();
    let dw = max_diff(&w, &wg) / max_abs(&wg);
    let dx = max_diff(&rec.column("xC_m").unwrap(), &gold.col("xC_m"));
    let dz = max_diff(&rec.column("zC_m").unwrap(), &gold.col("zC_m"));
    let db = max_diff(&rec.column("beta_rad").unwrap(), &gold.col("beta_rad"));
    let dw2 = max_diff(&rec.column("w_at_0.07m").unwrap(), &gold.col("w_L2_m")) / max_abs(&gold.col("w_L2_m"));
    eprintln!("FS golden: dw/max|w| = {dw:.3e}, dw(L/2) = {dw2:.3e}, dx = {dx:.3e} m, dz = {dz:.3e} m, dbeta = {db:.3e} rad; {:?}", sum.counters);
    assert!(dw <= 1e-6, "w(4L/7) differs by {dw:e} of max|w|");
    assert!(dx <= 1e-9 && dz <= 1e-9, "slider position differs: dx {dx:e}, dz {dz:e}");
    assert!(db <= 1e-7, "beta differs by {db:e}");
}

#[test]
fn golden_pcs_124hz_14ms2_s025() {
    let gold = read_reference("golden_pcs_124Hz_14ms2_s025.csv");
    let (rec, sum) = run(reference_params(), SliderModel::PseudoConstrained { s: 0.25 }, 124.0, 14.0, 0.25, 0.2, 10);
    assert_eq!(sum.status, Status::Completed);
    assert_eq!(rec.rows(), gold.rows.len());
    let wg = gold.col("w_4L7_m");
    let dw = max_diff(&rec.column("w_4L7_m").unwrap(), &wg) / max_abs(&wg);
    let dx = max_diff(&rec.column("xC_m").unwrap(), &gold.col("xC_m"));
    let dz = max_diff(&rec.column("zC_m").unwrap(), &gold.col("zC_m"));
    let db = max_diff(&rec.column("beta_rad").unwrap(), &gold.col("beta_rad"));
    eprintln!("PCS golden: dw/max|w| = {dw:.3e}, dx = {dx:.3e} m, dz = {dz:.3e} m, dbeta = {db:.3e} rad; {:?}", sum.counters);
    assert!(dw <= 1e-6, "w(4L/7) differs by {dw:e} of max|w|");
    assert!(dx <= 1e-9 && dz <= 1e-9, "slider position differs: dx {dx:e}, dz {dz:e}");
    assert!(db <= 1e-7, "beta differs by {db:e}");
}
