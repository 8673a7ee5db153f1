//! The simulated LMS1xx in the SITL world: geometry, occlusion, mounting,
//! noise and dropouts, determinism.

use std::f64::consts::{FRAC_PI_2, PI};
use std::time::Duration;

use drivers::scanner::Scan;
use sim::{GnssSimConfig, MovingObstacle, ObstacleWorld, Shape, SimScannerConfig, VehicleOutline, World, WorldConfig};
use vehicle_types::ActuatorDemand;

const STEP: Duration = Duration::from_millis(20);

fn world_at(home_heading_deg: f64, seed: u64) -> World {
    let config = WorldConfig {
        home_heading_deg,
        gnss: GnssSimConfig {
            enabled: false,
            ..GnssSimConfig::default()
        },
        ..WorldConfig::default()
    };
    World::new(config, seed)
}

fn scanners_in(world: &mut World, obstacles: ObstacleWorld, scanners: Vec<SimScannerConfig>) {
    world.set_obstacles(Some(obstacles));
    world.set_scanners(scanners);
}

/// Step at rest (or with `demand`) for `seconds`, collecting the scans.
fn run(world: &mut World, demand: ActuatorDemand, seconds: f64) -> Vec<(usize, Scan)> {
    let end = world.time() + Duration::from_secs_f64(seconds);
    let mut scans = Vec::new();
    while world.time() < end {
        world.step(STEP.min(end - world.time()), &demand);
        world.take_scans(&mut scans);
    }
    scans
}

fn quiet(config: SimScannerConfig) -> SimScannerConfig {
    SimScannerConfig {
        dropout_probability: 0.0,
        ..config
    }
}

fn line(from: [f64; 2], to: [f64; 2]) -> Shape {
    Shape::Wall {
        from,
        to,
        thickness_m: 0.0,
    }
}

fn post(center: [f64; 2], radius_m: f64) -> Shape {
    Shape::Circle { center, radius_m }
}

/// World points of a scan's returns, by the scanner-to-world transform
/// (scanner.rs): the beam's world bearing is vehicle yaw + mount yaw + angle.
fn world_points(world: &World, config: &SimScannerConfig, scan: &Scan) -> Vec<[f64; 2]> {
    let truth = world.truth();
    let (sin, cos) = truth.yaw_rad.sin_cos();
    let origin = [
        truth.north_m + config.mount_x_m * cos - config.mount_y_m * sin,
        truth.east_m + config.mount_x_m * sin + config.mount_y_m * cos,
    ];
    scan.returns()
        .map(|(angle_rad, range_m)| {
            let bearing = truth.yaw_rad + config.mount_yaw_rad + angle_rad;
            [origin[0] + range_m * bearing.cos(), origin[1] + range_m * bearing.sin()]
        })
        .collect()
}

#[test]
fn a_wall_five_metres_ahead_reads_five_over_cos_along_the_expected_beams() {
    let config = quiet(SimScannerConfig::default());
    let mut world = world_at(0.0, 11);
    // The scanner sits 3.6 m ahead of the reference point at home: the wall
    // is 5 m ahead of the scanner, 60 m long.
    scanners_in(
        &mut world,
        ObstacleWorld::new(vec![line([8.6, -30.0], [8.6, 30.0])], Vec::new()),
        vec![config.clone()],
    );
    let scans = run(&mut world, ActuatorDemand::STOP, 1.0);
    assert_eq!(scans.len(), 51, "0 to 1 s at 50 Hz, both ends included");
    let mut residuals = Vec::new();
    for (k, (index, scan)) in scans.iter().enumerate() {
        assert_eq!(*index, 0);
        assert_eq!(scan.t, STEP * k as u32);
        assert_eq!(scan.scan_counter, k as u32);
        assert_eq!(scan.ranges_m.len(), 541);
        assert!((scan.start_angle_rad + 135f64.to_radians()).abs() < 1e-12);
        assert!((scan.step_rad - 0.5f64.to_radians()).abs() < 1e-12);
        for (beam, range_m) in scan.ranges_m.iter().enumerate() {
            let angle = scan.angle_rad(beam);
            let expected_m = 5.0 / angle.cos();
            // The wall's ends are 80.5° out; range runs out at 75.5°.
            let visible = angle.abs() < FRAC_PI_2 && expected_m <= 20.0 && angle.abs() < 80f64.to_radians();
            if visible {
                let residual = f64::from(*range_m) - expected_m;
                assert!(
                    residual.abs() < 0.06,
                    "beam {beam} at {angle}: {range_m} vs {expected_m}"
                );
                residuals.push(residual);
            } else if angle.abs() > 76f64.to_radians() {
                assert!(range_m.is_nan(), "beam {beam} at {angle}: {range_m}");
            }
        }
    }
    let n = residuals.len() as f64;
    let mean = residuals.iter().sum::<f64>() / n;
    let sigma = (residuals.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n).sqrt();
    assert!(residuals.len() > 50 * 290, "{}", residuals.len());
    assert!(mean.abs() < 0.001, "bias {mean}");
    assert!((sigma - 0.01).abs() < 0.001, "σ {sigma}");
}

