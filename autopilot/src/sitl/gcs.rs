//! A ground station inside the process: builds the messages a GCS sends and
//! hands them to a [`Simulation`] as if they came over a link. Used by the
//! benchmarks and the in-process scenario tests.

use mavlink::dialects::ardupilotmega::{
    COMMAND_LONG_DATA, HEARTBEAT_DATA, MavAutopilot, MavCmd, MavFrame, MavMessage, MavModeFlag, MavState, MavType,
    PositionTargetTypemask, SET_POSITION_TARGET_GLOBAL_INT_DATA,
};
use mavlink::{MavHeader, MavlinkVersion};

use super::simulation::Simulation;
use crate::vehicle::{Inbound, LinkEvent, LinkId};

/// The link the in-process GCS talks on.
pub const GCS_LINK: LinkId = LinkId(0);

/// A GCS as pymavlink presents itself (system 255, component 190).
pub const GCS_HEADER: MavHeader = MavHeader {
    system_id: 255,
    component_id: 190,
    sequence: 0,
};

/// Opens the in-process GCS link (stream slot 0).
pub fn connect(sim: &mut Simulation) {
    let events = &mut sim.inputs_mut().link_events;
    events.push(LinkEvent::Opened {
        link: GCS_LINK,
        stream_slot: 0,
    });
    // As a TCP client does: the link opens with its ground station on it.
    events.push(LinkEvent::PeerJoined {
        link: GCS_LINK,
        peer: crate::vehicle::PeerId(0),
    });
}

/// Queues `message` for the next step.
pub fn send(sim: &mut Simulation, message: MavMessage) {
    sim.inputs_mut().messages.push(Inbound {
        link: GCS_LINK,
        header: GCS_HEADER,
        version: MavlinkVersion::V2,
        message,
    });
}

/// A ground station's HEARTBEAT (MAV_TYPE_GCS, as QGroundControl sends it).
pub fn heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_GCS,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    })
}

pub fn command_long(command: MavCmd, params: [f32; 7]) -> MavMessage {
    MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
        param1: params[0],
        param2: params[1],
        param3: params[2],
        param4: params[3],
        param5: params[4],
        param6: params[5],
        param7: params[6],
        command,
        target_system: 1,
        target_component: 1,
        confirmation: 0,
    })
}

/// DO_SET_MODE with an ArduPilot Rover custom mode number.
pub fn set_mode(number: u32) -> MavMessage {
    command_long(
        MavCmd::MAV_CMD_DO_SET_MODE,
        [1.0, number as f32, 0.0, 0.0, 0.0, 0.0, 0.0],
    )
}

pub fn arm() -> MavMessage {
    command_long(
        MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    )
}

/// A GUIDED position target, position only.
pub fn position_target(lat_deg: f64, lon_deg: f64) -> MavMessage {
    MavMessage::SET_POSITION_TARGET_GLOBAL_INT(SET_POSITION_TARGET_GLOBAL_INT_DATA {
        time_boot_ms: 0,
        lat_int: (lat_deg * 1e7).round() as i32,
        lon_int: (lon_deg * 1e7).round() as i32,
        alt: 0.0,
        vx: 0.0,
        vy: 0.0,
        vz: 0.0,
        afx: 0.0,
        afy: 0.0,
        afz: 0.0,
        yaw: 0.0,
        yaw_rate: 0.0,
        type_mask: PositionTargetTypemask::from_bits_truncate(0b0000_1111_1111_1000),
        target_system: 1,
        target_component: 1,
        coordinate_frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
    })
}

/// A GUIDED target `north_m`/`east_m` from the simulator's home.
pub fn local_target(sim: &Simulation, north_m: f64, east_m: f64) -> MavMessage {
    let p = sim.world().local_to_geodetic(north_m, east_m);
    position_target(p.lat_deg, p.lon_deg)
}

/// A GUIDED position target `north_m`/`east_m` from home in the simulator's
/// frame, to stop facing `yaw_deg` (true).
pub fn local_pose_target(sim: &Simulation, north_m: f64, east_m: f64, yaw_deg: f64) -> MavMessage {
    let p = sim.world().local_to_geodetic(north_m, east_m);
    let MavMessage::SET_POSITION_TARGET_GLOBAL_INT(mut target) = position_target(p.lat_deg, p.lon_deg) else {
        unreachable!("position_target builds a SET_POSITION_TARGET_GLOBAL_INT")
    };
    target.yaw = yaw_deg.to_radians() as f32;
    target.type_mask -= PositionTargetTypemask::POSITION_TARGET_TYPEMASK_YAW_IGNORE;
    MavMessage::SET_POSITION_TARGET_GLOBAL_INT(target)
}
