//! The linear beam's modal data in one record (docs/model.md §2 and §9): frequencies, modal
//! constants, the first mode with the axial preload, and the mode shapes normalised and sampled
//! for figures and fits; what a front end shows of a beam, computed here once.

use serde::Serialize;

use crate::params::Params;
use crate::physics::beam::Beam;

/// Samples of the normalised first mode shape φ₁/φ₁(L/2): x/L = 0, 1/100, …, 1.
pub const SHAPE_POINTS: usize = 100;

/// Modal data of the linear beam of `params` (field names carry their units).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BeamProperties {
    /// Natural angular frequencies ω₁..ω_N [rad/s].
    pub omega_rad_s: Vec<f64>,
    /// Modal coupling constants γ₁..γ_N.
    pub gamma: Vec<f64>,
    /// K₁₁ [1/m].
    pub k11_per_m: f64,
    /// Axial stiffness of the clamping [N/m].
    pub k_ax_n_per_m: f64,
    /// φ₁(L/2).
    pub phi_mid: f64,
    /// Hardening coefficient b* [1/s²] (docs/model.md §9).
    pub b_star_per_s2: f64,
    /// ω₁ with the axial preload (eigenvalue problem) [rad/s].
    pub omega1_preload_rad_s: f64,
    /// Rayleigh estimate of ω₁ with the preload [rad/s].
    pub omega1_rayleigh_rad_s: f64,
    /// b* with the preload [1/s²].
    pub b_star_preload_per_s2: f64,
    /// Modal vector of the first mode with the preload.
    pub mode1_vector: Vec<f64>,
    /// Bending stiffness EI [N m²].
    pub ei_n_m2: f64,
    /// Axial stiffness EA [N].
    pub ea_n: f64,
    /// x/L of the shape samples.
    pub shape_x_over_l: Vec<f64>,
    /// φ₁/φ₁(L/2) at `shape_x_over_l`.
    pub shape_phi1: Vec<f64>,
    /// The matrix K, N rows.
    pub k_matrix: Vec<Vec<f64>>,
    /// φₘ at the requested x/L, N rows.
    pub phi: Vec<Vec<f64>>,
    /// Axial preload [N].
    pub preload_n: f64,
}

impl BeamProperties {
    /// The data of `beam` built from `p`, with the mode shapes sampled at `x_over_l`.
    pub fn of(beam: &Beam, p: &Params, x_over_l: &[f64]) -> BeamProperties {
        let first = beam.first_mode(p.thickness_m);
        let (shape_x_over_l, shape_phi1) = beam.mode1_shape(SHAPE_POINTS);
        BeamProperties {
            omega_rad_s: beam.omega.clone(),
            gamma: beam.gamma.clone(),
            k11_per_m: beam.k[0],
            k_ax_n_per_m: beam.k_ax,
            phi_mid: beam.phi_exact(0, 0.5 * p.length_m),
            b_star_per_s2: beam.b_star(p.thickness_m),
            omega1_preload_rad_s: first.omega_rad_s,
            omega1_rayleigh_rad_s: first.omega_rayleigh_rad_s,
            b_star_preload_per_s2: first.b_star_per_s2,
            mode1_vector: first.vector,
            ei_n_m2: p.bending_stiffness(),
            ea_n: p.youngs_modulus_pa * p.area_m2(),
            shape_x_over_l,
            shape_phi1,
            k_matrix: beam.k_rows(),
            phi: beam.phi_at(x_over_l),
            preload_n: beam.preload_n,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Valid;

    #[test]
    fn shape_is_normalised_at_mid_span_and_rows_are_per_mode() {
        let p = Params::default();
        let m = crate::Model::of(&Valid::new(p.clone()).unwrap()).unwrap();
        let b = BeamProperties::of(&m.beam, &p, &[0.25, 0.5]);
        assert_eq!(b.shape_phi1.len(), SHAPE_POINTS + 1);
        assert!((b.shape_phi1[SHAPE_POINTS / 2] - 1.0).abs() < 1e-12);
        assert_eq!(b.k_matrix.len(), m.beam.n);
        assert_eq!(b.phi.len(), m.beam.n);
        assert_eq!(b.phi[0][1], b.phi_mid);
    }
}
