use std::f64::consts::{PI, TAU};
use std::time::Duration;

use super::*;

const SUB_STEP: Duration = Duration::from_micros(2500);

fn bench() -> AckermannConfig {
    AckermannConfig::default()
}

/// Speeds after each sub-step while `demand` is held.
fn speed_trace(world: &mut World, demand: ActuatorDemand, seconds: f64) -> Vec<f64> {
    let steps = (seconds / SUB_STEP.as_secs_f64()).round() as usize;
    (0..steps)
        .map(|_| {
            world.step(SUB_STEP, &demand);
            world.truth().speed_mps
        })
        .collect()
}

fn max_rate(trace: &[f64], start: f64) -> f64 {
    let h = SUB_STEP.as_secs_f64();
    std::iter::once(start)
        .chain(trace.iter().copied())
        .collect::<Vec<_>>()
        .windows(2)
        .map(|w| (w[1] - w[0]).abs() / h)
        .fold(0.0, f64::max)
}

#[test]
fn straight_acceleration_is_limited_then_lags_into_the_command() {
    let mut world = quiet_world(VehicleModel::Ackermann(bench()), 0.0);
    let trace = speed_trace(&mut world, ackermann(0.0, 0.5), 12.0);
    assert!(max_rate(&trace, 0.0) <= 1.0 + 1e-9);
    // Slew at 1 m/s² until the lag asks for less (gap 1·0.3 m/s at 1.7 s)…
    let at = |t: f64| trace[(t / 0.0025).round() as usize - 1];
    assert!((at(1.0) - 1.0).abs() < 1e-9);
    assert!((at(1.7) - 1.7).abs() < 1e-9);
    // …then the first-order tail.
    assert!((at(2.6) - (2.0 - 0.3 * (-3.0f64).exp())).abs() < 1e-9);
    assert!((at(12.0) - 2.0).abs() < 1e-9);
    let truth = world.truth();
    assert_eq!((truth.east_m, truth.yaw_rad, truth.yaw_rate_rad_s), (0.0, 0.0, 0.0));
    // Distance: ½·1·1.7² on the ramp, then 2·t minus the tail's lag 0.3·0.3.
    let expected_m = 0.5 * 1.7 * 1.7 + 2.0 * (12.0 - 1.7) - 0.3 * 0.3;
    assert!((truth.north_m - expected_m).abs() < 1e-5, "{}", truth.north_m);
}

#[test]
fn braking_is_limited_by_brake_max() {
    let mut world = quiet_world(VehicleModel::Ackermann(bench()), 0.0);
    run(&mut world, ackermann(0.0, 1.0), 15.0, SUB_STEP);
    assert!((world.truth().speed_mps - 4.0).abs() < 1e-9);
    let trace = speed_trace(&mut world, ackermann(0.0, 0.0), 6.0);
    let peak = max_rate(&trace, 4.0);
    assert!(peak <= 2.0 + 1e-9 && peak > 2.0 - 1e-9, "{peak}");
    // Slew at 2 m/s² down to 0.6 m/s (1.7 s), then the lag.
    assert!((trace[679] - 0.6).abs() < 1e-9);
    assert!(trace.iter().all(|&v| v >= 0.0));
    assert!(trace[2399] < 1e-6);
}

#[test]
fn reversing_through_zero_brakes_then_accelerates() {
    let mut world = quiet_world(VehicleModel::Ackermann(bench()), 0.0);
    run(&mut world, ackermann(0.0, 0.5), 10.0, SUB_STEP);
    let trace = speed_trace(&mut world, ackermann(0.0, -0.5), 10.0);
    let zero = trace.iter().position(|&v| v <= 0.0).unwrap();
    assert!((zero as f64 * 0.0025 - 1.0).abs() < 0.003, "2 m/s at 2 m/s² takes 1 s");
    assert!(max_rate(&trace[..zero], 2.0) <= 2.0 + 1e-9);
    assert!(max_rate(&trace[zero + 1..], trace[zero]) <= 1.0 + 1e-9);
    assert!((trace.last().unwrap() + 2.0).abs() < 1e-6);
}

