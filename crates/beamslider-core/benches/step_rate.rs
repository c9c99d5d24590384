//! `step_rate`: ns per time step averaged over the full 120 s free-slider run at the
//! signature-move point (124 Hz, 14 m/s², s₀ = 0.3), one thread, recording every 10th step.
//!
//! cargo bench -p beamslider-core --bench step_rate [-- --reps 5 --seconds 120 --reference]
//!
//! Prints the median over the repetitions (and min/max) for the fast solver and, unless
//! `--fast-only`, the reference solver.

use std::time::Instant;

use beamslider_core::*;

fn one_run(solver: ContactSolver, seconds: f64) -> (f64, RunSummary, usize) {
    let model = Model::new(Params { contact_solver: solver, ..Params::default() }).unwrap();
    let exc = Excitation::new(124.0, 14.0);
    let start = model.initial_state(0.3, &exc).unwrap();
    let opts = RunOptions::free(exc, seconds);
    let mut rec = MemoryRecorder::new();
    let t = Instant::now();
    let sum = model.run(&start, &opts, &mut rec, &mut ()).unwrap();
    let el = t.elapsed().as_secs_f64();
    (el, sum, rec.rows())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let get = |flag: &str, default: f64| args.iter().position(|a| a == flag).and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(default);
    let reps = get("--reps", 3.0) as usize;
    let seconds = get("--seconds", 120.0);
    let fast_only = args.iter().any(|a| a == "--fast-only");
    let mut solvers = vec![ContactSolver::Fast];
    if !fast_only {
        solvers.push(ContactSolver::Reference);
    }
    println!(
        "step_rate: FS (124 Hz, 14 m/s^2, s0 = 0.3), {seconds} s physical time, record every 10th step, 1 thread, {} cores on this machine",
        std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
    );
    for solver in solvers {
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..reps.max(1) {
            let (el, sum, rows) = one_run(solver, seconds);
            times.push(el / sum.counters.steps as f64 * 1e9);
            last = Some((sum, rows, el));
        }
        times.sort_by(|a, b| a.partial_cmp(b).unwrap());
        let (sum, rows, el) = last.unwrap();
        let c = sum.counters;
        println!(
            "{solver:>9}: median {:.1} ns/step (min {:.1}, max {:.1}; {} reps), {:.2} s wall per run, {} steps, {} rows, status {}",
            times[times.len() / 2],
            times[0],
            times[times.len() - 1],
            times.len(),
            el,
            c.steps,
            rows,
            sum.status.name()
        );
        println!(
            "           contact steps {:.1} %, closed histogram {:?}, GS sweeps {}, cap hits {}, first-guess hits {:.1} % of contact steps, enumerations {}, fallbacks {}",
            100.0 * c.contact_steps as f64 / c.steps as f64,
            c.closed_histogram,
            c.solver_iterations,
            c.cap_hits,
            100.0 * c.first_guess_hits as f64 / c.contact_steps.max(1) as f64,
            c.enumerations,
            c.fallbacks
        );
        println!("           final s = {:.4}", sum.state.slider_q[0] / 0.14);
    }
}
