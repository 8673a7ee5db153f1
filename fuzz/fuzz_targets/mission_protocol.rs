//! The mission microservice on its own (`mission::MissionProtocol`): several
//! links and senders interleaving uploads, downloads, acks, clears, link
//! losses and timeouts, far faster than through the whole vehicle.
//!
//! Properties: a plan in force always passes `validate_plan` (a bad upload
//! never replaces a good plan); after any session, a clean download returns
//! exactly the stored items, home as item 0 when set.
#![no_main]
// Ground stations still send the deprecated MISSION_ITEM, SET_MODE, …
#![allow(deprecated)]

use std::time::Duration;

use libfuzzer_sys::arbitrary::{self, Arbitrary};
use libfuzzer_sys::fuzz_target;
use mavlink::dialects::ardupilotmega::{
    MISSION_ACK_DATA, MISSION_CLEAR_ALL_DATA, MISSION_COUNT_DATA, MISSION_ITEM_DATA, MISSION_ITEM_INT_DATA,
    MISSION_REQUEST_INT_DATA, MISSION_REQUEST_LIST_DATA, MavCmd, MavFrame, MavMessage, MavMissionResult,
    MavMissionType,
};
use mission::{HomeItem, MissionEvent, MissionProtocol, MissionType, Outgoing, Plans, Sender, validate_plan};
use num_traits::FromPrimitive;

#[derive(Arbitrary, Debug)]
enum Op {
    Count {
        mission_type: u8,
        count: u8,
    },
    Item {
        mission_type: u8,
        seq: u16,
        frame: u8,
        command: u16,
        current: bool,
        params: [f32; 4],
        x: i32,
        y: i32,
        z: f32,
    },
    /// An item near (0.5°, 0.5°) that validates as a mission, fence or
    /// rally item: uploads then complete.
    Good {
        mission_type: u8,
        seq: u16,
        north: i16,
        east: i16,
    },
    FloatItem {
        mission_type: u8,
        seq: u16,
        frame: u8,
        command: u16,
        x: f32,
        y: f32,
    },
    Undecodable {
        mission_type: u8,
        seq: u16,
        bad_frame: bool,
    },
    RequestList {
        mission_type: u8,
    },
    Request {
        mission_type: u8,
        seq: u16,
    },
    Ack {
        mission_type: u8,
        result: u8,
    },
    Clear {
        mission_type: u8,
    },
    LinkClosed,
    Home(Option<(i32, i32)>),
    /// Milliseconds; the poll after it may time an upload out.
    Wait(u16),
}

#[derive(Arbitrary, Debug)]
struct Step {
    /// Link 0–3 and sender 0–3: uploads from several ground stations.
    who: u8,
    op: Op,
}

fn mission_type(raw: u8) -> MavMissionType {
    MavMissionType::from_u8(raw % 3).unwrap_or_default()
}

fn cmd(raw: u16) -> MavCmd {
    MavCmd::from_u16(raw).unwrap_or(MavCmd::MAV_CMD_NAV_WAYPOINT)
}

fn frame(raw: u8) -> MavFrame {
    MavFrame::from_u8(raw).unwrap_or(MavFrame::MAV_FRAME_GLOBAL_INT)
}

fn check_plans(protocol: &MissionProtocol<u8>) {
    for t in [MissionType::Mission, MissionType::Fence, MissionType::Rally] {
        let items = protocol.plans().get(t).items().to_vec();
        assert!(validate_plan(t, items).is_ok(), "{t:?} plan in force does not validate");
    }
}

/// Downloads `t` on a fresh link and checks it returns the stored plan.
fn check_download(protocol: &mut MissionProtocol<u8>, now: Duration, t: MissionType) {
    let sender = Sender {
        system_id: 200,
        component_id: 1,
    };
    let link = 9;
    let (mut out, mut events) = (Vec::new(), Vec::new());
    let list = MavMessage::MISSION_REQUEST_LIST(MISSION_REQUEST_LIST_DATA {
        target_system: 1,
        target_component: 1,
        mission_type: t.to_mavlink(),
    });
    protocol.handle(now, link, sender, &list, &mut out, &mut events);
    let count = match out.as_slice() {
        [
            Outgoing {
                message: MavMessage::MISSION_COUNT(c),
                ..
            },
        ] => c.count,
        other => panic!("MISSION_REQUEST_LIST answered with {other:?}"),
    };
    let mut expected: Vec<_> = protocol.plans().get(t).items().to_vec();
    if t == MissionType::Mission
        && let Some(home) = protocol.home()
    {
        if expected.is_empty() {
            expected.push(home.to_item());
        } else {
            expected[0] = home.to_item();
        }
    }
    assert_eq!(usize::from(count), expected.len(), "{t:?} download count");
    for (seq, want) in expected.iter().enumerate() {
        out.clear();
        let request = MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
            seq: seq as u16,
            target_system: 1,
            target_component: 1,
            mission_type: t.to_mavlink(),
        });
        protocol.handle(now, link, sender, &request, &mut out, &mut events);
        let got = match out.as_slice() {
            [
                Outgoing {
                    message: MavMessage::MISSION_ITEM_INT(item),
                    ..
                },
            ] => mission::MissionItem::from_mavlink(item),
            other => panic!("MISSION_REQUEST_INT {seq} answered with {other:?}"),
        };
        assert_eq!(
            got.content_bytes(),
            want.content_bytes(),
            "{t:?} item {seq} downloaded differs"
        );
    }
    out.clear();
    let ack = MavMessage::MISSION_ACK(MISSION_ACK_DATA {
        target_system: 1,
        target_component: 1,
        mavtype: MavMissionResult::MAV_MISSION_ACCEPTED,
        mission_type: t.to_mavlink(),
        opaque_id: 0,
    });
    protocol.handle(now, link, sender, &ack, &mut out, &mut events);
}