#[test]
fn steering_slews_at_most_at_its_rate() {
    let cfg = bench();
    let mut world = quiet_world(VehicleModel::Ackermann(cfg), 0.0);
    let demand = ackermann(1.0, 0.0);
    let mut steer = Vec::new();
    for _ in 0..800 {
        world.step(SUB_STEP, &demand);
        steer.push(world.truth().steer_rad);
    }
    let rate = max_rate(&steer, 0.0);
    assert!(rate <= cfg.steer_rate_rad_s + 1e-9);
    assert!(
        rate > cfg.steer_rate_rad_s - 1e-9,
        "a full-lock demand slews at the limit"
    );
    // 30° at 30°/s less the lag band: at 0.9 s it is still slewing.
    assert!((steer[359] - 0.9 * cfg.steer_rate_rad_s).abs() < 1e-9);
    assert!((steer[799] - cfg.max_steer_rad).abs() < 1e-5);
    // Beyond ±1 is clamped; NaN is centre.
    world.step(Duration::from_secs(5), &ackermann(7.0, 0.0));
    assert!((world.truth().steer_rad - cfg.max_steer_rad).abs() < 1e-9);
    world.step(Duration::from_secs(5), &ackermann(f64::NAN, 0.0));
    assert!(world.truth().steer_rad.abs() < 1e-9);
}

/// Centre of the circle the vehicle is on, for yaw rate `w` (right turn: to the right).
fn turn_centre(truth: &VehicleTruth, radius_m: f64) -> (f64, f64) {
    let side = truth.yaw_rate_rad_s.signum();
    (
        truth.north_m - side * radius_m * truth.yaw_rad.sin(),
        truth.east_m + side * radius_m * truth.yaw_rad.cos(),
    )
}

fn assert_on_circle(world: &mut World, demand: ActuatorDemand, radius_m: f64, seconds: f64) {
    let centre = turn_centre(world.truth(), radius_m);
    let mut worst_m: f64 = 0.0;
    let steps = (seconds / 0.01).round() as usize;
    for _ in 0..steps {
        world.step(Duration::from_millis(10), &demand);
        let t = world.truth();
        let r = (t.north_m - centre.0).hypot(t.east_m - centre.1);
        worst_m = worst_m.max((r - radius_m).abs());
    }
    assert!(worst_m < 1e-3, "radius off by {worst_m} m");
}

#[test]
fn steady_turn_radius_is_wheelbase_over_tan_steer() {
    let cfg = bench();
    for (steering, turns_right) in [(1.0, true), (-0.5, false)] {
        let mut world = quiet_world(VehicleModel::Ackermann(cfg), 37.0);
        let demand = ackermann(steering, 0.25);
        run(&mut world, demand, 20.0, Duration::from_millis(20));
        let steer = steering * cfg.max_steer_rad;
        assert!((world.truth().steer_rad - steer).abs() < 1e-12);
        assert_eq!(world.truth().yaw_rate_rad_s > 0.0, turns_right);
        let radius_m = cfg.wheelbase_m / steer.tan().abs();
        assert_on_circle(&mut world, demand, radius_m, 40.0);
    }
}

#[test]
fn a_full_circle_closes() {
    let cfg = bench();
    let mut world = quiet_world(VehicleModel::Ackermann(cfg), -100.0);
    let demand = ackermann(0.8, 0.5);
    run(&mut world, demand, 15.0, Duration::from_millis(20));
    let start = *world.truth();
    let radius_m = cfg.wheelbase_m / (0.8 * cfg.max_steer_rad).tan();
    let period = Duration::from_secs_f64(TAU * radius_m / start.speed_mps);
    // Odd step sizes, so sub-steps do not line up with the start.
    run(&mut world, demand, period.as_secs_f64(), Duration::from_micros(7_300));
    let end = world.truth();
    let gap_m = (end.north_m - start.north_m).hypot(end.east_m - start.east_m);
    assert!(gap_m < 1e-3, "circle opens by {gap_m} m");
    let yaw_gap = (end.yaw_rad - start.yaw_rad + PI).rem_euclid(TAU) - PI;
    assert!(yaw_gap.abs() < 1e-6, "{yaw_gap}");
    assert!((-PI..PI).contains(&end.yaw_rad));
}

