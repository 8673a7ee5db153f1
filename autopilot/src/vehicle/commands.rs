//! The command protocol: COMMAND_LONG and COMMAND_INT share one handler and
//! every command gets exactly one COMMAND_ACK on the link it came from.
//!
//! Deprecated commands and frames (GET_HOME_POSITION, the `*_INT` frames…)
//! are still sent by ground stations in the field, so they are answered.
#![allow(deprecated)]

use std::time::Duration;

use mavlink::dialects::ardupilotmega::{
    COMMAND_ACK_DATA, COMMAND_INT_DATA, COMMAND_LONG_DATA, MESSAGE_INTERVAL_DATA, MavCmd, MavFrame, MavMessage,
    MavModeFlag, MavResult,
};

use super::modes::ModeRefusal;
use super::{Core, Destination, Inbound, LinkId};
use crate::geo::GeoPoint;
use crate::modes::Mode;
use crate::telemetry::streams::{MessageInterval, StreamMsg};

/// COMPONENT_ARM_DISARM param2 that skips the checks.
const FORCE_ARM_MAGIC: f32 = 21196.0;
/// MAV_DO_REPOSITION_FLAGS_CHANGE_MODE.
const REPOSITION_CHANGE_MODE: u32 = 1;
/// Highest and lowest home altitude a GCS may set (as `--home`).
const HOME_ALT_RANGE_M: std::ops::RangeInclusive<f64> = -1000.0..=10_000.0;

/// A param that must be a whole number in `0..=max` (an id, a mode, a
/// flag set): NaN, fractions and anything beyond are refused rather than
/// cast into something else.
fn whole(v: f32, max: u32) -> Option<u32> {
    (v.is_finite() && v.fract() == 0.0 && (0.0..=f64::from(max)).contains(&f64::from(v))).then_some(v as u32)
}

/// A speed a GCS may ask for: above 0 and no faster than a mission may.
fn speed_in_range(speed_mps: f32) -> bool {
    speed_mps > 0.0 && speed_mps <= mission::command::limits::MAX_SPEED_MPS
}

/// A position carried by a command, as it arrived.
#[derive(Clone, Copy, Debug)]
enum CommandPosition {
    /// COMMAND_INT: degrees × 1e7 and the frame they are in.
    Int { lat_e7: i32, lon_e7: i32, frame: MavFrame },
    /// COMMAND_LONG: params 5 and 6 in degrees.
    Float { lat_deg: f32, lon_deg: f32 },
}

/// Where a command's COMMAND_ACK goes (kept when it waits for a save).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct AckTo {
    link: LinkId,
    command: MavCmd,
    target_system: u8,
    target_component: u8,
}

/// COMMAND_LONG and COMMAND_INT in one shape.
#[derive(Clone, Copy, Debug)]
struct Command {
    command: MavCmd,
    params: [f32; 4],
    position: CommandPosition,
    z: f32,
}

impl Command {
    fn is_int(&self) -> bool {
        matches!(self.position, CommandPosition::Int { .. })
    }

    /// The command's location in a global frame, if it is one.
    fn location(&self, alt_m: f64) -> Result<Option<GeoPoint>, MavResult> {
        let point = match self.position {
            CommandPosition::Int { lat_e7, lon_e7, frame } => {
                let global = matches!(
                    frame,
                    MavFrame::MAV_FRAME_GLOBAL
                        | MavFrame::MAV_FRAME_GLOBAL_INT
                        | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
                        | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
                );
                if !global {
                    return Err(MavResult::MAV_RESULT_COMMAND_UNSUPPORTED_MAV_FRAME);
                }
                if lat_e7 == 0 && lon_e7 == 0 {
                    return Ok(None);
                }
                GeoPoint::from_e7(lat_e7, lon_e7, alt_m)
            }
            CommandPosition::Float { lat_deg, lon_deg } => {
                if lat_deg == 0.0 && lon_deg == 0.0 {
                    return Ok(None);
                }
                GeoPoint::new(f64::from(lat_deg), f64::from(lon_deg), alt_m)
            }
        };
        if point.is_valid() {
            Ok(Some(point))
        } else {
            Err(MavResult::MAV_RESULT_DENIED)
        }
    }
}

