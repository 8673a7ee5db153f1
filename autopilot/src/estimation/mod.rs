//! The pose estimate: where the vehicle's reference point (the rear axle
//! centre) is, which way it points and how fast it moves.
//!
//! This first estimator takes the latest GNSS fix, moves it from the antenna
//! to the reference point with the lever arm (`GPS_POS1_X/Y`), takes heading
//! from a dual-antenna HDT (or the course over ground when there is none),
//! and dead-reckons with the GNSS velocity between fixes. The navigation
//! issue replaces it with the EKF of DESIGN §5.2.

mod gnss_status;

use std::time::Duration;

use drivers::gnss::{FixQuality, GnssSample};

use crate::geo::{GeoPoint, LocalFrame, Ned, wrap_pi};

pub use gnss_status::GnssStatus;

/// A fix or heading older than this is not used.
const SAMPLE_TIMEOUT: Duration = Duration::from_millis(1000);
/// Below this ground speed the course over ground is noise.
const MIN_COURSE_SPEED_MPS: f64 = 0.3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EstimatorConfig {
    /// GNSS antenna position in the body frame (x forward, y right) relative
    /// to the reference point.
    pub antenna_body_m: (f64, f64),
}

/// The estimate at one instant.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    pub position: Ned,
    pub yaw_rad: f64,
    pub yaw_rate_rad_s: f64,
    pub vel_north_mps: f64,
    pub vel_east_mps: f64,
    /// Along the body x axis: negative when reversing.
    pub speed_mps: f64,
    pub position_valid: bool,
    pub heading_valid: bool,
    /// 1-σ horizontal position uncertainty.
    pub horiz_sigma_m: f64,
}

impl Estimate {
    pub fn ground_speed_mps(&self) -> f64 {
        self.vel_north_mps.hypot(self.vel_east_mps)
    }
}

#[derive(Default)]
pub struct Estimator {
    frame: Option<LocalFrame>,
    gnss: GnssStatus,
    antenna_ned: Option<(Duration, Ned)>,
    heading: Option<(Duration, f64)>,
    yaw_rate_rad_s: f64,
    velocity: Option<(Duration, f64, f64)>,
    estimate: Estimate,
}

impl Estimator {
    pub fn new() -> Self {
        Self::default()
    }

    /// The local frame, fixed at the first valid fix (ArduPilot's EKF origin).
    pub fn frame(&self) -> Option<&LocalFrame> {
        self.frame.as_ref()
    }

    pub fn gnss(&self) -> &GnssStatus {
        &self.gnss
    }

    pub fn estimate(&self) -> &Estimate {
        &self.estimate
    }

    /// Folds in new samples, then predicts the estimate to `now`.
    pub fn update(&mut self, now: Duration, config: &EstimatorConfig, samples: &[GnssSample]) {
        for sample in samples {
            self.gnss.apply(sample);
            self.apply(sample);
        }
        self.predict(now, config);
    }

    fn apply(&mut self, sample: &GnssSample) {
        match sample {
            GnssSample::Fix(fix) => {
                let p = GeoPoint::new(fix.lat_deg, fix.lon_deg, fix.alt_msl_m);
                if fix.quality == FixQuality::NoFix || !p.is_valid() {
                    self.antenna_ned = None;
                    return;
                }
                let frame = *self.frame.get_or_insert_with(|| LocalFrame::new(p));
                self.antenna_ned = Some((fix.t, frame.to_local(&p)));
            }
            GnssSample::Heading(h) if h.heading_deg.is_finite() => {
                let yaw = wrap_pi(h.heading_deg.to_radians());
                if let Some((t0, yaw0)) = self.heading {
                    let dt = h.t.saturating_sub(t0).as_secs_f64();
                    if dt > 0.0 && dt < 1.0 {
                        // Light low-pass: differentiated heading noise is large.
                        let rate = wrap_pi(yaw - yaw0) / dt;
                        self.yaw_rate_rad_s += 0.5 * (rate - self.yaw_rate_rad_s);
                    }
                }
                self.heading = Some((h.t, yaw));
            }
            GnssSample::Velocity(v) if v.speed_mps.is_finite() => {
                let course = v.course_deg.filter(|c| c.is_finite()).map(f64::to_radians);
                let (vn, ve) = match course {
                    Some(c) if v.speed_mps >= 0.05 => (v.speed_mps * c.cos(), v.speed_mps * c.sin()),
                    _ => (0.0, 0.0),
                };
                self.velocity = Some((v.t, vn, ve));
            }
            _ => {}
        }
    }

