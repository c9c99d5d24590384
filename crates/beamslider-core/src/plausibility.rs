//! Units and plausibility of a parameter set (docs/model.md §1, "Units and plausibility"): values
//! that pass the ranges of `Params::validate` but lie orders of magnitude away from every beam
//! and slider of this kind (a value typed in mm for m, g for kg, GPa for Pa, a percentage for a
//! ratio), and pairs of parameters that describe one quantity and disagree (the beam's ρ·A·L
//! against `beam_mass_kg` through the width it implies, the slider's inertia against its mass
//! and size). Each is refused naming the field, the value and the likely unit, unless the
//! environment variable [`OVERRIDE_ENV`] is set (a value that is meant).

use crate::error::{Error, Result};

/// Set to anything but "" or "0" to run parameter sets these checks refuse.
pub const OVERRIDE_ENV: &str = "BEAMSLIDER_ALLOW_IMPLAUSIBLE";

/// One implausible value: the field, its value and why (with the likely unit where one fits).
#[derive(Debug, Clone, PartialEq)]
pub struct Finding {
    /// The field (TOML key) to look at.
    pub field: &'static str,
    /// Its value.
    pub value: f64,
    /// Why the value is implausible, and what it likely is.
    pub why: String,
}

/// Plausible range of a field [lo, hi] (SI) and the units a value outside it may have been
/// typed in: (the unit's size in SI, its name).
struct Range {
    field: &'static str,
    lo: f64,
    hi: f64,
    what: &'static str,
    units: &'static [(f64, &'static str)],
}

/// The plausible ranges: a clamped strip of centimetres to metres (steel, aluminium, brass,
/// plastics) carrying a slider of up to kilograms (docs/model.md §1).
const RANGES: &[Range] = &[
    Range { field: "length_m", lo: 0.01, hi: 2.0, what: "beam length", units: &[(1e-3, "mm"), (1e-2, "cm")] },
    Range { field: "thickness_m", lo: 1e-5, hi: 0.02, what: "beam thickness", units: &[(1e-3, "mm"), (1e-6, "µm"), (1e-2, "cm")] },
    Range { field: "density_kg_m3", lo: 500.0, hi: 25_000.0, what: "density of a solid", units: &[(1e3, "g/cm³")] },
    Range { field: "youngs_modulus_pa", lo: 1e8, hi: 1.5e12, what: "Young's modulus of a solid", units: &[(1e9, "GPa"), (1e6, "MPa"), (1e6, "N/mm²")] },
    // No lower bound: a vanishing slider (1e-15 kg) is how the beam alone is modelled (docs/model.md §9).
    Range { field: "slider_mass_kg", lo: 0.0, hi: 5.0, what: "slider mass", units: &[(1e-3, "g")] },
    Range { field: "gap_ratio", lo: 1.0, hi: 10.0, what: "ratio of the opening to the thickness (R/h)", units: &[(1e-2, "per cent")] },
    Range { field: "damping_ratio", lo: 0.0, hi: 1.0, what: "modal damping ratio", units: &[(1e-2, "per cent")] },
    Range { field: "gravity_m_s2", lo: 0.0, hi: 100.0, what: "gravitational acceleration", units: &[(1e-2, "cm/s²")] },
    Range { field: "friction_coefficient", lo: 0.0, hi: 5.0, what: "Coulomb friction coefficient", units: &[(1e-2, "per cent")] },
];

/// A number for a message: six significant digits at most, trailing zeros dropped (`0.0462`,
/// `140`), in exponent form far from 1 (`1e300`).
fn short(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    if !(1e-4..1e7).contains(&x.abs()) {
        return format!("{x:e}");
    }
    let decimals = (5 - x.abs().log10().floor() as i32).max(0) as usize;
    let text = format!("{x:.decimals$}");
    if text.contains('.') { text.trim_end_matches('0').trim_end_matches('.').to_string() } else { text }
}

/// The plausible range of `r` in words.
fn range_text(r: &Range) -> String {
    if r.lo == 0.0 { format!("at most {} in SI units", short(r.hi)) } else { format!("{} to {} in SI units", short(r.lo), short(r.hi)) }
}

/// Why `value` is out of `r`, naming the unit that would bring it in range (if one does).
fn out_of_range(r: &Range, value: f64) -> Option<Finding> {
    if (r.lo..=r.hi).contains(&value) {
        return None;
    }
    let hint = r
        .units
        .iter()
        .find(|(size, _)| (r.lo..=r.hi).contains(&(value * size)))
        .map(|(size, unit)| format!("; is it in {unit}? ({} {unit} = {} in SI units)", short(value), short(value * size)))
        .unwrap_or_default();
    Some(Finding {
        field: r.field,
        value,
        why: format!("implausible {}: orders of magnitude from every beam and slider of this kind ({}){hint}", r.what, range_text(r)),
    })
}

