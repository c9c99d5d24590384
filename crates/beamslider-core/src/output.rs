//! Trajectory files written while a run goes (docs/model.md §7, "outputs"): the recorded rows are
//! streamed to disk at constant memory, as CSV (shortest round-trip numbers) or as an uncompressed
//! NumPy `.npz` (one `<column>.npy` per channel, readable memory-mapped). Files are written under a
//! temporary name beside the target (`.<name>.partial-<pid>`) and renamed when complete, so a run
//! that is interrupted or fails leaves nothing under the final name. The expected size of an
//! in-memory recording ([`recorded_bytes`]) lets front ends refuse runs that would not fit.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::record::{CsvRecorder, Recorder};

/// Format of a trajectory file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Comma-separated values: a header line of column names, then one row per sample.
    Csv,
    /// NumPy `.npz` (stored, not compressed): `<column>.npy` per channel, float64 little-endian.
    Npz,
}

impl Format {
    /// The format of a file name by its extension (`.csv`, `.npz`).
    pub fn from_path(path: &Path) -> Result<Format> {
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("csv") => Ok(Format::Csv),
            Some("npz") => Ok(Format::Npz),
            _ => Err(Error::invalid("out", path.display(), "the file name must end in .npz or .csv")),
        }
    }
}

/// Number of rows a run records: the start state and every `record_every`-th of the
/// round(duration/dt) steps.
pub fn recorded_rows(duration_s: f64, dt_s: f64, record_every: usize) -> u64 {
    let steps = (duration_s / dt_s).round();
    let steps = if steps.is_finite() && steps > 0.0 { steps.min(u64::MAX as f64) as u64 } else { 0 };
    1 + steps / record_every.max(1) as u64
}

/// Bytes of the recorded arrays of a run (float64 per row and column).
pub fn recorded_bytes(duration_s: f64, dt_s: f64, record_every: usize, columns: usize) -> f64 {
    recorded_rows(duration_s, dt_s, record_every) as f64 * columns as f64 * 8.0
}

fn io_err(path: &Path, source: std::io::Error) -> Error {
    Error::Io { path: path.display().to_string(), source }
}

/// The temporary name of `path` while it is written: `.<name>.partial-<pid>` in the same folder.
pub fn partial_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.partial-{}", std::process::id()))
}

const BUF: usize = 1 << 20;

/// A recorder that streams rows into a trajectory file. Call [`FileRecorder::commit`] after a
/// run to move the finished file under its name; dropped without a commit (error, interrupt), it
/// removes its temporary files.
pub struct FileRecorder {
    path: PathBuf,
    tmp: PathBuf,
    kind: Kind,
    rows: u64,
    done: bool,
}

enum Kind {
    Csv(Option<CsvRecorder<BufWriter<File>>>),
    /// One raw little-endian float64 file per column until the commit assembles the zip.
    Npz { names: Vec<String>, columns: Vec<(PathBuf, BufWriter<File>)> },
}

impl FileRecorder {
    /// Start a trajectory file at `path` (format by extension). The folder must exist; an
    /// existing file under the final name is replaced only at the commit.
    pub fn create(path: &Path) -> Result<FileRecorder> {
        Self::create_as(path, Format::from_path(path)?)
    }

    /// As [`FileRecorder::create`] with the format given.
    pub fn create_as(path: &Path, format: Format) -> Result<FileRecorder> {
        let tmp = partial_path(path);
        let kind = match format {
            Format::Csv => {
                let f = File::create(&tmp).map_err(|e| io_err(&tmp, e))?;
                Kind::Csv(Some(CsvRecorder::new(BufWriter::with_capacity(BUF, f), &path.display().to_string())))
            }
            Format::Npz => Kind::Npz { names: Vec::new(), columns: Vec::new() },
        };
        Ok(FileRecorder { path: path.to_path_buf(), tmp, kind, rows: 0, done: false })
    }

    /// Rows written so far.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Finish the file and rename it to its final name. Returns the number of rows.
    pub fn commit(mut self) -> Result<u64> {
        match &mut self.kind {
            Kind::Csv(rec) => {
                let w = rec.take().expect("committed once").finish()?;
                let f = w.into_inner().map_err(|e| io_err(&self.tmp, e.into_error()))?;
                f.sync_data().map_err(|e| io_err(&self.tmp, e))?;
            }
            Kind::Npz { names, columns } => {
                for (p, w) in columns.iter_mut() {
                    w.flush().map_err(|e| io_err(p, e))?;
                }
                write_npz(&self.tmp, names, columns, self.rows)?;
            }
        }
        std::fs::rename(&self.tmp, &self.path).map_err(|e| io_err(&self.path, e))?;
        self.done = true;
        self.cleanup_columns();
        Ok(self.rows)
    }

    fn cleanup_columns(&mut self) {
        if let Kind::Npz { columns, .. } = &mut self.kind {
            for (p, _) in columns.drain(..) {
                let _ = std::fs::remove_file(p);
            }
        }
    }
}