impl Core {
    pub(super) fn handle_command_long(&mut self, inbound: &Inbound, c: &COMMAND_LONG_DATA) {
        let command = Command {
            command: c.command,
            params: [c.param1, c.param2, c.param3, c.param4],
            position: CommandPosition::Float {
                lat_deg: c.param5,
                lon_deg: c.param6,
            },
            z: c.param7,
        };
        self.run_command(inbound, command);
    }

    pub(super) fn handle_command_int(&mut self, inbound: &Inbound, c: &COMMAND_INT_DATA) {
        let command = Command {
            command: c.command,
            params: [c.param1, c.param2, c.param3, c.param4],
            position: CommandPosition::Int {
                lat_e7: c.x,
                lon_e7: c.y,
                frame: c.frame,
            },
            z: c.z,
        };
        self.run_command(inbound, command);
    }

    fn run_command(&mut self, inbound: &Inbound, command: Command) {
        self.counters.commands += 1;
        let mut follow_up = Vec::new();
        let ack_to = AckTo {
            link: inbound.link,
            command: command.command,
            target_system: inbound.header.system_id as u8,
            target_component: inbound.header.component_id,
        };
        let result = match command.command {
            MavCmd::MAV_CMD_DO_FLIGHTTERMINATION => match self.flight_termination(command.params[0], ack_to) {
                Some(result) => result,
                // Acknowledged once saved.
                None => return,
            },
            _ => self.execute(inbound, &command, &mut follow_up),
        };
        self.send_ack(ack_to, result);
        for (dest, message) in follow_up {
            self.send(dest, message);
        }
    }

    /// The one COMMAND_ACK of a command.
    pub(super) fn send_ack(&mut self, to: AckTo, result: MavResult) {
        let ack = COMMAND_ACK_DATA {
            command: to.command,
            result,
            progress: 0,
            result_param2: 0,
            target_system: to.target_system,
            target_component: to.target_component,
        };
        self.send(Destination::Link(to.link), MavMessage::COMMAND_ACK(ack));
    }

    fn execute(&mut self, inbound: &Inbound, c: &Command, follow_up: &mut Vec<(Destination, MavMessage)>) -> MavResult {
        let [p1, p2, _p3, _p4] = c.params;
        match c.command {
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM => self.arm_disarm(p1, p2),
            MavCmd::MAV_CMD_DO_SET_MODE => self.do_set_mode(p1, p2),
            MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH => self.set_mode_result(Mode::Rtl.number()),
            MavCmd::MAV_CMD_MISSION_START => {
                // First/last item selection is not supported (as ArduPilot).
                if p1 != 0.0 || p2 != 0.0 {
                    return MavResult::MAV_RESULT_DENIED;
                }
                self.set_mode_result(Mode::Auto.number())
            }
            MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT => self.do_set_mission_current(p1, p2),
            MavCmd::MAV_CMD_DO_REPOSITION => self.do_reposition(c),
            MavCmd::MAV_CMD_DO_SET_HOME => self.do_set_home(c),
            MavCmd::MAV_CMD_DO_CHANGE_SPEED => self.do_change_speed(p1, p2),
            MavCmd::MAV_CMD_DO_SET_SERVO => self.do_set_servo(p1, p2),
            MavCmd::MAV_CMD_DO_SET_RELAY => self.do_set_relay(p1, p2),
            // Continue releases an obstacle stop held for the GCS
            // (OA_RESUME 0) once the way is clear; pausing is not supported.
            MavCmd::MAV_CMD_DO_PAUSE_CONTINUE if p1 == 1.0 => {
                if self.obstacle_continue() || !self.obstacle_status().stopped {
                    MavResult::MAV_RESULT_ACCEPTED
                } else {
                    MavResult::MAV_RESULT_TEMPORARILY_REJECTED
                }
            }
            MavCmd::MAV_CMD_REQUEST_MESSAGE => self.request_message(inbound, c, follow_up),
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL => self.set_message_interval(inbound, p1, p2),
            MavCmd::MAV_CMD_GET_MESSAGE_INTERVAL => self.get_message_interval(inbound, p1, follow_up),
            MavCmd::MAV_CMD_GET_HOME_POSITION => match self.build_home_position() {
                Some(home) => {
                    follow_up.push((Destination::Link(inbound.link), home));
                    MavResult::MAV_RESULT_ACCEPTED
                }
                None => MavResult::MAV_RESULT_FAILED,
            },
            MavCmd::MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES | MavCmd::MAV_CMD_REQUEST_PROTOCOL_VERSION => {
                let id = if c.command == MavCmd::MAV_CMD_REQUEST_PROTOCOL_VERSION {
                    300
                } else {
                    148
                };
                if let Some(message) = self.build_requested(id) {
                    follow_up.push((Destination::Link(inbound.link), message));
                }
                MavResult::MAV_RESULT_ACCEPTED
            }
            _ => MavResult::MAV_RESULT_UNSUPPORTED,
        }
    }

