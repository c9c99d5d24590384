use beamslider_core::Params;
use beamslider_core::superslow::{HbOptions, hb_manifold, closed_form_n1, default_grid};
fn main() {
    let args: Vec<f64> = std::env::args().skip(1).map(|a| a.parse().unwrap()).collect();
    let (f, a, n) = (args[0], args[1], args[2] as usize);
    let p = Params::default();
    let m = hb_manifold(&p, f, a, &HbOptions { n_modes: n, ..HbOptions::default() }).unwrap();
    println!("folds {:?} s_up {:?} s_dn {:?} s_res {:?} steps {} warn {:?}", m.folds, m.s_up, m.s_dn, m.s_res, m.steps, m.warnings);
    for (name, b) in [("up", &m.up_run), ("down", &m.down_run)] {
        for i in (0..b.len()).step_by((b.len() / 25).max(1)) {
            println!("{name} {:.5} {:.5} {:.3} {}", b.s[i], b.amplitude_h[i], b.phase_rad[i], b.stable[i]);
        }
        println!("{name} n={}", b.len());
    }
    let cf = closed_form_n1(&p, f, a, &default_grid(&p, 201), None).unwrap();
    println!("cf folds {:?} s_res {:?}", cf.folds, cf.s_res);
}
