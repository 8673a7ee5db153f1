//! Pose goals reached by manoeuvres, in simulated time through MAVLink: a
//! GUIDED goal behind and beside the vehicle, RTL facing away from home.
//! Poses are checked against the simulator's truth; every "Reached" claim
//! against the vehicle's own stop report and the truth. With the simulator's
//! default GNSS (a 5 mm wander per axis) the estimate cannot confirm 10 mm,
//! and the vehicle says it stopped there unconfirmed; with an RTK-grade one
//! it claims the stop, and the claim is true.

mod common;

use autopilot::geo::wrap_pi;
use autopilot::sitl::gcs;
use autopilot::sitl::simulation::ModelKind;
use common::Harness;

/// The true pose's error from (`north_m`, `east_m`, `yaw_deg`): metres,
/// degrees.
fn pose_error(h: &Harness, north_m: f64, east_m: f64, yaw_deg: Option<f64>) -> (f64, f64) {
    let t = h.sim.world().truth();
    let yaw = yaw_deg.map_or(0.0, |y| wrap_pi(t.yaw_rad - y.to_radians()).to_degrees());
    (h.distance_to(north_m, east_m), yaw)
}

fn guided(model: ModelKind, seed: u64) -> Harness {
    guided_with_walk(model, seed, None)
}

/// `walk_m`: the GNSS's slow wander, simulated and as the estimator models it.
fn guided_with_walk(model: ModelKind, seed: u64, walk_m: Option<f64>) -> Harness {
    let mut h = Harness::new(seed, model);
    if let Some(walk_m) = walk_m {
        for name in ["SIM_GPS_WALK", "EKF_GPS_WALK"] {
            h.sim.core_mut().params_mut().set_by_name(name, walk_m).unwrap();
        }
    }
    h.run_for(5.0);
    h.set_mode(15);
    h.arm();
    h.step();
    assert!(h.sim.core().is_armed(), "{:?}", h.texts());
    h
}

/// Sends the goal and waits for the GUIDED/RTL verdict.
fn wait_for_verdict(h: &mut Harness, seconds: f64) -> String {
    let done = |t: &String| {
        ["Reached destination", "Destination NOT reached", "Stopped at"]
            .iter()
            .any(|v| t.starts_with(v))
    };
    let before = h.texts().len();
    let mut verdict = None;
    h.run_until(seconds, |_| false);
    for t in h.texts().into_iter().skip(before) {
        if done(&t) {
            verdict = Some(t);
        }
    }
    verdict.unwrap_or_else(|| panic!("no verdict: {:?}", h.texts()))
}

fn direction_changes(texts: &[String]) -> Vec<String> {
    texts.iter().filter(|t| t.starts_with("Manoeuvre")).cloned().collect()
}

/// The verdict is honest: "Reached" (or, where the estimate's σ cannot
/// confirm the tolerance, "Stopped at … unconfirmed") only after an
/// in-tolerance stop report (the estimate's view); the truth is within the
/// GNSS walk of it, and within the tolerance (10 mm, 0.05°) for a claim.
fn check_reached(h: &Harness, verdict: &str, north: f64, east: f64, yaw_deg: Option<f64>) {
    let texts = h.texts();
    let claimed = verdict.starts_with("Reached destination");
    assert!(
        claimed || (verdict.starts_with("Stopped at") && verdict.contains("unconfirmed")),
        "{texts:?}"
    );
    let last_stop = texts
        .iter()
        .rev()
        .find(|t| t.starts_with("Stop:") || t.starts_with("Stop #"))
        .expect("a stop report");
    assert!(last_stop.contains("in tolerance"), "{texts:?}");
    let (m, deg) = pose_error(h, north, east, yaw_deg);
    assert!(m < 0.03 && deg.abs() < 0.1, "truth {:.1} mm, {deg:.3}°", m * 1000.0);
    if claimed {
        assert!(
            m <= 0.010 && deg.abs() <= 0.05,
            "false claim: truth {:.1} mm, {deg:.3}°: {texts:?}",
            m * 1000.0
        );
    }
    let changes: Vec<usize> = direction_changes(&texts)
        .iter()
        .filter_map(|t| t.split(", ").nth(1)?.split(' ').next()?.parse::<usize>().ok())
        .collect();
    // Each manoeuvre keeps to MNV_DIR_MAX; a miss is retried once (a stop
    // just out of tolerance, e.g. 0.052° against 0.05°, costs a retry and
    // its changes of direction: the bench counts those).
    let retries = texts.iter().filter(|t| t.contains("trying again")).count();
    assert!(
        changes.iter().all(|&c| c <= 3) && retries <= 1,
        "{changes:?} direction changes, {retries} retries: {texts:?}"
    );
}