    fn arm_disarm(&mut self, p1: f32, p2: f32) -> MavResult {
        let force = p2 == FORCE_ARM_MAGIC;
        let ok = if p1 == 1.0 {
            self.arm(force)
        } else if p1 == 0.0 {
            self.fleet_note_gcs_disarm();
            self.disarm()
        } else {
            return MavResult::MAV_RESULT_DENIED;
        };
        if ok {
            MavResult::MAV_RESULT_ACCEPTED
        } else {
            MavResult::MAV_RESULT_FAILED
        }
    }

    fn do_set_mode(&mut self, p1: f32, p2: f32) -> MavResult {
        let (Some(flags), Some(mode)) = (whole(p1, u32::from(u8::MAX)), whole(p2, u32::MAX)) else {
            return MavResult::MAV_RESULT_DENIED;
        };
        let flags = MavModeFlag::from_bits_truncate(flags as u8);
        if !flags.contains(MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED) {
            return MavResult::MAV_RESULT_DENIED;
        }
        self.set_mode_result(mode)
    }

    fn do_set_mission_current(&mut self, p1: f32, p2: f32) -> MavResult {
        // -1 keeps the current item (only resetting jump counters).
        let seq = if p1 == -1.0 {
            self.missions.executor.current()
        } else {
            match whole(p1, u32::from(u16::MAX)) {
                Some(seq) => seq as u16,
                None => return MavResult::MAV_RESULT_DENIED,
            }
        };
        if self.set_mission_current(seq, p2 == 1.0) {
            MavResult::MAV_RESULT_ACCEPTED
        } else {
            MavResult::MAV_RESULT_DENIED
        }
    }

    /// As ArduPilot: only a channel no function owns (SERVOn_FUNCTION 0 or
    /// 1) takes a pulse from the GCS.
    fn do_set_servo(&mut self, p1: f32, p2: f32) -> MavResult {
        let channel = whole(p1, 64).map_or(0, |c| c as usize);
        let servos = self.p.servos.config(&self.params);
        match servos.channels.get(channel.wrapping_sub(1)) {
            Some(ch) if ch.function.accepts_direct_pulse() && (0.0..=3000.0).contains(&p2) => {
                self.missions.servo_us[channel - 1] = p2 as u16;
                MavResult::MAV_RESULT_ACCEPTED
            }
            _ => MavResult::MAV_RESULT_DENIED,
        }
    }

    fn do_set_relay(&mut self, p1: f32, p2: f32) -> MavResult {
        let Some(relay) = whole(p1, 15).map(|r| r as usize) else {
            return MavResult::MAV_RESULT_DENIED;
        };
        let servos = self.p.servos.config(&self.params);
        let fitted = servos.relay_channels.get(relay).is_some_and(Option::is_some);
        if !(fitted && (p2 == 0.0 || p2 == 1.0)) {
            return MavResult::MAV_RESULT_DENIED;
        }
        let bit = 1u16 << relay;
        self.missions.relays_used |= bit;
        if p2 == 1.0 {
            self.missions.relays_on |= bit;
        } else {
            self.missions.relays_on &= !bit;
        }
        MavResult::MAV_RESULT_ACCEPTED
    }

