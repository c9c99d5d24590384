//! Binding of layer (a) of issue 17 (`beamslider_core::superslow`): the harmonic-balance
//! super-slow manifold, its N = 1 closed form and the single-mode backbone. Types and errors only.

use beamslider_core::superslow::{HbBranch, HbOptions, HbSystem, closed_form_n1_scaled, hb_manifold as core_hb};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::{guarded, parse_params};

fn branch_dict<'py>(py: Python<'py>, b: &HbBranch) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("s", b.s.clone().into_pyarray(py))?;
    d.set_item("amplitude_h", b.amplitude_h.clone().into_pyarray(py))?;
    d.set_item("phase_rad", b.phase_rad.clone().into_pyarray(py))?;
    d.set_item("stable", b.stable.clone().into_pyarray(py))?;
    d.set_item("q_re", b.q_re.clone().into_pyarray(py))?;
    d.set_item("q_im", b.q_im.clone().into_pyarray(py))?;
    Ok(d)
}

/// HB super-slow manifold (issue 17 §2.3). Returns a dict: branches `high`, `low`, `middle`,
/// `up_run`, `down_run` (dicts of arrays `s`, `amplitude_h`, `phase_rad`, `stable`, `q_re`,
/// `q_im` flat (point, mode)), `folds_s`, `folds_amplitude_h`, `s_up`, `s_dn` (None when absent),
/// `s_res`, `s_range`, `n_modes`, `steps`, `warnings`, and with `sample_on_grid` the branches
/// solved on the grid: `s_grid`, `high_on_grid`, `low_on_grid` (NaN where absent).
#[pyfunction]
#[pyo3(signature = (params_toml, *, f_ex_hz, a_ex_m_s2, n_modes=5, harmonics=1, d_eff=None, omega1_factor=1.0, s_values=None, max_steps=20_000, max_step=0.05, sample_on_grid=false))]
#[allow(clippy::too_many_arguments)]
pub fn hb_manifold<'py>(
    py: Python<'py>,
    params_toml: &str,
    f_ex_hz: f64,
    a_ex_m_s2: f64,
    n_modes: usize,
    harmonics: usize,
    d_eff: Option<f64>,
    omega1_factor: f64,
    s_values: Option<Vec<f64>>,
    max_steps: usize,
    max_step: f64,
    sample_on_grid: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let params = parse_params(params_toml)?;
    let opts = HbOptions { n_modes, harmonics, d_eff, omega1_factor, s: s_values, max_steps, max_step, sample_on_grid };
    let m = py.detach(|| guarded(|| core_hb(&params, f_ex_hz, a_ex_m_s2, &opts)))?;
    let d = PyDict::new(py);
    d.set_item("high", branch_dict(py, &m.high)?)?;
    d.set_item("low", branch_dict(py, &m.low)?)?;
    d.set_item("middle", branch_dict(py, &m.middle)?)?;
    d.set_item("up_run", branch_dict(py, &m.up_run)?)?;
    d.set_item("down_run", branch_dict(py, &m.down_run)?)?;
    d.set_item("folds_s", m.folds.iter().map(|f| f.s).collect::<Vec<_>>().into_pyarray(py))?;
    d.set_item("folds_amplitude_h", m.folds.iter().map(|f| f.amplitude_h).collect::<Vec<_>>().into_pyarray(py))?;
    d.set_item("s_up", m.s_up)?;
    d.set_item("s_dn", m.s_dn)?;
    d.set_item("s_res", m.s_res.into_pyarray(py))?;
    d.set_item("s_range", m.s_range)?;
    d.set_item("n_modes", m.n_modes)?;
    d.set_item("steps", m.steps)?;
    d.set_item("warnings", m.warnings)?;
    d.set_item("s_grid", m.s_grid.into_pyarray(py))?;
    d.set_item("high_on_grid", m.high_on_grid.into_pyarray(py))?;
    d.set_item("low_on_grid", m.low_on_grid.into_pyarray(py))?;
    Ok(d)
}

/// N = 1 closed form (issue 17 §2.2) on `s_values`. Returns a dict: `s`, `roots_h` (n×3, NaN where
/// absent), `n_roots`, `discriminant`, `folds`, `s_up`, `s_dn`, `s_res`, `backbone_h`.
#[pyfunction]
#[pyo3(signature = (params_toml, *, f_ex_hz, a_ex_m_s2, s_values, d_eff=None, omega1_factor=1.0))]
pub fn hb_closed_form_n1<'py>(
    py: Python<'py>,
    params_toml: &str,
    f_ex_hz: f64,
    a_ex_m_s2: f64,
    s_values: Vec<f64>,
    d_eff: Option<f64>,
    omega1_factor: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let params = parse_params(params_toml)?;
    let c = py.detach(|| guarded(|| closed_form_n1_scaled(&params, f_ex_hz, a_ex_m_s2, &s_values, d_eff, omega1_factor)))?;
    let d = PyDict::new(py);
    d.set_item("s", c.s.into_pyarray(py))?;
    d.set_item("roots_h", c.roots_h.iter().flatten().copied().collect::<Vec<f64>>().into_pyarray(py))?;
    d.set_item("n_roots", c.n_roots.into_pyarray(py))?;
    d.set_item("discriminant", c.discriminant.into_pyarray(py))?;
    d.set_item("folds", c.folds.into_pyarray(py))?;
    d.set_item("s_up", c.s_up)?;
    d.set_item("s_dn", c.s_dn)?;
    d.set_item("s_res", c.s_res.into_pyarray(py))?;
    d.set_item("backbone_h", c.backbone_h.into_pyarray(py))?;
    Ok(d)
}

/// Single-mode backbone with the slider Ω_bb(Â, s) [rad/s] (issue 17 §2.2) at paired values.
#[pyfunction]
#[pyo3(signature = (params_toml, amplitude_h, s, omega1_factor=1.0))]
pub fn hb_backbone(py: Python<'_>, params_toml: &str, amplitude_h: Vec<f64>, s: Vec<f64>, omega1_factor: f64) -> PyResult<Vec<f64>> {
    let params = parse_params(params_toml)?;
    if amplitude_h.len() != s.len() {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "invalid parameter `s`: {} values for {} amplitudes (must be the same length)",
            s.len(),
            amplitude_h.len()
        )));
    }
    py.detach(|| {
        guarded(|| {
            let opts = HbOptions { n_modes: 1, omega1_factor, ..HbOptions::default() };
            let sys = HbSystem::new(&params, 100.0, 1.0, &opts)?;
            Ok(amplitude_h.iter().zip(&s).map(|(&a, &x)| sys.backbone_omega(a, x)).collect())
        })
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(hb_manifold, m)?)?;
    m.add_function(wrap_pyfunction!(hb_closed_form_n1, m)?)?;
    m.add_function(wrap_pyfunction!(hb_backbone, m)?)?;
    Ok(())
}
