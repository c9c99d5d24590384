//! Physical checks of the model and the integrator (docs/model.md §2–§6).

use crate::common;
use beamslider_core::*;

fn energy(model: &Model, q: &[f64], u: &[f64]) -> f64 {
    let b = &model.beam;
    let mut e = b.string_potential(q);
    for i in 0..b.n {
        e += 0.5 * u[i] * u[i] + 0.5 * b.omega[i].powi(2) * q[i] * q[i];
    }
    e
}

/// Max relative energy error of the undamped, unforced, contact-free beam over 20 ms.
fn beam_energy_error(dt: f64) -> f64 {
    let p = Params { damping_ratio: 0.0, dt_s: dt, ..Params::default() };
    let model = Model::new(p).unwrap();
    let exc = Excitation::new(100.0, 0.0);
    let mut start = model.initial_state_pcs(&exc).unwrap();
    // Large amplitude (w(L/2) ≈ 2h): the string force matters.
    start.q = vec![1.6e-4, 2e-5, -1e-5, 4e-6, 2e-6];
    start.u = vec![0.0, 0.06, 0.0, -0.04, 0.02];
    let opts = RunOptions {
        excitation: exc,
        model: SliderModel::BeamOnly,
        duration_s: 0.02,
        record_every: 1,
        channels: vec![Channel::ModalQ, Channel::ModalU],
        audit_contacts: false,
    };
    let mut rec = MemoryRecorder::new();
    model.run(&start, &opts, &mut rec, &mut ()).unwrap();
    let e0 = energy(&model, &start.q, &start.u);
    let n = model.beam.n;
    rec.data.chunks(2 * n).map(|r| ((energy(&model, &r[..n], &r[n..]) - e0) / e0).abs()).fold(0.0, f64::max)
}

#[test]
fn energy_of_free_beam_conserved_to_second_order() {
    let e1 = beam_energy_error(2e-5);
    let e2 = beam_energy_error(1e-5);
    let e3 = beam_energy_error(5e-6);
    eprintln!("energy errors: {e1:.3e} {e2:.3e} {e3:.3e}; ratios {:.2} {:.2}", e1 / e2, e2 / e3);
    assert!(e1 < 1e-2, "{e1}");
    for r in [e1 / e2, e2 / e3] {
        assert!((3.5..4.5).contains(&r), "error must shrink like dt^2, ratio {r}");
    }
}

#[test]
fn slider_resting_on_motionless_beam_sticks() {
    // No excitation: the slider drops onto the beam, settles, and must then stay put.
    // Strong damping so that the beam is motionless after the drop.
    let model = Model::new(Params { damping_ratio: 0.02, ..Params::default() }).unwrap();
    let exc = Excitation::new(124.0, 0.0);
    let start = model.initial_state(0.3, &exc).unwrap();
    let mut rec = MemoryRecorder::new();
    let mut opts = RunOptions::free(exc, 1.5);
    opts.channels = vec![Channel::Time, Channel::XC, Channel::ZC, Channel::Percussions];
    let sum = model.run(&start, &opts, &mut rec, &mut ()).unwrap();
    assert_eq!(sum.status, Status::Completed);
    let t = rec.column("t_s").unwrap();
    let x = rec.column("xC_m").unwrap();
    // The coupled system has settled after 1 s (2 % damping); from then on x_C must not move.
    let i0 = t.iter().position(|&t| t >= 1.0).unwrap();
    let drift = x[i0..].iter().fold(0.0f64, |m, v| m.max((v - x[i0]).abs()));
    // Top contacts carry the weight.
    let pn1 = rec.column("PN1").unwrap();
    let pn4 = rec.column("PN4").unwrap();
    let last = pn1.len() - 1;
    let weight = model.params.slider_mass_kg * model.params.gravity_m_s2 * model.params.dt_s;
    eprintln!("drift {drift:e} m, PN1+PN4 = {:e} N s vs m g dt = {weight:e}", pn1[last] + pn4[last]);
    assert!(drift < 1e-9, "slider drifted by {drift} m");
    assert!(((pn1[last] + pn4[last]) / weight - 1.0).abs() < 0.05);
    assert!(sum.state.slider_u.iter().all(|v| v.abs() < 1e-6), "{:?}", sum.state.slider_u);
    assert!((x[0] - 0.3 * 0.14).abs() < 1e-6, "moved during the drop: {}", x[0]);

    // Without friction the same slider slides down the deflected beam towards the centre.
    let slippery = Model::new(Params { damping_ratio: 0.02, friction_coefficient: 0.0, ..Params::default() }).unwrap();
    let mut rec = MemoryRecorder::new();
    slippery.run(&start, &opts, &mut rec, &mut ()).unwrap();
    let x = rec.column("xC_m").unwrap();
    assert!(x[x.len() - 1] - x[0] > 1e-4, "frictionless slider should slide: {}", x[x.len() - 1] - x[0]);
}

