//! Determinism: identical inputs give bitwise identical outputs — across repeated runs, across
//! threads running at the same time, with the AVX2 build of the time loop on or off, and for
//! both contact solvers. (Maps across thread counts: `map.rs`,
//! `rows_do_not_depend_on_the_number_of_threads`.) One test function, because `set_simd` is global
//! (it holds `common::SIMD_SWITCH`).

use crate::common::SIMD_SWITCH;
use beamslider_core::*;

fn run(params: &Params, exc: Excitation, model: SliderModel, duration: f64) -> (Vec<u64>, RunSummary) {
    let m = Model::new(params.clone()).unwrap();
    let start = match model {
        SliderModel::Free => m.initial_state(0.3, &exc).unwrap(),
        _ => m.initial_state_pcs(&exc).unwrap(),
    };
    let mut channels = Channel::defaults();
    channels.extend([Channel::ModalQ, Channel::ModalU, Channel::SliderU, Channel::Percussions]);
    let opts = RunOptions { excitation: exc, model, duration_s: duration, record_every: 7, channels, audit_contacts: false };
    let mut rec = MemoryRecorder::new();
    let sum = m.run(&start, &opts, &mut rec, &mut ()).unwrap();
    (rec.data.iter().map(|v| v.to_bits()).collect(), sum)
}

fn state_bits(s: &State) -> Vec<u64> {
    std::iter::once(s.t_s).chain(s.q.iter().copied()).chain(s.u.iter().copied()).chain(s.slider_q).chain(s.slider_u).map(f64::to_bits).collect()
}

#[test]
fn identical_inputs_give_bitwise_identical_outputs() {
    let _switch = SIMD_SWITCH.lock().unwrap_or_else(|e| e.into_inner());
    let exc = Excitation::new(124.0, 14.0);
    let fast = Params::default();
    let reference = Params { contact_solver: ContactSolver::Reference, ..Params::default() };
    for (name, p, model) in [
        ("fs fast", &fast, SliderModel::Free),
        ("fs reference", &reference, SliderModel::Free),
        ("pcs fast", &fast, SliderModel::PseudoConstrained { s: 0.25 }),
    ] {
        let (a, sa) = run(p, exc, model, 0.3);
        assert!(sa.counters.contact_steps > 0, "{name}: no contact, a weak test");
        // Repeated run.
        let (b, sb) = run(p, exc, model, 0.3);
        assert!(a == b, "{name}: two runs differ");
        assert_eq!(state_bits(&sa.state), state_bits(&sb.state), "{name}");
        assert_eq!(sa.counters, sb.counters, "{name}");
        // Two runs at the same time on two threads.
        let (c, d) = std::thread::scope(|sc| {
            let h1 = sc.spawn(|| run(p, exc, model, 0.3).0);
            let h2 = sc.spawn(|| run(p, exc, model, 0.3).0);
            (h1.join().unwrap(), h2.join().unwrap())
        });
        assert!(a == c && a == d, "{name}: concurrent runs differ");
        // Generic build of the time loop instead of the AVX2 one.
        set_simd(false);
        let (e, _) = run(p, exc, model, 0.3);
        set_simd(true);
        assert!(a == e, "{name}: AVX2 and generic builds differ");
    }
}
