//! Profile helper: `--save FILE` runs the signature-move case for 60 s and writes the state;
//! `--load FILE --seconds S` continues from it (the high-vibration phase) for S seconds.
use beamslider_core::*;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let model = Model::new(Params::default()).unwrap();
    let exc = Excitation::new(124.0, 14.0);
    if let Some(i) = args.iter().position(|a| a == "--save") {
        let start = model.initial_state(0.3, &exc).unwrap();
        let s = model.run(&start, &RunOptions::free(exc, 60.0), &mut NullRecorder, &mut ()).unwrap();
        let st = &s.state;
        let mut v = vec![st.t_s];
        v.extend(&st.q);
        v.extend(&st.u);
        v.extend(st.slider_q);
        v.extend(st.slider_u);
        std::fs::write(&args[i + 1], v.iter().map(|x| format!("{x:e}")).collect::<Vec<_>>().join("\n")).unwrap();
        return;
    }
    let i = args.iter().position(|a| a == "--load").unwrap();
    let secs: f64 = args[args.iter().position(|a| a == "--seconds").unwrap() + 1].parse().unwrap();
    let v: Vec<f64> = std::fs::read_to_string(&args[i + 1]).unwrap().lines().map(|l| l.parse().unwrap()).collect();
    let n = 5;
    let st = State { t_s: v[0], q: v[1..1 + n].to_vec(), u: v[1 + n..1 + 2 * n].to_vec(), slider_q: [v[11], v[12], v[13]], slider_u: [v[14], v[15], v[16]] };
    let t = std::time::Instant::now();
    let s = model.run(&st, &RunOptions::free(exc, secs), &mut NullRecorder, &mut ()).unwrap();
    println!("{:.1} ns/step; {:?}", t.elapsed().as_secs_f64() / s.counters.steps as f64 * 1e9, s.counters);
}
