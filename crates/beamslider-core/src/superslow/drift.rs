//! Layer (b1) of docs/model.md §6.3: the super-slow drift velocity V(s, branch) measured in the
//! pseudo-constrained slider (PCS) model of docs/model.md §6.
//!
//! In the PCS the contact kinematics use the prescribed position sL while the slider keeps its
//! horizontal freedom, so the horizontal velocity of its centre of mass carries exactly the
//! locomotion forces at s:
//!
//! ```text
//! V(s, β) = [x_C(t₁) − x_C(t₀)] / (L (t₁ − t₀))      [1/s; > 0 = towards larger s]
//! ```
//!
//! over a record window on the steady state of branch β, reached by sequential continuation in s
//! as for the manifold (docs/model.md §6): the **down** sweep starts at the centre s = ½ from rest
//! and follows the low branch L; the **up** sweep starts at s_min = B/(2L) from rest and follows
//! the high branch H (the branch continuous with H near the clamping). At each s the run settles
//! for `settle_periods` excitation periods (the first point of a sweep, from rest, for
//! `first_settle_periods`) and then records a window of an integer number of periods ≥
//! `window_s`, split into `sub_windows` equal sub-windows of an integer number of periods each;
//! V is the mean of the sub-window velocities and its standard error their standard deviation
//! over √(sub_windows). With `mirror` the sweeps run at 1 − s (the far half; by symmetry
//! V(1 − s) = −V(s)).
//!
//! A sweep **leaves its branch** when the window amplitude Â (mean |Hilbert(w(4L/7))|/h) rises
//! (down sweep) or falls (up sweep) against that of a row within Δs = 0.02 before it by a
//! factor > 2 and by > 0.2 h (the classifier's jump thresholds; [`leaves_branch`]; a jump may take
//! two or more steps of a fine grid): the
//! row is written with the new branch label (its `jump` flag set) and the sweep stops there — the
//! rest of the new branch is covered by the other sweep. Readers keep one row per (s, branch),
//! preferring the sweep native to the branch (down for L, up for H).
//!
//! Rows are appended to a results file ([`crate::results`]: one writer, each line synced, a torn
//! last line cut off) as they are produced (first line: the settings);
//! each row holds the end state of its runs, so a killed run resumes each sweep from its last
//! row — bitwise as if it had not stopped (every run starts a fresh stepper from the state).

use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use serde::{Deserialize, Serialize};

use crate::dynamics::record::{Channel, MemoryRecorder, NullRecorder};
use crate::dynamics::simulation::{CancelFlag, Excitation, Model, RunOptions, SliderModel, State, Status};
use crate::error::{Error, Result};
use crate::results::{ResultsLock, append_json_lines, read_tagged_lines};
use crate::signal::hilbert_envelope;

/// Settings of [`drift_table_pcs`] (the defaults of docs/model.md §6.3; `s_values` is required
/// when read from keyword arguments, the other fields take their defaults).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriftOptions {
    /// Slider positions, strictly increasing, within [B/(2L), ½] (the up sweep visits them in
    /// this order, the down sweep in reverse).
    pub s_values: Vec<f64>,
    /// Settling periods at each s after a step (default 40).
    #[serde(default = "defaults::settle")]
    pub settle_periods: usize,
    /// Settling periods at the first s of a sweep, from rest (default 400).
    #[serde(default = "defaults::first_settle")]
    pub first_settle_periods: usize,
    /// Least length of the record window [s] (default 1).
    #[serde(default = "defaults::window")]
    pub window_s: f64,
    /// Sub-windows for the standard error (default 4).
    #[serde(default = "defaults::sub_windows")]
    pub sub_windows: usize,
    /// Run at 1 − s (the far half) instead of s.
    #[serde(default)]
    pub mirror: bool,
}

/// The defaults of [`DriftOptions`] (docs/model.md §6.3).
mod defaults {
    pub fn settle() -> usize {
        40
    }
    pub fn first_settle() -> usize {
        400
    }
    pub fn window() -> f64 {
        1.0
    }
    pub fn sub_windows() -> usize {
        4
    }
}

