//! Bounded-time random-mutation fuzzer of the core's file readers (cargo-fuzz needs a nightly
//! toolchain; this runs on stable): the TOML parameter loader (`Params::from_toml_str`, then
//! `Model::new` on what it accepts), the map configuration (`MapConfig::from_toml_str`, then its
//! grid points) and the map results reader used by `--resume` (`results::read_results`).
//!
//! Each input is a valid seed mutated a few times (byte flips, insertions of interesting tokens
//! such as `nan`, `1e400`, `-1`, quotes and brackets, deletions, duplications, truncation, splices
//! of another seed). A finding is a panic, a non-finite accepted value, an accepted input that
//! does not round-trip through TOML, or a single input that takes longer than a second; each is
//! saved under `--findings DIR`.
//!
//! ```sh
//! cargo run --release -p beamslider-core --example fuzz_readers -- --seconds 60 [--seed 1] [--findings fuzz-findings]
//! ```
//! Prints the executions per target and the findings; exits with 1 when there are findings.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use beamslider_core::map::MapConfig;
use beamslider_core::params::Valid;
use beamslider_core::results::read_results;
use beamslider_core::{Model, Params};

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        // xorshift64*
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

const TOKENS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "+inf",
    "-1",
    "0",
    "0.0",
    "-0.0",
    "1e400",
    "1e-400",
    "5e-324",
    "1e308",
    "18446744073709551616",
    "9223372036854775807",
    "-9223372036854775808",
    "\"",
    "'",
    "[",
    "]",
    "{",
    "}",
    "=",
    ",",
    "\n",
    "#",
    "\"fast\"",
    "\"reference\"",
    "true",
    "[grid]",
    "[params]",
    "[criteria]",
    "[[grid]]",
    "1979-05-27",
    "0x10",
    "1_000",
    "\u{0}",
    "\u{feff}",
    "é",
    "\\",
    "\"\"\"",
    "null",
    "NaN",
    "{\"index\":",
    "\"wall_time_s\":",
    ":",
    "\r\n",
    "  ",
    ".",
];

const KEYS: &[&str] = &[
    "length_m",
    "thickness_m",
    "density_kg_m3",
    "beam_mass_kg",
    "youngs_modulus_pa",
    "slider_mass_kg",
    "slider_inertia_kg_m2",
    "contact_spacing_m",
    "com_offset_m",
    "gap_ratio",
    "k_r_nm_per_rad",
    "k_t_n_per_m",
    "damping_ratio",
    "damping_ratio_quadratic",
    "axial_preload_n",
    "friction_coefficient",
    "restitution",
    "gravity_m_s2",
    "tilt_rad",
    "n_modes",
    "dt_s",
    "contact_solver",
    "solver_tol_rel",
    "solver_tol_abs",
    "solver_max_iter",
    "duration_s",
    "record_every",
    "f_ex_hz",
    "a_ex_m_s2",
    "s0",
    "start",
    "stop",
    "step",
];

fn mutate(rng: &mut Rng, seed: &[u8], other: &[u8]) -> Vec<u8> {
    let mut v = seed.to_vec();
    for _ in 0..1 + rng.below(6) {
        let pos = rng.below(v.len() + 1);
        match rng.below(9) {
            0 if !v.is_empty() => {
                let i = rng.below(v.len());
                v[i] ^= 1 << rng.below(8);
            }
            1 | 2 => {
                let t = TOKENS[rng.below(TOKENS.len())].as_bytes();
                v.splice(pos..pos, t.iter().copied());
            }
            3 if !v.is_empty() => {
                let end = (pos + 1 + rng.below(16)).min(v.len());
                v.drain(pos.min(end)..end);
            }
            4 if !v.is_empty() => {
                let a = rng.below(v.len());
                let b = (a + 1 + rng.below(40)).min(v.len());
                let chunk = v[a..b].to_vec();
                v.splice(pos..pos, chunk);
            }
            5 => v.truncate(pos),
            6 => {
                // replace a number-like run by a token
                let t = TOKENS[rng.below(TOKENS.len())].as_bytes();
                let end = (pos..v.len()).find(|&i| !(v[i].is_ascii_digit() || b".e-+".contains(&v[i]))).unwrap_or(v.len());
                v.splice(pos..end.max(pos), t.iter().copied());
            }
            7 => {
                let line = format!("\n{} = {}\n", KEYS[rng.below(KEYS.len())], TOKENS[rng.below(TOKENS.len())]);
                v.splice(pos..pos, line.bytes());
            }
            _ if !other.is_empty() => {
                let a = rng.below(other.len());
                let b = (a + 1 + rng.below(200)).min(other.len());
                v.splice(pos..pos, other[a..b].iter().copied());
            }
            _ => {}
        }
    }
    v
}

/// Checks one input; Err(description) is a finding.
type Target = fn(&[u8], &std::path::Path) -> Result<(), String>;

