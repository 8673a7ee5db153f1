//! GUIDED at any latitude: within metres of either pole, across the pole,
//! across the antimeridian and at 0°, 0°. Each run must reach its target
//! within `WP_RADIUS`, end its precision stop in tolerance, and see no EKF
//! rejection, reset or failsafe on the way.

mod common;

use autopilot::sitl::gcs;
use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};
use common::Harness;
use mavlink::dialects::ardupilotmega::MavMessage;
use vehicle_types::GeoPoint;

fn at(lat_deg: f64, lon_deg: f64, alt_m: f64) -> GeoPoint {
    GeoPoint {
        lat_deg,
        lon_deg,
        alt_m,
    }
}

/// A harness whose simulated vehicle starts at `home`, facing `heading_deg`
/// (in the home tangent plane).
fn harness_at(home: GeoPoint, heading_deg: f64) -> Harness {
    let mut h = Harness::new(1, ModelKind::Ackermann);
    let config = SimulationConfig {
        home,
        home_heading_deg: heading_deg,
        ..SimulationConfig::default()
    };
    h.sim = Simulation::new(&config, SimulationParams::new(ModelKind::Ackermann));
    gcs::connect(&mut h.sim);
    h
}

/// What went wrong on a GUIDED goto to (`north_m`, `east_m`) of the home
/// tangent plane, if anything.
fn goto_problems(h: &mut Harness, north_m: f64, east_m: f64, limit_s: f64) -> Vec<String> {
    h.run_for(2.0);
    h.set_mode(15);
    h.arm();
    h.step();
    let mut problems = Vec::new();
    if !h.sim.core().is_armed() {
        problems.push("not armed".to_owned());
    }
    h.goto_local(north_m, east_m);
    let arrived = h.run_until(limit_s, |s| s.core().navigator().arrived());
    h.run_for(8.0);
    let error_m = h.distance_to(north_m, east_m);
    if !arrived {
        problems.push(format!("never arrived, {error_m:.2} m short"));
    }
    if error_m > 0.05 {
        problems.push(format!("ended {error_m:.3} m from the target"));
    }
    let texts = h.texts();
    let stops: Vec<&String> = texts.iter().filter(|t| t.starts_with("Stop")).collect();
    println!("({north_m}, {east_m}): truth {error_m:.4} m from the target, {stops:?}");
    for bad in ["rejected", "reset", "Failsafe", "OUT of tolerance", "unhealthy"] {
        problems.extend(texts.iter().filter(|t| t.contains(bad)).cloned());
    }
    if !texts
        .iter()
        .any(|t| t.starts_with("Stop") && t.contains("in tolerance"))
    {
        problems.push(format!("no stop in tolerance: {texts:?}"));
    }
    problems.extend(telemetry_problems(h));
    problems
}

/// GLOBAL_POSITION_INT must put the vehicle where it is: within 5 cm of the
/// simulated truth (the estimate's own error is millimetres).
fn telemetry_problems(h: &Harness) -> Vec<String> {
    let last = h.received.iter().rev().find_map(|o| match &o.message {
        MavMessage::GLOBAL_POSITION_INT(g) => Some(g.clone()),
        _ => None,
    });
    let Some(g) = last else {
        return vec!["no GLOBAL_POSITION_INT".to_owned()];
    };
    // At its reported altitude: 2.8 km below the plane, a point 200 m from
    // home would sit 9 cm sideways of it.
    let reported = at(
        f64::from(g.lat) * 1e-7,
        f64::from(g.lon) * 1e-7,
        f64::from(g.alt) * 1e-3,
    );
    let (north_m, east_m) = h.sim.world().geodetic_to_local(&reported);
    let error_m = h.distance_to(north_m, east_m);
    let mut problems = Vec::new();
    if error_m > 0.05 {
        problems.push(format!("GLOBAL_POSITION_INT {error_m:.3} m from the truth"));
    }
    // hdg is the true heading where the vehicle is, in centidegrees.
    let gap_deg = (f64::from(g.hdg) / 100.0 - true_heading_deg(h) + 180.0).rem_euclid(360.0) - 180.0;
    if gap_deg.abs() > 0.1 {
        problems.push(format!("GLOBAL_POSITION_INT.hdg {gap_deg:.3}° off the true heading"));
    }
    problems
}

