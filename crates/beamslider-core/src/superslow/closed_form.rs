//! The single-mode, single-harmonic closed form of the super-slow manifold (docs/model.md §6.4).

use super::continuation::check_grid;
use super::hb::{check_d_eff, check_excitation};
use super::roots::{zeros_from_values, zeros_on_grid};
use crate::error::{Error, Result};
use crate::params::Params;
use crate::physics::beam::Beam;

/// The single-mode closed form (docs/model.md §6.4) on an s-grid.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct ClosedFormN1 {
    /// Slider positions [-].
    pub s: Vec<f64>,
    /// Â = |φ₁(4L/7)| a / h of the real roots, ascending (low, middle, high); NaN where absent.
    /// With one root it is the first entry.
    pub roots_h: Vec<[f64; 3]>,
    /// Number of real (all positive) roots: 1 or 3 (2 only at a fold exactly on the grid).
    pub n_roots: Vec<usize>,
    /// Discriminant Δ of the cubic in the scaled unknown x = A b/ω² (sign as Δ).
    pub discriminant: Vec<f64>,
    /// Folds: zeros of Δ(s), bracketed on the grid and refined by Brent's method, ascending.
    pub folds: Vec<f64>,
    /// Jump-up position: the first fold (the low branch ends there).
    pub s_up: Option<f64>,
    /// Jump-down position: the second fold (None if the high branch reaches the grid's end).
    pub s_dn: Option<f64>,
    /// Linear resonance: M₁(s_res) = ω²/Ω² (with the preload, ω² → ω² + H₀K₁₁).
    pub s_res: Vec<f64>,
    /// High-branch estimate away from its end, a_H = √(4(M₁Ω² − ω²)/(3b)), as Â (NaN where
    /// M₁Ω² ≤ ω²).
    pub backbone_h: Vec<f64>,
}

/// Coefficients of the scaled cubic (9/16)x³ + β x² + γ x − κ = 0 at s, and the scale
/// Â per √x.
pub(super) struct Cubic {
    pub(super) beta: f64,
    pub(super) gamma: f64,
    pub(super) kappa: f64,
}

pub(super) struct N1<'a> {
    pub(super) omega2: f64,
    pub(super) b: f64,
    pub(super) c: f64,
    pub(super) gamma1: f64,
    pub(super) mass: f64,
    pub(super) j_g: f64,
    pub(super) om2: f64,
    pub(super) a_ex: f64,
    pub(super) length: f64,
    pub(super) amp_scale: f64,
    pub(super) beam: &'a Beam,
}

impl N1<'_> {
    fn m1(&self, s: f64) -> (f64, f64) {
        let x = s * self.length;
        let phi = self.beam.phi_exact(0, x);
        let dphi = self.beam.dphi_exact(0, x);
        (1.0 + self.mass * phi * phi + self.j_g * dphi * dphi, phi)
    }

    fn cubic(&self, s: f64) -> Cubic {
        let (m1, phi) = self.m1(s);
        let delta = (self.omega2 - m1 * self.om2) / self.omega2;
        let cc = self.c / self.omega2;
        let f = (self.gamma1 + self.mass * phi) * self.a_ex;
        Cubic { beta: 1.5 * delta, gamma: delta * delta + cc * cc, kappa: f * f * self.b / self.omega2.powi(3) }
    }
}

pub(super) fn discriminant(c: &Cubic) -> f64 {
    // Δ = 18αβγκ' − 4β³κ' + β²γ² − 4αγ³ − 27α²κ'² for αx³ + βx² + γx + κ', κ' = −κ.
    let (al, be, ga, ka) = (9.0 / 16.0, c.beta, c.gamma, -c.kappa);
    18.0 * al * be * ga * ka - 4.0 * be.powi(3) * ka + be * be * ga * ga - 4.0 * al * ga.powi(3) - 27.0 * al * al * ka * ka
}

