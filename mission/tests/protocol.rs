//! The mission microservice against a simulated ground station: uploads,
//! downloads, time-outs (the wall clock advanced explicitly), partners.

#![allow(deprecated)] // MISSION_ITEM and MISSION_REQUEST must still be served.

use std::sync::Arc;
use std::time::Duration;

use mavlink::dialects::ardupilotmega::{
    MISSION_ACK_DATA, MISSION_CLEAR_ALL_DATA, MISSION_COUNT_DATA, MISSION_ITEM_DATA, MISSION_ITEM_INT_DATA,
    MISSION_REQUEST_DATA, MISSION_REQUEST_INT_DATA, MISSION_REQUEST_LIST_DATA, MISSION_WRITE_PARTIAL_LIST_DATA,
    MavMessage, MavMissionResult, MavMissionType,
};
use mission::command::{cmd, frame};
use mission::protocol::{FINAL_ACK_LINGER, ITEM_TIMEOUT, MAX_RETRIES};
use mission::validate::{mav_cmd, mav_frame};
use mission::{
    HomeItem, MissionEvent, MissionItem, MissionProtocol, MissionType, Outgoing, Plan, Plans, Reply, Sender,
    validate_plan,
};

const GCS: Sender = Sender {
    system_id: 255,
    component_id: 190,
};
const OTHER_GCS: Sender = Sender {
    system_id: 254,
    component_id: 190,
};
const HOME: (i32, i32) = (291_330_000, 1_196_400_000);

type Link = u8;

struct Bench {
    p: MissionProtocol<Link>,
    now: Duration,
    events: Vec<MissionEvent>,
}

impl Bench {
    fn new() -> Bench {
        Bench {
            p: MissionProtocol::new(Plans::default()),
            now: Duration::ZERO,
            events: Vec::new(),
        }
    }

    /// Hands a message in; returns the replies (all must go back on `link`,
    /// addressed to `from`).
    fn send(&mut self, link: Link, from: Sender, message: MavMessage) -> Vec<MavMessage> {
        let mut out = Vec::new();
        assert!(
            self.p
                .handle(self.now, link, from, &message, &mut out, &mut self.events)
        );
        replies(out, link, from)
    }

    /// Advances the wall clock and polls.
    fn advance(&mut self, by: Duration) -> Vec<Outgoing<Link>> {
        self.now += by;
        let mut out = Vec::new();
        self.p.poll(self.now, &mut out, &mut self.events);
        out
    }

    fn take_events(&mut self) -> Vec<MissionEvent> {
        std::mem::take(&mut self.events)
    }
}

fn replies(out: Vec<Outgoing<Link>>, link: Link, to: Sender) -> Vec<MavMessage> {
    out.into_iter()
        .map(|o| {
            assert_eq!(o.dest, Reply::Link(link));
            assert_eq!(target(&o.message), Some(to), "{:?}", o.message);
            o.message
        })
        .collect()
}

fn target(m: &MavMessage) -> Option<Sender> {
    let (system_id, component_id) = match m {
        MavMessage::MISSION_ACK(a) => (a.target_system, a.target_component),
        MavMessage::MISSION_COUNT(a) => (a.target_system, a.target_component),
        MavMessage::MISSION_REQUEST_INT(a) => (a.target_system, a.target_component),
        MavMessage::MISSION_ITEM_INT(a) => (a.target_system, a.target_component),
        _ => return None,
    };
    Some(Sender {
        system_id,
        component_id,
    })
}

fn mav_type(t: MissionType) -> MavMissionType {
    t.to_mavlink()
}

fn count(t: MissionType, n: u16) -> MavMessage {
    MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
        count: n,
        target_system: 1,
        target_component: 1,
        mission_type: mav_type(t),
        opaque_id: 0,
    })
}

fn item_int(t: MissionType, it: &MissionItem) -> MavMessage {
    MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
        param1: it.params[0],
        param2: it.params[1],
        param3: it.params[2],
        param4: it.params[3],
        x: it.x,
        y: it.y,
        z: it.z,
        seq: it.seq,
        command: mav_cmd(it.command).expect("dialect command"),
        target_system: 1,
        target_component: 1,
        frame: mav_frame(it.frame).expect("dialect frame"),
        current: u8::from(it.current),
        autocontinue: u8::from(it.autocontinue),
        mission_type: mav_type(t),
    })
}

fn request_list(t: MavMissionType) -> MavMessage {
    MavMessage::MISSION_REQUEST_LIST(MISSION_REQUEST_LIST_DATA {
        target_system: 1,
        target_component: 1,
        mission_type: t,
    })
}

fn request_int(t: MavMissionType, seq: u16) -> MavMessage {
    MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
        seq,
        target_system: 1,
        target_component: 1,
        mission_type: t,
    })
}

fn gcs_ack(t: MissionType, result: MavMissionResult) -> MavMessage {
    MavMessage::MISSION_ACK(MISSION_ACK_DATA {
        target_system: 1,
        target_component: 1,
        mavtype: result,
        mission_type: mav_type(t),
        opaque_id: 0,
    })
}

fn clear_all(t: MavMissionType) -> MavMessage {
    MavMessage::MISSION_CLEAR_ALL(MISSION_CLEAR_ALL_DATA {
        target_system: 1,
        target_component: 1,
        mission_type: t,
    })
}

fn item(seq: u16, command: u16, f: u8, params: [f32; 4], x: i32, y: i32, z: f32) -> MissionItem {
    MissionItem {
        seq,
        frame: f,
        command,
        current: false,
        autocontinue: true,
        params,
        x,
        y,
        z,
    }
}

/// Home plus `n - 1` varied items: waypoints in several frames (global and
/// local), NaN params, speed changes, a jump, a delay.
fn mission_items(n: u16) -> Vec<MissionItem> {
    let mut items = vec![item(
        0,
        cmd::NAV_WAYPOINT,
        frame::GLOBAL,
        [0.0; 4],
        HOME.0,
        HOME.1,
        40.0,
    )];
    for seq in 1..n {
        let i = i32::from(seq);
        let it = match seq % 7 {
            0 => item(
                seq,
                cmd::DO_CHANGE_SPEED,
                frame::MISSION,
                [1.0, 0.5 + (i % 5) as f32, -1.0, 0.0],
                0,
                0,
                0.0,
            ),
            1 => item(
                seq,
                cmd::NAV_WAYPOINT,
                frame::GLOBAL_RELATIVE_ALT,
                [(i % 3) as f32, 0.0, 0.0, f32::NAN],
                HOME.0 + i * 9,
                HOME.1 - i * 11,
                1.5,
            ),
            2 => item(
                seq,
                cmd::NAV_WAYPOINT,
                frame::GLOBAL_RELATIVE_ALT_INT,
                [0.0; 4],
                HOME.0 - i,
                HOME.1 + i,
                0.0,
            ),
            3 => item(
                seq,
                cmd::NAV_WAYPOINT,
                frame::LOCAL_NED,
                [0.0; 4],
                i * 1234,
                -i * 77,
                0.0,
            ),
            4 => item(
                seq,
                cmd::DO_SET_REVERSE,
                frame::MISSION,
                [(i % 2) as f32, 0.0, 0.0, 0.0],
                0,
                0,
                0.0,
            ),
            5 => item(
                seq,
                cmd::NAV_LOITER_TIME,
                frame::GLOBAL,
                [2.5, 0.0, 0.0, 0.0],
                HOME.0 + i,
                HOME.1 + i,
                12.25,
            ),
            _ => item(
                seq,
                cmd::CONDITION_DELAY,
                frame::MISSION,
                [0.125 * (i % 9) as f32, 0.0, 0.0, 0.0],
                0,
                0,
                0.0,
            ),
        };
        items.push(MissionItem {
            current: seq == 1,
            autocontinue: seq % 11 != 0,
            ..it
        });
    }
    if n > 3 {
        items[usize::from(n) - 1] = item(n - 1, cmd::DO_JUMP, frame::MISSION, [1.0, 2.0, 0.0, 0.0], 0, 0, 0.0);
    }
    items
}

