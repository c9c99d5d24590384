//! A map driven by a front end (docs/model.md §8): the results opened once ([`MapResults`]:
//! locked, checked, jobs planned), then the jobs run here ([`MapSession::run_local`]) or
//! elsewhere in chunks ([`run_chunk`], e.g. on a Dask worker) whose rows come back as JSON text
//! ([`MapSession::append_json`]). Jobs and rows cross process boundaries as [`WireJob`]s and
//! row JSON; every method takes `&self`, so a front end can read the progress while a run goes on.

use std::collections::HashMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use super::config::MapConfig;
use super::run::{Job, MapOutcome, MapResults, MapRunOptions, Progress, run_jobs};
use crate::error::{Error, Result};
use crate::results::{MapPoint, MapRow};

/// A job as it crosses to another process: (grid index, None) for a run from rest, (grid index,
/// row JSON with its end state) for a continuation.
pub type WireJob = (usize, Option<String>);

fn parse_row(text: &str) -> Result<MapRow> {
    serde_json::from_str(text).map_err(|e| Error::invalid("rows", "JSON", &format!("not a map row: {e}")))
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// The results of a map being computed, with the jobs still to run.
#[derive(Debug)]
pub struct MapSession {
    cfg: MapConfig,
    results: Mutex<Option<MapResults>>,
    jobs: Mutex<Vec<Job>>,
    done: AtomicUsize,
    /// Points in the grid.
    pub total: usize,
    /// Not-settled points continued from their end states.
    pub extended: usize,
}

impl MapSession {
    /// Open the results of `cfg` ([`MapResults::open`]: checks, lock, torn line, header, jobs).
    pub fn open(cfg: MapConfig, opts: &MapRunOptions) -> Result<MapSession> {
        let mut r = MapResults::open(&cfg, opts)?;
        let jobs = std::mem::take(&mut r.jobs);
        let (total, extended, done) = (r.total, r.extended, r.rows.len());
        Ok(MapSession { cfg, results: Mutex::new(Some(r)), jobs: Mutex::new(jobs), done: AtomicUsize::new(done), total, extended })
    }

    /// Rows so far (kept and appended).
    pub fn done(&self) -> usize {
        self.done.load(Ordering::Relaxed)
    }

    /// The jobs still to run, as they cross to other processes.
    pub fn wire_jobs(&self) -> Vec<WireJob> {
        lock(&self.jobs)
            .iter()
            .map(|j| match j {
                Job::Fresh(p) => (p.index, None),
                Job::Continue(p, row) => (p.index, Some(row.to_json())),
            })
            .collect()
    }

    fn append(&self, row: MapRow, progress: Option<Progress<'_>>) -> Result<bool> {
        let mut g = lock(&self.results);
        let r = g.as_mut().ok_or_else(|| Error::invalid("results", "closed", "the map's results are closed"))?;
        if r.rows.iter().any(|x| x.index == row.index) {
            return Ok(false);
        }
        r.append(row)?;
        self.done.store(r.rows.len(), Ordering::Relaxed);
        if let (Some(progress), Some(last)) = (progress, r.rows.last()) {
            progress(r.rows.len(), self.total, last);
        }
        Ok(true)
    }

    /// Append rows computed elsewhere (JSON texts of [`run_chunk`]); rows of points already in the
    /// results are skipped (a chunk re-run after a lost worker). Returns the number appended.
    pub fn append_json(&self, rows: &[String]) -> Result<usize> {
        let mut n = 0;
        for text in rows {
            n += usize::from(self.append(parse_row(text)?, None)?);
        }
        Ok(n)
    }

    /// Run the remaining jobs here on `threads` threads (None: one per core), appending each
    /// row at once and then calling `progress(rows so far, points in the grid, row)`. A set
    /// `cancel` stops the map; finished rows stay.
    pub fn run_local(&self, threads: Option<usize>, cancel: &AtomicBool, progress: Option<Progress<'_>>) -> Result<()> {
        let jobs = std::mem::take(&mut *lock(&self.jobs));
        run_jobs(&self.cfg, &jobs, threads, cancel, |row| self.append(row, progress).map(|_| ()))
    }

    /// Close the results (release the lock): all rows sorted by index, with the counts.
    pub fn outcome(&self) -> Result<MapOutcome> {
        let r = lock(&self.results).take().ok_or_else(|| Error::invalid("results", "closed", "the map's results are closed"))?;
        Ok(r.finish())
    }

    /// [`MapSession::outcome`] as (rows, continued points); [`Error::Interrupted`] when points
    /// are missing.
    pub fn finish(&self) -> Result<(Vec<MapRow>, usize)> {
        let outcome = self.outcome()?;
        if outcome.cancelled {
            return Err(Error::Interrupted { t_s: 0.0 });
        }
        Ok((outcome.rows, outcome.extended))
    }

    /// Release the lock without collecting the rows.
    pub fn close(&self) {
        lock(&self.results).take();
    }
}

/// Run the grid of `cfg` in parallel, appending each finished point to the results file (a
/// [`MapSession`] run here). Setting `cancel` stops the map: points in flight are abandoned,
/// finished ones are kept.
pub fn run_map(cfg: &MapConfig, opts: &MapRunOptions, cancel: &AtomicBool, progress: Progress<'_>) -> Result<MapOutcome> {
    let session = MapSession::open(cfg.clone(), opts)?;
    session.run_local(opts.threads, cancel, Some(progress))?;
    session.outcome()
}

/// Run `jobs` (see [`MapSession::wire_jobs`]) of the map `cfg` on `threads` threads: the rows as
/// JSON texts sorted by grid index, each bitwise the row the local runner writes (but
/// `wall_time_s`).
pub fn run_chunk(cfg: &MapConfig, jobs: &[WireJob], threads: usize, cancel: &AtomicBool) -> Result<Vec<String>> {
    crate::dynamics::runner::check_threads(Some(threads))?;
    let points: HashMap<usize, MapPoint> = cfg.points()?.into_iter().map(|p| (p.index, p)).collect();
    let jobs: Vec<Job> = jobs
        .iter()
        .map(|(i, row)| {
            let p = *points.get(i).ok_or_else(|| Error::invalid("jobs", i, "not a grid index of this map"))?;
            Ok(match row {
                None => Job::Fresh(p),
                Some(text) => Job::Continue(p, Box::new(parse_row(text)?)),
            })
        })
        .collect::<Result<_>>()?;
    let mut rows: Vec<MapRow> = Vec::with_capacity(jobs.len());
    run_jobs(cfg, &jobs, Some(threads), cancel, |row| {
        rows.push(row);
        Ok(())
    })?;
    rows.sort_by_key(|r| r.index);
    Ok(rows.iter().map(MapRow::to_json).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tiny() -> MapConfig {
        let mut cfg = MapConfig { duration_s: 0.05, ..MapConfig::default() };
        cfg.grid.f_ex_hz = crate::map::Axis::List(vec![120.0, 124.0]);
        cfg.grid.a_ex_m_s2 = crate::map::Axis::List(vec![14.0]);
        cfg
    }

    #[test]
    fn rows_of_a_chunk_run_elsewhere_equal_the_local_rows_and_are_appended_once() {
        let cfg = tiny();
        let cancel = AtomicBool::new(false);
        let local = MapSession::open(cfg.clone(), &MapRunOptions::default()).unwrap();
        assert_eq!((local.total, local.done()), (2, 0));
        let wire = local.wire_jobs();
        local.run_local(Some(1), &cancel, None).unwrap();
        assert_eq!(local.done(), 2);
        let (rows, _) = local.finish().unwrap();
        let remote = MapSession::open(cfg.clone(), &MapRunOptions::default()).unwrap();
        let chunk = run_chunk(&cfg, &wire, 1, &cancel).unwrap();
        assert_eq!(remote.append_json(&chunk).unwrap(), 2);
        assert_eq!(remote.append_json(&chunk).unwrap(), 0);
        let (again, _) = remote.finish().unwrap();
        let strip = |r: &MapRow| MapRow { wall_time_s: 0.0, ..r.clone() }.to_json();
        assert_eq!(rows.iter().map(strip).collect::<Vec<_>>(), again.iter().map(strip).collect::<Vec<_>>());
        assert!(remote.finish().is_err());
    }

    #[test]
    fn missing_points_are_an_interruption_and_bad_jobs_are_refused() {
        let cfg = tiny();
        let s = MapSession::open(cfg.clone(), &MapRunOptions::default()).unwrap();
        assert!(matches!(s.finish(), Err(Error::Interrupted { .. })));
        let cancel = AtomicBool::new(false);
        assert!(run_chunk(&cfg, &[(7, None)], 1, &cancel).is_err());
        assert!(run_chunk(&cfg, &[(0, None)], 0, &cancel).is_err());
    }
}
