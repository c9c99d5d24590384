//! Binding of the virtual ENMA (`beamslider_core::enma`) and the beam's modal data (docs/model.md §9).

use beamslider_core::enma::{EnmaOptions, virtual_enma as core_enma};
use beamslider_core::{Error, Model};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::{PyMonitor, guarded, parse_params};

/// Virtual ENMA of the beam of `params_toml`; `options_json` holds the fields of the core's
/// `EnmaOptions` (missing ones take defaults). Returns the result as JSON text.
#[pyfunction]
#[pyo3(signature = (params_toml, options_json, progress=None))]
pub fn virtual_enma(py: Python<'_>, params_toml: &str, options_json: &str, progress: Option<Py<PyAny>>) -> PyResult<String> {
    let params = parse_params(params_toml)?;
    let opts: EnmaOptions = serde_json::from_str(options_json)
        .map_err(|e| PyValueError::new_err(format!("invalid ENMA options: {e}")))?;
    let mut monitor = PyMonitor::new(progress);
    let out = py.detach(|| {
        guarded(|| {
            let model = Model::new(params)?;
            let r = core_enma(&model, &opts, &mut monitor)?;
            serde_json::to_string(&r).map_err(|e| Error::Numerical(e.to_string()))
        })
    });
    if let Some(e) = monitor.error.take() {
        return Err(e);
    }
    out
}

/// Modal data of the linear beam: `omega_rad_s`, `gamma`, `k11_per_m`, `k_ax_n_per_m`,
/// `phi_mid` (φ₁(L/2)), `b_star_per_s2` (docs/model.md §9), the first mode with the axial preload
/// (`Beam::first_mode`: `omega1_preload_rad_s` from the eigenvalue problem, its Rayleigh estimate
/// `omega1_rayleigh_rad_s`, `b_star_preload_per_s2`, `mode1_vector`), `ei_n_m2` (EI), `ea_n` (EA),
/// the mode shape φ₁/φ₁(L/2) at 101 points x/L = 0 … 1 (`shape_x_over_l`, `shape_phi1`), the
/// matrix K (`k_matrix`, N×N rows) and φₘ at the requested `x_over_l` (`phi`, N rows).
#[pyfunction]
#[pyo3(signature = (params_toml, x_over_l=Vec::new()))]
pub fn beam_properties<'py>(py: Python<'py>, params_toml: &str, x_over_l: Vec<f64>) -> PyResult<Bound<'py, PyDict>> {
    let params = parse_params(params_toml)?;
    let thickness = params.thickness_m;
    let half = 0.5 * params.length_m;
    let model = py.detach(|| guarded(|| Model::new(params)))?;
    let b = &model.beam;
    let d = PyDict::new(py);
    d.set_item("omega_rad_s", b.omega.clone())?;
    d.set_item("gamma", b.gamma.clone())?;
    d.set_item("k11_per_m", b.k[0])?;
    d.set_item("k_ax_n_per_m", b.k_ax)?;
    d.set_item("phi_mid", b.phi_exact(0, half))?;
    d.set_item("b_star_per_s2", b.b_star(thickness))?;
    let first = b.first_mode(thickness);
    d.set_item("omega1_preload_rad_s", first.omega_rad_s)?;
    d.set_item("omega1_rayleigh_rad_s", first.omega_rayleigh_rad_s)?;
    d.set_item("b_star_preload_per_s2", first.b_star_per_s2)?;
    d.set_item("mode1_vector", first.vector)?;
    d.set_item("ei_n_m2", model.params.bending_stiffness())?;
    d.set_item("ea_n", model.params.youngs_modulus_pa * model.params.area_m2())?;
    let xi: Vec<f64> = (0..=100).map(|i| i as f64 / 100.0).collect();
    let mid = b.phi_exact(0, half);
    let shape: Vec<f64> = xi.iter().map(|&x| b.phi_exact(0, x * 2.0 * half) / mid).collect();
    d.set_item("shape_x_over_l", xi)?;
    d.set_item("shape_phi1", shape)?;
    let n = b.n;
    let kmat: Vec<Vec<f64>> = (0..n).map(|i| b.k[i * n..(i + 1) * n].to_vec()).collect();
    d.set_item("k_matrix", kmat)?;
    let phi: Vec<Vec<f64>> =
        (0..n).map(|m| x_over_l.iter().map(|&x| b.phi_exact(m, x * 2.0 * half)).collect()).collect();
    d.set_item("phi", phi)?;
    d.set_item("preload_n", b.preload_n)?;
    Ok(d)
}
