//! The navigation core through the whole vehicle, in simulated time: a
//! precision stop and its report, a GUIDED target behind the vehicle, and
//! the fix-quality policy (`GPS_FLOAT_ACT`, `GPS_SINGLE_ACT`).

mod common;

use autopilot::modes::Mode;
use autopilot::sitl::simulation::ModelKind;
use common::Harness;
use mavlink::dialects::ardupilotmega::MavMessage;

fn guided(seed: u64) -> Harness {
    let mut h = Harness::new(seed, ModelKind::Ackermann);
    h.run_for(3.0);
    h.set_mode(15);
    h.arm();
    h.step();
    assert_eq!(h.sim.core().mode(), Mode::Guided, "{:?}", h.texts());
    h
}

fn set(h: &mut Harness, name: &str, value: f64) {
    h.sim.core_mut().params_mut().set_by_name(name, value).expect(name);
}

#[test]
fn a_guided_stop_ends_within_tolerance_and_says_so() {
    let mut h = guided(2);
    h.goto_local(30.0, 0.0);
    assert!(h.run_until(120.0, |s| s.core().navigator().arrived()));
    let report = h
        .texts()
        .into_iter()
        .find(|t| t.starts_with("Stop:"))
        .expect("a stop report");
    assert!(report.contains("in tolerance"), "{report}");
    // The truth, not just the estimate: within a few centimetres (the GNSS
    // walk alone is 5 mm per axis), and at rest.
    assert!(h.distance_to(30.0, 0.0) < 0.03, "{:.4} m", h.distance_to(30.0, 0.0));
    assert!(h.sim.world().truth().speed_mps.abs() < 0.002);
}

#[test]
fn a_guided_target_just_behind_is_reached_in_reverse() {
    let mut h = guided(3);
    h.goto_local(-6.0, 0.0);
    let mut reversed = false;
    let arrived = h.run_until(60.0, |s| {
        reversed |= s.world().truth().speed_mps < -0.2;
        s.core().navigator().arrived()
    });
    assert!(
        arrived && reversed,
        "arrived {arrived}, reversed {reversed} {:?}",
        h.texts()
    );
    assert!(h.distance_to(-6.0, 0.0) < 0.03);
    let yaw = h.sim.world().truth().yaw_rad.to_degrees();
    assert!(yaw.abs() < 1.0, "still facing north: {yaw:.2}°");
}

#[test]
fn rtk_float_slows_down_and_a_single_fix_holds() {
    let mut h = guided(4);
    h.goto_local(200.0, 0.0);
    h.run_for(20.0);
    assert!(h.sim.world().truth().speed_mps > 1.5);

    set(&mut h, "SIM_GPS_QUALITY", 5.0);
    h.run_for(8.0);
    assert!(
        h.texts().iter().any(|t| t == "GPS: RTK fixed lost, now RTK float"),
        "{:?}",
        h.texts()
    );
    let speed = h.sim.world().truth().speed_mps;
    assert!(
        (0.3..=0.55).contains(&speed),
        "GPS_FLOAT_ACT 1 slows to 0.5 m/s: {speed:.2}"
    );
    assert_eq!(h.sim.core().mode(), Mode::Guided);

    set(&mut h, "SIM_GPS_QUALITY", 1.0);
    h.run_for(5.0);
    assert_eq!(h.sim.core().mode(), Mode::Hold, "{:?}", h.texts());
    assert!(h.texts().iter().any(|t| t == "GPS fix degraded: HOLD"));
    assert!(h.sim.world().truth().speed_mps.abs() < 0.05);
    let reports: Vec<f32> = h
        .received
        .iter()
        .filter_map(|o| match &o.message {
            MavMessage::EKF_STATUS_REPORT(r) => Some(r.pos_horiz_variance),
            _ => None,
        })
        .collect();
    assert!(
        reports.first().is_some_and(|v| *v < 0.5),
        "RTK fixed: green, {reports:?}"
    );
    assert!(
        reports.last().is_some_and(|v| *v > 0.8),
        "single: red (Mission Planner: > 0.8), {reports:?}"
    );

    // With both actions at "continue" a downgrade is only reported.
    let mut h = guided(5);
    set(&mut h, "GPS_FLOAT_ACT", 0.0);
    set(&mut h, "GPS_SINGLE_ACT", 0.0);
    h.goto_local(200.0, 0.0);
    h.run_for(10.0);
    set(&mut h, "SIM_GPS_QUALITY", 1.0);
    h.run_for(5.0);
    assert_eq!(h.sim.core().mode(), Mode::Guided, "{:?}", h.texts());
    assert!(h.sim.world().truth().speed_mps > 1.5);
    assert!(h.texts().iter().any(|t| t == "GPS: RTK fixed lost, now single"));
}