fn fence_items() -> Vec<MissionItem> {
    let v = |seq, n: f32, x, y| {
        item(
            seq,
            cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION,
            frame::GLOBAL,
            [n, 0.0, 0.0, 0.0],
            x,
            y,
            0.0,
        )
    };
    vec![
        v(0, 3.0, HOME.0, HOME.1),
        v(1, 3.0, HOME.0 + 1000, HOME.1),
        v(2, 3.0, HOME.0, HOME.1 + 1000),
        item(
            3,
            cmd::NAV_FENCE_CIRCLE_EXCLUSION,
            frame::GLOBAL,
            [5.0, 0.0, 0.0, 0.0],
            HOME.0 + 300,
            HOME.1 + 300,
            0.0,
        ),
    ]
}

fn rally_items() -> Vec<MissionItem> {
    (0..3)
        .map(|s| {
            item(
                s,
                cmd::NAV_RALLY_POINT,
                frame::GLOBAL_RELATIVE_ALT,
                [0.0; 4],
                HOME.0 + i32::from(s),
                HOME.1,
                5.0,
            )
        })
        .collect()
}

fn ack_of(m: &MavMessage) -> Option<&MISSION_ACK_DATA> {
    match m {
        MavMessage::MISSION_ACK(a) => Some(a),
        _ => None,
    }
}

fn requested(m: &MavMessage) -> Option<u16> {
    match m {
        MavMessage::MISSION_REQUEST_INT(r) => Some(r.seq),
        _ => None,
    }
}

/// A well-behaved GCS uploading `items`: answers each request; returns the
/// final ACK.
fn upload(b: &mut Bench, link: Link, from: Sender, t: MissionType, items: &[MissionItem]) -> MISSION_ACK_DATA {
    let mut pending = b.send(link, from, count(t, items.len() as u16));
    loop {
        assert_eq!(pending.len(), 1, "{pending:?}");
        let reply = pending.remove(0);
        if let Some(a) = ack_of(&reply) {
            return a.clone();
        }
        let seq = requested(&reply).unwrap_or_else(|| panic!("unexpected {reply:?}"));
        if let MavMessage::MISSION_REQUEST_INT(r) = &reply {
            assert_eq!(r.mission_type, mav_type(t));
        }
        pending = b.send(link, from, item_int(t, &items[usize::from(seq)]));
    }
}

/// A GCS downloading a plan: returns the items and MISSION_COUNT's opaque id.
fn download(b: &mut Bench, link: Link, from: Sender, t: MissionType) -> (Vec<MissionItem>, u32) {
    let reply = b.send(link, from, request_list(mav_type(t)));
    let MavMessage::MISSION_COUNT(c) = &reply[0] else {
        panic!("{reply:?}")
    };
    assert_eq!(c.mission_type, mav_type(t));
    let mut items = Vec::new();
    for seq in 0..c.count {
        let reply = b.send(link, from, request_int(mav_type(t), seq));
        let MavMessage::MISSION_ITEM_INT(m) = &reply[0] else {
            panic!("{reply:?}")
        };
        assert_eq!((m.seq, m.mission_type), (seq, mav_type(t)));
        items.push(MissionItem::from_mavlink(m));
    }
    assert!(
        b.send(link, from, gcs_ack(t, MavMissionResult::MAV_MISSION_ACCEPTED))
            .is_empty()
    );
    (items, c.opaque_id)
}

/// Every field, bit for bit (NaN included).
fn same(a: &[MissionItem], b: &[MissionItem]) {
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        assert_eq!(x.content_bytes(), y.content_bytes(), "{x:?} vs {y:?}");
    }
}

#[test]
fn upload_and_download_10_100_1000_items() {
    for n in [10u16, 100, 1000] {
        let mut b = Bench::new();
        let items = mission_items(n);
        let ack = upload(&mut b, 1, GCS, MissionType::Mission, &items);
        assert_eq!(ack.mavtype, MavMissionResult::MAV_MISSION_ACCEPTED);
        assert_eq!(ack.mission_type, MavMissionType::MAV_MISSION_TYPE_MISSION);
        let id = b.p.plans().mission.opaque_id();
        assert_eq!(ack.opaque_id, id);
        assert_ne!(id, 0);
        assert_eq!(b.take_events(), vec![MissionEvent::PlanReplaced(MissionType::Mission)]);
        let (back, count_id) = download(&mut b, 2, OTHER_GCS, MissionType::Mission);
        assert_eq!(count_id, id);
        same(&back, &items);
        assert!(!b.p.is_uploading());
    }
}

#[test]
fn fence_and_rally_are_independent_plans() {
    let mut b = Bench::new();
    let mission = mission_items(5);
    let fence = fence_items();
    let rally = rally_items();
    for (t, items) in [
        (MissionType::Mission, &mission),
        (MissionType::Fence, &fence),
        (MissionType::Rally, &rally),
    ] {
        let ack = upload(&mut b, 1, GCS, t, items);
        assert_eq!(ack.mavtype, MavMissionResult::MAV_MISSION_ACCEPTED);
        assert_eq!(ack.mission_type, mav_type(t));
    }
    same(&download(&mut b, 1, GCS, MissionType::Mission).0, &mission);
    same(&download(&mut b, 1, GCS, MissionType::Fence).0, &fence);
    same(&download(&mut b, 1, GCS, MissionType::Rally).0, &rally);
    let ids: Vec<u32> = MissionType::ALL
        .iter()
        .map(|t| b.p.plans().get(*t).opaque_id())
        .collect();
    assert!(ids[0] != ids[1] && ids[1] != ids[2] && ids[0] != ids[2]);
}

#[test]
fn out_of_sequence_and_duplicate_items_are_dropped_and_re_requested() {
    let mut b = Bench::new();
    let items = mission_items(4);
    let t = MissionType::Mission;
    assert_eq!(requested(&b.send(1, GCS, count(t, 4))[0]), Some(0));
    // Item 1 before item 0: dropped, 0 asked again.
    assert_eq!(requested(&b.send(1, GCS, item_int(t, &items[1]))[0]), Some(0));
    assert_eq!(requested(&b.send(1, GCS, item_int(t, &items[0]))[0]), Some(1));
    // Item 0 again (a duplicate): dropped, 1 asked again.
    assert_eq!(requested(&b.send(1, GCS, item_int(t, &items[0]))[0]), Some(1));
    // An item of another plan type from the partner: dropped too.
    let rally = rally_items();
    assert_eq!(
        requested(&b.send(1, GCS, item_int(MissionType::Rally, &rally[1]))[0]),
        Some(1)
    );
    assert_eq!(requested(&b.send(1, GCS, item_int(t, &items[1]))[0]), Some(2));
    assert_eq!(requested(&b.send(1, GCS, item_int(t, &items[3]))[0]), Some(2));
    assert_eq!(requested(&b.send(1, GCS, item_int(t, &items[2]))[0]), Some(3));
    let reply = b.send(1, GCS, item_int(t, &items[3]));
    assert_eq!(
        ack_of(&reply[0]).unwrap().mavtype,
        MavMissionResult::MAV_MISSION_ACCEPTED
    );
    same(b.p.plans().mission.items(), &items);
    assert_eq!(b.take_events(), vec![MissionEvent::PlanReplaced(t)]);
}

