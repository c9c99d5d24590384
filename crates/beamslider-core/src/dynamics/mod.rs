//! Time integration of docs/model.md §5–§6.1: contact solvers, Moreau's midpoint stepper, runs with their recorders and the parallel batch runner.

pub mod beam_only;
pub mod record;
pub mod runner;
pub mod simulation;
pub mod solver;
pub mod stepper;

pub use record::{Channel, ColumnRecorder, CsvRecorder, MemoryRecorder, NullRecorder, Recorder, Tee};
pub use simulation::{CancelFlag, Checkpoint, Model, Monitor, RunOptions, RunSummary, SliderModel, State, Status};
pub use stepper::{Counters, StepperMemory};
