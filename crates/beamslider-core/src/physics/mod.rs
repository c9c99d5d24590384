//! The mechanical system of docs/model.md §2–§4: beam, base excitation, slider and contact kinematics.

pub mod beam;
pub mod contact;
pub mod excitation;
pub mod modes;
pub mod properties;
pub mod slider;

pub use beam::{Beam, FirstMode, Loc};
pub use excitation::{BaseState, Excitation};
pub use properties::BeamProperties;
pub use slider::Slider;
