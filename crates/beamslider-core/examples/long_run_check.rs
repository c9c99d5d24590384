//! Long-run behaviour of the fast solver against the reference solver (issue: 120 s runs at
//! (124, 14), (104, 14), (124, 6): final s within 0.01 and final 1-s envelope amplitude within
//! 3 %; at (126, 10) the same relaxation-oscillation cycle: range of s within 0.01, period
//! within 10 %).
//!
//! cargo run --release -p beamslider-core --example long_run_check [-- --seconds 120 --threads 2]
//!
//! Prints one line per operating point and solver, then the comparison; exits non-zero when a
//! criterion fails.

use beamslider_core::signal::hilbert_envelope;
use beamslider_core::*;

struct Outcome {
    final_s: f64,
    final_amp: f64,
    s_range: f64,
    period: f64,
    wall: f64,
    status: Status,
}

fn run(f: f64, a: f64, solver: ContactSolver, seconds: f64) -> Outcome {
    let model = Model::new(Params { contact_solver: solver, ..Params::default() }).unwrap();
    let exc = Excitation::new(f, a);
    let start = model.initial_state(0.3, &exc).unwrap();
    let mut opts = RunOptions::free(exc, seconds);
    opts.channels = vec![Channel::Time, Channel::W4L7, Channel::S];
    let mut rec = MemoryRecorder::new();
    let t0 = std::time::Instant::now();
    let sum = model.run(&start, &opts, &mut rec, &mut ()).unwrap();
    let wall = t0.elapsed().as_secs_f64();
    let t = rec.column("t_s").unwrap();
    let w = rec.column("w_4L7_m").unwrap();
    let s = rec.column("s").unwrap();
    let dt = t[1] - t[0];
    let n1 = (1.0 / dt).round() as usize;
    // Final 1-s envelope amplitude: mean |Hilbert(w)| over the last second (2 s window, last 1 s kept).
    let tail = &w[w.len().saturating_sub(2 * n1)..];
    let env = hilbert_envelope(tail);
    let final_amp = env[env.len() - n1..].iter().sum::<f64>() / n1 as f64;
    // Relaxation cycle: s range and period from upward crossings of the mean after 30 s.
    let i30 = t.iter().position(|&x| x >= 30.0_f64.min(seconds / 4.0)).unwrap_or(0);
    let ss = &s[i30..];
    let (lo, hi) = ss.iter().fold((f64::MAX, f64::MIN), |(l, h), &v| (l.min(v), h.max(v)));
    let mid = 0.5 * (lo + hi);
    let hyst = 0.2 * (hi - lo);
    let mut ups = Vec::new();
    let mut armed = false;
    for (k, &v) in ss.iter().enumerate() {
        if v < mid - hyst {
            armed = true;
        } else if armed && v > mid {
            ups.push(t[i30 + k]);
            armed = false;
        }
    }
    let period = if ups.len() >= 2 { (ups[ups.len() - 1] - ups[0]) / (ups.len() - 1) as f64 } else { f64::NAN };
    Outcome { final_s: s[s.len() - 1], final_amp, s_range: hi - lo, period, wall, status: sum.status }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let get = |flag: &str, d: f64| args.iter().position(|a| a == flag).and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok()).unwrap_or(d);
    let seconds = get("--seconds", 120.0);
    let threads = get("--threads", 2.0) as usize;
    let points = [(124.0, 14.0), (104.0, 14.0), (124.0, 6.0), (126.0, 10.0)];
    let jobs: Vec<(f64, f64, ContactSolver)> = points.iter().flat_map(|&(f, a)| [(f, a, ContactSolver::Fast), (f, a, ContactSolver::Reference)]).collect();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results = std::sync::Mutex::new(vec![None; jobs.len()].into_iter().map(|_: Option<()>| None).collect::<Vec<Option<Outcome>>>());
    std::thread::scope(|sc| {
        for _ in 0..threads.max(1) {
            sc.spawn(|| {
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                    if i >= jobs.len() {
                        break;
                    }
                    let (f, a, solver) = jobs[i];
                    let o = run(f, a, solver, seconds);
                    results.lock().unwrap()[i] = Some(o);
                }
            });
        }
    });
    let results = results.into_inner().unwrap();
    let mut ok = true;
    println!("{seconds} s runs from s0 = 0.3 (defaults of docs/model.md §1)");
    println!("point          solver     status     final s   final amp/h  s range   period [s]  wall [s]");
    for (k, &(f, a)) in points.iter().enumerate() {
        let fast = results[2 * k].as_ref().unwrap();
        let refr = results[2 * k + 1].as_ref().unwrap();
        for (name, o) in [("fast", fast), ("reference", refr)] {
            println!(
                "({f:5.1}, {a:4.1})  {name:9}  {:9}  {:.4}    {:8.3}     {:.4}    {:8.2}    {:.2}",
                o.status.name(),
                o.final_s,
                o.final_amp / 1e-3,
                o.s_range,
                o.period,
                o.wall
            );
        }
        let verdict = if (f, a) == (126.0, 10.0) {
            let dr = (fast.s_range - refr.s_range).abs();
            let dp = (fast.period - refr.period).abs() / refr.period;
            let pass = dr <= 0.01 && dp <= 0.10;
            format!("|d range s| = {dr:.4} (<= 0.01), |d period|/period = {:.1} % (<= 10 %): {}", 100.0 * dp, if pass { "PASS" } else { "FAIL" })
        } else {
            let ds = (fast.final_s - refr.final_s).abs();
            let da = (fast.final_amp - refr.final_amp).abs() / refr.final_amp;
            let pass = ds <= 0.01 && da <= 0.03;
            format!("|d final s| = {ds:.4} (<= 0.01), |d amp|/amp = {:.2} % (<= 3 %): {}", 100.0 * da, if pass { "PASS" } else { "FAIL" })
        };
        ok &= verdict.ends_with("PASS");
        println!("    -> {verdict}");
    }
    if !ok {
        std::process::exit(1);
    }
}
