//! ns/step of the beam alone, the PCS and the free slider (for profiling the time loop).
use beamslider_core::*;
fn main() {
    let model = Model::new(Params::default()).unwrap();
    let exc = Excitation::new(124.0, 14.0);
    for (name, kind) in [("beam only", SliderModel::BeamOnly), ("pcs s=0.3", SliderModel::PseudoConstrained { s: 0.3 }), ("free", SliderModel::Free)] {
        let start = model.initial_state(0.3, &exc).unwrap();
        let mut opts = RunOptions::free(exc, 20.0);
        opts.model = kind;
        let mut best = f64::MAX;
        for _ in 0..3 {
            let t = std::time::Instant::now();
            let s = model.run(&start, &opts, &mut NullRecorder, &mut ()).unwrap();
            best = best.min(t.elapsed().as_secs_f64() / s.counters.steps as f64 * 1e9);
        }
        println!("{name:10}: {best:.1} ns/step (best of 3)");
    }
    let start = model.initial_state(0.3, &exc).unwrap();
    let opts = RunOptions::free(exc, 120.0);
    let t = std::time::Instant::now();
    model.run(&start, &opts, &mut NullRecorder, &mut ()).unwrap();
    println!("free 120 s, no recording: {:.1} ns/step", t.elapsed().as_secs_f64() / 6e6 * 1e9);
    let t = std::time::Instant::now();
    let mut rec = MemoryRecorder::new();
    model.run(&start, &opts, &mut rec, &mut ()).unwrap();
    println!("free 120 s, recording every 10th step: {:.1} ns/step", t.elapsed().as_secs_f64() / 6e6 * 1e9);
}
