//! The JSON-lines results files of operating maps, studies, drift tables and design runs (docs/model.md §6.3, §8): row schema, header, reading and resuming, appending, and the writer's lock.

mod file;
mod lines;
pub mod lock;
mod row;

pub use file::{FORMAT_VERSION, READABLE_VERSIONS, ResultsFile, Settings, latest, read_results};
pub(crate) use file::{header_line_predictor, header_line_with, io_err, open_append, write_line};
pub use lines::{JsonLines, append_json_lines, read_json_lines, read_tagged_lines};
pub use lock::ResultsLock;
pub use row::{EndState, MapPoint, MapRow, STATUS_ERROR, STATUS_PREDICTED};
