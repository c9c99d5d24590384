//! Behaviour classification (MODEL.md §8) on synthetic super-slow signals of each type, and on the
//! four representative operating points of the paper (slow: `cargo test --release -- --ignored`).

use beamslider_core::{Behaviour, Criteria, Excitation, Model, Params, SuperSlow, classify};
use beamslider_core::map::{MapConfig, MapPoint, run_point};

const DT: f64 = 0.05;
const T_END: f64 = 120.0;

/// Sample s(t) and A(t) [h] every 0.05 s over 120 s.
fn signals(s: impl Fn(f64) -> f64, a: impl Fn(f64) -> f64) -> SuperSlow {
    let n = (T_END / DT).round() as usize + 1;
    let t = |i: usize| i as f64 * DT;
    SuperSlow { t0_s: 0.0, dt_s: DT, s: (0..n).map(|i| s(t(i))).collect(), amplitude_h: (0..n).map(|i| a(t(i))).collect() }
}

/// Linear ramp from y0 at t0 to y1 at t1, constant outside.
fn ramp(t: f64, t0: f64, t1: f64, y0: f64, y1: f64) -> f64 {
    y0 + (y1 - y0) * ((t - t0) / (t1 - t0)).clamp(0.0, 1.0)
}

/// Build-up of the beam from rest (time constant 1 s) up to the level `a`.
fn build_up(t: f64, a: f64) -> f64 {
    a * (1.0 - (-t).exp())
}

fn decide(x: &SuperSlow) -> beamslider_core::Classification {
    classify(x, &Criteria::default()).unwrap()
}

#[test]
fn inactivity_slider_does_not_move() {
    let x = signals(|t| 0.3 + 0.003 * (t / 7.0).sin(), |t| build_up(t, 0.14));
    let c = decide(&x);
    assert_eq!(c.behaviour, Behaviour::Inactivity, "{c:?}");
    assert!(c.net_travel.abs() < 0.01);
}

#[test]
fn trivial_adaption_monotonic_towards_centre_without_jump() {
    let x = signals(|t| 0.3 + 0.07 * (1.0 - (-t / 20.0).exp()), |t| build_up(t, 0.2 + 0.6 * (1.0 - (-t / 20.0).exp())));
    let c = decide(&x);
    assert_eq!(c.behaviour, Behaviour::TrivialAdaption, "{c:?}");
    assert!(c.jump_up_t_s.is_empty() && c.jump_down_t_s.is_empty());
    assert!(c.turn_s.is_nan());
    assert!(c.steady && c.amplitude_final_h > 0.75 && (c.s_final - 0.37).abs() < 0.002);
}

/// Low branch while moving towards the clamping, jump up at 8 s, back towards the centre, steady.
fn signature(t: f64) -> (f64, f64) {
    let s = if t < 8.0 { ramp(t, 0.0, 8.0, 0.3, 0.258) } else { ramp(t, 8.0, 30.0, 0.258, 0.331) };
    let a = if t < 8.0 { build_up(t, 0.08) } else { ramp(t, 8.0, 9.0, 0.08, 0.8) + ramp(t, 9.0, 30.0, 0.0, 0.39) };
    (s, a)
}

#[test]
fn signature_move_turning_point_and_jump_up() {
    let x = signals(|t| signature(t).0, |t| signature(t).1);
    let c = decide(&x);
    assert_eq!(c.behaviour, Behaviour::SignatureMove, "{c:?}");
    assert!((c.turn_s - 0.258).abs() < 1e-3 && (c.turn_t_s - 8.0).abs() < 0.1, "{c:?}");
    assert_eq!(c.jump_up_t_s.len(), 1, "{c:?}");
    assert!((c.jump_up_t_s[0] - 8.5).abs() < 2.0, "{c:?}");
    assert!(c.jump_down_t_s.is_empty());
    assert!(c.steady && (c.s_final - 0.331).abs() < 1e-3 && c.amplitude_final_h > 1.1);
}

/// Cycle of 25 s: low branch towards the clamping (s 0.33 → 0.24), jump up, high branch back to
/// 0.33, jump down.
fn relaxation(t: f64) -> (f64, f64) {
    let tc = (t + 3.7) % 25.0;
    if tc < 15.0 {
        (ramp(tc, 0.0, 15.0, 0.33, 0.24), 0.03 + 0.01 * tc / 15.0)
    } else {
        (ramp(tc, 15.0, 25.0, 0.24, 0.33), ramp(tc, 15.0, 16.0, 0.04, 1.0) + 0.1 * (tc - 15.0) / 10.0)
    }
}