#[test]
fn guided_to_a_pose_behind_and_beside() {
    for (north, east, yaw) in [(-4.0, 1.5, 0.0), (1.0, 3.0, 0.0), (2.0, 5.0, 180.0)] {
        let mut h = guided(ModelKind::Ackermann, 1);
        let target = gcs::local_pose_target(&h.sim, north, east, yaw);
        h.send(target);
        let verdict = wait_for_verdict(&mut h, 180.0);
        check_reached(&h, &verdict, north, east, Some(yaw));
        assert_eq!(h.sim.core().mode(), autopilot::modes::Mode::Guided);
    }
}

#[test]
fn guided_beside_without_a_heading() {
    let mut h = guided(ModelKind::Ackermann, 2);
    h.goto_local(0.0, 6.0);
    let verdict = wait_for_verdict(&mut h, 180.0);
    check_reached(&h, &verdict, 0.0, 6.0, None);
}

#[test]
fn rtl_facing_away_returns_facing_the_way_it_left() {
    let mut h = guided(ModelKind::Ackermann, 3);
    // Home was set facing north; park 5 m east, 4 m north facing east.
    let target = gcs::local_pose_target(&h.sim, 4.0, 5.0, 90.0);
    h.send(target);
    let verdict = wait_for_verdict(&mut h, 180.0);
    check_reached(&h, &verdict, 4.0, 5.0, Some(90.0));
    h.received.clear();
    h.set_mode(11);
    let verdict = wait_for_verdict(&mut h, 180.0);
    assert!(verdict.contains("home"), "{verdict}");
    check_reached(&h, &verdict, 0.0, 0.0, Some(0.0));
}

/// With an RTK-grade receiver (1 mm wander) the estimate is sure enough to
/// claim 10 mm: a goal behind-beside and RTL from it are claimed, and the
/// truth agrees. The default receiver's stops are said to be unconfirmed.
#[test]
fn an_rtk_grade_fix_confirms_the_stop_and_the_default_one_does_not() {
    let mut h = guided_with_walk(ModelKind::Ackermann, 4, Some(0.001));
    let target = gcs::local_pose_target(&h.sim, -3.0, 2.0, 0.0);
    h.send(target);
    let verdict = wait_for_verdict(&mut h, 180.0);
    assert!(verdict.starts_with("Reached destination"), "{:?}", h.texts());
    check_reached(&h, &verdict, -3.0, 2.0, Some(0.0));
    h.received.clear();
    h.set_mode(11);
    let verdict = wait_for_verdict(&mut h, 180.0);
    assert_eq!(verdict, "Reached destination: home", "{:?}", h.texts());
    check_reached(&h, &verdict, 0.0, 0.0, Some(0.0));

    let mut h = guided(ModelKind::Ackermann, 4);
    let target = gcs::local_pose_target(&h.sim, -3.0, 2.0, 0.0);
    h.send(target);
    let verdict = wait_for_verdict(&mut h, 180.0);
    // The text goes out in 50-character STATUSTEXT chunks: this is the first.
    assert!(verdict.contains("unconfirmed"), "{:?}", h.texts());
    check_reached(&h, &verdict, -3.0, 2.0, Some(0.0));
}

