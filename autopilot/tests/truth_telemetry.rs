//! What a ground station can check Furrow's accuracy with: LOCAL_POSITION_NED
//! (the estimate in float metres about the local origin) and, in SITL,
//! SIMSTATE (the simulator's true pose) and the true error beside each stop.

mod common;

use autopilot::geo::{GeoPoint, LocalFrame};
use autopilot::sitl::simulation::ModelKind;
use common::Harness;
use mavlink::dialects::ardupilotmega::MavMessage;

#[test]
fn local_position_and_simstate_agree_with_the_global_position_and_the_truth() {
    let mut h = Harness::new(3, ModelKind::Ackermann);
    h.run_for(2.0);
    h.set_mode(15);
    h.arm();
    h.goto_local(12.0, 4.0);
    h.run_for(8.0);
    h.received.clear();
    h.run_for(2.0);
    let origin = h.sim.core().estimator().frame().expect("a frame").origin();
    let (mut locals, mut globals, mut simstates) = (Vec::new(), Vec::new(), Vec::new());
    for o in &h.received {
        match &o.message {
            MavMessage::LOCAL_POSITION_NED(m) => locals.push(m.clone()),
            MavMessage::GLOBAL_POSITION_INT(m) => globals.push(m.clone()),
            MavMessage::SIMSTATE(m) => simstates.push(m.clone()),
            _ => {}
        }
    }
    assert!(
        locals.len() >= 6 && simstates.len() >= 6,
        "{} {}",
        locals.len(),
        simstates.len()
    );
    let tangent = LocalFrame::new(origin);
    let local = |lat_e7: i32, lon_e7: i32| tangent.to_local(&GeoPoint::from_e7(lat_e7, lon_e7, origin.alt_m));
    for g in &globals {
        let Some(l) = locals.iter().find(|l| l.time_boot_ms == g.time_boot_ms) else {
            panic!(
                "no LOCAL_POSITION_NED beside GLOBAL_POSITION_INT at {} ms",
                g.time_boot_ms
            );
        };
        let p = local(g.lat, g.lon);
        // Within half a 1e-7° step (5.6 mm north, 4.9 mm east here) and the
        // float's resolution at 10 m (1 µm).
        assert!((p.north_m - f64::from(l.x)).abs() < 0.006, "{} vs {}", p.north_m, l.x);
        assert!((p.east_m - f64::from(l.y)).abs() < 0.006, "{} vs {}", p.east_m, l.y);
        assert!((f64::from(g.vx) / 100.0 - f64::from(l.vx)).abs() <= 0.006);
    }
    // SIMSTATE is the simulator's pose: within a few cm of the estimate
    // while driving at 1e-7° resolution, and its yaw the true yaw.
    let truth = *h.sim.world().truth();
    let Some(MavMessage::SIMSTATE(last)) = h.sim.core().build_requested(164) else {
        panic!("no SIMSTATE in SITL");
    };
    let at = h.sim.world().truth_geodetic();
    assert!((f64::from(last.lat) * 1e-7 - at.lat_deg).abs() < 1e-7);
    assert!((f64::from(last.lng) * 1e-7 - at.lon_deg).abs() < 1e-7);
    assert!(
        (f64::from(last.yaw) - truth.yaw_rad).abs() < 0.01,
        "{} vs {}",
        last.yaw,
        truth.yaw_rad
    );
    assert!((f64::from(last.zacc) + 9.80665).abs() < 1e-3);
    for (g, s) in globals.iter().zip(&simstates) {
        let off_m = local(g.lat, g.lon).distance_to(&local(s.lat, s.lng));
        assert!(off_m < 0.1, "estimate {off_m:.3} m from the truth");
    }
}

#[test]
fn a_stop_reports_its_true_error_in_sitl() {
    let mut h = Harness::new(4, ModelKind::Differential);
    h.run_for(2.0);
    h.set_mode(15);
    h.arm();
    h.goto_local(10.0, 0.0);
    h.run_for(1.0);
    // The stop point as the core has it (the goto's 1e-7° steps from
    // (10, 0), in the core's frame), on the world's plane.
    let core = h.sim.core();
    let point = core.navigator().target().expect("a target").point;
    let point = core.estimator().frame().expect("a frame").to_geodetic(&point);
    let (point_north_m, point_east_m) = h.sim.world().geodetic_to_local(&point);
    assert!(h.run_until(60.0, |s| s.core().navigator().arrived()), "never arrived");
    h.run_for(12.0);
    let texts = h.texts();
    let stop = texts.iter().position(|t| t.starts_with("Stop")).expect("a stop report");
    let truth = texts[stop + 1..]
        .iter()
        .find(|t| t.starts_with("SITL truth: "))
        .unwrap_or_else(|| panic!("no true error after the stop: {texts:?}"));
    let mm: f64 = truth["SITL truth: ".len()..]
        .split(" mm")
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let reported = h.distance_to(point_north_m, point_east_m) * 1000.0;
    // The text was made when the vehicle came to rest; it has not moved since.
    assert!(
        (mm - reported).abs() < 0.2,
        "{truth} vs {reported:.2} mm from the point now"
    );
}
