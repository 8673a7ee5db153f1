//! Failsafes: a cause watched every tick, an action when it starts
//! (`FS_*`, `BATT_FS_*`; ArduPilot Rover's names and values where it has
//! them) and a STATUSTEXT when it starts and when it clears.
//!
//! A failsafe's state is its cause's, not the mode's: the cause (a silent
//! sensor, a stale fix, a low battery…) is judged the same in every mode and
//! armed or not, so the HOLD a failsafe chooses, or any mode the operator
//! picks, or a disarm, cannot end it. Where it *starts* does depend on the
//! vehicle: armed and in a mode the failsafe acts in. While on, it refuses
//! arming and the self-driving modes it would act in, with its name.
//! Latching failsafes stay on while armed even once their cause is gone,
//! then clear at the first moment disarmed without it.
//!
//! Recovery: a failsafe never drives the vehicle again by itself unless
//! `FS_RESUME` is 1, and then only after a sensor failsafe (GNSS, heading,
//! EKF, scanner) that stopped AUTO or RTL, once every failsafe has cleared
//! and nobody changed the mode or disarmed meanwhile. The GCS, battery and core
//! failsafes leave the vehicle stopped until the operator acts (as
//! ArduPilot does).

use std::time::Duration;

use mavlink::dialects::ardupilotmega::{EkfStatusFlags, MavSeverity, MavSysStatusSensor};

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
    /// The inertial unit went silent: reported only, as the estimator
    /// goes on without its yaw rate.
    ImuLost,
}

impl Failsafe {
    pub const ALL: [Failsafe; 11] = [
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
        Failsafe::ImuLost,
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
            Failsafe::ImuLost => "IMU lost",
        }
    }

    /// A sensor failsafe whose stop `FS_RESUME` may undo.
    fn resumable(self) -> bool {
        matches!(
            self,
            Failsafe::GnssLost | Failsafe::HeadingLost | Failsafe::Ekf | Failsafe::Scanner
        )
    }

    /// Stays on while armed once it started, whatever the cause does
    /// meanwhile: a battery recovers when unloaded, a missed deadline is an
    /// event, a path error or a runaway cannot be seen once stopped.
    fn latches(self) -> bool {
        matches!(
            self,
            Failsafe::BatteryLow
                | Failsafe::BatteryCritical
                | Failsafe::CoreStall
                | Failsafe::Control
                | Failsafe::Runaway
        )
    }

    /// The modes in which the cause starts the failsafe (and which it
    /// refuses while on): a position failsafe matters only to a mode that
    /// steers by the position, a scanner only to one that drives itself.
    pub fn acts_in(self, mode: Mode) -> bool {
        match self {
            Failsafe::GnssLost | Failsafe::HeadingLost | Failsafe::Ekf => mode.requires_position(),
            Failsafe::Scanner => mode.self_driving(),
            Failsafe::Runaway => mode == Mode::Hold,
            Failsafe::Gcs
            | Failsafe::BatteryLow
            | Failsafe::BatteryCritical
            | Failsafe::CoreStall
            | Failsafe::Control
            | Failsafe::ImuLost => true,
        }
    }

    /// The SYS_STATUS health bit cleared while this failsafe is on.
    pub fn health_sensor(self) -> Option<MavSysStatusSensor> {
        match self {
            Failsafe::GnssLost => Some(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS),
            Failsafe::HeadingLost | Failsafe::Ekf => Some(MavSysStatusSensor::MAV_SYS_STATUS_AHRS),
            Failsafe::Scanner => Some(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_PROXIMITY),
            Failsafe::BatteryLow | Failsafe::BatteryCritical => Some(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_BATTERY),
            Failsafe::Control => Some(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL),
            Failsafe::Runaway => Some(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS),
            // The accelerometer's bit too (see `sensors_health`).
            Failsafe::ImuLost => Some(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO),
            // No SYS_STATUS sensor for a link or the scheduler: HEARTBEAT
            // CRITICAL is what says it.
            Failsafe::Gcs | Failsafe::CoreStall => None,
        }
    }

    /// The EKF_STATUS_REPORT flags withheld while this failsafe is on.
    pub fn ekf_flags_withheld(self) -> EkfStatusFlags {
        match self {
            Failsafe::GnssLost | Failsafe::Ekf => {
                EkfStatusFlags::EKF_VELOCITY_HORIZ
                    | EkfStatusFlags::EKF_POS_HORIZ_REL
                    | EkfStatusFlags::EKF_POS_HORIZ_ABS
                    | EkfStatusFlags::EKF_PRED_POS_HORIZ_REL
                    | EkfStatusFlags::EKF_PRED_POS_HORIZ_ABS
            }
            Failsafe::HeadingLost => EkfStatusFlags::EKF_ATTITUDE,
            _ => EkfStatusFlags::empty(),
        }
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

    pub(super) fn name(self) -> &'static str {
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
    /// `FS_XTRACK_M`, and since when it has been told to stop (HOLD or
    /// disarmed).
    off_path_since: Option<Duration>,
    stop_since: Option<Duration>,
    /// Whether the vehicle has been within `FS_XTRACK_M` of the path since
    /// it started driving this leg.
    was_on_path: bool,
    /// Since when the battery has read below each threshold.
    battery_low_since: Option<Duration>,
    battery_critical_since: Option<Duration>,
    /// A tick gap longer than `FS_LOOP_MS`, seen by `step`.
    pub(super) stall: Option<Duration>,
    /// The heading reading that froze (its `heading_unchanged_since`).
    heading_frozen_since: Option<Duration>,
    /// The mode a resumable failsafe stopped (for `FS_RESUME`).
    interrupted: Option<Mode>,
    /// The mode a failsafe took the vehicle out of, while it stays in the
    /// one the failsafe chose: a further cause is judged for that mode (a
    /// GNSS lost after the EKF's HOLD stopped GUIDED is still said).
    stopped: Option<Stopped>,
}

