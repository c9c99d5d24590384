//! Streaming output of a run: the channels a caller asks for, every k-th step, into memory or
//! straight into a CSV writer (bounded memory either way).

use std::io::Write;

use crate::error::{Error, Result};

/// A quantity that can be recorded.
#[derive(Debug, Clone, PartialEq)]
pub enum Channel {
    /// Time t [s] (`t_s`).
    Time,
    /// Elastic beam displacement at the laser position x = 4L/7 [m] (`w_4L7_m`).
    W4L7,
    /// Elastic beam displacement at x [m] (`w_at_<x>m`).
    WAt(f64),
    /// Relative slider position s = x_C/L (the prescribed s for the PCS) (`s`).
    S,
    /// x_C [m] (`xC_m`).
    XC,
    /// z_C [m] (`zC_m`).
    ZC,
    /// β [rad] (`beta_rad`).
    Beta,
    /// Modal coordinates q₁..q_N (`q1`..).
    ModalQ,
    /// Modal velocities (`u1`..).
    ModalU,
    /// Slider velocities (`uxC`, `uzC`, `ubeta`).
    SliderU,
    /// Percussions of the last step (`PN1`, `PT1`, …, `PN4`, `PT4`) [N s].
    Percussions,
}

impl Channel {
    /// Parse a channel name as used on the command line: t, w, w@X (X in metres), s, xc, zc,
    /// beta, q, u, uslider, p.
    pub fn parse(name: &str) -> Result<Channel> {
        let n = name.trim();
        Ok(match n {
            "t" => Channel::Time,
            "w" | "w4l7" => Channel::W4L7,
            "s" => Channel::S,
            "xc" => Channel::XC,
            "zc" => Channel::ZC,
            "beta" => Channel::Beta,
            "q" => Channel::ModalQ,
            "u" => Channel::ModalU,
            "uslider" => Channel::SliderU,
            "p" => Channel::Percussions,
            _ => match n.strip_prefix("w@").map(str::parse::<f64>) {
                Some(Ok(x)) if x.is_finite() => Channel::WAt(x),
                _ => {
                    return Err(Error::invalid("channel", n, "one of t, w, w@X (X in m), s, xc, zc, beta, q, u, uslider, p"));
                }
            },
        })
    }

    /// Column names this channel produces for N modes.
    pub fn names(&self, n_modes: usize) -> Vec<String> {
        match self {
            Channel::Time => vec!["t_s".into()],
            Channel::W4L7 => vec!["w_4L7_m".into()],
            Channel::WAt(x) => vec![format!("w_at_{x}m")],
            Channel::S => vec!["s".into()],
            Channel::XC => vec!["xC_m".into()],
            Channel::ZC => vec!["zC_m".into()],
            Channel::Beta => vec!["beta_rad".into()],
            Channel::ModalQ => (1..=n_modes).map(|i| format!("q{i}")).collect(),
            Channel::ModalU => (1..=n_modes).map(|i| format!("u{i}")).collect(),
            Channel::SliderU => vec!["uxC".into(), "uzC".into(), "ubeta".into()],
            Channel::Percussions => (1..=4).flat_map(|i| [format!("PN{i}"), format!("PT{i}")]).collect(),
        }
    }

    /// The default channels: t, w(4L/7), s, z_C, β.
    pub fn defaults() -> Vec<Channel> {
        vec![Channel::Time, Channel::W4L7, Channel::S, Channel::ZC, Channel::Beta]
    }
}

/// Receives the recorded rows of a run.
pub trait Recorder {
    /// Called once before the first row with the column names.
    fn begin(&mut self, names: &[String]) -> Result<()>;
    /// One row (same length as the names).
    fn push(&mut self, row: &[f64]) -> Result<()>;
}

/// Keeps the rows in memory (row-major).
#[derive(Debug, Clone, Default)]
pub struct MemoryRecorder {
    /// Column names.
    pub names: Vec<String>,
    /// Row-major values.
    pub data: Vec<f64>,
}

impl MemoryRecorder {
    /// Empty recorder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        if self.names.is_empty() { 0 } else { self.data.len() / self.names.len() }
    }

    /// One column by name.
    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        let c = self.names.iter().position(|n| n == name)?;
        let w = self.names.len();
        Some(self.data.iter().skip(c).step_by(w).copied().collect())
    }
}

impl Recorder for MemoryRecorder {
    fn begin(&mut self, names: &[String]) -> Result<()> {
        self.names = names.to_vec();
        self.data.clear();
        Ok(())
    }
    fn push(&mut self, row: &[f64]) -> Result<()> {
        self.data.extend_from_slice(row);
        Ok(())
    }
}

