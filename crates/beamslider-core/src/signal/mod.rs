//! Post-processing of docs/model.md §7: envelope filters, the streamed super-slow signals, trajectory files and the run overview.

pub mod envelope_stream;
pub mod filters;
pub mod output;
pub mod overview;
pub mod reduced;
pub mod run;

pub use envelope_stream::{EnvelopeStream, SuperSlow};
pub use filters::{blocked_envelope, blocked_hilbert_envelope, envelope, envelope_checked, hilbert_envelope, moving_average, positive};