#[test]
fn a_post_is_seen_at_its_bearing_and_range() {
    let config = SimScannerConfig {
        range_sigma_m: 0.0,
        ..quiet(SimScannerConfig::default())
    };
    // Vehicle heading 30°; a post 8 m from the scanner, 40° to its right.
    let mut world = world_at(30.0, 5);
    let scanner = [3.6 * 30f64.to_radians().cos(), 3.6 * 30f64.to_radians().sin()];
    let bearing = 70f64.to_radians();
    let center = [scanner[0] + 8.0 * bearing.cos(), scanner[1] + 8.0 * bearing.sin()];
    scanners_in(
        &mut world,
        ObstacleWorld::new(vec![post(center, 0.3)], Vec::new()),
        vec![config],
    );
    let scans = run(&mut world, ActuatorDemand::STOP, 0.1);
    let scan = &scans.last().unwrap().1;
    let returns: Vec<(f64, f64)> = scan.returns().collect();
    // 0.6 m at 8 m subtends 4.3°: 8 or 9 beams.
    assert!((8..=9).contains(&returns.len()), "{returns:?}");
    let (nearest_angle, nearest_m) = returns.iter().copied().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    assert!((nearest_angle - 40f64.to_radians()).abs() <= 0.25f64.to_radians() + 1e-9);
    assert!((nearest_m - 7.7).abs() < 0.005, "{nearest_m}");
    let mean_angle = returns.iter().map(|r| r.0).sum::<f64>() / returns.len() as f64;
    assert!(
        (mean_angle - 40f64.to_radians()).abs() < 0.3f64.to_radians(),
        "{mean_angle}"
    );
}

#[test]
fn a_person_behind_a_box_is_hidden_until_they_walk_out() {
    let config = quiet(SimScannerConfig::default());
    let mut world = world_at(0.0, 8);
    // Scanner at (3.6, 0). A 2 m wide box 4 m ahead of it; a person 8 m
    // ahead of it, right behind the box, who starts walking east at 1 s.
    let person = MovingObstacle {
        name: "hidden".to_owned(),
        shape: post([0.0, 0.0], 0.25),
        path: vec![[11.6, 0.0], [11.6, 4.0]],
        speed_mps: 1.0,
        start_s: 1.0,
        looped: false,
        vanish_at_end: false,
    };
    let truck = Shape::Box {
        center: [8.6, 0.0],
        length_m: 1.0,
        width_m: 2.0,
        yaw_rad: 0.0,
    };
    scanners_in(
        &mut world,
        ObstacleWorld::new(vec![truck], vec![person]),
        vec![config.clone()],
    );
    let mut hidden_scans = 0;
    let mut seen_scans = 0;
    let scans = run(&mut world, ActuatorDemand::STOP, 5.0);
    // Each scan against where the person really was at that instant.
    for (_, scan) in &scans {
        let t_s = scan.t.as_secs_f64();
        let (at, _) = world.obstacles().unwrap().mover_state(0, t_s).unwrap();
        let on_person = world_points(&world, &config, scan)
            .iter()
            .filter(|p| ((p[0] - at[0]).hypot(p[1] - at[1]) - 0.25).abs() < 0.05)
            .count();
        // The box's edge is at east 1; seen from (3.6, 0) it hides east < 1.6
        // at north 11.6, and the person's far edge clears it once at > 1.85.
        if at[1] + 0.25 < 1.6 {
            assert_eq!(on_person, 0, "t {t_s}: person at {at:?} should be hidden");
            hidden_scans += 1;
        } else if at[1] > 1.85 + 0.25 {
            assert!(on_person >= 2, "t {t_s}: person at {at:?} seen by {on_person} beams");
            seen_scans += 1;
        }
    }
    assert!(hidden_scans > 50 && seen_scans > 50, "{hidden_scans} {seen_scans}");
}

