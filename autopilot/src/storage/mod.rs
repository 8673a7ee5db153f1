//! The data directory (an edge: files live here, never in the core).
//!
//! - [`data_dir`]: the directory, its lock (one process at a time) and the
//!   vehicle profile it belongs to.
//! - [`file_writer`]: a thread that writes files atomically, coalescing
//!   bursts, and reports each save once durable, so the core tick never
//!   waits for a disk and acknowledges only what is on it.
//! - [`missions`]: the mission, fence and rally plans (QGC WPL 110 files),
//!   loaded at start and saved atomically.
//! - [`session`]: a run's table: defaults, stored values, command-line
//!   overrides that are not saved.
//! - [`termination`]: whether a flight termination is in force.

pub mod data_dir;
pub mod file_writer;
pub mod missions;
pub mod session;
pub mod signing_key;
pub mod termination;
