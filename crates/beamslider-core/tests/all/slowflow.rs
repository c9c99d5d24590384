//! The slow flow of docs/model.md §6.3: the slow-flow event logic on synthetic drift laws and
//! manifolds, one case per behaviour, and the degenerate inputs (folds at grid points, empty
//! coexistence, V ≡ 0).

use beamslider_core::Behaviour;
use beamslider_core::superslow::drift::BranchLabel;
use beamslider_core::superslow::slowflow::{EventKind, SlowBranch, SlowFlowOptions, SlowModel, slow_flow};

const S_MIN: f64 = 0.036;

fn grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n).map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64).collect()
}

fn branch(lo: f64, hi: f64, amp: impl Fn(f64) -> f64, v: impl Fn(f64) -> f64) -> SlowBranch {
    let s = grid(lo, hi, 41);
    SlowBranch { amplitude_h: s.iter().map(|&x| amp(x)).collect(), v_per_s: s.iter().map(|&x| v(x)).collect(), s }
}

/// L on [0.25, 0.5] (fold at 0.25, Â = 0.1), H on [s_min, s_dn or 0.5] (Â = 1.0).
fn model(v_low: impl Fn(f64) -> f64, v_high: impl Fn(f64) -> f64, s_dn: Option<f64>) -> SlowModel {
    SlowModel {
        low: branch(0.25, 0.5, |_| 0.1, v_low),
        high: branch(S_MIN, s_dn.unwrap_or(0.5), |_| 1.0, v_high),
        low_ends_in_fold: true,
        high_ends_in_fold: s_dn.is_some(),
    }
}

fn kinds(p: &beamslider_core::superslow::slowflow::Prediction) -> Vec<EventKind> {
    p.events.iter().map(|e| e.kind).collect()
}

#[test]
fn trivial_adaption_stops_at_the_zero_of_v_high() {
    let m = model(|_| -0.005, |s| 0.1 * (0.4 - s), None);
    let p = slow_flow(&m, 0.2, &SlowFlowOptions::default()).unwrap();
    assert_eq!(p.branch_initial, BranchLabel::H);
    assert_eq!(kinds(&p), vec![EventKind::Equilibrium]);
    assert!((p.events[0].s - 0.4).abs() < 1e-9);
    // Closed form: s(t) = 0.4 − 0.2 e^{−0.1 t}.
    for (t, s) in p.t_s.iter().zip(&p.s).step_by(50) {
        assert!((s - (0.4 - 0.2 * (-0.1 * t).exp())).abs() < 1e-9, "t = {t}: s = {s}");
    }
    assert!((p.s_final - 0.4).abs() < 1e-4);
    assert_eq!(p.classification.behaviour, Behaviour::TrivialAdaption, "{}", p.classification.reason);
}

#[test]
fn signature_move_jumps_up_at_s_up_and_returns() {
    let m = model(|_| -0.005, |s| 0.1 * (0.4 - s), None);
    let p = slow_flow(&m, 0.35, &SlowFlowOptions::default()).unwrap();
    assert_eq!(p.branch_initial, BranchLabel::L);
    assert_eq!(kinds(&p), vec![EventKind::JumpUp, EventKind::Equilibrium]);
    let j = p.events[0];
    assert!((j.s - 0.25).abs() < 1e-12);
    assert!((j.t_s - 20.0).abs() < 1e-9, "jump-up time {} (expected 0.1/0.005 = 20 s)", j.t_s);
    assert_eq!(p.branch_final, BranchLabel::H);
    assert!((p.s_final - 0.4).abs() < 1e-3);
    assert_eq!(p.classification.behaviour, Behaviour::SignatureMove, "{}", p.classification.reason);
    assert!((p.classification.jump_up_t_s[0] - 20.0).abs() < 1.5);
}

#[test]
fn signature_move_on_the_far_half_is_mirrored() {
    let m = model(|_| -0.005, |s| 0.1 * (0.4 - s), None);
    let p = slow_flow(&m, 0.65, &SlowFlowOptions::default()).unwrap();
    assert!((p.events[0].s - 0.75).abs() < 1e-12);
    assert!((p.s_final - 0.6).abs() < 1e-3);
    assert_eq!(p.classification.behaviour, Behaviour::SignatureMove, "{}", p.classification.reason);
}

