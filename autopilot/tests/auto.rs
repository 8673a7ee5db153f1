//! AUTO in simulated time: a mission built in code (local frame), driven
//! through the core with the real navigator and vehicle model.

mod common;

use autopilot::modes::Mode;
use autopilot::sitl::simulation::ModelKind;
use common::{Harness, item};
use mavlink::dialects::ardupilotmega::{MavCmd, MavMessage, MavResult, MissionState};
use mission::command::{cmd, frame};
use mission::{ExecState, MissionItem, MissionType, Plan};

fn wp(seq: u16, north_m: f64, east_m: f64, hold_s: f32) -> MissionItem {
    item(
        seq,
        cmd::NAV_WAYPOINT,
        frame::LOCAL_NED,
        [hold_s, 0.0, 0.0, 0.0],
        north_m,
        east_m,
    )
}

fn do_item(seq: u16, command: u16, params: [f32; 4]) -> MissionItem {
    item(seq, command, frame::MISSION, params, 0.0, 0.0)
}

fn reached(h: &Harness) -> Vec<u16> {
    h.received
        .iter()
        .filter_map(|o| match &o.message {
            MavMessage::MISSION_ITEM_REACHED(r) => Some(r.seq),
            _ => None,
        })
        .collect()
}

/// Forward 30 m north, reverse back 15 m into a stop with a servo, then a
/// loop (DO_JUMP) around two waypoints twice.
fn mission() -> Plan {
    let items = vec![
        wp(0, 0.0, 0.0, 0.0),
        do_item(1, cmd::DO_CHANGE_SPEED, [1.0, 2.0, -1.0, 0.0]),
        wp(2, 30.0, 0.0, 0.0),
        do_item(3, cmd::DO_SET_REVERSE, [1.0, 0.0, 0.0, 0.0]),
        do_item(4, cmd::DO_CHANGE_SPEED, [1.0, 0.5, -1.0, 0.0]),
        wp(5, 15.0, 0.0, 2.0),
        do_item(6, cmd::DO_SET_SERVO, [9.0, 1900.0, 0.0, 0.0]),
        do_item(7, cmd::DO_SET_REVERSE, [0.0, 0.0, 0.0, 0.0]),
        do_item(8, cmd::DO_CHANGE_SPEED, [1.0, 1.5, -1.0, 0.0]),
        wp(9, 35.0, 0.0, 0.0),
        wp(10, 35.0, 20.0, 0.0),
        do_item(11, cmd::DO_JUMP, [9.0, 1.0, 0.0, 0.0]),
        wp(12, 60.0, 20.0, 0.0),
    ];
    Plan::new(MissionType::Mission, items)
}

#[test]
fn auto_runs_the_mission_in_order_with_reverse_servo_and_jump() {
    let mut h = Harness::new(2, ModelKind::Ackermann);
    h.sim.core_mut().load_plan(MissionType::Mission, mission());
    h.run_for(2.0);
    h.arm();
    h.set_mode(10);
    h.step();
    assert_eq!(h.sim.core().mode(), Mode::Auto, "{:?}", h.texts());

    let mut reversing_seen = false;
    let done = h.run_until(600.0, |s| {
        let t = s.world().truth();
        if t.speed_mps < -0.3 {
            // Driving backwards: heading stays north while moving south.
            assert!(t.yaw_rad.abs() < 0.6, "reversing with heading {}", t.yaw_rad);
            reversing_seen = true;
        }
        s.core().mission_state() == ExecState::Complete
    });
    assert!(
        done,
        "mission did not complete: reached {:?}, texts {:?}",
        reached(&h),
        h.texts()
    );
    assert!(reversing_seen, "the reverse leg was driven backwards");
    assert_eq!(reached(&h), vec![2, 5, 9, 10, 9, 10, 12]);
    assert!(h.texts().iter().any(|t| t == "Reached waypoint #5"));
    assert!(h.texts().iter().any(|t| t == "Mission Complete"));
    let servo9 = h.received.iter().rev().find_map(|o| match &o.message {
        MavMessage::SERVO_OUTPUT_RAW(s) => Some(s.servo9_raw),
        _ => None,
    });
    assert_eq!(servo9, Some(1900));
    h.run_for(3.0);
    assert!(
        h.sim.world().truth().speed_mps.abs() < 0.01,
        "holds at the end (MIS_DONE_BEHAVE 0)"
    );
    let current = h.received.iter().rev().find_map(|o| match &o.message {
        MavMessage::MISSION_CURRENT(c) => Some(c.clone()),
        _ => None,
    });
    let current = current.expect("MISSION_CURRENT streamed");
    assert_eq!(current.total, 12);
    assert_eq!(current.mission_state, MissionState::MISSION_STATE_COMPLETE);
    assert_eq!(current.mission_id, mission().opaque_id());
}