#[test]
fn the_mount_offset_and_yaw_place_the_scan_on_the_obstacles() {
    // A rear scanner, facing backwards and 0.4 m right of the centre line.
    let rear = SimScannerConfig {
        mount_x_m: -0.8,
        mount_y_m: 0.4,
        mount_yaw_rad: PI,
        range_sigma_m: 0.0,
        ..quiet(SimScannerConfig::default())
    };
    // Vehicle at home heading east: the scanner is at (−0.4, −0.8) looking west.
    let mut world = world_at(90.0, 2);
    let behind = post([-0.4, -6.8], 0.2);
    let left_rear = post([4.6, -3.8], 0.2);
    let ahead = post([-0.4, 8.0], 0.2);
    scanners_in(
        &mut world,
        ObstacleWorld::new(vec![behind.clone(), left_rear, ahead], Vec::new()),
        vec![rear.clone()],
    );
    let scans = run(&mut world, ActuatorDemand::STOP, 0.1);
    let scan = &scans.last().unwrap().1;
    let returns: Vec<(f64, f64)> = scan.returns().collect();
    let near = |angle_deg: f64| {
        returns
            .iter()
            .filter(|r| (r.0 - angle_deg.to_radians()).abs() < 3f64.to_radians())
            .map(|r| r.1)
            .fold(f64::INFINITY, f64::min)
    };
    // Dead behind the vehicle = straight ahead of the scanner, 6 m less the radius.
    assert!((near(0.0) - 5.8).abs() < 1e-3, "{}", near(0.0));
    // 5 m north and 3 m west of the scanner: west is its forward axis, north
    // its right, so +atan(5/3) clockwise.
    let expected = (5f64).atan2(3.0).to_degrees();
    assert!((near(expected) - 34f64.sqrt() + 0.2).abs() < 0.01, "{}", near(expected));
    // The post ahead of the vehicle is behind the scanner: unseen.
    assert!(returns.iter().all(|r| r.0.abs() < FRAC_PI_2), "{returns:?}");
    // Every return lands on a post's outline.
    let on_posts = |scan: &Scan, world: &World| {
        for p in world_points(world, &rear, scan) {
            let on_a_post = [[-0.4, -6.8], [4.6, -3.8]]
                .iter()
                .any(|c: &[f64; 2]| ((p[0] - c[0]).hypot(p[1] - c[1]) - 0.2).abs() < 1e-4);
            assert!(on_a_post, "{p:?}");
        }
    };
    on_posts(scan, &world);
    // Drive on east: the scan follows the vehicle, the post behind recedes.
    let demand = ActuatorDemand::Ackermann {
        steering: 0.0,
        throttle: 0.25,
    };
    let scans = run(&mut world, demand, 2.0);
    let (_, last) = scans.last().unwrap();
    assert_eq!(last.t, world.time());
    let gone_m = world.truth().east_m;
    assert!(gone_m > 1.0, "{gone_m}");
    on_posts(last, &world);
    let behind_m = last.returns().filter(|r| r.0.abs() < 1e-9).map(|r| r.1).next().unwrap();
    assert!((behind_m - (5.8 + gone_m)).abs() < 1e-4, "{behind_m} after {gone_m}");
    assert!(behind.contains([-0.4, -6.8]));
}

#[test]
fn dropouts_come_at_the_configured_rate() {
    // A room 4 m round the scanner: every beam has an echo.
    let room = ObstacleWorld::new(
        vec![
            line([-1.0, -4.0], [9.0, -4.0]),
            line([9.0, -4.0], [9.0, 4.0]),
            line([9.0, 4.0], [-1.0, 4.0]),
            line([-1.0, 4.0], [-1.0, -4.0]),
        ],
        Vec::new(),
    );
    for (p, seconds) in [(0.02, 4.0), (0.002, 10.0), (0.0, 2.0)] {
        let mut world = world_at(0.0, 21);
        let config = SimScannerConfig {
            dropout_probability: p,
            ..SimScannerConfig::default()
        };
        scanners_in(&mut world, room.clone(), vec![config]);
        let scans = run(&mut world, ActuatorDemand::STOP, seconds);
        let beams: usize = scans.iter().map(|(_, s)| s.ranges_m.len()).sum();
        let dropped = scans
            .iter()
            .flat_map(|(_, s)| &s.ranges_m)
            .filter(|r| r.is_nan())
            .count();
        let expected = p * beams as f64;
        let sigma = (beams as f64 * p * (1.0 - p)).sqrt();
        assert!(
            (dropped as f64 - expected).abs() <= 5.0 * sigma,
            "p {p}: {dropped} of {beams}, expected {expected} ± {sigma}"
        );
        if p > 0.0 {
            assert!(dropped > 0);
        }
    }
}

fn bits(scans: &[(usize, Scan)]) -> Vec<(usize, Duration, u32, Vec<u32>)> {
    scans
        .iter()
        .map(|(i, s)| {
            (
                *i,
                s.t,
                s.scan_counter,
                s.ranges_m.iter().map(|r| r.to_bits()).collect(),
            )
        })
        .collect()
}

