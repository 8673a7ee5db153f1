//! Arming and disarming. Each failed check is reported in its own
//! STATUSTEXT ("PreArm: …") the way ArduPilot does, so the operator sees
//! every reason, not just the first. `ARMING_CHECK` selects the checks with
//! ArduPilot's bits where the check has an ArduPilot counterpart.

use drivers::gnss::FixQuality;
use mavlink::dialects::ardupilotmega::MavSeverity;

use super::Core;
use super::estimation::{fix_name, rank};
use crate::modes::Mode;

/// `ARMING_CHECK` bits.
pub mod check {
    pub const ALL: i32 = 1;
    pub const HEADING: i32 = 4;
    pub const POSITION_FIX: i32 = 8;
    pub const EKF: i32 = 16;
    pub const PARAMETERS: i32 = 32;
    pub const BATTERY: i32 = 256;
    pub const FENCE: i32 = 8192;
    pub const MISSION: i32 = 16384;
    pub const SCANNERS: i32 = 32768;
}

impl Core {
    /// Reasons the vehicle cannot arm now (empty: it can).
    pub fn arming_failures(&self) -> Vec<String> {
        let mut failures = Vec::new();
        if self.terminated {
            failures.push(super::termination::TERMINATED.to_string());
        }
        if self.mode == Mode::Initialising {
            failures.push("Mode not armable".to_string());
        }
        let mask = self.p.system.arming_check.get(&self.params);
        let enabled = |bit: i32| mask & check::ALL != 0 || mask & bit != 0;
        let estimate = self.estimator.estimate();
        // Driven by hand or along a tape, the vehicle needs no fix (as
        // ArduPilot's manual modes); HOLD is where it waits to drive itself.
        let drives_itself = !matches!(self.mode, Mode::Manual | Mode::Magnetic);
        let gnss = self.estimator.gnss();
        // A fix older than the GNSS failsafe's timeout is a lost GNSS.
        let fix_max_age = crate::time::duration_from_secs(f64::from(self.p.failsafe.gnss_lost_s.get(&self.params)));
        let has_fix = gnss.has_fix(self.now.boot, fix_max_age);
        if enabled(check::POSITION_FIX) && drives_itself {
            if !has_fix {
                failures.push("No position fix".to_string());
            } else if let Some(quality) = gnss.quality
                && let Some(needed) = self.required_fix()
                && rank(quality) < rank(needed)
            {
                // STATUSTEXT carries 50 characters: "PreArm: " + this fits.
                failures.push(format!("GPS fix {}, need {}", fix_name(quality), fix_name(needed)));
            }
        }
        if enabled(check::EKF) && drives_itself && has_fix && !estimate.position_valid {
            failures.push("EKF unhealthy".to_string());
        }
        if enabled(check::HEADING) && drives_itself && estimate.position_valid && !estimate.heading_valid {
            failures.push("No heading".to_string());
        }
        if enabled(check::SCANNERS) && self.mode != Mode::Manual {
            for scanner in self.stale_scanners() {
                failures.push(format!("Scanner {} not sending", scanner + 1));
            }
        }
        // AUTO drives a VDA 5050 order when one is held, else the mission.
        let nothing_to_drive = !self.missions.executor.has_nav_items() && !self.fleet_drives();
        if enabled(check::MISSION) && self.mode == Mode::Auto && nothing_to_drive {
            failures.push("No mission for AUTO".to_string());
        }
        if enabled(check::FENCE)
            && let Some(fence) = self.fence_arming_failure()
        {
            failures.push(fence.to_string());
        }
        if enabled(check::BATTERY) {
            failures.extend(self.battery_arming_failure());
        }
        if enabled(check::PARAMETERS) {
            failures.extend(self.parameter_inconsistencies());
        }
        // Not an ARMING_CHECK bit: a failsafe that is on is no check to skip.
        failures.extend(
            self.failsafes_refusing_arming(self.mode)
                .map(|f| format!("Failsafe on: {}", f.name())),
        );
        failures
    }

    /// `ARMING_RTK_REQ`: the fix needed to arm a vehicle that drives itself.
    fn required_fix(&self) -> Option<FixQuality> {
        match self.p.failsafe.rtk_required.get(&self.params) {
            1 => Some(FixQuality::RtkFloat),
            2 => Some(FixQuality::RtkFixed),
            _ => None,
        }
    }

    pub(super) fn battery_arming_failure(&self) -> Option<String> {
        let voltage = self.battery?.voltage_v;
        let fs = &self.p.failsafe;
        let critical = f64::from(fs.batt_crit_volt.get(&self.params));
        let low = f64::from(fs.batt_low_volt.get(&self.params));
        if critical > 0.0 && voltage < critical {
            Some(format!("Battery {voltage:.1} V below BATT_CRT_VOLT"))
        } else if low > 0.0 && voltage < low {
            Some(format!("Battery {voltage:.1} V below BATT_LOW_VOLT"))
        } else {
            None
        }
    }

    /// Settings that are each in range but contradict one another.
    fn parameter_inconsistencies(&self) -> Vec<String> {
        let t = &self.params;
        let mut found = Vec::new();
        if f64::from(self.p.nav.wp_speed_mps.get(t)) <= 0.0 {
            found.push("WP_SPEED is 0".to_string());
        }
        let fs = &self.p.failsafe;
        let (low, critical) = (fs.batt_low_volt.get(t), fs.batt_crit_volt.get(t));
        if low > 0.0 && critical > 0.0 && critical >= low {
            found.push("BATT_CRT_VOLT not below BATT_LOW_VOLT".to_string());
        }
        let scanners = &self.p.obstacles.scanners;
        if self.p.obstacles.avoidance.enable.get(t) && !scanners.scan1_enable.get(t) && !scanners.scan2_enable.get(t) {
            found.push("OA_ENABLE 1 but no scanner enabled".to_string());
        }
        found
    }

    /// Arms if the checks pass (or `force`: the checks are still run and
    /// what they found is said, as a warning). Home follows the vehicle
    /// until arming, as in ArduPilot, unless a ground station set it.
    pub(super) fn arm(&mut self, force: bool) -> bool {
        if self.armed {
            return true;
        }
        let failures = self.arming_failures();
        // A termination is no check to skip.
        if force && self.terminated {
            let text = format!("PreArm: {}", super::termination::TERMINATED);
            self.send_text(MavSeverity::MAV_SEVERITY_CRITICAL, &text);
            return false;
        }
        if force {
            tracing::warn!("arming forced (magic value): checks skipped: {failures:?}");
            self.send_text(MavSeverity::MAV_SEVERITY_WARNING, "Arming checks skipped (forced)");
            for f in &failures {
                self.send_text(MavSeverity::MAV_SEVERITY_WARNING, &format!("Skipped: {f}"));
            }
        } else if !failures.is_empty() {
            for f in failures {
                self.send_text(MavSeverity::MAV_SEVERITY_CRITICAL, &format!("PreArm: {f}"));
            }
            return false;
        }
        if !self.home_set_by_gcs {
            self.set_home_to_current(false);
        }
        self.armed = true;
        self.speed_control.reset(self.estimator.estimate().speed_mps);
        self.send_text(MavSeverity::MAV_SEVERITY_INFO, "Throttle armed");
        true
    }

    pub(super) fn disarm(&mut self) -> bool {
        if self.armed {
            self.armed = false;
            self.send_text(MavSeverity::MAV_SEVERITY_INFO, "Throttle disarmed");
        }
        true
    }
}
