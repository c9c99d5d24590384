//! beamslider-core: the self-adaptive beam–slider system of Müller, Beck & Krack (MSSP 2023),
//! as specified in the project's docs/model.md — a geometrically nonlinear, elastically clamped beam
//! (modal reduction) carrying a rigid slider in frictional, unilateral contact, integrated with
//! Moreau's midpoint time-stepping scheme.
//!
//! Modules, in layers (a module uses only those above it in this list):
//!
//! - [`arith`] (numeric kernels), [`error`], [`params`] and [`plausibility`] (§1);
//! - [`physics`]: beam and its modal basis, excitation (§2), slider (§3), contact (§4);
//! - [`dynamics`]: contact solvers and the stepper (§5), runs, recorders and the batch runner (§6.1);
//! - [`signal`]: filters, the streamed super-slow signals, trajectory files, the run overview (§7);
//! - [`classify`]: the behaviour of a run (§8);
//! - [`results`]: the JSON-lines results files of maps and studies (§8);
//! - [`map`] and [`study`]: operating maps and studies (§8); [`manifold`] (§6.2), [`enma`] (§9);
//! - [`superslow`]: the harmonic-balance manifold, the drift law, the slow flow and predicted
//!   maps (§6.3–§6.4).
#![warn(missing_docs)]
// Numerical kernels index several arrays with one loop variable (the equations of docs/model.md
// read that way), and the input checks write `!(x > 0.0)` so that NaN fails with the out-of-range values.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord, clippy::nonminimal_bool)]

mod arith;
pub mod classify;
pub mod dynamics;
pub mod enma;
pub mod error;
pub mod manifold;
pub mod map;
pub mod measured;
pub mod params;
pub mod physics;
pub mod plausibility;
pub mod results;
pub mod signal;
pub mod study;
pub mod superslow;

pub use classify::{Behaviour, Classification, Criteria, SuperSlow, classify};
pub use dynamics::record::{Channel, ColumnRecorder, CsvRecorder, MemoryRecorder, NullRecorder, Recorder, Tee};
pub use dynamics::simulation::{CancelFlag, Checkpoint, Excitation, Model, Monitor, RunOptions, RunSummary, SliderModel, State, Status, set_simd};
pub use dynamics::stepper::{Counters, StepperMemory};
pub use enma::{EnmaOptions, EnmaPoint, EnmaResult, virtual_enma};
pub use error::{Error, Result};
pub use manifold::{Branch, Manifold, ManifoldOptions, super_slow_manifold};
pub use map::{Axis, Grid, MapConfig, MapOutcome, MapPoint, MapRow, MapRunOptions, run_map};
pub use params::{ContactSolver, Params};
pub use physics::beam::Beam;
pub use results::ResultsLock;
pub use signal::output::{FileRecorder, Format, recorded_bytes, recorded_rows};
pub use signal::overview::{Overview, OverviewRecorder};
pub use superslow::{ClosedFormN1, Fold, HbBranch, HbManifold, HbOptions, HbSystem, closed_form_n1, hb_manifold};