#[test]
fn reverse_moves_backwards_with_heading_unchanged() {
    let mut world = quiet_world(VehicleModel::Ackermann(bench()), 120.0);
    let yaw = world.truth().yaw_rad;
    run(&mut world, ackermann(0.0, -0.25), 5.0, Duration::from_millis(20));
    let t = world.truth();
    assert!(t.speed_mps < -0.9);
    assert_eq!(t.yaw_rad, yaw);
    let along = t.north_m * yaw.cos() + t.east_m * yaw.sin();
    let across = -t.north_m * yaw.sin() + t.east_m * yaw.cos();
    assert!(along < -3.0, "{along}");
    assert!(across.abs() < 1e-9);
    // Reversing while steering right turns the nose left (yaw decreases).
    run(&mut world, ackermann(1.0, -0.25), 1.0, Duration::from_millis(20));
    assert!(world.truth().yaw_rate_rad_s < 0.0);
}

#[test]
fn differential_turns_towards_the_slower_wheel_on_the_right_radius() {
    let cfg = DifferentialConfig::default();
    for (left, right) in [(0.5, 0.25), (0.2, 0.6)] {
        let mut world = quiet_world(VehicleModel::Differential(cfg), 10.0);
        let demand = ActuatorDemand::Differential { left, right };
        run(&mut world, demand, 10.0, Duration::from_millis(20));
        let (l, r) = (left * cfg.wheel_speed_max_mps, right * cfg.wheel_speed_max_mps);
        let t = *world.truth();
        assert!((t.left_mps - l).abs() < 1e-9 && (t.right_mps - r).abs() < 1e-9);
        assert_eq!(t.yaw_rate_rad_s > 0.0, left > right, "left faster turns right");
        assert!((t.yaw_rate_rad_s - (l - r) / cfg.track_m).abs() < 1e-9);
        let radius_m = (cfg.track_m / 2.0 * (l + r) / (l - r)).abs();
        assert_on_circle(&mut world, demand, radius_m, 20.0);
    }
}

#[test]
fn differential_spins_on_the_spot() {
    let mut world = quiet_world(VehicleModel::Differential(DifferentialConfig::default()), 0.0);
    run(
        &mut world,
        ActuatorDemand::Differential { left: 0.5, right: -0.5 },
        3.0,
        SUB_STEP,
    );
    let t = world.truth();
    assert!(t.north_m.abs() < 1e-12 && t.east_m.abs() < 1e-12);
    assert!(t.yaw_rate_rad_s > 3.0 && t.speed_mps.abs() < 1e-12);
}

#[test]
fn model_change_keeps_pose_and_motion() {
    let mut world = quiet_world(VehicleModel::Ackermann(bench()), 45.0);
    run(&mut world, ackermann(0.3, 0.25), 8.0, Duration::from_millis(20));
    let before = *world.truth();
    world.set_vehicle_model(VehicleModel::Differential(DifferentialConfig::default()));
    let after = *world.truth();
    assert_eq!(
        (after.north_m, after.east_m, after.yaw_rad),
        (before.north_m, before.east_m, before.yaw_rad)
    );
    assert!((after.speed_mps - before.speed_mps).abs() < 1e-9);
    assert!((after.yaw_rate_rad_s - before.yaw_rate_rad_s).abs() < 1e-9);
    assert_eq!(after.steer_rad, 0.0);
    world.set_vehicle_model(VehicleModel::Ackermann(bench()));
    let back = *world.truth();
    assert!((back.steer_rad - before.steer_rad).abs() < 1e-9);
}
