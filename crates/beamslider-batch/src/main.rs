//! `beamslider-batch`: batch runs of the beam–slider model (docs/model.md) from the command line.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use beamslider_core::signal::run::{Output, RunSpec};
use beamslider_core::*;
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};

#[derive(Parser)]
#[command(name = "beamslider-batch", version, about = "Batch runs of the self-adaptive beam-slider model (Rust core of beamslider)")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, ValueEnum)]
enum ModelKind {
    /// Free slider.
    Fs,
    /// Pseudo-constrained slider at --s-pcs.
    Pcs,
}

#[derive(Clone, Copy, ValueEnum)]
enum SolverKind {
    Fast,
    Reference,
}

#[derive(clap::Args)]
struct Common {
    /// Parameter file (TOML, keys as printed by `beamslider-batch params`); defaults = the paper's prototype.
    #[arg(long, short = 'p', value_name = "FILE")]
    params: Option<PathBuf>,
    /// Excitation frequency f_ex [Hz].
    #[arg(long, default_value_t = 124.0)]
    f_ex: f64,
    /// Base-acceleration amplitude a_ex [m/s^2].
    #[arg(long, default_value_t = 14.0)]
    a_ex: f64,
    /// Override the contact solver of the parameter file.
    #[arg(long, value_enum)]
    solver: Option<SolverKind>,
    /// Hide the progress bar.
    #[arg(long, short = 'q')]
    quiet: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate one run and write the recorded channels as CSV (header row, then one row per record).
    #[command(allow_negative_numbers = true)] // `--a-ex -1` is a bad value, not an unknown flag
    Simulate {
        #[command(flatten)]
        common: Common,
        /// Initial relative slider position s0 = x_C/L (free slider).
        #[arg(long, default_value_t = 0.3)]
        s0: f64,
        /// Simulated duration [s].
        #[arg(long, short = 't', default_value_t = 120.0)]
        duration: f64,
        /// Model: free slider (fs) or pseudo-constrained slider (pcs).
        #[arg(long, value_enum, default_value = "fs")]
        model: ModelKind,
        /// Slider position of the PCS model.
        #[arg(long)]
        s_pcs: Option<f64>,
        /// Record every k-th time step.
        #[arg(long, default_value_t = 10)]
        record_every: usize,
        /// Channels (comma-separated): t, w, w@X (X in m), s, xc, zc, beta, q, u, uslider, p.
        #[arg(long, default_value = "t,w,s,zc,beta", value_delimiter = ',')]
        channels: Vec<String>,
        /// Output file: <name>.npz (NumPy, one float64 array per column) or CSV (shortest
        /// round-trip numbers); written under a temporary name and renamed when complete.
        /// '-' = CSV on standard output.
        #[arg(long, short = 'o', value_name = "FILE")]
        out: PathBuf,
    },
    /// Super-slow manifold by PCS continuation (docs/model.md §6); CSV with columns branch, s, amplitude_m.
    #[command(allow_negative_numbers = true)] // `--a-ex -1` is a bad value, not an unknown flag
    Manifold {
        #[command(flatten)]
        common: Common,
        /// Excitation periods per slider position.
        #[arg(long, default_value_t = 100)]
        periods: usize,
        /// Periods at the end of each position averaged for the amplitude.
        #[arg(long, default_value_t = 25)]
        record: usize,
        /// Start at s = 0 as the reference sweep does (contact points beyond the clamping);
        /// by default the sweep starts at the first s whose contact points lie on the beam.
        #[arg(long)]
        from_zero: bool,
        /// Output CSV file ('-' = standard output).
        #[arg(long, short = 'o', value_name = "FILE")]
        out: PathBuf,
    },
    /// Print the default parameters as TOML (a template for --params).
    Params,
    /// Operating map (docs/model.md §8, the paper's Fig. 11): classify the behaviour of the free slider at
    /// every point of an (f_ex, a_ex, s0) grid, in parallel. Each finished point is appended at once
    /// to DIR/map.jsonl; --resume skips the points already there; --extend-to T continues the
    /// points that had not settled from their saved end states to T seconds. At the end
    /// DIR/map.txt holds the map as a letter table.
    #[command(allow_negative_numbers = true)] // `--a-ex -1` is a bad value, not an unknown flag
    Map {
        /// Map configuration (TOML: duration_s, dt_s, record_every, [grid], [params], [criteria]);
        /// default: the paper's map (f_ex 100..130 step 2 Hz, a_ex 4..16 step 2 m/s^2, s0 0.3, 120 s).
        #[arg(long, short = 'c', value_name = "FILE")]
        config: Option<PathBuf>,
        /// Output folder (map.jsonl, map.toml, map.txt).
        #[arg(long, short = 'o', value_name = "DIR")]
        out: PathBuf,
        /// Worker threads (default: one per core).
        #[arg(long, short = 'j')]
        threads: Option<usize>,
        /// Continue the results in DIR: skip the points already there.
        #[arg(long)]
        resume: bool,
        /// Extend the map in DIR to T seconds: continue its not-settled points from their saved
        /// end states (bitwise the T-second runs); the configuration defaults to DIR/map.toml.
        #[arg(long, value_name = "T")]
        extend_to: Option<f64>,
        /// Print the default configuration (the paper's map) as TOML and exit.
        #[arg(long)]
        print_config: bool,
        /// Predict the map with the reduced super-slow model (docs/model.md §6.3, the fitted law) and this drift law
        /// (JSON, written by `beamslider.slowflow.fit_drift_law(...).save(path)`) instead of FS
        /// runs: milliseconds per point, the same results format (status `predicted`).
        #[arg(long, value_name = "LAW.json")]
        predictor: Option<PathBuf>,
        /// Hide the progress bar.
        #[arg(long, short = 'q')]
        quiet: bool,
    },
}

