//! The plausibility of a parameter set (core `plausibility`, docs/model.md §1 "Units and plausibility").

use pyo3::prelude::*;

use crate::params::PyParams;

/// Every implausible value of `params` as (field, value, why), whether or not the override is set.
#[pyfunction]
fn plausibility_findings(params: &Bound<'_, PyParams>) -> Vec<(&'static str, f64, String)> {
    let p = params.get().0.get();
    beamslider_core::plausibility::findings(&|field| p.plausibility_value(field)).into_iter().map(|f| (f.field, f.value, f.why)).collect()
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("PLAUSIBILITY_OVERRIDE_ENV", beamslider_core::plausibility::OVERRIDE_ENV)?;
    crate::convert::export!(m, plausibility_findings);
    Ok(())
}