fuzz_target!(|steps: Vec<Step>| {
    let mut protocol: MissionProtocol<u8> = MissionProtocol::new(Plans::default());
    let mut now = Duration::ZERO;
    let (mut out, mut events): (Vec<Outgoing<u8>>, Vec<MissionEvent>) = (Vec::new(), Vec::new());
    let base = (5_000_000, 5_000_000);
    for step in steps.iter().take(512) {
        let link = step.who & 3;
        let sender = Sender {
            system_id: 250 + ((step.who >> 2) & 3),
            component_id: 190,
        };
        let message = match step.op {
            Op::Count { mission_type: t, count } => MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
                count: u16::from(count),
                target_system: 1,
                target_component: 1,
                mission_type: mission_type(t),
                opaque_id: 0,
            }),
            Op::Item {
                mission_type: t,
                seq,
                frame: f,
                command,
                current,
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
                command: cmd(command),
                target_system: 1,
                target_component: 1,
                frame: frame(f),
                current: u8::from(current),
                autocontinue: 1,
                mission_type: mission_type(t),
            }),
            Op::Good {
                mission_type: t,
                seq,
                north,
                east,
            } => {
                let t = mission_type(t);
                let command = match t {
                    MavMissionType::MAV_MISSION_TYPE_FENCE => MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
                    MavMissionType::MAV_MISSION_TYPE_RALLY => MavCmd::MAV_CMD_NAV_RALLY_POINT,
                    _ => MavCmd::MAV_CMD_NAV_WAYPOINT,
                };
                MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
                    param1: 50.0,
                    x: base.0 + i32::from(north),
                    y: base.1 + i32::from(east),
                    seq,
                    command,
                    target_system: 1,
                    target_component: 1,
                    frame: MavFrame::MAV_FRAME_GLOBAL_INT,
                    autocontinue: 1,
                    mission_type: t,
                    ..Default::default()
                })
            }
            Op::FloatItem {
                mission_type: t,
                seq,
                frame: f,
                command,
                x,
                y,
            } => MavMessage::MISSION_ITEM(MISSION_ITEM_DATA {
                x,
                y,
                seq,
                command: cmd(command),
                target_system: 1,
                target_component: 1,
                frame: frame(f),
                autocontinue: 1,
                mission_type: mission_type(t),
                ..Default::default()
            }),
            Op::Undecodable {
                mission_type: t,
                seq,
                bad_frame,
            } => {
                protocol.handle_undecodable_item(now, link, sender, seq, t, bad_frame, &mut out, &mut events);
                check_plans(&protocol);
                continue;
            }
            Op::RequestList { mission_type: t } => MavMessage::MISSION_REQUEST_LIST(MISSION_REQUEST_LIST_DATA {
                target_system: 1,
                target_component: 1,
                mission_type: mission_type(t),
            }),
            Op::Request { mission_type: t, seq } => MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
                seq,
                target_system: 1,
                target_component: 1,
                mission_type: mission_type(t),
            }),
            Op::Ack {
                mission_type: t,
                result,
            } => MavMessage::MISSION_ACK(MISSION_ACK_DATA {
                target_system: 1,
                target_component: 1,
                mavtype: MavMissionResult::from_u8(result).unwrap_or_default(),
                mission_type: mission_type(t),
                opaque_id: 0,
            }),
            Op::Clear { mission_type: t } => MavMessage::MISSION_CLEAR_ALL(MISSION_CLEAR_ALL_DATA {
                target_system: 1,
                target_component: 1,
                mission_type: mission_type(t),
            }),
            Op::LinkClosed => {
                protocol.link_closed(link, &mut events);
                continue;
            }
            Op::Home(home) => {
                protocol.set_home(home.map(|(lat_e7, lon_e7)| HomeItem {
                    lat_e7: lat_e7 % 900_000_000,
                    lon_e7: lon_e7 % 1_800_000_000,
                    alt_m: 10.0,
                }));
                continue;
            }
            Op::Wait(ms) => {
                now += Duration::from_millis(u64::from(ms));
                protocol.poll(now, &mut out, &mut events);
                check_plans(&protocol);
                continue;
            }
        };
        assert!(protocol.handle(now, link, sender, &message, &mut out, &mut events));
        check_plans(&protocol);
        out.clear();
        events.clear();
    }
    for link in 0..4 {
        protocol.link_closed(link, &mut events);
    }
    for t in [MissionType::Mission, MissionType::Fence, MissionType::Rally] {
        check_download(&mut protocol, now, t);
    }
});
