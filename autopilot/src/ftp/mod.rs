//! MAVLink FTP (mavlink.io file transfer protocol), as ground stations use
//! it with ArduPilot: the parameter table as `@PARAM/param.pck` (MAVProxy,
//! QGroundControl and Mission Planner download it instead of one
//! PARAM_VALUE per parameter), and the data directory's files.
//!
//! - [`wire`]: the FILE_TRANSFER_PROTOCOL payload.
//! - [`server`]: the protocol as a state machine over a [`server::Files`]
//!   trait (no I/O of its own).
//! - [`param_pack`]: ArduPilot's packed parameter format.
//! - [`disk`] (edge): [`server::Files`] on the data directory.
//! - [`service`] (edge): the worker thread the runners feed.
//!
//! What is served:
//! - `/` (or an empty path) is the data directory; plain files there and in
//!   its subdirectories can be listed, read, written, created, truncated,
//!   renamed and removed, except the vehicle's own (parameter store, plans,
//!   lock, profile: read-only; signing key: hidden and unreadable). `..` and
//!   symlinks are refused, so nothing outside it is reachable.
//! - `@PARAM/param.pck` (`?withdefaults=1` adds the defaults that differ):
//!   the table as it is when the file is opened.
//! - `@LOGS/`: the data directory's `logs/` directory, read-only. Another
//!   directory is exposed the same way with one line in
//!   [`service::FtpService::start`]: `files.mount("NAME", dir)` serves `dir`
//!   read-only as `@NAME/`.

pub mod disk;
pub mod param_pack;
pub mod server;
pub mod service;
pub mod wire;

#[cfg(test)]
mod tests;
