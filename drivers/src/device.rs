//! Health of one device as the status view shows it: shared between the
//! device's I/O task (the writer) and the core's edge (the reader).

use std::sync::{Arc, Mutex};
use std::time::Duration;

/// Counters and state of one device. Times are on the caller's clock
/// (time since the process started).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeviceStatus {
    /// The port or connection is open now.
    pub connected: bool,
    /// Successful opens or connections (1 after the first; more after replugs).
    pub connects: u64,
    pub bytes_in: u64,
    pub bytes_out: u64,
    /// Good units received (sentences, telegrams, frames).
    pub messages: u64,
    /// Malformed units and I/O errors.
    pub errors: u64,
    /// When the last good unit arrived.
    pub last_message: Option<Duration>,
    /// The most recent error, for the status view.
    pub last_error: Option<String>,
}

/// The handle both sides hold.
pub type SharedStatus = Arc<Mutex<DeviceStatus>>;

/// A fresh shared status.
pub fn shared_status() -> SharedStatus {
    Arc::new(Mutex::new(DeviceStatus::default()))
}

/// Updates a shared status; a poisoned lock (a panicked writer) is taken
/// over rather than propagated, since the counters stay meaningful.
pub fn update(status: &SharedStatus, f: impl FnOnce(&mut DeviceStatus)) {
    let mut guard = status.lock().unwrap_or_else(|p| p.into_inner());
    f(&mut guard);
}

/// A copy of the current status.
pub fn snapshot(status: &SharedStatus) -> DeviceStatus {
    status.lock().unwrap_or_else(|p| p.into_inner()).clone()
}
