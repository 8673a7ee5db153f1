//! The edge's clocks: the wall clock read for task timing, and the two ways
//! a runner decides when the next tick is due (simulated time paced against
//! the wall, or a fixed period on the wall clock).

use std::time::{Duration, Instant};

use crate::time::TaskTimer;

/// Reads the wall clock for task timing (the edge's clock, injected into
/// the core).
pub struct InstantTimer(Instant);

impl Default for InstantTimer {
    fn default() -> Self {
        InstantTimer(Instant::now())
    }
}

impl TaskTimer for InstantTimer {
    fn now_ns(&mut self) -> u64 {
        self.0.elapsed().as_nanos() as u64
    }
}

/// Keeps simulated time at `speedup` × wall time. After a stall it
/// re-anchors instead of racing to catch up.
#[derive(Debug, Default)]
pub struct Pacer {
    anchor: Option<(Duration, Duration, Option<f64>)>,
    pub late_restarts: u64,
    /// Ticks that started a whole period (wall time) or more after their
    /// paced time: deadlines missed.
    pub late_ticks: u64,
}

impl Pacer {
    const MAX_LAG: Duration = Duration::from_millis(200);

    /// How long to sleep before the step that ends at simulated time `sim`
    /// (`period`: the simulated loop period).
    pub fn delay(&mut self, sim: Duration, wall: Duration, speedup: Option<f64>, period: Duration) -> Option<Duration> {
        let (wall0, sim0, s0) = *self.anchor.get_or_insert((wall, sim, speedup));
        if s0 != speedup {
            self.anchor = Some((wall, sim, speedup));
            return None;
        }
        let speedup = speedup?;
        let target = wall0 + sim.saturating_sub(sim0).div_f64(speedup);
        if wall >= target + period.div_f64(speedup) {
            self.late_ticks += 1;
        }
        if wall > target + Self::MAX_LAG {
            self.late_restarts += 1;
            self.anchor = Some((wall, sim, Some(speedup)));
            return None;
        }
        target.checked_sub(wall).filter(|d| !d.is_zero())
    }
}

/// Ticks every `period` of wall time. A tick that starts more than a
/// period late restarts the schedule from now (the caller is told, as the
/// outputs of the last tick are stale by then).
#[derive(Debug)]
pub struct WallTicks {
    period: Duration,
    next: Option<Duration>,
    pub late_ticks: u64,
}

impl WallTicks {
    pub fn new(period: Duration) -> Self {
        WallTicks {
            period,
            next: None,
            late_ticks: 0,
        }
    }

    /// A tick starts at `wall`: true when it is more than a period late.
    pub fn start(&mut self, wall: Duration) -> bool {
        let next = *self.next.get_or_insert(wall);
        if wall > next + self.period {
            self.late_ticks += 1;
            self.next = Some(wall);
            return true;
        }
        false
    }

    /// After a tick: how long until the next one is due (`None`: now).
    pub fn until_next(&mut self, wall: Duration) -> Option<Duration> {
        let next = self.next.get_or_insert(wall);
        *next += self.period;
        next.checked_sub(wall).filter(|d| !d.is_zero())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(v: u64) -> Duration {
        Duration::from_millis(v)
    }

    #[test]
    fn real_time_sleeps_until_the_step_is_due() {
        let mut p = Pacer::default();
        assert_eq!(
            p.delay(ms(20), ms(0), Some(1.0), ms(20)),
            None,
            "anchors on the first step"
        );
        assert_eq!(p.delay(ms(40), ms(5), Some(1.0), ms(20)), Some(ms(15)));
    }

    #[test]
    fn speedup_scales_and_max_never_sleeps() {
        let mut p = Pacer::default();
        p.delay(ms(0), ms(0), Some(10.0), ms(20));
        assert_eq!(p.delay(ms(1000), ms(50), Some(10.0), ms(20)), Some(ms(50)));
        let mut p = Pacer::default();
        for k in 0..100 {
            assert_eq!(p.delay(ms(20 * k), ms(0), None, ms(20)), None);
        }
    }

    #[test]
    fn a_stall_re_anchors_instead_of_racing() {
        let mut p = Pacer::default();
        p.delay(ms(0), ms(0), Some(1.0), ms(20));
        assert_eq!(p.delay(ms(20), ms(1000), Some(1.0), ms(20)), None);
        assert_eq!(p.late_restarts, 1);
        assert_eq!(p.delay(ms(40), ms(1000), Some(1.0), ms(20)), Some(ms(20)));
    }

    #[test]
    fn wall_ticks_keep_the_period_and_restart_after_a_late_tick() {
        let mut t = WallTicks::new(ms(20));
        assert!(!t.start(ms(100)));
        assert_eq!(t.until_next(ms(103)), Some(ms(17)));
        assert!(!t.start(ms(125)), "5 ms late is within a period");
        assert_eq!(t.until_next(ms(126)), Some(ms(14)));
        assert!(t.start(ms(200)), "60 ms late");
        assert_eq!(t.late_ticks, 1);
        assert_eq!(
            t.until_next(ms(201)),
            Some(ms(19)),
            "the schedule restarts at the late tick"
        );
        assert_eq!(t.until_next(ms(240)), None, "due already");
    }
}