impl DriftOptions {
    /// The defaults on the grid s_min, s_min + Δs, …, with ½ appended (`ds` = 0.02, docs/model.md §6.3).
    pub fn with_step(s_min: f64, ds: f64) -> Result<DriftOptions> {
        if !(ds.is_finite() && ds > 0.0 && ds <= 0.5) {
            return Err(Error::invalid("ds", ds, "must lie in (0, 0.5]"));
        }
        let mut s_values = Vec::new();
        let mut k = 0;
        loop {
            let s = s_min + k as f64 * ds;
            if s >= 0.5 - 1e-9 {
                break;
            }
            s_values.push(s);
            k += 1;
        }
        s_values.push(0.5);
        Ok(DriftOptions { s_values, settle_periods: 40, first_settle_periods: 400, window_s: 1.0, sub_windows: 4, mirror: false })
    }

    fn validate(&self, model: &Model) -> Result<()> {
        let s_min = model.params.s_min();
        if self.s_values.is_empty() {
            return Err(Error::invalid("s_values", "[]", "need at least one slider position"));
        }
        for w in self.s_values.windows(2) {
            if !(w[1] > w[0]) {
                return Err(Error::invalid("s_values", format!("{:?}", w), "must be strictly increasing"));
            }
        }
        if self.s_values.iter().any(|s| !(s.is_finite() && *s >= s_min - 1e-12 && *s <= 0.5 + 1e-12)) {
            return Err(Error::invalid(
                "s_values",
                "out of range",
                &format!("all s must lie in [{s_min:.6}, 0.5] (the half near the clamping; `mirror` gives the other half)"),
            ));
        }
        if self.settle_periods == 0 || self.first_settle_periods == 0 {
            return Err(Error::invalid("settle_periods", 0, "must be >= 1"));
        }
        if !(self.window_s.is_finite() && self.window_s > 0.0 && self.window_s <= 1000.0) {
            return Err(Error::invalid("window_s", self.window_s, "must lie in (0, 1000]"));
        }
        if self.sub_windows < 2 {
            return Err(Error::invalid("sub_windows", self.sub_windows, "must be >= 2"));
        }
        Ok(())
    }
}

/// Branch label of the super-slow manifold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum BranchLabel {
    /// Low branch (continuous with the centre).
    L,
    /// High branch (continuous with the clamping).
    H,
}

/// Sweep direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Sweep {
    /// From the centre outwards (starts on L).
    Down,
    /// From the clamping inwards (starts on H).
    Up,
}

/// The state saved with a row (enough to continue the sweep).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SavedState {
    /// Time [s].
    pub t_s: f64,
    /// Modal coordinates.
    pub q: Vec<f64>,
    /// Modal velocities.
    pub u: Vec<f64>,
    /// Slider (x_C, z_C, β).
    pub slider_q: [f64; 3],
    /// Slider velocities.
    pub slider_u: [f64; 3],
}

impl From<&State> for SavedState {
    fn from(s: &State) -> Self {
        SavedState { t_s: s.t_s, q: s.q.clone(), u: s.u.clone(), slider_q: s.slider_q, slider_u: s.slider_u }
    }
}

impl From<&SavedState> for State {
    fn from(s: &SavedState) -> Self {
        State { t_s: s.t_s, q: s.q.clone(), u: s.u.clone(), slider_q: s.slider_q, slider_u: s.slider_u }
    }
}

/// One measured drift velocity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DriftRow {
    /// Sweep that produced the row.
    pub sweep: Sweep,
    /// Index of the s in the sweep's order (0 = its first point).
    pub index: usize,
    /// Slider position (1 − s of the grid with `mirror`).
    pub s: f64,
    /// Branch the row belongs to.
    pub branch: BranchLabel,
    /// The sweep left its branch at this s (the row is on the other branch; the sweep ends).
    pub jump: bool,
    /// V = Δx_C/(L Δt) over the window [1/s] (> 0: towards larger s).
    pub v_per_s: f64,
    /// Standard error of V from the sub-windows [1/s].
    pub v_se_per_s: f64,
    /// V of each sub-window [1/s].
    pub v_sub_per_s: Vec<f64>,
    /// Mean |Hilbert(w(4L/7))| / h over the window.
    pub amplitude_h: f64,
    /// Start of the window [s] (simulated time of the sweep).
    pub t_window_s: f64,
    /// Length of the window [s].
    pub window_s: f64,
    /// End state (resume point of the sweep).
    pub state: SavedState,
}