#[test]
fn silence_is_re_requested_every_second_then_the_upload_is_cancelled() {
    let mut b = Bench::new();
    let old = mission_items(3);
    upload(&mut b, 1, GCS, MissionType::Mission, &old);
    let old_id = b.p.plans().mission.opaque_id();
    b.take_events();
    let items = mission_items(6);
    let t = MissionType::Mission;
    b.send(1, GCS, count(t, 6));
    b.send(1, GCS, item_int(t, &items[0]));
    // Item 1 was requested at t = 0: asked again every second, 5 times.
    let almost = ITEM_TIMEOUT - Duration::from_millis(1);
    for retry in 1..=MAX_RETRIES {
        assert!(b.advance(almost).is_empty(), "retry {retry}");
        let out = b.advance(Duration::from_millis(1));
        assert_eq!(out.len(), 1, "retry {retry}");
        assert_eq!(out[0].dest, Reply::Link(1));
        assert_eq!(requested(&out[0].message), Some(1));
    }
    assert!(b.advance(almost).is_empty());
    assert!(b.p.is_uploading());
    let out = b.advance(Duration::from_millis(1));
    assert_eq!(out.len(), 1);
    let a = ack_of(&out[0].message).unwrap();
    assert_eq!(a.mavtype, MavMissionResult::MAV_MISSION_OPERATION_CANCELLED);
    assert_eq!((a.target_system, a.opaque_id), (GCS.system_id, 0));
    assert!(!b.p.is_uploading());
    let events = b.take_events();
    assert!(
        matches!(&events[..], [MissionEvent::TransferFailed { mission_type: MissionType::Mission, text }] if text.contains("timed out")),
        "{events:?}"
    );
    // The old plan is still in force.
    assert_eq!(b.p.plans().mission.opaque_id(), old_id);
    same(&download(&mut b, 1, GCS, t).0, &old);
    // Late items of the dead upload are errors now.
    let reply = b.send(1, GCS, item_int(t, &items[1]));
    assert_eq!(ack_of(&reply[0]).unwrap().mavtype, MavMissionResult::MAV_MISSION_ERROR);
    assert!(b.advance(Duration::from_secs(10)).is_empty());
}

#[test]
fn a_lost_final_ack_is_sent_again_when_the_last_item_is_repeated() {
    let mut b = Bench::new();
    let items = mission_items(3);
    let t = MissionType::Mission;
    let first = upload(&mut b, 1, GCS, t, &items);
    b.take_events();
    b.advance(Duration::from_secs(2));
    let again = b.send(1, GCS, item_int(t, &items[2]));
    assert_eq!(ack_of(&again[0]), Some(&first));
    // An earlier item repeated late is ignored; nothing replaced twice.
    assert!(b.send(1, GCS, item_int(t, &items[1])).is_empty());
    assert!(b.take_events().is_empty());
    // Someone else repeating it is not the partner.
    let other = b.send(2, GCS, item_int(t, &items[2]));
    assert_eq!(ack_of(&other[0]).unwrap().mavtype, MavMissionResult::MAV_MISSION_ERROR);
    b.advance(FINAL_ACK_LINGER);
    let late = b.send(1, GCS, item_int(t, &items[2]));
    assert_eq!(ack_of(&late[0]).unwrap().mavtype, MavMissionResult::MAV_MISSION_ERROR);
}

#[test]
fn a_second_partner_is_denied_while_the_first_completes() {
    let mut b = Bench::new();
    let old = mission_items(3);
    upload(&mut b, 1, GCS, MissionType::Mission, &old);
    b.take_events();
    let items = mission_items(5);
    let t = MissionType::Mission;
    b.send(1, GCS, count(t, 5));
    b.send(1, GCS, item_int(t, &items[0]));
    let denied = |r: Vec<MavMessage>| {
        assert_eq!(r.len(), 1);
        let a = ack_of(&r[0]).unwrap();
        assert_eq!((a.mavtype, a.opaque_id), (MavMissionResult::MAV_MISSION_DENIED, 0));
    };
    // Another link, another system on the same link, another component.
    denied(b.send(2, GCS, count(t, 2)));
    denied(b.send(1, OTHER_GCS, count(MissionType::Fence, 2)));
    let other_component = Sender {
        component_id: 191,
        ..GCS
    };
    denied(b.send(1, other_component, count(t, 2)));
    denied(b.send(2, GCS, clear_all(MavMissionType::MAV_MISSION_TYPE_FENCE)));
    denied(b.send(2, GCS, item_int(t, &items[1])));
    // A download meanwhile sees the plan in force.
    same(&download(&mut b, 2, OTHER_GCS, t).0, &old);
    // An ACK from the other partner cancels nothing.
    assert!(
        b.send(
            2,
            OTHER_GCS,
            gcs_ack(t, MavMissionResult::MAV_MISSION_OPERATION_CANCELLED)
        )
        .is_empty()
    );
    assert!(b.take_events().is_empty());
    // The first partner finishes.
    let mut next = 1;
    loop {
        let r = b.send(1, GCS, item_int(t, &items[next]));
        if let Some(a) = ack_of(&r[0]) {
            assert_eq!(a.mavtype, MavMissionResult::MAV_MISSION_ACCEPTED);
            break;
        }
        next = usize::from(requested(&r[0]).unwrap());
    }
    same(b.p.plans().mission.items(), &items);
    // And the second may upload now.
    let ack = upload(&mut b, 2, OTHER_GCS, MissionType::Rally, &rally_items());
    assert_eq!(ack.mavtype, MavMissionResult::MAV_MISSION_ACCEPTED);
}

#[test]
fn the_partner_cancels_with_an_ack() {
    let mut b = Bench::new();
    let old = mission_items(3);
    upload(&mut b, 1, GCS, MissionType::Mission, &old);
    b.take_events();
    let items = mission_items(5);
    let t = MissionType::Mission;
    b.send(1, GCS, count(t, 5));
    b.send(1, GCS, item_int(t, &items[0]));
    // An ACCEPTED ack (ending some download) does not cancel.
    assert!(
        b.send(1, GCS, gcs_ack(t, MavMissionResult::MAV_MISSION_ACCEPTED))
            .is_empty()
    );
    assert!(b.p.is_uploading());
    // An ack for another plan type does not either.
    b.send(
        1,
        GCS,
        gcs_ack(MissionType::Fence, MavMissionResult::MAV_MISSION_OPERATION_CANCELLED),
    );
    assert!(b.p.is_uploading());
    assert!(
        b.send(1, GCS, gcs_ack(t, MavMissionResult::MAV_MISSION_OPERATION_CANCELLED))
            .is_empty()
    );
    assert!(!b.p.is_uploading());
    let events = b.take_events();
    assert!(
        matches!(&events[..], [MissionEvent::TransferFailed { text, .. }] if text.contains("cancelled")),
        "{events:?}"
    );
    same(b.p.plans().mission.items(), &old);
    assert!(
        b.advance(Duration::from_secs(30)).is_empty(),
        "no re-requests after a cancel"
    );
}

