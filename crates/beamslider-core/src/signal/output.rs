//! Trajectory files written while a run goes (docs/model.md §7, "outputs"): the recorded rows are
//! streamed to disk at constant memory, as CSV (shortest round-trip numbers) or as an uncompressed
//! NumPy `.npz` (one `<column>.npy` per channel, readable memory-mapped). Files are written under a
//! temporary name beside the target (`.<name>.partial-<pid>`) and renamed when complete, so a run
//! that is interrupted or fails leaves nothing under the final name. The expected size of an
//! in-memory recording ([`recorded_bytes`]) lets front ends refuse runs that would not fit.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::dynamics::record::{CsvRecorder, Recorder};
use crate::error::{Error, Result};

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
    (steps / record_every.max(1) as u64).saturating_add(1)
}

pub use crate::dynamics::simulation::{MAX_STEPS, step_count};

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
///
/// NPZ: the run's expected number of rows fixes the archive's layout before the first row (one
/// stored `<column>.npy` member per channel, laid out by the `zip` crate on a dry run), so every
/// value is written once, at its final place, by a writer thread (rows are gathered in chunks of
/// [`NPZ_CHUNK_BYTES`] and handed over a bounded channel: stepping and I/O overlap); the CRC-32 of
/// each member is computed as it is written, and a syncing thread flushes the file to disk every
/// [`NPZ_SYNC_BYTES`] so that little is left to flush at the commit. A run that ends early (fewer
/// rows than expected) is compacted into a new archive at the commit.
pub struct FileRecorder {
    path: PathBuf,
    tmp: PathBuf,
    kind: Kind,
    rows: u64,
    expected_rows: u64,
    done: bool,
}

enum Kind {
    Csv(Option<CsvRecorder<BufWriter<File>>>),
    Npz(Option<NpzStream>),
}

/// Bytes of row data gathered before they go to the writer thread (all columns together).
pub const NPZ_CHUNK_BYTES: usize = 1 << 20;
/// Chunks that may wait for the writer thread (bounded memory: at most this many + 2 chunks).
const NPZ_QUEUE: usize = 8;
/// Bytes written between two flushes to disk by the syncing thread.
pub const NPZ_SYNC_BYTES: u64 = 32 << 20;

impl FileRecorder {
    /// Start a trajectory file at `path` (format by extension) for a run of `expected_rows` rows
    /// ([`recorded_rows`]). The folder must exist; an existing file under the final name is
    /// replaced only at the commit.
    pub fn create(path: &Path, expected_rows: u64) -> Result<FileRecorder> {
        Self::create_as(path, Format::from_path(path)?, expected_rows)
    }

    /// As [`FileRecorder::create`] with the format given.
    pub fn create_as(path: &Path, format: Format, expected_rows: u64) -> Result<FileRecorder> {
        let tmp = partial_path(path);
        let kind = match format {
            Format::Csv => {
                let f = File::create(&tmp).map_err(|e| io_err(&tmp, e))?;
                Kind::Csv(Some(CsvRecorder::new(BufWriter::with_capacity(BUF, f), &path.display().to_string())))
            }
            Format::Npz => Kind::Npz(None),
        };
        Ok(FileRecorder { path: path.to_path_buf(), tmp, kind, rows: 0, expected_rows, done: false })
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
            Kind::Npz(stream) => {
                let stream = match stream.take() {
                    Some(s) => s,
                    None => NpzStream::start(&self.tmp, &[], self.expected_rows)?, // no begin(): no columns
                };
                stream.finish(&self.tmp, self.rows)?;
            }
        }
        std::fs::rename(&self.tmp, &self.path).map_err(|e| io_err(&self.path, e))?;
        self.done = true;
        Ok(self.rows)
    }
}

