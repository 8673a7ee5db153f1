//! `MAV_CMD_DO_FLIGHTTERMINATION` as ArduPilot Rover carries it out (its
//! advanced failsafe's `terminate_vehicle`): the vehicle is disarmed and put
//! in HOLD, and stays terminated — it cannot be armed, not even by force —
//! until a ground station sends the command again with param1 0. A fleet's
//! master control sees it as a REMOTE e-stop (`vehicle/fleet_report.rs`).

use mavlink::dialects::ardupilotmega::{MavResult, MavSeverity};

use super::Core;
use crate::modes::Mode;

/// Why arming is refused while the vehicle is terminated (fits a
/// "PreArm: …" STATUSTEXT).
pub(super) const TERMINATED: &str = "Flight terminated";

impl Core {
    /// param1 > 0.5 terminates, otherwise the termination is cleared (as
    /// ArduPilot's `gcs_terminate`).
    pub(super) fn flight_termination(&mut self, p1: f32) -> MavResult {
        if !p1.is_finite() {
            return MavResult::MAV_RESULT_DENIED;
        }
        if p1 > 0.5 {
            self.terminate();
        } else if self.terminated {
            self.terminated = false;
            self.send_text(
                MavSeverity::MAV_SEVERITY_INFO,
                "Aborting termination due to GCS request",
            );
        }
        MavResult::MAV_RESULT_ACCEPTED
    }

    fn terminate(&mut self) {
        if !self.terminated {
            self.send_text(MavSeverity::MAV_SEVERITY_CRITICAL, "Terminating due to GCS request");
        }
        self.terminated = true;
        self.disarm();
        if self.mode != Mode::Hold {
            self.enter_mode(Mode::Hold);
        }
    }

    /// Terminated by a ground station and not cleared yet.
    pub fn is_terminated(&self) -> bool {
        self.terminated
    }
}
