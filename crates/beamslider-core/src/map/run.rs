//! Running an operating map (docs/model.md §8): one classified free-slider run per grid point,
//! in parallel, appended to the results file; resume and extension in time.

use std::collections::HashSet;
use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use super::config::MapConfig;
use crate::classify::{Behaviour, Classification, classify};
use crate::dynamics::record::{Channel, Recorder};
use crate::dynamics::runner::{catch_panic, run_batch};
use crate::dynamics::simulation::{CancelFlag, Checkpoint, Excitation, Model, RunOptions, SliderModel, Status};
use crate::dynamics::stepper::Counters;
use crate::error::{Error, Result};
use crate::results::{
    EndState, FORMAT_VERSION, MapPoint, MapRow, ResultsFile, ResultsLock, STATUS_ERROR, header_line_predictor, io_err, latest, open_append, read_results,
    write_line,
};
use crate::signal::envelope_stream::EnvelopeStream;

/// Feeds w(4L/7) and s of every recorded row (channels [W4L7, S]) into the super-slow stream.
struct StreamRecorder<'a>(&'a mut EnvelopeStream);

impl Recorder for StreamRecorder<'_> {
    fn begin(&mut self, _: &[String]) -> Result<()> {
        Ok(())
    }
    fn push(&mut self, row: &[f64]) -> Result<()> {
        self.0.push(row[0], row[1]);
        Ok(())
    }
}

fn run_options(cfg: &MapConfig, p: &MapPoint) -> RunOptions {
    RunOptions {
        excitation: Excitation::new(p.f_ex_hz, p.a_ex_m_s2),
        model: SliderModel::Free,
        duration_s: cfg.duration_s,
        record_every: cfg.record_every,
        channels: vec![Channel::W4L7, Channel::S],
        audit_contacts: false,
    }
}

/// Run and classify one point from rest. `None` when cancelled.
pub fn run_point(model: &Model, cfg: &MapConfig, p: &MapPoint, cancel: &AtomicBool) -> Result<Option<MapRow>> {
    let t0 = Instant::now();
    let exc = Excitation::new(p.f_ex_hz, p.a_ex_m_s2);
    let start = model.initial_state(p.s0, &exc)?;
    let opts = run_options(cfg, p);
    let mut stream = EnvelopeStream::new(model.params.dt_s * cfg.record_every as f64)?;
    let (sum, cp) = model.run_checkpointed(&start, &opts, &mut StreamRecorder(&mut stream), &mut CancelFlag(cancel))?;
    finish_point(model, cfg, p, sum.status, &sum.counters, cp, stream, t0)
}

/// Continue a not-settled point from the end state of its row to `cfg.duration_s` and classify
/// the whole run: bitwise the row of a run from rest to `cfg.duration_s` (but the wall time).
/// `None` when cancelled.
pub fn continue_point(model: &Model, cfg: &MapConfig, row: &MapRow, cancel: &AtomicBool) -> Result<Option<MapRow>> {
    let t0 = Instant::now();
    let end = row.end.as_ref().ok_or_else(|| Error::invalid("extend_to", row.index, "this row has no saved end state (map written by an older version?)"))?;
    let (cp, mut stream) = end.restore(model.beam.n, model.params.dt_s * cfg.record_every as f64)?;
    let p = row.point();
    let opts = run_options(cfg, &p);
    let (sum, cp) = model.run_from(&cp, &opts, &mut StreamRecorder(&mut stream), &mut CancelFlag(cancel))?;
    finish_point(model, cfg, &p, sum.status, &sum.counters, cp, stream, t0)
}

#[allow(clippy::too_many_arguments)]
fn finish_point(
    model: &Model, cfg: &MapConfig, p: &MapPoint, status: Status, counters: &Counters, cp: Checkpoint, stream: EnvelopeStream, t0: Instant,
) -> Result<Option<MapRow>> {
    if let Status::Interrupted { .. } = status {
        return Ok(None);
    }
    let dt = model.params.dt_s * cfg.record_every as f64;
    let t_end = (stream.len().saturating_sub(1)) as f64 * dt;
    let x = stream.super_slow(model.params.thickness_m, 1.0);
    let c = if x.s.len() >= 2 {
        let mut c = classify(&x, &cfg.criteria)?;
        if status != Status::Completed {
            c.behaviour = Behaviour::Undetermined;
            c.reason = status.message();
            c.phase = "failed".into();
            c.settled = false;
        }
        c
    } else if status != Status::Completed {
        no_classification(p, status.message())
    } else {
        no_classification(p, format!("too short to classify: the super-slow signals need two {} s bins", crate::signal::envelope_stream::BIN_S))
    };
    let end = (status == Status::Completed).then(|| EndState::new(&cp, stream));
    Ok(Some(MapRow::new(p, t_end, &status, &c, counters, t0.elapsed().as_secs_f64(), end)))
}

