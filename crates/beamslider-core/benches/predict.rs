//! `predict`: wall time of the reduced super-slow predictor (docs/model.md §6.3) per operating point,
//! one thread, split into layer (a) (the HB manifold), the slow model (features + V from the drift
//! law on the nodes) and the slow flow with the classifier; plus the whole 7 × 16 map point by
//! point. The law is `python/beamslider/data/default_law.json` (the default law).
//!
//! cargo bench -p beamslider-core --bench predict [-- --reps 50]
//!
//! Prints medians over the repetitions (one thread, so the figures compare with one FS run).

use std::time::Instant;

use beamslider_core::superslow::law::{DriftLaw, beam_for};
use beamslider_core::superslow::predict::{PredictOptions, predict_point_with, slow_model_with};
use beamslider_core::superslow::slowflow::{SlowFlowOptions, slow_flow};
use beamslider_core::*;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let reps = args.iter().position(|a| a == "--reps").and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(30usize);
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../python/beamslider/data/default_law.json");
    let law = DriftLaw::from_file(&root).expect("python/beamslider/data/default_law.json");
    let params = params::Valid::new(Params::default()).unwrap();
    let opts = PredictOptions::default();
    let beam = beam_for(&params, opts.hb.n_modes).unwrap();
    println!("predictor, one thread, median of {reps} repetitions [ms]");
    println!("{:>12} {:>10} {:>12} {:>10} {:>10}", "point", "manifold", "slow model", "slow flow", "total");
    for (f, a) in [(124.0, 14.0), (126.0, 10.0), (104.0, 14.0), (124.0, 6.0), (106.0, 10.0)] {
        let (mut ta, mut tb, mut tc, mut tt) = (vec![], vec![], vec![], vec![]);
        for _ in 0..reps {
            let t0 = Instant::now();
            let m = hb_manifold(&params, f, a, &opts.hb).unwrap();
            let t1 = Instant::now();
            let (model, _) = slow_model_with(&params, &beam, &m, &law, f, a, opts.nodes).unwrap();
            let t2 = Instant::now();
            let fo =
                SlowFlowOptions { t_end_s: 120.0, build_up_s: 3.0 / (params.damping_ratio * 2.0 * std::f64::consts::PI * f), ..SlowFlowOptions::default() };
            let _ = slow_flow(&model, 0.3, &fo).unwrap();
            let t3 = Instant::now();
            let _ = predict_point_with(&params, &beam, &law, f, a, 0.3, 120.0, &opts).unwrap();
            let t4 = Instant::now();
            ta.push((t1 - t0).as_secs_f64());
            tb.push((t2 - t1).as_secs_f64());
            tc.push((t3 - t2).as_secs_f64());
            tt.push((t4 - t3).as_secs_f64());
        }
        println!("{:>12} {:10.3} {:12.3} {:10.3} {:10.3}", format!("({f}, {a})"), 1e3 * median(ta), 1e3 * median(tb), 1e3 * median(tc), 1e3 * median(tt));
    }
    let mut per_map = vec![];
    for _ in 0..reps.div_ceil(10).max(3) {
        let t0 = Instant::now();
        for fi in 0..16 {
            for ai in 0..7 {
                let (f, a) = (100.0 + 2.0 * fi as f64, 4.0 + 2.0 * ai as f64);
                let _ = predict_point_with(&params, &beam, &law, f, a, 0.3, 120.0, &opts).unwrap();
            }
        }
        per_map.push(t0.elapsed().as_secs_f64());
    }
    let m = median(per_map);
    println!("7 x 16 map, point by point on one thread: {:.1} ms ({:.3} ms per point)", 1e3 * m, 1e3 * m / 112.0);
}