#[test]
fn a_bad_item_is_refused_at_once_with_its_precise_result_and_the_old_plan_stays() {
    let mut b = Bench::new();
    let old = mission_items(4);
    upload(&mut b, 1, GCS, MissionType::Mission, &old);
    let old_id = b.p.plans().mission.opaque_id();
    b.take_events();
    let t = MissionType::Mission;
    let cases = [
        (
            item(3, 21, frame::GLOBAL, [0.0; 4], 1, 1, 0.0),
            MavMissionResult::MAV_MISSION_UNSUPPORTED,
        ),
        (
            item(3, cmd::NAV_WAYPOINT, frame::MISSION, [0.0; 4], 1, 1, 0.0),
            MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME,
        ),
        (
            item(3, cmd::NAV_WAYPOINT, frame::GLOBAL, [0.0; 4], 950_000_000, 1, 0.0),
            MavMissionResult::MAV_MISSION_INVALID_PARAM5_X,
        ),
        (
            item(3, cmd::DO_JUMP, frame::MISSION, [9.0, 1.0, 0.0, 0.0], 0, 0, 0.0),
            MavMissionResult::MAV_MISSION_INVALID_PARAM1,
        ),
        (
            item(
                3,
                cmd::DO_CHANGE_SPEED,
                frame::MISSION,
                [1.0, f32::NAN, 0.0, 0.0],
                0,
                0,
                0.0,
            ),
            MavMissionResult::MAV_MISSION_INVALID_PARAM2,
        ),
    ];
    for (bad, result) in cases {
        let mut items = mission_items(6);
        items[3] = bad;
        let ack = upload(&mut b, 1, GCS, t, &items);
        assert_eq!((ack.mavtype, ack.opaque_id), (result, 0));
        let events = b.take_events();
        assert!(
            matches!(&events[..], [MissionEvent::TransferFailed { mission_type: MissionType::Mission, text }] if text.contains("item 3")),
            "{events:?}"
        );
        assert!(!b.p.is_uploading());
        let (back, id) = download(&mut b, 2, OTHER_GCS, t);
        assert_eq!(id, old_id);
        same(&back, &old);
        // The GCS repeating the refused item (our ACK lost) hears it again.
        let again = b.send(1, GCS, item_int(t, &items[3]));
        assert_eq!(ack_of(&again[0]).unwrap().mavtype, result);
    }
}

#[test]
fn a_fence_with_an_incomplete_polygon_is_refused() {
    let mut b = Bench::new();
    let good = fence_items();
    upload(&mut b, 1, GCS, MissionType::Fence, &good);
    b.take_events();
    // A polygon announcing 4 vertices followed by a circle.
    let mut bad = fence_items();
    for v in bad.iter_mut().take(3) {
        v.params[0] = 4.0;
    }
    let ack = upload(&mut b, 1, GCS, MissionType::Fence, &bad);
    assert_eq!(ack.mavtype, MavMissionResult::MAV_MISSION_INVALID_PARAM1);
    assert_eq!(ack.mission_type, MavMissionType::MAV_MISSION_TYPE_FENCE);
    let events = b.take_events();
    assert!(
        matches!(&events[..], [MissionEvent::TransferFailed { mission_type: MissionType::Fence, text }] if text.contains("item 3")),
        "{events:?}"
    );
    same(b.p.plans().fence.items(), &good);
    // A polygon of two vertices is refused on its first item.
    let two: Vec<MissionItem> = fence_items()
        .into_iter()
        .take(2)
        .map(|v| MissionItem {
            params: [2.0, 0.0, 0.0, 0.0],
            ..v
        })
        .collect();
    let ack = upload(&mut b, 1, GCS, MissionType::Fence, &two);
    assert_eq!(ack.mavtype, MavMissionResult::MAV_MISSION_INVALID_PARAM1);
}

#[test]
fn count_zero_clears_one_plan() {
    let mut b = Bench::new();
    upload(&mut b, 1, GCS, MissionType::Mission, &mission_items(4));
    upload(&mut b, 1, GCS, MissionType::Rally, &rally_items());
    b.take_events();
    let r = b.send(1, GCS, count(MissionType::Mission, 0));
    let a = ack_of(&r[0]).unwrap();
    assert_eq!(a.mavtype, MavMissionResult::MAV_MISSION_ACCEPTED);
    assert!(b.p.plans().mission.is_empty());
    assert_eq!(a.opaque_id, b.p.plans().mission.opaque_id());
    assert_eq!(a.opaque_id, Plan::new(MissionType::Mission, Vec::new()).opaque_id());
    assert_eq!(b.take_events(), vec![MissionEvent::PlanReplaced(MissionType::Mission)]);
    assert_eq!(b.p.plans().rally.len(), 3, "other plans untouched");
    assert!(!b.p.is_uploading());
}

#[test]
fn clear_all_clears_one_plan_and_refuses_type_all() {
    let mut b = Bench::new();
    for (t, items) in [
        (MissionType::Mission, mission_items(4)),
        (MissionType::Fence, fence_items()),
        (MissionType::Rally, rally_items()),
    ] {
        upload(&mut b, 1, GCS, t, &items);
    }
    b.take_events();
    let r = b.send(1, GCS, clear_all(MavMissionType::MAV_MISSION_TYPE_FENCE));
    let a = ack_of(&r[0]).unwrap();
    assert_eq!(a.mavtype, MavMissionResult::MAV_MISSION_ACCEPTED);
    assert_eq!(a.mission_type, MavMissionType::MAV_MISSION_TYPE_FENCE);
    assert_eq!(a.opaque_id, b.p.plans().fence.opaque_id());
    assert!(b.p.plans().fence.is_empty() && !b.p.plans().mission.is_empty());
    assert_eq!(b.take_events(), vec![MissionEvent::PlanReplaced(MissionType::Fence)]);
    // MISSION_TYPE_ALL: UNSUPPORTED, as ArduPilot answers it; nothing cleared.
    let ids = |p: &Plans| MissionType::ALL.map(|t| p.get(t).opaque_id());
    let before = ids(b.p.plans());
    let r = b.send(2, OTHER_GCS, clear_all(MavMissionType::MAV_MISSION_TYPE_ALL));
    let a = ack_of(&r[0]).unwrap();
    assert_eq!(a.mavtype, MavMissionResult::MAV_MISSION_UNSUPPORTED);
    assert_eq!(a.mission_type, MavMissionType::MAV_MISSION_TYPE_ALL);
    assert_eq!(ids(b.p.plans()), before);
    assert!(b.take_events().is_empty());
    // The partner clearing mid-upload abandons its upload.
    b.send(1, GCS, count(MissionType::Mission, 3));
    b.send(1, GCS, clear_all(MavMissionType::MAV_MISSION_TYPE_MISSION));
    assert!(!b.p.is_uploading());
}

#[test]
fn mission_type_all_and_partial_writes_are_unsupported() {
    let mut b = Bench::new();
    let all = MavMissionType::MAV_MISSION_TYPE_ALL;
    let unsupported = |r: Vec<MavMessage>| {
        assert_eq!(
            ack_of(&r[0]).unwrap().mavtype,
            MavMissionResult::MAV_MISSION_UNSUPPORTED
        );
    };
    unsupported(b.send(1, GCS, request_list(all)));
    unsupported(b.send(1, GCS, request_int(all, 0)));
    let mut c = MISSION_COUNT_DATA::DEFAULT;
    c.count = 3;
    c.mission_type = all;
    unsupported(b.send(1, GCS, MavMessage::MISSION_COUNT(c)));
    assert!(!b.p.is_uploading());
    unsupported(b.send(
        1,
        GCS,
        MavMessage::MISSION_WRITE_PARTIAL_LIST(MISSION_WRITE_PARTIAL_LIST_DATA {
            start_index: 1,
            end_index: 2,
            target_system: 1,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        }),
    ));
    // Not mission messages at all.
    let mut out = Vec::new();
    let mut events = Vec::new();
    let hb = MavMessage::HEARTBEAT(Default::default());
    assert!(!b.p.handle(b.now, 1, GCS, &hb, &mut out, &mut events));
    assert!(out.is_empty() && events.is_empty());
}