fn params_target(data: &[u8], _: &std::path::Path) -> Result<(), String> {
    let Ok(text) = std::str::from_utf8(data) else { return Ok(()) };
    let Ok(p) = Params::from_toml_str(text).and_then(Valid::new).map(Valid::into_inner) else { return Ok(()) };
    let back = Params::from_toml_str(&p.to_toml_string()).map_err(|e| format!("accepted parameters do not round-trip: {e}"))?;
    if back != p {
        return Err("accepted parameters change on a TOML round trip".into());
    }
    let finite = [p.length_m, p.thickness_m, p.dt_s, p.friction_coefficient, p.restitution, p.gap_ratio];
    if finite.iter().any(|v| !v.is_finite()) {
        return Err(format!("accepted a non-finite value: {p:?}"));
    }
    // Accepted parameters either build a model or give an error; Model::new must not panic/hang.
    let _ = Model::new(p);
    Ok(())
}

fn map_config_target(data: &[u8], _: &std::path::Path) -> Result<(), String> {
    let Ok(text) = std::str::from_utf8(data) else { return Ok(()) };
    let Ok(cfg) = MapConfig::from_toml_str(text) else { return Ok(()) };
    let pts = cfg.points().map_err(|e| format!("validated config has no points: {e}"))?;
    if pts.is_empty() || pts.iter().any(|p| !(p.f_ex_hz.is_finite() && p.a_ex_m_s2.is_finite() && p.s0.is_finite())) {
        return Err("validated config with empty or non-finite grid".into());
    }
    let back = MapConfig::from_toml_str(&cfg.to_toml_string()).map_err(|e| format!("config does not round-trip: {e}"))?;
    if back.points().map_err(|e| e.to_string())?.len() != pts.len() {
        return Err("config round trip changes the grid".into());
    }
    Ok(())
}

fn results_target(data: &[u8], tmp: &std::path::Path) -> Result<(), String> {
    std::fs::write(tmp, data).map_err(|e| format!("cannot write {}: {e}", tmp.display()))?;
    if let Ok(r) = read_results(tmp) {
        if r.good_len as usize > data.len() {
            return Err("good_len beyond the end of the file".into());
        }
        if !r.truncated && r.good_len as usize != data.len() {
            return Err("not truncated but good_len != file length".into());
        }
    }
    Ok(())
}

