//! `MAV_CMD_DO_FLIGHTTERMINATION` as ArduPilot Rover carries it out (its
//! advanced failsafe's `terminate_vehicle`): the vehicle is disarmed and put
//! in HOLD, and stays terminated — it cannot be armed, not even by force —
//! until a ground station sends the command again with param1 0. A fleet's
//! master control sees it as a REMOTE e-stop (`vehicle/fleet_report.rs`).
//!
//! With durable storage the state is saved before the command is
//! acknowledged, and a restart comes back terminated: a termination stops
//! the vehicle at once, and its ACK says whether it is saved; a clear is in
//! force only once saved (else the restart would terminate again).

use mavlink::dialects::ardupilotmega::{MavResult, MavSeverity};

use super::commands::AckTo;
use super::{Core, Storage};
use crate::modes::Mode;

/// Why arming is refused while the vehicle is terminated (fits a
/// "PreArm: …" STATUSTEXT).
pub(super) const TERMINATED: &str = "Flight terminated";

impl Core {
    /// param1 > 0.5 terminates, otherwise the termination is cleared (as
    /// ArduPilot's `gcs_terminate`). `None`: the COMMAND_ACK waits for the
    /// save ([`Core::termination_saved`] sends it).
    pub(super) fn flight_termination(&mut self, p1: f32, ack_to: AckTo) -> Option<MavResult> {
        if !p1.is_finite() {
            return Some(MavResult::MAV_RESULT_DENIED);
        }
        let terminate = p1 > 0.5;
        if terminate {
            self.terminate();
        }
        match self.persist.storage.clone() {
            Storage::Volatile => {
                if !terminate {
                    self.clear_termination();
                }
                Some(MavResult::MAV_RESULT_ACCEPTED)
            }
            Storage::ReadOnly(why) => {
                self.termination_not_saved(terminate, &format!("storage read-only: {why}"));
                Some(MavResult::MAV_RESULT_FAILED)
            }
            Storage::Durable => {
                self.termination_save_requested(terminate, ack_to);
                None
            }
        }
    }

    /// The save of a termination (or of its clear) is done: the clear is
    /// put in force, and the command acknowledged.
    pub(super) fn termination_saved(&mut self, terminate: bool, ack_to: AckTo, result: &Result<(), String>) {
        let result = match result {
            Ok(()) => {
                // A termination asked for since stays.
                if !terminate && !self.termination_save_pending(true) {
                    self.clear_termination();
                }
                MavResult::MAV_RESULT_ACCEPTED
            }
            Err(why) => {
                self.termination_not_saved(terminate, why);
                MavResult::MAV_RESULT_FAILED
            }
        };
        self.send_ack(ack_to, result);
    }

    fn termination_not_saved(&mut self, terminate: bool, why: &str) {
        let text = if terminate {
            format!("Terminated, not saved ({why}): a restart would clear it")
        } else {
            format!("Termination not cleared: not saved ({why})")
        };
        self.send_text(MavSeverity::MAV_SEVERITY_CRITICAL, &text);
    }

    /// The data directory said the vehicle was terminated when it stopped
    /// (or could not say): it starts terminated.
    pub fn restore_termination(&mut self, damaged: Option<String>) {
        self.terminated = true;
        let text = match damaged {
            None => "Flight terminated before the restart: DO_FLIGHTTERMINATION 0 clears it".to_owned(),
            Some(why) => format!("Termination state unreadable ({why}): terminated until DO_FLIGHTTERMINATION 0"),
        };
        self.add_startup_notice(MavSeverity::MAV_SEVERITY_CRITICAL, text);
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

    fn clear_termination(&mut self) {
        if self.terminated {
            self.terminated = false;
            self.send_text(
                MavSeverity::MAV_SEVERITY_INFO,
                "Aborting termination due to GCS request",
            );
        }
    }

    /// Terminated by a ground station and not cleared yet.
    pub fn is_terminated(&self) -> bool {
        self.terminated
    }
}
