//! A ground station's session built from structured input: mission uploads
//! and downloads, parameter reads and sets, commands, mode changes, GUIDED
//! targets, manual control, with time passing and reconnects in between.
//! Raw bytes (`mavlink_core`) rarely get past a MISSION_COUNT to a complete
//! upload; here every operation is a well-formed message, so the fuzzer
//! spends its time on the handlers' states instead of on CRCs.
//!
//! Properties: every command addressed to the vehicle gets exactly one
//! COMMAND_ACK; every PARAM_SET of an existing parameter is answered with a
//! PARAM_VALUE holding the value now in the table.
#![no_main]
// Ground stations still send the deprecated MISSION_ITEM, SET_MODE, …
#![allow(deprecated)]

use std::time::Duration;

use furrow_fuzz::FuzzVehicle;
use libfuzzer_sys::arbitrary::{self, Arbitrary};
use libfuzzer_sys::fuzz_target;
use mavlink::dialects::ardupilotmega::{
    COMMAND_INT_DATA, COMMAND_LONG_DATA, MANUAL_CONTROL_DATA, MISSION_ACK_DATA, MISSION_CLEAR_ALL_DATA,
    MISSION_COUNT_DATA, MISSION_ITEM_DATA, MISSION_ITEM_INT_DATA, MISSION_REQUEST_INT_DATA, MISSION_REQUEST_LIST_DATA,
    MISSION_SET_CURRENT_DATA, MavCmd, MavFrame, MavMessage, MavMissionResult, MavMissionType, MavModeFlag,
    MavParamType, PARAM_REQUEST_LIST_DATA, PARAM_REQUEST_READ_DATA, PARAM_SET_DATA, PositionTargetTypemask,
    RC_CHANNELS_OVERRIDE_DATA, SET_MODE_DATA, SET_POSITION_TARGET_GLOBAL_INT_DATA,
};
use mavlink::{MavHeader, MavlinkVersion};
use num_traits::FromPrimitive;

/// Which vehicle a message is for: mostly ours, sometimes broadcast or
/// another one (which must be ignored).
#[derive(Arbitrary, Debug, Clone, Copy)]
enum Target {
    Us,
    Broadcast,
    Other(u8, u8),
}

#[derive(Arbitrary, Debug)]
enum Op {
    MissionCount {
        mission_type: u8,
        count: u16,
    },
    MissionItemInt {
        mission_type: u8,
        seq: u16,
        frame: u8,
        command: u16,
        current: bool,
        autocontinue: bool,
        params: [f32; 4],
        x: i32,
        y: i32,
        z: f32,
    },
    /// A waypoint near home: valid items make uploads complete.
    Waypoint {
        mission_type: u8,
        seq: u16,
        north_1e7: i16,
        east_1e7: i16,
    },
    MissionItemFloat {
        mission_type: u8,
        seq: u16,
        frame: u8,
        command: u16,
        x: f32,
        y: f32,
    },
    MissionRequestList {
        mission_type: u8,
    },
    MissionRequestInt {
        mission_type: u8,
        seq: u16,
    },
    MissionAck {
        mission_type: u8,
        result: u8,
    },
    MissionClearAll {
        mission_type: u8,
    },
    MissionSetCurrent {
        seq: u16,
    },
    ParamRequestList,
    ParamRequestRead {
        index: i16,
        name: ParamChoice,
    },
    ParamSet {
        name: ParamChoice,
        value: f32,
        param_type: u8,
    },
    CommandLong {
        command: u16,
        params: [f32; 7],
        confirmation: u8,
    },
    CommandInt {
        command: u16,
        frame: u8,
        params: [f32; 4],
        x: i32,
        y: i32,
        z: f32,
    },
    SetMode {
        custom_mode: u32,
    },
    ManualControl {
        x: i16,
        y: i16,
        z: i16,
        r: i16,
    },
    RcOverride {
        channels: [u16; 4],
    },
    PositionTarget {
        north_1e7: i16,
        east_1e7: i16,
        type_mask: u16,
    },
    /// Ticks of the core (up to ~5 s at 50 Hz).
    Steps(u8),
    /// Wall time only, in tenths of a second (link timeouts).
    Wait(u8),
    Reconnect,
}