    /// REQUEST_MESSAGE: param 1 the message id; param 7 = 2 answers on
    /// every link, else on the asking one.
    fn request_message(
        &mut self,
        inbound: &Inbound,
        c: &Command,
        follow_up: &mut Vec<(Destination, MavMessage)>,
    ) -> MavResult {
        let response = if c.z == 2.0 {
            Destination::AllLinks
        } else {
            Destination::Link(inbound.link)
        };
        let Some(id) = whole(c.params[0], u32::MAX) else {
            return MavResult::MAV_RESULT_DENIED;
        };
        match self.build_requested(id) {
            Some(message) => {
                follow_up.push((response, message));
                MavResult::MAV_RESULT_ACCEPTED
            }
            None if self.can_build(id) => MavResult::MAV_RESULT_FAILED,
            None => MavResult::MAV_RESULT_UNSUPPORTED,
        }
    }

    fn get_message_interval(
        &self,
        inbound: &Inbound,
        p1: f32,
        follow_up: &mut Vec<(Destination, MavMessage)>,
    ) -> MavResult {
        let Some(msg) = whole(p1, u32::MAX).and_then(StreamMsg::from_message_id) else {
            return MavResult::MAV_RESULT_UNSUPPORTED;
        };
        let interval_us = self.message_interval_us(inbound, msg);
        follow_up.push((
            Destination::Link(inbound.link),
            MavMessage::MESSAGE_INTERVAL(MESSAGE_INTERVAL_DATA {
                interval_us,
                message_id: msg.message_id() as u16,
            }),
        ));
        MavResult::MAV_RESULT_ACCEPTED
    }

    fn set_mode_result(&mut self, number: u32) -> MavResult {
        let Some(mode) = Mode::from_number(number) else {
            self.warn_unknown_mode(number);
            return MavResult::MAV_RESULT_DENIED;
        };
        mode_result(self.request_mode(mode))
    }

    /// DO_REPOSITION (COMMAND_INT only, as positional commands must be):
    /// drive to the point in GUIDED, switching to GUIDED if param 2 allows,
    /// facing param 4 (degrees true; NaN: any heading) when it stops.
    fn do_reposition(&mut self, c: &Command) -> MavResult {
        if !c.is_int() {
            return MavResult::MAV_RESULT_COMMAND_INT_ONLY;
        }
        let Some(flags) = whole(c.params[1], u32::MAX) else {
            return MavResult::MAV_RESULT_DENIED;
        };
        let change_mode = flags & REPOSITION_CHANGE_MODE != 0;
        if self.mode != Mode::Guided && !change_mode {
            return MavResult::MAV_RESULT_DENIED;
        }
        let target = match c.location(self.estimator.gnss().alt_msl_m) {
            Ok(Some(p)) => p,
            Ok(None) => return MavResult::MAV_RESULT_DENIED,
            Err(e) => return e,
        };
        // Param 4: a heading must be a number of degrees (or NaN: none).
        if c.params[3].is_infinite() {
            return MavResult::MAV_RESULT_DENIED;
        }
        // Param 1: speed, -1 or NaN (or 0) keep the current one.
        let speed = c.params[0];
        if speed > mission::command::limits::MAX_SPEED_MPS {
            return MavResult::MAV_RESULT_DENIED;
        }
        if self.mode != Mode::Guided
            && let refused @ Err(_) = self.request_mode(Mode::Guided)
        {
            return mode_result(refused);
        }
        if speed_in_range(speed) {
            self.speed_override_mps = Some(f64::from(speed));
        }
        let yaw = self.local_yaw(&target, f64::from(c.params[3]).to_radians());
        if self.navigate_to(target, yaw, None) {
            MavResult::MAV_RESULT_ACCEPTED
        } else {
            MavResult::MAV_RESULT_FAILED
        }
    }