fn two_scanner_run(seed: u64, with_scanners: bool) -> (World, Vec<(usize, Scan)>, Vec<u8>) {
    let walker = MovingObstacle {
        name: "walker".to_owned(),
        shape: post([0.0, 0.0], 0.25),
        path: vec![[12.0, 5.0], [12.0, -5.0], [-6.0, -5.0]],
        speed_mps: 1.4,
        start_s: 0.5,
        looped: true,
        vanish_at_end: false,
    };
    let obstacles = ObstacleWorld::new(
        vec![
            line([-10.0, 6.0], [30.0, 6.0]),
            Shape::Polygon {
                points: vec![[-5.0, -3.0], [-4.0, -4.0], [-6.0, -4.5]],
            },
        ],
        vec![walker],
    );
    let mut world = World::new(WorldConfig::default(), seed);
    if with_scanners {
        let rear = SimScannerConfig {
            mount_x_m: -0.8,
            mount_yaw_rad: PI,
            rate_hz: 25.0,
            step_rad: 0.25f64.to_radians(),
            dropout_probability: 0.01,
            ..SimScannerConfig::default()
        };
        scanners_in(&mut world, obstacles, vec![SimScannerConfig::default(), rear]);
    }
    let demand = ActuatorDemand::Ackermann {
        steering: 0.2,
        throttle: 0.3,
    };
    let mut scans = Vec::new();
    let mut gnss = Vec::new();
    // Uneven steps: scans must land on their grid whatever the caller does.
    for k in 0..300u32 {
        world.step(Duration::from_micros(7_000 + 3_100 * u64::from(k % 5)), &demand);
        world.take_scans(&mut scans);
        world.take_gnss_bytes(&mut gnss);
    }
    (world, scans, gnss)
}

#[test]
fn the_same_seed_gives_the_same_scans_and_scanners_leave_the_rest_alone() {
    let (a, a_scans, a_gnss) = two_scanner_run(4, true);
    let (_, b_scans, b_gnss) = two_scanner_run(4, true);
    let (_, c_scans, _) = two_scanner_run(5, true);
    assert_eq!(bits(&a_scans), bits(&b_scans));
    assert_ne!(bits(&a_scans), bits(&c_scans), "another seed, other noise");
    assert_eq!(a_gnss, b_gnss);
    // Both scanners, each on its own grid and counter, in time order.
    let end = a.time();
    let front: Vec<&Scan> = a_scans.iter().filter(|(i, _)| *i == 0).map(|(_, s)| s).collect();
    let rear: Vec<&Scan> = a_scans.iter().filter(|(i, _)| *i == 1).map(|(_, s)| s).collect();
    assert_eq!(front.len() as u128, end.as_millis() / 20 + 1);
    assert_eq!(rear.len() as u128, end.as_millis() / 40 + 1);
    assert_eq!(rear[0].ranges_m.len(), 1081);
    for (k, s) in rear.iter().enumerate() {
        assert_eq!((s.t, s.scan_counter), (Duration::from_millis(40) * k as u32, k as u32));
    }
    assert!(a_scans.windows(2).all(|w| w[0].1.t <= w[1].1.t));
    assert!(front.iter().any(|s| s.returns().count() > 100));
    // Without scanners: the same truth and the same GNSS bytes to the bit.
    let (plain, no_scans, plain_gnss) = two_scanner_run(4, false);
    assert!(no_scans.is_empty());
    assert_eq!(plain.truth(), a.truth());
    assert!(plain_gnss == a_gnss, "scanners changed the GNSS stream");
    assert_eq!(plain.clearance_m(&VehicleOutline::default()), None);
}

#[test]
fn clearance_follows_the_true_pose() {
    let mut world = world_at(0.0, 1);
    // A wall across the road 10 m ahead of the front bumper (3.6 m ahead).
    world.set_obstacles(Some(ObstacleWorld::new(
        vec![line([13.6, -5.0], [13.6, 5.0])],
        Vec::new(),
    )));
    let outline = VehicleOutline::default();
    assert!((world.clearance_m(&outline).unwrap() - 10.0).abs() < 1e-9);
    let demand = ActuatorDemand::Ackermann {
        steering: 0.0,
        throttle: 0.5,
    };
    let mut last = f64::INFINITY;
    while world.truth().north_m < 12.0 {
        world.step(STEP, &demand);
        let clearance = world.clearance_m(&outline).unwrap();
        let expected = (10.0 - world.truth().north_m).max(0.0);
        assert!((clearance - expected).abs() < 1e-6, "{clearance} vs {expected}");
        assert!(clearance <= last);
        last = clearance;
    }
    assert_eq!(last, 0.0, "driven into the wall");
    assert!(world.scanner_configs().next().is_none());
    let mut scans = Vec::new();
    world.take_scans(&mut scans);
    assert!(scans.is_empty(), "no scanners fitted");
}
