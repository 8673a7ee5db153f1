//! Tangent-bug detour round a static obstacle (seed 004 §III.D): side
//! choice, clearance of the path and of the body, corridor, refusals.
//!
//! Sources: docs/references.md §Seed 004.

use autopilot::geo::Ned;
use autopilot::obstacles::detour::{Detour, DetourConfig, DetourRefusal, Side, plan_detour};
use autopilot::obstacles::{Footprint, Pose};

const FOOTPRINT: Footprint = Footprint {
    front_m: 1.2,
    rear_m: 0.3,
    half_width_m: 0.4,
};
const CONFIG: DetourConfig = DetourConfig {
    clearance_m: 0.5,
    corridor_m: 3.0,
    min_turn_radius_m: 2.0,
};

/// The test's own leg frame (independent of the module's): along from
/// `from`, across positive to the right of travel.
struct Leg {
    from: Ned,
    heading_rad: f64,
    length_m: f64,
}

impl Leg {
    fn north(length_m: f64) -> Leg {
        Leg {
            from: Ned::new(0.0, 0.0),
            heading_rad: 0.0,
            length_m,
        }
    }

    fn to(&self) -> Ned {
        self.at(self.length_m, 0.0)
    }

    fn at(&self, along_m: f64, cross_m: f64) -> Ned {
        let (s, c) = self.heading_rad.sin_cos();
        Ned::new(
            self.from.north_m + along_m * c - cross_m * s,
            self.from.east_m + along_m * s + cross_m * c,
        )
    }

    fn along_cross(&self, p: &Ned) -> (f64, f64) {
        let (s, c) = self.heading_rad.sin_cos();
        let dn = p.north_m - self.from.north_m;
        let de = p.east_m - self.from.east_m;
        (dn * c + de * s, -dn * s + de * c)
    }

    fn start_pose(&self) -> Pose {
        Pose {
            position: self.from,
            yaw_rad: self.heading_rad,
        }
    }
}

/// The outline of a square, `size_m` a side, centred `along_m`/`cross_m` in
/// the leg frame, one point every 5 cm (a scanner would see only part of it).
fn square(leg: &Leg, along_m: f64, cross_m: f64, size_m: f64) -> Vec<Ned> {
    let per_side = (size_m / 0.05).round() as usize;
    let half = size_m / 2.0;
    let mut points = Vec::new();
    for k in 0..per_side {
        let t = -half + size_m * k as f64 / per_side as f64;
        points.push(leg.at(along_m + t, cross_m - half));
        points.push(leg.at(along_m + half, cross_m + t));
        points.push(leg.at(along_m - t, cross_m + half));
        points.push(leg.at(along_m - half, cross_m - t));
    }
    points
}

/// A line of points beside the leg, every 10 cm.
fn wall(leg: &Leg, cross_m: f64, from_along_m: f64, to_along_m: f64) -> Vec<Ned> {
    let count = ((to_along_m - from_along_m) / 0.1).round() as usize;
    (0..=count)
        .map(|k| leg.at(from_along_m + 0.1 * k as f64, cross_m))
        .collect()
}

fn plan(leg: &Leg, obstacle: &[Ned], others: &[Ned], config: &DetourConfig) -> Result<Detour, DetourRefusal> {
    plan_detour(
        leg.from,
        leg.to(),
        &leg.start_pose(),
        &FOOTPRINT,
        obstacle,
        others,
        config,
    )
}

fn point_segment_distance_m(p: &Ned, a: &Ned, b: &Ned) -> f64 {
    let (abn, abe) = (b.north_m - a.north_m, b.east_m - a.east_m);
    let length_sq = abn * abn + abe * abe;
    let t = if length_sq > 0.0 {
        (((p.north_m - a.north_m) * abn + (p.east_m - a.east_m) * abe) / length_sq).clamp(0.0, 1.0)
    } else {
        0.0
    };
    Ned::new(a.north_m + t * abn, a.east_m + t * abe).distance_to(p)
}

/// Reference-point poses every centimetre along the detour polyline, the
/// body heading along each segment.
fn sampled_poses(detour: &Detour) -> Vec<(Ned, f64)> {
    let mut poses = Vec::new();
    for pair in detour.waypoints.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let steps = (a.distance_to(&b) / 0.01).ceil().max(1.0) as usize;
        let heading_rad = a.bearing_to(&b);
        for k in 0..=steps {
            let t = k as f64 / steps as f64;
            let p = Ned::new(
                a.north_m + t * (b.north_m - a.north_m),
                a.east_m + t * (b.east_m - a.east_m),
            );
            poses.push((p, heading_rad));
        }
    }
    poses
}