/// Keeps the rows in memory column by column, each column allocated once for the expected number
/// of rows (no doubling on growth, and the columns can be handed out without a copy). An
/// allocation that fails is an error, not an abort.
#[derive(Debug, Clone, Default)]
pub struct ColumnRecorder {
    /// Column names.
    pub names: Vec<String>,
    /// One vector per column.
    pub columns: Vec<Vec<f64>>,
    expected_rows: usize,
}

impl ColumnRecorder {
    /// Empty recorder that reserves `expected_rows` per column when the run begins.
    pub fn with_rows(expected_rows: usize) -> Self {
        ColumnRecorder { names: Vec::new(), columns: Vec::new(), expected_rows }
    }

    /// [`ColumnRecorder::with_rows`] whose columns reuse the vectors `spare` (their memory; their
    /// contents are cleared when the run begins).
    pub fn reusing(expected_rows: usize, spare: Vec<Vec<f64>>) -> Self {
        ColumnRecorder { names: Vec::new(), columns: spare, expected_rows }
    }

    /// One column by name.
    pub fn column(&self, name: &str) -> Option<&Vec<f64>> {
        let c = self.names.iter().position(|n| n == name)?;
        self.columns.get(c)
    }
}

impl Recorder for ColumnRecorder {
    fn begin(&mut self, names: &[String]) -> Result<()> {
        self.names = names.to_vec();
        let mut spare = std::mem::take(&mut self.columns);
        self.columns = Vec::with_capacity(names.len());
        for _ in names {
            let mut v: Vec<f64> = spare.pop().unwrap_or_default();
            v.clear();
            v.try_reserve_exact(self.expected_rows).map_err(|_| {
                Error::invalid(
                    "t_end",
                    format!("{} rows", self.expected_rows),
                    &format!(
                        "the recorded arrays ({:.3} GB) do not fit in memory: raise record_every, shorten t_end, or stream to a file (out=)",
                        self.expected_rows as f64 * names.len() as f64 * 8e-9
                    ),
                )
            })?;
            self.columns.push(v);
        }
        Ok(())
    }
    fn push(&mut self, row: &[f64]) -> Result<()> {
        for (c, v) in self.columns.iter_mut().zip(row) {
            c.push(*v);
        }
        Ok(())
    }
}

/// Writes rows as CSV (header line, then shortest round-trip numbers).
pub struct CsvRecorder<W: Write> {
    out: W,
    path: String,
    line: String,
}

impl<W: Write> CsvRecorder<W> {
    /// CSV into `out`; `path` names it in error messages.
    pub fn new(out: W, path: &str) -> Self {
        CsvRecorder { out, path: path.to_string(), line: String::new() }
    }

    /// Flush and return the writer.
    pub fn finish(mut self) -> Result<W> {
        self.out.flush().map_err(|e| self.io(e))?;
        Ok(self.out)
    }

    fn io(&self, source: std::io::Error) -> Error {
        Error::Io { path: self.path.clone(), source }
    }
}

impl<W: Write> Recorder for CsvRecorder<W> {
    fn begin(&mut self, names: &[String]) -> Result<()> {
        writeln!(self.out, "{}", names.join(",")).map_err(|e| self.io(e))
    }
    fn push(&mut self, row: &[f64]) -> Result<()> {
        use std::fmt::Write as _;
        self.line.clear();
        for (i, v) in row.iter().enumerate() {
            if i > 0 {
                self.line.push(',');
            }
            let _ = write!(self.line, "{v:e}");
        }
        self.line.push('\n');
        self.out.write_all(self.line.as_bytes()).map_err(|e| Error::Io { path: self.path.clone(), source: e })
    }
}

/// Hands every row to two recorders (e.g. a file and an [`crate::signal::overview::OverviewRecorder`]).
pub struct Tee<'a>(pub &'a mut dyn Recorder, pub &'a mut dyn Recorder);

impl Recorder for Tee<'_> {
    fn begin(&mut self, names: &[String]) -> Result<()> {
        self.0.begin(names)?;
        self.1.begin(names)
    }
    fn push(&mut self, row: &[f64]) -> Result<()> {
        self.0.push(row)?;
        self.1.push(row)
    }
}

/// Discards everything.
#[derive(Debug, Default, Clone, Copy)]
pub struct NullRecorder;

impl Recorder for NullRecorder {
    fn begin(&mut self, _: &[String]) -> Result<()> {
        Ok(())
    }
    fn push(&mut self, _: &[f64]) -> Result<()> {
        Ok(())
    }
}
