//! Post-processing of docs/model.md §7: envelope filters, the streamed super-slow signals, trajectory files and the run overview.

pub mod envelope_stream;
pub mod filters;
pub mod output;
pub mod overview;
pub mod reduced;
pub mod run;

pub use envelope_stream::{EnvelopeStream, SuperSlow};
pub use filters::{envelope, envelope_checked, hilbert_envelope, moving_average, positive};
