//! Pure-rolling steering geometry and the rear electronic differential
//! (seed 002 §3, eq. 6–13), checked against the geometry itself, against the
//! seed's own (one-direction, magnitude) formulas, and against the SITL
//! vehicle.
//!
//! Sources: docs/references.md §Seed 002.

use std::f64::consts::FRAC_PI_2;
use std::time::Duration;

use autopilot::control::ackermann::{
    AckermannGeometry, curvature_from_steer, differential_wheel_speeds, front_wheel_angles, rear_speed_ratio,
    rear_wheel_speeds, steer_from_curvature,
};
use proptest::prelude::*;
use sim::{AckermannConfig, DifferentialConfig, GnssSimConfig, VehicleModel, World, WorldConfig};
use vehicle_types::ActuatorDemand;

fn geometry(wheelbase_m: f64, track_m: f64, e_left_m: f64, e_right_m: f64) -> AckermannGeometry {
    AckermannGeometry {
        kingpin_offset_left_m: e_left_m,
        kingpin_offset_right_m: e_right_m,
        ..AckermannGeometry::new(wheelbase_m, track_m)
    }
}

/// Where a wheel's axle line (through the kingpin at body (L, y), square to
/// the wheel) crosses the rear axle line x = 0: y + L/tan φ.
fn axle_crossing_y_m(wheelbase_m: f64, kingpin_y_m: f64, wheel_rad: f64) -> f64 {
    kingpin_y_m + wheelbase_m * wheel_rad.cos() / wheel_rad.sin()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// All four wheels roll about one point: the rear wheels' axle is the
    /// rear axle line, and both front axle lines cross it at the ICR, 1/κ
    /// to the right of the rear axle centre.
    #[test]
    fn all_wheel_axes_meet_at_the_instantaneous_centre(
        steer_rad in prop_oneof![-1.5f64..-0.001, 0.001f64..1.5],
        wheelbase_m in 0.3f64..5.0,
        track_m in 0.2f64..3.0,
        e_left in 0.0f64..0.15,
        e_right in 0.0f64..0.15,
    ) {
        let g = geometry(wheelbase_m, track_m, e_left * track_m, e_right * track_m);
        let a = front_wheel_angles(&g, steer_rad);
        let icr_y_m = 1.0 / curvature_from_steer(wheelbase_m, steer_rad);
        let left_y = -track_m / 2.0 + g.kingpin_offset_left_m;
        let right_y = track_m / 2.0 - g.kingpin_offset_right_m;
        let tolerance_m = 1e-9 * icr_y_m.abs().max(wheelbase_m);
        prop_assert!((axle_crossing_y_m(wheelbase_m, left_y, a.left_rad) - icr_y_m).abs() < tolerance_m);
        prop_assert!((axle_crossing_y_m(wheelbase_m, right_y, a.right_rad) - icr_y_m).abs() < tolerance_m);
        // The inner wheel turns more, both the same way as δ.
        let (inner, outer) = a.inner_outer_rad();
        prop_assert!(inner.abs() > outer.abs());
        prop_assert!(inner.signum() == steer_rad.signum() && outer.signum() == steer_rad.signum());
    }

    /// Mirror image: −δ gives the other wheel's angle, negated, and swaps
    /// the rear wheel speeds.
    #[test]
    fn left_and_right_turns_are_mirror_images(
        steer_rad in -1.5f64..1.5,
        wheelbase_m in 0.3f64..5.0,
        track_m in 0.2f64..3.0,
        e in 0.0f64..0.1,
        speed_mps in -3.0f64..3.0,
    ) {
        let g = geometry(wheelbase_m, track_m, e, e);
        let right = front_wheel_angles(&g, steer_rad);
        let left = front_wheel_angles(&g, -steer_rad);
        prop_assert!((left.left_rad + right.right_rad).abs() < 1e-12);
        prop_assert!((left.right_rad + right.left_rad).abs() < 1e-12);
        let v_right = rear_wheel_speeds(&g, steer_rad, speed_mps);
        let v_left = rear_wheel_speeds(&g, -steer_rad, speed_mps);
        let scale = 1e-12 * (1.0 + v_right.left_mps.abs());
        prop_assert!((v_left.left_mps - v_right.right_mps).abs() < scale);
        prop_assert!((v_left.right_mps - v_right.left_mps).abs() < scale);
    }

    /// The rear wheels' speed ratio is their radius ratio about the ICR
    /// (eq. 10–13), the rear axle centre moves at v, and each wheel's speed
    /// over its radius is the one yaw rate v·κ.
    #[test]
    fn rear_speeds_follow_the_radii(
        steer_rad in prop_oneof![-1.3f64..-0.001, 0.001f64..1.3],
        wheelbase_m in 0.3f64..5.0,
        track_m in 0.2f64..3.0,
        speed_mps in 0.1f64..4.0,
    ) {
        let g = AckermannGeometry::new(wheelbase_m, track_m);
        let icr_y_m = 1.0 / curvature_from_steer(wheelbase_m, steer_rad);
        // Signed distances from the ICR to the left and right rear wheels.
        let (left_r_m, right_r_m) = (icr_y_m + track_m / 2.0, icr_y_m - track_m / 2.0);
        let v = rear_wheel_speeds(&g, steer_rad, speed_mps);
        let ratio = rear_speed_ratio(&g, steer_rad);
        prop_assert!((ratio - right_r_m / left_r_m).abs() < 1e-9 * (1.0 + ratio.abs()));
        prop_assert!((v.right_mps / v.left_mps - ratio).abs() < 1e-9 * (1.0 + ratio.abs()));
        prop_assert!(((v.left_mps + v.right_mps) / 2.0 - speed_mps).abs() < 1e-9 * speed_mps);
        let yaw_rate = speed_mps / icr_y_m;
        prop_assert!((v.left_mps / left_r_m - yaw_rate).abs() < 1e-9 * (1.0 + yaw_rate.abs()));
        prop_assert!((v.right_mps / right_r_m - yaw_rate).abs() < 1e-9 * (1.0 + yaw_rate.abs()));
    }
}

