//! The JSON-lines results file of operating maps and studies (docs/model.md §8): header and
//! settings, reading with a torn last line, appending one flushed line per row.

use std::collections::HashSet;
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::row::MapRow;
use crate::classify::Criteria;
use crate::error::{Error, Result};

/// Version written in the results file's header (3: rows carry `settled`, `drift_s` and
/// `drift_a_h`, docs/model.md §8).
pub const FORMAT_VERSION: u32 = 3;
/// Versions this build reads. Version 1: rows classified by the rules before the phases, without
/// end states; read for display, never resumed or extended. Version 2: rows without the
/// `settled` flag and the drifts; read with `settled` derived from `steady`
/// ([`MapRow::derive_settled`]); a map resumed or extended is first upgraded to version 3, each
/// completed row reclassified from the signals of its end state (docs/model.md §8).
pub const READABLE_VERSIONS: [u32; 3] = [1, 2, 3];

/// What decides a row besides the grid point: written to the results header, compared on resume.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    /// Parameters as canonical TOML text (dt_s included).
    pub params_toml: String,
    /// Simulated duration per point [s].
    pub duration_s: f64,
    /// Recording interval in steps.
    pub record_every: usize,
    /// Classification thresholds.
    pub criteria: Criteria,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Header {
    beamslider_map: u32,
    settings: Settings,
    /// A study's configuration (study results files only, [`crate::study::StudyResults`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    study: Option<serde_json::Value>,
    /// The reduced predictor of a predicted map ([`crate::superslow::predicted_map::run_predicted_map`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    predictor: Option<serde_json::Value>,
}

/// Contents of an existing results file.
#[derive(Debug, Clone, Default)]
pub struct ResultsFile {
    /// Settings from the header (None for an empty file).
    pub settings: Option<Settings>,
    /// Complete rows in file order (an extended map has a later row for each continued point:
    /// see [`latest`]).
    pub rows: Vec<MapRow>,
    /// Byte length of the complete part (a truncated last line starts here).
    pub good_len: u64,
    /// Whether the file ended in an incomplete line.
    pub truncated: bool,
    /// Format version of the header (0 for an empty file).
    pub version: u32,
    /// The study configuration of the header (a study results file), as JSON.
    pub study: Option<serde_json::Value>,
    /// The predictor of the header (a predicted map, [`crate::superslow::predict`]), as JSON.
    pub predictor: Option<serde_json::Value>,
}

pub(crate) fn io_err(path: &Path, source: std::io::Error) -> Error {
    Error::Io { path: path.display().to_string(), source }
}

impl ResultsFile {
    /// The header line as read (version, settings and, for a study, its configuration) as JSON
    /// text; None for a file without a header.
    pub fn header_json(&self) -> Option<String> {
        let s = self.settings.as_ref()?;
        Some(
            serde_json::to_string(&Header { beamslider_map: self.version, settings: s.clone(), study: self.study.clone(), predictor: self.predictor.clone() })
                .expect("header serialises"),
        )
    }
}