#[test]
fn pcs_geometry_ignores_x_c() {
    let model = Model::new(Params::default()).unwrap();
    let exc = Excitation::new(124.0, 14.0);
    let a = model.initial_state_pcs(&exc).unwrap();
    let mut b = a.clone();
    b.slider_q[0] = 0.11;
    let opts = RunOptions {
        excitation: exc,
        model: SliderModel::PseudoConstrained { s: 0.3 },
        duration_s: 0.1,
        record_every: 5,
        channels: vec![Channel::W4L7, Channel::ZC, Channel::Beta, Channel::ModalQ],
        audit_contacts: false,
    };
    let mut ra = MemoryRecorder::new();
    let mut rb = MemoryRecorder::new();
    model.run(&a, &opts, &mut ra, &mut ()).unwrap();
    model.run(&b, &opts, &mut rb, &mut ()).unwrap();
    let first = ra.data.iter().zip(&rb.data).position(|(a, b)| a != b);
    assert!(
        first.is_none(),
        "PCS contact geometry must not depend on x_C: first difference at {first:?} ({:?})",
        first.map(|i| (i / ra.names.len(), &ra.names[i % ra.names.len()]))
    );
    assert!(common::max_abs(&ra.column("w_4L7_m").unwrap()) > 1e-6, "the beam moved");
}

#[test]
fn leaving_the_beam_stops_with_status() {
    let model = Model::new(Params::default()).unwrap();
    let exc = Excitation::new(124.0, 14.0);
    let mut start = model.initial_state(0.95, &exc).unwrap();
    start.slider_u[0] = 1.0; // towards the clamping at x = L
    let mut rec = MemoryRecorder::new();
    let sum = model.run(&start, &RunOptions::free(exc, 0.1), &mut rec, &mut ()).unwrap();
    match sum.status {
        Status::LeftBeam { t_s, x_m } => {
            assert!(t_s > 0.0 && t_s < 0.1 && x_m > 0.14);
        }
        s => panic!("expected LeftBeam, got {s:?}"),
    }
    assert!(rec.data.iter().all(|v| v.is_finite()));
    assert!(sum.state.slider_q.iter().all(|v| v.is_finite()));
}

#[test]
fn blow_up_stops_with_status_and_no_nan() {
    let model = Model::new(Params::default()).unwrap();
    let exc = Excitation::new(124.0, 14.0);
    let mut start = model.initial_state(0.3, &exc).unwrap();
    start.u = vec![1e4, 0.0, 0.0, 0.0, 1e4];
    let mut rec = MemoryRecorder::new();
    let sum = model.run(&start, &RunOptions::free(exc, 0.1), &mut rec, &mut ()).unwrap();
    assert!(matches!(sum.status, Status::Diverged { .. }), "{:?}", sum.status);
    assert!(rec.data.iter().all(|v| v.is_finite()));
    assert!(sum.state.q.iter().all(|v| v.is_finite()));
}

