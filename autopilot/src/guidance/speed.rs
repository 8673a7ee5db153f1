//! How fast to drive: the cruise speed, limited so the vehicle can still stop
//! at the end of the leg and slowed while its heading is far off the path.

/// Limits for the speed schedule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedLimits {
    pub cruise_mps: f64,
    /// Deceleration the schedule plans with (below the vehicle's brake limit).
    pub decel_mps2: f64,
    /// Slowest approach speed, so the vehicle does not stall short of a stop.
    pub approach_mps: f64,
}

/// Speed magnitude for `remaining_m` to go to a stop with a heading error of
/// `heading_error_rad`.
pub fn scheduled_speed(limits: &SpeedLimits, remaining_m: f64, heading_error_rad: f64) -> f64 {
    let cruise = limits.cruise_mps.max(0.0);
    let stopping = (2.0 * limits.decel_mps2.max(0.01) * remaining_m.max(0.0)).sqrt();
    // Large heading errors make the vehicle sweep sideways: slow down, but
    // never below the approach speed so it can still turn onto the path.
    let heading_factor = heading_error_rad.cos().max(0.0);
    let speed = cruise.min(stopping).min(cruise * heading_factor.max(0.25));
    speed.max(limits.approach_mps.min(cruise))
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: SpeedLimits = SpeedLimits {
        cruise_mps: 2.0,
        decel_mps2: 0.5,
        approach_mps: 0.1,
    };

    #[test]
    fn cruises_far_from_the_stop_and_brakes_near_it() {
        assert_eq!(scheduled_speed(&LIMITS, 50.0, 0.0), 2.0);
        assert!((scheduled_speed(&LIMITS, 1.0, 0.0) - 1.0).abs() < 1e-12);
        assert_eq!(scheduled_speed(&LIMITS, 0.0, 0.0), 0.1);
    }

    #[test]
    fn heading_error_slows_down() {
        assert!((scheduled_speed(&LIMITS, 50.0, 60f64.to_radians()) - 1.0).abs() < 1e-9);
        assert_eq!(scheduled_speed(&LIMITS, 50.0, 3.0), 0.5);
    }
}