/// The classification of a point that has no super-slow signals (failed or stopped at once).
fn no_classification(p: &MapPoint, reason: String) -> Classification {
    Classification {
        behaviour: Behaviour::Undetermined,
        reason,
        s_initial: p.s0,
        s_final: f64::NAN,
        amplitude_final_h: f64::NAN,
        amplitude_initial_h: f64::NAN,
        amplitude_max_h: f64::NAN,
        s_min: f64::NAN,
        s_max: f64::NAN,
        net_travel: f64::NAN,
        travel_to_centre: f64::NAN,
        turn_s: f64::NAN,
        turn_t_s: f64::NAN,
        jump_up_t_s: vec![],
        jump_down_t_s: vec![],
        steady: false,
        phase: "failed".into(),
        settled: false,
        drift_s: f64::NAN,
        drift_a_h: f64::NAN,
    }
}

/// What to compute for one grid point: a run from rest, or the continuation of a not-settled
/// row from its end state.
#[derive(Debug, Clone)]
pub enum Job {
    /// A run from rest.
    Fresh(MapPoint),
    /// The continuation of a not-settled row (the grid point, the row with its end state).
    Continue(MapPoint, Box<MapRow>),
}

impl Job {
    /// The grid point of the job.
    pub fn point(&self) -> &MapPoint {
        match self {
            Job::Fresh(p) | Job::Continue(p, _) => p,
        }
    }
}

/// Run one job; an error or a panic of the run becomes a row with status `error` and the
/// message as reason, so that one failing point does not stop the map. `None` when cancelled.
pub fn run_job(model: &Model, cfg: &MapConfig, job: &Job, cancel: &AtomicBool) -> Option<MapRow> {
    run_point_guarded(model, cfg, job, cancel)
}

fn run_point_guarded(model: &Model, cfg: &MapConfig, job: &Job, cancel: &AtomicBool) -> Option<MapRow> {
    let t0 = Instant::now();
    let p = match job {
        Job::Fresh(p) | Job::Continue(p, _) => p,
    };
    let r = catch_panic(|| match job {
        Job::Fresh(p) => run_point(model, cfg, p, cancel),
        Job::Continue(p, row) => continue_point(model, cfg, row, cancel).map(|r| {
            r.map(|mut r| {
                r.index = p.index;
                r
            })
        }),
    });
    let message = match r {
        Ok(Ok(row)) => return row,
        Ok(Err(e)) => e.to_string(),
        Err(what) => format!("internal error: {what}"),
    };
    Some(error_row(p, &message, t0))
}

/// The row of a point that failed with `message` (status `error`; started at `t0`).
pub fn error_row(p: &MapPoint, message: &str, t0: Instant) -> MapRow {
    let c = no_classification(p, message.to_string());
    let mut row = MapRow::new(p, f64::NAN, &Status::Completed, &c, &Counters::default(), t0.elapsed().as_secs_f64(), None);
    row.status = STATUS_ERROR.to_string();
    row.t_end_s = 0.0;
    row
}

/// Progress of a map: called after every finished point with (points done, points total, row).
pub type Progress<'a> = &'a (dyn Fn(usize, usize, &MapRow) + Sync);

/// Outcome of [`super::run_map`].
#[derive(Debug, Clone)]
pub struct MapOutcome {
    /// All rows of the grid present in the results (resumed and new), sorted by grid index.
    pub rows: Vec<MapRow>,
    /// Points skipped because they were already in the results file.
    pub resumed: usize,
    /// Points computed by this call (from rest or continued).
    pub computed: usize,
    /// Not-settled and undetermined points continued from their saved end states by this call.
    pub extended: usize,
    /// Whether the run was cancelled before all points were done.
    pub cancelled: bool,
}

impl MapOutcome {
    /// Rows whose run did not complete (status `left_beam`, `diverged` or `error`), by index.
    pub fn failures(&self) -> Vec<&MapRow> {
        self.rows.iter().filter(|r| r.status != Status::Completed.name()).collect()
    }
}