    fn predict(&mut self, now: Duration, config: &EstimatorConfig) {
        let fresh = |t: Duration| now.saturating_sub(t) <= SAMPLE_TIMEOUT;
        let (vel_n, vel_e) = match self.velocity {
            Some((t, vn, ve)) if fresh(t) => (vn, ve),
            _ => (0.0, 0.0),
        };
        let ground_speed = vel_n.hypot(vel_e);

        let (heading_valid, yaw) = match self.heading {
            Some((t, yaw)) if fresh(t) => (
                true,
                wrap_pi(yaw + self.yaw_rate_rad_s * now.saturating_sub(t).as_secs_f64()),
            ),
            // No heading sensor: the course over ground when moving forwards.
            _ if ground_speed >= MIN_COURSE_SPEED_MPS => (true, vel_e.atan2(vel_n)),
            _ => (false, self.estimate.yaw_rad),
        };
        let yaw_rate = if heading_valid { self.yaw_rate_rad_s } else { 0.0 };

        let (position_valid, position) = match self.antenna_ned {
            Some((t, antenna)) if fresh(t) => {
                let dt = now.saturating_sub(t).as_secs_f64();
                let (s, c) = yaw.sin_cos();
                let (ax, ay) = config.antenna_body_m;
                let reference = Ned::new(
                    antenna.north_m - (ax * c - ay * s) + vel_n * dt,
                    antenna.east_m - (ax * s + ay * c) + vel_e * dt,
                );
                (true, reference)
            }
            _ => (false, self.estimate.position),
        };

        let along_heading = vel_n * yaw.cos() + vel_e * yaw.sin();
        self.estimate = Estimate {
            position,
            yaw_rad: yaw,
            yaw_rate_rad_s: yaw_rate,
            vel_north_mps: vel_n,
            vel_east_mps: vel_e,
            speed_mps: if heading_valid { along_heading } else { ground_speed },
            position_valid,
            heading_valid,
            horiz_sigma_m: self.gnss.horizontal_sigma_m(),
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drivers::gnss::{GnssFix, GnssHeading, GnssVelocity};

    fn fix(t_ms: u64, lat: f64, lon: f64) -> GnssSample {
        GnssSample::Fix(GnssFix {
            t: Duration::from_millis(t_ms),
            utc_time_of_day_s: None,
            lat_deg: lat,
            lon_deg: lon,
            alt_msl_m: 40.0,
            quality: FixQuality::RtkFixed,
            satellites: 20,
            hdop: 0.6,
        })
    }

    fn heading(t_ms: u64, deg: f64) -> GnssSample {
        GnssSample::Heading(GnssHeading {
            t: Duration::from_millis(t_ms),
            heading_deg: deg,
        })
    }

    #[test]
    fn lever_arm_moves_the_fix_to_the_reference_point() {
        let config = EstimatorConfig {
            antenna_body_m: (0.5, 0.0),
        };
        let mut est = Estimator::new();
        // Origin at the first fix, vehicle facing east: the reference point
        // is 0.5 m west of the antenna.
        est.update(Duration::ZERO, &config, &[heading(0, 90.0), fix(0, 29.133, 119.64)]);
        let e = est.estimate();
        assert!(e.position_valid && e.heading_valid);
        assert!((e.position.east_m + 0.5).abs() < 1e-9, "{:?}", e.position);
        assert!(e.position.north_m.abs() < 1e-9);
    }

    #[test]
    fn dead_reckons_between_fixes_and_detects_reverse() {
        let config = EstimatorConfig {
            antenna_body_m: (0.0, 0.0),
        };
        let mut est = Estimator::new();
        let vel = GnssSample::Velocity(GnssVelocity {
            t: Duration::ZERO,
            speed_mps: 1.0,
            course_deg: Some(180.0),
        });
        est.update(Duration::ZERO, &config, &[heading(0, 0.0), fix(0, 29.133, 119.64), vel]);
        est.update(Duration::from_millis(50), &config, &[]);
        let e = est.estimate();
        assert!((e.position.north_m + 0.05).abs() < 1e-6, "{:?}", e.position);
        assert!(
            (e.speed_mps + 1.0).abs() < 1e-9,
            "facing north, moving south: reversing"
        );
    }

    #[test]
    fn stale_fix_invalidates_position() {
        let config = EstimatorConfig {
            antenna_body_m: (0.0, 0.0),
        };
        let mut est = Estimator::new();
        est.update(Duration::ZERO, &config, &[heading(0, 0.0), fix(0, 29.133, 119.64)]);
        est.update(Duration::from_millis(1500), &config, &[]);
        assert!(!est.estimate().position_valid);
    }
}
