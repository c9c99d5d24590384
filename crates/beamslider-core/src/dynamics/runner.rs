//! The one runner for batches of independent runs (operating maps, uncertainty studies, and any
//! later batch such as design runs or predictor validations; MODEL.md §8).
//!
//! A batch is a list of jobs, each computed independently from its own inputs, so its results do
//! not depend on the number of threads or on the order in which jobs finish (bitwise). The runner
//! owns what every batch needs and nothing of the physics:
//! - **parallelism**: rayon, one job at a time per worker (`with_max_len(1)`), on a pool of
//!   `threads` workers (default: rayon's global pool, one per core);
//! - **cancellation**: a shared flag; jobs not yet started are skipped, a job in flight sees the
//!   flag through its own run (e.g. [`crate::CancelFlag`]) and returns `Ok(None)`;
//! - **results**: each finished result is handed to `on_done` (append to a results file, count
//!   progress) under one lock, in completion order, then kept; the caller sorts;
//! - **errors**: an error or a panic of a job (panic → [`Error::Numerical`], never across the
//!   caller's boundary) or of `on_done` stops the batch: the flag is set and the first error is
//!   returned. A batch that wants a failed job to be a result row (maps) converts the error in
//!   its job function instead.
//!
//! [`watched`] runs a whole batch on a worker thread while the calling thread polls (Ctrl-C,
//! progress bars): the one watcher loop of every front end. A single run watched that way reports
//! to a [`SharedMonitor`], which the watcher reads.

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::time::Duration;

use rayon::prelude::*;

use crate::dynamics::simulation::Monitor;
use crate::error::{Error, Result};

/// A run's monitor read by a watcher on another thread ([`watched`]): the latest progress and the
/// cancellation flag; with a start gate, [`Monitor::start`] waits until the watcher opens it
/// ([`SharedMonitor::open`], e.g. after a front end's hook) or cancels the run.
pub struct SharedMonitor<'a> {
    cancel: &'a AtomicBool,
    progress: Mutex<Option<(f64, f64)>>,
    /// 0: no gate or open, 1: gated, 2: the run waits at the gate.
    gate: AtomicU8,
}

impl<'a> SharedMonitor<'a> {
    /// A monitor of the flag `cancel`, its start gated (`gated`) or not.
    pub fn new(cancel: &'a AtomicBool, gated: bool) -> Self {
        SharedMonitor { cancel, progress: Mutex::new(None), gate: AtomicU8::new(u8::from(gated)) }
    }

    /// Record progress (done, total) of work that reports counts, not through a run's [`Monitor`].
    pub fn report(&self, done: f64, total: f64) {
        *self.progress.lock().unwrap_or_else(|e| e.into_inner()) = Some((done, total));
    }

    /// The cancellation flag the watcher sets.
    pub fn cancel(&self) -> &AtomicBool {
        self.cancel
    }

    /// The progress (done, total) reported since the last call, if any.
    pub fn take_progress(&self) -> Option<(f64, f64)> {
        self.progress.lock().unwrap_or_else(|e| e.into_inner()).take()
    }

    /// Whether the run waits at its start gate (its inputs checked, nothing written yet).
    pub fn waiting(&self) -> bool {
        self.gate.load(Ordering::Acquire) == 2
    }

    /// Let the run start.
    pub fn open(&self) {
        self.gate.store(0, Ordering::Release);
    }
}

impl Monitor for &SharedMonitor<'_> {
    fn poll(&mut self, t_s: f64, t_end_s: f64) -> bool {
        self.report(t_s, t_end_s);
        !self.cancel.load(Ordering::Relaxed)
    }

    fn start(&mut self) -> bool {
        if self.gate.compare_exchange(1, 2, Ordering::AcqRel, Ordering::Acquire).is_ok() {
            while self.gate.load(Ordering::Acquire) != 0 && !self.cancel.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(1));
            }
        }
        !self.cancel.load(Ordering::Relaxed)
    }
}

/// Outcome of [`run_batch`].
#[derive(Debug, Clone)]
pub struct BatchOutcome<R> {
    /// The results of the finished jobs, in completion order.
    pub results: Vec<R>,
    /// Whether the batch was cancelled before all jobs had a result.
    pub cancelled: bool,
}