/// First line of a drift-table file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DriftHeader {
    /// Format tag, "beamslider drift table".
    pub format: String,
    /// Version (1).
    pub version: u32,
    /// Canonical parameter TOML.
    pub params_toml: String,
    /// Excitation frequency [Hz].
    pub f_ex_hz: f64,
    /// Base-acceleration amplitude [m/s²].
    pub a_ex_m_s2: f64,
    /// Options.
    pub options: DriftOptions,
}

/// A drift table: one row per (s, branch) after [`DriftTable::dedup`].
#[derive(Debug, Clone, PartialEq)]
pub struct DriftTable {
    /// Settings.
    pub header: DriftHeader,
    /// Rows in production order.
    pub rows: Vec<DriftRow>,
    /// Rows computed now (the others were read from the file).
    pub computed: usize,
}

impl DriftTable {
    /// One row per (s, branch), preferring the branch's native sweep (down for L, up for H),
    /// sorted by branch then s.
    pub fn dedup(&self) -> Vec<DriftRow> {
        let mut out: Vec<DriftRow> = Vec::new();
        for r in &self.rows {
            let native = matches!((r.sweep, r.branch), (Sweep::Down, BranchLabel::L) | (Sweep::Up, BranchLabel::H));
            match out.iter_mut().find(|o| o.branch == r.branch && (o.s - r.s).abs() < 1e-12) {
                Some(o) => {
                    if native {
                        *o = r.clone();
                    }
                }
                None => out.push(r.clone()),
            }
        }
        out.sort_by(|a, b| (a.branch as u8).cmp(&(b.branch as u8)).then(a.s.total_cmp(&b.s)));
        out
    }
}

const FORMAT: &str = "beamslider drift table";

/// One line of a drift-table file (its header or a row).
fn json_line<T: Serialize>(x: &T) -> Result<String> {
    serde_json::to_string(x).map_err(|e| Error::Numerical(e.to_string()))
}

/// Read a drift-table file (a results file of [`crate::results`]): the header and the complete
/// rows (a torn last line, from a killed run, is left out). A table without rows (a header only)
/// is refused: it holds no drift to predict with.
pub fn read_drift_table(path: &Path) -> Result<(DriftHeader, Vec<DriftRow>)> {
    let (header, rows, _) = read_with_length(path)?;
    if rows.is_empty() {
        let why = "no rows: the header only (a table stopped before its first point); finish it (drift-table --resume) before using it";
        return Err(Error::invalid("drift table", path.display(), why));
    }
    Ok((header, rows))
}

/// [`read_drift_table`] and the byte length of the file's complete part.
fn read_with_length(path: &Path) -> Result<(DriftHeader, Vec<DriftRow>, u64)> {
    let file = read_tagged_lines(path, "format", &serde_json::json!(FORMAT))?;
    let bad = |why: String| Error::invalid("drift table", path.display(), &why);
    let Some((first, rest)) = file.lines.split_first() else {
        return Err(bad("the file is empty (no header line)".into()));
    };
    let header: DriftHeader = serde_json::from_str(first).map_err(|e| bad(format!("first line is not a drift-table header: {e}")))?;
    if header.version != 1 {
        let why = if header.version > 1 { "newer than this build (1)" } else { "not a version of the format (1)" };
        return Err(bad(format!("version {}: {why}", header.version)));
    }
    // A row's s lies where the slider's contact points are on the beam (docs/model.md §5).
    let lo = crate::params::Params::from_toml_str(&header.params_toml).map_or(0.0, |p| p.s_min());
    let rows = rest.iter().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let row = |(i, l): (usize, &String)| -> Result<DriftRow> {
        let r: DriftRow = serde_json::from_str(l).map_err(|e| bad(format!("line {}: {e}", i + 2)))?;
        if !(r.s.is_finite() && r.s >= lo - 1e-9 && r.s <= 1.0 - lo + 1e-9) {
            return Err(bad(format!("line {}: s = {} lies off the beam (the slider's contact points need {lo:.4} <= s <= {:.4})", i + 2, r.s, 1.0 - lo)));
        }
        Ok(r)
    };
    let rows = rows.map(row).collect::<Result<_>>()?;
    Ok((header, rows, file.good_len))
}

