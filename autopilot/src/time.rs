//! The two clocks the core is given.
//!
//! `boot` is the vehicle's own time: it drives estimation, guidance and
//! control, and in SITL it is simulated time. `wall` is the monotonic wall
//! clock since start: everything a ground station paces against (telemetry
//! rates, heartbeats, transfer timeouts, GCS loss) uses it, because a GCS runs
//! in wall time even when SITL runs 1000× faster. On a real vehicle the two
//! advance together.

use std::time::Duration;

/// Float seconds from outside as a `Duration`, saturating (never panics):
/// the one conversion every crate uses (it lives in `mission`, the lowest
/// crate that needs it).
pub use mission::seconds::duration_from_secs;

/// The time given to one core step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Now {
    /// Vehicle time since boot (simulated time in SITL).
    pub boot: Duration,
    /// Monotonic wall time since the process started.
    pub wall: Duration,
}

impl Now {
    pub fn boot_ms(&self) -> u32 {
        // Wraps after 49 days like every MAVLink time_boot_ms.
        self.boot.as_millis() as u32
    }
}

/// Reads a monotonic nanosecond counter to time scheduler tasks. Injected so
/// the core never reads a clock itself; the readings only feed statistics and
/// never change what the core computes.
pub trait TaskTimer {
    fn now_ns(&mut self) -> u64;
}

/// A timer that never advances: for tests and replays.
#[derive(Default)]
pub struct FrozenTimer;

impl TaskTimer for FrozenTimer {
    fn now_ns(&mut self) -> u64 {
        0
    }
}
