//! Operating maps (docs/model.md §8): configuration, the parallel point runner, the session a
//! front end drives (local or in chunks elsewhere) and the text table.
//!
//! The paper's Fig. 11: the behaviour of the free slider at every point
//! of a grid of excitation frequency f_ex, level a_ex and initial position s₀, each point a 120-s
//! run classified by [`crate::classify`].
//!
//! Points run in parallel (rayon). Each finished point is appended at once as one JSON line to a
//! results file (`map.jsonl`) and flushed, so a killed run loses only the points in flight; a
//! later run with `resume` skips the points already in the file (a truncated last line from the
//! kill is cut off first). Every point is computed independently from the same inputs, so the rows
//! do not depend on the number of threads (bitwise, apart from `wall_time_s`).
//!
//! Results file: line 1 is a header `{"beamslider_map": 3, "settings": {...}}` with everything
//! that decides a row besides the grid point (parameters, duration, recording interval,
//! classification thresholds); resuming with different settings is an error. Each further line
//! is one [`MapRow`]; a later row of the same point replaces an earlier one (extension).
//!
//! Every completed row carries its run's end state ([`EndState`]: the state, the step index, the
//! stepper's memory and the super-slow signals so far, [`crate::signal::envelope_stream`]). A map can
//! therefore be **extended in time** ([`MapRunOptions::extend`]): the points that had not
//! settled (`settled` false: [`crate::classify::Behaviour::NotSettled`], or a behaviour still
//! creeping) or got no behaviour ([`crate::classify::Behaviour::Undetermined`]) continue from their saved end states to the new duration,
//! bitwise as if they had run there from the start; settled points keep their rows. Memory per
//! point in flight: the binned super-slow signals and a few hundred raw samples.

mod config;
mod run;
mod session;
mod table;

pub use crate::results::{EndState, MapPoint, MapRow};
pub use config::{Axis, DEFAULT_RECORD_EVERY, Grid, MAX_POINTS, MapConfig, RESULTS_FILE};
pub use run::{Job, MapOutcome, MapResults, MapRunOptions, Progress, continue_point, error_row, preflight, run_job, run_jobs, run_point, upgrade_row};
pub use session::{MapSession, WireJob, run_chunk, run_map};
pub use table::{TableCell, marked_unsettled, t_end_text, table_of_cells, table_of_columns, text_table};
