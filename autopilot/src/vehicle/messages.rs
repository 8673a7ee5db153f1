//! Inbound MAVLink messages.
//!
//! SET_MODE and the `*_INT` frames are superseded but MAVProxy, pymavlink and
//! Mission Planner still send them.
#![allow(deprecated)]

use mavlink::Message;
use mavlink::dialects::ardupilotmega::{
    MANUAL_CONTROL_DATA, MavFrame, MavMessage, MavModeFlag, PositionTargetTypemask, RC_CHANNELS_OVERRIDE_DATA,
    SET_POSITION_TARGET_GLOBAL_INT_DATA,
};

use super::{COMPONENT_ID, Core, Inbound};
use crate::control::mixer::from_pwm_us;
use crate::geo::GeoPoint;
use crate::modes::Mode;

/// RC_CHANNELS_OVERRIDE: 0 releases a channel, UINT16_MAX leaves it alone.
const RC_RELEASE: u16 = 0;
const RC_IGNORE: u16 = u16::MAX;

/// Whether a message is for the vehicle `sysid`: broadcast or addressed
/// to its system and (any or our) component.
pub fn addressed_to(sysid: u8, message: &MavMessage) -> bool {
    let system_ok = message.target_system_id().is_none_or(|s| s == 0 || s == sysid);
    let component_ok = message
        .target_component_id()
        .is_none_or(|c| c == 0 || c == COMPONENT_ID);
    system_ok && component_ok
}

impl Core {
    /// Whether a message is for this vehicle (see [`addressed_to`]).
    pub fn is_for_us(&self, message: &MavMessage) -> bool {
        addressed_to(self.sysid, message)
    }

    pub(super) fn handle_message(&mut self, inbound: &Inbound) {
        if !self.is_for_us(&inbound.message) {
            self.counters.messages_not_for_us += 1;
            return;
        }
        self.counters.messages_handled += 1;
        let from_gcs = inbound.header.system_id == u32::from(self.gcs_sysid());
        match &inbound.message {
            MavMessage::HEARTBEAT(_) if from_gcs => self.last_gcs_heartbeat_wall = Some(self.now.wall),
            MavMessage::PARAM_REQUEST_LIST(_) | MavMessage::PARAM_REQUEST_READ(_) | MavMessage::PARAM_SET(_) => {
                self.handle_param_message(inbound)
            }
            MavMessage::MISSION_COUNT(_)
            | MavMessage::MISSION_ITEM_INT(_)
            | MavMessage::MISSION_ITEM(_)
            | MavMessage::MISSION_REQUEST_LIST(_)
            | MavMessage::MISSION_REQUEST_INT(_)
            | MavMessage::MISSION_REQUEST(_)
            | MavMessage::MISSION_ACK(_)
            | MavMessage::MISSION_CLEAR_ALL(_)
            | MavMessage::MISSION_WRITE_PARTIAL_LIST(_) => {
                self.handle_mission_message(inbound);
            }
            MavMessage::COMMAND_LONG(c) => self.handle_command_long(inbound, c),
            MavMessage::COMMAND_INT(c) => self.handle_command_int(inbound, c),
            // SET_MODE carries ArduPilot's custom mode; the spec has no ACK
            // for it (the DO_SET_MODE command has one).
            MavMessage::SET_MODE(m) if m.base_mode.contains(MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED) => {
                match Mode::from_number(m.custom_mode) {
                    Some(mode) => {
                        let _ = self.request_mode(mode);
                    }
                    None => self.warn_unknown_mode(m.custom_mode),
                }
            }
            MavMessage::MANUAL_CONTROL(m) if from_gcs => self.handle_manual_control(m),
            MavMessage::RC_CHANNELS_OVERRIDE(m) if from_gcs => self.handle_rc_override(m),
            MavMessage::SET_POSITION_TARGET_GLOBAL_INT(m) => self.handle_position_target(m),
            MavMessage::MISSION_SET_CURRENT(m) => self.mission_set_current_message(m.seq),
            MavMessage::LOG_REQUEST_LIST(_)
            | MavMessage::LOG_REQUEST_DATA(_)
            | MavMessage::LOG_ERASE(_)
            | MavMessage::LOG_REQUEST_END(_) => self.onboard_log.request(inbound.link, inbound.message.clone()),
            MavMessage::REQUEST_DATA_STREAM(r) => {
                if let Some(streams) = self.links.get_mut(&inbound.link) {
                    streams.request_data_stream(r.req_stream_id as u8, r.req_message_rate, r.start_stop != 0);
                }
            }
            _ => {}
        }
    }