/// Distance from `p` to the vehicle's rectangle with its rear axle at
/// `reference` heading `yaw_rad`.
fn body_distance_m(reference: &Ned, yaw_rad: f64, p: &Ned) -> f64 {
    let (s, c) = yaw_rad.sin_cos();
    let dn = p.north_m - reference.north_m;
    let de = p.east_m - reference.east_m;
    let x = dn * c + de * s;
    let y = -dn * s + de * c;
    let dx = (-FOOTPRINT.rear_m - x).max(x - FOOTPRINT.front_m).max(0.0);
    let dy = (y.abs() - FOOTPRINT.half_width_m).max(0.0);
    dx.hypot(dy)
}

/// The properties every returned detour must have, for `points` it must
/// clear (the obstacle, and the others).
fn assert_sound(leg: &Leg, detour: &Detour, obstacle: &[Ned], others: &[Ned], config: &DetourConfig) {
    assert_eq!(detour.waypoints.len(), 4, "{detour:?}");
    let (vehicle_along_m, _) = leg.along_cross(&leg.start_pose().position);
    let legs: Vec<(f64, f64)> = detour.waypoints.iter().map(|w| leg.along_cross(w)).collect();
    for (along_m, cross_m) in &legs {
        assert!(
            cross_m.abs() <= config.corridor_m + 1e-9,
            "waypoint outside the corridor: {legs:?}"
        );
        assert!(
            *along_m >= vehicle_along_m - 1e-9 && *along_m <= leg.length_m + 1e-9,
            "{legs:?}"
        );
        match detour.side {
            Side::Left => assert!(*cross_m <= 1e-9, "left detour right of the line: {legs:?}"),
            Side::Right => assert!(*cross_m >= -1e-9, "right detour left of the line: {legs:?}"),
        }
    }
    assert!(
        legs.windows(2).all(|w| w[1].0 >= w[0].0),
        "waypoints go backwards: {legs:?}"
    );
    assert!(
        legs[0].1.abs() < 1e-9 && legs[3].1.abs() < 1e-9,
        "must leave and rejoin on the line: {legs:?}"
    );
    let (rejoin_along_m, _) = legs[3];
    assert!((detour.rejoin_along_m - rejoin_along_m).abs() < 1e-9);
    assert!(detour.rejoin_along_m <= leg.length_m + 1e-9);
    let obstacle_far_m = obstacle
        .iter()
        .map(|p| leg.along_cross(p).0)
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(
        rejoin_along_m >= obstacle_far_m + FOOTPRINT.rear_m + config.clearance_m,
        "rejoins before the rear has passed: {rejoin_along_m} vs far face {obstacle_far_m}"
    );
    // Full offset before the front reaches the obstacle, held until the
    // rear has passed it.
    let obstacle_near_m = obstacle
        .iter()
        .map(|p| leg.along_cross(p).0)
        .fold(f64::INFINITY, f64::min);
    assert!(
        legs[1].0 + FOOTPRINT.front_m + config.clearance_m <= obstacle_near_m + 1e-9,
        "{legs:?}"
    );
    assert!(
        legs[2].0 - FOOTPRINT.rear_m - config.clearance_m >= obstacle_far_m - 1e-9,
        "{legs:?}"
    );
    let widest_m = legs.iter().map(|l| l.1.abs()).fold(0.0, f64::max);
    assert!((detour.max_offset_m - widest_m).abs() < 1e-9);

    // The reference path keeps half the width plus the clearance from the
    // obstacle (1 cm for the sampling)...
    let path_margin_m = FOOTPRINT.half_width_m + config.clearance_m - 0.01;
    for p in obstacle {
        for pair in detour.waypoints.windows(2) {
            let d = point_segment_distance_m(p, &pair[0], &pair[1]);
            assert!(d >= path_margin_m, "path {d:.3} m from obstacle point {p:?}");
        }
    }
    // ...and the body, driven along the polyline, keeps the clearance from
    // the obstacle and from every other point.
    for (reference, yaw_rad) in sampled_poses(detour) {
        for p in obstacle.iter().chain(others) {
            let d = body_distance_m(&reference, yaw_rad, p);
            assert!(
                d >= config.clearance_m - 0.01,
                "body {d:.3} m from {p:?} at {reference:?}"
            );
        }
    }
}