#[test]
fn too_many_items_is_no_space() {
    let mut b = Bench::new();
    let r = b.send(1, GCS, count(MissionType::Rally, 201));
    let a = ack_of(&r[0]).unwrap();
    assert_eq!(a.mavtype, MavMissionResult::MAV_MISSION_NO_SPACE);
    assert!(!b.p.is_uploading());
    let r = b.send(1, GCS, count(MissionType::Mission, 10_001));
    assert_eq!(ack_of(&r[0]).unwrap().mavtype, MavMissionResult::MAV_MISSION_NO_SPACE);
    let r = b.send(1, GCS, count(MissionType::Fence, 1000));
    assert_eq!(requested(&r[0]), Some(0));
}

#[test]
fn a_new_count_from_the_partner_restarts_the_upload() {
    let mut b = Bench::new();
    let t = MissionType::Mission;
    let first = mission_items(6);
    b.send(1, GCS, count(t, 6));
    b.send(1, GCS, item_int(t, &first[0]));
    b.send(1, GCS, item_int(t, &first[1]));
    let items = mission_items(3);
    let ack = upload(&mut b, 1, GCS, t, &items);
    assert_eq!(ack.mavtype, MavMissionResult::MAV_MISSION_ACCEPTED);
    same(b.p.plans().mission.items(), &items);
}

#[test]
fn requests_past_the_end_are_invalid_sequence() {
    let mut b = Bench::new();
    upload(&mut b, 1, GCS, MissionType::Rally, &rally_items());
    let r = b.send(1, GCS, request_int(MavMissionType::MAV_MISSION_TYPE_RALLY, 3));
    let a = ack_of(&r[0]).unwrap();
    assert_eq!(
        (a.mavtype, a.mission_type),
        (
            MavMissionResult::MAV_MISSION_INVALID_SEQUENCE,
            MavMissionType::MAV_MISSION_TYPE_RALLY
        )
    );
    let r = b.send(1, GCS, request_int(MavMissionType::MAV_MISSION_TYPE_FENCE, 0));
    assert_eq!(
        ack_of(&r[0]).unwrap().mavtype,
        MavMissionResult::MAV_MISSION_INVALID_SEQUENCE
    );
}

#[test]
fn deprecated_mission_request_is_answered_with_mission_item_int() {
    let mut b = Bench::new();
    let items = mission_items(3);
    upload(&mut b, 1, GCS, MissionType::Mission, &items);
    let r = b.send(
        1,
        GCS,
        MavMessage::MISSION_REQUEST(MISSION_REQUEST_DATA {
            seq: 1,
            target_system: 1,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        }),
    );
    let MavMessage::MISSION_ITEM_INT(m) = &r[0] else {
        panic!("{r:?}")
    };
    same(&[MissionItem::from_mavlink(m)], &items[1..2]);
}

fn float_item(seq: u16, f: u8, x: f32, y: f32) -> MavMessage {
    MavMessage::MISSION_ITEM(MISSION_ITEM_DATA {
        param1: 0.0,
        param2: 0.0,
        param3: 0.0,
        param4: 0.0,
        x,
        y,
        z: 3.5,
        seq,
        command: mav_cmd(cmd::NAV_WAYPOINT).unwrap(),
        target_system: 1,
        target_component: 1,
        frame: mav_frame(f).unwrap(),
        current: 0,
        autocontinue: 1,
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
    })
}

#[test]
fn deprecated_mission_item_is_converted() {
    let mut b = Bench::new();
    let t = MissionType::Mission;
    b.send(1, GCS, count(t, 3));
    b.send(1, GCS, float_item(0, frame::GLOBAL, 29.133, 119.64));
    b.send(1, GCS, float_item(1, frame::GLOBAL_RELATIVE_ALT, -29.5, -119.25));
    let r = b.send(1, GCS, float_item(2, frame::LOCAL_ENU, 12.3456, -0.5));
    assert_eq!(ack_of(&r[0]).unwrap().mavtype, MavMissionResult::MAV_MISSION_ACCEPTED);
    let plan = b.p.plans().mission.items();
    // f32 degrees: rounded to the nearest 1e-7 of the f32's value.
    assert_eq!(
        (plan[0].x, plan[0].y),
        (
            (f64::from(29.133f32) * 1e7).round() as i32,
            (f64::from(119.64f32) * 1e7).round() as i32
        )
    );
    assert_eq!((plan[1].x, plan[1].y), (-295_000_000, -1_192_500_000));
    assert_eq!((plan[2].x, plan[2].y), (123_456, -5_000));
    assert_eq!(plan[2].z, 3.5);
    // A latitude that is not a number is refused.
    b.send(1, GCS, count(t, 2));
    b.send(1, GCS, float_item(0, frame::GLOBAL, 29.133, 119.64));
    let r = b.send(1, GCS, float_item(1, frame::GLOBAL, f32::NAN, 119.64));
    assert_eq!(
        ack_of(&r[0]).unwrap().mavtype,
        MavMissionResult::MAV_MISSION_INVALID_PARAM5_X
    );
    b.send(1, GCS, count(t, 2));
    b.send(1, GCS, float_item(0, frame::GLOBAL, 29.133, 119.64));
    let r = b.send(1, GCS, float_item(1, frame::LOCAL_NED, 1.0, 1e10));
    assert_eq!(
        ack_of(&r[0]).unwrap().mavtype,
        MavMissionResult::MAV_MISSION_INVALID_PARAM6_Y
    );
}

#[test]
fn undecodable_items_are_unsupported() {
    let mut b = Bench::new();
    let t = MissionType::Mission;
    let items = mission_items(3);
    for (bad_frame, result) in [
        (false, MavMissionResult::MAV_MISSION_UNSUPPORTED),
        (true, MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME),
    ] {
        b.send(1, GCS, count(t, 3));
        b.send(1, GCS, item_int(t, &items[0]));
        let mut out = Vec::new();
        // Not the expected seq: dropped and re-requested like any other.
        b.p.handle_undecodable_item(b.now, 1, GCS, 2, 0, bad_frame, &mut out, &mut b.events);
        assert_eq!(requested(&replies(out, 1, GCS)[0]), Some(1));
        let mut out = Vec::new();
        b.p.handle_undecodable_item(b.now, 1, GCS, 1, 0, bad_frame, &mut out, &mut b.events);
        let r = replies(out, 1, GCS);
        assert_eq!(ack_of(&r[0]).unwrap().mavtype, result);
        assert!(!b.p.is_uploading());
        assert!(matches!(b.take_events()[..], [MissionEvent::TransferFailed { .. }]));
    }
    // Outside an upload, with a mission type the dialect lacks.
    let mut out = Vec::new();
    b.p.handle_undecodable_item(b.now, 1, GCS, 0, 7, false, &mut out, &mut b.events);
    assert_eq!(
        ack_of(&replies(out, 1, GCS)[0]).unwrap().mavtype,
        MavMissionResult::MAV_MISSION_UNSUPPORTED
    );
}

#[test]
fn undecodable_payloads_are_inspected() {
    use mission::protocol::{UndecodableItem, inspect_undecodable_item};
    // MISSION_ITEM_INT: seq 3, command 31999 (unknown), frame 3, mission type 1.
    let mut p = [0u8; 38];
    p[28..30].copy_from_slice(&3u16.to_le_bytes());
    p[30..32].copy_from_slice(&31_999u16.to_le_bytes());
    p[32] = 1;
    p[33] = 1;
    p[34] = 3;
    p[37] = 1;
    let want = UndecodableItem {
        seq: 3,
        target_system: 1,
        target_component: 1,
        mission_type: 1,
        bad_frame: false,
    };
    assert_eq!(inspect_undecodable_item(73, &p), Some(want));
    assert_eq!(inspect_undecodable_item(39, &p), Some(want));
    assert_eq!(inspect_undecodable_item(44, &p), None);
    // A known command with an unknown frame.
    p[30..32].copy_from_slice(&16u16.to_le_bytes());
    p[34] = 99;
    assert!(inspect_undecodable_item(73, &p).unwrap().bad_frame);
    // Decodable: not for this path. Truncated (MAVLink 2): mission type 0.
    p[34] = 3;
    assert_eq!(inspect_undecodable_item(73, &p), None);
    p[30..32].copy_from_slice(&31_999u16.to_le_bytes());
    assert_eq!(inspect_undecodable_item(73, &p[..35]).unwrap().mission_type, 0);
    assert!(
        inspect_undecodable_item(73, &[]).is_some(),
        "command 0 is not in the dialect"
    );
}