#[test]
fn hold_then_auto_resumes_the_current_leg() {
    let mut h = Harness::new(3, ModelKind::Ackermann);
    h.sim.core_mut().load_plan(MissionType::Mission, mission());
    h.run_for(2.0);
    h.arm();
    h.set_mode(10);
    h.run_until(60.0, |s| s.core().mission_current_seq() == 5);
    h.set_mode(4);
    h.run_for(5.0);
    assert_eq!(h.sim.core().mission_current_seq(), 5);
    h.set_mode(10);
    h.run_until(60.0, |s| s.core().mission_current_seq() > 5);
    let r = reached(&h);
    assert_eq!(&r[..2], &[2, 5], "resumed at #5, not restarted: {r:?}");
}

#[test]
fn auto_without_a_mission_is_refused_and_mission_start_works() {
    let mut h = Harness::new(1, ModelKind::Ackermann);
    h.run_for(2.0);
    h.set_mode(10);
    h.step();
    assert_eq!(h.acks(MavCmd::MAV_CMD_DO_SET_MODE), vec![MavResult::MAV_RESULT_FAILED]);
    assert!(h.texts().iter().any(|t| t.contains("no mission")));
    h.sim.core_mut().load_plan(MissionType::Mission, mission());
    h.command(MavCmd::MAV_CMD_MISSION_START, [0.0; 7]);
    h.step();
    assert_eq!(
        h.acks(MavCmd::MAV_CMD_MISSION_START),
        vec![MavResult::MAV_RESULT_ACCEPTED]
    );
    assert_eq!(h.sim.core().mode(), Mode::Auto);
}

#[test]
fn set_current_jumps_ahead() {
    let mut h = Harness::new(1, ModelKind::Ackermann);
    h.sim.core_mut().load_plan(MissionType::Mission, mission());
    h.run_for(2.0);
    h.command(
        MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT,
        [10.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    );
    h.command(
        MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT,
        [99.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    );
    h.step();
    assert_eq!(
        h.acks(MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT),
        vec![MavResult::MAV_RESULT_ACCEPTED, MavResult::MAV_RESULT_DENIED]
    );
    assert_eq!(h.sim.core().mission_current_seq(), 10);
}

/// A loop whose last corner is sharper than the legs leave room to round
/// (135° onto a 14 m leg into the final stop): the stop at home is still
/// reached within tolerance and reported, as pymavlink's DO_JUMP test sees.
#[test]
fn a_stop_after_a_corner_too_sharp_to_round_is_still_reached() {
    let items = vec![
        wp(0, 0.0, 0.0, 0.0),
        wp(1, 10.0, 0.0, 0.0),
        wp(2, 10.0, 9.7, 0.0),
        do_item(3, cmd::DO_JUMP, [1.0, 2.0, 0.0, 0.0]),
        wp(4, 0.0, 0.0, 0.0),
    ];
    let mut h = Harness::new(4, ModelKind::Ackermann);
    h.sim
        .core_mut()
        .load_plan(MissionType::Mission, Plan::new(MissionType::Mission, items));
    h.run_for(2.0);
    h.arm();
    h.set_mode(10);
    let done = h.run_until(600.0, |s| s.core().mission_state() == ExecState::Complete);
    let texts = h.texts();
    assert!(done, "mission did not complete: {texts:?}");
    assert_eq!(reached(&h), vec![1, 2, 1, 2, 1, 2, 4], "{texts:?}");
}