#[test]
fn box_right_of_the_line_is_passed_on_the_left() {
    let leg = Leg::north(30.0);
    let obstacle = square(&leg, 12.0, 0.3, 1.0);
    let detour = plan(&leg, &obstacle, &[], &CONFIG).expect("detour");
    assert_eq!(detour.side, Side::Left);
    assert_sound(&leg, &detour, &obstacle, &[], &CONFIG);
    // The left edge is at −0.2: half width + clearance beyond it.
    let expected_offset_m = 0.2 + FOOTPRINT.half_width_m + CONFIG.clearance_m;
    assert!(
        (detour.max_offset_m - expected_offset_m).abs() < 1e-9,
        "{}",
        detour.max_offset_m
    );
}

#[test]
fn box_left_of_the_line_is_passed_on_the_right() {
    let leg = Leg::north(30.0);
    let obstacle = square(&leg, 12.0, -0.3, 1.0);
    let detour = plan(&leg, &obstacle, &[], &CONFIG).expect("detour");
    assert_eq!(detour.side, Side::Right);
    assert_sound(&leg, &detour, &obstacle, &[], &CONFIG);
}

#[test]
fn sides_are_relative_to_the_direction_of_travel_on_any_heading() {
    for &heading_deg in &[37.0_f64, 90.0, 180.0, -123.0] {
        let leg = Leg {
            from: Ned::new(5.0, -3.0),
            heading_rad: heading_deg.to_radians(),
            length_m: 30.0,
        };
        let right_of_line = square(&leg, 14.0, 0.3, 1.0);
        let detour = plan(&leg, &right_of_line, &[], &CONFIG).expect("detour");
        assert_eq!(detour.side, Side::Left, "heading {heading_deg}");
        assert_sound(&leg, &detour, &right_of_line, &[], &CONFIG);
        let left_of_line = square(&leg, 14.0, -0.3, 1.0);
        let detour = plan(&leg, &left_of_line, &[], &CONFIG).expect("detour");
        assert_eq!(detour.side, Side::Right, "heading {heading_deg}");
        assert_sound(&leg, &detour, &left_of_line, &[], &CONFIG);
    }
}

#[test]
fn the_offset_is_taken_over_an_ackermann_run_in() {
    let leg = Leg::north(40.0);
    let obstacle = square(&leg, 15.0, 0.3, 1.0);
    let mut previous_run_m = 0.0;
    for &radius_m in &[0.5, 2.0, 4.0] {
        let config = DetourConfig {
            min_turn_radius_m: radius_m,
            ..CONFIG
        };
        let detour = plan(&leg, &obstacle, &[], &config).expect("detour");
        assert_sound(&leg, &detour, &obstacle, &[], &config);
        let along: Vec<f64> = detour.waypoints.iter().map(|w| leg.along_cross(w).0).collect();
        let needed_m = 2.0 * (detour.max_offset_m * radius_m).sqrt();
        let (run_in_m, run_out_m) = (along[1] - along[0], along[3] - along[2]);
        assert!(
            run_in_m >= needed_m - 1e-9 && run_out_m >= needed_m - 1e-9,
            "R {radius_m}: {along:?}"
        );
        // The full offset is reached before the front can reach the box.
        assert!(
            along[1] + FOOTPRINT.front_m + CONFIG.clearance_m <= 14.5 + 1e-9,
            "R {radius_m}: {along:?}"
        );
        assert!(run_in_m > previous_run_m, "a wider turn needs a longer run-in");
        previous_run_m = run_in_m;
    }
}

#[test]
fn a_wall_on_the_shorter_side_pushes_the_detour_to_the_other() {
    let leg = Leg::north(30.0);
    let obstacle = square(&leg, 12.0, 0.3, 1.0);
    let left_wall = wall(&leg, -1.6, 0.0, 30.0);
    let detour = plan(&leg, &obstacle, &left_wall, &CONFIG).expect("detour");
    assert_eq!(detour.side, Side::Right);
    assert_sound(&leg, &detour, &obstacle, &left_wall, &CONFIG);
}

