//! Slider of docs/model.md §3: planar rigid body (x_C, z_C, β) with four potential contact points.

use crate::arith::fma;
use crate::params::Params;

/// Number of potential contact points.
pub const N_CONTACTS: usize = 4;
/// Largest number of simultaneously closed contacts: all four points of the slider.
pub const MAX_CLOSED: usize = N_CONTACTS;
/// Size of the local contact problem's arrays: a normal and a tangential direction per contact.
pub const DIM: usize = 2 * MAX_CLOSED;

/// Top (+1) / bottom (−1) side of each contact point, counted counter-clockwise from top-left.
pub const ZETA_Z: [f64; N_CONTACTS] = [1.0, -1.0, -1.0, 1.0];
/// Left (−1) / right (+1) side of each contact point.
pub const ZETA_X: [f64; N_CONTACTS] = [-1.0, -1.0, 1.0, 1.0];

/// Rigid-body data of the slider and its contact geometry.
#[derive(Debug, Clone)]
pub struct Slider {
    /// Mass m [kg].
    pub mass: f64,
    /// Rotary inertia J_C [kg m²].
    pub inertia: f64,
    /// Position of each contact point relative to C in slider axes, r_CPᵢ = (ζXᵢ B/2, ζZᵢ R/2 + d).
    pub r_cp: [[f64; 2]; N_CONTACTS],
    /// Half the beam thickness h/2 [m].
    pub half_thickness: f64,
    /// d [m]: the geometric centre lies d above C.
    pub com_offset: f64,
}

impl Slider {
    /// Slider of the given parameters.
    pub fn new(p: &Params) -> Slider {
        let r = p.opening_m();
        let mut r_cp = [[0.0; 2]; N_CONTACTS];
        for i in 0..N_CONTACTS {
            r_cp[i] = [ZETA_X[i] * 0.5 * p.contact_spacing_m, ZETA_Z[i] * 0.5 * r + p.com_offset_m];
        }
        Slider { mass: p.slider_mass_kg, inertia: p.slider_inertia_kg_m2, r_cp, half_thickness: 0.5 * p.thickness_m, com_offset: p.com_offset_m }
    }

    /// Inertial position r_Pᵢ = (x, z) + A(β) r_CPᵢ with A(β) = [[cos β, sin β], [−sin β, cos β]].
    #[inline(always)]
    pub fn point(&self, i: usize, x: f64, z: f64, sin_b: f64, cos_b: f64) -> [f64; 2] {
        let [rx, rz] = self.r_cp[i];
        [fma(sin_b, rz, fma(cos_b, rx, x)), fma(cos_b, rz, fma(-sin_b, rx, z))]
    }

    /// All four points at once: (x₀..x₃, z₀..z₃), each as in [`Slider::point`].
    #[inline(always)]
    pub fn points(&self, x: f64, z: f64, sin_b: f64, cos_b: f64) -> ([f64; N_CONTACTS], [f64; N_CONTACTS]) {
        let mut xs = [0.0; N_CONTACTS];
        let mut zs = [0.0; N_CONTACTS];
        for i in 0..N_CONTACTS {
            let [rx, rz] = self.r_cp[i];
            xs[i] = fma(sin_b, rz, fma(cos_b, rx, x));
            zs[i] = fma(cos_b, rz, fma(-sin_b, rx, z));
        }
        (xs, zs)
    }

    /// A'(β) r_CPᵢ = [[0,1],[−1,0]] A(β) r_CPᵢ (derivative of the point position with β).
    #[inline(always)]
    pub fn point_dbeta(&self, i: usize, sin_b: f64, cos_b: f64) -> [f64; 2] {
        let [rx, rz] = self.r_cp[i];
        [fma(cos_b, rz, -sin_b * rx), fma(-sin_b, rz, -cos_b * rx)]
    }
}