/// Read a results file. Only lines ending in a newline count; an incomplete last line (a run
/// killed while writing) is reported as `truncated` and ignored; a complete line that is not a
/// row (or the header, on line 1) is an error naming the line.
pub fn read_results(path: &Path) -> Result<ResultsFile> {
    let f = File::open(path).map_err(|e| io_err(path, e))?;
    let mut r = BufReader::new(f);
    let mut out = ResultsFile::default();
    let mut line = String::new();
    let mut lineno = 0;
    let mut pending_bad: Option<usize> = None;
    loop {
        line.clear();
        let n = r.read_line(&mut line).map_err(|e| {
            if e.kind() == std::io::ErrorKind::InvalidData {
                Error::invalid("results file", format!("{}:{}", path.display(), lineno + 1), "this line is not UTF-8 text (not a result row)")
            } else {
                io_err(path, e)
            }
        })?;
        if n == 0 {
            break;
        }
        lineno += 1;
        if let Some(bad) = pending_bad {
            return Err(Error::invalid("results file", format!("{}:{bad}", path.display()), "a line in the middle of the file is not a complete result row"));
        }
        if !line.ends_with('\n') {
            out.truncated = true;
            break;
        }
        let text = line.trim_end();
        let ok = if lineno == 1 {
            // The version first: another version may have other settings.
            if let Some(v) = serde_json::from_str::<serde_json::Value>(text).ok().and_then(|v| v.get("beamslider_map").cloned())
                && !READABLE_VERSIONS.iter().any(|r| v == serde_json::json!(r))
            {
                return Err(Error::invalid("results file", path.display(), &format!("format version {v} (this build reads {FORMAT_VERSION})")));
            }
            match serde_json::from_str::<Header>(text) {
                Ok(h) => {
                    if !READABLE_VERSIONS.contains(&h.beamslider_map) {
                        return Err(Error::invalid(
                            "results file",
                            path.display(),
                            &format!("format version {} (this build reads {FORMAT_VERSION})", h.beamslider_map),
                        ));
                    }
                    out.version = h.beamslider_map;
                    out.settings = Some(h.settings);
                    out.study = h.study;
                    out.predictor = h.predictor;
                    true
                }
                Err(_) => false,
            }
        } else if text.is_empty() {
            true
        } else {
            match serde_json::from_str::<MapRow>(text) {
                Ok(row) => {
                    out.rows.push(row);
                    true
                }
                Err(_) => false,
            }
        };
        if ok {
            out.good_len += n as u64;
        } else {
            pending_bad = Some(lineno);
        }
    }
    if out.version < 3 {
        let cycles = out.settings.as_ref().map_or(crate::classify::Criteria::default().relax_min_cycles, |s| s.criteria.relax_min_cycles);
        for r in &mut out.rows {
            r.derive_settled(cycles);
        }
    }
    if let Some(bad) = pending_bad {
        // A kill while writing leaves a line without its newline (handled above); a complete
        // line that does not parse is damage, and cutting it off would lose data.
        return Err(Error::invalid("results file", format!("{}:{bad}", path.display()), "this line is not a result row (nor the header on line 1)"));
    }
    Ok(out)
}

/// The rows of a map's results file as they stand: a later row of the same point (an extended
/// run) replaces the earlier one.
pub fn latest(rows: Vec<MapRow>) -> Vec<MapRow> {
    let mut seen = HashSet::new();
    let mut rows: Vec<MapRow> = rows.into_iter().rev().filter(|r| seen.insert(r.key())).collect();
    rows.reverse();
    rows
}

/// Open a results file for appending (O_APPEND: every row lands at the end in one write), after
/// cutting it to `good_len` (a torn last line from a killed writer; we hold the lock).
pub(crate) fn open_append(path: &Path, good_len: u64) -> Result<File> {
    OpenOptions::new().write(true).open(path).and_then(|f| f.set_len(good_len)).map_err(|e| io_err(path, e))?;
    OpenOptions::new().append(true).open(path).map_err(|e| io_err(path, e))
}

/// The header line of a results file (without the newline); `study`: a study's configuration.
pub(crate) fn header_line_with(s: &Settings, study: Option<&serde_json::Value>) -> String {
    serde_json::to_string(&Header { beamslider_map: FORMAT_VERSION, settings: s.clone(), study: study.cloned(), predictor: None }).expect("header serialises")
}

pub(crate) fn header_line_predictor(s: &Settings, predictor: Option<&serde_json::Value>) -> String {
    serde_json::to_string(&Header { beamslider_map: FORMAT_VERSION, settings: s.clone(), study: None, predictor: predictor.cloned() })
        .expect("header serialises")
}

/// Append one line and flush it to the operating system.
pub(crate) fn write_line(f: &mut File, path: &Path, line: &str) -> Result<()> {
    let mut buf = String::with_capacity(line.len() + 1);
    buf.push_str(line);
    buf.push('\n');
    f.write_all(buf.as_bytes()).map_err(|e| io_err(path, e))?;
    f.flush().map_err(|e| io_err(path, e))
}