#[derive(Clone, Copy, Debug)]
struct Stopped {
    from: Mode,
    into: Mode,
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
            // A disarm is the operator taking over: nothing resumes by itself.
            self.failsafes.interrupted = None;
        }
        let mode = self.mode;
        if !(self.armed && self.failsafes.any()) || self.failsafes.stopped.is_some_and(|s| s.into != mode) {
            self.failsafes.stopped = None;
        }
        for failsafe in Failsafe::ALL {
            // Judged every tick, on or not, so its timers run in every mode.
            let cause = self.failsafe_cause(failsafe);
            // A latching failsafe outlasts its cause while armed.
            let lasts = cause || (failsafe.latches() && self.armed);
            if !self.failsafes.is_active(failsafe) {
                let acts =
                    failsafe.acts_in(self.mode) || self.failsafes.stopped.is_some_and(|s| failsafe.acts_in(s.from));
                if cause && self.armed && acts {
                    self.failsafes.active |= failsafe.bit();
                    self.start_failsafe(failsafe);
                }
            } else if !lasts {
                self.failsafes.active &= !failsafe.bit();
                self.send_text(
                    MavSeverity::MAV_SEVERITY_INFO,
                    &format!("Failsafe cleared: {}", failsafe.name()),
                );
            } else if self.armed && self.mode.self_driving() && self.failsafe_blocks(failsafe, self.mode) {
                // Driving by itself where the failsafe, on, refuses it (its
                // action was report only until a parameter changed, or the
                // fence chose the mode): it acts again.
                self.start_failsafe(failsafe);
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

    /// Whether the failsafe's cause is present now, whatever the mode and
    /// whether armed (a HOLD needs no position, but the GNSS is still lost).
    fn failsafe_cause(&mut self, failsafe: Failsafe) -> bool {
        let fs = self.p.failsafe;
        let t = &self.params;
        let now = self.now.boot;
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
                !self.estimator.gnss().has_fix(now, timeout)
            }
            Failsafe::HeadingLost => self.heading_lost_cause(),
            Failsafe::Ekf => fs.ekf_action.get(t) != 0 && !self.estimator.healthy(),
            Failsafe::Scanner => self.stale_scanners().next().is_some(),
            Failsafe::BatteryLow => self.battery_below_for(self.failsafes.battery_low_since),
            Failsafe::BatteryCritical => self.battery_below_for(self.failsafes.battery_critical_since),
            Failsafe::CoreStall => self.failsafes.stall.is_some(),
            Failsafe::Control => self.off_path_cause(),
            Failsafe::Runaway => self.runaway_cause(),
            // A unit that reported once and fell silent (none fitted: none
            // to lose).
            Failsafe::ImuLost => {
                let imu = self.estimator.imu();
                imu.last().is_some() && !imu.fresh(now)
            }
        }
    }

    /// The heading sensor silent, or reading exactly the same since it was
    /// seen to while driving (a sensor at rest may repeat its value, so a
    /// freeze is only caught under way, and lasts until the value moves).
    fn heading_lost_cause(&mut self) -> bool {
        let now = self.now.boot;
        let timeout = crate::time::duration_from_secs(f64::from(self.p.failsafe.heading_lost_s.get(&self.params)));
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
        let frozen =
            self.failsafes.heading_frozen_since.is_some() && self.failsafes.heading_frozen_since == unchanged_since;
        silent || frozen
    }

    /// Off the path by more than `FS_XTRACK_M` for `OFF_PATH_FOR`, while
    /// driving a leg by itself (a detour leaves the leg on purpose), having
    /// been on it: a vehicle resumed where this failsafe stopped it starts
    /// off the path and is rejoining it, not leaving it.
    fn off_path_cause(&mut self) -> bool {
        let now = self.now.boot;
        let limit_m = f64::from(self.p.failsafe.xtrack_max_m.get(&self.params));
        let status = self.navigator.status();
        let on_a_leg = self.armed && self.mode.self_driving() && status.active && !self.obstacles.detouring();
        let beyond = limit_m > 0.0 && status.crosstrack_m.abs() > limit_m;
        self.failsafes.was_on_path = on_a_leg && (self.failsafes.was_on_path || !beyond);
        let off = on_a_leg && beyond && self.failsafes.was_on_path;
        self.failsafes.off_path_since = if off {
            self.failsafes.off_path_since.or(Some(now))
        } else {
            None
        };
        self.failsafes
            .off_path_since
            .is_some_and(|s| now.saturating_sub(s) >= OFF_PATH_FOR)
    }

    /// Still moving `RUNAWAY_AFTER` after being told to stop (HOLD, or
    /// disarmed: a runaway's own disarm does not end it while it coasts).
    fn runaway_cause(&mut self) -> bool {
        let now = self.now.boot;
        let told_to_stop = self.mode == Mode::Hold || !self.armed;
        self.failsafes.stop_since = if told_to_stop {
            self.failsafes.stop_since.or(Some(now))
        } else {
            None
        };
        // Only a speed the vehicle can trust: dead reckoning without GNSS
        // keeps its last speed.
        let measured = self.estimator.healthy() && self.estimator.gnss().has_fix(now, Duration::from_secs(1));
        self.failsafes
            .stop_since
            .is_some_and(|s| now.saturating_sub(s) >= RUNAWAY_AFTER)
            && measured
            && self.estimator.estimate().speed_mps.abs() > RUNAWAY_SPEED_MPS
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

    /// What the failsafe does when it starts in `mode`.
    fn configured_action(&self, failsafe: Failsafe, mode: Mode) -> FailsafeAction {
        let fs = self.p.failsafe;
        let t = &self.params;
        match failsafe {
            Failsafe::Gcs if fs.gcs_enable.get(t) == 2 && mode == Mode::Auto => FailsafeAction::Report,
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
            Failsafe::ImuLost => FailsafeAction::Report,
        }
    }

    /// The action as it can be carried out: RTL needs a position and home;
    /// without them the nearest safe thing is to stop where it is.
    pub(super) fn effective_action(&self, failsafe: Failsafe, mode: Mode) -> FailsafeAction {
        let action = self.configured_action(failsafe, mode);
        let can_rtl = self.home.is_some()
            && self.estimator.estimate().position_valid
            && !matches!(failsafe, Failsafe::GnssLost | Failsafe::Ekf | Failsafe::HeadingLost);
        if action == FailsafeAction::Rtl && !can_rtl {
            FailsafeAction::Hold
        } else {
            action
        }
    }

    /// Whether being in `mode` is what the failsafe, on, would stop: it
    /// acts there, by more than a report, and not by choosing `mode` itself.
    fn failsafe_blocks(&self, failsafe: Failsafe, mode: Mode) -> bool {
        if !failsafe.acts_in(mode) {
            return false;
        }
        match self.effective_action(failsafe, mode) {
            FailsafeAction::Report => false,
            FailsafeAction::Rtl => mode != Mode::Rtl,
            FailsafeAction::Hold => mode != Mode::Hold,
            FailsafeAction::Disarm => true,
        }
    }

    /// The failsafe that is on and refuses entering `mode`, if any (only
    /// the modes that drive by themselves are refused: HOLD and MANUAL are
    /// how the operator takes over).
    pub(super) fn failsafe_refusing_mode(&self, mode: Mode) -> Option<Failsafe> {
        if !mode.self_driving() {
            return None;
        }
        self.active_failsafes().find(|&f| self.failsafe_blocks(f, mode))
    }

    /// The failsafes that are on and refuse arming in `mode`: where they
    /// act, anywhere once they cut the power, and in HOLD (where the
    /// vehicle waits to drive itself) when they refuse driving.
    pub(super) fn failsafes_refusing_arming(&self, mode: Mode) -> impl Iterator<Item = Failsafe> + '_ {
        self.active_failsafes().filter(move |&f| {
            self.failsafe_blocks(f, mode)
                || self.effective_action(f, mode) == FailsafeAction::Disarm
                || (mode == Mode::Hold
                    && [Mode::Auto, Mode::Guided, Mode::Rtl]
                        .into_iter()
                        .any(|m| self.failsafe_blocks(f, m)))
        })
    }

    pub(super) fn active_failsafes(&self) -> impl Iterator<Item = Failsafe> + '_ {
        Failsafe::ALL.into_iter().filter(|&f| self.failsafes.is_active(f))
    }

    fn start_failsafe(&mut self, failsafe: Failsafe) {
        let action = self.effective_action(failsafe, self.mode);
        let what = match (failsafe, self.failsafes.stall) {
            (Failsafe::CoreStall, Some(gap)) => format!("core stalled {} ms", gap.as_millis()),
            _ => failsafe.name().to_string(),
        };
        self.send_text(
            MavSeverity::MAV_SEVERITY_CRITICAL,
            &format!("Failsafe: {what}: {}", action.name()),
        );
        let from = self.mode;
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
        if self.armed && self.mode != from && self.failsafes.stopped.is_none() {
            self.failsafes.stopped = Some(Stopped { from, into: self.mode });
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
