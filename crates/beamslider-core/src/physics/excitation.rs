//! Harmonic base excitation of docs/model.md §2: the clamped ends move with w₀(t) = (a_ex/Ω²) cos Ωt,
//! Ω = 2π f_ex, so the base acceleration is ẅ₀ = −a_ex cos Ωt. One type for the excitation
//! ([`Excitation`]) and one for its value at an instant as the contact kinematics need it
//! ([`BaseState`]).

use crate::error::{Error, Result};

/// Harmonic base excitation: ẅ₀ = −a_ex cos(2π f_ex t).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Excitation {
    /// Excitation frequency f_ex [Hz].
    pub f_ex_hz: f64,
    /// Base-acceleration amplitude a_ex [m/s²].
    pub a_ex_m_s2: f64,
}

/// Lowest excitation frequency [Hz]: below it the base displacement a_ex/Ω² overflows.
pub const MIN_F_EX_HZ: f64 = 1e-3;

impl Excitation {
    /// Excitation at f_ex [Hz] and a_ex [m/s²].
    pub fn new(f_ex_hz: f64, a_ex_m_s2: f64) -> Self {
        Excitation { f_ex_hz, a_ex_m_s2 }
    }

    /// f_ex must be finite and > 0, a_ex finite and ≥ 0.
    pub fn validate(&self) -> Result<()> {
        if !(self.f_ex_hz.is_finite() && self.f_ex_hz > 0.0) {
            return Err(Error::invalid("f_ex_hz", self.f_ex_hz, "must be finite and > 0"));
        }
        // The base displacement a_ex/Ω² (docs/model.md §3) must stay a number: f_ex >= 1 mHz.
        if self.f_ex_hz < MIN_F_EX_HZ {
            return Err(Error::invalid("f_ex_hz", self.f_ex_hz, &format!("must be >= {MIN_F_EX_HZ} Hz (a period of at most {} s)", 1.0 / MIN_F_EX_HZ)));
        }
        if !(self.a_ex_m_s2.is_finite() && self.a_ex_m_s2 >= 0.0) {
            return Err(Error::invalid("a_ex_m_s2", self.a_ex_m_s2, "must be finite and >= 0"));
        }
        Ok(())
    }

    /// Ω = 2π f_ex [rad/s].
    #[inline(always)]
    pub fn omega_rad_s(&self) -> f64 {
        2.0 * std::f64::consts::PI * self.f_ex_hz
    }

    /// w₀, ẇ₀ and ẅ₀ at t: w₀ = (a_ex/Ω²) cos Ωt, ẇ₀ = −(a_ex/Ω) sin Ωt, ẅ₀ = −a_ex cos Ωt; for
    /// f_ex = 0 a constant acceleration ẅ₀ = −a_ex (w₀ = ẇ₀ = 0: the frame moves with the base).
    #[inline(always)]
    pub fn at(&self, t: f64) -> (f64, f64, f64) {
        let omega = self.omega_rad_s();
        if omega == 0.0 {
            return (0.0, 0.0, -self.a_ex_m_s2);
        }
        let (s, c) = (omega * t).sin_cos();
        (self.a_ex_m_s2 / (omega * omega) * c, -self.a_ex_m_s2 / omega * s, -self.a_ex_m_s2 * c)
    }

    /// Excitation period 1/f_ex [s].
    pub fn period_s(&self) -> f64 {
        1.0 / self.f_ex_hz
    }
}

/// Base motion at one instant as the contact kinematics (docs/model.md §4) use it: w₀ and ẇ₀.
#[derive(Debug, Clone, Copy)]
pub struct BaseState {
    /// Base displacement w₀ [m].
    pub w0: f64,
    /// Base velocity ẇ₀ [m/s].
    pub w0_dot: f64,
}
