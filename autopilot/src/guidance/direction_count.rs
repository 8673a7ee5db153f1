//! The changes between forward and reverse the navigator has driven: the
//! limit on a goal's changes of direction (`MNV_DIR_MAX`) is on what the
//! wheels do on the way to it, planned or not. A stop that overshoots and
//! creeps back is a change of direction as much as a manoeuvre's cusp, and
//! a retry planned after it has only what is left.

use crate::guidance::tracker::Direction;

/// A speed command this small either way is no driving: at the end of an
/// approach the estimate's jitter about the point (several mm on RTK-grade
/// fixes) turns the approach's command (`WP_APPR_GAIN` × the distance to
/// go) to and fro by a few mm/s while the wheels barely turn. A creep back
/// from 17 mm or more past (at the default gain 0.6/s) commands more, and
/// it is what the truth shows as a change of direction: a tracker of the
/// truth counting one past 20 mm/s saw 16 mm/s commanded reach 23 mm/s.
pub const DRIVEN_SPEED_MPS: f64 = 0.01;

/// The changes of direction driven since the count was started afresh,
/// and the way the vehicle last drove.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DirectionCount {
    pub changes: usize,
    pub last: Option<Direction>,
}

impl DirectionCount {
    /// Notes a tick's signed speed command (negative: reverse).
    pub fn note(&mut self, speed_mps: f64) {
        // NaN is no command either.
        if speed_mps.is_nan() || speed_mps.abs() <= DRIVEN_SPEED_MPS {
            return;
        }
        let way = if speed_mps > 0.0 {
            Direction::Forward
        } else {
            Direction::Reverse
        };
        if self.last.is_some_and(|last| last != way) {
            self.changes = self.changes.saturating_add(1);
        }
        self.last = Some(way);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_each_turn_back_and_ignores_a_standstill_or_a_whisper() {
        let mut count = DirectionCount::default();
        for speed in [0.0, 0.3, 0.001, -0.002, 0.2, f64::NAN] {
            count.note(speed);
        }
        assert_eq!(
            count,
            DirectionCount {
                changes: 0,
                last: Some(Direction::Forward)
            }
        );
        // A stop past its point creeping back, then a stroke forwards again.
        for speed in [-0.016, -0.01, 0.0, 0.5] {
            count.note(speed);
        }
        assert_eq!(
            count,
            DirectionCount {
                changes: 2,
                last: Some(Direction::Forward)
            }
        );
    }
}