/// How to run a map.
#[derive(Debug, Clone, Default)]
pub struct MapRunOptions {
    /// Results file (JSON lines); `None` keeps the rows in memory only.
    pub out: Option<PathBuf>,
    /// Continue an existing results file: skip its points (otherwise an existing file is an error).
    pub resume: bool,
    /// Worker threads (None = rayon's default: one per core).
    pub threads: Option<usize>,
    /// Extend the map in `out` to `cfg.duration_s`: the results file must exist with the same
    /// settings but a shorter (or, when resuming an interrupted extension, the same) duration;
    /// its not-settled points continue from their end states, the others keep their rows.
    pub extend: bool,
}

/// Everything [`super::run_map`] checks before it computes or writes anything: the configuration, the
/// model (Δt against the highest mode) and the results file (exists without `resume`, written
/// with other settings, unreadable). Front ends call it before they write files of their own
/// (`map.toml`), so that a refused map overwrites nothing.
pub fn preflight(cfg: &MapConfig, opts: &MapRunOptions) -> Result<()> {
    cfg.validate()?;
    Model::of(&cfg.valid_params()?)?;
    cfg.check_records()?;
    if opts.extend && opts.out.is_none() {
        return Err(Error::invalid("extend_to", cfg.duration_s, "needs the results file of the map to extend (out)"));
    }
    if let Some(path) = &opts.out {
        existing_results(cfg, opts, path, None)?;
    }
    Ok(())
}

/// The results file `path` of the map to run, read and checked (None when absent or empty): an
/// existing file needs `resume` or `extend` and the same settings ([`check_settings`]); `extend`
/// needs one.
fn existing_results(cfg: &MapConfig, opts: &MapRunOptions, path: &Path, predictor: Option<&serde_json::Value>) -> Result<Option<ResultsFile>> {
    let exists = path.exists() && std::fs::metadata(path).map(|m| m.len() > 0).unwrap_or(false);
    if exists && !opts.resume && !opts.extend {
        return Err(Error::invalid("out", path.display(), "the results file exists: resume it, or choose another output"));
    }
    if opts.extend && !exists {
        return Err(Error::invalid("extend_to", path.display(), "no results file to extend"));
    }
    if !exists {
        return Ok(None);
    }
    let old = read_results(path)?;
    check_settings(cfg, opts, path, &old, predictor)?;
    Ok(Some(old))
}

/// The settings of an existing results file against the map to run (resume: equal; extend:
/// equal but for a duration ≤ the new one, and end states saved for the not-settled points).
fn check_settings(cfg: &MapConfig, opts: &MapRunOptions, path: &Path, old: &ResultsFile, predictor: Option<&serde_json::Value>) -> Result<()> {
    let new = cfg.settings();
    if old.settings.is_some() && old.version < 2 {
        let what = if opts.extend { "extend_to" } else { "resume" };
        return Err(Error::invalid(
            what,
            path.display(),
            &format!("the results file has format version {} (rows classified by older rules, no end states); start a new map", old.version),
        ));
    }
    let Some(s) = &old.settings else {
        if opts.extend {
            return Err(Error::invalid("extend_to", path.display(), "the results file has no map to extend"));
        }
        return Ok(());
    };
    if opts.extend {
        let mut same = s.clone();
        same.duration_s = new.duration_s;
        if same != new {
            return Err(Error::invalid(
                "extend_to",
                path.display(),
                "the results file was written with other settings (parameters, record_every or criteria); only the duration may change",
            ));
        }
        if s.duration_s > new.duration_s {
            return Err(Error::invalid("extend_to", new.duration_s, &format!("must exceed the map's t_end ({} s)", s.duration_s)));
        }
        if let Some(r) = old.rows.iter().find(|r| {
            (!r.settled || matches!(r.behaviour, Behaviour::NotSettled | Behaviour::Undetermined)) && r.status == Status::Completed.name() && r.end.is_none()
        }) {
            return Err(Error::invalid(
                "extend_to",
                path.display(),
                &format!("point #{} (f_ex = {} Hz, a_ex = {} m/s^2, s0 = {}) has no saved end state", r.index, r.f_ex_hz, r.a_ex_m_s2, r.s0),
            ));
        }
        return Ok(());
    }
    let mut extended = new.clone();
    extended.duration_s = s.duration_s;
    // An interrupted extension: the header has the longer duration, and points still end before it.
    if *s != new && extended == *s && s.duration_s > new.duration_s && latest(old.rows.clone()).iter().any(|r| r.continuable(s.duration_s)) {
        return Err(Error::invalid(
            "resume",
            path.display(),
            &format!(
                "the map is being extended to {} s (an interrupted --extend-to): run the same --extend-to {} again to finish it",
                s.duration_s, s.duration_s
            ),
        ));
    }
    if *s != new {
        return Err(Error::invalid(
            "resume",
            path.display(),
            "the results file was written with other settings (parameters, duration, record_every or criteria); only the grid may change",
        ));
    }
    if old.predictor.as_ref() != predictor {
        let what = match (&old.predictor, predictor) {
            (Some(_), None) => "the results file is a predicted map (reduced predictor), not FS runs",
            (None, Some(_)) => "the results file holds FS runs, not a predicted map",
            _ => "the results file was predicted with another drift law or predictor settings",
        };
        return Err(Error::invalid("resume", path.display(), what));
    }
    Ok(())
}

