//! The time a device thread reads: "now" for sample stamps and silence
//! detection, and the deadline of its reconnect backoff.
//!
//! Production threads read the wall clock ([`WallClock`]). Tests give them a
//! [`ManualClock`] and move time on explicitly, so a backoff expiry or a
//! silence timeout happens when the test says, not when a wall deadline
//! passes. (The core's clocks live in `autopilot::time`; this one is for the
//! std threads of the device edge, which the core never sees.)

use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

/// A clock a device thread reads. Blocking I/O still waits in wall time; a
/// thread asks [`DeviceClock::wall_wait`] how long it may block before it
/// reads the clock again.
pub trait DeviceClock: Send + Sync {
    /// Time since the clock's origin.
    fn now(&self) -> Duration;

    /// How long to block (in wall time) while `left` remains until a
    /// deadline on this clock.
    fn wall_wait(&self, left: Duration) -> Duration;
}

/// The wall clock since `origin`: what every real device reads.
#[derive(Clone, Copy, Debug)]
pub struct WallClock {
    origin: Instant,
}

impl WallClock {
    pub fn new(origin: Instant) -> Self {
        Self { origin }
    }
}

impl DeviceClock for WallClock {
    fn now(&self) -> Duration {
        self.origin.elapsed()
    }

    fn wall_wait(&self, left: Duration) -> Duration {
        left
    }
}

/// A clock that moves only when [`ManualClock::advance`] is called: for tests
/// that decide when a timeout or a backoff expires.
#[derive(Debug, Default)]
pub struct ManualClock {
    now: Mutex<Duration>,
}

impl ManualClock {
    /// How often a thread waiting on a manual deadline looks again: the test
    /// moves the clock from another thread and nothing wakes the waiter.
    pub const POLL: Duration = Duration::from_millis(1);

    pub fn new() -> Arc<Self> {
        Arc::new(Self::default())
    }

    pub fn advance(&self, by: Duration) {
        let mut now = self.now.lock().unwrap_or_else(PoisonError::into_inner);
        *now = now.saturating_add(by);
    }
}

impl DeviceClock for ManualClock {
    fn now(&self) -> Duration {
        *self.now.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn wall_wait(&self, left: Duration) -> Duration {
        left.min(Self::POLL)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manual_clock_moves_only_when_advanced() {
        let clock = ManualClock::new();
        assert_eq!(clock.now(), Duration::ZERO);
        clock.advance(Duration::from_millis(250));
        clock.advance(Duration::from_millis(50));
        assert_eq!(clock.now(), Duration::from_millis(300));
        assert_eq!(clock.wall_wait(Duration::from_secs(5)), ManualClock::POLL);
        assert_eq!(clock.wall_wait(Duration::ZERO), Duration::ZERO);
    }

    #[test]
    fn wall_clock_blocks_for_the_whole_wait() {
        let clock = WallClock::new(Instant::now());
        assert_eq!(clock.wall_wait(Duration::from_secs(2)), Duration::from_secs(2));
        let first = clock.now();
        assert!(clock.now() >= first);
    }
}