/// Runs an AUTO mission of home and one stop at (`north`, `east`) m about
/// the estimator's origin facing `yaw_deg` to its end; gives the texts and
/// where that origin is in the world (LOCAL_NED items are about the first
/// fix, not the world's origin).
fn drive_stop_with_heading(h: &mut Harness, north: f64, east: f64, yaw_deg: f32) -> (Vec<String>, (f64, f64)) {
    use mission::command::{cmd, frame};
    use mission::{ExecState, MissionType, Plan};
    let items = vec![
        common::item(0, cmd::NAV_WAYPOINT, frame::LOCAL_NED, [0.0; 4], 0.0, 0.0),
        common::item(
            1,
            cmd::NAV_WAYPOINT,
            frame::LOCAL_NED,
            [0.0, 0.0, 0.0, yaw_deg],
            north,
            east,
        ),
    ];
    h.sim
        .core_mut()
        .load_plan(MissionType::Mission, Plan::new(MissionType::Mission, items));
    h.run_for(5.0);
    h.arm();
    h.set_mode(10);
    let done = h.run_until(240.0, |s| s.core().mission_state() == ExecState::Complete);
    let texts = h.texts();
    assert!(done, "{texts:?}");
    let origin = h.sim.core().estimator().frame().expect("a local frame").origin();
    let origin_local = h.sim.world().geodetic_to_local(&vehicle_types::GeoPoint {
        lat_deg: origin.lat_deg,
        lon_deg: origin.lon_deg,
        alt_m: 0.0,
    });
    (texts, origin_local)
}

/// AUTO: a mission stop with a heading (NAV_WAYPOINT param 4, 90° true)
/// beside-ahead of the vehicle is reached as a pose goal when `MNV_WP_YAW`
/// is set, and reported reached (MISSION_ITEM_REACHED) only by the stop on
/// that heading; without it the heading is ignored, as ArduPilot Rover does.
#[test]
fn a_mission_stop_with_a_heading_is_reached_facing_it() {
    for honour in [true, false] {
        let mut h = Harness::new(5, ModelKind::Ackermann);
        h.sim
            .core_mut()
            .params_mut()
            .set_by_name("MNV_WP_YAW", f64::from(u8::from(honour)))
            .unwrap();
        let (texts, (north, east)) = drive_stop_with_heading(&mut h, 10.0, 0.0, 90.0);
        let (m, yaw_deg) = pose_error(&h, north + 10.0, east, Some(if honour { 90.0 } else { 0.0 }));
        assert!(
            m < 0.03 && yaw_deg.abs() < 0.1,
            "honour {honour}: truth {:.1} mm, {yaw_deg:.3}°: {texts:?}",
            m * 1000.0
        );
        // A stop with a heading is claimed only when the estimate is sure
        // of it (GUIDED's rule); with the default GNSS's σ it may not be.
        let claimed = texts.iter().any(|t| t == "Reached waypoint #1");
        let unconfirmed = texts.iter().any(|t| t == "Waypoint #1 not claimed: stop unconfirmed");
        assert!(claimed || (honour && unconfirmed), "{texts:?}");
        let manoeuvres = texts.iter().filter(|t| t.starts_with("Manoeuvre")).count();
        assert_eq!(manoeuvres > 0, honour, "{texts:?}");
    }
}

/// A differential-drive vehicle with `MNV_PIVOT` 1 turns on the spot: beside, behind and a
/// heading change where it stands are a turn, a straight and a turn, with
/// no change of direction, each stop in tolerance by the truth's 3 cm and
/// 0.1° (the GNSS wander's share), and the turns shown in the manoeuvre
/// text.
#[test]
fn a_differential_vehicle_turns_on_the_spot() {
    for (north, east, yaw) in [(0.0, 3.0, 0.0), (-4.0, 0.0, 90.0), (0.0, 0.0, -120.0)] {
        let mut h = guided(ModelKind::Differential, 4);
        h.sim.core_mut().params_mut().set_by_name("MNV_PIVOT", 1.0).unwrap();
        let target = gcs::local_pose_target(&h.sim, north, east, yaw);
        h.send(target);
        let verdict = wait_for_verdict(&mut h, 120.0);
        check_reached(&h, &verdict, north, east, Some(yaw));
        let texts = h.texts();
        let plan = direction_changes(&texts);
        assert!(
            plan.first()
                .is_some_and(|t| t.contains(" 0 reversals") && !t.contains(" 0 pivots")),
            "{texts:?}"
        );
    }
}