impl Drop for FileRecorder {
    fn drop(&mut self) {
        if let Kind::Npz(s) = &mut self.kind
            && let Some(s) = s.take()
        {
            let _ = s.stop();
        }
        if !self.done {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

impl Recorder for FileRecorder {
    fn begin(&mut self, names: &[String]) -> Result<()> {
        match &mut self.kind {
            Kind::Csv(rec) => rec.as_mut().expect("open").begin(names),
            Kind::Npz(s) => {
                *s = Some(NpzStream::start(&self.tmp, names, self.expected_rows)?);
                Ok(())
            }
        }
    }

    fn push(&mut self, row: &[f64]) -> Result<()> {
        self.rows += 1;
        match &mut self.kind {
            Kind::Csv(rec) => rec.as_mut().expect("open").push(row),
            Kind::Npz(s) => s.as_mut().expect("begin() before push()").push(row),
        }
    }
}

/// Options of the stored `.npy` members (zip64 when a member may exceed 4 GiB).
fn npz_options(rows: u64) -> zip::write::SimpleFileOptions {
    let large = rows.saturating_mul(8) >= u32::MAX as u64 - 4096;
    zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored).large_file(large).with_alignment(64)
}

fn zip_err(path: &Path) -> impl Fn(zip::result::ZipError) -> Error + '_ {
    move |e| io_err(path, std::io::Error::other(e))
}

/// Lay the members out with the `zip` crate: `start_file`, the `.npy` header, then (written
/// independently of the crate) the member's `rows` float64 values, whose CRC-32 is `crcs[k]`.
/// `fill(writer, k)` writes or skips the values of member k. Returns the offset of each member's
/// first value.
fn npz_members<W: Write + std::io::Seek>(
    out: W, names: &[String], rows: u64, crcs: &[u32], mut fill: impl FnMut(&mut W, usize) -> std::io::Result<()>, path: &Path,
) -> Result<(Vec<u64>, W)> {
    let zerr = zip_err(path);
    let mut z = zip::ZipWriter::new(out);
    let mut offsets = Vec::with_capacity(names.len());
    let header = npy_header(rows);
    for (k, name) in names.iter().enumerate() {
        z.start_file(format!("{name}.npy"), npz_options(rows)).map_err(&zerr)?;
        // SAFETY (an API contract of the zip crate, not memory safety): the member's bytes are
        // written to the underlying writer right after its local header, and their length and
        // CRC-32 are declared with `set_file_metadata` before the next member starts.
        let w = unsafe { z.get_mut() }.ok_or_else(|| zerr(zip::result::ZipError::Io(std::io::Error::other("closed"))))?;
        w.write_all(&header).map_err(|e| io_err(path, e))?;
        offsets.push(w.stream_position().map_err(|e| io_err(path, e))?);
        fill(w, k).map_err(|e| io_err(path, e))?;
        let len = header.len() as u64 + rows * 8;
        unsafe { z.set_file_metadata(len, crcs[k]) }.map_err(&zerr)?;
    }
    let w = z.finish().map_err(&zerr)?;
    Ok((offsets, w))
}

/// The CRC-32 of a `.npy` header followed by `rows` zero values (the dry run's placeholder).
fn header_crc(rows: u64) -> crc32fast::Hasher {
    let mut h = crc32fast::Hasher::new();
    h.update(&npy_header(rows));
    h
}

/// Counts the bytes a writer would write (the dry run of the layout).
#[derive(Default)]
struct Counter {
    pos: u64,
    len: u64,
}

impl Write for Counter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.pos += buf.len() as u64;
        self.len = self.len.max(self.pos);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl std::io::Seek for Counter {
    fn seek(&mut self, to: std::io::SeekFrom) -> std::io::Result<u64> {
        self.pos = match to {
            std::io::SeekFrom::Start(p) => p,
            std::io::SeekFrom::End(d) => self.len.checked_add_signed(d).ok_or_else(|| std::io::Error::other("seek"))?,
            std::io::SeekFrom::Current(d) => self.pos.checked_add_signed(d).ok_or_else(|| std::io::Error::other("seek"))?,
        };
        Ok(self.pos)
    }
}

/// One chunk of rows, column-major little-endian bytes: column k of the chunk is
/// `bytes[k * cap * 8 .. (k * cap + rows) * 8]`.
struct Chunk {
    first_row: u64,
    rows: usize,
    bytes: Vec<u8>,
}

/// What the writer thread hands back: the per-column CRC state, or the first I/O error.
type WriterResult = std::result::Result<Vec<crc32fast::Hasher>, std::io::Error>;

/// The NPZ being written: the rows of the current chunk, the writer and syncing threads.
struct NpzStream {
    tmp: PathBuf,
    names: Vec<String>,
    expected: u64,
    offsets: Vec<u64>,
    cap: usize,
    chunk: Chunk,
    tx: Option<std::sync::mpsc::SyncSender<Chunk>>,
    free: std::sync::mpsc::Receiver<Vec<u8>>,
    writer: Option<std::thread::JoinHandle<WriterResult>>,
}

impl NpzStream {
    fn start(tmp: &Path, names: &[String], expected: u64) -> Result<NpzStream> {
        use std::sync::mpsc;
        let (offsets, _) = npz_members(
            Counter::default(),
            names,
            expected,
            &vec![0; names.len()],
            |w, _| {
                use std::io::Seek;
                w.seek(std::io::SeekFrom::Current(expected as i64 * 8)).map(|_| ())
            },
            tmp,
        )?;
        let file = File::create(tmp).map_err(|e| io_err(tmp, e))?;
        let cols = names.len().max(1);
        let cap = (NPZ_CHUNK_BYTES / (8 * cols)).max(64);
        let (tx, rx) = mpsc::sync_channel::<Chunk>(NPZ_QUEUE);
        let (free_tx, free) = mpsc::channel::<Vec<u8>>();
        let syncer_file = file.try_clone().map_err(|e| io_err(tmp, e))?;
        let (offs, n_cols) = (offsets.clone(), names.len());
        let hashers = vec![header_crc(expected); n_cols];
        let writer = std::thread::Builder::new()
            .name("beamslider-npz-writer".into())
            .spawn(move || npz_writer(file, syncer_file, rx, free_tx, offs, cap, hashers))
            .map_err(|e| io_err(tmp, e))?;
        Ok(NpzStream {
            tmp: tmp.to_path_buf(),
            names: names.to_vec(),
            expected,
            offsets,
            cap,
            chunk: Chunk { first_row: 0, rows: 0, bytes: vec![0; cap * 8 * cols] },
            tx: Some(tx),
            free,
            writer: Some(writer),
        })
    }