/// A parameter name: one of the table's, or arbitrary bytes.
#[derive(Arbitrary, Debug)]
enum ParamChoice {
    Index(u16),
    Raw([u8; 16]),
}

#[derive(Arbitrary, Debug)]
struct Session {
    /// MAVLink 1 or 2 as the version the messages arrived with.
    mavlink1: bool,
    ops: Vec<(Target, Op)>,
}

/// Home of the simulated vehicle in degrees × 1e7 (SimulationConfig's).
fn home_e7(vehicle: &FuzzVehicle) -> (i32, i32) {
    let p = vehicle.sim().world().local_to_geodetic(0.0, 0.0);
    ((p.lat_deg * 1e7).round() as i32, (p.lon_deg * 1e7).round() as i32)
}

fn mission_type(raw: u8) -> MavMissionType {
    MavMissionType::from_u8(raw % 3).unwrap_or_default()
}

fn param_id(vehicle: &FuzzVehicle, choice: &ParamChoice) -> [u8; 16] {
    match choice {
        ParamChoice::Index(i) => {
            let table = vehicle.sim().core().params();
            let len = table.len().max(1) as u16;
            table.def(i % len).name.to_mavlink_id()
        }
        ParamChoice::Raw(bytes) => *bytes,
    }
}

/// Where a message goes, and the vehicle's home (degrees × 1e7) that the
/// generated positions are near.
#[derive(Clone, Copy)]
struct To {
    system: u8,
    component: u8,
    home_lat_e7: i32,
    home_lon_e7: i32,
}

fn message(vehicle: &FuzzVehicle, target: Target, op: &Op) -> Option<MavMessage> {
    let (system, component) = match target {
        Target::Us => (vehicle.sim().core().sysid(), 1),
        Target::Broadcast => (0, 0),
        Target::Other(s, c) => (s, c),
    };
    let (home_lat_e7, home_lon_e7) = home_e7(vehicle);
    let to = To {
        system,
        component,
        home_lat_e7,
        home_lon_e7,
    };
    mission_item_message(to, op)
        .or_else(|| waypoint_message(to, op))
        .or_else(|| mission_message(to, op))
        .or_else(|| param_or_command_message(vehicle, to, op))
        .or_else(|| control_message(to, op))
}

fn mav_cmd(c: u16) -> MavCmd {
    MavCmd::from_u16(c).unwrap_or(MavCmd::MAV_CMD_NAV_WAYPOINT)
}

fn mav_frame(f: u8) -> MavFrame {
    MavFrame::from_u8(f).unwrap_or(MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)
}

/// The mission items as a ground station sends them, fields from the input;
/// other ops: `None`.
fn mission_item_message(to: To, op: &Op) -> Option<MavMessage> {
    Some(match *op {
        Op::MissionItemInt {
            mission_type: t,
            seq,
            frame: f,
            command,
            current,
            autocontinue,
            params,
            x,
            y,
            z,
        } => MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
            param1: params[0],
            param2: params[1],
            param3: params[2],
            param4: params[3],
            x,
            y,
            z,
            seq,
            command: mav_cmd(command),
            target_system: to.system,
            target_component: to.component,
            frame: mav_frame(f),
            current: u8::from(current),
            autocontinue: u8::from(autocontinue),
            mission_type: mission_type(t),
        }),
        Op::MissionItemFloat {
            mission_type: t,
            seq,
            frame: f,
            command,
            x,
            y,
        } => MavMessage::MISSION_ITEM(MISSION_ITEM_DATA {
            param1: 0.0,
            param2: 0.0,
            param3: 0.0,
            param4: 0.0,
            x,
            y,
            z: 0.0,
            seq,
            command: mav_cmd(command),
            target_system: to.system,
            target_component: to.component,
            frame: mav_frame(f),
            current: 0,
            autocontinue: 1,
            mission_type: mission_type(t),
        }),
        _ => return None,
    })
}

