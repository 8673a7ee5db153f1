//! The wait between attempts to reach a device or a peer: every driver and
//! link that reconnects uses this one.

use std::time::Duration;

/// A zero backoff would retry a missing device in a hot loop.
pub const MIN_BACKOFF: Duration = Duration::from_millis(1);

/// Exponential backoff: `initial`, doubling up to `max`; [`Backoff::reset`]
/// once a connection has proved itself (so one that opens and dies at once
/// is not hammered).
#[derive(Clone, Debug)]
pub struct Backoff {
    initial: Duration,
    max: Duration,
    next: Duration,
}

impl Backoff {
    /// `initial` is at least [`MIN_BACKOFF`], `max` at least `initial`.
    pub fn new(initial: Duration, max: Duration) -> Self {
        let initial = initial.max(MIN_BACKOFF);
        Self {
            initial,
            max: max.max(initial),
            next: initial,
        }
    }

    /// The same wait every time.
    pub fn constant(wait: Duration) -> Self {
        Self::new(wait, wait)
    }

    /// The wait before the next attempt; the one after is twice as long.
    pub fn next_delay(&mut self) -> Duration {
        let delay = self.next;
        self.next = self.next.saturating_mul(2).min(self.max);
        delay
    }

    pub fn reset(&mut self) {
        self.next = self.initial;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(v: u64) -> Duration {
        Duration::from_millis(v)
    }

    #[test]
    fn backoff_doubles_up_to_the_cap_and_resets() {
        let mut backoff = Backoff::new(ms(100), ms(700));
        let delays: Vec<_> = (0..6).map(|_| backoff.next_delay()).collect();
        assert_eq!(delays, [ms(100), ms(200), ms(400), ms(700), ms(700), ms(700)]);
        backoff.reset();
        assert_eq!(backoff.next_delay(), ms(100));
    }

    #[test]
    fn backoff_never_zero_and_cap_never_below_initial() {
        let mut zero = Backoff::new(Duration::ZERO, Duration::ZERO);
        assert!(zero.next_delay() >= MIN_BACKOFF);
        let mut inverted = Backoff::new(ms(300), ms(50));
        assert_eq!((inverted.next_delay(), inverted.next_delay()), (ms(300), ms(300)));
        let mut constant = Backoff::constant(ms(1000));
        assert_eq!((constant.next_delay(), constant.next_delay()), (ms(1000), ms(1000)));
    }
}
