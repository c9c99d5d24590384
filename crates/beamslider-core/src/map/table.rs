//! The operating map as a text table, one letter per behaviour (docs/model.md §8).

use crate::dynamics::simulation::Status;
use crate::results::{MapRow, STATUS_PREDICTED};

/// "t_end = 120 s", or for an extended map "t_end = 120 s (settled points kept from 60 s)".
fn t_end_text(rows: &[&MapRow]) -> String {
    let ok: Vec<f64> = rows.iter().filter(|r| r.status == Status::Completed.name() || r.status == STATUS_PREDICTED).map(|r| r.t_end_s).collect();
    let hi = ok.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let lo = ok.iter().copied().fold(f64::INFINITY, f64::min);
    if ok.is_empty() {
        "t_end = -".into()
    } else if lo == hi {
        format!("t_end = {} s", round3(hi))
    } else {
        format!("t_end = {} s (settled points kept from {} s)", round3(hi), round3(lo))
    }
}

fn round3(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
}

/// Whether the table marks the row as not yet settled: a behaviour reached (not `not_settled`)
/// by a completed or predicted run with `settled` false (docs/model.md §8).
pub fn marked_unsettled(r: &MapRow) -> bool {
    !r.settled && r.behaviour != crate::classify::Behaviour::NotSettled && (r.status == Status::Completed.name() || r.status == STATUS_PREDICTED)
}

/// The map as text: one row per a_ex (highest first, as in the paper's figure), one column per
/// f_ex, one letter per behaviour ([`Behaviour::letter`]), followed by `*` when the behaviour is
/// reached but has not settled ([`marked_unsettled`]); one block per s₀.
pub fn text_table(rows: &[MapRow]) -> String {
    use std::fmt::Write as _;
    let mut s0s: Vec<f64> = rows.iter().map(|r| r.s0).collect();
    s0s.sort_by(f64::total_cmp);
    s0s.dedup();
    let mut out = String::new();
    for s0 in s0s {
        let sub: Vec<&MapRow> = rows.iter().filter(|r| r.s0 == s0).collect();
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
                let c = sub.iter().find(|r| r.f_ex_hz == *f && r.a_ex_m_s2 == *a).map_or(".".to_string(), |r| format!("{}{}", r.behaviour.letter(), if marked_unsettled(r) { "*" } else { "" }));
                let _ = write!(out, "{c:>4}");
            }
            out.push('\n');
        }
    }
    out
}
