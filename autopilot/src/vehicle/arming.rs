//! Arming and disarming. Each failed check is reported in its own
//! STATUSTEXT ("PreArm: …") the way ArduPilot does, so the operator sees
//! every reason, not just the first.

use std::time::Duration;

use mavlink::dialects::ardupilotmega::MavSeverity;

use super::Core;
use crate::modes::Mode;

/// A fix older than this does not count for arming.
const FIX_MAX_AGE: Duration = Duration::from_secs(2);

impl Core {
    /// Reasons the vehicle cannot arm now (empty: it can).
    pub fn arming_failures(&self) -> Vec<&'static str> {
        let mut failures = Vec::new();
        if self.mode == Mode::Initialising {
            failures.push("Mode not armable");
        }
        if self.p.system.arming_check.get(&self.params) == 0 {
            return failures;
        }
        let estimate = self.estimator.estimate();
        // Driven by hand or along a tape, the vehicle needs no fix (as
        // ArduPilot's manual modes); HOLD is where it waits to drive itself.
        let needs_fix = !matches!(self.mode, Mode::Manual | Mode::Magnetic);
        let has_fix = self.estimator.gnss().has_fix(self.now.boot, FIX_MAX_AGE) && estimate.position_valid;
        if needs_fix && !has_fix {
            failures.push("No position fix");
        }
        if !estimate.heading_valid && self.mode.requires_position() {
            failures.push("No heading");
        }
        if f64::from(self.p.nav.wp_speed_mps.get(&self.params)) <= 0.0 {
            failures.push("WP_SPEED is 0");
        }
        if let Some(fence) = self.fence_arming_failure() {
            failures.push(fence);
        }
        failures
    }

    /// Arms if the checks pass (or `force`). Home follows the vehicle until
    /// arming, as in ArduPilot, unless a ground station set it.
    pub(super) fn arm(&mut self, force: bool) -> bool {
        if self.armed {
            return true;
        }
        if force {
            self.send_text(MavSeverity::MAV_SEVERITY_WARNING, "Arming checks skipped (forced)");
        } else {
            let failures = self.arming_failures();
            if !failures.is_empty() {
                for f in failures {
                    self.send_text(MavSeverity::MAV_SEVERITY_CRITICAL, &format!("PreArm: {f}"));
                }
                return false;
            }
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
