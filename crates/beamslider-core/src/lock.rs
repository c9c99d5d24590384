//! One writer per results file (map.jsonl, study.jsonl, …): an advisory lock on `<file>.lock`
//! beside it, taken with the standard library's `File::try_lock` (flock(2) on Unix, LockFileEx
//! on Windows; released by the operating system when the holder exits, even on a crash). The
//! holder writes its process id into the lock file so that a second writer can name it.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// An exclusive lock on a results file, held until dropped.
#[derive(Debug)]
pub struct ResultsLock {
    file: File,
    path: PathBuf,
    results: PathBuf,
}

/// The lock file of a results file: `<results>.lock`.
pub fn lock_path(results: &Path) -> PathBuf {
    let name = results.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    results.with_file_name(format!("{name}.lock"))
}

fn io_err(path: &Path, source: std::io::Error) -> Error {
    Error::Io { path: path.display().to_string(), source }
}

impl ResultsLock {
    /// Take the lock of `results` at once, or fail with [`Error::Busy`] naming the folder and the
    /// holder's process id. The folder must exist.
    pub fn acquire(results: &Path) -> Result<ResultsLock> {
        let path = lock_path(results);
        let mut file = OpenOptions::new().create(true).truncate(false).read(true).write(true).open(&path).map_err(|e| io_err(&path, e))?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                // The holder writes its pid just after it locks: give it a moment.
                let mut pid = String::new();
                for _ in 0..20 {
                    pid.clear();
                    let _ = file.seek(SeekFrom::Start(0));
                    let _ = file.read_to_string(&mut pid);
                    if !pid.trim().is_empty() {
                        break;
                    }
                    std::thread::sleep(std::time::Duration::from_millis(10));
                }
                let folder = results.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
                return Err(Error::Busy {
                    folder: folder.display().to_string(),
                    file: results.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
                    pid: pid.trim().parse().ok(),
                });
            }
            Err(TryLockError::Error(e)) => return Err(io_err(&path, e)),
        }
        file.set_len(0).map_err(|e| io_err(&path, e))?;
        file.seek(SeekFrom::Start(0)).map_err(|e| io_err(&path, e))?;
        file.write_all(format!("{}\n", std::process::id()).as_bytes()).map_err(|e| io_err(&path, e))?;
        file.flush().map_err(|e| io_err(&path, e))?;
        Ok(ResultsLock { file, path, results: results.to_path_buf() })
    }

    /// The results file this lock guards.
    pub fn results(&self) -> &Path {
        &self.results
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for ResultsLock {
    fn drop(&mut self) {
        // Leave the file (removing it would race with a writer that just opened it); the
        // stale pid is harmless: only the lock itself counts.
        let _ = self.file.set_len(0);
        let _ = self.file.unlock();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn second_writer_is_refused_with_the_pid() {
        let dir = std::env::temp_dir().join(format!("bs-lock-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let results = dir.join("map.jsonl");
        let a = ResultsLock::acquire(&results).unwrap();
        let e = ResultsLock::acquire(&results).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains(&std::process::id().to_string()), "{msg}");
        assert!(msg.contains(&dir.display().to_string()), "{msg}");
        drop(a);
        let _b = ResultsLock::acquire(&results).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