fn load_params(c: &Common) -> Result<Params> {
    let mut p = match &c.params {
        Some(path) => Params::from_toml_file(path)?,
        None => Params::default(),
    };
    if let Some(s) = c.solver {
        p.contact_solver = match s {
            SolverKind::Fast => ContactSolver::Fast,
            SolverKind::Reference => ContactSolver::Reference,
        };
    }
    Ok(p)
}

fn open_out(path: &PathBuf) -> Result<Box<dyn Write>> {
    if path.as_os_str() == "-" {
        return Ok(Box::new(BufWriter::new(std::io::stdout().lock())));
    }
    let f = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    Ok(Box::new(BufWriter::new(f)))
}

/// Progress bar as a run monitor.
struct Bar(ProgressBar);

impl Bar {
    fn new(quiet: bool, len: u64, unit: &str) -> Bar {
        if quiet {
            return Bar(ProgressBar::hidden());
        }
        let pb = ProgressBar::new(len);
        let template = format!("{{elapsed_precise}} [{{bar:40}}] {{pos}}/{{len}} {unit} (eta {{eta}})");
        pb.set_style(ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar()));
        Bar(pb)
    }
}

impl Monitor for Bar {
    fn poll(&mut self, t: f64, _t_end: f64) -> bool {
        self.0.set_position(t.floor() as u64);
        true
    }
}

/// Exit status of a run that stopped on a fault (diverged, left the beam) or a map with failed
/// points; user errors exit with 1.
const EXIT_FAULT: u8 = 3;

fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Map { config, out, threads, resume, extend_to, print_config, predictor, quiet } => {
            let saved = out.join("map.toml");
            let mut cfg = match &config {
                Some(path) => MapConfig::from_toml_file(path)?,
                None if extend_to.is_some() && saved.exists() => MapConfig::from_toml_file(&saved)?,
                None => MapConfig::default(),
            };
            if let Some(t) = extend_to {
                if !(t.is_finite() && t > cfg.duration_s) {
                    anyhow::bail!("invalid --extend-to {t}: must exceed the map's duration ({} s)", cfg.duration_s);
                }
                cfg.duration_s = t;
            }
            if print_config {
                print!("{}", cfg.to_toml_string());
                return Ok(ExitCode::SUCCESS);
            }
            if let Some(law) = predictor {
                if extend_to.is_some() {
                    anyhow::bail!("--extend-to does not apply to a predicted map (--predictor): predict it for the longer duration");
                }
                return run_predicted_map_command(&cfg, &law, &out, threads, resume, quiet);
            }
            return run_map_command(&cfg, &out, threads, resume, extend_to.is_some(), quiet);
        }
        Command::Params => {
            print!("{}", Params::default().to_toml_string());
        }
        Command::Simulate { common, s0, duration, model, s_pcs, record_every, channels, out } => {
            let params = load_params(&common)?;
            let m = Model::new(params)?;
            let exc = Excitation::new(common.f_ex, common.a_ex);
            let kind = match model {
                ModelKind::Fs => SliderModel::Free,
                ModelKind::Pcs => {
                    let Some(s) = s_pcs else { bail!("--model pcs needs --s-pcs") };
                    SliderModel::PseudoConstrained { s }
                }
            };
            let channels = channels.iter().map(|c| Channel::parse(c)).collect::<beamslider_core::Result<Vec<_>>>()?;
            let spec = RunSpec { model: kind, s0, excitation: exc, duration_s: duration, record_every, channels };
            let mut bar = Bar::new(common.quiet, duration.ceil() as u64, "s simulated");
            let t0 = std::time::Instant::now();
            // Inputs are checked before the output is created (bad input overwrites nothing); a
            // file is written under a temporary name and renamed when complete (.npz or CSV).
            let output = if out.as_os_str() == "-" {
                Output::Csv(Box::new(BufWriter::new(std::io::stdout().lock())), "standard output")
            } else {
                let format = if out.extension().is_some_and(|e| e.eq_ignore_ascii_case("npz")) { Format::Npz } else { Format::Csv };
                Output::File { path: &out, format: Some(format), overview: None }
            };
            let sum = signal::run::run(&m, &spec, output, &mut bar)?.summary;
            bar.0.finish_and_clear();
            let c = sum.counters;
            eprintln!(
                "{}: {} steps in {:.2} s ({:.0} ns/step); contact in {:.1} % of steps, closed contacts per step {:?}; solver: {} GS sweeps, {} cap hits, {} enumerations, {} fallbacks",
                sum.status.message(),
                c.steps,
                t0.elapsed().as_secs_f64(),
                t0.elapsed().as_secs_f64() / c.steps.max(1) as f64 * 1e9,
                100.0 * c.contact_steps as f64 / c.steps.max(1) as f64,
                c.closed_histogram,
                c.solver_iterations,
                c.cap_hits,
                c.enumerations,
                c.fallbacks
            );
            if sum.status != Status::Completed {
                eprintln!("beamslider-batch: {}", sum.status.message());
                return Ok(ExitCode::from(EXIT_FAULT));
            }
        }
        Command::Manifold { common, periods, record, from_zero, out } => {
            let params = load_params(&common)?;
            let m = Model::new(params)?;
            let exc = Excitation::new(common.f_ex, common.a_ex);
            let mut opts = if from_zero { ManifoldOptions::reference() } else { ManifoldOptions::physical(&m) };
            opts.periods = periods;
            opts.record_periods = record;
            let mut bar = Bar::new(common.quiet, 2 * opts.s_values.len() as u64, "positions");
            let man = super_slow_manifold(&m, &exc, &opts, &mut bar)?;
            bar.0.finish_and_clear();
            let mut w = open_out(&out)?;
            let io = |e| anyhow::anyhow!("{}: {e}", out.display());
            w.write_all(man.to_csv().as_bytes()).map_err(io)?;
            w.flush().map_err(io)?;
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn run_map_command(cfg: &MapConfig, out: &std::path::Path, threads: Option<usize>, resume: bool, extend: bool, quiet: bool) -> Result<ExitCode> {
    use std::sync::atomic::AtomicBool;
    let results = out.join(map::RESULTS_FILE);
    let opts = MapRunOptions { out: Some(results.clone()), resume, threads, extend };
    // Refuse bad input before writing anything (map.toml included).
    map::preflight(cfg, &opts)?;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let total = cfg.points()?.len();
    let bar = if quiet { ProgressBar::hidden() } else { ProgressBar::new(total as u64) };
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} points (eta {eta}) {msg}").unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let cancel = AtomicBool::new(false);
    let first = std::sync::atomic::AtomicBool::new(true);
    let progress = |done: usize, _total: usize, row: &MapRow| {
        if first.swap(false, std::sync::atomic::Ordering::Relaxed) {
            // ETA from the points computed now, not the resumed ones.
            bar.set_position((done - 1) as u64);
            bar.reset_eta();
        }
        bar.set_position(done as u64);
        bar.set_message(format!("{} Hz {} m/s2: {}", row.f_ex_hz, row.a_ex_m_s2, row.behaviour));
    };
    std::fs::write(out.join("map.toml"), cfg.to_toml_string()).with_context(|| format!("cannot write {}", out.join("map.toml").display()))?;
    let t0 = std::time::Instant::now();
    let outcome = run_map(cfg, &opts, &cancel, &progress)?;
    bar.finish_and_clear();
    let table = map::text_table(&outcome.rows);
    std::fs::write(out.join("map.txt"), &table).with_context(|| format!("cannot write {}", out.join("map.txt").display()))?;
    print!("{table}");
    if extend || outcome.extended > 0 {
        eprintln!("re-ran {} points (settled = false, or undetermined) from their saved end states to t = {} s", outcome.extended, cfg.duration_s);
    }
    eprintln!(
        "{} points: {} computed in {:.1} s, {} from the results file; wrote {}",
        outcome.rows.len(),
        outcome.computed,
        t0.elapsed().as_secs_f64(),
        outcome.resumed,
        results.display()
    );
    let failed = outcome.failures();
    if failed.is_empty() {
        return Ok(ExitCode::SUCCESS);
    }
    eprintln!("beamslider-batch: {} of {} points failed (the others are done):", failed.len(), outcome.rows.len());
    for r in failed {
        eprintln!("  #{} f_ex = {} Hz, a_ex = {} m/s^2, s0 = {}: {}: {}", r.index, r.f_ex_hz, r.a_ex_m_s2, r.s0, r.status, r.reason);
    }
    Ok(ExitCode::from(EXIT_FAULT))
}

