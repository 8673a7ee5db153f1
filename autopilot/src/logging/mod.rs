//! Onboard logs in ArduPilot's DataFlash format (`.BIN`).
//!
//! The core builds the records ([`format`], [`messages`]) and hands them
//! out in its outputs as [`LogCommand`]s; the edge writes them to the data
//! directory's `logs/` folder on a thread of its own, never blocking the
//! core, and serves them over MAVLink's LOG_* messages.

pub mod format;
pub mod messages;
pub mod params;

use mavlink::dialects::ardupilotmega::MavMessage;

use crate::vehicle::LinkId;

/// How many log files to keep and how large one may grow.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FileLimits {
    pub max_files: u16,
    /// 0: no limit.
    pub max_bytes: u64,
}

/// What the core asks of the log writer, in order.
#[derive(Clone, Debug)]
pub enum LogCommand {
    /// Start a new file (closing the one open).
    Open(FileLimits),
    /// Encoded records for the open file.
    Records(Vec<u8>),
    /// Close the open file.
    Close,
    /// A LOG_* request from a ground station (list, download, erase).
    Request { link: LinkId, message: Box<MavMessage> },
    /// A link went away: a download for it stops (no work for a gone
    /// client).
    LinkClosed(LinkId),
}
pub mod edge;
pub mod protocol;
pub mod reader;
pub mod store;
