//! Model parameters of docs/model.md §1 (defaults = the paper's prototype), TOML I/O and validation.

use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};

/// Local contact solver used in each time step (docs/model.md §5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum ContactSolver {
    /// Exact solution of the local problem: active-set guess, enumeration of contact
    /// patterns as fallback, Gauss–Seidel as last resort.
    #[default]
    Fast,
    /// Augmented-Lagrangian / proximal-point nonlinear Gauss–Seidel exactly as in docs/model.md §5.
    Reference,
}

impl std::fmt::Display for ContactSolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ContactSolver::Fast => "fast",
            ContactSolver::Reference => "reference",
        })
    }
}

/// All model parameters, SI units. Field names are the TOML keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Free length of the beam L [m].
    pub length_m: f64,
    /// Beam thickness h [m].
    pub thickness_m: f64,
    /// Beam density ρ [kg/m³].
    pub density_kg_m3: f64,
    /// Beam mass of the free length ρAL [kg].
    pub beam_mass_kg: f64,
    /// Young's modulus E [Pa].
    pub youngs_modulus_pa: f64,
    /// Slider mass m [kg].
    pub slider_mass_kg: f64,
    /// Slider rotary inertia about its centre of mass J_C [kg m²].
    pub slider_inertia_kg_m2: f64,
    /// Horizontal distance B between the two contact points on one side [m].
    pub contact_spacing_m: f64,
    /// Distance d from the slider's geometric centre down to its centre of mass [m].
    pub com_offset_m: f64,
    /// Relative inner height of the slider opening R/h [-] (must exceed 1).
    pub gap_ratio: f64,
    /// Rotational clamping stiffness k_r at each end [N m/rad]; `inf` = ideal clamping.
    pub k_r_nm_per_rad: f64,
    /// Axial clamping stiffness k_t [N/m]; `inf` = ideal clamping.
    pub k_t_n_per_m: f64,
    /// Modal damping ratio D of all modes [-].
    pub damping_ratio: f64,
    /// Amplitude growth D₂ of the damping ratio [-] (micro-slip in the clamping): the modal
    /// damping ratio is D + 4 D₂ (w(L/2, t)/h)², so that single-term harmonic balance gives
    /// D̃(ã) = D + D₂ ã². 0 = linear damping (docs/model.md §2).
    pub damping_ratio_quadratic: f64,
    /// Static axial force H₀ in the beam [N], tension positive: adds H₀ K q to the modal forces
    /// (extension of docs/model.md §2). 0 = no preload.
    pub axial_preload_n: f64,
    /// Coulomb friction coefficient μ [-].
    pub friction_coefficient: f64,
    /// Normal restitution coefficient ε_N [-] (tangential ε_T = 0).
    pub restitution: f64,
    /// Gravitational acceleration g [m/s²], acting on the slider only.
    pub gravity_m_s2: f64,
    /// Tilt α of the frame about the transverse axis [rad] (extension of docs/model.md §3): the
    /// slider's gravity is (g sin α, −g cos α) in beam axes (x along the beam, z across), so
    /// α > 0 lowers the end x = L. 0 = level frame (the paper's set-up).
    pub tilt_rad: f64,
    /// Number of retained beam modes N (1..=20).
    pub n_modes: usize,
    /// Fixed time step Δt [s].
    pub dt_s: f64,
    /// Local contact solver: "fast" (exact, default) or "reference".
    pub contact_solver: ContactSolver,
    /// Relative stop tolerance of the Gauss–Seidel solver [-].
    pub solver_tol_rel: f64,
    /// Absolute stop tolerance of the Gauss–Seidel solver [N s].
    pub solver_tol_abs: f64,
    /// Iteration cap of the Gauss–Seidel solver (sweeps per step).
    pub solver_max_iter: usize,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            length_m: 0.140,
            thickness_m: 1.0e-3,
            density_kg_m3: 7683.0,
            beam_mass_kg: 15.1e-3,
            youngs_modulus_pa: 210e9,
            slider_mass_kg: 46.2e-3,
            slider_inertia_kg_m2: 3.15e-6,
            contact_spacing_m: 10e-3,
            com_offset_m: 4.1e-3,
            gap_ratio: 1.05,
            k_r_nm_per_rad: 125.0,
            k_t_n_per_m: 1.93e7,
            damping_ratio: 1.0e-3,
            damping_ratio_quadratic: 0.0,
            axial_preload_n: 0.0,
            friction_coefficient: 0.2,
            restitution: 0.5,
            gravity_m_s2: 9.81,
            tilt_rad: 0.0,
            n_modes: 5,
            dt_s: 2e-5,
            contact_solver: ContactSolver::Fast,
            solver_tol_rel: 1e-5,
            solver_tol_abs: 1e-7,
            solver_max_iter: 10_000,
        }
    }
}

