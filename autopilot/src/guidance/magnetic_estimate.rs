//! Where the tape is relative to the vehicle between readings: the guide's
//! lateral and angle deviation carried forward with the vehicle's own
//! motion (speed and yaw rate), so that a sensor reading only its edge
//! probe, or both sensors off the tape for a moment, do not leave the guide
//! blind. Found in SITL (`magnetic_scenario`): from 5° away from the tape
//! the rear sensor leaves its range while the vehicle turns back, whatever
//! it does (it sits behind the rear axle and swings out), and the edge
//! readings on the way out collapse the measured deviation; steering on
//! the carried-forward deviation instead turns the vehicle back at speed.

/// The tape relative to the sensors' midpoint, in the guide's signs: both
/// positive when the vehicle should steer right (see `super::magnetic`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TapeEstimate {
    pub lateral_m: f64,
    pub angle_rad: f64,
    /// Since a reading last set it.
    pub age_s: f64,
}

impl TapeEstimate {
    /// Set from a reading.
    pub fn measured(lateral_m: f64, angle_rad: f64) -> Self {
        TapeEstimate {
            lateral_m,
            angle_rad,
            age_s: 0.0,
        }
    }

    /// Carried forward by `dt_s`: the tape's direction relative to the body
    /// turns at v·k − ω (k the tape's curvature, positive right; ω the yaw
    /// rate, positive clockwise) and the midpoint (`mid_x_m` ahead of the
    /// point that does not slip sideways) drifts across it at
    /// v·tan α − ω·x_mid, as the guide's kinematic rate has it.
    pub fn predicted(
        &self,
        speed_mps: f64,
        yaw_rate_rad_s: f64,
        curvature_per_m: f64,
        mid_x_m: f64,
        dt_s: f64,
    ) -> Self {
        let dt_s = if dt_s.is_finite() { dt_s.max(0.0) } else { 0.0 };
        let inputs_ok = speed_mps.is_finite() && yaw_rate_rad_s.is_finite() && curvature_per_m.is_finite();
        if !inputs_ok {
            return TapeEstimate {
                age_s: self.age_s + dt_s,
                ..*self
            };
        }
        let angle_rad = self.angle_rad + (speed_mps * curvature_per_m - yaw_rate_rad_s) * dt_s;
        let mid_angle_rad = 0.5 * (self.angle_rad + angle_rad);
        let lateral_m = self.lateral_m + (speed_mps * mid_angle_rad.tan() - yaw_rate_rad_s * mid_x_m) * dt_s;
        TapeEstimate {
            lateral_m,
            angle_rad,
            age_s: self.age_s + dt_s,
        }
    }

    /// The deviations the front and rear sensors (spacing `spacing_m`)
    /// would read: the inverse of `lateral_and_angle`.
    pub fn sensor_deviations_m(&self, spacing_m: f64) -> (f64, f64) {
        let cos = self.angle_rad.cos().max(f64::EPSILON);
        let centre_m = self.lateral_m / cos;
        let half_m = 0.5 * spacing_m * self.angle_rad.tan();
        (centre_m + half_m, centre_m - half_m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::guidance::magnetic::lateral_and_angle;

    #[test]
    fn sensor_deviations_invert_lateral_and_angle() {
        for (front_m, rear_m) in [(0.02, -0.03), (0.07, 0.01), (-0.05, -0.05)] {
            let (lateral_m, angle_rad) = lateral_and_angle(front_m, rear_m, 2.0);
            let (f, r) = TapeEstimate::measured(lateral_m, angle_rad).sensor_deviations_m(2.0);
            assert!((f - front_m).abs() < 1e-12 && (r - rear_m).abs() < 1e-12, "{f} {r}");
        }
    }

    /// Heading 5° left of a straight tape (angle +5°: the tape heads right
    /// of the body) the tape drifts right of the midpoint at v·tan 5°;
    /// turning right at the yaw rate that cancels the angle in 1 s ends
    /// aligned, having drifted half as far.
    #[test]
    fn carried_forward_with_the_vehicles_motion() {
        let angle_rad = 5f64.to_radians();
        let mut estimate = TapeEstimate::measured(0.0, angle_rad);
        for _ in 0..100 {
            estimate = estimate.predicted(1.5, angle_rad, 0.0, 0.0, 0.01);
        }
        assert!(estimate.angle_rad.abs() < 1e-12, "{}", estimate.angle_rad);
        let expected_m = 1.5 * angle_rad.tan() / 2.0;
        assert!((estimate.lateral_m - expected_m).abs() < 2e-3, "{}", estimate.lateral_m);
        assert!((estimate.age_s - 1.0).abs() < 1e-9);
        // Along an arc turning with it: nothing changes.
        let on_arc = TapeEstimate::measured(0.01, 0.0).predicted(1.5, 0.1, 0.1 / 1.5, 0.0, 0.5);
        assert!((on_arc.lateral_m - 0.01).abs() < 1e-12 && on_arc.angle_rad.abs() < 1e-12);
    }
}