#[test]
fn opaque_ids_are_equal_for_equal_plans_and_differ_otherwise() {
    let mut b = Bench::new();
    let items = mission_items(20);
    let a1 = upload(&mut b, 1, GCS, MissionType::Mission, &items);
    let a2 = upload(&mut b, 2, OTHER_GCS, MissionType::Mission, &items);
    assert_eq!(a1.opaque_id, a2.opaque_id);
    let mut changed = items.clone();
    changed[7].params[1] += 1.0;
    let a3 = upload(&mut b, 1, GCS, MissionType::Mission, &changed);
    assert_ne!(a3.opaque_id, a1.opaque_id);
    let mut moved = items.clone();
    moved[5].x += 1;
    assert_ne!(
        upload(&mut b, 1, GCS, MissionType::Mission, &moved).opaque_id,
        a1.opaque_id
    );
    assert_eq!(
        upload(&mut b, 1, GCS, MissionType::Mission, &items).opaque_id,
        a1.opaque_id
    );
    let (_, id) = download(&mut b, 1, GCS, MissionType::Mission);
    assert_eq!(id, a1.opaque_id);
    // The same items as another plan type have another id.
    let rally = rally_items();
    let r = upload(&mut b, 1, GCS, MissionType::Rally, &rally);
    let mut as_rally = MissionProtocol::<Link>::new(Plans::default());
    as_rally.replace(MissionType::Rally, validate_plan(MissionType::Rally, rally).unwrap());
    assert_eq!(as_rally.plans().rally.opaque_id(), r.opaque_id);
}

#[test]
fn downloads_return_the_current_home_as_item_0() {
    let mut b = Bench::new();
    let home = HomeItem {
        lat_e7: 291_331_234,
        lon_e7: 1_196_405_678,
        alt_m: 41.5,
    };
    // No mission yet: home alone.
    b.p.set_home(Some(home));
    let (items, _) = download(&mut b, 1, GCS, MissionType::Mission);
    assert_eq!(items.len(), 1);
    same(&items, &[home.to_item()]);
    let uploaded = mission_items(4);
    upload(&mut b, 1, GCS, MissionType::Mission, &uploaded);
    let (items, _) = download(&mut b, 1, GCS, MissionType::Mission);
    assert_eq!(items[0].frame, frame::GLOBAL);
    assert_eq!(items[0].command, cmd::NAV_WAYPOINT);
    assert_eq!((items[0].x, items[0].y, items[0].z), (home.lat_e7, home.lon_e7, 41.5));
    same(&items[1..], &uploaded[1..]);
    // The stored item 0 is unchanged; without a home it is returned.
    same(&b.p.plans().mission.items()[..1], &uploaded[..1]);
    b.p.set_home(None);
    same(&download(&mut b, 1, GCS, MissionType::Mission).0, &uploaded);
    // Fence downloads never get a home.
    b.p.set_home(Some(home));
    assert!(download(&mut b, 1, GCS, MissionType::Fence).0.is_empty());
}

#[test]
fn a_closed_link_ends_its_upload() {
    let mut b = Bench::new();
    b.send(3, GCS, count(MissionType::Mission, 4));
    let mut events = Vec::new();
    b.p.link_closed(2, &mut events);
    assert!(b.p.is_uploading() && events.is_empty());
    b.p.link_closed(3, &mut events);
    assert!(!b.p.is_uploading());
    assert!(matches!(events[..], [MissionEvent::TransferFailed { .. }]));
}

mod random {
    //! Random message sequences never panic, and never leave a plan that
    //! fails validation.

    use super::*;
    use proptest::prelude::*;

    #[derive(Clone, Debug)]
    enum Step {
        Message(Link, Sender, Box<MavMessage>),
        Undecodable(Link, Sender, u16, u8, bool),
        Advance(u64),
        /// The uploading partner sends the item last requested, valid.
        Cooperate(i32),
    }

    fn sender() -> impl Strategy<Value = Sender> {
        prop_oneof![Just(GCS), Just(OTHER_GCS)]
    }

    fn mtype() -> impl Strategy<Value = MavMissionType> {
        prop_oneof![
            4 => Just(MavMissionType::MAV_MISSION_TYPE_MISSION),
            2 => Just(MavMissionType::MAV_MISSION_TYPE_FENCE),
            2 => Just(MavMissionType::MAV_MISSION_TYPE_RALLY),
            1 => Just(MavMissionType::MAV_MISSION_TYPE_ALL),
        ]
    }

    fn param() -> impl Strategy<Value = f32> {
        prop_oneof![
            4 => (0u8..6).prop_map(f32::from),
            1 => Just(f32::NAN),
            1 => Just(-1.0f32),
            1 => Just(f32::INFINITY),
            1 => any::<f32>(),
        ]
    }