/// Largest number of retained modes.
pub const MAX_MODES: usize = 20;

/// One row of the parameter table of docs/model.md §1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Field {
    /// Field name (TOML key).
    pub name: &'static str,
    /// Symbol in docs/model.md.
    pub symbol: &'static str,
    /// Meaning.
    pub meaning: &'static str,
    /// Unit ("-" when dimensionless).
    pub unit: &'static str,
    /// Allowed values, as [`Params::validate`] enforces them.
    pub allowed: &'static str,
}

/// The fields of [`Params`] in declaration order: the table of docs/model.md §1 (without the
/// defaults, which are [`Params::default`]).
pub const FIELDS: [Field; 25] = [
    Field { name: "length_m", symbol: "L", meaning: "Free length of the beam", unit: "m", allowed: "finite, > 0" },
    Field { name: "thickness_m", symbol: "h", meaning: "Beam thickness", unit: "m", allowed: "finite, > 0" },
    Field { name: "density_kg_m3", symbol: "ρ", meaning: "Beam density", unit: "kg/m³", allowed: "finite, > 0" },
    Field { name: "beam_mass_kg", symbol: "ρAL", meaning: "Beam mass of the free length", unit: "kg", allowed: "finite, > 0" },
    Field { name: "youngs_modulus_pa", symbol: "E", meaning: "Young's modulus", unit: "Pa", allowed: "finite, > 0" },
    Field { name: "slider_mass_kg", symbol: "m", meaning: "Slider mass", unit: "kg", allowed: "finite, > 0" },
    Field { name: "slider_inertia_kg_m2", symbol: "J_C", meaning: "Slider rotary inertia about its centre of mass", unit: "kg m²", allowed: "finite, > 0" },
    Field {
        name: "contact_spacing_m",
        symbol: "B",
        meaning: "Horizontal distance between the two contact points on one side",
        unit: "m",
        allowed: "finite, > 0, < `length_m`",
    },
    Field {
        name: "com_offset_m",
        symbol: "d",
        meaning: "Distance from the slider's geometric centre down to its centre of mass",
        unit: "m",
        allowed: "finite, ≥ 0",
    },
    Field {
        name: "gap_ratio",
        symbol: "R/h",
        meaning: "Relative inner height of the slider opening (> 1)",
        unit: "-",
        allowed: "finite, > 1, `gap_ratio`·`thickness_m` < `length_m`",
    },
    Field {
        name: "k_r_nm_per_rad",
        symbol: "k_r",
        meaning: "Rotational clamping stiffness at each end; `inf` = ideal clamping",
        unit: "N m/rad",
        allowed: "> 0, `inf` allowed (ideal clamping)",
    },
    Field {
        name: "k_t_n_per_m",
        symbol: "k_t",
        meaning: "Axial clamping stiffness; `inf` = ideal clamping",
        unit: "N/m",
        allowed: "> 0, `inf` allowed (ideal clamping)",
    },
    Field { name: "damping_ratio", symbol: "D", meaning: "Modal damping ratio of all modes", unit: "-", allowed: "finite, ≥ 0" },
    Field { name: "damping_ratio_quadratic", symbol: "D₂", meaning: "Amplitude growth of the damping ratio", unit: "-", allowed: "finite, ≥ 0" },
    Field {
        name: "axial_preload_n",
        symbol: "H₀",
        meaning: "Static axial force in the beam, tension positive (adds H0 K q to the modal forces)",
        unit: "N",
        allowed: "finite; a compression below the buckling load of the retained modes",
    },
    Field { name: "friction_coefficient", symbol: "μ", meaning: "Coulomb friction coefficient", unit: "-", allowed: "finite, ≥ 0" },
    Field { name: "restitution", symbol: "ε_N", meaning: "Normal restitution coefficient (tangential eps_T = 0)", unit: "-", allowed: "in [0, 1]" },
    Field { name: "gravity_m_s2", symbol: "g", meaning: "Gravitational acceleration, acting on the slider only", unit: "m/s²", allowed: "finite, ≥ 0" },
    Field { name: "tilt_rad", symbol: "α", meaning: "Tilt alpha of the frame about the transverse axis", unit: "rad", allowed: "finite, −π/2 < α < π/2" },
    Field { name: "n_modes", symbol: "N", meaning: "Number of retained beam modes (1..20)", unit: "-", allowed: "integer 1..20" },
    Field {
        name: "dt_s",
        symbol: "Δt",
        meaning: "Fixed time step",
        unit: "s",
        allowed: "finite, > 0; below the stability limit ≈ 2/ω_N of the highest mode; ≥ 10 steps per excitation period",
    },
    Field {
        name: "contact_solver",
        symbol: "—",
        meaning: "Local contact solver (docs/model.md §5): \"fast\" (exact) or \"reference\" (Gauss–Seidel of the paper)",
        unit: "-",
        allowed: "\"fast\" or \"reference\"",
    },
    Field { name: "solver_tol_rel", symbol: "—", meaning: "Relative stop tolerance of the Gauss–Seidel solver", unit: "-", allowed: "finite, > 0" },
    Field { name: "solver_tol_abs", symbol: "—", meaning: "Absolute stop tolerance of the Gauss–Seidel solver", unit: "N s", allowed: "finite, ≥ 0" },
    Field {
        name: "solver_max_iter", symbol: "—", meaning: "Iteration cap of the Gauss–Seidel solver (sweeps per step)", unit: "-", allowed: "integer ≥ 1"
    },
];

