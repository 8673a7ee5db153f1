//! What each mode does, one file per mode as ArduPilot's `mode_*.cpp`
//! (the mode numbers and names are in `crate::modes`):
//!
//! - entering a mode (the checks, the refusal a ground station is told, what
//!   entering sets up) in [`change`];
//! - MANUAL in [`manual`];
//! - GUIDED, RTL and AUTO, which all drive to the navigator's target, in [`navigate`];
//! - AUTO's mission (the executor's actions, mission telemetry) in [`auto`];
//! - MAGNETIC, the magnetic-tape guide, in [`magnetic`];
//! - HOLD (and every mode Furrow refuses) stands still: no file of its own.
//!
//! `Core::update_mode` below is the per-tick dispatch.

mod auto;
mod change;
pub(super) mod magnetic;
mod manual;
mod navigate;

use mavlink::dialects::ardupilotmega::MavSeverity;

use super::Core;
use super::drive::Demand;
use crate::modes::Mode;

pub(super) use change::ModeRefusal;

impl Core {
    /// The mode's work for this tick.
    pub(super) fn update_mode(&mut self, dt_s: f64) {
        self.update_failsafes();
        if self.mode.requires_position() && !self.estimator.estimate().position_valid {
            // ArduPilot Rover's EKF failsafe: a mode that needs a position
            // cannot drive without one.
            self.send_text(MavSeverity::MAV_SEVERITY_CRITICAL, "Position lost: switching to HOLD");
            self.enter_mode(Mode::Hold);
        }

        self.check_fence();
        if self.mode == Mode::Auto && self.fleet_drives() {
            self.run_order();
        } else if self.mode == Mode::Auto {
            self.run_mission();
        }
        let obstacle_stop = self.obstacle_tick();
        let demand = match self.mode {
            Mode::Manual => self.manual_demand(),
            Mode::Guided | Mode::Rtl | Mode::Auto if obstacle_stop => {
                self.maybe_plan_detour(true);
                Demand::Brake
            }
            Mode::Magnetic if obstacle_stop => Demand::Brake,
            Mode::Guided | Mode::Rtl | Mode::Auto => self.navigate_demand(dt_s),
            Mode::Magnetic => self.magnetic_demand(dt_s).map_or(Demand::Stop, Demand::Navigate),
            // HOLD, and the modes Furrow refuses: stand still.
            _ => Demand::Stop,
        };
        self.apply_demand(demand, dt_s);
    }
}
