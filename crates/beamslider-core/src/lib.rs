//! beamslider-core: the self-adaptive beam–slider system of Müller, Beck & Krack (MSSP 2023),
//! as specified in the project's MODEL.md — a geometrically nonlinear, elastically clamped beam
//! (modal reduction) carrying a rigid slider in frictional, unilateral contact, integrated with
//! Moreau's midpoint time-stepping scheme.
#![warn(missing_docs)]

pub mod beam;
pub mod error;
pub mod params;

pub use beam::Beam;
pub use error::{Error, Result};
pub use params::{ContactSolver, Params};
