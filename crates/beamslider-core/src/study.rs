//! Uncertainty studies (MODEL.md §8): chunks of independent free-slider runs, each point with its
//! own parameter set, operating point (f_ex, a_ex, s₀) and duration, run from rest and classified
//! exactly as a point of an operating map ([`crate::map::run_point`]), so a study row is bitwise
//! the map row of the same inputs. The points run on the one batch runner ([`crate::dynamics::runner`]).
//!
//! The study's results file ([`StudyResults`]) is a map results file whose header also holds the
//! study's configuration and whose rows also hold their sample, operating point and parameter
//! values; written, read and resumed here only. The sampling, the statistics and the distribution
//! over a Dask cluster live in the Python package (`beamslider.study`); a Dask task runs one chunk
//! through [`run_points`] and the client adds its rows to the [`StudyResults`].

use std::collections::{BTreeMap, HashMap};
use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use rayon::prelude::*;

use crate::dynamics::runner::{run_batch, with_threads};
use crate::dynamics::simulation::Model;
use crate::error::{Error, Result};
use crate::map::{self, MapConfig, MapPoint, MapRow};
use crate::params::{Params, Valid};
use crate::results::{self, ResultsLock};

/// One point of a study: its own parameters, operating point and duration.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyPoint {
    /// Index of the point in the study (the row's `index`).
    pub index: usize,
    /// Full parameter set, validated (the configuration's `dt_s` override applies).
    pub params: Valid,
    /// f_ex [Hz].
    pub f_ex_hz: f64,
    /// a_ex [m/s²].
    pub a_ex_m_s2: f64,
    /// s₀.
    pub s0: f64,
    /// Simulated duration [s].
    pub duration_s: f64,
}

/// A point as a front end sends it: (index, parameters, f_ex [Hz], a_ex [m/s²], s₀, duration [s]).
pub type PointTuple = (usize, Valid, f64, f64, f64, f64);

impl From<PointTuple> for StudyPoint {
    fn from((index, params, f_ex_hz, a_ex_m_s2, s0, duration_s): PointTuple) -> Self {
        StudyPoint { index, params, f_ex_hz, a_ex_m_s2, s0, duration_s }
    }
}

/// Run the points of a chunk in parallel on `threads` workers (default one per core).
/// `cfg` is a map configuration (record_every, dt_s, criteria; its grid and parameters are not
/// used). Points with the same parameter text share one [`Model`]. `on_row(&row)` sees every
/// finished row (streaming); an error there, or of a point, stops the chunk. Returns the rows
/// sorted by index, `None` when cancelled before all points were done. A study row keeps the
/// classification, not the end state (it is not extended in time).
pub fn run_points(
    cfg: &MapConfig, points: &[StudyPoint], threads: Option<usize>, cancel: &AtomicBool, on_row: impl FnMut(&MapRow) -> Result<()> + Send,
) -> Result<Option<Vec<MapRow>>> {
    for (i, p) in points.iter().enumerate() {
        if !(p.duration_s.is_finite() && p.duration_s > 0.0) {
            return Err(Error::invalid("duration_s", format!("{} (point {i})", p.duration_s), "must be finite and > 0"));
        }
    }
    // One model per distinct parameter set (keyed by its canonical text), built in parallel;
    // validated again only where the configuration's dt_s overrides theirs.
    let keys: Vec<String> = points.iter().map(|p| p.params.to_toml_string()).collect();
    let mut sets: HashMap<&str, &Valid> = HashMap::new();
    for (k, p) in keys.iter().zip(points) {
        sets.entry(k.as_str()).or_insert(&p.params);
    }
    let sets: Vec<(&str, &Valid)> = sets.into_iter().collect();
    let models: Vec<Model> = with_threads(threads, || {
        sets.par_iter()
            .map(|(_, p)| match cfg.dt_s {
                Some(dt) if dt != p.dt_s => Model::new(Params { dt_s: dt, ..p.get().clone() }),
                _ => Model::of(p),
            })
            .collect::<Result<_>>()
    })??;
    let by_key: HashMap<&str, &Model> = sets.iter().map(|(k, _)| *k).zip(models.iter()).collect();
    let model_of: HashMap<usize, &Model> = points.iter().zip(&keys).map(|(p, k)| (p.index, by_key[k.as_str()])).collect();
    let run = |pt: &StudyPoint| {
        let mut c = cfg.clone();
        c.duration_s = pt.duration_s;
        let p = MapPoint { index: pt.index, f_ex_hz: pt.f_ex_hz, a_ex_m_s2: pt.a_ex_m_s2, s0: pt.s0 };
        Ok(map::run_point(model_of[&pt.index], &c, &p, cancel)?.map(|mut row| {
            row.end = None;
            row
        }))
    };
    let outcome = run_batch(points, threads, cancel, run, on_row)?;
    if outcome.cancelled {
        return Ok(None);
    }
    let mut rows = outcome.results;
    rows.sort_by_key(|r| r.index);
    Ok(Some(rows))
}