/// Real roots of (9/16)x³ + βx² + γx − κ, ascending, each polished by Newton's method.
pub(super) fn cubic_roots(c: &Cubic) -> Vec<f64> {
    let al = 9.0 / 16.0;
    let (a2, a1, a0) = (c.beta / al, c.gamma / al, -c.kappa / al);
    // Depressed cubic x = t − a2/3: t³ + pt + q = 0.
    let p = a1 - a2 * a2 / 3.0;
    let q = 2.0 * a2.powi(3) / 27.0 - a2 * a1 / 3.0 + a0;
    let shift = -a2 / 3.0;
    let disc = (q / 2.0).powi(2) + (p / 3.0).powi(3);
    let mut roots = if disc > 0.0 {
        let sq = disc.sqrt();
        let u = (-q / 2.0 + sq).cbrt();
        let v = (-q / 2.0 - sq).cbrt();
        vec![u + v + shift]
    } else if p == 0.0 {
        vec![(-q).cbrt() + shift]
    } else {
        let r = (-p / 3.0).sqrt();
        let arg = (3.0 * q / (2.0 * p * r)).clamp(-1.0, 1.0);
        let th = arg.acos() / 3.0;
        (0..3).map(|k| 2.0 * r * (th - 2.0 * std::f64::consts::PI * k as f64 / 3.0).cos() + shift).collect()
    };
    let poly = |x: f64| ((al * x + c.beta) * x + c.gamma) * x - c.kappa;
    let dpoly = |x: f64| (3.0 * al * x + 2.0 * c.beta) * x + c.gamma;
    for x in roots.iter_mut() {
        for _ in 0..3 {
            let d = dpoly(*x);
            if d == 0.0 {
                break;
            }
            let nx = *x - poly(*x) / d;
            if !nx.is_finite() {
                break;
            }
            *x = nx;
        }
    }
    roots.sort_by(f64::total_cmp);
    roots
}

/// The N = 1 closed form (docs/model.md §6.4) on the grid `s` (strictly increasing, within
/// [B/(2L), 1 − B/(2L)]). Requires damping_ratio_quadratic = 0 (the cubic assumes linear damping).
pub fn closed_form_n1(params: &Params, f_ex_hz: f64, a_ex: f64, s: &[f64], d_eff: Option<f64>) -> Result<ClosedFormN1> {
    closed_form_n1_scaled(params, f_ex_hz, a_ex, s, d_eff, 1.0)
}

/// [`closed_form_n1`] with ω₁ → `omega1_factor`·ω₁.
pub fn closed_form_n1_scaled(params: &Params, f_ex_hz: f64, a_ex: f64, s: &[f64], d_eff: Option<f64>, omega1_factor: f64) -> Result<ClosedFormN1> {
    params.validate()?;
    check_inputs(params, f_ex_hz, a_ex, s, d_eff)?;
    let beam = Beam::new(&Params { n_modes: 1, ..params.clone() })?;
    closed_form_n1_with_beam(&beam, params, f_ex_hz, a_ex, s, d_eff, omega1_factor)
}

/// The closed form's inputs: excitation, d_eff, linear damping only, the grid within the beam.
fn check_inputs(params: &Params, f_ex_hz: f64, a_ex: f64, s: &[f64], d_eff: Option<f64>) -> Result<()> {
    check_excitation(f_ex_hz, a_ex)?;
    check_d_eff(d_eff)?;
    if params.damping_ratio_quadratic != 0.0 {
        return Err(Error::invalid(
            "damping_ratio_quadratic",
            params.damping_ratio_quadratic,
            "the N = 1 closed form assumes linear damping (use hb_manifold with n_modes = 1)",
        ));
    }
    check_grid(s, params.s_min(), 1.0 - params.s_min())?;
    Ok(())
}