    fn item_message() -> impl Strategy<Value = MavMessage> {
        let commands = prop::sample::select(vec![
            cmd::NAV_WAYPOINT,
            cmd::NAV_TAKEOFF,
            21,
            cmd::DO_JUMP,
            cmd::DO_CHANGE_SPEED,
            cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION,
            cmd::NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
            cmd::NAV_FENCE_CIRCLE_INCLUSION,
            cmd::NAV_FENCE_RETURN_POINT,
            cmd::NAV_RALLY_POINT,
        ]);
        let frames = prop::sample::select(vec![0u8, 1, 2, 3, 4, 5, 6, 8, 10]);
        let xy = prop_oneof![Just(0i32), -2000i32..2000, any::<i32>()];
        (
            (0u16..6, commands, frames, mtype(), any::<bool>()),
            (param(), param(), param(), param()),
            (xy.clone(), xy, param()),
        )
            .prop_map(|((seq, c, f, t, int), (p1, p2, p3, p4), (x, y, z))| {
                if int {
                    MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
                        param1: p1,
                        param2: p2,
                        param3: p3,
                        param4: p4,
                        x,
                        y,
                        z,
                        seq,
                        command: mav_cmd(c).unwrap(),
                        target_system: 1,
                        target_component: 1,
                        frame: mav_frame(f).unwrap(),
                        current: 0,
                        autocontinue: 1,
                        mission_type: t,
                    })
                } else {
                    MavMessage::MISSION_ITEM(MISSION_ITEM_DATA {
                        param1: p1,
                        param2: p2,
                        param3: p3,
                        param4: p4,
                        x: x as f32 * 1e-4,
                        y: y as f32 * 1e-4,
                        z,
                        seq,
                        command: mav_cmd(c).unwrap(),
                        target_system: 1,
                        target_component: 1,
                        frame: mav_frame(f).unwrap(),
                        current: 0,
                        autocontinue: 1,
                        mission_type: t,
                    })
                }
            })
    }

    fn message() -> impl Strategy<Value = MavMessage> {
        let result = prop::sample::select(vec![
            MavMissionResult::MAV_MISSION_ACCEPTED,
            MavMissionResult::MAV_MISSION_ERROR,
            MavMissionResult::MAV_MISSION_OPERATION_CANCELLED,
        ]);
        prop_oneof![
            3 => (mtype(), 0u16..7).prop_map(|(t, n)| MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
                count: n,
                target_system: 1,
                target_component: 1,
                mission_type: t,
                opaque_id: 0,
            })),
            8 => item_message(),
            1 => mtype().prop_map(request_list),
            1 => (mtype(), 0u16..8).prop_map(|(t, s)| request_int(t, s)),
            1 => (mtype(), result).prop_map(|(t, r)| MavMessage::MISSION_ACK(MISSION_ACK_DATA {
                target_system: 1,
                target_component: 1,
                mavtype: r,
                mission_type: t,
                opaque_id: 0,
            })),
            1 => mtype().prop_map(clear_all),
        ]
    }

    fn step() -> impl Strategy<Value = Step> {
        prop_oneof![
            10 => (0u8..2, sender(), message()).prop_map(|(l, s, m)| Step::Message(l, s, Box::new(m))),
            1 => (0u8..2, sender(), 0u16..6, prop::sample::select(vec![0u8, 1, 2, 7, 255]), any::<bool>())
                .prop_map(|(l, s, q, t, f)| Step::Undecodable(l, s, q, t, f)),
            3 => (0u64..3000).prop_map(Step::Advance),
            8 => (1i32..1000).prop_map(Step::Cooperate),
        ]
    }

    type Asked = Option<(Link, Sender, MavMissionType, u16)>;

    /// Remembers the last MISSION_REQUEST_INT sent.
    fn note(asked: &mut Asked, out: &[(Link, MavMessage)]) {
        for (link, m) in out {
            if let MavMessage::MISSION_REQUEST_INT(r) = m {
                let to = Sender {
                    system_id: r.target_system,
                    component_id: r.target_component,
                };
                *asked = Some((*link, to, r.mission_type, r.seq));
            }
        }
    }

    /// A valid item of a plan type at `seq` (circles: fence items valid alone).
    fn valid_item(t: MavMissionType, seq: u16, k: i32) -> MavMessage {
        let (mt, it) = match t {
            MavMissionType::MAV_MISSION_TYPE_FENCE => (
                MissionType::Fence,
                item(
                    seq,
                    cmd::NAV_FENCE_CIRCLE_INCLUSION,
                    frame::GLOBAL,
                    [k as f32, 0.0, 0.0, 0.0],
                    HOME.0 + k,
                    HOME.1,
                    0.0,
                ),
            ),
            MavMissionType::MAV_MISSION_TYPE_RALLY => (
                MissionType::Rally,
                item(
                    seq,
                    cmd::NAV_RALLY_POINT,
                    frame::GLOBAL_RELATIVE_ALT,
                    [0.0; 4],
                    HOME.0,
                    HOME.1 + k,
                    2.0,
                ),
            ),
            _ => (
                MissionType::Mission,
                item(
                    seq,
                    cmd::NAV_WAYPOINT,
                    frame::GLOBAL_RELATIVE_ALT,
                    [0.0; 4],
                    HOME.0 - k,
                    HOME.1 + k,
                    0.0,
                ),
            ),
        };
        item_int(mt, &it)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]

        #[test]
        fn random_sequences_keep_valid_plans(steps in prop::collection::vec(step(), 1..150)) {
            let mut b = Bench::new();
            // The last MISSION_REQUEST_INT sent: (link, to, type, seq).
            let mut asked: Asked = None;
            for s in steps {
                let mut out = Vec::new();
                match s {
                    Step::Message(link, from, m) => {
                        prop_assert!(b.p.handle(b.now, link, from, &m, &mut out, &mut b.events));
                        let r = replies(out, link, from);
                        note(&mut asked, &r.into_iter().map(|m| (link, m)).collect::<Vec<_>>());
                    }
                    Step::Undecodable(link, from, seq, t, f) => {
                        b.p.handle_undecodable_item(b.now, link, from, seq, t, f, &mut out, &mut b.events);
                        let r = replies(out, link, from);
                        note(&mut asked, &r.into_iter().map(|m| (link, m)).collect::<Vec<_>>());
                    }
                    Step::Advance(ms) => {
                        let out = b.advance(Duration::from_millis(ms));
                        let mut sent = Vec::new();
                        for o in out {
                            let Reply::Link(link) = o.dest else {
                                return Err(TestCaseError::fail("a broadcast"));
                            };
                            sent.push((link, o.message));
                        }
                        note(&mut asked, &sent);
                    }
                    Step::Cooperate(k) => {
                        if let Some((link, to, t, seq)) = asked {
                            let m = valid_item(t, seq, k);
                            prop_assert!(b.p.handle(b.now, link, to, &m, &mut out, &mut b.events));
                            let r = replies(out, link, to);
                            note(&mut asked, &r.into_iter().map(|m| (link, m)).collect::<Vec<_>>());
                        }
                    }
                }
                for t in MissionType::ALL {
                    let plan = b.p.plans().get(t);
                    let again = validate_plan(t, plan.items().to_vec()).map(|p| p.opaque_id());
                    prop_assert_eq!(again, Ok(plan.opaque_id()));
                }
            }
        }
    }
}

/// A protocol that saves before it acknowledges.
fn saving_bench() -> Bench {
    let mut b = Bench::new();
    b.p.set_save_first(true);
    b
}

/// Uploads all but the last item's answer: returns the replies to the last.
fn upload_to_last(b: &mut Bench, t: MissionType, items: &[MissionItem]) -> Vec<MavMessage> {
    b.send(1, GCS, count(t, items.len() as u16));
    let mut last = Vec::new();
    for it in items {
        last = b.send(1, GCS, item_int(t, it));
    }
    last
}

fn save_requested(events: &[MissionEvent]) -> Option<(MissionType, Plan)> {
    events.iter().find_map(|e| match e {
        MissionEvent::SaveRequested { mission_type, plan } => Some((*mission_type, plan.clone())),
        _ => None,
    })
}

#[test]
fn saving_first_the_ack_and_the_new_plan_wait_for_the_save() {
    let mut b = saving_bench();
    let items = mission_items(4);
    let t = MissionType::Mission;
    let last = upload_to_last(&mut b, t, &items);
    assert!(last.is_empty(), "no ACK before the save: {last:?}");
    let (saved_type, plan) = save_requested(&b.take_events()).expect("save requested");
    assert_eq!(saved_type, t);
    same(plan.items(), &items);
    assert!(b.p.plans().mission.is_empty(), "not in force before the save");
    assert!(b.p.is_saving());
    // Meanwhile: others are denied, the partner's repeated last item waits
    // for its ACK, downloads see the old plan.
    let r = b.send(2, OTHER_GCS, count(MissionType::Fence, 2));
    assert_eq!(ack_of(&r[0]).unwrap().mavtype, MavMissionResult::MAV_MISSION_DENIED);
    assert!(b.send(1, GCS, item_int(t, &items[3])).is_empty());
    assert!(download(&mut b, 2, OTHER_GCS, t).0.is_empty());
    let mut out = Vec::new();
    b.p.saved(b.now, Ok(()), &mut out, &mut b.events);
    let r = replies(out, 1, GCS);
    let a = ack_of(&r[0]).unwrap();
    assert_eq!(a.mavtype, MavMissionResult::MAV_MISSION_ACCEPTED);
    assert_eq!(a.opaque_id, plan.opaque_id());
    assert_eq!(b.p.plans().mission.opaque_id(), plan.opaque_id());
    assert_eq!(b.take_events(), vec![MissionEvent::PlanReplaced(t)]);
    // A lost ACK is sent again for the repeated last item.
    let again = b.send(1, GCS, item_int(t, &items[3]));
    assert_eq!(
        ack_of(&again[0]).unwrap().mavtype,
        MavMissionResult::MAV_MISSION_ACCEPTED
    );
}