/// A row of a version-2 results file as this version writes it: a completed row with an end
/// state is reclassified from the super-slow signals saved in it (the classification depends on
/// these signals and the criteria only, so the row is bitwise the one a run of this version
/// writes, but for the wall time); a row without (a failed run, a predicted point) keeps its
/// fields, with `settled` as read ([`MapRow::derive_settled`]).
pub fn upgrade_row(cfg: &MapConfig, thickness_m: f64, row: &MapRow) -> Result<MapRow> {
    let Some(end) = row.end.as_ref().filter(|_| row.status == Status::Completed.name()) else {
        return Ok(row.clone());
    };
    let x = end.signals.super_slow(thickness_m, 1.0);
    if x.s.len() < 2 {
        return Ok(row.clone());
    }
    let c = classify(&x, &cfg.criteria)?;
    let mut out = MapRow::from_classification(&row.point(), row.t_end_s, &row.status, &c, row.counters, row.wall_time_s, row.end.clone());
    out.extra = row.extra.clone();
    Ok(out)
}

/// The results of a map being run: the rows kept from an existing results file, the jobs still
/// to do, and — with a results file — the file, locked for this process ([`ResultsLock`]: a
/// second writer fails at once naming the holder) and opened for appending (O_APPEND, one write
/// per row). Shared by the local runner ([`super::run_map`]) and front ends that run the jobs
/// elsewhere (a Dask cluster) and append the rows here.
#[derive(Debug)]
pub struct MapResults {
    file: Option<(File, PathBuf, ResultsLock)>,
    /// Rows of the grid so far: kept from the file, then appended.
    pub rows: Vec<MapRow>,
    /// Points still to compute (continuations first, then runs from rest).
    pub jobs: Vec<Job>,
    /// Points in the grid.
    pub total: usize,
    /// Points kept from the results file.
    pub resumed: usize,
    /// Not-settled points to be continued from their end states.
    pub extended: usize,
}

impl MapResults {
    /// Check the map (as [`preflight`]), take the results file's lock, cut off a torn last line,
    /// write the header of a new file and plan the jobs.
    pub fn open(cfg: &MapConfig, opts: &MapRunOptions) -> Result<MapResults> {
        MapResults::open_with(cfg, opts, None)
    }

    /// As [`MapResults::open`] for a map predicted by the reduced model ([`crate::superslow::predict`]):
    /// the header also holds `predictor`, and a resumed file must hold the same one.
    pub fn open_predicted(cfg: &MapConfig, opts: &MapRunOptions, predictor: &serde_json::Value) -> Result<MapResults> {
        MapResults::open_with(cfg, opts, Some(predictor))
    }

