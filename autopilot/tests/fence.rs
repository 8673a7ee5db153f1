//! Geofence and rally points in simulated time.

mod common;

use autopilot::modes::Mode;
use autopilot::sitl::simulation::ModelKind;
use common::Harness;
use mavlink::dialects::ardupilotmega::{MavCmd, MavResult};
use mission::command::{cmd, frame};
use mission::{MissionItem, MissionType, Plan};

fn local(seq: u16, command: u16, p1: f32, north_m: f64, east_m: f64) -> MissionItem {
    MissionItem {
        seq,
        frame: frame::LOCAL_NED,
        command,
        current: false,
        autocontinue: true,
        params: [p1, 0.0, 0.0, 0.0],
        x: (north_m * 1e4).round() as i32,
        y: (east_m * 1e4).round() as i32,
        z: 0.0,
    }
}

#[test]
fn leaving_an_inclusion_circle_triggers_rtl() {
    let mut h = Harness::new(1, ModelKind::Ackermann);
    let fence = Plan::new(
        MissionType::Fence,
        vec![local(0, cmd::NAV_FENCE_CIRCLE_INCLUSION, 20.0, 0.0, 0.0)],
    );
    h.sim.core_mut().load_plan(MissionType::Fence, fence);
    h.run_for(2.0);
    h.set_mode(15);
    h.arm();
    h.step();
    h.goto_local(40.0, 0.0);
    let rtl = h.run_until(60.0, |s| s.core().mode() == Mode::Rtl);
    assert!(rtl, "no fence action: {:?}", h.texts());
    let north = h.sim.world().truth().north_m;
    assert!(
        (19.0..24.0).contains(&north),
        "breached at {north:.1} m (fence 20 m, antenna lead)"
    );
    assert!(
        h.texts().iter().any(|t| t.starts_with("Fence breach")),
        "{:?}",
        h.texts()
    );
    assert!(h.run_until(120.0, |s| s.core().navigator().arrived()));
    assert!(h.distance_to(0.0, 0.0) < 2.0);
}

#[test]
fn arming_is_refused_inside_an_exclusion_zone() {
    let mut h = Harness::new(1, ModelKind::Ackermann);
    let fence = Plan::new(
        MissionType::Fence,
        vec![local(0, cmd::NAV_FENCE_CIRCLE_EXCLUSION, 5.0, 1.0, 0.0)],
    );
    h.sim.core_mut().load_plan(MissionType::Fence, fence);
    h.run_for(2.0);
    h.arm();
    h.step();
    assert_eq!(
        h.acks(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM),
        vec![MavResult::MAV_RESULT_FAILED]
    );
    assert!(
        h.texts()
            .iter()
            .any(|t| t == "PreArm: Vehicle inside an exclusion zone"),
        "{:?}",
        h.texts()
    );
    h.sim.core_mut().params_mut().set_by_name("FENCE_ENABLE", 0.0).unwrap();
    h.arm();
    h.step();
    assert!(h.sim.core().is_armed());
}

#[test]
fn rtl_goes_to_the_nearest_rally_point() {
    let mut h = Harness::new(1, ModelKind::Ackermann);
    let rally = Plan::new(
        MissionType::Rally,
        vec![
            local(0, cmd::NAV_RALLY_POINT, 0.0, 30.0, 10.0),
            local(1, cmd::NAV_RALLY_POINT, 0.0, -80.0, 0.0),
        ],
    );
    h.sim.core_mut().load_plan(MissionType::Rally, rally);
    h.run_for(2.0);
    h.set_mode(15);
    h.arm();
    h.step();
    h.goto_local(25.0, 0.0);
    h.run_until(60.0, |s| s.core().navigator().arrived());
    h.set_mode(11);
    assert!(h.run_until(120.0, |s| s.core().navigator().arrived()));
    h.run_for(2.0);
    assert!(
        h.distance_to(30.0, 10.0) < 2.0,
        "{:.2} m from the rally point",
        h.distance_to(30.0, 10.0)
    );
}