    fn push(&mut self, row: &[f64]) -> Result<()> {
        let at = self.chunk.first_row + self.chunk.rows as u64;
        if at >= self.expected {
            return Err(Error::Numerical(format!("internal error: more than the {} rows planned for the trajectory file", self.expected)));
        }
        let r = self.chunk.rows;
        for (k, v) in row.iter().enumerate().take(self.names.len()) {
            let i = (k * self.cap + r) * 8;
            self.chunk.bytes[i..i + 8].copy_from_slice(&v.to_le_bytes());
        }
        self.chunk.rows += 1;
        if self.chunk.rows == self.cap {
            self.send()?;
        }
        Ok(())
    }

    /// Hand the current chunk to the writer thread and start a new one (a recycled buffer when
    /// one is back).
    fn send(&mut self) -> Result<()> {
        let next_row = self.chunk.first_row + self.chunk.rows as u64;
        let bytes = self.free.try_recv().unwrap_or_else(|_| vec![0; self.cap * 8 * self.names.len().max(1)]);
        let full = std::mem::replace(&mut self.chunk, Chunk { first_row: next_row, rows: 0, bytes });
        if full.rows == 0 {
            return Ok(());
        }
        let sent = self.tx.as_ref().map(|tx| tx.send(full).is_ok()).unwrap_or(false);
        if !sent {
            // The writer stopped on an error: report it.
            return Err(self.join().err().unwrap_or_else(|| Error::Numerical("internal error: the trajectory writer stopped".into())));
        }
        Ok(())
    }

    /// Stop the writer thread (after the chunks sent) and return its result.
    fn join(&mut self) -> Result<Vec<crc32fast::Hasher>> {
        self.tx = None;
        let Some(h) = self.writer.take() else {
            return Err(Error::Numerical("internal error: the trajectory writer was joined twice".into()));
        };
        match h.join() {
            Ok(Ok(crcs)) => Ok(crcs),
            Ok(Err(e)) => Err(io_err(&self.tmp, e)),
            Err(p) => Err(Error::Numerical(format!("internal error in the trajectory writer: {}", crate::error::panic_message(p.as_ref())))),
        }
    }

    /// Stop without finishing (the caller removes the file).
    fn stop(mut self) -> Result<()> {
        self.join().map(|_| ())
    }