/// The seed's eq. 8 and 9 (right wheel from the left one, tan in
/// magnitudes) and eq. 12 and 13 (rear ratio from the left wheel), left and
/// right turns, with kingpin offsets.
#[test]
fn the_seed_equations_hold_once_given_signs() {
    let (l, w, e_l, e_r) = (0.87, 0.55, 0.04, 0.03);
    let g = geometry(l, w, e_l, e_r);
    for k in 1..=80 {
        let delta = f64::from(k) * 0.01;
        // Left turn: eq. 8 and 12 with t = tan φ_L > 0 (inner wheel).
        let a = front_wheel_angles(&g, -delta);
        let t = a.left_rad.abs().tan();
        let eq8 = (l * t / (l + (w - e_l - e_r) * t)).atan();
        assert!(
            (a.right_rad.abs() - eq8).abs() < 1e-12,
            "δ {delta}: {} vs eq. 8 {eq8}",
            a.right_rad
        );
        let eq12 = (l + (w - e_l) * t) / (l - e_l * t);
        assert!((rear_speed_ratio(&g, -delta) - eq12).abs() < 1e-9, "δ {delta}");
        // Right turn: eq. 9 and 13 with t = tan φ_L > 0 (outer wheel).
        let a = front_wheel_angles(&g, delta);
        let t = a.left_rad.tan();
        let eq9 = (l * t / (l - (w - e_r - e_l) * t)).atan();
        assert!(
            (a.right_rad - eq9).abs() < 1e-12,
            "δ {delta}: {} vs eq. 9 {eq9}",
            a.right_rad
        );
        let eq13 = (l - (w - e_l) * t) / (l + e_l * t);
        assert!((rear_speed_ratio(&g, delta) - eq13).abs() < 1e-9, "δ {delta}");
    }
}

#[test]
fn straight_ahead_is_zero_angles_and_equal_speeds() {
    let g = geometry(2.9, 1.6, 0.05, 0.05);
    let a = front_wheel_angles(&g, 0.0);
    assert_eq!((a.left_rad, a.right_rad), (0.0, 0.0));
    let v = rear_wheel_speeds(&g, 0.0, 1.5);
    assert_eq!((v.left_mps, v.right_mps), (1.5, 1.5));
    assert_eq!(rear_speed_ratio(&g, 0.0), 1.0);
    let v = differential_wheel_speeds(-0.7, 0.0, 0.6);
    assert_eq!((v.left_mps, v.right_mps), (-0.7, -0.7));
    assert_eq!(curvature_from_steer(2.9, 0.0), 0.0);
}

