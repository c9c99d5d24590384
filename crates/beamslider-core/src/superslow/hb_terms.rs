//! The coefficients of the harmonic-balance system of docs/model.md §6.4 at one excitation (the
//! beam with the slider rigidly attached at s) and the continuation parameter: what the
//! single-term residual (`hb`) and the multi-harmonic one (`mhb`) both read. A leaf: it uses no
//! other module of the HB manifold.

use nalgebra::{DMatrix, DVector};

use crate::physics::beam::Beam;

/// Coefficients of M(s) q̈ + C q̇ + Λ q + f_nl(q) = Γ(s) a_ex cos Ωt (docs/model.md §6.4) and the
/// scales of the unknowns, built by [`super::HbSystem::new`].
#[derive(Debug, Clone)]
pub struct HbTerms {
    pub(super) beam: std::sync::Arc<Beam>,
    /// Number of modes N.
    pub(super) n: usize,
    pub(super) length: f64,
    pub(super) thickness: f64,
    /// Ω [rad/s].
    pub(super) omega_ex: f64,
    pub(super) a_ex: f64,
    /// Slider mass m and inertia J_G about the contact line's centre.
    pub(super) mass: f64,
    pub(super) j_g: f64,
    /// Λ = diag(ωₙ²) + H₀K (ω₁ scaled by the detuning factor).
    pub(super) lam: DMatrix<f64>,
    /// Ω·2Dₙωₙ: the damping term's diagonal.
    pub(super) e_diag: Vec<f64>,
    pub(super) kmat: DMatrix<f64>,
    pub(super) k_ax: f64,
    pub(super) gamma: DVector<f64>,
    /// Amplitude-dependent damping D₂: per-mode coefficients and Φ(L/2) (None without D₂).
    pub(super) d2: Option<(Vec<f64>, Vec<f64>)>,
    /// Φ(4L/7): the amplitude's reference point.
    pub(super) p47: Vec<f64>,
    /// Scales of the unknowns (Q/q_ref) and of the residual (R/f_ref).
    pub(super) q_ref: f64,
    pub(super) f_ref: f64,
}

/// The continuation parameter of the HB system.
#[derive(Debug, Clone, Copy)]
pub(super) enum Param {
    /// Continuation parameter s; forcing scaled by `load`.
    S { load: f64 },
    /// Continuation parameter: load factor at fixed s.
    Load { s: f64 },
}