/// A valid waypoint near home (a fence or rally point for those mission
/// types), so uploads complete; other ops: `None`.
fn waypoint_message(to: To, op: &Op) -> Option<MavMessage> {
    Some(match *op {
        Op::Waypoint {
            mission_type: t,
            seq,
            north_1e7,
            east_1e7,
        } => {
            let mission_type = mission_type(t);
            let command = match mission_type {
                MavMissionType::MAV_MISSION_TYPE_FENCE => MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
                MavMissionType::MAV_MISSION_TYPE_RALLY => MavCmd::MAV_CMD_NAV_RALLY_POINT,
                _ => MavCmd::MAV_CMD_NAV_WAYPOINT,
            };
            MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
                param1: 20.0,
                param2: 0.0,
                param3: 0.0,
                param4: 0.0,
                x: to.home_lat_e7.saturating_add(i32::from(north_1e7)),
                y: to.home_lon_e7.saturating_add(i32::from(east_1e7)),
                z: 0.0,
                seq,
                command,
                target_system: to.system,
                target_component: to.component,
                frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                current: 0,
                autocontinue: 1,
                mission_type,
            })
        }
        _ => return None,
    })
}

/// The rest of the mission protocol; other ops: `None`.
fn mission_message(to: To, op: &Op) -> Option<MavMessage> {
    Some(match *op {
        Op::MissionCount { mission_type: t, count } => MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count,
            target_system: to.system,
            target_component: to.component,
            mission_type: mission_type(t),
            opaque_id: 0,
        }),
        Op::MissionRequestList { mission_type: t } => MavMessage::MISSION_REQUEST_LIST(MISSION_REQUEST_LIST_DATA {
            target_system: to.system,
            target_component: to.component,
            mission_type: mission_type(t),
        }),
        Op::MissionRequestInt { mission_type: t, seq } => MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
            seq,
            target_system: to.system,
            target_component: to.component,
            mission_type: mission_type(t),
        }),
        Op::MissionAck {
            mission_type: t,
            result,
        } => MavMessage::MISSION_ACK(MISSION_ACK_DATA {
            target_system: to.system,
            target_component: to.component,
            mavtype: MavMissionResult::from_u8(result).unwrap_or_default(),
            mission_type: mission_type(t),
            opaque_id: 0,
        }),
        Op::MissionClearAll { mission_type: t } => MavMessage::MISSION_CLEAR_ALL(MISSION_CLEAR_ALL_DATA {
            target_system: to.system,
            target_component: to.component,
            mission_type: mission_type(t),
        }),
        Op::MissionSetCurrent { seq } => MavMessage::MISSION_SET_CURRENT(MISSION_SET_CURRENT_DATA {
            seq,
            target_system: to.system,
            target_component: to.component,
        }),
        _ => return None,
    })
}

/// Parameter reads and sets, commands; other ops: `None`.
fn param_or_command_message(vehicle: &FuzzVehicle, to: To, op: &Op) -> Option<MavMessage> {
    Some(match *op {
        Op::ParamRequestList => MavMessage::PARAM_REQUEST_LIST(PARAM_REQUEST_LIST_DATA {
            target_system: to.system,
            target_component: to.component,
        }),
        Op::ParamRequestRead { index, ref name } => MavMessage::PARAM_REQUEST_READ(PARAM_REQUEST_READ_DATA {
            param_index: index,
            target_system: to.system,
            target_component: to.component,
            param_id: param_id(vehicle, name).into(),
        }),
        Op::ParamSet {
            ref name,
            value,
            param_type,
        } => MavMessage::PARAM_SET(PARAM_SET_DATA {
            param_value: value,
            target_system: to.system,
            target_component: to.component,
            param_id: param_id(vehicle, name).into(),
            param_type: MavParamType::from_u8(param_type).unwrap_or_default(),
        }),
        Op::CommandLong {
            command,
            params,
            confirmation,
        } => MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            param1: params[0],
            param2: params[1],
            param3: params[2],
            param4: params[3],
            param5: params[4],
            param6: params[5],
            param7: params[6],
            command: mav_cmd(command),
            target_system: to.system,
            target_component: to.component,
            confirmation,
        }),
        Op::CommandInt {
            command,
            frame: f,
            params,
            x,
            y,
            z,
        } => MavMessage::COMMAND_INT(COMMAND_INT_DATA {
            param1: params[0],
            param2: params[1],
            param3: params[2],
            param4: params[3],
            x,
            y,
            z,
            command: mav_cmd(command),
            target_system: to.system,
            target_component: to.component,
            frame: mav_frame(f),
            current: 0,
            autocontinue: 0,
        }),
        _ => return None,
    })
}

