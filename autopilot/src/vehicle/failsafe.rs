//! Failsafes: a condition watched every tick, an action when it starts
//! (`FS_*`, `BATT_FS_*`; ArduPilot Rover's names and values where it has
//! them) and a STATUSTEXT when it starts and when it clears.
//!
//! Recovery: a failsafe never drives the vehicle again by itself unless
//! `FS_RESUME` is 1, and then only after a sensor failsafe (GNSS, heading,
//! EKF, scanner) that stopped a self-driving mode, once every condition has
//! cleared and nobody changed the mode meanwhile. The GCS, battery and core
//! failsafes leave the vehicle stopped until the operator acts (as
//! ArduPilot does).

use std::time::Duration;

use mavlink::dialects::ardupilotmega::MavSeverity;

use super::Core;
use crate::modes::Mode;

/// A vehicle under way this slow, or slower, is not "driving" for the
/// frozen-heading test (a sensor at rest may repeat its value).
const DRIVING_MIN_SPEED_MPS: f64 = 0.3;

/// Off the path for this long before the control failsafe.
const OFF_PATH_FOR: Duration = Duration::from_secs(1);

/// A vehicle in HOLD this long that still moves is not obeying: its power
/// is cut (disarm).
const RUNAWAY_AFTER: Duration = Duration::from_secs(3);
const RUNAWAY_SPEED_MPS: f64 = 0.3;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Failsafe {
    Gcs,
    GnssLost,
    HeadingLost,
    Ekf,
    Scanner,
    BatteryLow,
    BatteryCritical,
    CoreStall,
    /// The vehicle leaves its path (steering not obeying).
    Control,
    /// The vehicle does not stop when told to (drive not obeying).
    Runaway,
}

impl Failsafe {
    pub const ALL: [Failsafe; 10] = [
        Failsafe::Gcs,
        Failsafe::GnssLost,
        Failsafe::HeadingLost,
        Failsafe::Ekf,
        Failsafe::Scanner,
        Failsafe::BatteryLow,
        Failsafe::BatteryCritical,
        Failsafe::CoreStall,
        Failsafe::Control,
        Failsafe::Runaway,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Failsafe::Gcs => "GCS heartbeat lost",
            Failsafe::GnssLost => "GNSS lost",
            Failsafe::HeadingLost => "heading lost",
            Failsafe::Ekf => "EKF unhealthy",
            Failsafe::Scanner => "scanner stale",
            Failsafe::BatteryLow => "battery low",
            Failsafe::BatteryCritical => "battery critical",
            Failsafe::CoreStall => "core deadline missed",
            Failsafe::Control => "off the path",
            Failsafe::Runaway => "vehicle does not stop",
        }
    }

    /// A sensor failsafe whose stop `FS_RESUME` may undo.
    fn resumable(self) -> bool {
        matches!(
            self,
            Failsafe::GnssLost | Failsafe::HeadingLost | Failsafe::Ekf | Failsafe::Scanner
        )
    }

    /// Stays on until disarmed once it started (a battery does not recover
    /// under load; a missed deadline is an event, not a state).
    fn latches(self) -> bool {
        matches!(
            self,
            Failsafe::BatteryLow | Failsafe::BatteryCritical | Failsafe::CoreStall | Failsafe::Control
        )
    }

    fn bit(self) -> u16 {
        1 << (self as u16)
    }
}

/// What a failsafe does (ArduPilot's `FS_ACTION` values; Furrow has no
/// SmartRTL, so 3 is RTL and 4 HOLD).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FailsafeAction {
    Report,
    Rtl,
    Hold,
    Disarm,
}

impl FailsafeAction {
    pub fn from_param(value: i8) -> FailsafeAction {
        match value {
            0 => FailsafeAction::Report,
            1 | 3 => FailsafeAction::Rtl,
            5 => FailsafeAction::Disarm,
            _ => FailsafeAction::Hold,
        }
    }

    fn name(self) -> &'static str {
        match self {
            FailsafeAction::Report => "report only",
            FailsafeAction::Rtl => "RTL",
            FailsafeAction::Hold => "HOLD",
            FailsafeAction::Disarm => "disarm",
        }
    }
}

#[derive(Clone, Debug, Default)]
pub(super) struct FailsafeState {
    /// Bit per [`Failsafe`] that is on.
    active: u16,
    /// Since when the vehicle has been off its path by more than
    /// `FS_XTRACK_M`, and since when it has been in HOLD.
    off_path_since: Option<Duration>,
    hold_since: Option<Duration>,
    /// Since when the battery has read below each threshold.
    battery_low_since: Option<Duration>,
    battery_critical_since: Option<Duration>,
    /// A tick gap longer than `FS_LOOP_MS`, seen by `step`.
    pub(super) stall: Option<Duration>,
    /// The heading reading that froze (its `heading_unchanged_since`).
    heading_frozen_since: Option<Duration>,
    /// The mode a resumable failsafe stopped (for `FS_RESUME`).
    interrupted: Option<Mode>,
}

impl FailsafeState {
    pub fn is_active(&self, failsafe: Failsafe) -> bool {
        self.active & failsafe.bit() != 0
    }

