//! The reduced predictor (docs/model.md §6.3–6.5): drift and design laws as handles parsed once,
//! the law's features and jump-down rule, predicted points and maps (results as the core's structs).

use beamslider_core::dynamics::runner::SharedMonitor;
use beamslider_core::superslow::design_law::{DesignLaw, design_coordinates as core_coordinates};
use beamslider_core::superslow::law::{self, DriftLaw};
use beamslider_core::superslow::predict::{self as pred, MapDrift, PredictArgs, TableDrift};
use beamslider_core::superslow::slowflow::SlowBranch;
use beamslider_core::superslow::{HbOptions, predicted_map as map};
use beamslider_core::{MapRow, MapRunOptions};
use pyo3::exceptions::PyKeyboardInterrupt;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{kwargs, monitored, object, table};
use crate::error::{CoreResult, guarded, released};
use crate::{maprun::PyMapConfig, params::PyParams};

type Branch = (Vec<f64>, Vec<f64>, Vec<f64>);
type Table = (Branch, Branch, Option<f64>, Option<f64>);
type Path = Option<std::path::PathBuf>;

fn branch(b: Branch) -> SlowBranch {
    SlowBranch { s: b.0, amplitude_h: b.1, v_per_s: b.2 }
}

/// A drift law (docs/model.md §6.3) checked once: from a law file's content (a dict) or its JSON text.
#[pyclass(name = "DriftLaw", module = "beamslider._core", frozen)]
pub struct PyDriftLaw(DriftLaw);

#[pymethods]
impl PyDriftLaw {
    #[new]
    fn new(law: &Bound<'_, PyAny>) -> CoreResult<Self> {
        if let Ok(text) = law.extract::<String>() {
            return Ok(PyDriftLaw(guarded(|| DriftLaw::from_json_str(&text))?));
        }
        let value = table("law", law)?;
        Ok(PyDriftLaw(guarded(|| DriftLaw::from_json_value(value))?))
    }

    /// V and the outside flag per row of law inputs `x` (rows of FEATURES) with Λ_g `lift_off`.
    #[pyo3(signature = (*, high, x, lift_off))]
    fn evaluate(&self, high: bool, x: Vec<[f64; law::NF]>, lift_off: Vec<f64>) -> CoreResult<(Vec<f64>, Vec<bool>)> {
        Ok(guarded(|| self.0.evaluate_rows(high, &x, &lift_off))?)
    }

    /// The monostability vote at (ln Â_L at the HB fold, s_up).
    fn monostable(&self, x: [f64; 2]) -> bool {
        self.0.monostable_at(&x)
    }
}

/// The law's jump-down position (docs/model.md §6.4, core `predict::law_s_dn`) on an HB high branch given by its points (s, Â).
#[pyfunction]
#[pyo3(signature = (s, amplitude_h, *, f_ex_hz, a_ex_m_s2, rho_c, s_p, thickness_m))]
pub fn law_s_dn(s: Vec<f64>, amplitude_h: Vec<f64>, f_ex_hz: f64, a_ex_m_s2: f64, rho_c: f64, s_p: f64, thickness_m: f64) -> CoreResult<Option<f64>> {
    Ok(guarded(|| pred::law_s_dn_on_high(s, amplitude_h, f_ex_hz, a_ex_m_s2, rho_c, s_p, thickness_m))?)
}

/// Layer-(a) features (docs/model.md §6.3, core `law::features_at`) at `s` on one branch of the HB manifold:
/// the core's `Features` as a list of dicts.
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, high, s, n_modes=5, d_eff=None))]
pub fn hb_features<'py>(
    py: Python<'py>, params: &Bound<'_, PyParams>, f_ex_hz: f64, a_ex_m_s2: f64, high: bool, s: Vec<f64>, n_modes: usize, d_eff: Option<f64>,
) -> CoreResult<Bound<'py, PyAny>> {
    let (params, opts) = (params.get().0.clone(), HbOptions { n_modes, d_eff, ..HbOptions::default() });
    object(py, &released(py, || law::features_at(&params, f_ex_hz, a_ex_m_s2, &opts, high, &s))?)
}