/// The truth's heading from true north where it is, by central differences
/// in latitude/longitude over ±1 mm on the WGS-84 radii (no ECEF: not the
/// method under test).
fn true_heading_deg(h: &Harness) -> f64 {
    const STEP_M: f64 = 1e-3;
    const A_M: f64 = 6_378_137.0;
    const E2: f64 = 6.694_379_990_141_3e-3;
    let t = h.sim.world().truth();
    let (sin, cos) = t.yaw_rad.sin_cos();
    let world = h.sim.world();
    let ahead = world.local_to_geodetic(t.north_m + STEP_M * cos, t.east_m + STEP_M * sin);
    let behind = world.local_to_geodetic(t.north_m - STEP_M * cos, t.east_m - STEP_M * sin);
    let lat = ((ahead.lat_deg + behind.lat_deg) / 2.0).to_radians();
    let w2 = 1.0 - E2 * lat.sin().powi(2);
    let (meridian_m, normal_m) = (A_M * (1.0 - E2) / (w2 * w2.sqrt()), A_M / w2.sqrt());
    let dlon_deg = (ahead.lon_deg - behind.lon_deg + 180.0).rem_euclid(360.0) - 180.0;
    let north = meridian_m * (ahead.lat_deg - behind.lat_deg).to_radians();
    let east = normal_m * lat.cos() * dlon_deg.to_radians();
    east.atan2(north).to_degrees()
}

fn assert_goto(home: GeoPoint, heading_deg: f64, north_m: f64, east_m: f64, limit_s: f64) {
    let mut h = harness_at(home, heading_deg);
    let problems = goto_problems(&mut h, north_m, east_m, limit_s);
    assert!(problems.is_empty(), "{home:?} → ({north_m}, {east_m}): {problems:?}");
}

/// 0.001° of latitude from the pole is 111.7 m.
#[test]
fn a_30_m_goto_111_m_from_the_south_pole() {
    assert_goto(at(-89.999, 30.0, 2800.0), 90.0, 0.0, 30.0, 60.0);
}

#[test]
fn a_goto_across_the_south_pole() {
    // The pole is 111.7 m south of home; the target 88 m beyond it.
    assert_goto(at(-89.999, -120.0, 2800.0), 180.0, -200.0, 5.0, 200.0);
}

#[test]
fn home_at_the_north_pole() {
    assert_goto(at(90.0, 0.0, 10.0), 45.0, 20.0, 20.0, 60.0);
}

#[test]
fn a_30_m_goto_1_1_km_from_the_north_pole() {
    assert_goto(at(89.99, 45.0, 10.0), 90.0, 0.0, 30.0, 60.0);
}

#[test]
fn a_goto_across_the_antimeridian() {
    assert_goto(at(-17.8, 179.99985, 5.0), 90.0, 10.0, 30.0, 60.0);
}

#[test]
fn a_goto_across_the_equator_and_the_prime_meridian() {
    assert_goto(at(0.0, 0.0, 0.0), 225.0, -20.0, -20.0, 60.0);
}

#[test]
fn a_goto_across_the_antimeridian_550_m_from_the_north_pole() {
    // True north turns by 3° over the 30 m.
    assert_goto(at(89.995, 179.999, 0.0), 90.0, 0.0, 30.0, 60.0);
}

#[test]
fn the_haversine_frame_gives_way_to_the_tangent_plane_at_the_south_pole() {
    let mut h = harness_at(at(-89.999, -120.0, 2800.0), 180.0);
    h.sim.core_mut().params_mut().set_by_name("GEO_FRAME", 1.0).unwrap();
    let problems = goto_problems(&mut h, -200.0, 5.0, 200.0);
    assert!(problems.is_empty(), "{problems:?}");
    assert!(
        h.texts()
            .iter()
            .any(|t| t == "EKF: GEO_FRAME 1 unusable at a pole: tangent plane"),
        "{:?}",
        h.texts()
    );
}
