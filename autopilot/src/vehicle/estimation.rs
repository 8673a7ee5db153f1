//! The estimator's settings from the parameters, what it reports said to
//! the operator, and the fix-quality policy (`GPS_FLOAT_ACT`,
//! `GPS_SINGLE_ACT`).

use drivers::gnss::FixQuality;
use mavlink::dialects::ardupilotmega::MavSeverity;

use super::Core;
use crate::control::mixer::DriveTrain;
use crate::estimation::ekf::EkfConfig;
use crate::estimation::{DegradedFixAction, EstimatorConfig, EstimatorEvent};
use crate::modes::Mode;

/// Rank of a fix: higher is better.
pub(super) fn rank(q: FixQuality) -> u8 {
    match q {
        FixQuality::RtkFixed => 5,
        FixQuality::RtkFloat => 4,
        FixQuality::Dgps => 3,
        FixQuality::Single => 2,
        _ => 0,
    }
}

pub(super) fn fix_name(q: FixQuality) -> &'static str {
    match q {
        FixQuality::RtkFixed => "RTK fixed",
        FixQuality::RtkFloat => "RTK float",
        FixQuality::Dgps => "DGPS",
        FixQuality::Single => "single",
        _ => "no fix",
    }
}

impl Core {
    pub(super) fn estimator_config(&self) -> EstimatorConfig {
        let t = &self.params;
        let ekf = &self.p.ekf;
        let vehicle = &self.p.vehicle;
        let (frame_kind, map) = self.p.geo.settings(t);
        let wheelbase = f64::from(vehicle.wheelbase_m.get(t));
        let steer_max = f64::from(vehicle.steer_max_deg.get(t)).to_radians();
        let base = EkfConfig {
            antenna_body_m: (
                f64::from(vehicle.antenna_x_m.get(t)),
                f64::from(vehicle.antenna_y_m.get(t)),
            ),
            // A single fix (σ ≈ 1–2.5 m) is still a position: whether to
            // drive on it is GPS_SINGLE_ACT's call, not the filter's health.
            healthy_max_position_sigma_m: 5.0,
            ..EkfConfig::default()
        };
        let base = match self.drive_train {
            // A car cannot turn on the spot: its yaw rate is speed × curvature.
            DriveTrain::Ackermann => EkfConfig {
                max_curvature_per_m: steer_max.tan() / wheelbase,
                ..base
            },
            // Two driven wheels set the yaw rate whatever the speed: it is
            // the pivot rate alone, with no curvature state. A curvature
            // beside it is unobservable near standstill, and through a turn
            // on the spot took values of 8/m, so the speed's noise times
            // that curvature let the heading wander by degrees per √s.
            DriveTrain::Differential => EkfConfig {
                pivot_yaw_accel_sigma_radps2: 1.0,
                init_pivot_rate_sigma_rad_s: 0.5,
                max_curvature_per_m: 0.0,
                ..base
            },
        };
        EstimatorConfig {
            ekf: ekf.ekf_config(t, base),
            frame_kind,
            map,
            velocity_sigma_mps: f64::from(ekf.vel_noise_mps.get(t)),
            heading_sigma_rad: f64::from(ekf.hdg_noise_deg.get(t)).to_radians(),
            declination_rad: f64::from(ekf.declination_rad.get(t)),
        }
    }

    /// What the current fix quality calls for.
    pub(super) fn degraded_fix_action(&self) -> DegradedFixAction {
        let q = &self.p.gnss_quality;
        match self.estimator.gnss().quality {
            Some(FixQuality::RtkFixed) | None => DegradedFixAction::Continue,
            Some(FixQuality::RtkFloat) => DegradedFixAction::from_param(q.float_action.get(&self.params)),
            Some(_) => DegradedFixAction::from_param(q.single_action.get(&self.params)),
        }
    }

    /// The speed limit a degraded fix sets ("slow"), if any.
    pub(super) fn degraded_fix_speed_limit(&self) -> Option<f64> {
        (self.degraded_fix_action() == DegradedFixAction::Slow)
            .then(|| f64::from(self.p.gnss_quality.degraded_speed_mps.get(&self.params)))
    }

    pub(super) fn report_estimator_events(&mut self) {
        for event in self.estimator.take_events() {
            match event {
                EstimatorEvent::FixQuality { from, to } => {
                    let worse = from.is_some_and(|f| rank(to) < rank(f));
                    let text = match from {
                        Some(f) if worse => format!("GPS: {} lost, now {}", fix_name(f), fix_name(to)),
                        _ => format!("GPS: {}", fix_name(to)),
                    };
                    let severity = if worse {
                        MavSeverity::MAV_SEVERITY_WARNING
                    } else {
                        MavSeverity::MAV_SEVERITY_INFO
                    };
                    self.send_text(severity, &text);
                    if worse {
                        self.apply_degraded_fix_action();
                    }
                }
                EstimatorEvent::GpsJumpRejected { distance_m } => self.send_text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    &format!("EKF: GPS jump of {distance_m:.2} m rejected"),
                ),
                EstimatorEvent::PositionReset { shift_m } => self.send_text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    &format!("EKF: position reset to GPS, moved {shift_m:.2} m"),
                ),
                EstimatorEvent::HeadingRejected { error_rad } => self.send_text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    &format!("EKF: heading {:.1} deg off rejected", error_rad.to_degrees()),
                ),
                EstimatorEvent::HeadingReset { shift_rad } => self.send_text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    &format!("EKF: heading reset, turned {:.2} deg", shift_rad.to_degrees()),
                ),
                EstimatorEvent::Initialised => {
                    self.send_text(MavSeverity::MAV_SEVERITY_INFO, "EKF: using GPS position and heading")
                }
                EstimatorEvent::Healthy(true) => self.send_text(MavSeverity::MAV_SEVERITY_INFO, "EKF: healthy"),
                EstimatorEvent::Healthy(false) => {
                    self.send_text(MavSeverity::MAV_SEVERITY_CRITICAL, "EKF: unhealthy, no position")
                }
                EstimatorEvent::GyroCalibrated { bias_rad_s } => self.send_text(
                    MavSeverity::MAV_SEVERITY_INFO,
                    &format!("IMU: gyro bias {:.3} deg/s, yaw rate in use", bias_rad_s.to_degrees()),
                ),
                // The one substitution there is (STATUSTEXT holds 50 characters).
                EstimatorEvent::FrameSubstituted { .. } => self.send_text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    "EKF: GEO_FRAME 1 unusable at a pole: tangent plane",
                ),
            }
        }
    }

    /// On a downgrade: `hold` stops a vehicle that is driving by itself.
    fn apply_degraded_fix_action(&mut self) {
        let driving = matches!(self.mode, Mode::Auto | Mode::Guided | Mode::Rtl);
        match self.degraded_fix_action() {
            DegradedFixAction::Hold if driving => {
                self.send_text(MavSeverity::MAV_SEVERITY_CRITICAL, "GPS fix degraded: HOLD");
                self.enter_mode(Mode::Hold);
            }
            DegradedFixAction::Slow if driving => {
                let limit = self.p.gnss_quality.degraded_speed_mps.get(&self.params);
                self.send_text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    &format!("GPS fix degraded: speed limited to {limit:.1} m/s"),
                );
            }
            _ => {}
        }
    }
}