    pub fn any(&self) -> bool {
        self.active != 0
    }
}

impl Core {
    /// Once per tick, before the mode runs.
    pub(super) fn update_failsafes(&mut self) {
        self.track_battery();
        if !self.armed {
            // Disarmed, nothing is acted on: what would stop the vehicle is
            // for the arming checks to refuse.
            self.failsafes.active = 0;
            self.failsafes.stall = None;
            self.failsafes.interrupted = None;
            self.failsafes.hold_since = None;
            self.failsafes.off_path_since = None;
            return;
        }
        for failsafe in Failsafe::ALL {
            let condition = self.failsafe_condition(failsafe);
            let active = self.failsafes.is_active(failsafe);
            if condition && !active {
                self.failsafes.active |= failsafe.bit();
                self.start_failsafe(failsafe);
            } else if !condition && active && !failsafe.latches() {
                self.failsafes.active &= !failsafe.bit();
                self.send_text(
                    MavSeverity::MAV_SEVERITY_INFO,
                    &format!("Failsafe cleared: {}", failsafe.name()),
                );
            }
        }
        self.failsafes.stall = None;
        self.maybe_resume();
    }

    /// Whether the failsafes are on (HEARTBEAT: CRITICAL).
    pub(super) fn failsafe_active(&self) -> bool {
        self.failsafes.any()
    }

    pub fn failsafe_is_active(&self, failsafe: Failsafe) -> bool {
        self.failsafes.is_active(failsafe)
    }

    fn failsafe_condition(&mut self, failsafe: Failsafe) -> bool {
        let fs = self.p.failsafe;
        let t = &self.params;
        let now = self.now.boot;
        // Judged for the mode the vehicle was in when a failsafe stopped it,
        // so a condition does not clear just because HOLD needs no position.
        let interrupted = self.failsafes.interrupted;
        let uses_position = self.mode.requires_position() || interrupted.is_some_and(Mode::requires_position);
        let self_driving = self.mode.self_driving() || interrupted.is_some_and(Mode::self_driving);
        match failsafe {
            Failsafe::Gcs => {
                let timeout = crate::time::duration_from_secs(f64::from(fs.gcs_timeout_s.get(t)));
                fs.gcs_enable.get(t) > 0
                    && self
                        .last_gcs_heartbeat_wall
                        .is_some_and(|last| self.now.wall.saturating_sub(last) > timeout)
            }
            Failsafe::GnssLost => {
                let timeout = crate::time::duration_from_secs(f64::from(fs.gnss_lost_s.get(t)));
                uses_position && !self.estimator.gnss().has_fix(now, timeout)
            }
            Failsafe::HeadingLost => {
                let timeout = crate::time::duration_from_secs(f64::from(fs.heading_lost_s.get(t)));
                let Some(last) = self.estimator.heading_sensor_last() else {
                    // Driving on the GNSS course: no sensor to lose.
                    return false;
                };
                let silent = now.saturating_sub(last) > timeout;
                let unchanged_since = self.estimator.heading_unchanged_since();
                let driving = self.estimator.gnss().speed_mps >= DRIVING_MIN_SPEED_MPS;
                if driving && unchanged_since.is_some_and(|since| now.saturating_sub(since) > timeout) {
                    self.failsafes.heading_frozen_since = unchanged_since;
                }
                let frozen = self.failsafes.heading_frozen_since.is_some()
                    && self.failsafes.heading_frozen_since == unchanged_since;
                uses_position && (silent || frozen)
            }
            Failsafe::Ekf => fs.ekf_action.get(t) != 0 && uses_position && !self.estimator.healthy(),
            Failsafe::Scanner => self_driving && self.stale_scanners().next().is_some(),
            Failsafe::BatteryLow => self.battery_below_for(self.failsafes.battery_low_since),
            Failsafe::BatteryCritical => self.battery_below_for(self.failsafes.battery_critical_since),
            Failsafe::CoreStall => self.failsafes.stall.is_some(),
            Failsafe::Control => {
                let limit_m = f64::from(fs.xtrack_max_m.get(t));
                let status = self.navigator.status();
                let off = limit_m > 0.0
                    && self.mode.self_driving()
                    && status.active
                    && !self.obstacles.detouring()
                    && status.crosstrack_m.abs() > limit_m;
                self.failsafes.off_path_since = if off {
                    self.failsafes.off_path_since.or(Some(now))
                } else {
                    None
                };
                self.failsafes
                    .off_path_since
                    .is_some_and(|s| now.saturating_sub(s) >= OFF_PATH_FOR)
            }
            Failsafe::Runaway => {
                self.failsafes.hold_since = if self.mode == Mode::Hold {
                    self.failsafes.hold_since.or(Some(now))
                } else {
                    None
                };
                // Only a speed the vehicle can trust: dead reckoning without
                // GNSS keeps its last speed.
                let measured = self.estimator.healthy() && self.estimator.gnss().has_fix(now, Duration::from_secs(1));
                self.failsafes
                    .hold_since
                    .is_some_and(|s| now.saturating_sub(s) >= RUNAWAY_AFTER)
                    && measured
                    && self.estimator.estimate().speed_mps.abs() > RUNAWAY_SPEED_MPS
            }
        }
    }