#[test]
fn relaxation_oscillation_is_a_limit_cycle_between_the_folds() {
    let m = model(|_| -0.01, |_| 0.01, Some(0.35));
    let p = slow_flow(&m, 0.3, &SlowFlowOptions::default()).unwrap();
    let k = kinds(&p);
    assert_eq!(k[0], EventKind::JumpUp);
    assert!(k.windows(2).all(|w| w[0] != w[1]), "jumps alternate: {k:?}");
    // 5 s to the first jump up, then a period of 2 × 0.1/0.01 = 20 s.
    let ups: Vec<f64> = p.events.iter().filter(|e| e.kind == EventKind::JumpUp).map(|e| e.t_s).collect();
    assert!((ups[0] - 5.0).abs() < 1e-9);
    for w in ups.windows(2) {
        assert!((w[1] - w[0] - 20.0).abs() < 1e-9);
    }
    assert_eq!(ups.len(), 6); // 5, 25, …, 105
    let (lo, hi) = p.s.iter().fold((1.0_f64, 0.0_f64), |(a, b), &s| (a.min(s), b.max(s)));
    assert!((lo - 0.25).abs() < 1e-9 && (hi - 0.35).abs() < 1e-9);
    assert_eq!(p.classification.behaviour, Behaviour::RelaxationOscillation, "{}", p.classification.reason);
}

#[test]
fn self_damping_follows_the_high_branch_to_the_no_lift_off_region() {
    // H: low amplitude near the clamping; V_H = 0 where Λ_g < 1 (s ≤ 0.1), −0.01 beyond.
    let high_amp = |s: f64| if s <= 0.12 { 0.02 } else { (0.02 + (s - 0.12) / 0.08 * 0.98).min(1.0) };
    let v_high = |s: f64| if s <= 0.1 { 0.0 } else { -0.01 };
    let mut m = model(|_| -0.005, v_high, None);
    m.high = SlowBranch {
        s: grid(S_MIN, 0.5, 233),
        amplitude_h: grid(S_MIN, 0.5, 233).iter().map(|&s| high_amp(s)).collect(),
        v_per_s: grid(S_MIN, 0.5, 233).iter().map(|&s| v_high(s)).collect(),
    };
    let p = slow_flow(&m, 0.3, &SlowFlowOptions::default()).unwrap();
    assert_eq!(kinds(&p)[0], EventKind::JumpUp);
    assert_eq!(*kinds(&p).last().unwrap(), EventKind::Equilibrium);
    assert!(p.s_final > 0.1 - 1e-9 && p.s_final < 0.11, "{}", p.s_final);
    assert!(p.amplitude_final_h < 0.05);
    assert_eq!(p.classification.behaviour, Behaviour::SelfDamping, "{}", p.classification.reason);
}

#[test]
fn inactivity_when_v_vanishes_everywhere() {
    let m = model(|_| 0.0, |_| 0.0, None);
    let p = slow_flow(&m, 0.3, &SlowFlowOptions::default()).unwrap();
    assert!(p.events.is_empty());
    assert!(p.s.iter().all(|&s| s == 0.3));
    assert_eq!(p.classification.behaviour, Behaviour::Inactivity, "{}", p.classification.reason);
}

#[test]
fn folds_and_zeros_exactly_at_grid_points_do_not_hang() {
    // Start exactly at the fold s_up = 0.25 (a node); V_H zero exactly at a node of H.
    let z = S_MIN + 30.0 * (0.5 - S_MIN) / 40.0;
    let m = model(|_| -0.005, |s| 0.1 * (z - s), None);
    let p = slow_flow(&m, 0.25, &SlowFlowOptions::default()).unwrap();
    assert_eq!(kinds(&p)[0], EventKind::JumpUp);
    assert_eq!(p.events[0].t_s, 0.0);
    assert!((p.s_final - z).abs() < 1e-3);
    // Start exactly at s_dn (a node) on H moving up.
    let m = model(|_| -0.01, |_| 0.01, Some(0.35));
    let p = slow_flow(&m, 0.35, &SlowFlowOptions::default()).unwrap();
    assert_eq!(p.branch_initial, BranchLabel::L);
    assert_eq!(p.classification.behaviour, Behaviour::RelaxationOscillation);
}

#[test]
fn empty_coexistence_interval_stops_with_a_warning() {
    // s_dn = s_up = 0.3: both folds at the same s; V drives into the fold from both sides.
    let m =
        SlowModel { low: branch(0.3, 0.5, |_| 0.1, |_| -0.01), high: branch(S_MIN, 0.3, |_| 1.0, |_| 0.01), low_ends_in_fold: true, high_ends_in_fold: true };
    let p = slow_flow(&m, 0.4, &SlowFlowOptions::default()).unwrap();
    assert!(!p.warnings.is_empty());
    assert!(p.events.len() < 10);
    assert!((p.s_final - 0.3).abs() < 1e-12);
    // A jump onto a missing branch (no low branch at all).
    let m = SlowModel { low: SlowBranch::default(), high: branch(S_MIN, 0.3, |_| 1.0, |_| 0.01), low_ends_in_fold: false, high_ends_in_fold: true };
    let p = slow_flow(&m, 0.2, &SlowFlowOptions::default()).unwrap();
    assert_eq!(kinds(&p), vec![EventKind::JumpDown]);
    assert!(!p.warnings.is_empty());
}

