//! The integration tests of the core, one test binary: each file of this folder is a module
//! (`cargo test -p beamslider-core --test all golden::` runs one of them). One binary instead of
//! one per file: the tests are compiled and linked once.
//!
//! The tests of all modules share one process: a test that changes global state (`set_simd`)
//! holds `common::SIMD_SWITCH` while it does.

mod common;

mod classify;
mod determinism;
mod enma;
mod fast_solver;
mod golden;
mod map;
mod physics;
mod slowflow;
mod solver_props;
mod superslow;
mod superslow_mhb;
mod tilt;
