//! One run of docs/model.md §5–6 to its recorders, the orchestration every front end shares
//! (the Python binding, `beamslider-batch`): the model's start state, the input checks before
//! anything is written, then the rows in memory, streamed to a trajectory file (with the run
//! overview and super-slow signals of §7 gathered as they stream) or written as CSV.

use std::io::Write;
use std::path::Path;

use crate::dynamics::record::{Channel, ColumnRecorder, CsvRecorder, Recorder, Tee};
use crate::dynamics::simulation::{Excitation, Model, Monitor, RunOptions, RunSummary, SliderModel, State, Status};
use crate::error::{Error, Result};
use crate::signal::envelope_stream::SuperSlow;
use crate::signal::output::{FileRecorder, Format, recorded_rows};
use crate::signal::overview::{Overview, OverviewRecorder};

/// What to run: model, start, excitation, duration and what to record.
#[derive(Debug, Clone)]
pub struct RunSpec {
    /// Free slider, pseudo-constrained slider or beam only.
    pub model: SliderModel,
    /// Initial slider position s₀ (free slider).
    pub s0: f64,
    /// Excitation.
    pub excitation: Excitation,
    /// Simulated duration [s].
    pub duration_s: f64,
    /// Keep every k-th step (the start state is the first row).
    pub record_every: usize,
    /// Recorded channels, in order.
    pub channels: Vec<Channel>,
}

/// The columns a front end records by default, with their names (docs/model.md §5): t, w(4L/7),
/// s, x_C, z_C, β.
pub const RECORDED: [(&str, Channel); 6] =
    [("t_s", Channel::Time), ("w_4L7_m", Channel::W4L7), ("s", Channel::S), ("xC_m", Channel::XC), ("zC_m", Channel::ZC), ("beta_rad", Channel::Beta)];

impl RunSpec {
    /// The run of the model named `name` ([`model_named`]) recording the [`RECORDED`] columns.
    pub fn recorded(name: &str, s_pcs: Option<f64>, s0: f64, excitation: Excitation, duration_s: f64, record_every: usize) -> Result<Self> {
        let model = model_named(name, s_pcs, s0)?;
        Ok(RunSpec { model, s0, excitation, duration_s, record_every, channels: RECORDED.map(|c| c.1).to_vec() })
    }
}

/// Where the rows go.
pub enum Output<'a> {
    /// Columns in memory ([`RunOutput::columns`]).
    Memory,
    /// A trajectory file written under a temporary name and renamed when complete (an
    /// interrupted run leaves nothing); `format` None: from the extension. With `overview`
    /// = (pixel columns, moving-average window [s]) the run overview and the super-slow signals
    /// are gathered as the rows stream.
    File {
        /// The file.
        path: &'a Path,
        /// Its format (None: from the extension).
        format: Option<Format>,
        /// (pixel columns, window [s]) of the overview, or None.
        overview: Option<(usize, f64)>,
    },
    /// CSV text to a writer (e.g. standard output), named `name` in errors.
    Csv(Box<dyn Write + 'a>, &'a str),
}

/// The outcome of a run.
#[derive(Debug)]
pub struct RunOutput {
    /// Status, counters and final state.
    pub summary: RunSummary,
    /// Recorded columns of an in-memory run, in channel order (empty otherwise).
    pub columns: Vec<Vec<f64>>,
    /// Rows recorded (0 when interrupted).
    pub rows: u64,
    /// Overview of a streamed run (with `overview` requested and the run not interrupted).
    pub overview: Option<Overview>,
    /// Super-slow signals of the overview (§7) with the requested window.
    pub super_slow: Option<SuperSlow>,
}

/// The model's start state and the run's options, with every input of `spec` checked.
fn prepare(model: &Model, spec: &RunSpec) -> Result<(State, RunOptions)> {
    let start = model.start(spec.model, spec.s0, &spec.excitation)?;
    let opts = RunOptions {
        excitation: spec.excitation,
        model: spec.model,
        duration_s: spec.duration_s,
        record_every: spec.record_every,
        channels: spec.channels.clone(),
        audit_contacts: false,
    };
    model.check_run(&start, &opts)?;
    Ok((start, opts))
}