/// [`closed_form_n1_scaled`] with the beam's modes given (computed once per parameter set:
/// `Beam::new` costs more than the closed form itself). `beam` must come from `params`.
pub fn closed_form_n1_with_beam(
    beam: &Beam, params: &Params, f_ex_hz: f64, a_ex: f64, s: &[f64], d_eff: Option<f64>, omega1_factor: f64,
) -> Result<ClosedFormN1> {
    check_inputs(params, f_ex_hz, a_ex, s, d_eff)?;
    let n1 = n1_model(beam, params, f_ex_hz, a_ex, d_eff, omega1_factor)?;
    let mut out = ClosedFormN1 { s: s.to_vec(), ..Default::default() };
    out.roots_h.reserve(s.len());
    for &si in s {
        let c = n1.cubic(si);
        let d = discriminant(&c);
        let r = cubic_roots(&c);
        let mut row = [f64::NAN; 3];
        let mut k = 0;
        for x in r.iter().filter(|x| **x > 0.0) {
            row[k] = n1.amp_scale * x.sqrt();
            k += 1;
        }
        out.n_roots.push(k);
        out.roots_h.push(row);
        out.discriminant.push(d);
        let (m1, _) = n1.m1(si);
        let x_h = 4.0 * (m1 * n1.om2 - n1.omega2) / (3.0 * n1.b);
        out.backbone_h.push(if x_h > 0.0 { n1.amp_scale * (x_h * n1.b / n1.omega2).sqrt() } else { f64::NAN });
    }
    let f = |x: f64| discriminant(&n1.cubic(x));
    out.folds = zeros_from_values(&f, s, &out.discriminant, 1e-14);
    out.folds.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    out.s_up = out.folds.first().copied();
    out.s_dn = out.folds.get(1).copied();
    let g = |x: f64| n1.m1(x).0 * n1.om2 - n1.omega2;
    out.s_res = zeros_on_grid(&g, s, 1e-14);
    Ok(out)
}

pub(super) fn n1_model<'a>(beam: &'a Beam, params: &Params, f_ex_hz: f64, a_ex: f64, d_eff: Option<f64>, omega1_factor: f64) -> Result<N1<'a>> {
    if !(omega1_factor.is_finite() && omega1_factor > 0.0) {
        return Err(Error::invalid("omega1_factor", omega1_factor, "must be finite and > 0"));
    }
    let p = params;
    let om = 2.0 * std::f64::consts::PI * f_ex_hz;
    let w1 = beam.omega[0] * omega1_factor;
    let omega2 = w1 * w1 + beam.preload_n * beam.k[0];
    let d = d_eff.unwrap_or(p.damping_ratio);
    let b = beam.hardening_b();
    let p47 = beam.phi_exact(0, 4.0 / 7.0 * p.length_m).abs();
    Ok(N1 {
        omega2,
        b,
        c: 2.0 * d * w1 * om,
        gamma1: beam.gamma[0],
        mass: p.slider_mass_kg,
        j_g: p.slider_inertia_centre_kg_m2(),
        om2: om * om,
        a_ex,
        length: p.length_m,
        // Â = |φ₁(4L/7)| √A / h with A = x ω²/b.
        amp_scale: p47 * (omega2 / b).sqrt() / p.thickness_m,
        beam,
    })
}

/// The single-mode backbone with the slider Ω_bb(Â, s) [rad/s] (docs/model.md §6.4,
/// [`HbSystem::backbone_omega`]) at paired values of `amplitude_h` and `s`, ω₁ scaled by
/// `omega1_factor`.
pub fn backbone<'a>(params: impl Into<crate::params::ParamsArg<'a>>, amplitude_h: &[f64], s: &[f64], omega1_factor: f64) -> Result<Vec<f64>> {
    if amplitude_h.len() != s.len() {
        return Err(Error::invalid("s", format!("{} values for {} amplitudes", s.len(), amplitude_h.len()), "must be the same length"));
    }
    let opts = super::branch::HbOptions { n_modes: 1, omega1_factor, ..super::branch::HbOptions::default() };
    let sys = super::hb::HbSystem::new(params, 100.0, 1.0, &opts)?;
    Ok(amplitude_h.iter().zip(s).map(|(&a, &x)| sys.backbone_omega(a, x)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cubic_roots_satisfy_the_polynomial() {
        for (beta, gamma, kappa) in [(-1.5, 1.0, 0.01), (1.5, 1.0, 0.3), (-3.0, 4.0, 0.5), (0.0, 1e-9, 1e-12)] {
            let c = Cubic { beta, gamma, kappa };
            let r = cubic_roots(&c);
            let d = discriminant(&c);
            assert_eq!(r.len(), if d > 0.0 { 3 } else { 1 }, "{beta} {gamma} {kappa}: {r:?} Δ = {d}");
            for x in r {
                let v = ((9.0 / 16.0 * x + beta) * x + gamma) * x - kappa;
                assert!(v.abs() < 1e-12 * (1.0 + kappa.abs()), "{x}: {v}");
                assert!(x > 0.0, "real roots are positive");
            }
        }
    }
}