/// Calls of [`Params::validate`] in this process (every check of a parameter set counts).
static VALIDATIONS: AtomicU64 = AtomicU64::new(0);

/// How often [`Params::validate`] has run in this process: front ends check with it that a run
/// validates its parameters once (docs/model.md §1).
pub fn validation_count() -> u64 {
    VALIDATIONS.load(Ordering::Relaxed)
}

/// Parameters that passed [`Params::validate`] (docs/model.md §1): the type the runners take. A
/// reader gives plain [`Params`] (a TOML file, a front end's values, overrides applied); [`Valid::new`]
/// is the one place that makes this type, once per parameter set, and nothing checks it again.
#[derive(Debug, Clone, PartialEq)]
pub struct Valid(Params);

impl Valid {
    /// Validate `params`.
    pub fn new(params: Params) -> Result<Valid> {
        params.validate()?;
        Ok(Valid(params))
    }

    /// The parameters.
    pub fn get(&self) -> &Params {
        &self.0
    }

    /// The parameters, owned.
    pub fn into_inner(self) -> Params {
        self.0
    }
}

impl std::ops::Deref for Valid {
    type Target = Params;
    fn deref(&self) -> &Params {
        &self.0
    }
}

/// Parameters as an entry point of the core takes them: `&Params` (validated there, once) or
/// `&Valid` (already validated). [`ParamsArg::check`] validates the first kind and passes the
/// result on, so that the functions it calls check nothing again.
#[derive(Debug, Clone, Copy)]
pub struct ParamsArg<'a> {
    params: &'a Params,
    valid: bool,
}

impl<'a> ParamsArg<'a> {
    /// Validate unless already valid.
    pub fn check(self) -> Result<ParamsArg<'a>> {
        if !self.valid {
            self.params.validate()?;
        }
        Ok(ParamsArg { params: self.params, valid: true })
    }

    /// Parameters derived in the core from validated ones without leaving the allowed values.
    pub(crate) fn derived(params: &'a Params) -> ParamsArg<'a> {
        ParamsArg { params, valid: true }
    }

    /// The parameters.
    pub fn get(&self) -> &'a Params {
        self.params
    }
}

impl<'a> From<&'a Params> for ParamsArg<'a> {
    fn from(params: &'a Params) -> Self {
        ParamsArg { params, valid: false }
    }
}

impl<'a> From<&'a Valid> for ParamsArg<'a> {
    fn from(v: &'a Valid) -> Self {
        ParamsArg { params: &v.0, valid: true }
    }
}