    fn battery_below_for(&self, since: Option<Duration>) -> bool {
        let timer = crate::time::duration_from_secs(f64::from(self.p.failsafe.batt_low_timer_s.get(&self.params)));
        since.is_some_and(|s| self.now.boot.saturating_sub(s) >= timer)
    }

    fn track_battery(&mut self) {
        let fs = self.p.failsafe;
        let voltage = self.battery.map(|b| b.voltage_v);
        let below = |threshold: f32| {
            let threshold = f64::from(threshold);
            threshold > 0.0 && voltage.is_some_and(|v| v < threshold)
        };
        let now = self.now.boot;
        let low = below(fs.batt_low_volt.get(&self.params));
        let critical = below(fs.batt_crit_volt.get(&self.params));
        self.failsafes.battery_low_since = if low {
            self.failsafes.battery_low_since.or(Some(now))
        } else {
            None
        };
        self.failsafes.battery_critical_since = if critical {
            self.failsafes.battery_critical_since.or(Some(now))
        } else {
            None
        };
    }

    fn configured_action(&self, failsafe: Failsafe) -> FailsafeAction {
        let fs = self.p.failsafe;
        let t = &self.params;
        match failsafe {
            Failsafe::Gcs if fs.gcs_enable.get(t) == 2 && self.mode == Mode::Auto => FailsafeAction::Report,
            Failsafe::Gcs => FailsafeAction::from_param(fs.action.get(t)),
            Failsafe::GnssLost => FailsafeAction::from_param(fs.gnss_action.get(t)),
            Failsafe::HeadingLost => FailsafeAction::from_param(fs.heading_action.get(t)),
            Failsafe::Ekf if fs.ekf_action.get(t) == 2 => FailsafeAction::Report,
            Failsafe::Ekf => FailsafeAction::Hold,
            Failsafe::Scanner => FailsafeAction::from_param(fs.scanner_action.get(t)),
            Failsafe::BatteryLow => FailsafeAction::from_param(fs.batt_low_action.get(t)),
            Failsafe::BatteryCritical => FailsafeAction::from_param(fs.batt_crit_action.get(t)),
            Failsafe::CoreStall => FailsafeAction::from_param(fs.loop_action.get(t)),
            Failsafe::Control => FailsafeAction::from_param(fs.control_action.get(t)),
            Failsafe::Runaway => FailsafeAction::Disarm,
        }
    }

    fn start_failsafe(&mut self, failsafe: Failsafe) {
        let mut action = self.configured_action(failsafe);
        // RTL needs a position and home; without them the nearest safe thing
        // is to stop where it is.
        let can_rtl = self.home.is_some()
            && self.estimator.estimate().position_valid
            && !matches!(failsafe, Failsafe::GnssLost | Failsafe::Ekf | Failsafe::HeadingLost);
        if action == FailsafeAction::Rtl && !can_rtl {
            action = FailsafeAction::Hold;
        }
        let what = match (failsafe, self.failsafes.stall) {
            (Failsafe::CoreStall, Some(gap)) => format!("core stalled {} ms", gap.as_millis()),
            _ => failsafe.name().to_string(),
        };
        self.send_text(
            MavSeverity::MAV_SEVERITY_CRITICAL,
            &format!("Failsafe: {what}: {}", action.name()),
        );
        match action {
            FailsafeAction::Report => {}
            FailsafeAction::Disarm => {
                self.disarm();
            }
            FailsafeAction::Rtl => {
                if self.mode != Mode::Rtl {
                    self.enter_mode(Mode::Rtl);
                }
            }
            FailsafeAction::Hold => {
                if self.mode != Mode::Hold {
                    // GUIDED's target is the ground station's, perhaps stale
                    // by now: only a mission or a return goes on by itself.
                    if failsafe.resumable() && matches!(self.mode, Mode::Auto | Mode::Rtl) {
                        self.failsafes.interrupted = self.failsafes.interrupted.or(Some(self.mode));
                    }
                    self.enter_mode(Mode::Hold);
                }
            }
        }
        if !failsafe.resumable() {
            // A stop nobody may undo automatically.
            self.failsafes.interrupted = None;
        }
    }

    /// `FS_RESUME`: back to the interrupted mode once all is clear.
    fn maybe_resume(&mut self) {
        let Some(mode) = self.failsafes.interrupted else {
            return;
        };
        if self.mode != Mode::Hold {
            // The operator chose another mode: theirs stands.
            self.failsafes.interrupted = None;
            return;
        }
        if self.failsafes.any() || !self.p.failsafe.resume.get(&self.params) {
            return;
        }
        self.failsafes.interrupted = None;
        if self.request_mode(mode).is_ok() {
            self.send_text(
                MavSeverity::MAV_SEVERITY_WARNING,
                &format!("Failsafe over: resuming {mode} (FS_RESUME)"),
            );
        }
    }
}