fn main() {
    let mut seconds = 30.0f64;
    let mut seed = 1u64;
    let mut findings_dir = PathBuf::from("fuzz-findings");
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--seconds" => seconds = args.next().and_then(|v| v.parse().ok()).expect("--seconds N"),
            "--seed" => seed = args.next().and_then(|v| v.parse().ok()).expect("--seed N"),
            "--findings" => findings_dir = PathBuf::from(args.next().expect("--findings DIR")),
            other => {
                eprintln!("unknown argument {other}; usage: fuzz_readers [--seconds N] [--seed N] [--findings DIR]");
                std::process::exit(2);
            }
        }
    }
    std::panic::set_hook(Box::new(|_| {})); // panics are findings, reported below
    let tmp = std::env::temp_dir().join(format!("beamslider-fuzz-{}.jsonl", std::process::id()));

    let params_seed = Params::default().to_toml_string();
    let partial_seed = "n_modes = 3\ncontact_solver = \"reference\"\nk_r_nm_per_rad = inf\ndt_s = 1e-5\n".to_string();
    let map_seed = MapConfig::default().to_toml_string();
    let map_seed2 = "duration_s = 3.0\nrecord_every = 10\n[grid]\nf_ex_hz = [110.0, 120.0]\na_ex_m_s2 = { start = 4.0, stop = 8.0, step = 2.0 }\ns0 = 0.3\n[params]\nn_modes = 4\n[criteria]\nhigh_h = 0.3\n".to_string();
    let mut results_seed =
        String::from("{\"beamslider_map\":1,\"settings\":{\"params_toml\":\"n_modes = 5\\n\",\"duration_s\":3.0,\"record_every\":20,\"criteria\":{}}}\n");
    results_seed.push_str("{\"index\":0,\"f_ex_hz\":110.0,\"a_ex_m_s2\":6.0,\"s0\":0.3,\"t_end_s\":3.0,\"status\":\"completed\",\"behaviour\":\"inactivity\",\"reason\":\"r\",\"s_final\":0.3,\"amplitude_final_h\":0.01,\"amplitude_initial_h\":0.01,\"amplitude_max_h\":0.02,\"s_min\":0.3,\"s_max\":0.3,\"net_travel\":0.0,\"travel_to_centre\":0.0,\"turn_s\":null,\"turn_t_s\":null,\"jump_up_t_s\":[],\"jump_down_t_s\":[],\"steady\":true,\"counters\":{\"steps\":1,\"contact_steps\":0,\"closed_histogram\":[1,0,0,0,0],\"solver_iterations\":0,\"max_iterations\":0,\"cap_hits\":0,\"first_guess_hits\":0,\"linear_solves\":0,\"enumerations\":0,\"fallbacks\":0},\"wall_time_s\":0.1}\n");
    results_seed.push_str("{\"index\":1,\"f_ex_hz\":112.0,\"a_ex_m_s2\":6.0,\"s0\":0.3,\"t_end_s\":0.0,\"status\":\"error\",\"behaviour\":\"undetermined\",\"reason\":\"x\",\"s_final\":null,\"amplitude_final_h\":null,\"amplitude_initial_h\":null,\"amplitude_max_h\":null,\"s_min\":null,\"s_max\":null,\"net_travel\":null,\"travel_to_centre\":null,\"turn_s\":null,\"turn_t_s\":null,\"jump_up_t_s\":[],\"jump_down_t_s\":[],\"steady\":false,\"counters\":{\"steps\":0,\"contact_steps\":0,\"closed_histogram\":[0,0,0,0,0],\"solver_iterations\":0,\"max_iterations\":0,\"cap_hits\":0,\"first_guess_hits\":0,\"linear_solves\":0,\"enumerations\":0,\"fallbacks\":0},\"wall_time_s\":0.0}\n");

    let targets: [(&str, Target, Vec<Vec<u8>>); 3] = [
        ("params_toml", params_target, vec![params_seed.into_bytes(), partial_seed.into_bytes()]),
        ("map_config_toml", map_config_target, vec![map_seed.into_bytes(), map_seed2.into_bytes()]),
        ("map_results_jsonl", results_target, vec![results_seed.into_bytes()]),
    ];
    // Sanity: every seed passes its target.
    for (name, f, seeds) in &targets {
        for s in seeds {
            if let Err(e) = f(s, &tmp) {
                eprintln!("seed of {name} fails: {e}");
                std::process::exit(2);
            }
        }
    }
    let mut rng = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
    let start = Instant::now();
    let budget = Duration::from_secs_f64(seconds);
    let mut execs = [0u64; 3];
    let mut accepted = [0u64; 3];
    let mut findings: Vec<(String, PathBuf, String)> = Vec::new();
    // Watchdog: an input that runs for more than 5 s is a hang; save it and stop.
    type Current = std::sync::Arc<std::sync::Mutex<Option<(Instant, &'static str, Vec<u8>)>>>;
    let current: Current = Default::default();
    {
        let current = current.clone();
        let dir = findings_dir.clone();
        std::thread::spawn(move || {
            loop {
                std::thread::sleep(Duration::from_millis(200));
                let g = current.lock().unwrap_or_else(|e| e.into_inner());
                if let Some((t0, name, input)) = g.as_ref()
                    && t0.elapsed() > Duration::from_secs(5)
                {
                    let _ = std::fs::create_dir_all(&dir);
                    let file = dir.join(format!("{name}-hang.txt"));
                    let _ = std::fs::write(&file, input);
                    println!("fuzz_readers: finding in {name}: hang (> 5 s) on the input saved to {}", file.display());
                    std::process::exit(1);
                }
            }
        });
    }
    while start.elapsed() < budget {
        let t = rng.below(3);
        let (name, f, seeds) = &targets[t];
        let s = &seeds[rng.below(seeds.len())];
        let o = &seeds[rng.below(seeds.len())];
        let input = mutate(&mut rng, s, o);
        let t0 = Instant::now();
        *current.lock().unwrap_or_else(|e| e.into_inner()) = Some((t0, *name, input.clone()));
        let r = catch_unwind(AssertUnwindSafe(|| f(&input, &tmp)));
        *current.lock().unwrap_or_else(|e| e.into_inner()) = None;
        let slow = t0.elapsed() > Duration::from_secs(1);
        execs[t] += 1;
        let problem = match r {
            Ok(Ok(())) if slow => Some(format!("took {:.1} s", t0.elapsed().as_secs_f64())),
            Ok(Ok(())) => None,
            Ok(Err(e)) => Some(e),
            Err(p) => {
                Some(format!("panic: {}", p.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| p.downcast_ref::<String>().cloned()).unwrap_or_default()))
            }
        };
        if problem.is_none() && std::str::from_utf8(&input).is_ok() {
            accepted[t] += (t == 2
                || match t {
                    0 => Params::from_toml_str(std::str::from_utf8(&input).unwrap()).and_then(Valid::new).is_ok(),
                    _ => MapConfig::from_toml_str(std::str::from_utf8(&input).unwrap()).is_ok(),
                }) as u64;
        }
        if let Some(what) = problem {
            let _ = std::fs::create_dir_all(&findings_dir);
            let file = findings_dir.join(format!("{name}-{}.txt", findings.len()));
            let _ = std::fs::write(&file, &input);
            eprintln!("finding in {name}: {what} (input saved to {})", file.display());
            findings.push((name.to_string(), file, what));
            if findings.len() >= 20 {
                break;
            }
        }
    }
    let _ = std::fs::remove_file(&tmp);
    let total: u64 = execs.iter().sum();
    println!(
        "fuzz_readers: {total} executions in {:.1} s (seed {seed}): params_toml {} ({} accepted), map_config_toml {} ({} accepted), map_results_jsonl {}; {} findings",
        start.elapsed().as_secs_f64(),
        execs[0],
        accepted[0],
        execs[1],
        accepted[1],
        execs[2],
        findings.len()
    );
    for (name, file, what) in &findings {
        println!("  {name}: {what} ({})", file.display());
    }
    if !findings.is_empty() {
        std::process::exit(1);
    }
}
