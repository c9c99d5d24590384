//! `design_band`: wall time of a new design's two-level band on the reduced predictor
//! (docs/model.md §6.3–6.5), one thread, split into its stages: the design law's blend for the
//! design (docs/model.md §6.5), then per point layer (a) (the HB manifold), the slow model
//! (features + V from the blended law), the slow flow and the robustness check (two more slow
//! flows). The band is the design search's: a_ex 10 and 14 m/s², 100–130 Hz step 2, s0 0.3,
//! 120 s (32 points). The law is `python/beamslider/data/default_design_law.json`.
//!
//! cargo bench -p beamslider-core --bench design_band [-- --reps 5] [--params a.toml b.toml ...]
//!
//! Without `--params`, five designs inside the box (the prototype with one or two coordinates
//! changed). Prints medians over the repetitions of each design.

use std::time::Instant;

use beamslider_core::superslow::design_law::DesignLaw;
use beamslider_core::superslow::law::beam_for;
use beamslider_core::superslow::predict::{PredictOptions, predict_point_with};
use beamslider_core::superslow::predicted_map::predicted_row;
use beamslider_core::*;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn designs(base: &Params) -> Vec<(String, Params)> {
    let with = |f: &dyn Fn(&mut Params)| {
        let mut p = base.clone();
        f(&mut p);
        p
    };
    vec![
        ("gap 1.11, mu 0.27".into(), with(&|p| (p.gap_ratio, p.friction_coefficient) = (1.11, 0.27))),
        (
            "m 40 g, B 9 mm".into(),
            with(&|p| {
                p.slider_inertia_kg_m2 *= (0.040 / p.slider_mass_kg) * (9e-3 / p.contact_spacing_m).powi(2);
                (p.slider_mass_kg, p.contact_spacing_m) = (0.040, 9e-3);
            }),
        ),
        ("d 5 mm, e 0.6".into(), with(&|p| (p.com_offset_m, p.restitution) = (5e-3, 0.6))),
        ("gap 1.25, D x1.5".into(), with(&|p| (p.gap_ratio, p.damping_ratio) = (1.25, p.damping_ratio * 1.5))),
        (
            "gap 1.06, m 30 g".into(),
            with(&|p| {
                p.slider_inertia_kg_m2 *= 0.030 / p.slider_mass_kg;
                (p.gap_ratio, p.slider_mass_kg) = (1.06, 0.030);
            }),
        ),
    ]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let reps = args.iter().position(|a| a == "--reps").and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(5usize);
    let files: Vec<&String> = args.iter().skip_while(|a| *a != "--params").skip(1).take_while(|a| !a.starts_with("--")).collect();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../python/beamslider/data/default_design_law.json");
    let t0 = Instant::now();
    let dl = DesignLaw::from_file(&root).expect("python/beamslider/data/default_design_law.json");
    println!("design law read once: {:.1} ms ({} designs)", 1e3 * t0.elapsed().as_secs_f64(), dl.laws.len());
    let list: Vec<(String, Params)> = if files.is_empty() {
        designs(&dl.base)
    } else {
        files.iter().map(|f| (f.to_string(), Params::from_toml_file(f).expect("a parameter file"))).collect()
    };
    let opts = PredictOptions::default();
    let band: Vec<(f64, f64)> = [10.0, 14.0].iter().flat_map(|&a| (0..16).map(move |i| (100.0 + 2.0 * i as f64, a))).collect();
    println!("new design's 32-point band, one thread, median of {reps} repetitions [ms]");
    println!("{:>28} {:>8} {:>9} {:>11} {:>10} {:>11} {:>8} {:>8}", "design", "blend", "manifold", "slow model", "slow flow", "robustness", "rows", "total");
    let mut totals = vec![];
    for (name, p) in &list {
        let p = &params::Valid::new(p.clone()).expect("valid parameters");
        let mut cols: [Vec<f64>; 7] = Default::default();
        for _ in 0..reps {
            let t0 = Instant::now();
            let (law, _) = dl.law_for_rule(p, true).expect("blend");
            let beam = beam_for(p, opts.hb.n_modes).unwrap();
            let t1 = Instant::now();
            let mut st = [0.0; 4];
            let mut t_rows = 0.0;
            for (i, &(f, a)) in band.iter().enumerate() {
                let pr = predict_point_with(p, &beam, &law, f, a, 0.3, 120.0, &opts).unwrap();
                let r0 = Instant::now();
                let row = predicted_row(i, f, a, 0.3, 120.0, &pr, 0.0);
                std::hint::black_box(row.to_json());
                t_rows += r0.elapsed().as_secs_f64();
                for (acc, t) in st.iter_mut().zip(pr.timings_s) {
                    *acc += t;
                }
            }
            let t2 = Instant::now();
            cols[0].push((t1 - t0).as_secs_f64());
            for k in 0..4 {
                cols[1 + k].push(st[k]);
            }
            cols[5].push(t_rows);
            cols[6].push((t2 - t0).as_secs_f64());
        }
        let m: Vec<f64> = cols.into_iter().map(|c| 1e3 * median(c)).collect();
        totals.push(m[6]);
        println!("{:>28} {:8.2} {:9.2} {:11.2} {:10.2} {:11.2} {:8.2} {:8.2}", name, m[0], m[1], m[2], m[3], m[4], m[5], m[6]);
    }
    println!("median over designs: {:.1} ms per band ({:.2} ms per point)", median(totals.clone()), median(totals) / 32.0);
}