/// What a study row carries besides its map row: the point's operating point (to check a resumed
/// row against), and the keys written after the map row's fields: `sample` (index of the
/// parameter sample), `point` (index of the operating point) and `params` (the uncertain
/// parameters' values, a JSON object).
#[derive(Debug, Clone, PartialEq)]
pub struct RowInfo {
    /// f_ex [Hz].
    pub f_ex_hz: f64,
    /// a_ex [m/s²].
    pub a_ex_m_s2: f64,
    /// s₀.
    pub s0: f64,
    /// Index of the sample.
    pub sample: usize,
    /// Index of the operating point.
    pub point: usize,
    /// The uncertain parameters' values.
    pub params: serde_json::Value,
}

/// The results of a study: the file `study.jsonl` (the map results format, [`crate::map`], with the
/// study's configuration in the header and [`RowInfo`] keys in every row), or rows in memory only.
/// Every added row is appended at once and flushed; opening an existing file with `resume` keeps
/// its rows (a truncated last line from a kill is cut off first) after checking that the file was
/// written by the same study.
#[derive(Debug)]
pub struct StudyResults {
    file: Option<(File, PathBuf, ResultsLock)>,
    info: HashMap<usize, RowInfo>,
    rows: BTreeMap<usize, MapRow>,
}

impl StudyResults {
    /// Open the results of a study. `path`: the results file (None: rows in memory only);
    /// `cfg` the map configuration of the study's runs (its settings go to the header); `study`
    /// the study's configuration (header key `study`); `info` the study's points by index.
    /// An existing non-empty file is an error without `resume`, and with it when written by
    /// another configuration or holding a row that is not one of `info`.
    pub fn open(path: Option<&Path>, cfg: &MapConfig, study: serde_json::Value, info: HashMap<usize, RowInfo>, resume: bool) -> Result<StudyResults> {
        let mut out = StudyResults { file: None, info, rows: BTreeMap::new() };
        let Some(path) = path else {
            return Ok(out);
        };
        let header = results::header_line_with(&cfg.settings(), Some(&study));
        let exists = path.exists() && std::fs::metadata(path).map(|m| m.len() > 0).unwrap_or(false);
        if exists && !resume {
            return Err(Error::invalid("out", path.display(), "the results file exists: resume it, or choose another output"));
        }
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| results::io_err(dir, e))?;
        }
        // One writer per results file: a second one fails here, naming the holder's PID.
        let lock = ResultsLock::acquire(path)?;
        let mut old = if exists { results::read_results(path)? } else { results::ResultsFile::default() };
        if old.settings.is_some() && old.version != results::FORMAT_VERSION {
            return Err(Error::invalid(
                "resume",
                path.display(),
                &format!(
                    "the results file has format version {} (rows without the settled flag, no end states to reclassify); this version resumes only version {} studies: start a new study",
                    old.version,
                    results::FORMAT_VERSION
                ),
            ));
        }
        if old.settings.is_some() && (old.settings != Some(cfg.settings()) || old.study.as_ref() != Some(&study)) {
            return Err(Error::invalid("resume", path.display(), "the results file was written by another study configuration"));
        }
        if !exists {
            OpenOptions::new().create(true).truncate(true).write(true).open(path).map_err(|e| results::io_err(path, e))?;
        }
        // O_APPEND: each row lands at the end in one write.
        let mut f = results::open_append(path, old.good_len)?;
        if old.settings.is_none() {
            results::write_line(&mut f, path, &header)?;
        }
        for row in std::mem::take(&mut old.rows) {
            let ok = out
                .info
                .get(&row.index)
                .is_some_and(|i| (row.f_ex_hz, row.a_ex_m_s2, row.s0) == (i.f_ex_hz, i.a_ex_m_s2, i.s0) && row.extra.get("params") == Some(&i.params));
            if !ok {
                return Err(Error::invalid("resume", format!("{}, row {}", path.display(), row.index), "this row does not belong to this study"));
            }
            out.rows.insert(row.index, row);
        }
        out.file = Some((f, path.to_path_buf(), lock));
        Ok(out)
    }

    /// Add a finished row: attach its [`RowInfo`] keys, append it to the file. A row already
    /// present (a chunk re-run after a lost worker) is skipped; returns whether it was new.
    pub fn add(&mut self, mut row: MapRow) -> Result<bool> {
        if self.rows.contains_key(&row.index) {
            return Ok(false);
        }
        let info = self.info.get(&row.index).ok_or_else(|| Error::invalid("row index", row.index, "not a point of this study"))?;
        row.extra.insert("sample".into(), info.sample.into());
        row.extra.insert("point".into(), info.point.into());
        row.extra.insert("params".into(), info.params.clone());
        if let Some((f, path, _)) = &mut self.file {
            results::write_line(f, path, &row.to_json())?;
        }
        self.rows.insert(row.index, row);
        Ok(true)
    }

    /// Whether the point `index` has its row.
    pub fn contains(&self, index: usize) -> bool {
        self.rows.contains_key(&index)
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Whether there is no row yet.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// The rows, sorted by index.
    pub fn rows(&self) -> impl Iterator<Item = &MapRow> {
        self.rows.values()
    }

    /// Close the file (further rows are kept in memory only).
    pub fn close(&mut self) {
        self.file = None;
    }

    /// [`StudyResults::open`] with the study's configuration and its points as they come from a
    /// front end: JSON texts, `points_json` a list of objects with `index`, `f_ex_hz`,
    /// `a_ex_m_s2`, `s0`, `sample`, `point` and `params`.
    pub fn open_json(path: Option<&Path>, cfg: &MapConfig, study_json: &str, points_json: &str, resume: bool) -> Result<StudyResults> {
        let bad = |what: &str, e: serde_json::Error| Error::invalid(what, "JSON", &format!("not valid: {e}"));
        let study = serde_json::from_str(study_json).map_err(|e| bad("study", e))?;
        let points: Vec<WirePoint> = serde_json::from_str(points_json).map_err(|e| bad("points", e))?;
        let info = points
            .into_iter()
            .map(|w| (w.index, RowInfo { f_ex_hz: w.f_ex_hz, a_ex_m_s2: w.a_ex_m_s2, s0: w.s0, sample: w.sample, point: w.point, params: w.params }))
            .collect();
        StudyResults::open(path, cfg, study, info, resume)
    }

    /// [`StudyResults::open_json`] of values already parsed (a front end's tables): `study` the
    /// study's header, `points` the list of each point's [`RowInfo`] with its index.
    pub fn open_values(path: Option<&Path>, cfg: &MapConfig, study: serde_json::Value, points: serde_json::Value, resume: bool) -> Result<StudyResults> {
        let points: Vec<WirePoint> = serde_json::from_value(points).map_err(|e| Error::invalid("points", "table", &format!("not valid: {e}")))?;
        let info = points
            .into_iter()
            .map(|w| (w.index, RowInfo { f_ex_hz: w.f_ex_hz, a_ex_m_s2: w.a_ex_m_s2, s0: w.s0, sample: w.sample, point: w.point, params: w.params }))
            .collect();
        StudyResults::open(path, cfg, study, info, resume)
    }

    /// Add rows given as JSON texts of map rows ([`StudyResults::add`]).
    pub fn add_json(&mut self, rows: &[String]) -> Result<()> {
        for text in rows {
            let row: MapRow = serde_json::from_str(text).map_err(|e| Error::invalid("rows", "JSON", &format!("not a map row: {e}")))?;
            self.add(row)?;
        }
        Ok(())
    }
}

/// A point's [`RowInfo`] with its index, as JSON from a front end.
#[derive(serde::Deserialize)]
struct WirePoint {
    index: usize,
    f_ex_hz: f64,
    a_ex_m_s2: f64,
    s0: f64,
    sample: usize,
    point: usize,
    params: serde_json::Value,
}
