//! Mode changes.

use mavlink::dialects::ardupilotmega::MavSeverity;

use super::Core;
use crate::geo::GeoPoint;
use crate::guidance::navigator::NavTarget;
use crate::modes::Mode;

/// Why a mode change was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum ModeRefusal {
    NotAvailable,
    NeedsPosition,
    NoHome,
    NoMission,
}

impl Core {
    /// Requested by a ground station: refusals are reported in a STATUSTEXT.
    pub(super) fn request_mode(&mut self, mode: Mode) -> Result<(), ModeRefusal> {
        let result = self.check_mode(mode);
        if let Err(why) = result {
            let reason = match why {
                ModeRefusal::NotAvailable => "not available",
                ModeRefusal::NeedsPosition => "requires position",
                ModeRefusal::NoHome => "home not set",
                ModeRefusal::NoMission => "no mission",
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
        let estimate = self.estimator.estimate();
        if mode.requires_position() && !(estimate.position_valid && estimate.heading_valid) {
            return Err(ModeRefusal::NeedsPosition);
        }
        if mode == Mode::Rtl && self.home.is_none() {
            return Err(ModeRefusal::NoHome);
        }
        if mode == Mode::Auto && !self.missions.executor.has_nav_items() {
            return Err(ModeRefusal::NoMission);
        }
        Ok(())
    }

    /// Switches mode unconditionally (failsafes use it directly).
    pub(super) fn enter_mode(&mut self, mode: Mode) {
        self.mode = mode;
        self.speed_override_mps = None;
        self.navigator.clear();
        match mode {
            Mode::Rtl => {
                if let Some(target) = self.rtl_target() {
                    self.navigate_to(target, None);
                }
            }
            Mode::Auto => self.start_mission(),
            _ => {}
        }
    }

    /// Drives in a straight leg from where the vehicle is to `target`, and
    /// stops there.
    pub(super) fn navigate_to(&mut self, target: GeoPoint, speed_mps: Option<f64>) -> bool {
        let Some(frame) = self.frame() else {
            return false;
        };
        let from = self.estimator.estimate().position;
        self.navigator.set_target(
            from,
            NavTarget {
                speed_mps,
                ..NavTarget::stop_at(frame.to_local(&target))
            },
        );
        true
    }
}