fn run_predicted_map_command(
    cfg: &MapConfig, law_path: &std::path::Path, out: &std::path::Path, threads: Option<usize>, resume: bool, quiet: bool,
) -> Result<ExitCode> {
    use std::sync::atomic::AtomicBool;
    let law = superslow::law::DriftLaw::from_file(law_path).with_context(|| format!("cannot use the drift law {}", law_path.display()))?;
    let results = out.join(map::RESULTS_FILE);
    let opts = MapRunOptions { out: Some(results.clone()), resume, threads, extend: false };
    // The checks of `map::preflight` (with the predictor's header) are made by the core before it
    // writes anything; map.toml and map.txt are written after the map.
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let total = cfg.points()?.len();
    let bar = if quiet { ProgressBar::hidden() } else { ProgressBar::new(total as u64) };
    bar.set_style(ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} points {msg}").unwrap_or_else(|_| ProgressStyle::default_bar()));
    let progress = |done: usize, _total: usize, row: &MapRow| {
        bar.set_position(done as u64);
        bar.set_message(format!("{} Hz {} m/s2: {}", row.f_ex_hz, row.a_ex_m_s2, row.behaviour));
    };
    let cancel = AtomicBool::new(false);
    let t0 = std::time::Instant::now();
    let outcome = superslow::predicted_map::run_predicted_map(cfg, &law, &superslow::predict::PredictOptions::default(), &opts, &cancel, &progress)?;
    bar.finish_and_clear();
    std::fs::write(out.join("map.toml"), cfg.to_toml_string()).with_context(|| format!("cannot write {}", out.join("map.toml").display()))?;
    let table = map::text_table(&outcome.rows);
    std::fs::write(out.join("map.txt"), &table).with_context(|| format!("cannot write {}", out.join("map.txt").display()))?;
    print!("{table}");
    let extrapolated = outcome.rows.iter().filter(|r| r.extra.get("extrapolated").and_then(|v| v.as_bool()).unwrap_or(false)).count();
    let weak = outcome.rows.iter().filter(|r| r.extra.get("robust").and_then(|v| v.as_bool()) == Some(false)).count();
    let robustness = if law.v_resolution > 0.0 {
        format!("; {weak} not robust (V ± {:.1e} 1/s changes the behaviour or the final s; key `robust` in the rows)", law.v_resolution)
    } else {
        String::new()
    };
    eprintln!(
        "{} points predicted by the drift law {} (trained on {} operating points): {} computed in {:.2} s, {} from the results file; {} outside the law's training range{}; wrote {}",
        outcome.rows.len(),
        law_path.display(),
        law.points.len(),
        outcome.computed,
        t0.elapsed().as_secs_f64(),
        outcome.resumed,
        extrapolated,
        robustness,
        results.display()
    );
    let failed: Vec<&MapRow> = outcome.rows.iter().filter(|r| r.status == results::STATUS_ERROR).collect();
    if failed.is_empty() {
        return Ok(ExitCode::SUCCESS);
    }
    eprintln!("beamslider-batch: {} of {} points failed (the others are done):", failed.len(), outcome.rows.len());
    for r in failed {
        eprintln!("  #{} f_ex = {} Hz, a_ex = {} m/s^2, s0 = {}: {}", r.index, r.f_ex_hz, r.a_ex_m_s2, r.s0, r.reason);
    }
    Ok(ExitCode::from(EXIT_FAULT))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("beamslider-batch: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