    pub(super) fn gcs_sysid(&self) -> u8 {
        self.p.system.gcs_sysid.get(&self.params).clamp(1, 255) as u8
    }

    pub(super) fn warn_unknown_mode(&mut self, number: u32) {
        self.send_text(
            mavlink::dialects::ardupilotmega::MavSeverity::MAV_SEVERITY_WARNING,
            &format!("Unknown mode {number}"),
        );
    }

    /// ArduPilot Rover: steering from `y`, throttle from `z`, both
    /// -1000..1000 (0 = centre / stop); INT16_MAX means "not in use".
    fn handle_manual_control(&mut self, m: &MANUAL_CONTROL_DATA) {
        let axis = |v: i16| (v != i16::MAX).then(|| (f64::from(v) / 1000.0).clamp(-1.0, 1.0));
        if let Some(s) = axis(m.y) {
            self.manual.steering = s;
        }
        if let Some(t) = axis(m.z) {
            self.manual.throttle = t;
        }
        self.manual.updated_wall = Some(self.now.wall);
    }

    /// Channel 1 steering, channel 3 throttle (ArduPilot Rover's RCMAP).
    fn handle_rc_override(&mut self, m: &RC_CHANNELS_OVERRIDE_DATA) {
        let channel = |pwm: u16| match pwm {
            RC_IGNORE => None,
            RC_RELEASE => Some(0.0),
            pwm => Some(from_pwm_us(pwm)),
        };
        if let Some(s) = channel(m.chan1_raw) {
            self.manual.steering = s;
        }
        if let Some(t) = channel(m.chan3_raw) {
            self.manual.throttle = t;
        }
        self.manual.updated_wall = Some(self.now.wall);
    }

    /// GUIDED position targets, as ArduPilot Rover accepts them: only in
    /// GUIDED, global frames, position not masked out; the yaw (radians
    /// true) is the heading to stop with unless masked out.
    fn handle_position_target(&mut self, m: &SET_POSITION_TARGET_GLOBAL_INT_DATA) {
        if self.mode != Mode::Guided {
            return;
        }
        let global = matches!(
            m.coordinate_frame,
            MavFrame::MAV_FRAME_GLOBAL
                | MavFrame::MAV_FRAME_GLOBAL_INT
                | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
                | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
                | MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT
                | MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT_INT
        );
        let position_ignored = m.type_mask.intersects(
            PositionTargetTypemask::POSITION_TARGET_TYPEMASK_X_IGNORE
                | PositionTargetTypemask::POSITION_TARGET_TYPEMASK_Y_IGNORE,
        );
        if !global || position_ignored {
            return;
        }
        let target = GeoPoint::from_e7(m.lat_int, m.lon_int, self.estimator.gnss().alt_msl_m);
        if target.is_valid() && !(m.lat_int == 0 && m.lon_int == 0) {
            let yaw = (!m
                .type_mask
                .contains(PositionTargetTypemask::POSITION_TARGET_TYPEMASK_YAW_IGNORE))
            .then(|| self.local_yaw(&target, f64::from(m.yaw)))
            .flatten();
            self.navigate_to(target, yaw, self.speed_override_mps);
        }
    }
}
