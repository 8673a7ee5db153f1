//! MAGNETIC: following a magnetic tape with the two guide sensors (seed 002,
//! docs/architecture.md §Kinematics and the magnetic guide). It needs no position fix: the tape is the reference.
//!
//! Sources: docs/references.md §Seed 002.

use std::time::Duration;

use mavlink::dialects::ardupilotmega::MavSeverity;

use crate::guidance::magnetic::{
    IncrementalPidGains, MagneticGuide, MagneticGuideConfig, MagneticInput, MagneticStatus,
};
use crate::guidance::navigator::NavDemand;
use crate::modes::Mode;
use crate::vehicle::Core;

/// A reading older than this is no reading: the mode stops.
const SENSOR_TIMEOUT: Duration = Duration::from_millis(500);

/// The mode's state.
#[derive(Clone, Debug, Default)]
pub(in crate::vehicle) struct MagneticState {
    pub guide: MagneticGuide,
    pub status: MagneticStatus,
    pub lost_s: f64,
    pub stale_reported: bool,
}

impl Core {
    pub(in crate::vehicle) fn magnetic_config(&self) -> MagneticGuideConfig {
        let t = &self.params;
        let m = &self.p.magnetic;
        let f = |p: params::Param<f32>| f64::from(p.get(t));
        let defaults = MagneticGuideConfig::default();
        MagneticGuideConfig {
            probe_pitch_m: f(m.pitch_mm) / 1000.0,
            front_x_m: f(m.front_x_m),
            rear_x_m: f(m.rear_x_m),
            steer: IncrementalPidGains {
                kp: f(m.steer_p),
                ki: f(m.steer_i),
                kd: f(m.steer_d),
                ..defaults.steer
            },
            steer_max_rad: f(self.p.vehicle.steer_max_deg).to_radians(),
            steer_rate_rad_s: f(self.p.vehicle.steer_rate_deg_s).to_radians(),
            steer_correction_max_rad: f(m.steer_correction_deg).to_radians(),
            wheelbase_m: f(self.p.vehicle.wheelbase_m),
            speed: IncrementalPidGains {
                kp: f(m.speed_p),
                ki: f(m.speed_i),
                ..defaults.speed
            },
            angle_deadband_rad: f(m.speed_deadband_deg).to_radians(),
            cruise_speed_mps: f(m.speed_mps),
            min_speed_mps: f(m.speed_min_mps),
            lost_speed_mps: f(m.lost_speed_mps),
            lost_hold_s: f(m.lost_hold_s),
            ..defaults
        }
    }

    /// Whether the sensors are reporting.
    pub(in crate::vehicle) fn magnetic_sensors_fresh(&self) -> bool {
        self.magnetic_sample
            .is_some_and(|s| self.now.boot.saturating_sub(s.t) <= SENSOR_TIMEOUT)
    }

    /// Entering MAGNETIC: the guide starts from the steering the wheels have.
    pub(in crate::vehicle) fn start_magnetic(&mut self) {
        let steer_max = f64::from(self.p.vehicle.steer_max_deg.get(&self.params)).to_radians();
        self.magnetic = MagneticState {
            guide: MagneticGuide::engaged_at(self.drive.steering * steer_max),
            ..MagneticState::default()
        };
    }

    /// This tick's demand in MAGNETIC; `None` to stop.
    pub(in crate::vehicle) fn magnetic_demand(&mut self, dt_s: f64) -> Option<NavDemand> {
        let Some(sample) = self.magnetic_sample.filter(|_| self.magnetic_sensors_fresh()) else {
            if !self.magnetic.stale_reported {
                self.magnetic.stale_reported = true;
                self.send_text(MavSeverity::MAV_SEVERITY_CRITICAL, "Magnetic sensors silent: stopped");
            }
            return None;
        };
        self.magnetic.stale_reported = false;
        let estimate = *self.estimator.estimate();
        // The guide needs speed and yaw rate for its kinematic rate. Without
        // an estimate (no GNSS under a roof, say), the last commands stand
        // in: the speed asked for, and the yaw rate its steering gives.
        let (speed, yaw_rate) = if estimate.position_valid && estimate.heading_valid {
            (estimate.speed_mps, estimate.yaw_rate_rad_s)
        } else {
            let speed = self.magnetic.status.speed_mps;
            let wheelbase = f64::from(self.p.vehicle.wheelbase_m.get(&self.params));
            (speed, speed * self.magnetic.status.steer_rad.tan() / wheelbase)
        };
        let config = self.magnetic_config();
        let status = self.magnetic.guide.update(
            &config,
            &MagneticInput {
                front_mask: sample.front_mask,
                rear_mask: sample.rear_mask,
                speed_mps: speed,
                yaw_rate_rad_s: yaw_rate,
            },
            dt_s,
        );
        self.magnetic.status = status;
        let lost_stop_s = f64::from(self.p.magnetic.lost_stop_s.get(&self.params));
        if status.lost {
            self.magnetic.lost_s += dt_s;
            if lost_stop_s > 0.0 && self.magnetic.lost_s >= lost_stop_s {
                self.send_text(
                    MavSeverity::MAV_SEVERITY_CRITICAL,
                    &format!("Magnetic tape lost for {lost_stop_s:.0} s: HOLD"),
                );
                self.enter_mode(Mode::Hold);
                return None;
            }
        } else {
            self.magnetic.lost_s = 0.0;
        }
        Some(NavDemand {
            steer_rad: status.steer_rad,
            speed_mps: status.speed_mps,
            pivot_rate_rad_s: 0.0,
        })
    }
}