#[test]
fn walls_at_the_clamping_edge_and_the_centre() {
    let m = model(|_| 0.01, |_| -0.01, None);
    let p = slow_flow(&m, 0.2, &SlowFlowOptions::default()).unwrap();
    assert_eq!(kinds(&p), vec![EventKind::Wall]);
    assert!((p.s_final - S_MIN).abs() < 1e-12);
    let p = slow_flow(&m, 0.45, &SlowFlowOptions::default()).unwrap();
    assert_eq!(kinds(&p), vec![EventKind::Wall]);
    assert!((p.s_final - 0.5).abs() < 1e-12);
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let m = model(|_| -0.005, |_| 0.0, None);
    for s0 in [f64::NAN, 0.0, 0.01, 0.999] {
        assert!(slow_flow(&m, s0, &SlowFlowOptions::default()).is_err(), "s0 = {s0}");
    }
    let o = SlowFlowOptions { t_end_s: -1.0, ..SlowFlowOptions::default() };
    assert!(slow_flow(&m, 0.3, &o).is_err());
    let mut bad = m.clone();
    bad.low.v_per_s[3] = f64::NAN;
    assert!(slow_flow(&bad, 0.3, &SlowFlowOptions::default()).is_err());
    let mut bad = m.clone();
    bad.low.s.swap(2, 3);
    assert!(slow_flow(&bad, 0.3, &SlowFlowOptions::default()).is_err());
    assert!(slow_flow(&SlowModel::default(), 0.3, &SlowFlowOptions::default()).is_err());
}

#[test]
fn build_up_delays_the_flow_and_ramps_the_amplitude() {
    let m = model(|_| -0.005, |s| 0.1 * (0.4 - s), None);
    let o = SlowFlowOptions { build_up_s: 4.0, ..SlowFlowOptions::default() };
    let p = slow_flow(&m, 0.35, &o).unwrap();
    assert!((p.events[0].t_s - 24.0).abs() < 1e-9, "jump up at 4 + 20 s, got {}", p.events[0].t_s);
    assert_eq!(p.s[10], 0.35); // t = 2 s
    // Â(2 s) = 0.1 (1 − e^{−3·2/4})
    assert!(p.amplitude_h[0] == 0.0 && (p.amplitude_h[10] - 0.1 * (1.0 - (-1.5f64).exp())).abs() < 1e-12);
    assert_eq!(p.classification.behaviour, Behaviour::SignatureMove);
    assert!(slow_flow(&m, 0.35, &SlowFlowOptions { build_up_s: f64::NAN, ..SlowFlowOptions::default() }).is_err());
}

#[test]
fn drifting_build_up_moves_at_once_and_a_jump_waits_for_its_end() {
    let m = model(|_| -0.005, |s| 0.1 * (0.4 - s), None);
    // The fold is reached after the build-up: the jump comes at 0.1/0.005 = 20 s, as without one.
    let o = SlowFlowOptions { build_up_s: 4.0, build_up_drift: true, ..SlowFlowOptions::default() };
    let p = slow_flow(&m, 0.35, &o).unwrap();
    assert!((p.events[0].t_s - 20.0).abs() < 1e-9, "jump up at 20 s, got {}", p.events[0].t_s);
    assert!((p.s[10] - (0.35 - 0.005 * 2.0)).abs() < 1e-12, "s(2 s) = {}", p.s[10]); // moving during the build-up
    assert!((p.amplitude_h[10] - 0.1 * (1.0 - (-1.5f64).exp())).abs() < 1e-12); // Â still ramps up
    // The fold is reached at 0.01/0.005 = 2 s, within the build-up of 10 s: the slider waits there.
    let o = SlowFlowOptions { build_up_s: 10.0, build_up_drift: true, ..SlowFlowOptions::default() };
    let p = slow_flow(&m, 0.26, &o).unwrap();
    assert_eq!(kinds(&p), vec![EventKind::JumpUp, EventKind::Equilibrium]);
    assert!((p.events[0].t_s - 10.0).abs() < 1e-9 && (p.events[0].s - 0.25).abs() < 1e-12, "{:?}", p.events[0]);
    assert!((p.s[25] - 0.25).abs() < 1e-12 && p.branch[25] == BranchLabel::L, "at the fold, on L, at t = 5 s");
    assert!(p.t_s.iter().zip(&p.branch).all(|(t, b)| *t < 10.0 - 1e-9 && *b == BranchLabel::L || *t > 10.0 - 1e-9));
    // Without drift the same start rests until 10 s and jumps at 12 s.
    let p = slow_flow(&m, 0.26, &SlowFlowOptions { build_up_s: 10.0, ..SlowFlowOptions::default() }).unwrap();
    assert!((p.events[0].t_s - 12.0).abs() < 1e-9, "{:?}", p.events[0]);
}