#[test]
fn time_step_too_large_for_highest_mode_is_rejected() {
    let e = Model::new(Params { dt_s: 2e-4, ..Params::default() }).unwrap_err();
    assert!(e.to_string().contains("dt_s"), "{e}");
    let e = Model::new(Params { n_modes: 20, ..Params::default() }).unwrap_err();
    assert!(e.to_string().contains("dt_s"), "{e}");
}

#[test]
fn start_outside_beam_is_rejected() {
    let model = Model::new(Params::default()).unwrap();
    let exc = Excitation::new(124.0, 14.0);
    for s0 in [0.0, 0.02, 0.99, f64::NAN] {
        let e = model.initial_state(s0, &exc).unwrap_err();
        assert!(e.to_string().contains("s0"), "{e}");
    }
    assert!(model.initial_state(0.3, &Excitation::new(0.0, 14.0)).is_err());
    assert!(model.initial_state(0.3, &Excitation::new(124.0, f64::INFINITY)).is_err());
}

#[test]
fn interruption_by_flag() {
    use std::sync::atomic::AtomicBool;
    let model = Model::new(Params::default()).unwrap();
    let exc = Excitation::new(124.0, 14.0);
    let start = model.initial_state(0.3, &exc).unwrap();
    let flag = AtomicBool::new(true);
    let mut rec = MemoryRecorder::new();
    let sum = model.run(&start, &RunOptions::free(exc, 10.0), &mut rec, &mut CancelFlag(&flag)).unwrap();
    assert!(matches!(sum.status, Status::Interrupted { t_s } if t_s < 0.1), "{:?}", sum.status);
}

#[test]
fn chained_runs_equal_one_run() {
    let model = Model::new(Params::default()).unwrap();
    let exc = Excitation::new(124.0, 14.0);
    let start = model.initial_state(0.3, &exc).unwrap();
    let mut opts = RunOptions::free(exc, 0.1);
    opts.channels = vec![Channel::Time, Channel::W4L7, Channel::XC];
    let mut r1 = MemoryRecorder::new();
    let one = model.run(&start, &opts, &mut r1, &mut ()).unwrap();
    opts.duration_s = 0.05;
    let mut r2 = MemoryRecorder::new();
    let half = model.run(&start, &opts, &mut r2, &mut ()).unwrap();
    let two = model.run(&half.state, &opts, &mut r2, &mut ()).unwrap();
    assert!((two.state.t_s - 0.1).abs() < 1e-12);
    for (a, b) in one.state.q.iter().zip(&two.state.q) {
        assert!((a - b).abs() <= 1e-12 * a.abs().max(1e-9), "{a} vs {b}");
    }
}

#[test]
fn manifold_is_interruptible_within_a_position_and_sweeps_both_ways() {
    struct StopAfter(usize);
    impl Monitor for StopAfter {
        fn poll(&mut self, _: f64, _: f64) -> bool {
            self.0 = self.0.saturating_sub(1);
            self.0 > 0
        }
    }
    let model = Model::new(Params::default()).unwrap();
    let exc = Excitation::new(124.0, 14.0);
    let opts = ManifoldOptions { s_values: vec![0.2, 0.25, 0.3], periods: 2000, record_periods: 25 };
    // 2000 periods ≈ 800k steps per position: the monitor is polled within the first position.
    let e = super_slow_manifold(&model, &exc, &opts, &mut StopAfter(3)).unwrap_err();
    assert!(matches!(e, Error::Interrupted { .. }), "{e}");
    let opts = ManifoldOptions { s_values: vec![0.2, 0.25, 0.3], periods: 40, record_periods: 10 };
    let m = super_slow_manifold(&model, &exc, &opts, &mut ()).unwrap();
    assert_eq!(m.up.s, vec![0.2, 0.25, 0.3]);
    assert_eq!(m.down.s, vec![0.3, 0.25, 0.2]);
    assert!(m.up.amplitude_m.iter().chain(&m.down.amplitude_m).all(|a| a.is_finite() && *a > 0.0));
}
