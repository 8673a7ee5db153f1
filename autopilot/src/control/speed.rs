//! Speed → throttle, as ArduPilot Rover does it: feed-forward from the cruise
//! model (`CRUISE_SPEED` reached at `CRUISE_THROTTLE`) plus a PI correction
//! on the speed error, with acceleration limits on the demanded speed.

use crate::control::pid::{PidGains, PidState, PidTerms};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedControlConfig {
    pub gains: PidGains,
    pub cruise_speed_mps: f64,
    /// Throttle fraction (0..1) that gives `cruise_speed_mps`.
    pub cruise_throttle: f64,
    pub accel_max_mps2: f64,
    pub decel_max_mps2: f64,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SpeedController {
    pid: PidState,
    /// The demand after the acceleration limit.
    limited_mps: f64,
    /// The last update's PID terms and feed-forward throttle (for the log).
    last_terms: PidTerms,
    last_feed_forward: f64,
}

impl SpeedController {
    pub fn reset(&mut self, current_speed_mps: f64) {
        self.pid.reset();
        self.limited_mps = current_speed_mps;
    }

    /// The acceleration-limited speed demand of the last update.
    pub fn limited_demand_mps(&self) -> f64 {
        self.limited_mps
    }

    /// The last update's PID terms and feed-forward throttle.
    pub fn last_terms(&self) -> (PidTerms, f64) {
        (self.last_terms, self.last_feed_forward)
    }

    /// Throttle in [-1, 1] for `desired_mps` given the measured speed; with
    /// no measurement (no estimate), the feed-forward alone.
    pub fn update(
        &mut self,
        config: &SpeedControlConfig,
        desired_mps: f64,
        measured_mps: Option<f64>,
        dt_s: f64,
    ) -> f64 {
        let step = desired_mps - self.limited_mps;
        let slowing = desired_mps.abs() < self.limited_mps.abs() || desired_mps * self.limited_mps < 0.0;
        let limit = if slowing {
            config.decel_max_mps2
        } else {
            config.accel_max_mps2
        } * dt_s;
        self.limited_mps += step.clamp(-limit, limit);

        let full_throttle_speed = if config.cruise_throttle > 0.0 {
            config.cruise_speed_mps / config.cruise_throttle
        } else {
            1.0
        };
        let feed_forward = self.limited_mps / full_throttle_speed.max(1e-3);
        self.last_terms = match measured_mps {
            Some(measured) => self.pid.update(&config.gains, self.limited_mps - measured, dt_s),
            None => {
                self.pid.reset();
                PidTerms::default()
            }
        };
        self.last_feed_forward = feed_forward;
        let correction = self.last_terms.output();
        (feed_forward + correction).clamp(-1.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config() -> SpeedControlConfig {
        SpeedControlConfig {
            gains: PidGains {
                kp: 0.2,
                ki: 0.2,
                kd: 0.0,
                imax: 0.5,
            },
            cruise_speed_mps: 2.0,
            cruise_throttle: 0.5,
            accel_max_mps2: 1.0,
            decel_max_mps2: 2.0,
        }
    }

    #[test]
    fn feed_forward_gives_cruise_throttle_at_cruise_speed() {
        let mut c = SpeedController::default();
        c.reset(2.0);
        assert!((c.update(&config(), 2.0, Some(2.0), 0.02) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn demand_ramps_at_the_acceleration_limit() {
        let mut c = SpeedController::default();
        c.reset(0.0);
        for _ in 0..50 {
            c.update(&config(), 2.0, Some(0.0), 0.02);
        }
        assert!((c.limited_demand_mps() - 1.0).abs() < 1e-9, "1 m/s² for 1 s");
    }

    #[test]
    fn reverse_gives_negative_throttle() {
        let mut c = SpeedController::default();
        c.reset(-1.0);
        assert!(c.update(&config(), -1.0, Some(-1.0), 0.02) < 0.0);
    }
}