#[test]
fn relaxation_oscillation_recurrent_jumps() {
    let x = signals(|t| relaxation(t).0, |t| relaxation(t).1.min(build_up(t, 2.0)));
    let c = decide(&x);
    assert_eq!(c.behaviour, Behaviour::RelaxationOscillation, "{c:?}");
    assert!(c.jump_up_t_s.len() >= 4 && c.jump_down_t_s.len() >= 4, "{c:?}");
    // jumps alternate
    for (u, d) in c.jump_up_t_s.iter().zip(&c.jump_down_t_s) {
        assert!(d > u && d - u < 25.0, "{c:?}");
    }
    assert!(!c.steady);
    assert!((c.s_min - 0.24).abs() < 1e-3 && (c.s_max - 0.33).abs() < 1e-3);
}

#[test]
fn self_damping_towards_clamping_low_level() {
    // s keeps moving towards the clamping; a small bump of the amplitude, then 0.01 h.
    let x = signals(
        |t| ramp(t, 0.0, 45.0, 0.3, 0.097),
        |t| build_up(t, 0.028) + 0.02 * (-((t - 20.0) / 4.0).powi(2)).exp() - ramp(t, 20.0, 45.0, 0.0, 0.018),
    );
    let c = decide(&x);
    assert_eq!(c.behaviour, Behaviour::SelfDamping, "{c:?}");
    assert!(c.steady && c.amplitude_final_h < 0.02 && (c.s_final - 0.097).abs() < 1e-3);
    assert!(c.travel_to_centre < -0.2);
}

#[test]
fn undetermined_with_reasons() {
    // Slow back-and-forth of s without jumps: no steady state.
    let x = signals(|t| 0.3 + 0.04 * (t / 3.0).sin(), |t| build_up(t, 0.5));
    let c = decide(&x);
    assert_eq!(c.behaviour, Behaviour::Undetermined);
    assert!(c.reason.contains("steady"), "{}", c.reason);
    // Intermediate final level.
    let x = signals(|t| ramp(t, 0.0, 40.0, 0.3, 0.36), |t| build_up(t, 0.2));
    let c = decide(&x);
    assert_eq!(c.behaviour, Behaviour::Undetermined);
    assert!(c.reason.contains("between"), "{}", c.reason);
}

#[test]
fn mirrored_start_is_classified_alike() {
    // The beam is symmetric: the signature move started at s0 = 0.7 mirrors the one at 0.3.
    let x = signals(|t| 1.0 - signature(t).0, |t| signature(t).1);
    let c = decide(&x);
    assert_eq!(c.behaviour, Behaviour::SignatureMove, "{c:?}");
    assert!((c.turn_s - 0.742).abs() < 1e-3);
}

#[test]
fn bad_input_is_an_error() {
    let mut x = signals(|_| 0.3, |_| 0.1);
    x.amplitude_h.pop();
    assert!(classify(&x, &Criteria::default()).is_err());
    let mut x = signals(|_| 0.3, |_| 0.1);
    x.s[5] = f64::NAN;
    assert!(classify(&x, &Criteria::default()).is_err());
}

/// The four representative points of MODEL.md §8 (paper, section 4): 120 s from s0 = 0.3.
/// Slow (≈ 2 s each in release): `cargo test --release -p beamslider-core --test classify -- --ignored`.
#[test]
#[ignore]
fn representative_operating_points() {
    let cfg = MapConfig::default();
    let model = Model::new(Params::default()).unwrap();
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let cases = [
        (124.0, 14.0, Behaviour::SignatureMove),
        (104.0, 14.0, Behaviour::TrivialAdaption),
        (126.0, 10.0, Behaviour::RelaxationOscillation),
        (124.0, 6.0, Behaviour::SelfDamping),
    ];
    for (i, (f, a, want)) in cases.into_iter().enumerate() {
        Excitation::new(f, a).validate().unwrap();
        let p = MapPoint { index: i, f_ex_hz: f, a_ex_m_s2: a, s0: 0.3 };
        let r = run_point(&model, &cfg, &p, &cancel).unwrap().unwrap();
        eprintln!("{f} Hz {a} m/s2: {} ({}), s_final {:.3}, A_final {:.3} h", r.behaviour, r.reason, r.s_final, r.amplitude_final_h);
        assert_eq!(r.behaviour, want, "{f} Hz, {a} m/s2: {}", r.reason);
        match want {
            // MODEL.md §8 / fast-solver results: final s 0.331, 0.369; self-damping 0.097, 0.01–0.02 h.
            Behaviour::SignatureMove => assert!((r.s_final - 0.331).abs() < 0.01),
            Behaviour::TrivialAdaption => assert!((r.s_final - 0.369).abs() < 0.01),
            Behaviour::RelaxationOscillation => assert!(r.s_min > 0.22 && r.s_max < 0.35 && r.jump_up_t_s.len() >= 3),
            Behaviour::SelfDamping => assert!((r.s_final - 0.097).abs() < 0.01 && r.amplitude_final_h < 0.03),
            _ => {}
        }
    }
}
