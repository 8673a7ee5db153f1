//! The MAVLink link layer (an edge: sockets, serial ports and threads live
//! here, never in the core).
//!
//! - [`frame`]: bytes → validated frames and decoded messages (no I/O).
//! - [`encode`]: messages → bytes with a per-link sequence number.
//! - [`pacing`]: which replies are bulk and when a link takes the next
//!   one (no I/O).
//! - [`router`]: ArduPilot's routing rules between links (no I/O).
//! - [`endpoint`]: the `--mavlink` endpoint syntax.
//! - [`signing`]: MAVLink 2 signing: key, timestamps, verify and sign (no I/O).
//! - [`sign_policy`]: which frames a link acts on once a key is set (no I/O).
//! - [`peers`]: which ground stations a link answers (no I/O).
//! - [`sockets`]: the endpoints bound before anything runs (port 0 picks).
//! - [`hub`]: the tasks: one per link, a hub that routes frames and fans
//!   the core's messages out, and the tlog recorder. A slow or dead
//!   link only ever fills its own bounded queue; the core never waits.

pub mod encode;
pub mod endpoint;
pub mod frame;
pub mod hub;
pub mod pacing;
pub mod peers;
pub mod router;
mod serial;
pub mod sign_policy;
pub mod signing;
pub mod sockets;
mod tcp;
pub mod tlog;
mod udp;

/// The wait before a TCP client or serial link tries again: soon after a
/// short outage, at most once a second.
fn reconnect_backoff() -> drivers::backoff::Backoff {
    use std::time::Duration;
    drivers::backoff::Backoff::new(Duration::from_millis(100), Duration::from_secs(1))
}
