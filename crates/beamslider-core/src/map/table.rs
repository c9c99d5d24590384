//! The operating map as a text table, one letter per behaviour (docs/model.md §8).

use crate::classify::Behaviour;
use crate::dynamics::simulation::Status;
use crate::error::{Error, Result};
use crate::results::{MapRow, STATUS_PREDICTED};

/// One point of the letter table: what the table shows of a map row.
#[derive(Debug, Clone, PartialEq)]
pub struct TableCell {
    /// s₀.
    pub s0: f64,
    /// f_ex [Hz].
    pub f_ex_hz: f64,
    /// a_ex [m/s²].
    pub a_ex_m_s2: f64,
    /// Simulated time reached [s].
    pub t_end_s: f64,
    /// Run status (`completed`, `predicted`, `left_beam`, …).
    pub status: String,
    /// The behaviour's letter ([`Behaviour::letter`]; `?` for a name this build does not know).
    pub letter: char,
    /// Marked `*`: reached but not yet settled ([`marked_unsettled`]).
    pub marked: bool,
}

impl TableCell {
    /// The cell of a point from its row's values (`behaviour` by name, as in the results file).
    pub fn new(s0: f64, f_ex_hz: f64, a_ex_m_s2: f64, t_end_s: f64, status: &str, behaviour: &str, settled: bool) -> TableCell {
        let b = Behaviour::parse(behaviour).ok();
        let marked = b.is_some_and(|b| unsettled(settled, b, status));
        TableCell { s0, f_ex_hz, a_ex_m_s2, t_end_s, status: status.to_string(), letter: b.map_or('?', |b| b.letter()), marked }
    }

    fn of(r: &MapRow) -> TableCell {
        TableCell {
            s0: r.s0,
            f_ex_hz: r.f_ex_hz,
            a_ex_m_s2: r.a_ex_m_s2,
            t_end_s: r.t_end_s,
            status: r.status.clone(),
            letter: r.behaviour.letter(),
            marked: marked_unsettled(r),
        }
    }

    fn done(&self) -> bool {
        self.status == Status::Completed.name() || self.status == STATUS_PREDICTED
    }
}

/// The letter table of columns of a map's rows (s₀, f_ex, a_ex, t_end, status, behaviour, settled)
/// and its [`t_end_text`]; the columns must have one length.
pub fn table_of_columns(
    s0: &[f64], f_ex_hz: &[f64], a_ex_m_s2: &[f64], t_end_s: &[f64], status: &[String], behaviour: &[String], settled: &[bool],
) -> Result<(String, String)> {
    let n = s0.len();
    if [f_ex_hz.len(), a_ex_m_s2.len(), t_end_s.len(), status.len(), behaviour.len(), settled.len()].iter().any(|&k| k != n) {
        return Err(Error::invalid("table", "(columns)", "the columns must have the same length"));
    }
    let cells: Vec<TableCell> = (0..n).map(|i| TableCell::new(s0[i], f_ex_hz[i], a_ex_m_s2[i], t_end_s[i], &status[i], &behaviour[i], settled[i])).collect();
    Ok((table_of_cells(&cells), t_end_text(&cells)))
}

/// "t_end = 120 s", or for an extended map "t_end = 120 s (settled points kept from 60 s)";
/// "predicted, t_end = 120 s" for a map of the reduced predictor (docs/model.md §8).
pub fn t_end_text(cells: &[TableCell]) -> String {
    let ok: Vec<f64> = cells.iter().filter(|c| c.done()).map(|c| c.t_end_s).collect();
    let hi = ok.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let lo = ok.iter().copied().fold(f64::INFINITY, f64::min);
    let predicted = if cells.iter().any(|c| c.status == STATUS_PREDICTED) { "predicted, " } else { "" };
    if ok.is_empty() {
        "t_end = -".into()
    } else if lo == hi {
        format!("{predicted}t_end = {} s", round3(hi))
    } else {
        format!("t_end = {} s (settled points kept from {} s)", round3(hi), round3(lo))
    }
}

fn round3(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
}

fn unsettled(settled: bool, behaviour: Behaviour, status: &str) -> bool {
    !settled && behaviour != Behaviour::NotSettled && (status == Status::Completed.name() || status == STATUS_PREDICTED)
}

/// Whether the table marks the row as not yet settled: a behaviour reached (not `not_settled`)
/// by a completed or predicted run with `settled` false (docs/model.md §8).
pub fn marked_unsettled(r: &MapRow) -> bool {
    unsettled(r.settled, r.behaviour, &r.status)
}

/// The map as text: one row per a_ex (highest first, as in the paper's figure), one column per
/// f_ex, one letter per behaviour ([`Behaviour::letter`]), followed by `*` when the behaviour is
/// reached but has not settled ([`marked_unsettled`]); one block per s₀.
pub fn text_table(rows: &[MapRow]) -> String {
    table_of_cells(&rows.iter().map(TableCell::of).collect::<Vec<_>>())
}

/// [`text_table`] of the cells of a map (the rows as read back by the Python package).
pub fn table_of_cells(cells: &[TableCell]) -> String {
    use std::fmt::Write as _;
    let mut s0s: Vec<f64> = cells.iter().map(|r| r.s0).collect();
    s0s.sort_by(f64::total_cmp);
    s0s.dedup();
    let mut out = String::new();
    for s0 in s0s {
        let sub: Vec<TableCell> = cells.iter().filter(|r| r.s0 == s0).cloned().collect();
        let mut fs: Vec<f64> = sub.iter().map(|r| r.f_ex_hz).collect();
        fs.sort_by(f64::total_cmp);
        fs.dedup();
        let mut as_: Vec<f64> = sub.iter().map(|r| r.a_ex_m_s2).collect();
        as_.sort_by(f64::total_cmp);
        as_.dedup();
        let _ = writeln!(
            out,
            "s0 = {s0}, {}; rows a_ex [m/s^2], columns f_ex [Hz]; I inactivity, T trivial adaption, S signature move, R relaxation oscillation, D self-damping, N not settled, ? undetermined, . not run; * reached, not yet settled",
            t_end_text(&sub)
        );
        let _ = write!(out, "{:>6} ", "a\\f");
        for f in &fs {
            let _ = write!(out, "{:>4}", format!("{f}"));
        }
        out.push('\n');
        for a in as_.iter().rev() {
            let _ = write!(out, "{:>6} ", format!("{a}"));
            for f in &fs {
                let c = sub
                    .iter()
                    .find(|r| r.f_ex_hz == *f && r.a_ex_m_s2 == *a)
                    .map_or(".".to_string(), |r| format!("{}{}", r.letter, if r.marked { "*" } else { "" }));
                let _ = write!(out, "{c:>4}");
            }
            out.push('\n');
        }
    }
    out
}