impl Params {
    /// Parse TOML text (missing keys take their defaults, unknown or mistyped keys are errors); not
    /// validated: [`Valid::new`] checks the values, after any override ([`Params::with_values`]).
    pub fn from_toml_str(text: &str) -> Result<Self> {
        toml::from_str(text).map_err(|e| Error::Toml { path: None, message: e.to_string().trim_end().to_string() })
    }

    /// Read a TOML file ([`Params::from_toml_str`]; not validated).
    pub fn from_toml_file(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.display().to_string(), source })?;
        Self::from_toml_str(&text).map_err(|e| match e {
            Error::Toml { message, .. } => Error::Toml { path: Some(path.display().to_string()), message },
            other => other,
        })
    }

    /// Parameters from values by field name (defaults for the others), not validated: the
    /// values of a front end (Python keyword arguments). A value of the wrong type or an unknown
    /// name is an error naming the field.
    pub fn from_values(values: impl IntoIterator<Item = (String, toml::Value)>) -> Result<Params> {
        Params::default().with_values(values)
    }

    /// These parameters with some fields replaced by name (a file's values with a command line's
    /// overrides), not validated; errors as [`Params::from_values`].
    pub fn with_values(&self, values: impl IntoIterator<Item = (String, toml::Value)>) -> Result<Params> {
        let mut table = self.table();
        for (key, value) in values {
            let one = toml::Value::Table(toml::Table::from_iter([(key.clone(), value.clone())]));
            if let Err(e) = one.try_into::<Params>() {
                // The reason without the field name the deserialiser appends on a second line.
                let reason = e.to_string();
                let reason = reason.lines().next().unwrap_or_default().trim_end();
                let shown = match &value {
                    toml::Value::String(text) => format!("{text:?}"),
                    other => other.to_string(),
                };
                return Err(match FIELDS.iter().any(|f| f.name == key) {
                    true => Error::invalid(&key, shown, reason),
                    false => Error::invalid(&key, shown, &format!("unknown parameter; allowed names are {}", FIELDS.map(|f| f.name).join(", "))),
                });
            }
            table.insert(key, value);
        }
        toml::Value::Table(table).try_into::<Params>().map_err(|e| Error::Toml { path: None, message: e.to_string().trim_end().to_string() })
    }

    /// The values by field name (floats, integers and the solver's name), in [`FIELDS`] order.
    pub fn values(&self) -> Vec<(&'static str, toml::Value)> {
        let mut table = self.table();
        FIELDS.iter().filter_map(|f| table.remove(f.name).map(|v| (f.name, v))).collect()
    }

    fn table(&self) -> toml::Table {
        match toml::Value::try_from(self) {
            Ok(toml::Value::Table(t)) => t,
            _ => unreachable!("plain struct of numbers and strings always serialises to a table"),
        }
    }

    /// TOML text of these parameters (infinite stiffnesses are written as `inf`).
    pub fn to_toml_string(&self) -> String {
        toml::to_string(self).expect("plain struct of numbers and strings always serialises")
    }

    /// Write the parameters as a TOML file.
    pub fn to_toml_file(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        std::fs::write(path, self.to_toml_string()).map_err(|source| Error::Io { path: path.display().to_string(), source })
    }

    /// Check every field; the error names the field and the allowed range.
    pub fn validate(&self) -> Result<()> {
        VALIDATIONS.fetch_add(1, Ordering::Relaxed);
        let positive_finite = [
            ("length_m", self.length_m),
            ("thickness_m", self.thickness_m),
            ("density_kg_m3", self.density_kg_m3),
            ("beam_mass_kg", self.beam_mass_kg),
            ("youngs_modulus_pa", self.youngs_modulus_pa),
            ("slider_mass_kg", self.slider_mass_kg),
            ("slider_inertia_kg_m2", self.slider_inertia_kg_m2),
            ("contact_spacing_m", self.contact_spacing_m),
            ("dt_s", self.dt_s),
            ("solver_tol_rel", self.solver_tol_rel),
        ];
        for (field, v) in positive_finite {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid(field, v, "must be finite and > 0"));
            }
        }
        for (field, v) in [("k_r_nm_per_rad", self.k_r_nm_per_rad), ("k_t_n_per_m", self.k_t_n_per_m)] {
            if v.is_nan() || v <= 0.0 {
                return Err(Error::invalid(field, v, "must be > 0 (inf = ideal clamping)"));
            }
        }
        let non_negative_finite = [
            ("com_offset_m", self.com_offset_m),
            ("damping_ratio", self.damping_ratio),
            ("damping_ratio_quadratic", self.damping_ratio_quadratic),
            ("friction_coefficient", self.friction_coefficient),
            ("gravity_m_s2", self.gravity_m_s2),
            ("solver_tol_abs", self.solver_tol_abs),
        ];
        for (field, v) in non_negative_finite {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::invalid(field, v, "must be finite and >= 0"));
            }
        }
        if !self.axial_preload_n.is_finite() {
            return Err(Error::invalid("axial_preload_n", self.axial_preload_n, "must be finite"));
        }
        if !(self.gap_ratio.is_finite() && self.gap_ratio > 1.0) {
            return Err(Error::invalid("gap_ratio", self.gap_ratio, "R/h must be finite and > 1 (the slider needs a clearance)"));
        }
        if !(self.restitution.is_finite() && (0.0..=1.0).contains(&self.restitution)) {
            return Err(Error::invalid("restitution", self.restitution, "must lie in [0, 1]"));
        }
        if !(self.tilt_rad.is_finite() && self.tilt_rad.abs() < std::f64::consts::FRAC_PI_2) {
            return Err(Error::invalid("tilt_rad", self.tilt_rad, "must be finite with |tilt_rad| < pi/2"));
        }
        if !(1..=MAX_MODES).contains(&self.n_modes) {
            return Err(Error::invalid("n_modes", self.n_modes, "must lie in 1..=20"));
        }
        if self.solver_max_iter == 0 {
            return Err(Error::invalid("solver_max_iter", 0, "must be >= 1"));
        }
        if self.contact_spacing_m >= self.length_m {
            return Err(Error::invalid("contact_spacing_m", self.contact_spacing_m, "must be smaller than the beam length length_m"));
        }
        // The slider opening must be physically meaningful: d and R/2 small against L.
        if self.gap_ratio * self.thickness_m >= self.length_m {
            return Err(Error::invalid("gap_ratio", self.gap_ratio, "opening height R = gap_ratio * thickness_m must be smaller than length_m"));
        }
        crate::plausibility::check(&|field| self.plausibility_value(field))
    }

    /// The value of a field by its name, for [`crate::plausibility`] (NaN for a field it does not judge).
    pub fn plausibility_value(&self, field: &str) -> f64 {
        match field {
            "length_m" => self.length_m,
            "thickness_m" => self.thickness_m,
            "density_kg_m3" => self.density_kg_m3,
            "beam_mass_kg" => self.beam_mass_kg,
            "youngs_modulus_pa" => self.youngs_modulus_pa,
            "slider_mass_kg" => self.slider_mass_kg,
            "slider_inertia_kg_m2" => self.slider_inertia_kg_m2,
            "contact_spacing_m" => self.contact_spacing_m,
            "com_offset_m" => self.com_offset_m,
            "gap_ratio" => self.gap_ratio,
            "damping_ratio" => self.damping_ratio,
            "gravity_m_s2" => self.gravity_m_s2,
            "friction_coefficient" => self.friction_coefficient,
            _ => f64::NAN,
        }
    }

    /// Cross-section area A = ρAL / (ρ L) [m²].
    pub fn area_m2(&self) -> f64 {
        self.beam_mass_kg / (self.density_kg_m3 * self.length_m)
    }

    /// Second moment of area I = width h³ / 12 with width = A / h [m⁴].
    pub fn second_moment_m4(&self) -> f64 {
        let width = self.area_m2() / self.thickness_m;
        width * self.thickness_m.powi(3) / 12.0
    }

    /// Bending stiffness EI [N m²].
    pub fn bending_stiffness(&self) -> f64 {
        self.youngs_modulus_pa * self.second_moment_m4()
    }

    /// Axial stiffness of the beam in series with the clamping, k_ax = 1 / (L/(EA) + 1/k_t) [N/m].
    pub fn axial_stiffness(&self) -> f64 {
        1.0 / (self.length_m / (self.youngs_modulus_pa * self.area_m2()) + 1.0 / self.k_t_n_per_m)
    }

    /// Inner opening height R = (R/h) h [m].
    pub fn opening_m(&self) -> f64 {
        self.gap_ratio * self.thickness_m
    }

    /// Slider rotary inertia about its geometric centre, J_G = J_C + m d² [kg m²].
    pub fn slider_inertia_centre_kg_m2(&self) -> f64 {
        self.slider_inertia_kg_m2 + self.slider_mass_kg * self.com_offset_m * self.com_offset_m
    }

    /// First physical slider position s_min = B/(2L) (both contact points on the beam) [-].
    pub fn s_min(&self) -> f64 {
        0.5 * self.contact_spacing_m / self.length_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_round_trip_through_toml() {
        let p = Params::default();
        let q = Params::from_toml_str(&p.to_toml_string()).unwrap();
        assert_eq!(p, q);
    }

    #[test]
    fn infinite_clamping_round_trips() {
        let p = Params { k_r_nm_per_rad: f64::INFINITY, k_t_n_per_m: f64::INFINITY, ..Params::default() };
        let text = p.to_toml_string();
        assert!(text.contains("inf"));
        assert_eq!(Params::from_toml_str(&text).unwrap(), p);
    }

    #[test]
    fn partial_toml_takes_defaults_and_solver_name() {
        let p = Params::from_toml_str("n_modes = 3\ncontact_solver = \"reference\"\n").unwrap();
        assert_eq!(p.n_modes, 3);
        assert_eq!(p.contact_solver, ContactSolver::Reference);
        assert_eq!(p.length_m, 0.14);
    }

    #[test]
    fn unknown_and_garbled_keys_are_errors() {
        let e = Params::from_toml_str("lenght_m = 0.1\n").unwrap_err().to_string();
        assert!(e.contains("lenght_m"), "{e}");
        let e = Params::from_toml_str("length_m = \"long\"\n").unwrap_err().to_string();
        assert!(e.contains("length_m"), "{e}");
        let e = Params::from_toml_str("contact_solver = \"magic\"\n").unwrap_err().to_string();
        assert!(e.contains("contact_solver"), "{e}");
    }

    fn field_of(p: Params) -> String {
        match p.validate().unwrap_err() {
            Error::InvalidParameter { field, .. } => field,
            e => panic!("unexpected {e}"),
        }
    }

    #[test]
    fn every_invalid_class_names_its_field() {
        let d = Params::default;
        assert_eq!(field_of(Params { length_m: 0.0, ..d() }), "length_m");
        assert_eq!(field_of(Params { thickness_m: -1e-3, ..d() }), "thickness_m");
        assert_eq!(field_of(Params { slider_mass_kg: f64::NAN, ..d() }), "slider_mass_kg");
        assert_eq!(field_of(Params { youngs_modulus_pa: f64::INFINITY, ..d() }), "youngs_modulus_pa");
        assert_eq!(field_of(Params { dt_s: 0.0, ..d() }), "dt_s");
        assert_eq!(field_of(Params { k_r_nm_per_rad: 0.0, ..d() }), "k_r_nm_per_rad");
        assert_eq!(field_of(Params { k_t_n_per_m: f64::NAN, ..d() }), "k_t_n_per_m");
        assert_eq!(field_of(Params { gap_ratio: 1.0, ..d() }), "gap_ratio");
        assert_eq!(field_of(Params { gap_ratio: 0.9, ..d() }), "gap_ratio");
        assert_eq!(field_of(Params { friction_coefficient: -0.1, ..d() }), "friction_coefficient");
        assert_eq!(field_of(Params { restitution: 1.5, ..d() }), "restitution");
        assert_eq!(field_of(Params { restitution: -0.1, ..d() }), "restitution");
        assert_eq!(field_of(Params { n_modes: 0, ..d() }), "n_modes");
        assert_eq!(field_of(Params { n_modes: 21, ..d() }), "n_modes");
        assert_eq!(field_of(Params { damping_ratio: f64::NAN, ..d() }), "damping_ratio");
        assert_eq!(field_of(Params { solver_max_iter: 0, ..d() }), "solver_max_iter");
        assert_eq!(field_of(Params { damping_ratio_quadratic: -1e-4, ..d() }), "damping_ratio_quadratic");
        assert_eq!(field_of(Params { axial_preload_n: f64::NAN, ..d() }), "axial_preload_n");
        assert_eq!(field_of(Params { tilt_rad: 1.6, ..d() }), "tilt_rad");
        assert_eq!(field_of(Params { tilt_rad: f64::NAN, ..d() }), "tilt_rad");
    }

    #[test]
    fn fields_table_lists_every_field_in_order() {
        let names: Vec<&str> = Params::default().values().iter().map(|(k, _)| *k).collect();
        assert_eq!(names, FIELDS.map(|f| f.name).to_vec());
        assert_eq!(Params::default().table().len(), FIELDS.len());
    }

    #[test]
    fn values_convert_by_name_and_name_the_bad_field() {
        let p = Params::from_values([("n_modes".to_string(), toml::Value::Integer(3)), ("length_m".to_string(), toml::Value::Integer(1))]).unwrap();
        assert_eq!((p.n_modes, p.length_m), (3, 1.0));
        let e = Params::from_values([("n_modes".to_string(), toml::Value::Float(2.5))]).unwrap_err().to_string();
        assert!(e.contains("n_modes") && e.contains("expected"), "{e}");
        let e = Params::from_values([("bogus".to_string(), toml::Value::Float(2.5))]).unwrap_err().to_string();
        assert!(e.contains("bogus"), "{e}");
        let n = validation_count();
        let v = Valid::new(Params::default()).unwrap();
        assert!(validation_count() > n);
        assert!(ParamsArg::from(&v).check().is_ok());
    }

    #[test]
    fn derived_section_quantities() {
        let p = Params::default();
        let a = p.area_m2();
        assert!((a - 15.1e-3 / (7683.0 * 0.14)).abs() < 1e-18);
        assert!(p.axial_stiffness() < p.k_t_n_per_m);
    }

    // Units and plausibility (crate::plausibility), judged on parameter sets.
    use crate::plausibility;

    fn implausible(p: Params) -> Option<(&'static str, String)> {
        plausibility::findings(&|n| p.plausibility_value(n)).into_iter().next().map(|f| (f.field, f.why))
    }

    #[test]
    fn the_prototype_is_plausible() {
        assert_eq!(plausibility::findings(&|n| Params::default().plausibility_value(n)), vec![]);
    }

    #[test]
    fn values_in_the_wrong_unit_are_named_with_the_unit() {
        let d = Params::default();
        let (f, why) = implausible(Params { length_m: 140.0, ..d.clone() }).unwrap();
        assert_eq!(f, "length_m");
        assert!(why.contains("in mm?"), "{why}");
        let (f, why) = implausible(Params { slider_mass_kg: 46.2, ..d.clone() }).unwrap();
        assert_eq!(f, "slider_mass_kg");
        assert!(why.contains("in g?"), "{why}");
        let (f, why) = implausible(Params { youngs_modulus_pa: 210.0, ..d.clone() }).unwrap();
        assert_eq!(f, "youngs_modulus_pa");
        assert!(why.contains("in GPa?"), "{why}");
        let (f, why) = implausible(Params { density_kg_m3: 7.683, ..d.clone() }).unwrap();
        assert_eq!(f, "density_kg_m3");
        assert!(why.contains("g/cm³"), "{why}");
        let (f, why) = implausible(Params { beam_mass_kg: 15.1, ..d.clone() }).unwrap();
        assert_eq!(f, "beam_mass_kg");
        assert!(why.contains("in g?"), "{why}");
        let (f, why) = implausible(Params { slider_inertia_kg_m2: 3.15, ..d.clone() }).unwrap();
        assert_eq!(f, "slider_inertia_kg_m2");
        assert!(why.contains("kg mm²"), "{why}");
        let (f, _) = implausible(Params { com_offset_m: 4.1, ..d.clone() }).unwrap();
        assert_eq!(f, "com_offset_m");
    }

    #[test]
    fn validation_refuses_them_unless_overridden() {
        let p = Params { length_m: 140.0, ..Params::default() };
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains("`length_m`") && e.contains(plausibility::OVERRIDE_ENV), "{e}");
    }
}
