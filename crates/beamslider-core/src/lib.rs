//! beamslider-core: the self-adaptive beam–slider system of Müller, Beck & Krack (MSSP 2023),
//! as specified in the project's docs/model.md — a geometrically nonlinear, elastically clamped beam
//! (modal reduction) carrying a rigid slider in frictional, unilateral contact, integrated with
//! Moreau's midpoint time-stepping scheme.
//!
//! Modules follow the physics: [`params`] (§1), [`beam`] and [`excitation`] (§2), [`slider`] (§3), [`contact`]
//! (§4), [`solver`] and [`stepper`] (§5), [`simulation`] and [`manifold`] (§6), [`record`] and
//! [`signal`], [`envelope_stream`], [`output`] and [`overview`] (§7), [`classify`], [`map`] and [`study`] (§8) on the one batch [`runner`], [`enma`] (§9); [`superslow`]: the super-slow
//! manifold by harmonic balance (issue 17, layer (a)); [`drift`] and [`slowflow`]: the drift law
//! from the PCS model and the slow flow (issue 17, layer (b)); [`predictor`]: the fitted drift law
//! evaluated in the core and predicted operating maps (issue 17, b2).
#![warn(missing_docs)]

mod arith;
pub mod beam;
pub mod classify;
pub mod contact;
pub mod drift;
pub mod enma;
pub mod error;
pub mod excitation;
pub mod manifold;
pub mod lock;
pub mod map;
pub mod output;
pub mod overview;
pub mod params;
pub mod predictor;
pub mod record;
pub mod runner;
pub mod signal;
pub mod envelope_stream;
pub mod simulation;
pub mod slider;
pub mod slowflow;
pub mod solver;
pub mod stepper;
pub mod study;
pub mod superslow;

pub use beam::Beam;
pub use enma::{EnmaOptions, EnmaPoint, EnmaResult, virtual_enma};
pub use manifold::{Branch, Manifold, ManifoldOptions, super_slow_manifold};
pub use error::{Error, Result};
pub use params::{ContactSolver, Params};
pub use lock::ResultsLock;
pub use output::{FileRecorder, Format, recorded_bytes, recorded_rows};
pub use overview::{Overview, OverviewRecorder};
pub use record::{ColumnRecorder, Channel, CsvRecorder, MemoryRecorder, NullRecorder, Recorder, Tee};
pub use simulation::{
    CancelFlag, Checkpoint, Excitation, Model, Monitor, RunOptions, RunSummary, SliderModel, State,
    Status, set_simd,
};
pub use stepper::{Counters, StepperMemory};
pub use superslow::{ClosedFormN1, Fold, HbBranch, HbManifold, HbOptions, HbSystem, closed_form_n1, hb_manifold};
pub use classify::{Behaviour, Classification, Criteria, SuperSlow, classify};
pub use map::{Axis, Grid, MapConfig, MapOutcome, MapPoint, MapRow, MapRunOptions, run_map};