    /// DO_SET_HOME: param 1 = 1 uses the current position, else the command's
    /// location (param 7 / z altitude, 0 keeps the current altitude).
    fn do_set_home(&mut self, c: &Command) -> MavResult {
        if c.params[0] == 1.0 {
            return if self.set_home_to_current(true) {
                MavResult::MAV_RESULT_ACCEPTED
            } else {
                MavResult::MAV_RESULT_FAILED
            };
        }
        let alt = if c.z != 0.0 && c.z.is_finite() {
            if !HOME_ALT_RANGE_M.contains(&f64::from(c.z)) {
                return MavResult::MAV_RESULT_DENIED;
            }
            f64::from(c.z)
        } else {
            self.estimator.gnss().alt_msl_m
        };
        match c.location(alt) {
            Ok(Some(home)) => {
                self.set_home(home, true);
                MavResult::MAV_RESULT_ACCEPTED
            }
            Ok(None) => MavResult::MAV_RESULT_DENIED,
            Err(e) => e,
        }
    }

    /// DO_CHANGE_SPEED: ground (or air, treated as ground) speed for the
    /// current mode; -1 keeps it, -2 returns to the default.
    fn do_change_speed(&mut self, speed_type: f32, speed_mps: f32) -> MavResult {
        if !(speed_type == 0.0 || speed_type == 1.0) {
            return MavResult::MAV_RESULT_DENIED;
        }
        if speed_mps == -2.0 {
            self.speed_override_mps = None;
        } else if speed_in_range(speed_mps) {
            self.speed_override_mps = Some(f64::from(speed_mps));
        } else if speed_mps != -1.0 {
            return MavResult::MAV_RESULT_DENIED;
        }
        MavResult::MAV_RESULT_ACCEPTED
    }

    fn set_message_interval(&mut self, inbound: &Inbound, id: f32, interval_us: f32) -> MavResult {
        let Some(msg) = whole(id, u32::MAX).and_then(StreamMsg::from_message_id) else {
            return MavResult::MAV_RESULT_UNSUPPORTED;
        };
        let interval = if interval_us == 0.0 {
            None
        } else if interval_us < 0.0 {
            Some(MessageInterval::Disabled)
        } else if f64::from(interval_us) <= f64::from(i32::MAX) {
            // MESSAGE_INTERVAL reports it as an i32 of µs: no longer.
            Some(MessageInterval::Every(
                Duration::from_micros(interval_us as u64).max(Duration::from_millis(2)),
            ))
        } else {
            return MavResult::MAV_RESULT_DENIED;
        };
        match self.links.get_mut(&inbound.link) {
            Some(streams) => {
                streams.set_message_interval(msg, interval);
                MavResult::MAV_RESULT_ACCEPTED
            }
            None => MavResult::MAV_RESULT_FAILED,
        }
    }

    /// MESSAGE_INTERVAL's encoding: -1 disabled, otherwise µs.
    fn message_interval_us(&self, inbound: &Inbound, msg: StreamMsg) -> i32 {
        let Some(streams) = self.links.get(&inbound.link) else {
            return -1;
        };
        let slot = streams.slot();
        match streams.interval(msg, |g| self.slot_rate_hz(slot, g)) {
            Some(d) => d.as_micros().min(i32::MAX as u128) as i32,
            None => -1,
        }
    }
}

/// COMMAND_ACK for a mode request: a failsafe's refusal lasts only as long
/// as the failsafe, so it is temporary (as ArduPilot answers a command it
/// cannot carry out now).
fn mode_result(result: Result<(), ModeRefusal>) -> MavResult {
    match result {
        Ok(()) => MavResult::MAV_RESULT_ACCEPTED,
        Err(ModeRefusal::NotAvailable) => MavResult::MAV_RESULT_DENIED,
        Err(ModeRefusal::Failsafe(_)) => MavResult::MAV_RESULT_TEMPORARILY_REJECTED,
        Err(_) => MavResult::MAV_RESULT_FAILED,
    }
}