pub use crate::error::panic_message;

/// Run `f`; a panic becomes `Err(its message)`.
pub fn catch_panic<T>(f: impl FnOnce() -> T) -> std::result::Result<T, String> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|p| panic_message(p.as_ref()))
}

/// The error of a panic in a job: "internal error: <message>".
fn internal(what: String) -> Error {
    Error::Numerical(format!("internal error: {what}"))
}

/// `threads` as a front end gives it: None (one per core) or at least 1.
pub fn check_threads(threads: Option<usize>) -> Result<()> {
    match threads {
        Some(0) => Err(Error::invalid("threads", 0, "must be >= 1")),
        _ => Ok(()),
    }
}

/// Run `work` on `threads` rayon workers (None: the global pool, one per core).
pub fn with_threads<T: Send>(threads: Option<usize>, work: impl FnOnce() -> T + Send) -> Result<T> {
    match threads {
        Some(n) => Ok(rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()
            .map_err(|e| Error::Numerical(format!("cannot start {n} threads: {e}")))?
            .install(work)),
        None => Ok(work()),
    }
}

/// Run every job of `jobs` in parallel (module header). `run(job)` computes one job: `Ok(None)`
/// when it saw the cancellation flag. `on_done(&result)` is called under one lock for every
/// finished result before it is kept (an error stops the batch).
pub fn run_batch<J, R>(
    jobs: &[J], threads: Option<usize>, cancel: &AtomicBool, run: impl Fn(&J) -> Result<Option<R>> + Sync, on_done: impl FnMut(&R) -> Result<()> + Send,
) -> Result<BatchOutcome<R>>
where
    J: Sync,
    R: Send,
{
    struct Sink<R, F> {
        results: Vec<R>,
        on_done: F,
        error: Option<Error>,
    }
    let sink = Mutex::new(Sink { results: Vec::with_capacity(jobs.len()), on_done, error: None });
    let fail = |g: &mut Sink<R, _>, e: Error| {
        g.error.get_or_insert(e);
        cancel.store(true, Ordering::Relaxed);
    };
    with_threads(threads, || {
        jobs.par_iter().with_max_len(1).for_each(|job| {
            if cancel.load(Ordering::Relaxed) {
                return;
            }
            let r = catch_panic(|| run(job)).unwrap_or_else(|what| Err(internal(what)));
            let mut g = sink.lock().unwrap_or_else(|e| e.into_inner());
            match r {
                Ok(Some(res)) => match (g.on_done)(&res) {
                    Ok(()) => g.results.push(res),
                    Err(e) => fail(&mut g, e),
                },
                Ok(None) => {}
                Err(e) => fail(&mut g, e),
            }
        })
    })?;
    let sink = sink.into_inner().unwrap_or_else(|e| e.into_inner());
    if let Some(e) = sink.error {
        return Err(e);
    }
    Ok(BatchOutcome { cancelled: sink.results.len() < jobs.len(), results: sink.results })
}

