//! Mode changes.

use mavlink::dialects::ardupilotmega::MavSeverity;

use crate::modes::Mode;
use crate::vehicle::Core;
use crate::vehicle::failsafe::Failsafe;

/// Why a mode change was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(in crate::vehicle) enum ModeRefusal {
    NotAvailable,
    NeedsPosition,
    NoHome,
    NoMission,
    NoMagneticSensors,
    /// A failsafe that is on would stop the mode (it says which).
    Failsafe(Failsafe),
}

impl Core {
    /// Requested by a ground station: refusals are reported in a STATUSTEXT.
    pub(in crate::vehicle) fn request_mode(&mut self, mode: Mode) -> Result<(), ModeRefusal> {
        let result = self.check_mode(mode);
        if let Err(why) = result {
            let reason = match why {
                ModeRefusal::NotAvailable => "not available".to_string(),
                ModeRefusal::NeedsPosition => "requires position".to_string(),
                ModeRefusal::NoHome => "home not set".to_string(),
                ModeRefusal::NoMission => "no mission".to_string(),
                ModeRefusal::NoMagneticSensors => "no tape sensors".to_string(),
                // "Mode change to GUIDED failed: GNSS lost" fits one STATUSTEXT.
                ModeRefusal::Failsafe(failsafe) => failsafe.name().to_string(),
            };
            self.send_text(
                MavSeverity::MAV_SEVERITY_WARNING,
                &format!("Mode change to {mode} failed: {reason}"),
            );
        } else if mode != self.mode {
            self.enter_mode(mode);
        }
        result
    }

    fn check_mode(&self, mode: Mode) -> Result<(), ModeRefusal> {
        if !mode.is_available() {
            return Err(ModeRefusal::NotAvailable);
        }
        if let Some(failsafe) = self.failsafe_refusing_mode(mode) {
            return Err(ModeRefusal::Failsafe(failsafe));
        }
        let estimate = self.estimator.estimate();
        if mode.requires_position() && !(estimate.position_valid && estimate.heading_valid) {
            return Err(ModeRefusal::NeedsPosition);
        }
        if mode == Mode::Rtl && self.home.is_none() {
            return Err(ModeRefusal::NoHome);
        }
        if mode == Mode::Auto && !self.missions.executor.has_nav_items() && !self.fleet_drives() {
            return Err(ModeRefusal::NoMission);
        }
        if mode == Mode::Magnetic && !self.magnetic_sensors_fresh() {
            return Err(ModeRefusal::NoMagneticSensors);
        }
        Ok(())
    }

    /// Switches mode unconditionally (failsafes use it directly).
    pub(in crate::vehicle) fn enter_mode(&mut self, mode: Mode) {
        self.mode = mode;
        self.speed_override_mps = None;
        self.navigator.clear();
        self.goals.goal = None;
        self.obstacles_mode_changed();
        match mode {
            Mode::Rtl => {
                if let Some(target) = self.rtl_target() {
                    self.navigate_to(target, self.rtl_yaw(&target), None);
                }
            }
            Mode::Auto if self.fleet_drives() => self.start_order(),
            Mode::Auto => self.start_mission(),
            Mode::Magnetic => self.start_magnetic(),
            _ => {}
        }
    }
}
