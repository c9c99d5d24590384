//! Binding of the reduced predictor (docs/model.md §6.3–6.5): the slow flow, the drift law and its
//! features, predicted points and maps, and the design law as a handle that parses its file once.
//! Conversions only: results cross as the core's JSON.

use beamslider_core::superslow::design_law::{DesignLaw, design_coordinates as core_coordinates};
use beamslider_core::superslow::law::{self, DriftLaw};
use beamslider_core::superslow::predict::{self as pred, Drift, PredictOptions, SDnRule, Source, TableDrift};
use beamslider_core::superslow::slowflow::{SlowBranch, SlowFlowOptions, SlowModel, slow_flow as core_slow_flow};
use beamslider_core::superslow::{HbOptions, hb_manifold};
use beamslider_core::{Criteria, Error, MapConfig, MapRow, MapRunOptions};
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering::Relaxed};

use crate::{detached, guarded, params::PyParams};

type Branch = (Vec<f64>, Vec<f64>, Vec<f64>);
type Table = (Branch, Branch, Option<f64>, Option<f64>);
type Path = Option<std::path::PathBuf>;
fn branch(b: Branch) -> SlowBranch { SlowBranch { s: b.0, amplitude_h: b.1, v_per_s: b.2 } }
macro_rules! js { ($x:expr) => { serde_json::to_string(&$x).map_err(|e| crate::SimulationError::new_err(format!("internal error: {e}"))) } }
fn parse_law(law_json: &str) -> PyResult<DriftLaw> { guarded(|| DriftLaw::from_json_str(law_json)) }
fn bad(field: &str, v: &str, allowed: &str) -> PyErr { PyValueError::new_err(Error::invalid(field, format!("{v:?}"), allowed).to_string()) }
fn options(n_modes: usize, d_eff: Option<f64>, s_dn: &str) -> PyResult<PredictOptions> {
    let rules = [("law", SDnRule::Law), ("hb", SDnRule::Hb), ("table", SDnRule::Table), ("none", SDnRule::None)];
    let rule = rules.iter().find(|r| r.0 == s_dn).ok_or_else(|| bad("s_dn", s_dn, "one of 'law', 'hb', 'table', 'none'"))?.1;
    Ok(PredictOptions { hb: HbOptions { n_modes, d_eff, ..PredictOptions::default().hb }, s_dn: rule, ..PredictOptions::default() })
}
/// Slow flow (docs/model.md §6.3) on branches given by nodes (s′ ∈ (0, ½] increasing, Â, V): the core's prediction, JSON.
#[pyfunction]
#[pyo3(signature = (low, high, *, low_ends_in_fold, high_ends_in_fold, s0, t_end_s=120.0, dt_out_s=0.2, smooth_s=1.0, build_up_s=0.0, build_up_drift=false, criteria_json=None))]
#[allow(clippy::too_many_arguments)]
pub fn slow_flow(py: Python<'_>, low: Branch, high: Branch, low_ends_in_fold: bool, high_ends_in_fold: bool, s0: f64, t_end_s: f64, dt_out_s: f64, smooth_s: f64, build_up_s: f64, build_up_drift: bool, criteria_json: Option<&str>) -> PyResult<String> {
    let criteria: Criteria = serde_json::from_str(criteria_json.unwrap_or("{}")).map_err(|e| PyValueError::new_err(format!("invalid parameter `criteria`: {e}")))?;
    let model = SlowModel { low: branch(low), high: branch(high), low_ends_in_fold, high_ends_in_fold };
    let opts = SlowFlowOptions { t_end_s, dt_out_s, smooth_s, criteria, build_up_s, build_up_drift, ..SlowFlowOptions::default() };
    js!(py.detach(|| guarded(|| core_slow_flow(&model, s0, &opts)))?)
}
/// The drift law (law-file JSON) at law inputs `x` (rows of FEATURES) with Λ_g `lift_off`: V and the outside flag per row.
#[pyfunction]
#[pyo3(signature = (law_json, *, high, x, lift_off))]
pub fn drift_law_evaluate(law_json: &str, high: bool, x: Vec<[f64; law::NF]>, lift_off: Vec<f64>) -> PyResult<(Vec<f64>, Vec<bool>)> {
    let law = parse_law(law_json)?;
    if x.len() != lift_off.len() { return Err(PyValueError::new_err("invalid parameter `x`: one lift_off per row")); }
    Ok(x.iter().zip(&lift_off).map(|(r, &l)| law.evaluate(high, r, l)).unzip())
}
/// Layer-(a) features (docs/model.md §6.3) at `s` on one branch of the HB manifold: JSON list.
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, high, s, n_modes=5, d_eff=None))]
#[allow(clippy::too_many_arguments)]
pub fn hb_features(py: Python<'_>, params: &Bound<'_, PyParams>, f_ex_hz: f64, a_ex_m_s2: f64, high: bool, s: Vec<f64>, n_modes: usize, d_eff: Option<f64>) -> PyResult<String> {
    let (params, opts) = (params.get().0.clone(), HbOptions { n_modes, d_eff, ..HbOptions::default() });
    js!(py.detach(|| guarded(|| law::features(&params, &hb_manifold(&params, f_ex_hz, a_ex_m_s2, &opts)?, f_ex_hz, a_ex_m_s2, high, &s)))?)
}
/// One operating point by the reduced model, drift a law (`law_json`) or a PCS table ((low, high, s_up, s_dn)): JSON.
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, s0, t_end_s, law_json=None, table=None, s_dn="law", source="hb", n_modes=5, d_eff=None, v_dead=0.0, build_up_s=None, build_up_drift=true, robustness=true))]
#[allow(clippy::too_many_arguments)]
pub fn predict(py: Python<'_>, params: &Bound<'_, PyParams>, f_ex_hz: f64, a_ex_m_s2: f64, s0: f64, t_end_s: f64, law_json: Option<&str>, table: Option<Table>, s_dn: &str, source: &str, n_modes: usize, d_eff: Option<f64>, v_dead: f64, build_up_s: Option<f64>, build_up_drift: bool, robustness: bool) -> PyResult<String> {
    let source = match source { "hb" => Source::Hb, "table" => Source::Table, _ => return Err(bad("source", source, "'hb' or 'table'")) };
    let opts = PredictOptions { v_dead, build_up_s, build_up_drift, robustness, source, ..options(n_modes, d_eff, s_dn)? };
    let (params, law) = (params.get().0.clone(), law_json.map(parse_law).transpose()?);
    let table = table.map(|(lo, hi, su, sd)| TableDrift::new(branch(lo), branch(hi), su, sd));
    let drift = match (&law, &table) { (Some(l), None) => Drift::Law(l), (None, Some(t)) => Drift::Table(t), _ => return Err(bad("drift", "", "one of law_json and table")) };
    js!(py.detach(|| guarded(|| pred::predict_drift(&params, &*law::beam_for(&params, n_modes)?, drift, f_ex_hz, a_ex_m_s2, s0, t_end_s, &opts)))?)
}
/// Interval [ms] of the interpreter's polls (Ctrl-C, progress) while a predicted map runs: the wait
/// ends at a poll, and a design's band takes a few tens of ms, so it is short.
const POLL_MS: u64 = 2;
/// A map predicted by the core (`map --predictor`; interpreter released, Ctrl-C stops it, `progress(done, total)`): rows, JSON.
#[allow(clippy::too_many_arguments)]
fn run_map(py: Python<'_>, cfg: &MapConfig, law: &DriftLaw, popts: &PredictOptions, out: Path, resume: bool, threads: Option<usize>, progress: Option<Py<PyAny>>) -> PyResult<Vec<String>> {
    crate::check_threads(threads)?;
    let (cancel, done, total) = (AtomicBool::new(false), AtomicUsize::new(0), guarded(|| cfg.points())?.len());
    let poll = |py: Python<'_>| progress.as_ref().map_or(Ok(()), |cb| cb.call1(py, (done.load(Relaxed), total)).map(|_| ()));
    let opts = MapRunOptions { out, resume, threads, extend: false };
    let run = || pred::run_predicted_map(cfg, law, popts, &opts, &cancel, &|n: usize, _t: usize, _r: &MapRow| done.store(n, Relaxed));
    let outcome = detached(py, &cancel, POLL_MS, run, poll)?;
    if outcome.cancelled || cancel.load(Relaxed) { return Err(PyKeyboardInterrupt::new_err("map interrupted")); }
    Ok(outcome.rows.iter().map(MapRow::to_json).collect())
}
/// A map predicted by the core with a drift law (JSON text): see `run_map`.
#[pyfunction]
#[pyo3(signature = (config_toml, law_json, *, out=None, resume=false, threads=None, n_modes=5, d_eff=None, s_dn="law", progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn predicted_map(py: Python<'_>, config_toml: &str, law_json: &str, out: Path, resume: bool, threads: Option<usize>, n_modes: usize, d_eff: Option<f64>, s_dn: &str, progress: Option<Py<PyAny>>) -> PyResult<Vec<String>> {
    let (cfg, law, popts) = (guarded(|| MapConfig::from_toml_str(config_toml))?, parse_law(law_json)?, options(n_modes, d_eff, s_dn)?);
    run_map(py, &cfg, &law, &popts, out, resume, threads, progress)
}
/// Design coordinates (docs/model.md §6.5) of `params` relative to `base`, in the core's order.
#[pyfunction]
pub fn design_coordinates(py: Python<'_>, params: &Bound<'_, PyParams>, base: &Bound<'_, PyParams>) -> PyResult<Vec<f64>> {
    let (p, b) = (params.get().0.clone(), base.get().0.clone());
    py.detach(|| guarded(|| core_coordinates(&p, &b).map(|c| c.to_vec())))
}
/// A design law (docs/model.md §6.5) parsed once from its file's JSON text (`source` names it).
#[pyclass(name = "DesignLaw", module = "beamslider._core", frozen)]
pub struct PyDesignLaw(DesignLaw);
#[pymethods]
impl PyDesignLaw {
    #[new]
    fn new(py: Python<'_>, text: &str, source: &str) -> PyResult<Self> { Ok(PyDesignLaw(py.detach(|| guarded(|| DesignLaw::from_json_str(text, source)))?)) }
    /// The blended law of design `params` (law-file JSON) and why it lies outside the law.
    fn law_for(&self, py: Python<'_>, params: &Bound<'_, PyParams>) -> PyResult<(String, Vec<String>)> {
        let p = params.get().0.clone();
        py.detach(|| guarded(|| self.0.law_file_for(&p).map(|(f, why)| (f.to_json(), why))))
    }
    /// A map predicted with the law blended for the configuration's parameters (`run_map`): (rows, why outside).
    #[pyo3(signature = (config_toml, *, out=None, resume=false, threads=None, n_modes=5, d_eff=None, s_dn="law", progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn predicted_map(&self, py: Python<'_>, config_toml: &str, out: Path, resume: bool, threads: Option<usize>, n_modes: usize, d_eff: Option<f64>, s_dn: &str, progress: Option<Py<PyAny>>) -> PyResult<(Vec<String>, Vec<String>)> {
        let (cfg, popts) = (guarded(|| MapConfig::from_toml_str(config_toml))?, options(n_modes, d_eff, if s_dn == "hb" { "law" } else { s_dn })?);
        let (law, why) = py.detach(|| guarded(|| self.0.law_for_rule(&cfg.effective_params(), s_dn != "hb")))?;
        Ok((run_map(py, &cfg, &law, &popts, out, resume, threads, progress)?, why))
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyDesignLaw>()?;
    let fs = [wrap_pyfunction!(slow_flow, m)?, wrap_pyfunction!(drift_law_evaluate, m)?, wrap_pyfunction!(hb_features, m)?, wrap_pyfunction!(predict, m)?];
    fs.into_iter().chain([wrap_pyfunction!(predicted_map, m)?, wrap_pyfunction!(design_coordinates, m)?]).try_for_each(|f| m.add_function(f))
}
