//! Helpers shared by the integration tests.
#![allow(dead_code)]

use beamslider_core::*;

/// Held by the tests that switch the AVX2 build of the time loop off and on (`set_simd` is global
/// to the process, and the tests of all modules run in one): they do not interleave.
pub static SIMD_SWITCH: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Columns of a reference CSV (comment lines start with '#').
pub struct Table {
    pub names: Vec<String>,
    pub rows: Vec<Vec<f64>>,
}

impl Table {
    pub fn col(&self, name: &str) -> Vec<f64> {
        let c = self.names.iter().position(|n| n == name).unwrap_or_else(|| panic!("no column {name}"));
        self.rows.iter().map(|r| r[c]).collect()
    }
}

pub fn read_reference(file: &str) -> Table {
    let path = format!("{}/tests/data/{file}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut lines = text.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty());
    let names = lines.next().unwrap().split(',').map(|s| s.trim().to_string()).collect();
    let rows = lines.map(|l| l.split(',').map(|v| v.trim().parse::<f64>().unwrap()).collect()).collect();
    Table { names, rows }
}

/// All channels the golden files hold.
pub fn golden_channels(l: f64) -> Vec<Channel> {
    vec![Channel::Time, Channel::W4L7, Channel::WAt(0.5 * l), Channel::XC, Channel::ZC, Channel::Beta, Channel::ModalQ, Channel::ModalU, Channel::SliderU]
}

#[allow(clippy::too_many_arguments)] // the run's settings, as the tests name them
pub fn run_audit(params: Params, model: SliderModel, f: f64, a: f64, s0: f64, t_end: f64, every: usize, audit: bool) -> (MemoryRecorder, RunSummary) {
    run_impl(params, model, f, a, s0, t_end, every, audit)
}

pub fn run(params: Params, model: SliderModel, f: f64, a: f64, s0: f64, t_end: f64, every: usize) -> (MemoryRecorder, RunSummary) {
    run_impl(params, model, f, a, s0, t_end, every, false)
}

#[allow(clippy::too_many_arguments)]
fn run_impl(params: Params, model: SliderModel, f: f64, a: f64, s0: f64, t_end: f64, every: usize, audit: bool) -> (MemoryRecorder, RunSummary) {
    let m = Model::new(params).unwrap();
    let exc = Excitation::new(f, a);
    let start = match model {
        SliderModel::Free => m.initial_state(s0, &exc).unwrap(),
        _ => m.initial_state_pcs(&exc).unwrap(),
    };
    let opts =
        RunOptions { excitation: exc, model, duration_s: t_end, record_every: every, channels: golden_channels(m.params.length_m), audit_contacts: audit };
    let mut rec = MemoryRecorder::new();
    let sum = m.run(&start, &opts, &mut rec, &mut ()).unwrap();
    (rec, sum)
}

pub fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |a, x| a.max(x.abs()))
}

pub fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}