#[test]
fn a_wall_only_beyond_the_detour_does_not_move_it() {
    let leg = Leg::north(30.0);
    let obstacle = square(&leg, 12.0, 0.3, 1.0);
    let unobstructed = plan(&leg, &obstacle, &[], &CONFIG).expect("detour");
    // Starts well after the rejoin point.
    let late_wall = wall(&leg, -1.6, unobstructed.rejoin_along_m + FOOTPRINT.front_m + 1.0, 30.0);
    let detour = plan(&leg, &obstacle, &late_wall, &CONFIG).expect("detour");
    assert_eq!(detour, unobstructed);
}

#[test]
fn a_single_point_in_the_swept_band_blocks_that_side() {
    let leg = Leg::north(30.0);
    let obstacle = square(&leg, 12.0, 0.3, 1.0);
    let unobstructed = plan(&leg, &obstacle, &[], &CONFIG).expect("detour");
    assert_eq!(unobstructed.side, Side::Left);
    // Abeam the box, beside the body's left side on the offset straight
    // (away from the S-bends, whose yawed body reaches further out): first
    // inside the clearance...
    let edge_m = unobstructed.max_offset_m + FOOTPRINT.half_width_m;
    let post = [leg.at(12.0, -(edge_m + CONFIG.clearance_m - 0.05))];
    let detour = plan(&leg, &obstacle, &post, &CONFIG).expect("detour");
    assert_eq!(detour.side, Side::Right);
    // ...then just outside it, which leaves the left side open.
    let post = [leg.at(12.0, -(edge_m + CONFIG.clearance_m + 0.05))];
    let detour = plan(&leg, &obstacle, &post, &CONFIG).expect("detour");
    assert_eq!(detour.side, Side::Left);
}

#[test]
fn a_point_on_either_s_bend_blocks_that_side() {
    let leg = Leg::north(30.0);
    let obstacle = square(&leg, 12.0, 0.3, 1.0);
    let unobstructed = plan(&leg, &obstacle, &[], &CONFIG).expect("detour");
    assert_eq!(unobstructed.side, Side::Left);
    let w = &unobstructed.waypoints;
    // Halfway along the turn away from the line and the turn back onto it:
    // where the reference point itself passes, clear of the straight.
    for (a, b) in [(w[0], w[1]), (w[2], w[3])] {
        let middle = Ned::new((a.north_m + b.north_m) / 2.0, (a.east_m + b.east_m) / 2.0);
        let detour = plan(&leg, &obstacle, &[middle], &CONFIG).expect("detour");
        assert_eq!(detour.side, Side::Right, "point at {middle:?}");
    }
}

#[test]
fn walls_on_both_sides_block_the_detour() {
    let leg = Leg::north(30.0);
    let obstacle = square(&leg, 12.0, 0.3, 1.0);
    let mut walls = wall(&leg, -1.6, 0.0, 30.0);
    walls.extend(wall(&leg, 1.6, 0.0, 30.0));
    assert_eq!(plan(&leg, &obstacle, &walls, &CONFIG), Err(DetourRefusal::Blocked));
}

#[test]
fn a_narrow_corridor_refuses() {
    let leg = Leg::north(30.0);
    let obstacle = square(&leg, 12.0, 0.3, 1.0);
    // The left detour needs 1.1 m, the right one 1.7 m.
    let narrow = DetourConfig {
        corridor_m: 1.0,
        ..CONFIG
    };
    assert_eq!(plan(&leg, &obstacle, &[], &narrow), Err(DetourRefusal::OutsideCorridor));
    let just_enough = DetourConfig {
        corridor_m: 1.11,
        ..CONFIG
    };
    let detour = plan(&leg, &obstacle, &[], &just_enough).expect("detour");
    assert_sound(&leg, &detour, &obstacle, &[], &just_enough);
}

#[test]
fn an_obstacle_at_or_just_before_the_goal_refuses() {
    let leg = Leg::north(30.0);
    let at_goal = square(&leg, 29.8, 0.0, 1.0);
    assert_eq!(
        plan(&leg, &at_goal, &[], &CONFIG),
        Err(DetourRefusal::GoalInsideObstacle)
    );
    // Past the obstacle there is not room to get back onto the line.
    let near_goal = square(&leg, 26.0, 0.0, 1.0);
    assert_eq!(
        plan(&leg, &near_goal, &[], &CONFIG),
        Err(DetourRefusal::GoalInsideObstacle)
    );
    // A leg ending in an obstacle too wide for the corridor is reported as
    // such, not as a corridor problem.
    let wide_at_goal = square(&leg, 29.0, 0.0, 8.0);
    assert_eq!(
        plan(&leg, &wide_at_goal, &[], &CONFIG),
        Err(DetourRefusal::GoalInsideObstacle)
    );
    // Further back there is.
    let earlier = square(&leg, 23.0, 0.0, 1.0);
    let detour = plan(&leg, &earlier, &[], &CONFIG).expect("detour");
    assert_sound(&leg, &detour, &earlier, &[], &CONFIG);
}