/// Run `work` on a scoped worker thread while the calling thread calls `poll()` every `period`
/// (signals, progress); the call returns as soon as the work ends, not at the next period. When `poll` returns false the flag `cancel` is set (the work is expected
/// to stop soon) and polling stops; the work is always joined. A panic of the work becomes
/// [`Error::Numerical`].
pub fn watched<T: Send>(cancel: &AtomicBool, period: Duration, work: impl FnOnce() -> Result<T> + Send, mut poll: impl FnMut() -> bool) -> Result<T> {
    use std::sync::mpsc::{RecvTimeoutError, channel};
    let (done, finished) = channel::<()>();
    std::thread::scope(|sc| {
        let worker = sc.spawn(move || {
            let out = catch_panic(work).unwrap_or_else(|what| Err(internal(what)));
            let _ = done.send(()); // wakes the watcher at once
            out
        });
        let mut polling = true;
        while let Err(RecvTimeoutError::Timeout) = finished.recv_timeout(period) {
            if polling && !poll() {
                cancel.store(true, Ordering::Relaxed);
                polling = false;
            }
        }
        worker.join().unwrap_or_else(|p| Err(internal(panic_message(p.as_ref()))))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_gated_start_waits_for_the_watcher_and_a_refused_one_cancels() {
        for open in [true, false] {
            let cancel = AtomicBool::new(false);
            let m = SharedMonitor::new(&cancel, true);
            let mut seen = None;
            let work = || {
                let mut run = &m;
                let started = run.start();
                run.poll(2.0, 4.0);
                Ok(started)
            };
            let out = watched(&cancel, Duration::from_millis(2), work, || {
                seen = seen.or(m.take_progress());
                if m.waiting() && open {
                    m.open();
                }
                open
            });
            assert_eq!(out.unwrap(), open);
            assert_eq!(seen.or(m.take_progress()), Some((2.0, 4.0)));
        }
    }

    #[test]
    fn watched_returns_when_the_work_ends_not_at_the_next_poll() {
        let cancel = AtomicBool::new(false);
        let t0 = std::time::Instant::now();
        let mut polls = 0;
        let out = watched(
            &cancel,
            Duration::from_secs(30),
            || Ok(7),
            || {
                polls += 1;
                true
            },
        );
        assert_eq!(out.unwrap(), 7);
        assert_eq!(polls, 0);
        assert!(t0.elapsed() < Duration::from_secs(10), "waited {:?}", t0.elapsed());
    }

    #[test]
    fn every_job_once_in_any_order_and_on_done_sees_each() {
        let jobs: Vec<u64> = (0..50).collect();
        let cancel = AtomicBool::new(false);
        let mut seen = Vec::new();
        let out = run_batch(
            &jobs,
            Some(2),
            &cancel,
            |j| Ok(Some(j * j)),
            |r: &u64| {
                seen.push(*r);
                Ok(())
            },
        )
        .unwrap();
        assert!(!out.cancelled);
        let mut got = out.results.clone();
        got.sort_unstable();
        assert_eq!(got, jobs.iter().map(|j| j * j).collect::<Vec<_>>());
        seen.sort_unstable();
        assert_eq!(seen, got);
    }

    #[test]
    fn a_panic_becomes_an_error_and_stops_the_batch() {
        let jobs: Vec<u32> = (0..20).collect();
        let cancel = AtomicBool::new(false);
        let r = run_batch(&jobs, Some(1), &cancel, |&j| if j == 3 { panic!("job three") } else { Ok(Some(j)) }, |_: &u32| Ok(()));
        let e = r.unwrap_err().to_string();
        assert!(e.contains("internal error: job three"), "{e}");
        assert!(cancel.load(Ordering::Relaxed));
    }

    #[test]
    fn an_error_of_on_done_stops_the_batch() {
        let jobs: Vec<u32> = (0..20).collect();
        let cancel = AtomicBool::new(false);
        let r = run_batch(&jobs, Some(1), &cancel, |&j| Ok(Some(j)), |_: &u32| Err(Error::Numerical("disk full".into())));
        assert!(r.unwrap_err().to_string().contains("disk full"));
    }

    #[test]
    fn cancelled_jobs_are_reported() {
        let jobs: Vec<u32> = (0..10).collect();
        let cancel = AtomicBool::new(false);
        let out = run_batch(
            &jobs,
            Some(1),
            &cancel,
            |&j| {
                if j == 4 {
                    cancel.store(true, Ordering::Relaxed);
                    return Ok(None);
                }
                Ok(Some(j))
            },
            |_: &u32| Ok(()),
        )
        .unwrap();
        assert!(out.cancelled && out.results.len() < jobs.len());
    }

    #[test]
    fn watched_polls_until_done_and_cancels_when_poll_says_so() {
        let cancel = AtomicBool::new(false);
        let mut polls = 0;
        let r = watched(
            &cancel,
            Duration::from_millis(1),
            || {
                while !cancel.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(1));
                }
                Ok(7)
            },
            || {
                polls += 1;
                polls < 3
            },
        );
        assert_eq!(r.unwrap(), 7);
        assert_eq!(polls, 3);
        let e = watched(&AtomicBool::new(false), Duration::from_millis(1), || -> Result<()> { panic!("boom") }, || true).unwrap_err();
        assert!(e.to_string().contains("internal error: boom"), "{e}");
    }

    #[test]
    fn zero_threads_is_one_thread() {
        assert_eq!(with_threads(Some(0), rayon::current_num_threads).unwrap(), 1);
    }
}
