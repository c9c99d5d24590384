//! The integration tests of `beamslider-batch`, one test binary: each file of this folder is a
//! module (`cargo test -p beamslider-batch --test all map::` runs one of them). One binary instead
//! of one per file: the tests are compiled and linked once.
//!
//! The tests run the built `beamslider-batch` binary as a child process; each works in a folder
//! of its own under `CARGO_TARGET_TMPDIR` named after the test and this process.

mod common;

mod bad_input;
mod cli;
mod map;
mod predictor;