#[test]
fn an_obstacle_too_close_ahead_refuses() {
    let leg = Leg::north(30.0);
    for &along_m in &[1.0, 3.0, 4.5] {
        let close = square(&leg, along_m, 0.0, 1.0);
        assert_eq!(
            plan(&leg, &close, &[], &CONFIG),
            Err(DetourRefusal::TooClose),
            "at {along_m} m"
        );
    }
    // Likewise an obstacle too close ahead and too wide for the corridor.
    let wide_close = square(&leg, 5.5, 0.0, 8.0);
    assert_eq!(plan(&leg, &wide_close, &[], &CONFIG), Err(DetourRefusal::TooClose));
    // A vehicle that turns on the spot gets round the 4.5 m one: it needs
    // only as much run-in as offset (1.4 m) where a 2 m radius needs 3.3 m.
    let spinner = DetourConfig {
        min_turn_radius_m: 0.0,
        ..CONFIG
    };
    let close = square(&leg, 4.5, 0.0, 1.0);
    let detour = plan(&leg, &close, &[], &spinner).expect("detour");
    assert_sound(&leg, &detour, &close, &[], &spinner);
}

#[test]
fn an_obstacle_off_the_path_or_behind_needs_no_detour() {
    let leg = Leg::north(30.0);
    let beside = square(&leg, 12.0, 1.5, 1.0);
    assert_eq!(plan(&leg, &beside, &[], &CONFIG), Err(DetourRefusal::NotInTheWay));
    let behind = square(&leg, -3.0, 0.0, 1.0);
    assert_eq!(plan(&leg, &behind, &[], &CONFIG), Err(DetourRefusal::NotInTheWay));
    let beyond_goal = square(&leg, 33.0, 0.0, 1.0);
    assert_eq!(plan(&leg, &beyond_goal, &[], &CONFIG), Err(DetourRefusal::NotInTheWay));
}

#[test]
fn bad_input_is_refused_not_panicked_on() {
    let leg = Leg::north(30.0);
    let obstacle = square(&leg, 12.0, 0.3, 1.0);
    let mut with_nan = obstacle.clone();
    with_nan.push(Ned::new(f64::NAN, 0.0));
    assert_eq!(plan(&leg, &with_nan, &[], &CONFIG), Err(DetourRefusal::InvalidInput));
    assert_eq!(plan(&leg, &[], &[], &CONFIG), Err(DetourRefusal::InvalidInput));
    assert_eq!(
        plan(&leg, &obstacle, &[Ned::new(1.0, f64::INFINITY)], &CONFIG),
        Err(DetourRefusal::InvalidInput)
    );
    let negative = DetourConfig {
        clearance_m: -0.1,
        ..CONFIG
    };
    assert_eq!(plan(&leg, &obstacle, &[], &negative), Err(DetourRefusal::InvalidInput));
    let pose = leg.start_pose();
    let no_leg = plan_detour(leg.from, leg.from, &pose, &FOOTPRINT, &obstacle, &[], &CONFIG);
    assert_eq!(no_leg, Err(DetourRefusal::InvalidInput));
}

#[test]
fn the_same_inputs_give_the_same_detour_in_any_point_order() {
    let leg = Leg {
        from: Ned::new(2.0, 7.0),
        heading_rad: 0.6,
        length_m: 30.0,
    };
    let obstacle = square(&leg, 12.0, 0.3, 1.2);
    let others = wall(&leg, -1.7, 0.0, 30.0);
    let first = plan(&leg, &obstacle, &others, &CONFIG).expect("detour");
    let second = plan(&leg, &obstacle, &others, &CONFIG).expect("detour");
    assert_eq!(first, second);
    let reversed: Vec<Ned> = obstacle.iter().rev().copied().collect();
    let others_reversed: Vec<Ned> = others.iter().rev().copied().collect();
    assert_eq!(plan(&leg, &reversed, &others_reversed, &CONFIG).expect("detour"), first);
}