    fn open_with(cfg: &MapConfig, opts: &MapRunOptions, predictor: Option<&serde_json::Value>) -> Result<MapResults> {
        cfg.validate()?;
        let points = cfg.points()?;
        let settings = cfg.settings();
        Model::of(&cfg.valid_params()?)?;
        cfg.check_records()?;
        if opts.extend && opts.out.is_none() {
            return Err(Error::invalid("extend_to", cfg.duration_s, "needs the results file of the map to extend (out)"));
        }
        let mut existing: Vec<MapRow> = Vec::new();
        let file = match &opts.out {
            None => None,
            Some(path) => {
                if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                    std::fs::create_dir_all(dir).map_err(|e| io_err(dir, e))?;
                }
                let lock = ResultsLock::acquire(path)?;
                let old = existing_results(cfg, opts, path, predictor)?;
                let exists = old.is_some();
                if let Some(old) = old
                    && old.settings.as_ref().is_some_and(|s| *s != settings || old.version != FORMAT_VERSION)
                {
                    // Extension: the header takes the new duration; an older format (version 2)
                    // is upgraded, its rows reclassified from their end states
                    // ([`upgrade_row`]). Write the new file beside the old one and swap them, so
                    // that a kill loses nothing.
                    let tmp = path.with_extension("jsonl.extend-tmp");
                    let mut text = header_line_predictor(&settings, predictor);
                    text.push('\n');
                    let thickness = cfg.effective_params().thickness_m;
                    for r in &latest(old.rows) {
                        let r = if old.version == FORMAT_VERSION { r.clone() } else { upgrade_row(cfg, thickness, r)? };
                        text.push_str(&r.to_json());
                        text.push('\n');
                    }
                    std::fs::write(&tmp, text).map_err(|e| io_err(&tmp, e))?;
                    std::fs::rename(&tmp, path).map_err(|e| io_err(path, e))?;
                }
                let f = if exists {
                    let old = read_results(path)?;
                    let mut f = open_append(path, old.good_len)?;
                    if old.settings.is_none() {
                        write_line(&mut f, path, &header_line_predictor(&settings, predictor))?;
                    }
                    existing = latest(old.rows);
                    f
                } else {
                    let mut f = OpenOptions::new().create(true).truncate(true).write(true).open(path).map_err(|e| io_err(path, e))?;
                    write_line(&mut f, path, &header_line_predictor(&settings, predictor))?;
                    drop(f);
                    OpenOptions::new().append(true).open(path).map_err(|e| io_err(path, e))?
                };
                Some((f, path.clone(), lock))
            }
        };
        // Points already done (by inputs, not by index: the grid may have changed).
        let done_keys: HashSet<_> = existing.iter().map(MapRow::key).collect();
        let mut kept: Vec<MapRow> = Vec::new();
        let mut seen = HashSet::new();
        for p in &points {
            if done_keys.contains(&p.key())
                && seen.insert(p.key())
                && let Some(r) = existing.iter().find(|r| r.key() == p.key())
            {
                let mut r = r.clone();
                r.index = p.index;
                kept.push(r);
            }
        }
        // Not-settled and undetermined rows that end before the map's duration continue from their end states.
        let (cont, kept): (Vec<MapRow>, Vec<MapRow>) = kept.into_iter().partition(|r| r.continuable(cfg.duration_s));
        let extended = cont.len();
        let mut jobs: Vec<Job> = cont.into_iter().map(|r| Job::Continue(r.point(), Box::new(r))).collect();
        jobs.extend(points.iter().filter(|p| !done_keys.contains(&p.key())).map(|p| Job::Fresh(*p)));
        let resumed = kept.len();
        Ok(MapResults { file, rows: kept, jobs, total: points.len(), resumed, extended })
    }

    /// Append a finished row: one line, one write to the file opened with O_APPEND.
    pub fn append(&mut self, row: MapRow) -> Result<()> {
        if let Some((f, path, _)) = &mut self.file {
            write_line(f, path, &row.to_json())?;
        }
        self.rows.push(row);
        Ok(())
    }

    /// The outcome: all rows sorted by grid index (releases the lock).
    pub fn finish(self) -> MapOutcome {
        let mut rows = self.rows;
        rows.sort_by_key(|r| r.index);
        let computed = rows.len() - self.resumed;
        MapOutcome { cancelled: rows.len() < self.total, rows, resumed: self.resumed, computed, extended: self.extended }
    }
}

/// Run `jobs` in parallel (the core's batch runner, [`run_batch`]: `threads` workers or one per
/// core), handing each finished row to `on_row`; an error of `on_row` cancels the rest.
pub fn run_jobs(cfg: &MapConfig, jobs: &[Job], threads: Option<usize>, cancel: &AtomicBool, mut on_row: impl FnMut(MapRow) -> Result<()> + Send) -> Result<()> {
    let model = Model::of(&cfg.valid_params()?)?;
    run_batch(jobs, threads, cancel, |job| Ok(run_point_guarded(&model, cfg, job, cancel)), |row: &MapRow| on_row(row.clone()))?;
    Ok(())
}
