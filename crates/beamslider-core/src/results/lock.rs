//! One writer per results file (map.jsonl, study.jsonl, …): an advisory lock on `<file>.lock`
//! beside it, taken with the standard library's `File::try_lock` (flock(2) on Unix, LockFileEx
//! on Windows; released by the operating system when the holder exits, even on a crash). The
//! holder writes its process id into the lock file so that a second writer can name it.
//!
//! The lock file is removed when the holder releases the lock (on Unix). A writer that opened the
//! file just before it was removed would then lock a file no longer in the folder, so after
//! locking, a writer checks that the path still names the file it locked (same device and inode)
//! and starts again if not. A lock file left by a killed process (no unlink) is harmless: its
//! flock died with the process, and the next writer locks and reuses it.

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
        // A few rounds at most: each retry means a holder released (and removed) the file meanwhile.
        for _ in 0..100 {
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
            if !still_named(&file, &path) {
                continue; // removed by the previous holder between our open and our lock
            }
            file.set_len(0).map_err(|e| io_err(&path, e))?;
            file.seek(SeekFrom::Start(0)).map_err(|e| io_err(&path, e))?;
            file.write_all(format!("{}\n", std::process::id()).as_bytes()).map_err(|e| io_err(&path, e))?;
            file.flush().map_err(|e| io_err(&path, e))?;
            return Ok(ResultsLock { file, path, results: results.to_path_buf() });
        }
        Err(io_err(&path, std::io::Error::other("the lock file kept being replaced by other writers")))
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
        // Removed while still locked: a writer that opened it meanwhile finds, once it holds the
        // lock, that the path no longer names its file and starts again (see `acquire`).
        #[cfg(unix)]
        let _ = std::fs::remove_file(&self.path);
        #[cfg(not(unix))]
        let _ = self.file.set_len(0);
        let _ = self.file.unlock();
    }
}

/// Whether `path` still names the open `file` (same device and inode on Unix).
#[cfg(unix)]
fn still_named(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), std::fs::metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn still_named(_file: &File, _path: &Path) -> bool {
    true // the lock file is never removed there
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
        #[cfg(unix)]
        assert!(!lock_path(&results).exists(), "lock file removed on release");
        let b = ResultsLock::acquire(&results).unwrap();
        drop(b);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_stale_lock_file_does_not_block() {
        let dir = std::env::temp_dir().join(format!("bs-lock-stale-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let results = dir.join("map.jsonl");
        std::fs::write(lock_path(&results), "999999\n").unwrap(); // left by a killed holder
        let a = ResultsLock::acquire(&results).unwrap();
        assert_eq!(std::fs::read_to_string(a.path()).unwrap().trim(), std::process::id().to_string());
        drop(a);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn one_writer_while_others_release_and_retake() {
        // Threads hammer acquire/release: never two holders at once (the counter stays at 0 or 1).
        use std::sync::Arc;
        use std::sync::atomic::{AtomicUsize, Ordering};
        let dir = std::env::temp_dir().join(format!("bs-lock-race-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let results = Arc::new(dir.join("map.jsonl"));
        let holders = Arc::new(AtomicUsize::new(0));
        let taken = Arc::new(AtomicUsize::new(0));
        let threads: Vec<_> = (0..4)
            .map(|_| {
                let (results, holders, taken) = (results.clone(), holders.clone(), taken.clone());
                std::thread::spawn(move || {
                    for _ in 0..300 {
                        if let Ok(l) = ResultsLock::acquire(&results) {
                            assert_eq!(holders.fetch_add(1, Ordering::SeqCst), 0, "two holders at once");
                            taken.fetch_add(1, Ordering::SeqCst);
                            std::thread::yield_now();
                            holders.fetch_sub(1, Ordering::SeqCst);
                            drop(l);
                        }
                    }
                })
            })
            .collect();
        for t in threads {
            t.join().unwrap();
        }
        assert!(taken.load(Ordering::SeqCst) > 0);
        assert!(!lock_path(&results).exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