/// Check the inputs of `spec` on `model` as [`run`] does first (operating point, start state,
/// duration and recording), running nothing: a front end's check before other work.
pub fn check(model: &Model, spec: &RunSpec) -> Result<()> {
    prepare(model, spec).map(|_| ())
}

/// The model named `name` (docs/model.md §6): "fs" (free slider), "pcs" (pseudo-constrained
/// slider at `s_pcs`, default `s0`) or "beam" (beam only).
pub fn model_named(name: &str, s_pcs: Option<f64>, s0: f64) -> Result<SliderModel> {
    match name {
        "fs" => Ok(SliderModel::Free),
        "pcs" => Ok(SliderModel::PseudoConstrained { s: s_pcs.unwrap_or(s0) }),
        "beam" => Ok(SliderModel::BeamOnly),
        other => {
            Err(Error::invalid("model", format!("{other:?}"), r#"must be one of "fs" (free slider), "pcs" (pseudo-constrained slider), "beam" (beam only)"#))
        }
    }
}

/// Run `spec` on `model` into `output`: inputs checked first (bad input writes nothing), then
/// [`Monitor::start`], then the steps. An interrupted run returns its summary (status
/// `Interrupted`) and leaves no file.
pub fn run(model: &Model, spec: &RunSpec, output: Output<'_>, monitor: &mut dyn Monitor) -> Result<RunOutput> {
    let (start, opts) = prepare(model, spec)?;
    let expected = recorded_rows(spec.duration_s, model.params.dt_s, spec.record_every);
    let out = |summary, columns, rows, overview| RunOutput { summary, columns, rows, overview, super_slow: None };
    if !monitor.start() {
        let summary = RunSummary { status: Status::Interrupted { t_s: start.t_s }, state: start, counters: Default::default() };
        return Ok(out(summary, Vec::new(), 0, None));
    }
    match output {
        Output::Memory => {
            let rows = usize::try_from(expected).map_err(|_| Error::invalid("t_end", spec.duration_s, "too many rows to record in memory"))?;
            let mut rec = ColumnRecorder::with_rows(rows);
            let summary = model.run(&start, &opts, &mut rec as &mut dyn Recorder, monitor)?;
            let n = rec.columns.first().map_or(0, Vec::len) as u64;
            let mut columns = std::mem::take(&mut rec.columns);
            columns.truncate(spec.channels.len());
            Ok(out(summary, columns, n, None))
        }
        Output::File { path, format, overview } => {
            let mut rec = match format {
                Some(f) => FileRecorder::create_as(path, f, expected)?,
                None => FileRecorder::create(path, expected)?,
            };
            let Some((columns, window_s)) = overview else {
                let summary = model.run(&start, &opts, &mut rec, monitor)?;
                if let Status::Interrupted { .. } = summary.status {
                    return Ok(out(summary, Vec::new(), 0, None)); // the recorder removes its files
                }
                let rows = rec.commit()?;
                return Ok(out(summary, Vec::new(), rows, None));
            };
            let mut ov = OverviewRecorder::new(expected, columns, model.params.dt_s, spec.record_every);
            let summary = model.run(&start, &opts, &mut Tee(&mut rec, &mut ov), monitor)?;
            if let Status::Interrupted { .. } = summary.status {
                return Ok(out(summary, Vec::new(), 0, None));
            }
            let rows = rec.commit()?;
            let ov = ov.finish();
            let super_slow = ov.signals.as_ref().map(|st| st.super_slow(model.params.thickness_m, window_s));
            Ok(RunOutput { super_slow, ..out(summary, Vec::new(), rows, Some(ov)) })
        }
        Output::Csv(writer, name) => {
            let mut rec = CsvRecorder::new(writer, name);
            let summary = model.run(&start, &opts, &mut rec, monitor)?;
            rec.finish()?;
            Ok(out(summary, Vec::new(), 0, None))
        }
    }
}