/// At ±90° the ICR is the rear axle centre: every axle line goes through it,
/// the inner front wheel is past 90°, the rear wheels turn opposite ways at
/// equal speeds; beyond, δ is clamped.
#[test]
fn full_lock_pivots_about_the_rear_axle_centre() {
    let (l, w) = (2.9, 1.6);
    let g = AckermannGeometry::new(l, w);
    let a = front_wheel_angles(&g, FRAC_PI_2);
    assert!((a.right_rad - l.atan2(-w / 2.0)).abs() < 1e-12, "inner {}", a.right_rad);
    assert!((a.left_rad - l.atan2(w / 2.0)).abs() < 1e-12, "outer {}", a.left_rad);
    assert!(a.right_rad > FRAC_PI_2 && a.left_rad < FRAC_PI_2);
    assert!((axle_crossing_y_m(l, w / 2.0, a.right_rad)).abs() < 1e-9);
    assert!((axle_crossing_y_m(l, -w / 2.0, a.left_rad)).abs() < 1e-9);
    assert!((rear_speed_ratio(&g, FRAC_PI_2) + 1.0).abs() < 1e-9);
    assert_eq!(front_wheel_angles(&g, 2.0), a);
    let b = front_wheel_angles(&g, -FRAC_PI_2);
    assert!((b.left_rad + a.right_rad).abs() < 1e-12);
    // Continuous on the way there (no tan blowing up at the inner wheel).
    let near = front_wheel_angles(&g, FRAC_PI_2 - 1e-9);
    assert!((near.right_rad - a.right_rad).abs() < 1e-6);
    // Where the ICR is under the inner wheel it turns 90° and the wheel stands.
    let under = steer_from_curvature(l, 2.0 / w);
    assert!((front_wheel_angles(&g, under).right_rad - FRAC_PI_2).abs() < 1e-12);
    assert!(rear_wheel_speeds(&g, under, 1.0).right_mps.abs() < 1e-12);
}

#[test]
fn curvature_and_steer_invert_each_other() {
    for k in -20..=20 {
        let steer_rad = f64::from(k) * 0.07;
        let back = steer_from_curvature(2.9, curvature_from_steer(2.9, steer_rad));
        assert!((back - steer_rad).abs() < 1e-12);
    }
}

fn quiet_world(vehicle: VehicleModel) -> World {
    let config = WorldConfig {
        vehicle,
        gnss: GnssSimConfig {
            enabled: false,
            ..GnssSimConfig::default()
        },
        ..WorldConfig::default()
    };
    World::new(config, 1)
}

/// The SITL Ackermann vehicle in a steady turn reports the rear wheel
/// speeds this module computes for its steering and speed.
#[test]
fn sitl_rear_wheels_agree() {
    let cfg = AckermannConfig::default();
    let mut world = quiet_world(VehicleModel::Ackermann(cfg));
    let demand = ActuatorDemand::Ackermann {
        steering: 0.5,
        throttle: 0.375,
    };
    for _ in 0..1000 {
        world.step(Duration::from_millis(10), &demand);
    }
    let truth = *world.truth();
    let g = AckermannGeometry::new(cfg.wheelbase_m, cfg.track_m);
    let v = rear_wheel_speeds(&g, truth.steer_rad, truth.speed_mps);
    assert!((truth.steer_rad - cfg.max_steer_rad / 2.0).abs() < 1e-9);
    assert!((v.left_mps - truth.left_mps).abs() < 1e-9 && (v.right_mps - truth.right_mps).abs() < 1e-9);
}

/// The SITL differential vehicle driven with the wheel speeds for a
/// curvature drives a circle of that curvature.
#[test]
fn sitl_differential_drives_the_curvature() {
    let cfg = DifferentialConfig::default();
    let mut world = quiet_world(VehicleModel::Differential(cfg));
    let curvature_1pm = 1.0 / 4.0;
    let v = differential_wheel_speeds(1.0, curvature_1pm, cfg.track_m).limited(cfg.wheel_speed_max_mps);
    let demand = ActuatorDemand::Differential {
        left: v.left_mps / cfg.wheel_speed_max_mps,
        right: v.right_mps / cfg.wheel_speed_max_mps,
    };
    for _ in 0..1000 {
        world.step(Duration::from_millis(10), &demand);
    }
    let truth = world.truth();
    assert!((truth.yaw_rate_rad_s / truth.speed_mps - curvature_1pm).abs() < 1e-9);
    assert!(truth.yaw_rate_rad_s > 0.0, "positive curvature turns right");
}