/// Every implausible value of `p`, the single fields first, then the pairs.
/// `p` gives a field's value by its name (the caller's parameter set, which this module does not
/// know: `Params::plausibility_value`).
pub fn findings(p: &dyn Fn(&str) -> f64) -> Vec<Finding> {
    let mut out: Vec<Finding> = RANGES.iter().filter_map(|r| out_of_range(r, p(r.field))).collect();
    // The beam's mass, density, length and thickness describe one cross-section: the width
    // b = ρAL / (ρ L h) they imply must be that of a beam (at least a tenth of its thickness, at
    // most twice its length; the prototype's is 14 mm).
    let width = p("beam_mass_kg") / (p("density_kg_m3") * p("length_m") * p("thickness_m"));
    let (b_lo, b_hi) = (0.1 * p("thickness_m"), 2.0 * p("length_m"));
    if !(b_lo..=b_hi).contains(&width) {
        let grams = p("beam_mass_kg") * 1e-3 / (p("density_kg_m3") * p("length_m") * p("thickness_m"));
        let hint = if width > b_hi && (b_lo..=b_hi).contains(&grams) {
            format!("; is it in g? ({} g = {} kg gives a width of {} m)", short(p("beam_mass_kg")), short(p("beam_mass_kg") * 1e-3), short(grams))
        } else {
            String::new()
        };
        out.push(Finding {
            field: "beam_mass_kg",
            value: p("beam_mass_kg"),
            why: format!(
                "does not agree with density_kg_m3 * length_m * thickness_m: their cross-section would be {} m wide (width = beam_mass_kg / \
                 (density_kg_m3 * length_m * thickness_m); a beam's lies between a tenth of its thickness, {} m, and twice its length, {} m){hint}",
                short(width),
                short(b_lo),
                short(b_hi)
            ),
        });
    }
    // The slider's inertia and mass describe one body: its radius of gyration sqrt(J_C / m) lies
    // between a thirtieth of its contact spacing and the beam's length (the prototype's: 8.3 mm
    // for B = 10 mm).
    let gyration = (p("slider_inertia_kg_m2") / p("slider_mass_kg")).sqrt();
    let (r_lo, r_hi) = (p("contact_spacing_m") / 30.0, p("length_m"));
    if !(r_lo..=r_hi).contains(&gyration) {
        let hint = [(1e-6, "kg mm²"), (1e-7, "g cm²"), (1e-9, "g mm²")]
            .iter()
            .find(|(size, _)| (r_lo..=r_hi).contains(&(p("slider_inertia_kg_m2") * size / p("slider_mass_kg")).sqrt()))
            .map(|(size, unit)| format!("; is it in {unit}? ({} {unit} = {} kg m²)", short(p("slider_inertia_kg_m2")), short(p("slider_inertia_kg_m2") * size)))
            .unwrap_or_default();
        out.push(Finding {
            field: "slider_inertia_kg_m2",
            value: p("slider_inertia_kg_m2"),
            why: format!(
                "does not agree with slider_mass_kg: the radius of gyration sqrt(J_C / m) would be {} m (a slider's lies between a thirtieth of \
                 contact_spacing_m, {} m, and length_m, {} m){hint}",
                short(gyration),
                short(r_lo),
                short(r_hi)
            ),
        });
    }
    // The centre of mass lies within the slider, whose size is below the beam's length.
    if p("com_offset_m") > p("length_m") {
        let hint = if p("com_offset_m") * 1e-3 <= p("length_m") {
            format!("; is it in mm? ({} mm = {} m)", short(p("com_offset_m")), short(p("com_offset_m") * 1e-3))
        } else {
            String::new()
        };
        out.push(Finding {
            field: "com_offset_m",
            value: p("com_offset_m"),
            why: format!("implausible: the slider's centre of mass would lie farther from its centre than the beam is long ({} m){hint}", short(p("length_m"))),
        });
    }
    out
}

/// Whether [`OVERRIDE_ENV`] lets implausible parameter sets through.
pub fn overridden() -> bool {
    std::env::var_os(OVERRIDE_ENV).is_some_and(|v| !v.is_empty() && v != "0")
}

/// Refuse the first implausible value of `p` (see [`findings`]), naming the field, unless
/// [`OVERRIDE_ENV`] is set.
pub fn check(p: &dyn Fn(&str) -> f64) -> Result<()> {
    if let Some(f) = findings(p).into_iter().next()
        && !overridden()
    {
        return Err(Error::invalid(f.field, f.value, &format!("{}; if the value is meant, set {OVERRIDE_ENV}=1", f.why)));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_short() {
        assert_eq!([short(0.0462), short(140.0), short(0.14), short(1e300), short(2.5e-7)], ["0.0462", "140", "0.14", "1e300", "2.5e-7"]);
    }
}
