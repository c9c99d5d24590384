//! The beam-only integrator of the virtual ENMA (docs/model.md §9): the stepper of §5.1 without
//! the slider, with the number of modes chosen at run time.

use super::stepper::{Kinematics, StateN, StepFault, Stepper};
use crate::params::Params;
use crate::physics::beam::Beam;
use crate::physics::excitation::Excitation;

/// A beam-only integrator whose number of modes is known at run time (the virtual ENMA): the
/// stepper's [`Stepper::step_beam`] behind a trait object.
pub trait BeamIntegrator {
    /// One step with base acceleration ẅ₀ [m/s²] at the midpoint.
    fn step(&mut self, w0_ddot: f64) -> Result<(), StepFault>;
    /// Modal coordinates q.
    fn q(&self) -> &[f64];
    /// Modal velocities q̇.
    fn u(&self) -> &[f64];
}

struct BeamOnlyN<'a, const N: usize> {
    stepper: Stepper<'a, N>,
    state: StateN<N>,
}

impl<const N: usize> BeamIntegrator for BeamOnlyN<'_, N> {
    #[inline]
    fn step(&mut self, w0_ddot: f64) -> Result<(), StepFault> {
        self.stepper.step_beam(&mut self.state, w0_ddot)
    }
    fn q(&self) -> &[f64] {
        &self.state.qb
    }
    fn u(&self) -> &[f64] {
        &self.state.ub
    }
}

/// The beam of `beam` at rest (q = q̇ = 0) as a [`BeamIntegrator`] with `beam.n` modes (1..=20).
pub fn beam_integrator<'a>(beam: &'a Beam, p: &Params) -> Option<Box<dyn BeamIntegrator + 'a>> {
    fn make<'a, const N: usize>(beam: &'a Beam, p: &Params) -> Box<dyn BeamIntegrator + 'a> {
        let base = Excitation::new(0.0, 0.0);
        let state = StateN { qb: [0.0; N], ub: [0.0; N], qs: [0.0; 3], us: [0.0; 3] };
        Box::new(BeamOnlyN { stepper: Stepper::<N>::new(beam, p, base, Kinematics::BeamOnly), state })
    }
    macro_rules! go {
        ($($n:literal)*) => {
            match beam.n {
                $($n => Some(make::<$n>(beam, p)),)*
                _ => None,
            }
        };
    }
    go!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20)
}
