//! Virtual ENMA of the default model against the single-mode backbone (docs/model.md §9).
//! `cargo run --release -p beamslider-core --example enma_check`
use beamslider_core::enma::{EnmaOptions, backbone_rad_s, virtual_enma};
use beamslider_core::{Model, Params};

fn main() {
    let model = Model::new(Params::default()).unwrap();
    let t0 = std::time::Instant::now();
    let opts = EnmaOptions {
        levels_m_s2: vec![0.25, 0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 15.0, 20.0, 25.0, 30.0],
        up_and_down: false,
        ..Default::default()
    };
    let r = virtual_enma(&model, &opts, &mut ()).unwrap();
    println!("{} levels, {:.1} s simulated, {} steps, {:.2} s wall", r.points.len(), r.simulated_s, r.steps, t0.elapsed().as_secs_f64());
    println!("run  a_ex   ã        f [Hz]     f_bb [Hz]  dev       D~        3rd/1st  settle conv shape");
    for p in &r.points {
        let fb = backbone_rad_s(&model, p.amplitude_h) / (2.0 * std::f64::consts::PI);
        println!(
            "{:4} {:5.2} {:.5} {:10.4} {:10.4} {:+.2e} {:.3e} {:.2e} {:6.2} {} {:?}",
            p.run.to_string(),
            p.level_m_s2,
            p.amplitude_h,
            p.frequency_hz,
            fb,
            p.frequency_hz / fb - 1.0,
            p.damping_ratio,
            p.third_harmonic_ratio,
            p.settle_time_s,
            p.converged,
            p.shape.iter().map(|v| format!("{v:.4}")).collect::<Vec<_>>()
        );
    }
}
