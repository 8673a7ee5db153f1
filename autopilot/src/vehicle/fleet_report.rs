//! What the core tells the VDA 5050 agent about the vehicle for `state`:
//! pose and its quality, motion, battery, and the health the master control
//! acts on — errors with their levels (failsafes, GNSS loss, obstacle
//! stops), information (mode, GNSS fix, why it stands), and the e-stop
//! (docs/architecture.md §Fleets).

use drivers::gnss::FixQuality;
use vda5050::state::{EStop, Error, ErrorLevel, InfoLevel, Information};

use super::Core;
use super::failsafe::{Failsafe, FailsafeAction};
use crate::fleet::VehicleReport;
use crate::fleet::order::error;
use crate::obstacles::policy::StopCause;

fn fix_name(quality: Option<FixQuality>) -> &'static str {
    match quality {
        Some(FixQuality::RtkFixed) => "RTK fixed",
        Some(FixQuality::RtkFloat) => "RTK float",
        Some(FixQuality::Dgps) => "DGPS",
        Some(FixQuality::Single) => "single",
        Some(FixQuality::DeadReckoning) => "dead reckoning",
        Some(FixQuality::Manual) => "manual",
        _ => "no fix",
    }
}

fn localization_score(quality: Option<FixQuality>) -> f64 {
    match quality {
        Some(FixQuality::RtkFixed) => 1.0,
        Some(FixQuality::RtkFloat) => 0.7,
        Some(FixQuality::Dgps) => 0.5,
        Some(FixQuality::Single) => 0.3,
        Some(FixQuality::DeadReckoning) => 0.1,
        _ => 0.0,
    }
}

fn info(info_type: &str, description: String) -> Information {
    Information {
        info_type: info_type.to_owned(),
        info_references: None,
        info_description: Some(description),
        info_level: InfoLevel::Info,
    }
}

/// A protective stop for something in the path (not a sensor fault).
fn in_path(cause: Option<StopCause>) -> bool {
    matches!(
        cause,
        Some(StopCause::ProtectiveField { .. } | StopCause::Collision { .. })
    )
}

impl Core {
    pub(super) fn vehicle_report(&self, driving: bool, remote_stop: bool) -> VehicleReport {
        let estimate = self.estimator.estimate();
        let obstacle_stop = self.obstacles.status().stop_cause;
        VehicleReport {
            pose: self.fleet_pose(),
            position_initialized: estimate.position_valid && estimate.heading_valid,
            localization_score: localization_score(self.estimator.gnss().quality),
            // 2σ: the standard's range holds the position with ~95 %.
            deviation_range_m: 2.0 * estimate.horiz_sigma_m,
            speed_mps: estimate.speed_mps,
            // Clockwise in the core, counter-clockwise in the map frame.
            yaw_rate_rad_s: -estimate.yaw_rate_rad_s,
            driving,
            battery_percent: self.battery.map_or(0.0, |b| b.remaining_pct),
            battery_voltage_v: self.battery.map(|b| b.voltage_v),
            operating_mode: self.operating_mode(),
            errors: self.fleet_errors(),
            information: self.fleet_information(remote_stop),
            field_violation: in_path(obstacle_stop),
            e_stop: self.fleet_e_stop(remote_stop),
        }
    }

    /// The e-stop the state reports: REMOTE while a ground station's
    /// termination or disarm holds the vehicle (both are cleared only from
    /// a ground station), AUTOACK while something in the path stops it (the
    /// stop ends by itself once the path is clear).
    pub(super) fn fleet_e_stop(&self, remote_stop: bool) -> EStop {
        if self.terminated || remote_stop {
            EStop::Remote
        } else if in_path(self.obstacles.status().stop_cause) {
            EStop::AutoAck
        } else {
            EStop::None
        }
    }

    /// Failsafes (FATAL when they take the vehicle, WARNING when they only
    /// report), a GNSS without fix, and an obstacle stop (WARNING).
    fn fleet_errors(&self) -> Vec<Error> {
        let mut errors = Vec::new();
        if self.terminated {
            let mut e = error(
                "flightTermination",
                "terminated by a ground station: disarmed and held".into(),
                Vec::new(),
            );
            e.error_level = ErrorLevel::Fatal;
            errors.push(e);
        }
        for failsafe in self.active_failsafes() {
            let kind = match failsafe {
                Failsafe::GnssLost => "gnssLost",
                Failsafe::Scanner => "scannerStale",
                _ => "failsafe",
            };
            let action = self.effective_action(failsafe, self.mode);
            let mut e = error(
                kind,
                format!("{}: {}", failsafe.name(), action.name()),
                vec![("failsafe", failsafe.name().to_owned())],
            );
            if action != FailsafeAction::Report {
                e.error_level = ErrorLevel::Fatal;
            }
            errors.push(e);
        }
        let quality = self.estimator.gnss().quality;
        let no_fix = matches!(quality, None | Some(FixQuality::NoFix));
        if no_fix && !self.active_failsafes().any(|f| f == Failsafe::GnssLost) {
            errors.push(error("gnssLost", "no GNSS fix".into(), Vec::new()));
        }
        if let Some(cause) = self.obstacles.status().stop_cause {
            let kind = if in_path(Some(cause)) {
                "obstacleStop"
            } else {
                "scannerStale"
            };
            errors.push(error(kind, format!("stopped: {cause}"), Vec::new()));
        }
        errors
    }

    /// The mode, the GNSS fix, and why the vehicle stands, for people.
    fn fleet_information(&self, remote_stop: bool) -> Vec<Information> {
        let gnss = self.estimator.gnss();
        let mut information = vec![
            info("mode", self.mode.name().to_owned()),
            info(
                "gnssFix",
                format!(
                    "{}, {} satellites, HDOP {:.1}",
                    fix_name(gnss.quality),
                    gnss.satellites,
                    gnss.hdop
                ),
            ),
        ];
        if let Some(cause) = self.obstacles.status().stop_cause {
            information.push(info("obstacleStop", cause.to_string()));
        }
        if self.terminated {
            information.push(info(
                "eStop",
                "flight termination by a ground station: DO_FLIGHTTERMINATION 0 clears it, then arm".into(),
            ));
        } else if remote_stop {
            information.push(info(
                "eStop",
                "disarmed by a ground station during the order: arm again to go on".into(),
            ));
        }
        information
    }
}
