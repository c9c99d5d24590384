//! The core's parameters (docs/model.md §1) as a Python object, validated once in the core
//! (`Valid::new`, the one place: after a file's values and the overrides are read); runs take the
//! object as it is (no TOML, no second check).

use beamslider_core::Params;
use beamslider_core::params::{FIELDS, Valid};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyString};

use crate::error::{CoreResult, guarded};

/// Validated model parameters (core `params::Valid`); immutable.
#[pyclass(name = "Params", module = "beamslider._core", frozen)]
pub struct PyParams(pub Valid);

/// A Python value as the core's value: bool, text, integer (also an integral float, which a
/// float field reads back exactly) or float; anything else is not a number.
fn value(key: &str, v: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    let bad = |why: &str| PyValueError::new_err(format!("invalid parameter `{key}` = {v}: {why}"));
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return v.extract::<String>().map(toml::Value::String).map_err(|_| bad("must be valid text (a lone surrogate is not)"));
    }
    if let Ok(i) = v.extract::<i64>() {
        return Ok(toml::Value::Integer(i));
    }
    match v.extract::<f64>() {
        Ok(x) if x.fract() == 0.0 && x.abs() < 9.0e15 && !(x == 0.0 && x.is_sign_negative()) => Ok(toml::Value::Integer(x as i64)),
        Ok(x) => Ok(toml::Value::Float(x)),
        Err(_) => Err(bad("must be a number")),
    }
}

/// Keyword arguments as the core's values by field name.
fn pairs(values: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, toml::Value)>> {
    let mut pairs = Vec::new();
    for (k, v) in values.into_iter().flatten() {
        let k: String = k.extract()?;
        pairs.push((k.clone(), value(&k, &v)?));
    }
    Ok(pairs)
}

#[pymethods]
impl PyParams {
    /// `Params(**values)`: missing fields take the defaults of docs/model.md §1.
    #[new]
    #[pyo3(signature = (**values))]
    fn new(values: Option<&Bound<'_, PyDict>>) -> CoreResult<Self> {
        let pairs = pairs(values)?;
        Ok(PyParams(guarded(|| Valid::new(Params::from_values(pairs)?))?))
    }

    /// Read a TOML parameter file (missing keys take their defaults), replace the fields given as
    /// keyword arguments (a command line's overrides), then validate once.
    #[staticmethod]
    #[pyo3(signature = (path, **overrides))]
    fn from_toml_file(path: std::path::PathBuf, overrides: Option<&Bound<'_, PyDict>>) -> CoreResult<Self> {
        let pairs = pairs(overrides)?;
        Ok(PyParams(guarded(|| Valid::new(Params::from_toml_file(&path)?.with_values(pairs)?))?))
    }

    /// Parse TOML parameter text, then validate once.
    #[staticmethod]
    fn from_toml_text(text: &str) -> CoreResult<Self> {
        Ok(PyParams(guarded(|| Valid::new(Params::from_toml_str(text)?))?))
    }

    /// Pickled as its canonical TOML text (validated again where it is unpickled: another process).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        Ok((slf.get_type().getattr("from_toml_text")?, (slf.get().0.to_toml_string(),)))
    }

    /// Field name → value (float, int or str), in the order of the fields.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, v) in self.0.values() {
            d.set_item(k, pythonize::pythonize(py, &v)?)?;
        }
        Ok(d)
    }

    /// The canonical TOML text the Rust tools write.
    fn toml_text(&self) -> String {
        self.0.to_toml_string()
    }

    /// The table of docs/model.md §1: (name, symbol, meaning, unit, allowed) per field, in order.
    #[staticmethod]
    fn fields() -> Vec<(&'static str, &'static str, &'static str, &'static str, &'static str)> {
        FIELDS.iter().map(|f| (f.name, f.symbol, f.meaning, f.unit, f.allowed)).collect()
    }
}

/// Times the core has validated a parameter set in this process (`Params::validate`).
#[pyfunction]
fn _validation_count() -> u64 {
    beamslider_core::params::validation_count()
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyParams>()?;
    crate::convert::export!(m, _validation_count);
    Ok(())
}
