//! Onboard logs in ArduPilot's DataFlash format (`.BIN`).
//!
//! The core builds the records ([`format`], [`messages`]) and hands them
//! out in its outputs as [`LogCommand`]s; the edge writes them to the data
//! directory's `logs/` folder on a thread of its own, never blocking the
//! core, and serves them over MAVLink's LOG_* messages.

pub mod format;
pub mod messages;