/// AUTO waits for its verdict on a pose stop as GUIDED does: with an
/// RTK-grade receiver a differential vehicle that turned on the spot onto
/// the stop's heading (the estimate's σ is widest just after turning) is
/// claimed reached once the estimate is sure, within 8 s at rest, and the
/// truth agrees.
#[test]
fn an_auto_pose_stop_waits_for_the_estimate_and_is_claimed() {
    for (seed, north, east, yaw_deg) in [(7, 6.0, 0.0, 90.0), (8, 0.0, 3.0, 0.0)] {
        let mut h = Harness::new(seed, ModelKind::Differential);
        for (name, value) in [("SIM_GPS_WALK", 0.001), ("EKF_GPS_WALK", 0.001), ("MNV_WP_YAW", 1.0)] {
            h.sim.core_mut().params_mut().set_by_name(name, value).unwrap();
        }
        let (texts, (north0, east0)) = drive_stop_with_heading(&mut h, north, east, yaw_deg);
        let (m, deg) = pose_error(&h, north0 + north, east0 + east, Some(f64::from(yaw_deg)));
        assert!(
            texts.iter().any(|t| t == "Reached waypoint #1"),
            "seed {seed}: truth {:.1} mm, {deg:.3}°: {texts:?}",
            m * 1000.0
        );
        assert!(
            m <= 0.010 && deg.abs() <= 0.05,
            "seed {seed}: false claim: truth {:.1} mm, {deg:.3}°: {texts:?}",
            m * 1000.0
        );
    }
}

/// A stop out of tolerance by the estimate but within the estimate's own
/// doubt is not driven again: a differential vehicle stops on the point
/// 1 m away, turns on the spot onto the heading, which stirs the position
/// estimate up (the bench's seed 103: truth 8.5 mm, estimate 15 mm, σ
/// 10.5 mm; here, seed 125: truth 9.0 mm, estimate 11.0 mm; seed 126,
/// which this took before a stop was judged where it comes to rest, now
/// ends in tolerance), and retrying
/// that "miss" turned it to face a point 15 mm away, crept there and
/// turned back (16 s more, no nearer). Now it says it did not reach the
/// goal and why, with no retry and no claim. (Seed 103 here ended in
/// tolerance by the estimate once the turn stopped swinging past its
/// heading.)
#[test]
fn a_miss_within_the_estimates_doubt_is_not_driven_again() {
    let (north, east) = (-std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::FRAC_1_SQRT_2);
    let mut h = guided(ModelKind::Differential, 125);
    h.sim.core_mut().params_mut().set_by_name("MNV_PIVOT", 1.0).unwrap();
    h.sim.core_mut().params_mut().set_by_name("MNV_WP_YAW", 1.0).unwrap();
    let target = gcs::local_pose_target(&h.sim, north, east, 0.0);
    h.send(target);
    let verdict = wait_for_verdict(&mut h, 120.0);
    let texts = h.texts();
    assert!(!texts.iter().any(|t| t.contains("trying again")), "{texts:?}");
    // A long text goes out in 50-character chunks.
    let said = texts.concat();
    assert!(
        verdict.starts_with("Destination NOT reached")
            && said.contains("; no retry: the miss is within position sigma"),
        "{texts:?}"
    );
    let (m, deg) = pose_error(&h, north, east, Some(0.0));
    assert!(m < 0.03 && deg.abs() < 0.1, "truth {:.1} mm, {deg:.3}°", m * 1000.0);
}