impl Drop for FileRecorder {
    fn drop(&mut self) {
        self.cleanup_columns();
        if !self.done {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

impl Recorder for FileRecorder {
    fn begin(&mut self, names: &[String]) -> Result<()> {
        match &mut self.kind {
            Kind::Csv(rec) => rec.as_mut().expect("open").begin(names),
            Kind::Npz { names: n, columns } => {
                *n = names.to_vec();
                for k in 0..names.len() {
                    let p = PathBuf::from(format!("{}.{k}", self.tmp.display()));
                    let f = File::create(&p).map_err(|e| io_err(&p, e))?;
                    columns.push((p, BufWriter::with_capacity(BUF / 4, f)));
                }
                Ok(())
            }
        }
    }

    fn push(&mut self, row: &[f64]) -> Result<()> {
        self.rows += 1;
        match &mut self.kind {
            Kind::Csv(rec) => rec.as_mut().expect("open").push(row),
            Kind::Npz { columns, .. } => {
                for ((p, w), v) in columns.iter_mut().zip(row) {
                    w.write_all(&v.to_le_bytes()).map_err(|e| io_err(p, e))?;
                }
                Ok(())
            }
        }
    }
}

/// The `.npy` header (format 1.0) of a float64 vector of `n` values, padded to 64 bytes.
fn npy_header(n: u64) -> Vec<u8> {
    let dict = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': ({n},), }}");
    let mut len = 10 + dict.len() + 1;
    len = len.div_ceil(64) * 64;
    let pad = len - 10 - dict.len() - 1;
    let mut h = Vec::with_capacity(len);
    h.extend_from_slice(b"\x93NUMPY\x01\x00");
    h.extend_from_slice(&((len - 10) as u16).to_le_bytes());
    h.extend_from_slice(dict.as_bytes());
    h.extend(std::iter::repeat_n(b' ', pad));
    h.push(b'\n');
    h
}

/// Assemble the stored (uncompressed) zip of `.npy` members from the raw column files.
fn write_npz(tmp: &Path, names: &[String], columns: &mut [(PathBuf, BufWriter<File>)], rows: u64) -> Result<()> {
    use zip::write::SimpleFileOptions;
    let f = File::create(tmp).map_err(|e| io_err(tmp, e))?;
    let mut z = zip::ZipWriter::new(BufWriter::with_capacity(BUF, f));
    let large = rows.saturating_mul(8) >= u32::MAX as u64 - 4096;
    let opts = SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Stored)
        .large_file(large)
        .with_alignment(64);
    let zerr = |e: zip::result::ZipError| io_err(tmp, std::io::Error::other(e));
    for (name, (p, _)) in names.iter().zip(columns.iter()) {
        z.start_file(format!("{name}.npy"), opts).map_err(zerr)?;
        z.write_all(&npy_header(rows)).map_err(|e| io_err(tmp, e))?;
        let mut src = File::open(p).map_err(|e| io_err(p, e))?;
        std::io::copy(&mut src, &mut z).map_err(|e| io_err(tmp, e))?;
    }
    let w = z.finish().map_err(zerr)?;
    let f = w.into_inner().map_err(|e| io_err(tmp, e.into_error()))?;
    f.sync_data().map_err(|e| io_err(tmp, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_header_is_aligned_and_parsable() {
        for n in [0, 1, 12345, u64::MAX / 8] {
            let h = npy_header(n);
            assert_eq!(h.len() % 64, 0);
            assert_eq!(*h.last().unwrap(), b'\n');
            let text = std::str::from_utf8(&h[10..]).unwrap();
            assert!(text.contains(&format!("'shape': ({n},)")));
        }
    }

    #[test]
    fn rows_of_a_run() {
        assert_eq!(recorded_rows(1.0, 0.5, 1), 3);
        assert_eq!(recorded_rows(1.0, 0.25, 3), 2);
        assert_eq!(recorded_rows(0.0, 0.25, 3), 1);
    }

    #[test]
    fn dropped_recorder_leaves_nothing() {
        let dir = std::env::temp_dir().join(format!("bs-out-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for name in ["a.csv", "a.npz"] {
            let path = dir.join(name);
            let mut r = FileRecorder::create(&path).unwrap();
            r.begin(&["t_s".into(), "x".into()]).unwrap();
            r.push(&[0.0, 1.0]).unwrap();
            drop(r);
            assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "{name}");
        }
        let path = dir.join("b.csv");
        let mut r = FileRecorder::create(&path).unwrap();
        r.begin(&["t_s".into(), "x".into()]).unwrap();
        r.push(&[0.1, 1.0 / 3.0]).unwrap();
        assert_eq!(r.commit().unwrap(), 1);
        let text = std::fs::read_to_string(&path).unwrap();
        let v: f64 = text.lines().nth(1).unwrap().split(',').nth(1).unwrap().parse().unwrap();
        assert_eq!(v, 1.0 / 3.0, "round trip");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