#[test]
fn saving_first_a_failed_save_answers_error_and_keeps_the_old_plan() {
    let mut b = saving_bench();
    let t = MissionType::Mission;
    let old = mission_items(3);
    upload_to_last(&mut b, t, &old);
    let mut out = Vec::new();
    b.p.saved(b.now, Ok(()), &mut out, &mut b.events);
    b.take_events();
    let old_id = b.p.plans().mission.opaque_id();
    upload_to_last(&mut b, t, &mission_items(6));
    assert!(save_requested(&b.take_events()).is_some());
    let mut out = Vec::new();
    b.p.saved(
        b.now,
        Err("mission.waypoints: No space left on device".into()),
        &mut out,
        &mut b.events,
    );
    let r = replies(out, 1, GCS);
    let a = ack_of(&r[0]).unwrap();
    assert_eq!((a.mavtype, a.opaque_id), (MavMissionResult::MAV_MISSION_ERROR, 0));
    assert_eq!(b.p.plans().mission.opaque_id(), old_id, "the old plan stays in force");
    match &b.take_events()[..] {
        [MissionEvent::TransferFailed { text, .. }] => {
            assert!(text.contains("No space left on device"), "{text}")
        }
        other => panic!("{other:?}"),
    }
    assert!(!b.p.is_saving());
    // Uploads work again afterwards.
    let r = b.send(1, GCS, count(t, 1));
    assert!(matches!(r[0], MavMessage::MISSION_REQUEST_INT(_)), "{r:?}");
}

#[test]
fn saving_first_clears_wait_for_the_save_too() {
    let mut b = saving_bench();
    let t = MissionType::Mission;
    upload_to_last(&mut b, t, &mission_items(3));
    let mut out = Vec::new();
    b.p.saved(b.now, Ok(()), &mut out, &mut b.events);
    b.take_events();
    for clear in [count(t, 0), clear_all(MavMissionType::MAV_MISSION_TYPE_MISSION)] {
        assert!(b.send(1, GCS, clear).is_empty(), "no ACK before the save");
        let (_, plan) = save_requested(&b.take_events()).expect("save requested");
        assert!(plan.is_empty());
        assert!(!b.p.plans().mission.is_empty());
        let mut out = Vec::new();
        b.p.saved(b.now, Err("read-only".into()), &mut out, &mut b.events);
        let r = replies(out, 1, GCS);
        assert_eq!(ack_of(&r[0]).unwrap().mavtype, MavMissionResult::MAV_MISSION_ERROR);
        assert!(!b.p.plans().mission.is_empty(), "the mission is not cleared");
        b.take_events();
    }
}

#[test]
fn unknown_mission_types_are_found_in_undecodable_payloads() {
    use mavlink::Message;
    use mission::protocol::{UnknownMissionType, inspect_unknown_mission_type};
    // Each message serialised with a known type (fence, 1), then the type
    // byte changed to one the dialect lacks.
    let fence = MavMissionType::MAV_MISSION_TYPE_FENCE;
    let messages = [
        request_list(fence),
        MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count: 300,
            target_system: 1,
            target_component: 1,
            mission_type: fence,
            opaque_id: 0,
        }),
        clear_all(fence),
        request_int(fence, 4),
        MavMessage::MISSION_REQUEST(MISSION_REQUEST_DATA {
            seq: 4,
            target_system: 1,
            target_component: 1,
            mission_type: fence,
        }),
        MavMessage::MISSION_WRITE_PARTIAL_LIST(MISSION_WRITE_PARTIAL_LIST_DATA {
            start_index: 1,
            end_index: 2,
            target_system: 1,
            target_component: 1,
            mission_type: fence,
        }),
    ];
    for message in messages {
        let mut bytes = [0u8; 64];
        let n = message.ser(mavlink::MavlinkVersion::V2, &mut bytes);
        let id = message.message_id();
        assert_eq!(
            inspect_unknown_mission_type(id, &bytes[..n]),
            None,
            "{id}: a known type"
        );
        let at = bytes[..n].iter().rposition(|b| *b == 1).expect("the type byte");
        for unknown in [7u8, 9, 254] {
            bytes[at] = unknown;
            assert_eq!(
                inspect_unknown_mission_type(id, &bytes[..n]),
                Some(UnknownMissionType {
                    target_system: 1,
                    target_component: 1,
                    mission_type: unknown,
                }),
                "message {id}"
            );
        }
    }
    // Other messages, MISSION_ACK included, are not answered.
    assert_eq!(inspect_unknown_mission_type(47, &[1, 1, 0, 7]), None);
    assert_eq!(inspect_unknown_mission_type(73, &[0; 38]), None);
}

/// The value the link layer answers downloads from answers every download
/// request as the protocol does, and is replaced (never changed in place)
/// exactly when a plan in force or home changes.
#[test]
fn the_shared_downloads_answer_as_the_protocol_and_are_replaced_on_every_change() {
    let mut b = Bench::new();
    let first = b.p.downloads().clone();
    download(&mut b, 1, GCS, MissionType::Mission);
    b.send(1, GCS, count(MissionType::Mission, 3));
    b.send(
        1,
        GCS,
        gcs_ack(MissionType::Mission, MavMissionResult::MAV_MISSION_OPERATION_CANCELLED),
    );
    b.p.set_home(None);
    assert!(
        Arc::ptr_eq(&first, b.p.downloads()),
        "a download, a cancelled upload, the same home"
    );

    let items = mission_items(5);
    upload(&mut b, 1, GCS, MissionType::Mission, &items);
    let uploaded = b.p.downloads().clone();
    assert!(!Arc::ptr_eq(&first, &uploaded));
    assert!(first.plans().mission.is_empty(), "the old value stays as it was");
    let mission = mav_type(MissionType::Mission);
    let mut requests = vec![
        request_list(mission),
        request_list(mav_type(MissionType::Fence)),
        request_list(MavMissionType::MAV_MISSION_TYPE_ALL),
        request_int(mav_type(MissionType::Rally), 0),
        MavMessage::MISSION_REQUEST(MISSION_REQUEST_DATA {
            seq: 2,
            target_system: 1,
            target_component: 1,
            mission_type: mission,
        }),
    ];
    requests.extend((0..7).map(|seq| request_int(mission, seq)));
    // Compared as printed: items hold NaN parameters, which are not `==`.
    for request in &requests {
        let shared = uploaded.answer(OTHER_GCS, request).expect("a download request");
        let from_protocol = b.send(2, OTHER_GCS, request.clone());
        assert_eq!(format!("{from_protocol:?}"), format!("{:?}", [shared]));
    }
    assert!(uploaded.answer(OTHER_GCS, &count(MissionType::Mission, 1)).is_none());

    let home = HomeItem {
        lat_e7: 291_331_234,
        lon_e7: 1_196_405_678,
        alt_m: 41.5,
    };
    b.p.set_home(Some(home));
    let homed = b.p.downloads().clone();
    assert!(!Arc::ptr_eq(&uploaded, &homed));
    let Some(MavMessage::MISSION_ITEM_INT(item_0)) = homed.answer(GCS, &request_int(mission, 0)) else {
        panic!("no item 0");
    };
    assert_eq!((item_0.x, item_0.y), (home.lat_e7, home.lon_e7));
    b.p.set_home(Some(home));
    assert!(Arc::ptr_eq(&homed, b.p.downloads()), "the same home again");
    b.send(1, GCS, clear_all(mission));
    assert!(!Arc::ptr_eq(&homed, b.p.downloads()), "a clear");
}