/// Mode changes, manual input, GUIDED targets; other ops (steps, waits,
/// reconnects): `None`.
fn control_message(to: To, op: &Op) -> Option<MavMessage> {
    Some(match *op {
        Op::SetMode { custom_mode } => MavMessage::SET_MODE(SET_MODE_DATA {
            custom_mode,
            target_system: to.system,
            base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
        }),
        Op::ManualControl { x, y, z, r } => MavMessage::MANUAL_CONTROL(MANUAL_CONTROL_DATA {
            x,
            y,
            z,
            r,
            target: to.system,
            ..Default::default()
        }),
        Op::RcOverride { channels } => MavMessage::RC_CHANNELS_OVERRIDE(RC_CHANNELS_OVERRIDE_DATA {
            chan1_raw: channels[0],
            chan2_raw: channels[1],
            chan3_raw: channels[2],
            chan4_raw: channels[3],
            target_system: to.system,
            target_component: to.component,
            ..Default::default()
        }),
        Op::PositionTarget {
            north_1e7,
            east_1e7,
            type_mask,
        } => MavMessage::SET_POSITION_TARGET_GLOBAL_INT(SET_POSITION_TARGET_GLOBAL_INT_DATA {
            lat_int: to.home_lat_e7.saturating_add(i32::from(north_1e7) * 10),
            lon_int: to.home_lon_e7.saturating_add(i32::from(east_1e7) * 10),
            type_mask: PositionTargetTypemask::from_bits_truncate(type_mask),
            target_system: to.system,
            target_component: to.component,
            coordinate_frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            ..Default::default()
        }),
        _ => return None,
    })
}

/// PARAM_SET of a parameter the table has: the answers must include a
/// PARAM_VALUE for it with the value now in force.
fn check_param_set(vehicle: &FuzzVehicle, set: &PARAM_SET_DATA, answers: &furrow_fuzz::Answers) {
    let id = set.param_id.to_str().unwrap_or_default();
    let table = vehicle.sim().core().params();
    let Some(index) = table.index_of(id) else {
        return;
    };
    let now = table.value(index) as f32;
    let answered = answers.messages.iter().any(|m| match m {
        MavMessage::PARAM_VALUE(v) => {
            v.param_id.to_str().unwrap_or_default() == id && v.param_value.to_bits() == now.to_bits()
        }
        _ => false,
    });
    assert!(
        answered,
        "PARAM_SET {id} = {} not answered with PARAM_VALUE {now}",
        set.param_value
    );
}

fuzz_target!(|session: Session| {
    let mut vehicle = FuzzVehicle::new();
    let version = if session.mavlink1 {
        MavlinkVersion::V1
    } else {
        MavlinkVersion::V2
    };
    let header = MavHeader {
        system_id: 255,
        component_id: 190,
        sequence: 0,
    };
    for (i, (target, op)) in session.ops.iter().take(256).enumerate() {
        match op {
            Op::Steps(n) => vehicle.steps(u32::from(*n)),
            Op::Wait(tenths) => vehicle.advance_wall(Duration::from_millis(u64::from(*tenths) * 100)),
            Op::Reconnect => vehicle.reconnect(),
            _ => {
                let Some(message) = message(&vehicle, *target, op) else {
                    continue;
                };
                let header = MavHeader {
                    sequence: i as u8,
                    ..header
                };
                let for_us = vehicle.sim().core().is_for_us(&message);
                vehicle.deliver(header, version, message.clone());
                let answers = vehicle.service();
                if let MavMessage::PARAM_SET(set) = &message
                    && for_us
                {
                    check_param_set(&vehicle, set, &answers);
                }
            }
        }
    }
    vehicle.steps(2);
});