/// One operating point by the reduced model (core `predict::predict`): the core's `PointPrediction` as a dict;
/// `options`: the core's `PredictArgs`.
#[pyfunction]
#[pyo3(signature = (params, *, f_ex_hz, a_ex_m_s2, s0, t_end_s, law=None, table=None, **options))]
pub fn predict<'py>(
    py: Python<'py>, params: &Bound<'_, PyParams>, f_ex_hz: f64, a_ex_m_s2: f64, s0: f64, t_end_s: f64, law: Option<&Bound<'_, PyDriftLaw>>,
    table: Option<Table>, options: Option<&Bound<'_, PyDict>>,
) -> CoreResult<Bound<'py, PyAny>> {
    let args: PredictArgs = kwargs(py, options)?;
    let (params, law) = (params.get().0.clone(), law.map(|l| &l.get().0));
    let table = table.map(|(lo, hi, su, sd)| TableDrift::new(branch(lo), branch(hi), su, sd));
    object(py, &released(py, || pred::predict(&params, law, table.as_ref(), f_ex_hz, a_ex_m_s2, s0, t_end_s, &args))?)
}

/// The drift of a predicted map: a drift law, or a design law blended for the map's parameters.
#[derive(FromPyObject)]
pub enum MapLaw<'py> {
    Drift(Bound<'py, PyDriftLaw>),
    Design(Bound<'py, PyDesignLaw>),
}

/// A map predicted by the core (`predicted_map::run_predicted_map`) with a drift law or a design law blended for its
/// parameters (`s_dn="hb"`: without its learnt jump-down); `options`: the core's `PredictArgs`.
#[pyfunction]
#[pyo3(signature = (config, law, *, out=None, resume=false, threads=None, progress=None, **options))]
pub fn predicted_map(
    py: Python<'_>, config: &Bound<'_, PyMapConfig>, law: MapLaw<'_>, out: Path, resume: bool, threads: Option<usize>, progress: Option<Py<PyAny>>,
    options: Option<&Bound<'_, PyDict>>,
) -> CoreResult<(Vec<String>, Vec<String>)> {
    let (cfg, args, opts): (_, PredictArgs, _) = (&config.get().cfg, kwargs(py, options)?, MapRunOptions { out, resume, threads, extend: false });
    let drift = match &law {
        MapLaw::Drift(l) => MapDrift::Law(&l.get().0),
        MapLaw::Design(d) => MapDrift::Design(&d.get().0),
    };
    let run = |m: &SharedMonitor| map::predicted_map(cfg, drift, &args, &opts, m.cancel(), &|n: usize, t: usize, _: &MapRow| m.report(n as f64, t as f64));
    let (outcome, why) = monitored(py, progress, None, run)?;
    if outcome.cancelled {
        return Err(PyKeyboardInterrupt::new_err("map interrupted").into());
    }
    Ok((outcome.rows.iter().map(MapRow::to_json).collect(), why))
}

/// Design coordinates (docs/model.md §6.5) of `params` relative to `base`, in the core's order.
#[pyfunction]
pub fn design_coordinates(py: Python<'_>, params: &Bound<'_, PyParams>, base: &Bound<'_, PyParams>) -> CoreResult<Vec<f64>> {
    let (p, b) = (params.get().0.clone(), base.get().0.clone());
    released(py, || core_coordinates(&p, &b).map(|c| c.to_vec()))
}

/// A design law (docs/model.md §6.5) checked once: from its file's JSON text or content (a dict; `source` names it).
#[pyclass(name = "DesignLaw", module = "beamslider._core", frozen)]
pub struct PyDesignLaw(DesignLaw);

#[pymethods]
impl PyDesignLaw {
    #[new]
    fn new(py: Python<'_>, law: &Bound<'_, PyAny>, source: &str) -> CoreResult<Self> {
        if let Ok(text) = law.extract::<String>() {
            return Ok(PyDesignLaw(released(py, || DesignLaw::from_json_str(&text, source))?));
        }
        let value = table("law", law)?;
        Ok(PyDesignLaw(released(py, || DesignLaw::from_json_value(value, source))?))
    }

    /// The blended law of design `params` (a law file's content, as a dict) and why it lies outside the law.
    fn law_for<'py>(&self, py: Python<'py>, params: &Bound<'_, PyParams>) -> CoreResult<(Bound<'py, PyAny>, Vec<String>)> {
        let p = params.get().0.clone();
        let (file, why) = released(py, || self.0.law_file_for(&p))?;
        Ok((object(py, &file)?, why))
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyDesignLaw>()?;
    m.add_class::<PyDriftLaw>()?;
    crate::convert::export!(m, law_s_dn, hb_features, predict, predicted_map, design_coordinates);
    Ok(())
}
