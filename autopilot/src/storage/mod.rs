//! The data directory (an edge: files live here, never in the core).
//!
//! - [`data_dir`]: the directory, its lock (one process at a time) and the
//!   vehicle profile it belongs to.
//! - [`param_writer`]: a thread that writes parameter changes atomically,
//!   coalescing bursts, so the core tick never waits for a disk.
//! - [`session`]: a run's table: defaults, stored values, command-line
//!   overrides that are not saved.

pub mod data_dir;
pub mod param_writer;
pub mod session;