/// Measure V(s, β) on both branches at one excitation (docs/model.md §6.3), the two sweeps in
/// parallel. With `out`, rows are appended to that JSON-lines file as they are produced; an
/// existing file with the same settings is resumed (`resume = true`; otherwise it is an error).
/// `progress(done, total)` is called after every row (from the worker threads); setting `cancel`
/// stops both sweeps (Error::Interrupted; finished rows stay in the file).
pub fn drift_table_pcs(
    model: &Model, excitation: &Excitation, opts: &DriftOptions, out: Option<&Path>, resume: bool, cancel: &AtomicBool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<DriftTable> {
    excitation.validate()?;
    opts.validate(model)?;
    let header = DriftHeader {
        format: FORMAT.into(),
        version: 1,
        params_toml: model.params.to_toml_string(),
        f_ex_hz: excitation.f_ex_hz,
        a_ex_m_s2: excitation.a_ex_m_s2,
        options: opts.clone(),
    };
    // One writer per file (the results lock); an existing table of the same settings is resumed,
    // its torn last line cut off before the first append.
    let (mut old, mut cut, _lock) = (Vec::new(), None, out.map(ResultsLock::acquire).transpose()?);
    if let Some(p) = out {
        if p.exists() {
            if !resume {
                return Err(Error::invalid("out", p.display(), "the drift table exists: resume it (resume / --resume) or choose another file"));
            }
            let (h, rows, good_len) = read_with_length(p)?;
            if h != header {
                return Err(Error::invalid("out", p.display(), "the drift table was made with other parameters, excitation or options: cannot resume it"));
            }
            (old, cut) = (rows, Some(good_len));
        } else {
            append_json_lines(p, None, &[json_line(&header)?])?;
        }
    }
    let sink = out.map(|p| (p, Mutex::new(cut)));
    let n = opts.s_values.len();
    let total = 2 * n;
    let done = AtomicUsize::new(old.len());
    progress(done.load(Ordering::Relaxed), total);
    let write_row = |r: &DriftRow| -> Result<()> {
        if let Some((p, cut)) = &sink {
            let mut cut = cut.lock().unwrap_or_else(|e| e.into_inner());
            append_json_lines(p, cut.take(), &[json_line(r)?])?;
        }
        let d = done.fetch_add(1, Ordering::Relaxed) + 1;
        progress(d, total);
        Ok(())
    };
    let prior = |sw: Sweep| -> Vec<DriftRow> { old.iter().filter(|r| r.sweep == sw).cloned().collect() };
    let (down_prior, up_prior) = (prior(Sweep::Down), prior(Sweep::Up));
    let (down, up) = std::thread::scope(|sc| {
        let h = sc.spawn(|| sweep(model, excitation, opts, Sweep::Down, down_prior, cancel, &write_row));
        let u = sweep(model, excitation, opts, Sweep::Up, up_prior, cancel, &write_row);
        let d = h.join().unwrap_or_else(|_| Err(Error::Numerical("drift sweep worker panicked".into())));
        (d, u)
    });
    if down.is_err() || up.is_err() {
        cancel.store(true, Ordering::Relaxed);
    }
    let (mut rows, up) = (down?, up?);
    rows.extend(up);
    let computed = rows.len() - old.len();
    Ok(DriftTable { header, rows, computed })
}

/// One sweep; `prior` are its rows read from the file (continued from the last one).
fn sweep(
    model: &Model, excitation: &Excitation, opts: &DriftOptions, dir: Sweep, prior: Vec<DriftRow>, cancel: &AtomicBool,
    write_row: &(dyn Fn(&DriftRow) -> Result<()> + Sync),
) -> Result<Vec<DriftRow>> {
    let grid: Vec<f64> = match dir {
        Sweep::Up => opts.s_values.clone(),
        Sweep::Down => opts.s_values.iter().rev().copied().collect(),
    };
    let mut rows = prior;
    rows.sort_by_key(|r| r.index);
    if rows.last().is_some_and(|r| r.jump) {
        return Ok(rows);
    }
    let mut branch = match dir {
        Sweep::Down => BranchLabel::L,
        Sweep::Up => BranchLabel::H,
    };
    // (s, Â) of the sweep's rows so far: a jump is looked for against all of them within
    // JUMP_LOOKBACK_S (a resumed sweep has them from its rows).
    let mut history: Vec<(f64, f64)> = rows.iter().map(|r| (r.s, r.amplitude_h)).collect();
    let (mut state, start) = match rows.last() {
        Some(r) => (State::from(&r.state), r.index + 1),
        None => (model.initial_state_pcs(excitation)?, 0),
    };
    for (i, &s_grid) in grid.iter().enumerate().skip(start) {
        if cancel.load(Ordering::Relaxed) {
            return Err(Error::Interrupted { t_s: state.t_s });
        }
        let s = if opts.mirror { 1.0 - s_grid } else { s_grid };
        let settle = if i == 0 { opts.first_settle_periods } else { opts.settle_periods };
        let (v, se, sub, amp, t_win, win, next) = measure(model, excitation, opts, s, settle, &state, cancel)?;
        let jump = leaves_branch(&history, s, amp, dir == Sweep::Down);
        if jump {
            branch = match branch {
                BranchLabel::L => BranchLabel::H,
                BranchLabel::H => BranchLabel::L,
            };
        }
        let row = DriftRow {
            sweep: dir,
            index: i,
            s,
            branch,
            jump,
            v_per_s: v,
            v_se_per_s: se,
            v_sub_per_s: sub,
            amplitude_h: amp,
            t_window_s: t_win,
            window_s: win,
            state: SavedState::from(&next),
        };
        write_row(&row)?;
        rows.push(row);
        if jump {
            break;
        }
        state = next;
        history.push((s, amp));
    }
    Ok(rows)
}

/// How far back in s [-] a sweep looks for the amplitude change of a jump: on a fine grid (Δs
/// 0.0025) the jump is spread over the few steps the beam needs to reach the other branch.
pub const JUMP_LOOKBACK_S: f64 = 0.02;

/// Whether a row at `s` with window amplitude `amp` [h] has left the branch of the rows before it
/// (`history`: (s, Â) in sweep order): Â lies above (`rising`: the down sweep, which can only
/// leave the low branch upwards) or below (the up sweep, which can only leave the high branch
/// downwards) that of a row within [`JUMP_LOOKBACK_S`] by a factor > 2 and by > 0.2 h (the
/// classifier's jump thresholds), and always the row before. On the Δs = 0.01 grid of the default
/// tables that is the last two rows. (The up sweep's steep rise from the clamping onto the high
/// branch is no jump.)
pub fn leaves_branch(history: &[(f64, f64)], s: f64, amp: f64, rising: bool) -> bool {
    // The row before always counts (a coarse grid's step may exceed the look-back).
    history.iter().rev().enumerate().take_while(|&(i, &(s0, _))| i == 0 || (s - s0).abs() <= JUMP_LOOKBACK_S + 1e-9).any(|(_, &(_, a0))| {
        let (hi, lo) = if rising { (amp, a0) } else { (a0, amp) };
        hi > 2.0 * lo && hi - lo > 0.2
    })
}

type Measured = (f64, f64, Vec<f64>, f64, f64, f64, State);

/// Settle at s, then record the window: (V, se, sub-window V, Â, window start, window length, end state).
fn measure(model: &Model, excitation: &Excitation, opts: &DriftOptions, s: f64, settle_periods: usize, start: &State, cancel: &AtomicBool) -> Result<Measured> {
    let dt = model.params.dt_s;
    let period = excitation.period_s();
    let steps_per = |periods: usize| (periods as f64 * period / dt).round() as u64;
    let k = opts.sub_windows;
    let sub_periods = (opts.window_s / period / k as f64).ceil().max(1.0) as usize;
    let kind = SliderModel::PseudoConstrained { s };
    let mut monitor = CancelFlag(cancel);
    let settle = RunOptions {
        excitation: *excitation,
        model: kind,
        duration_s: steps_per(settle_periods) as f64 * dt,
        record_every: usize::MAX,
        channels: vec![],
        audit_contacts: false,
    };
    let a = model.run(start, &settle, &mut NullRecorder, &mut monitor)?;
    check(&a.status, s)?;
    let n_sub = steps_per(sub_periods);
    let rec_opts = RunOptions { duration_s: (k as u64 * n_sub) as f64 * dt, record_every: 1, channels: vec![Channel::W4L7, Channel::XC], ..settle };
    let mut rec = MemoryRecorder::new();
    let b = model.run(&a.state, &rec_opts, &mut rec, &mut monitor)?;
    check(&b.status, s)?;
    let w = rec.column("w_4L7_m").unwrap_or_default();
    let x = rec.column("xC_m").unwrap_or_default();
    if x.len() as u64 != k as u64 * n_sub + 1 {
        return Err(Error::Numerical(format!("drift window at s = {s}: {} samples recorded, expected {}", x.len(), k as u64 * n_sub + 1)));
    }
    let l = model.params.length_m;
    let t_sub = n_sub as f64 * dt;
    let sub: Vec<f64> = (0..k).map(|j| (x[(j + 1) * n_sub as usize] - x[j * n_sub as usize]) / (l * t_sub)).collect();
    let v = sub.iter().sum::<f64>() / k as f64;
    let var = sub.iter().map(|u| (u - v).powi(2)).sum::<f64>() / (k - 1) as f64;
    let se = (var / k as f64).sqrt();
    let env = hilbert_envelope(&w[1..]);
    let amp = env.iter().sum::<f64>() / env.len().max(1) as f64 / model.params.thickness_m;
    Ok((v, se, sub, amp, a.state.t_s, k as f64 * t_sub, b.state))
}

fn check(status: &Status, s: f64) -> Result<()> {
    match status {
        Status::Completed => Ok(()),
        Status::Interrupted { t_s } => Err(Error::Interrupted { t_s: *t_s }),
        other => Err(Error::Numerical(format!("drift table at s = {s}: {}", other.message()))),
    }
}

#[cfg(test)]
mod tests {
    use super::leaves_branch;

    #[test]
    fn a_jump_spread_over_two_steps_is_found() {
        // The (124 Hz, 8 m/s²) down sweep of the default law's tables (Δs 0.01): 0.052 h, then
        // 0.216 h (× 4.2 but only +0.164 h), then 0.288 h: +0.236 h against the row two steps back.
        let h = [(0.2657, 0.044), (0.2557, 0.052)];
        assert!(!leaves_branch(&h, 0.2457, 0.216, true));
        let h2 = [(0.2657, 0.044), (0.2557, 0.052), (0.2457, 0.216)];
        assert!(leaves_branch(&h2, 0.2357, 0.288, true));
        // One step, both thresholds: found (the rule before): a rise in the down sweep, a fall in
        // the up sweep.
        assert!(leaves_branch(&[(0.30, 0.05)], 0.29, 0.6, true));
        assert!(leaves_branch(&[(0.30, 1.0)], 0.31, 0.3, false));
    }

    #[test]
    fn only_the_direction_that_leaves_the_sweep_s_branch_counts() {
        // The up sweep rising from the clamping onto the high branch ((124 Hz, 8 m/s²): 0.1 h at
        // s = 0.226, 0.35 h at 0.246) stays on it; the down sweep cannot jump down.
        assert!(!leaves_branch(&[(0.226, 0.10), (0.236, 0.2)], 0.246, 0.35, false));
        assert!(leaves_branch(&[(0.226, 0.10), (0.236, 0.2)], 0.246, 0.35, true));
        assert!(!leaves_branch(&[(0.30, 1.0)], 0.29, 0.3, true));
    }

    #[test]
    fn gradual_change_and_old_rows_are_no_jump() {
        // The low branch rising towards its fold on a fine grid: ×2 over 0.02 but < 0.2 h.
        let h: Vec<(f64, f64)> = (0..9).map(|i| (0.284 - 0.0025 * i as f64, 0.078 + 0.0095 * i as f64)).collect();
        assert!(!leaves_branch(&h, 0.2615, 0.16, true));
        // A low row more than 0.02 away does not count.
        assert!(!leaves_branch(&[(0.33, 0.05), (0.32, 0.30)], 0.305, 0.31, true));
        assert!(!leaves_branch(&[], 0.3, 1.0, true));
        // A coarse grid (Δs 0.05 > the look-back): the row before still counts.
        assert!(leaves_branch(&[(0.186, 0.076), (0.236, 0.418)], 0.286, 0.097, false));
    }
}