    /// Write the last chunk, wait for the writer, then the zip headers and directory (or, for a
    /// run that ended early, a compacted copy); flush to disk.
    fn finish(mut self, tmp: &Path, rows: u64) -> Result<()> {
        self.send()?;
        let crcs = self.join()?;
        if rows != self.expected {
            return self.compact(tmp, rows);
        }
        let crcs: Vec<u32> = crcs.into_iter().map(|h| h.finalize()).collect();
        let f = std::fs::OpenOptions::new().write(true).open(tmp).map_err(|e| io_err(tmp, e))?;
        let (offsets, w) = npz_members(
            BufWriter::with_capacity(1 << 16, f),
            &self.names,
            rows,
            &crcs,
            |w, _| {
                use std::io::Seek;
                w.seek(std::io::SeekFrom::Current(rows as i64 * 8)).map(|_| ())
            },
            tmp,
        )?;
        if offsets != self.offsets {
            return Err(Error::Numerical("internal error: the NPZ layout changed between the plan and the commit".into()));
        }
        let f = w.into_inner().map_err(|e| io_err(tmp, e.into_error()))?;
        f.sync_data().map_err(|e| io_err(tmp, e))
    }

    /// A run that stopped early: copy the `rows` values of each column into a new archive, which
    /// then replaces the planned one.
    fn compact(&self, tmp: &Path, rows: u64) -> Result<()> {
        use std::io::{Read, Seek};
        let mut src = File::open(tmp).map_err(|e| io_err(tmp, e))?;
        let dst = PathBuf::from(format!("{}.compact", tmp.display()));
        let result = (|| {
            let f = File::create(&dst).map_err(|e| io_err(&dst, e))?;
            let mut z = zip::ZipWriter::new(BufWriter::with_capacity(BUF, f));
            let zerr = zip_err(&dst);
            for (name, &off) in self.names.iter().zip(&self.offsets) {
                z.start_file(format!("{name}.npy"), npz_options(rows)).map_err(&zerr)?;
                z.write_all(&npy_header(rows)).map_err(|e| io_err(&dst, e))?;
                src.seek(std::io::SeekFrom::Start(off)).map_err(|e| io_err(tmp, e))?;
                std::io::copy(&mut (&mut src).take(rows * 8), &mut z).map_err(|e| io_err(&dst, e))?;
            }
            let w = z.finish().map_err(&zerr)?;
            let f = w.into_inner().map_err(|e| io_err(&dst, e.into_error()))?;
            f.sync_data().map_err(|e| io_err(&dst, e))?;
            std::fs::rename(&dst, tmp).map_err(|e| io_err(tmp, e))
        })();
        if result.is_err() {
            let _ = std::fs::remove_file(&dst);
        }
        result
    }
}

/// The writer thread: each chunk's columns at their places (positioned writes), the CRC-32 of
/// every column, buffers handed back for reuse; every [`NPZ_SYNC_BYTES`] a syncing thread is
/// asked to flush the file to disk (it runs beside the writer, so neither waits for the disk).
fn npz_writer(
    mut file: File, sync_file: File, rx: std::sync::mpsc::Receiver<Chunk>, free: std::sync::mpsc::Sender<Vec<u8>>, offsets: Vec<u64>, cap: usize,
    mut crcs: Vec<crc32fast::Hasher>,
) -> WriterResult {
    use std::io::Seek;
    let (sync_tx, sync_rx) = std::sync::mpsc::channel::<()>();
    let syncer = std::thread::Builder::new().name("beamslider-npz-sync".into()).spawn(move || {
        while sync_rx.recv().is_ok() {
            while sync_rx.try_recv().is_ok() {}
            sync_file.sync_data()?;
        }
        Ok(())
    })?;
    let mut since_sync = 0u64;
    let mut result = Ok(());
    for chunk in rx.iter() {
        for (k, &off) in offsets.iter().enumerate() {
            let col = &chunk.bytes[k * cap * 8..(k * cap + chunk.rows) * 8];
            crcs[k].update(col);
            result = file.seek(std::io::SeekFrom::Start(off + chunk.first_row * 8)).and_then(|_| file.write_all(col));
            if result.is_err() {
                break;
            }
        }
        if result.is_err() {
            break;
        }
        since_sync += (chunk.rows * 8 * offsets.len()) as u64;
        if since_sync >= NPZ_SYNC_BYTES {
            since_sync = 0;
            let _ = sync_tx.send(());
        }
        let _ = free.send(chunk.bytes);
    }
    drop(sync_tx);
    let synced = syncer.join().unwrap_or_else(|_| Err(std::io::Error::other("the syncing thread panicked")));
    result?;
    synced?;
    Ok(crcs)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_counts_are_checked_and_bounded() {
        assert_eq!(step_count("duration_s", 120.0, 2e-5).unwrap(), 6_000_000);
        assert_eq!(step_count("duration_s", 0.0, 2e-5).unwrap(), 0);
        for (t, dt) in [(1e300, 2e-5), (1.0, 1e-300), (f64::INFINITY, 2e-5), (f64::NAN, 2e-5), (-1.0, 2e-5)] {
            let e = step_count("duration_s", t, dt).unwrap_err().to_string();
            assert!(e.contains("duration_s"), "{e}");
            assert!(e.len() < 300, "{e}");
        }
        assert!(step_count("duration_s", 1e300, 2e-5).unwrap_err().to_string().contains("1e11"));
        // The row count saturates instead of wrapping (a wrapped count read as zero rows).
        assert_eq!(recorded_rows(1e30, 1e-10, 1), u64::MAX);
    }

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
            let mut r = FileRecorder::create(&path, 1).unwrap();
            r.begin(&["t_s".into(), "x".into()]).unwrap();
            r.push(&[0.0, 1.0]).unwrap();
            drop(r);
            assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "{name}");
        }
        let path = dir.join("b.csv");
        let mut r = FileRecorder::create(&path, 1).unwrap();
        r.begin(&["t_s".into(), "x".into()]).unwrap();
        r.push(&[0.1, 1.0 / 3.0]).unwrap();
        assert_eq!(r.commit().unwrap(), 1);
        let text = std::fs::read_to_string(&path).unwrap();
        let v: f64 = text.lines().nth(1).unwrap().split(',').nth(1).unwrap().parse().unwrap();
        assert_eq!(v, 1.0 / 3.0, "round trip");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The members of an NPZ read back with the zip crate (which checks each CRC-32).
    fn read_npz(path: &Path) -> Vec<(String, Vec<f64>)> {
        use std::io::Read;
        let mut z = zip::ZipArchive::new(File::open(path).unwrap()).unwrap();
        (0..z.len())
            .map(|i| {
                let mut f = z.by_index(i).unwrap();
                let name = f.name().unwrap().to_string();
                let mut b = Vec::new();
                f.read_to_end(&mut b).unwrap(); // fails on a CRC mismatch
                assert_eq!(&b[..6], b"\x93NUMPY");
                let h = 10 + u16::from_le_bytes([b[8], b[9]]) as usize;
                (name, b[h..].chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap())).collect())
            })
            .collect()
    }

    #[test]
    fn npz_of_many_chunks_and_of_a_run_that_stopped_early() {
        let dir = std::env::temp_dir().join(format!("bs-npz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let names: Vec<String> = ["t_s", "w_4L7_m", "s"].iter().map(|s| s.to_string()).collect();
        let row = |i: u64| [i as f64 * 1e-3, (i as f64 * 0.1).sin(), 1.0 / (i as f64 + 3.0)];
        let planned = 250_003u64; // several chunks and a partial last one
        for written in [planned, 123_457] {
            let path = dir.join(format!("r{written}.npz"));
            let mut r = FileRecorder::create(&path, planned).unwrap();
            r.begin(&names).unwrap();
            for i in 0..written {
                r.push(&row(i)).unwrap();
            }
            assert_eq!(r.commit().unwrap(), written);
            let back = read_npz(&path);
            assert_eq!(back.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>(), ["t_s.npy", "w_4L7_m.npy", "s.npy"]);
            for (k, (_, v)) in back.iter().enumerate() {
                assert_eq!(v.len() as u64, written);
                assert!(v.iter().enumerate().all(|(i, x)| x.to_bits() == row(i as u64)[k].to_bits()), "column {k}");
            }
        }
        // More rows than planned is an error, not a corrupt file.
        let path = dir.join("over.npz");
        let mut r = FileRecorder::create(&path, 2).unwrap();
        r.begin(&names).unwrap();
        r.push(&row(0)).unwrap();
        r.push(&row(1)).unwrap();
        assert!(r.push(&row(2)).is_err());
        drop(r);
        assert!(!path.exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
