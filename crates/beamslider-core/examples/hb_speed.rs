//! Speed of the harmonic-balance manifold (docs/model.md §6.4; one core): the N = 1 closed form over 201 s
//! values (≤ 0.2 ms) and the N = 5 continuation of both branches (≤ 5 ms).
//!
//! `cargo run --release -p beamslider-core --example hb_speed` prints medians over repeated runs.

use std::time::Instant;

use beamslider_core::Params;
use beamslider_core::superslow::{HbOptions, closed_form_n1, closed_form_n1_with_beam, default_grid, hb_manifold};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    beam_cost();
    let p = Params::default();
    let grid = default_grid(&p, 201);
    for (f, a) in [(124.0, 14.0), (124.0, 8.0), (126.0, 10.0), (104.0, 14.0)] {
        // Closed form (Beam::new for one mode included).
        let mut t = Vec::new();
        for _ in 0..200 {
            let t0 = Instant::now();
            let cf = closed_form_n1(&p, f, a, &grid, None).unwrap();
            std::hint::black_box(&cf);
            t.push(t0.elapsed().as_secs_f64());
        }
        let cf_ms = median(t) * 1e3;
        // The same with the beam's modes computed once per parameter set.
        let beam1 = beamslider_core::Beam::new(&Params { n_modes: 1, ..p.clone() }).unwrap();
        let mut t = Vec::new();
        for _ in 0..200 {
            let t0 = Instant::now();
            let cf = closed_form_n1_with_beam(&beam1, &p, f, a, &grid, None, 1.0).unwrap();
            std::hint::black_box(&cf);
            t.push(t0.elapsed().as_secs_f64());
        }
        let cf_only_ms = median(t) * 1e3;
        let mut line = format!("({f:>5}, {a:>4}) closed form N=1, 201 s: median {cf_only_ms:.4} ms (incl. modes {cf_ms:.4} ms)");
        for n in [1usize, 2, 5] {
            let o = HbOptions { n_modes: n, ..HbOptions::default() };
            let mut t = Vec::new();
            let mut steps = 0;
            for _ in 0..30 {
                let t0 = Instant::now();
                let m = hb_manifold(&p, f, a, &o).unwrap();
                t.push(t0.elapsed().as_secs_f64());
                steps = m.steps;
            }
            line += &format!(" | HB N={n} (incl. modes): median {:.3} ms ({steps} steps)", median(t) * 1e3);
        }
        println!("{line}");
    }
}

#[allow(dead_code)]
fn beam_cost() {
    for n in [1usize, 2, 5] {
        let p = Params { n_modes: n, ..Params::default() };
        let mut t = Vec::new();
        for _ in 0..50 {
            let t0 = Instant::now();
            std::hint::black_box(beamslider_core::Beam::new(&p).unwrap());
            t.push(t0.elapsed().as_secs_f64());
        }
        println!("Beam::new N={n}: median {:.3} ms", median(t) * 1e3);
    }
}
