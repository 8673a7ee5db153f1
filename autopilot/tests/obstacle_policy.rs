//! Collision prediction, protective/warning fields and the stop/resume
//! policy (docs/architecture.md §Obstacles, seed 004 §III.C–D), exercised through their public
//! API with scenes built from tracks, as the core builds them.
//!
//! Sources: docs/references.md §Seed 004.

use autopilot::geo::Ned;
use autopilot::obstacles::field::{FieldConfig, FieldStatus, check_field, fields, warning_speed_limit};
use autopilot::obstacles::policy::{
    DECIDE_LEAD_S, ObstaclePolicy, PolicyConfig, PolicyEvent, PolicyInputs, StopCause, Verdict, distance_gained_m,
    pass_first_holds, pass_first_requirement,
};
use autopilot::obstacles::prediction::{CollisionPrediction, VehicleMotion, predict_collision};
use autopilot::obstacles::{Footprint, Pose, Track, TrackStatus};

/// Seed 004's AGV: 1.0 m long, 0.6 m wide; the rear axle 0.2 m from the
/// rear bumper.
const FOOTPRINT: Footprint = Footprint {
    front_m: 0.8,
    rear_m: 0.2,
    half_width_m: 0.3,
};
const MARGIN_M: f64 = 0.2;

fn track(id: u32, north_m: f64, east_m: f64, vel_north_mps: f64, vel_east_mps: f64, radius_m: f64) -> Track {
    Track {
        id,
        status: TrackStatus::Confirmed,
        position: Ned::new(north_m, east_m),
        vel_north_mps,
        vel_east_mps,
        position_sigma_m: 0.03,
        velocity_sigma_mps: 0.05,
        radius_m,
        outline: None,
        age_s: 2.0,
        unseen_s: 0.0,
        hits: 50,
        misses: 0,
        still_s: 0.0,
    }
}

fn pose(north_m: f64, east_m: f64, yaw_rad: f64) -> Pose {
    Pose {
        position: Ned::new(north_m, east_m),
        yaw_rad,
    }
}

fn moving(speed_mps: f64) -> VehicleMotion {
    VehicleMotion::along_heading(pose(0.0, 0.0, 0.0), speed_mps)
}

/// Distance from a body-frame point to the footprint rectangle: an oracle
/// independent of the ray casting under test.
fn distance_to_footprint(x: f64, y: f64, footprint: &Footprint) -> f64 {
    let dx = (-footprint.rear_m - x).max(x - footprint.front_m).max(0.0);
    let dy = (y.abs() - footprint.half_width_m).max(0.0);
    dx.hypot(dy)
}

/// Steps the straight-line motions and returns the first sampled time the
/// disc comes within reach of the footprint (vehicle heading north).
fn sampled_contact(track: &Track, vehicle_speed_mps: f64, reach_m: f64, horizon_s: f64, dt_s: f64) -> Option<f64> {
    let steps = (horizon_s / dt_s) as usize;
    (0..=steps).map(|i| i as f64 * dt_s).find(|t| {
        let x = track.position.north_m + (track.vel_north_mps - vehicle_speed_mps) * t;
        let y = track.position.east_m + track.vel_east_mps * t;
        distance_to_footprint(x, y, &FOOTPRINT) <= reach_m
    })
}

// --- collision geometry -------------------------------------------------

#[test]
fn head_on_time_is_gap_over_closing_speed() {
    // Vehicle north at 1 m/s; person 10 m ahead walking south at 0.5 m/s.
    let person = track(1, 10.0, 0.0, -0.5, 0.0, 0.3);
    let p = predict_collision(&person, &moving(1.0), &FOOTPRINT, MARGIN_M, 20.0).expect("head-on must collide");
    let gap_m = 10.0 - FOOTPRINT.front_m - 0.3 - MARGIN_M;
    assert!((p.time_s - gap_m / 1.5).abs() < 1e-9, "t_c {}", p.time_s);
    assert!((p.relative_speed_mps - 1.5).abs() < 1e-12);
    assert!((p.distance_m - (10.0 - FOOTPRINT.front_m - 0.3)).abs() < 1e-9);
    assert!(p.closing);
    // Eq. 17 corrected: where the reference point will be, in the local frame.
    assert!((p.place.north_m - p.time_s).abs() < 1e-9 && p.place.east_m.abs() < 1e-12);
}

#[test]
fn crossing_at_right_angles_hits_where_sampling_says() {
    // Vehicle north at 1 m/s; a person 4 m ahead and 3 m to the left walking
    // east at 1 m/s reaches the path just as the front arrives.
    let person = track(2, 4.0, -3.0, 0.0, 1.0, 0.25);
    let p = predict_collision(&person, &moving(1.0), &FOOTPRINT, MARGIN_M, 10.0).expect("crossing must collide");
    let sampled = sampled_contact(&person, 1.0, 0.25 + MARGIN_M, 10.0, 1e-4).expect("sampling finds it too");
    assert!((p.time_s - sampled).abs() < 2e-4, "ray {} sampled {sampled}", p.time_s);
}

#[test]
fn pure_crossing_of_a_stationary_vehicle_has_a_finite_time() {
    // Seed eq. 16 divides by the relative velocity's x component, here 0.
    let person = track(3, 0.3, -5.0, 0.0, 1.0, 0.25);
    let p = predict_collision(&person, &moving(0.0), &FOOTPRINT, MARGIN_M, 10.0).expect("walks into the side");
    let expected = 5.0 - FOOTPRINT.half_width_m - 0.25 - MARGIN_M;
    assert!((p.time_s - expected).abs() < 1e-9, "t_c {}", p.time_s);
}

#[test]
fn a_miss_by_ten_centimetres_beyond_the_margin_is_none_and_just_inside_is_some() {
    let lateral_miss_m = FOOTPRINT.half_width_m + 0.25 + MARGIN_M + 0.1;
    let beside = track(4, 8.0, lateral_miss_m, 0.0, 0.0, 0.25);
    assert!(predict_collision(&beside, &moving(1.5), &FOOTPRINT, MARGIN_M, 20.0).is_none());
    let inside = track(4, 8.0, lateral_miss_m - 0.11, 0.0, 0.0, 0.25);
    assert!(predict_collision(&inside, &moving(1.5), &FOOTPRINT, MARGIN_M, 20.0).is_some());
}

#[test]
fn grazing_a_corner_is_caught_at_the_rounded_corner() {
    // A post passing 0.3 m outside the vehicle's side line with a reach of
    // 0.35 m: only the disc sweeps over the front corner. Its centre line
    // misses the rectangle, and so does the line of its nearest point
    // (0.05 m beside), so the seed's three projections (eq. 14) see nothing.
    let reach_m = 0.35;
    let post = track(5, 5.0, FOOTPRINT.half_width_m + 0.3, 0.0, 0.0, reach_m - MARGIN_M);
    let p = predict_collision(&post, &moving(1.0), &FOOTPRINT, MARGIN_M, 20.0).expect("the corner is grazed");
    let along_m = (reach_m * reach_m - 0.3 * 0.3_f64).sqrt();
    let expected = 5.0 - FOOTPRINT.front_m - along_m;
    assert!(
        (p.time_s - expected).abs() < 1e-9,
        "t_c {} expected {expected}",
        p.time_s
    );
    // Earlier than reaching the front bumper's line, which a grown
    // rectangle without rounded corners would report.
    assert!(p.time_s < 5.0 - FOOTPRINT.front_m);
    // A few centimetres further out it misses.
    let clear = track(
        5,
        5.0,
        FOOTPRINT.half_width_m + reach_m + 0.02,
        0.0,
        0.0,
        reach_m - MARGIN_M,
    );
    assert!(predict_collision(&clear, &moving(1.0), &FOOTPRINT, MARGIN_M, 20.0).is_none());
}

#[test]
fn obstacle_behind_while_reversing() {
    let post = track(6, -5.0, 0.1, 0.0, 0.0, 0.3);
    let p = predict_collision(&post, &moving(-1.0), &FOOTPRINT, MARGIN_M, 20.0).expect("reversing into it");
    let expected = 5.0 - FOOTPRINT.rear_m - 0.3 - MARGIN_M;
    assert!((p.time_s - expected).abs() < 1e-9);
    assert!(
        (p.place.north_m + expected).abs() < 1e-9,
        "the vehicle will be behind where it is"
    );
    // Going forward it is receding.
    assert!(predict_collision(&post, &moving(1.0), &FOOTPRINT, MARGIN_M, 20.0).is_none());
}

#[test]
fn already_touching_is_now() {
    let leaning = track(7, FOOTPRINT.front_m + 0.3, 0.0, 0.0, 0.0, 0.25);
    let p = predict_collision(&leaning, &moving(0.5), &FOOTPRINT, MARGIN_M, 20.0).expect("overlapping");
    assert_eq!(p.time_s, 0.0);
    assert!((p.distance_m - 0.05).abs() < 1e-9);
    assert!(p.closing);
    // Overlapping without relative motion still reports, not closing.
    let p = predict_collision(&leaning, &moving(0.0), &FOOTPRINT, MARGIN_M, 20.0).expect("overlapping at rest");
    assert_eq!(p.time_s, 0.0);
    assert!(!p.closing);
}

#[test]
fn receding_obstacle_is_none() {
    let walker = track(8, 4.0, 0.0, 1.5, 0.0, 0.25);
    assert!(predict_collision(&walker, &moving(1.0), &FOOTPRINT, MARGIN_M, 60.0).is_none());
    let static_vehicle_no_motion = track(8, 4.0, 0.0, 0.0, 0.0, 0.25);
    assert!(predict_collision(&static_vehicle_no_motion, &moving(0.0), &FOOTPRINT, MARGIN_M, 60.0).is_none());
}

#[test]
fn ray_never_misses_a_sampled_contact() {
    // A deterministic sweep of approach angles, speeds and offsets: before
    // the predicted time no sampled position is within reach, and at it the
    // disc touches (or a None is confirmed by sampling).
    let mut checked = 0;
    for i in 0..24 {
        let heading = i as f64 * std::f64::consts::TAU / 24.0;
        for (speed, offset) in [(0.4, 0.0), (1.0, 0.5), (1.6, -0.7), (0.8, 1.1)] {
            let (s, c) = heading.sin_cos();
            let start = (3.0 + offset, -2.0 + 0.5 * offset);
            let obstacle = track(9, start.0, start.1, speed * c, speed * s, 0.2);
            let vehicle_speed = 0.7;
            let reach = 0.2 + MARGIN_M;
            let predicted = predict_collision(&obstacle, &moving(vehicle_speed), &FOOTPRINT, MARGIN_M, 8.0);
            let sampled = sampled_contact(&obstacle, vehicle_speed, reach, 8.0, 1e-3);
            match (predicted, sampled) {
                (Some(p), Some(t)) => assert!(p.time_s <= t + 1e-9 && t - p.time_s < 1.1e-3, "{p:?} vs {t}"),
                (Some(p), None) => {
                    // Only a tangent graze between samples may escape sampling.
                    let x = start.0 + (speed * c - vehicle_speed) * p.time_s;
                    let y = start.1 + speed * s * p.time_s;
                    assert!((distance_to_footprint(x, y, &FOOTPRINT) - reach).abs() < 1e-6);
                }
                (None, Some(t)) => panic!("missed a contact at {t} s (heading {heading})"),
                (None, None) => {}
            }
            checked += 1;
        }
    }
    assert_eq!(checked, 96);
}

// --- fields -------------------------------------------------------------

fn b4_config() -> FieldConfig {
    // Reference B.4's worked example: 90 ms reaction, 1 m/s², Z_G 0.1 m.
    FieldConfig {
        reaction_s: 0.09,
        decel_mps2: 1.0,
        margin_m: 0.1,
        lateral_margin_m: 0.15,
        warning_time_s: 2.0,
        min_length_m: 0.0,
    }
}

#[test]
fn field_lengths_forward_and_reverse() {
    let config = b4_config();
    for (speed, protective) in [(0.0, 0.1), (1.0, 0.69), (2.0, 2.28)] {
        for sign in [1.0, -1.0] {
            let f = fields(sign * speed, &FOOTPRINT, &config);
            assert!((f.protective_length_m - protective).abs() < 1e-9, "{speed}: {f:?}");
            assert!((f.warning_length_m - (protective + 2.0 * speed)).abs() < 1e-9);
            assert!((f.half_width_m - 0.45).abs() < 1e-12);
            let expected_direction = if sign < 0.0 && speed > 0.0 { -1 } else { 1 };
            assert_eq!(f.direction, expected_direction);
        }
    }
}

#[test]
fn field_starts_at_the_bumper_in_the_driving_direction() {
    let config = b4_config();
    // 0.5 m beyond each bumper, on the centre line.
    let points = [(FOOTPRINT.front_m + 0.5, 0.0), (-FOOTPRINT.rear_m - 0.5, 0.0)];
    let forward = check_field(&fields(1.0, &FOOTPRINT, &config), &FOOTPRINT, points);
    assert_eq!(forward.protective_hits, 1);
    assert!((forward.nearest_protective_m.unwrap_or(0.0) - 0.5).abs() < 1e-12);
    let reverse = check_field(&fields(-1.0, &FOOTPRINT, &config), &FOOTPRINT, points);
    assert_eq!(reverse.protective_hits, 1);
    assert!((reverse.nearest_protective_m.unwrap_or(0.0) - 0.5).abs() < 1e-12);
}

#[test]
fn points_beside_the_vehicle_and_on_it_do_not_hit() {
    let config = b4_config();
    let f = fields(2.0, &FOOTPRINT, &config);
    let off_side = FOOTPRINT.half_width_m + 0.6;
    let points = [
        // Beside the body, both sides.
        (0.3, off_side),
        (0.3, -off_side),
        // 0.6 m off the side line but ahead, inside the braking distance.
        (FOOTPRINT.front_m + 1.0, off_side),
        // The vehicle's own body.
        (0.5, 0.1),
        (FOOTPRINT.front_m, 0.0),
        (f64::NAN, 0.0),
    ];
    assert_eq!(check_field(&f, &FOOTPRINT, points), FieldStatus::default());
    // Just inside the lateral margin it does hit.
    let edge = check_field(
        &f,
        &FOOTPRINT,
        [(FOOTPRINT.front_m + 1.0, FOOTPRINT.half_width_m + 0.14)],
    );
    assert_eq!(edge.protective_hits, 1);
}

#[test]
fn warning_band_slows_to_keep_the_point_outside_the_protective_field() {
    let config = b4_config();
    let f = fields(1.0, &FOOTPRINT, &config);
    let d = 1.5; // beyond 0.69, within 0.69 + 2
    let status = check_field(
        &f,
        &FOOTPRINT,
        [(FOOTPRINT.front_m + d, 0.1), (FOOTPRINT.front_m + 2.5, 0.0)],
    );
    assert_eq!((status.protective_hits, status.warning_hits), (0, 2));
    assert!((status.nearest_warning_m.unwrap_or(0.0) - d).abs() < 1e-12);
    let limit = warning_speed_limit(&f, &status, &config, 5.0).expect("a warning hit limits the speed");
    let at_limit = fields(limit, &FOOTPRINT, &config);
    assert!(
        (at_limit.protective_length_m - d).abs() < 1e-9,
        "{limit} m/s gives {at_limit:?}"
    );
    // Capped by the cruise speed.
    assert_eq!(warning_speed_limit(&f, &status, &config, 0.3), Some(0.3));
}

// --- pass first (eq. 18, corrected) ---------------------------------------

#[test]
fn corrected_eq18_accounts_for_acceleration_and_length() {
    let config = PolicyConfig {
        max_speed_mps: 2.0,
        accel_mps2: 0.3,
        safe_distance_m: 0.5,
        ..PolicyConfig::default()
    };
    let (v_now, t_c, obstacle_size) = (0.5, 3.0, 0.6);
    let length = FOOTPRINT.front_m + FOOTPRINT.rear_m;
    // The seed's condition holds comfortably: 1.5 × 3 = 4.5 > 1.1.
    assert!((2.0 - v_now) * t_c > obstacle_size + config.safe_distance_m);
    // At 0.3 m/s² only 1.35 m is gained by t_c, short of L + AC + ΔL = 2.1 m.
    assert!((distance_gained_m(v_now, 2.0, 0.3, t_c) - 1.35).abs() < 1e-12);
    assert!(!pass_first_holds(
        v_now,
        t_c,
        length + obstacle_size + config.safe_distance_m,
        &config
    ));
    // At 2 m/s² it reaches V_max after 0.75 s and gains 1.5 × (3 − 0.375).
    let brisk = PolicyConfig {
        accel_mps2: 2.0,
        ..config
    };
    assert!((distance_gained_m(v_now, 2.0, 2.0, t_c) - 3.9375).abs() < 1e-12);
    assert!(pass_first_holds(
        v_now,
        t_c,
        length + obstacle_size + config.safe_distance_m,
        &brisk
    ));
}

#[test]
fn requirement_for_an_obstacle_reaching_the_front_bumper_is_length_plus_size_plus_safe_distance() {
    // At 1 m/s, an obstacle of radius 0.3 that reaches the lane after 2 s
    // exactly where the front bumper will be.
    let radius = 0.3;
    let lateral = FOOTPRINT.half_width_m + radius + 2.0 * 0.8; // 0.8 m/s across, 2 s away
    let x_now = 2.0 * 1.0 + FOOTPRINT.front_m + radius;
    let person = track(10, x_now, -lateral, 0.0, 0.8, radius);
    let (t_c, required) =
        pass_first_requirement(&person, &pose(0.0, 0.0, 0.0), 1.0, &FOOTPRINT, 0.5).expect("crossing");
    assert!((t_c - 2.0).abs() < 1e-9);
    let length = FOOTPRINT.front_m + FOOTPRINT.rear_m;
    assert!(
        (required - (length + 2.0 * radius + 0.5)).abs() < 1e-9,
        "required {required}"
    );
    // Walking along the path (head-on) is not crossing: speeding up cannot help.
    let head_on = track(11, 6.0, -0.9, -1.0, 0.1, radius);
    assert!(pass_first_requirement(&head_on, &pose(0.0, 0.0, 0.0), 1.0, &FOOTPRINT, 0.5).is_none());
}

// --- policy -------------------------------------------------------------

/// One tick's inputs, owned, so tests can tweak them.
struct Scene {
    t_s: f64,
    wants_to_move: bool,
    settling: bool,
    speed_mps: f64,
    scan_age_s: Option<f64>,
    field: FieldStatus,
    field_at_resume: FieldStatus,
    predictions: Vec<CollisionPrediction>,
    predictions_at_resume: Vec<CollisionPrediction>,
    tracks: Vec<Track>,
    pose: Pose,
    warning_limit_mps: Option<f64>,
}

impl Scene {
    fn clear(t_s: f64, speed_mps: f64) -> Self {
        Scene {
            t_s,
            wants_to_move: true,
            settling: false,
            speed_mps,
            scan_age_s: Some(0.02),
            field: FieldStatus::default(),
            field_at_resume: FieldStatus::default(),
            predictions: Vec::new(),
            predictions_at_resume: Vec::new(),
            tracks: Vec::new(),
            pose: pose(0.0, 0.0, 0.0),
            warning_limit_mps: None,
        }
    }

    /// Tracks, with predictions at the current and at the planned speed.
    fn with_tracks(mut self, tracks: Vec<Track>, planned_mps: f64) -> Self {
        let now = VehicleMotion::along_heading(self.pose, self.speed_mps);
        let planned = VehicleMotion::along_heading(self.pose, planned_mps);
        self.predictions = tracks
            .iter()
            .filter_map(|t| predict_collision(t, &now, &FOOTPRINT, MARGIN_M, 10.0))
            .collect();
        self.predictions_at_resume = tracks
            .iter()
            .filter_map(|t| predict_collision(t, &planned, &FOOTPRINT, MARGIN_M, 10.0))
            .collect();
        self.tracks = tracks;
        self
    }

    fn inputs(&self) -> PolicyInputs<'_> {
        PolicyInputs {
            t_s: self.t_s,
            wants_to_move: self.wants_to_move,
            settling: self.settling,
            speed_mps: self.speed_mps,
            scan_age_s: self.scan_age_s,
            field: &self.field,
            field_at_resume: &self.field_at_resume,
            predictions: &self.predictions,
            predictions_at_resume: &self.predictions_at_resume,
            tracks: &self.tracks,
            pose: self.pose,
            footprint: &FOOTPRINT,
            warning_limit_mps: self.warning_limit_mps,
        }
    }
}

fn hit(distance_m: f64) -> FieldStatus {
    FieldStatus {
        protective_hits: 3,
        nearest_protective_m: Some(distance_m),
        ..FieldStatus::default()
    }
}

fn count(events: &[PolicyEvent], pred: impl Fn(&PolicyEvent) -> bool) -> usize {
    events.iter().filter(|e| pred(e)).count()
}

#[test]
fn protective_hit_stops_and_resumes_only_after_resume_s_of_clear() {
    let config = PolicyConfig::default(); // resume_s 2, auto_resume
    let mut policy = ObstaclePolicy::new();
    let mut events = Vec::new();
    let mut resumed_at = None;
    // 20 Hz ticks: clear, then an object in the field from 1 s to 3 s, a
    // flicker in the resume field at 4 s, then clear.
    for i in 0..200 {
        let t = i as f64 * 0.05;
        let mut scene = Scene::clear(t, if policy.is_stopped() { 0.0 } else { 1.0 });
        if (1.0..3.0).contains(&t) {
            scene.field = hit(0.4);
            scene.field_at_resume = hit(0.4);
        }
        if (4.0..4.1).contains(&t) {
            scene.field_at_resume = hit(1.5);
        }
        let status = policy.update(&scene.inputs(), &config);
        if t < 1.0 {
            assert_eq!(status.verdict, Verdict::Go, "t {t}");
        }
        if (1.0..6.1).contains(&t) {
            assert!(status.stopped, "t {t}: {status:?}");
            assert!(matches!(status.verdict, Verdict::Stop(_)));
        }
        if status.events.iter().any(|e| matches!(e, PolicyEvent::Resumed { .. })) {
            resumed_at = Some(t);
        }
        events.extend(status.events);
    }
    assert_eq!(
        count(&events, |e| matches!(e, PolicyEvent::Stopped(_))),
        1,
        "{events:?}"
    );
    assert_eq!(
        count(&events, |e| matches!(e, PolicyEvent::Resumed { .. })),
        1,
        "{events:?}"
    );
    // Clear from 4.1 s (the flicker restarted the hysteresis): resume at 6.1 s.
    let resumed_at = resumed_at.expect("resumed");
    assert!((resumed_at - 6.1).abs() < 1e-9, "resumed at {resumed_at}");
    let stopped_s = events.iter().find_map(|e| match e {
        PolicyEvent::Resumed { stopped_s } => Some(*stopped_s),
        _ => None,
    });
    assert!((stopped_s.unwrap_or(0.0) - 5.1).abs() < 1e-9);
    assert!(matches!(
        events.first(),
        Some(PolicyEvent::Stopped(StopCause::ProtectiveField { distance_m })) if (*distance_m - 0.4).abs() < 1e-12
    ));
}

#[test]
fn crossing_person_stops_then_the_vehicle_waits_for_the_resume_prediction_to_clear() {
    let config = PolicyConfig::default();
    let mut policy = ObstaclePolicy::new();
    // A person 3 m ahead, 2 m to the left, walking east across at 1 m/s.
    let person = |t: f64| track(4, 3.0, -2.0 + t, 0.0, 1.0, 0.25);
    let status = policy.update(
        &Scene::clear(0.0, 1.0).with_tracks(vec![person(0.0)], 1.0).inputs(),
        &config,
    );
    let Verdict::Stop(
        cause @ StopCause::Collision {
            track_id: 4, time_s, ..
        },
    ) = status.verdict
    else {
        panic!("expected a collision stop, got {status:?}");
    };
    assert!(time_s > 0.0 && time_s < config.stop_horizon_s);
    assert_eq!(status.events, vec![PolicyEvent::Stopped(cause)]);
    assert!(cause.to_string().starts_with("obstacle #4 collision in"));
    // Standing still while the person crosses; resume once the prediction at
    // the planned 1 m/s has been clear for 2 s.
    let mut first_clear = None;
    let mut resumed = None;
    for i in 1..200 {
        let t = i as f64 * 0.05;
        let scene = Scene::clear(t, 0.0).with_tracks(vec![person(t)], 1.0);
        if first_clear.is_none() && scene.predictions_at_resume.is_empty() {
            first_clear = Some(t);
        }
        let status = policy.update(&scene.inputs(), &config);
        if status.events.iter().any(|e| matches!(e, PolicyEvent::Resumed { .. })) {
            resumed = Some(t);
            break;
        }
        assert!(status.stopped);
    }
    let (first_clear, resumed) = (first_clear.expect("the person walks off"), resumed.expect("resumed"));
    assert!(
        (resumed - first_clear - config.resume_s).abs() < 0.05 + 1e-9,
        "{first_clear} → {resumed}"
    );
}

#[test]
fn waits_for_the_operator_when_auto_resume_is_off() {
    let config = PolicyConfig {
        auto_resume: false,
        ..PolicyConfig::default()
    };
    let mut policy = ObstaclePolicy::new();
    let mut blocked = Scene::clear(0.0, 1.0);
    blocked.field = hit(0.3);
    let status = policy.update(&blocked.inputs(), &config);
    assert!(status.stopped);
    assert!(!policy.operator_resume(0.5), "way blocked: no release");
    let mut events = Vec::new();
    for i in 1..=100 {
        let t = i as f64 * 0.1;
        let status = policy.update(&Scene::clear(t, 0.0).inputs(), &config);
        assert!(status.stopped, "t {t}");
        events.extend(status.events);
        if t < 2.0 {
            assert!(!policy.operator_resume(t), "t {t}: too early");
        }
    }
    assert_eq!(
        count(&events, |e| matches!(e, PolicyEvent::WaitingForOperator(_))),
        1,
        "{events:?}"
    );
    assert_eq!(count(&events, |e| matches!(e, PolicyEvent::Resumed { .. })), 0);
    assert!(policy.operator_resume(10.05));
    assert!(!policy.operator_resume(10.06), "only once");
    let status = policy.update(&Scene::clear(10.1, 0.0).inputs(), &config);
    assert!(!status.stopped);
    assert_eq!(status.verdict, Verdict::Go);
    assert_eq!(status.events, vec![PolicyEvent::Resumed { stopped_s: 10.05 }]);
}

#[test]
fn stale_or_missing_scan_stops_only_when_wanting_to_move() {
    let config = PolicyConfig::default();
    let mut policy = ObstaclePolicy::new();
    let mut parked = Scene::clear(0.0, 0.0);
    parked.wants_to_move = false;
    parked.scan_age_s = None;
    assert_eq!(policy.update(&parked.inputs(), &config).verdict, Verdict::Go);

    let mut stale = Scene::clear(0.1, 1.0);
    stale.scan_age_s = Some(0.35);
    let status = policy.update(&stale.inputs(), &config);
    assert_eq!(
        status.verdict,
        Verdict::Stop(StopCause::StaleScan { age_s: Some(0.35) })
    );
    assert_eq!(status.events.len(), 1);
    assert_eq!(
        StopCause::StaleScan { age_s: Some(0.35) }.to_string(),
        "scanner stale 0.35 s"
    );

    // Fresh again: still held until resume_s has passed.
    let fresh = Scene::clear(1.0, 0.0);
    assert!(policy.update(&fresh.inputs(), &config).stopped);
    assert!(policy.update(&Scene::clear(2.9, 0.0).inputs(), &config).stopped);
    assert!(!policy.update(&Scene::clear(3.0, 0.0).inputs(), &config).stopped);

    let mut policy = ObstaclePolicy::new();
    let mut missing = Scene::clear(0.0, 0.5);
    missing.scan_age_s = None;
    assert_eq!(
        policy.update(&missing.inputs(), &config).verdict,
        Verdict::Stop(StopCause::StaleScan { age_s: None })
    );
}

#[test]
fn person_walking_away_ahead_is_followed_not_stopped_for() {
    let config = PolicyConfig::default();
    let mut policy = ObstaclePolicy::new();
    // 3 m ahead walking north at 0.5 m/s while the vehicle does 1.2 m/s.
    let walker = track(6, 3.0, 0.1, 0.5, 0.0, 0.25);
    let scene = Scene::clear(0.0, 1.2).with_tracks(vec![walker], 1.2);
    assert!(!scene.predictions.is_empty(), "the vehicle would catch up");
    let status = policy.update(&scene.inputs(), &config);
    assert_eq!(status.verdict, Verdict::Slow { limit_mps: 0.5 });
    assert_eq!(status.events, vec![PolicyEvent::Slowing]);
    // Still following once down to its speed (the prediction at the current
    // velocity has cleared, the one at the planned 1.2 m/s has not): no
    // second event, no speeding up in between.
    for (i, speed) in [0.9, 0.7, 0.5, 0.5].into_iter().enumerate() {
        let scene = Scene::clear(0.05 * (i + 1) as f64, speed).with_tracks(vec![walker], 1.2);
        let status = policy.update(&scene.inputs(), &config);
        assert_eq!(status.verdict, Verdict::Slow { limit_mps: 0.5 }, "at {speed} m/s");
        assert!(status.events.is_empty());
    }
    // Far ahead it no longer matters.
    let far = track(6, 30.0, 0.1, 0.5, 0.0, 0.25);
    let status = policy.update(&Scene::clear(0.3, 1.2).with_tracks(vec![far], 1.2).inputs(), &config);
    assert_eq!(status.verdict, Verdict::Go);
    // If it stands still instead, stop.
    let standing = track(6, 3.0, 0.1, 0.0, 0.0, 0.25);
    let status = policy.update(
        &Scene::clear(0.1, 1.2).with_tracks(vec![standing], 1.2).inputs(),
        &config,
    );
    assert!(matches!(
        status.verdict,
        Verdict::Stop(StopCause::Collision { track_id: 6, .. })
    ));
    // And a walker inside the protective field is a stop regardless.
    let mut policy = ObstaclePolicy::new();
    let mut close = Scene::clear(0.0, 1.2).with_tracks(vec![walker], 1.2);
    close.field = hit(0.5);
    assert!(policy.update(&close.inputs(), &config).stopped);
}

#[test]
fn a_person_overtaking_from_the_side_is_stopped_for_not_followed() {
    // Beside the vehicle (ahead of the axle, behind the front bumper),
    // walking forward faster than the vehicle and closing in from the left.
    let config = PolicyConfig::default();
    let mut policy = ObstaclePolicy::new();
    let overtaker = track(8, 0.4, -1.5, 1.4, 1.4, 0.25);
    let scene = Scene::clear(0.0, 1.0).with_tracks(vec![overtaker], 1.0);
    assert!(!scene.predictions.is_empty(), "it is on a collision course");
    let status = policy.update(&scene.inputs(), &config);
    assert!(
        matches!(status.verdict, Verdict::Stop(StopCause::Collision { track_id: 8, .. })),
        "{:?}",
        status.verdict
    );
    // The same walker in the lane ahead of the bumper is followed.
    let mut policy = ObstaclePolicy::new();
    let ahead = track(8, 1.9, 0.0, 0.6, 0.0, 0.25);
    let status = policy.update(&Scene::clear(0.0, 1.0).with_tracks(vec![ahead], 1.0).inputs(), &config);
    assert_eq!(status.verdict, Verdict::Slow { limit_mps: 0.6 });
}

#[test]
fn tentative_tracks_do_not_stop_the_vehicle() {
    let config = PolicyConfig::default();
    let mut policy = ObstaclePolicy::new();
    let mut ghost = track(7, 3.0, 0.0, 0.0, 0.0, 0.25);
    ghost.status = TrackStatus::Tentative;
    let scene = Scene::clear(0.0, 1.0).with_tracks(vec![ghost], 1.0);
    assert!(!scene.predictions.is_empty());
    assert_eq!(policy.update(&scene.inputs(), &config).verdict, Verdict::Go);
}

#[test]
fn warning_hits_slow_the_vehicle() {
    let config = PolicyConfig::default();
    let mut policy = ObstaclePolicy::new();
    let mut scene = Scene::clear(0.0, 1.0);
    scene.field.warning_hits = 2;
    scene.field.nearest_warning_m = Some(1.2);
    scene.warning_limit_mps = Some(0.8);
    let status = policy.update(&scene.inputs(), &config);
    assert_eq!(status.verdict, Verdict::Slow { limit_mps: 0.8 });
    assert_eq!(status.events, vec![PolicyEvent::Slowing]);
}

/// A person crossing from the left who reaches the vehicle's lane 2.5 s
/// from now, 0.3 m ahead of where the front bumper would touch it at 0.8 m/s.
fn crossing_scene(t_s: f64) -> Scene {
    crossing_scene_in(t_s, 2.5)
}

/// The same crossing, reaching the lane `reach_s` from now.
fn crossing_scene_in(t_s: f64, reach_s: f64) -> Scene {
    let person = track(
        9,
        0.8 * reach_s + FOOTPRINT.front_m + 0.25 + 0.3,
        -(0.3 + 0.25 + reach_s),
        0.0,
        1.0,
        0.25,
    );
    Scene::clear(t_s, 0.8).with_tracks(vec![person], 0.8)
}

fn pass_config(pass_first: bool, accel_mps2: f64) -> PolicyConfig {
    PolicyConfig {
        pass_first,
        accel_mps2,
        max_speed_mps: 2.0,
        safe_distance_m: 0.5,
        ..PolicyConfig::default()
    }
}

/// At rest (wanting to move), a person crossing from the left into the
/// side of the vehicle `reach_s` from now, were it to start at 0.8 m/s.
fn crossing_at_rest(t_s: f64, reach_s: f64) -> Scene {
    let person = track(
        9,
        0.5 + 0.8 * reach_s,
        -(FOOTPRINT.half_width_m + 0.25 + MARGIN_M + reach_s),
        0.0,
        1.0,
        0.25,
    );
    Scene::clear(t_s, 0.0).with_tracks(vec![person], 0.8)
}

#[test]
fn at_rest_a_walkers_far_prediction_waits_and_a_near_one_stops() {
    let config = PolicyConfig::default();
    let lead_s = config.reaction_s + DECIDE_LEAD_S;
    let far = crossing_at_rest(0.0, 2.0);
    let time_s = far.predictions_at_resume.first().map_or(f64::NAN, |p| p.time_s);
    assert!(time_s > lead_s && time_s < config.stop_horizon_s, "{time_s}");
    // Its velocity is still settling: the vehicle does not start (braked
    // at a standstill), and no stop is held or announced.
    let mut policy = ObstaclePolicy::new();
    let status = policy.update(&far.inputs(), &config);
    assert!(
        matches!(status.verdict, Verdict::Wait(StopCause::Collision { track_id: 9, .. })),
        "{status:?}"
    );
    assert!(!status.stopped && status.events.is_empty(), "{status:?}");
    assert!(!policy.is_stopped());
    // Still coming a second and a half later: stop.
    let near = crossing_at_rest(1.5, 0.5);
    let time_s = near.predictions_at_resume.first().map_or(f64::NAN, |p| p.time_s);
    assert!(time_s <= lead_s, "{time_s}");
    let status = policy.update(&near.inputs(), &config);
    assert!(matches!(
        status.verdict,
        Verdict::Stop(StopCause::Collision { track_id: 9, .. })
    ));
    // Something standing that the start would meet as far off: stop at once.
    let post = track(3, FOOTPRINT.front_m + 0.25 + MARGIN_M + 1.2, 0.0, 0.0, 0.0, 0.25);
    let standing = Scene::clear(0.0, 0.0).with_tracks(vec![post], 0.8);
    let time_s = standing.predictions_at_resume.first().map_or(f64::NAN, |p| p.time_s);
    assert!(time_s > lead_s && time_s < config.stop_horizon_s, "{time_s}");
    let status = ObstaclePolicy::new().update(&standing.inputs(), &config);
    assert!(status.stopped, "{status:?}");
}

#[test]
fn pass_first_off_stops_for_a_crossing_person() {
    let scene = crossing_scene(0.0);
    let time_s = scene.predictions.first().map(|p| p.time_s);
    assert!(
        time_s.is_some_and(|t| t < 3.0),
        "the person meets the front corner: {time_s:?}"
    );
    // Further off than stopping from 0.8 m/s (0.95 s) plus the decision
    // lead: hold the speed and look again.
    let mut policy = ObstaclePolicy::new();
    let status = policy.update(&scene.inputs(), &pass_config(false, 1.5));
    assert_eq!(status.verdict, Verdict::Slow { limit_mps: 0.8 });
    // Still coming a second later: stop, with the lead to spare.
    let nearer = crossing_scene_in(1.0, 1.5);
    let time_s = nearer.predictions.first().map_or(f64::NAN, |p| p.time_s);
    assert!(time_s <= 0.15 + 0.8 + DECIDE_LEAD_S, "{time_s}");
    let status = policy.update(&nearer.inputs(), &pass_config(false, 1.5));
    assert!(matches!(
        status.verdict,
        Verdict::Stop(StopCause::Collision { track_id: 9, .. })
    ));
}

#[test]
fn pass_first_speeds_up_only_when_the_corrected_eq18_holds() {
    // Required by t_c = 2.5 s: the person's centre 0.3 + 0.8 + 0.25 m ahead
    // of the reference point, + radius 0.25 + rear 0.2 + ΔL 0.5 = 2.3 m.
    // The seed's eq. 18 passes at any acceleration: (2 − 0.8) × 2.5 = 3 m
    // > AC + ΔL = 1 m.
    let scene = crossing_scene(0.0);
    let (t_c, required) =
        pass_first_requirement(&scene.tracks[0], &scene.pose, 0.8, &FOOTPRINT, 0.5).expect("crossing");
    assert!(
        (t_c - 2.5).abs() < 1e-9 && (required - 2.3).abs() < 1e-9,
        "{t_c} {required}"
    );

    // 0.8 m/s²: 1.2 × (2.5 − 0.75) = 2.1 m gained: stop.
    assert!((distance_gained_m(0.8, 2.0, 0.8, 2.5) - 2.1).abs() < 1e-9);
    let mut policy = ObstaclePolicy::new();
    let status = policy.update(&scene.inputs(), &pass_config(true, 0.8));
    assert!(status.stopped, "gains 2.1 m of 2.3 m: {status:?}");

    // 1.5 m/s²: 1.2 × (2.5 − 0.4) = 2.52 m gained: pass first.
    let config = pass_config(true, 1.5);
    let mut policy = ObstaclePolicy::new();
    let status = policy.update(&scene.inputs(), &config);
    assert_eq!(status.verdict, Verdict::SpeedUp { target_mps: 2.0 });
    assert_eq!(status.events, vec![PolicyEvent::PassingFirst { track_id: 9 }]);

    // Once faster, the prediction clears before the person is behind: the
    // speed is held, and the event is not repeated.
    let mut later = Scene::clear(0.1, 1.6);
    later.tracks = scene.tracks.clone();
    let status = policy.update(&later.inputs(), &config);
    assert_eq!(status.verdict, Verdict::SpeedUp { target_mps: 2.0 });
    assert!(status.events.is_empty());
    // The person behind the rear bumper: back to normal.
    let mut passed = Scene::clear(2.0, 1.6);
    passed.pose = pose(6.0, 0.0, 0.0);
    passed.tracks = scene.tracks.clone();
    assert_eq!(policy.update(&passed.inputs(), &config).verdict, Verdict::Go);
}

#[test]
fn reset_forgets_a_held_stop() {
    let config = PolicyConfig::default();
    let mut policy = ObstaclePolicy::new();
    let mut blocked = Scene::clear(0.0, 1.0);
    blocked.field = hit(0.3);
    assert!(policy.update(&blocked.inputs(), &config).stopped);
    policy.reset();
    let status = policy.update(&Scene::clear(0.1, 0.0).inputs(), &config);
    assert!(!status.stopped && status.events.is_empty());
}

// --- stop/go hysteresis ---------------------------------------------------

fn prediction(track_id: u32, time_s: f64) -> CollisionPrediction {
    CollisionPrediction {
        track_id,
        time_s,
        place: Ned::default(),
        distance_m: time_s,
        relative_speed_mps: 1.0,
        obstacle_speed_mps: 0.0,
        closing: true,
    }
}

/// One stop/go cycle for track 1: driving into a predicted collision at
/// `t_s`, standing with the way clear until it resumes. Returns the events
/// and the time it resumed (None: it never did within 10 s).
fn stop_and_go(
    policy: &mut ObstaclePolicy,
    config: &PolicyConfig,
    t_s: f64,
    later: Option<f64>,
) -> (Vec<PolicyEvent>, Option<f64>) {
    let tracks = vec![track(1, 5.0, 0.0, 0.0, 0.0, 0.3)];
    let mut moving = Scene::clear(t_s, 1.0);
    moving.tracks = tracks.clone();
    moving.predictions = vec![prediction(1, 2.0)];
    moving.predictions_at_resume = vec![prediction(1, 2.0)];
    let mut events = policy.update(&moving.inputs(), config).events;
    let mut t = t_s;
    while t < t_s + 10.0 {
        t += 0.05;
        let mut resting = Scene::clear(t, 0.0);
        resting.tracks = tracks.clone();
        // Beyond the stop horizon: clear for a plain stop, not for a patient one.
        resting.predictions_at_resume = later.map(|s| vec![prediction(1, s)]).unwrap_or_default();
        let status = policy.update(&resting.inputs(), config);
        events.extend(status.events);
        if !status.stopped {
            return (events, Some(t));
        }
    }
    (events, None)
}

#[test]
fn repeated_stops_for_one_object_turn_patient_after_the_set_number_of_cycles() {
    let config = PolicyConfig::default();
    assert_eq!(config.stop_cycles, 3);
    let mut policy = ObstaclePolicy::new();
    let mut t = 0.0;
    for cycle in 0..3 {
        let (events, resumed) = stop_and_go(&mut policy, &config, t, Some(5.0));
        assert!(
            !events.iter().any(|e| matches!(e, PolicyEvent::StopGo { .. })),
            "cycle {cycle}: {events:?}"
        );
        let resumed = resumed.expect("a plain stop resumes once clear for OA_RESUME_S");
        assert!(resumed - t >= config.resume_s);
        // Drives on for a second, then stops for the same object again.
        t = resumed + 1.0;
    }
    // The fourth stop is the third within a few seconds of a resume.
    let (events, resumed) = stop_and_go(&mut policy, &config, t, Some(5.0));
    assert!(
        events
            .iter()
            .any(|e| matches!(e, PolicyEvent::StopGo { cycles: 3, .. })),
        "{events:?}"
    );
    assert_eq!(resumed, None, "a patient stop waits while anything is predicted for it");
    // Once nothing at all is predicted for it, it resumes after OA_RESUME_S.
    let (_, resumed) = stop_and_go(&mut policy, &config, t + 10.0, None);
    assert!(resumed.is_some());
}

/// Stands at rest from `t_s` with nothing predicted (a check at rest sees
/// the way clear) and `tracks` in view; the events and when it resumed
/// (None: not within 10 s).
fn rest_with(
    policy: &mut ObstaclePolicy,
    config: &PolicyConfig,
    t_s: f64,
    tracks: &[Track],
) -> (Vec<PolicyEvent>, Option<f64>) {
    let mut events = Vec::new();
    let mut t = t_s;
    while t < t_s + 10.0 {
        t += 0.05;
        let mut resting = Scene::clear(t, 0.0);
        resting.tracks = tracks.to_vec();
        let status = policy.update(&resting.inputs(), config);
        events.extend(status.events);
        if !status.stopped {
            return (events, Some(t));
        }
    }
    (events, None)
}

/// Someone standing where the turn being driven sweeps: each resume (the
/// check at rest sees the way clear) meets them again a moment later. Once
/// the stop is patient it waits while they stand where they stood, and
/// resumes only after they have stepped away.
#[test]
fn a_patient_stop_for_someone_standing_waits_until_they_step_away() {
    let config = PolicyConfig::default();
    let mut policy = ObstaclePolicy::new();
    let mut person = track(1, 5.0, 0.0, 0.0, 0.0, 0.25);
    person.still_s = 10.0;
    let mut t = 0.0;
    for cycle in 0..=config.stop_cycles {
        let mut moving = Scene::clear(t, 1.0);
        moving.tracks = vec![person];
        moving.predictions = vec![prediction(1, 2.0)];
        moving.predictions_at_resume = vec![prediction(1, 2.0)];
        let status = policy.update(&moving.inputs(), &config);
        assert!(status.stopped, "cycle {cycle}");
        let (_, resumed) = rest_with(&mut policy, &config, t, &[person]);
        if cycle < config.stop_cycles {
            t = resumed.expect("a plain stop resumes once clear for OA_RESUME_S") + 1.0;
        } else {
            assert_eq!(resumed, None, "the patient stop waits while they stand there");
            t += 10.0;
        }
    }
    // The track's noise on a standing person is not stepping away.
    person.position = Ned::new(5.05, 0.05);
    assert_eq!(rest_with(&mut policy, &config, t, &[person]).1, None);
    t += 10.0;
    person.position = Ned::new(5.0, 1.5);
    let (_, resumed) = rest_with(&mut policy, &config, t, &[person]);
    let resumed = resumed.expect("resumes once they have stepped away");
    assert!(resumed - t >= config.resume_s);
}

#[test]
fn stops_far_apart_or_with_cycles_off_never_turn_patient() {
    for (config, gap_s) in [
        (PolicyConfig::default(), 6.0),
        (
            PolicyConfig {
                stop_cycles: 0,
                ..PolicyConfig::default()
            },
            1.0,
        ),
    ] {
        let mut policy = ObstaclePolicy::new();
        let mut t = 0.0;
        for _ in 0..6 {
            let (events, resumed) = stop_and_go(&mut policy, &config, t, Some(5.0));
            assert!(
                !events.iter().any(|e| matches!(e, PolicyEvent::StopGo { .. })),
                "{events:?}"
            );
            t = resumed.expect("resumes") + gap_s;
        }
    }
}

/// A prediction of contact now (time 0) that is not closing: someone
/// standing against the side of a vehicle at rest.
fn against_the_side(track_id: u32) -> CollisionPrediction {
    CollisionPrediction {
        track_id,
        time_s: 0.0,
        place: Ned::default(),
        distance_m: 0.05,
        relative_speed_mps: 0.0,
        obstacle_speed_mps: 0.0,
        closing: false,
    }
}

#[test]
fn the_vehicle_does_not_start_with_someone_against_it() {
    let config = PolicyConfig::default();
    let side = FOOTPRINT.half_width_m + 0.25 + 0.05;
    for status in [TrackStatus::Confirmed, TrackStatus::Coasting] {
        let mut person = track(9, 0.3, side, 0.0, 0.0, 0.25);
        person.status = status;
        let mut scene = Scene::clear(0.0, 0.0);
        scene.tracks = vec![person];
        scene.predictions_at_resume = vec![against_the_side(9)];
        let mut policy = ObstaclePolicy::new();
        let verdict = policy.update(&scene.inputs(), &config).verdict;
        assert!(
            matches!(verdict, Verdict::Stop(StopCause::Collision { track_id: 9, .. })),
            "{status:?}: {verdict:?}"
        );
        // Driving past it (not starting), a gap that is not closing is no
        // reason to stop.
        let mut driving = Scene::clear(0.0, 1.0);
        driving.tracks = vec![person];
        driving.predictions = vec![against_the_side(9)];
        driving.predictions_at_resume = vec![against_the_side(9)];
        let verdict = ObstaclePolicy::new().update(&driving.inputs(), &config).verdict;
        assert_eq!(verdict, Verdict::Go, "{status:?}");
    }
    // A tentative track (maybe noise) does not hold the vehicle.
    let mut ghost = track(9, 0.3, side, 0.0, 0.0, 0.25);
    ghost.status = TrackStatus::Tentative;
    let mut scene = Scene::clear(0.0, 0.0);
    scene.tracks = vec![ghost];
    scene.predictions_at_resume = vec![against_the_side(9)];
    assert_eq!(
        ObstaclePolicy::new().update(&scene.inputs(), &config).verdict,
        Verdict::Go
    );
}

#[test]
fn a_held_stop_does_not_resume_while_a_lost_track_may_be_against_the_body() {
    let config = PolicyConfig::default();
    let mut policy = ObstaclePolicy::new();
    let mut scene = Scene::clear(0.0, 1.0);
    scene.field = hit(0.4);
    assert!(policy.update(&scene.inputs(), &config).stopped);
    // The field clears; a track lost next to the body (no longer in the
    // list) holds the stop for as long as it is reported.
    for i in 1..=200 {
        let t = f64::from(i) * 0.05;
        let mut scene = Scene::clear(t, 0.0);
        if t < 6.0 {
            scene.predictions_at_resume = vec![against_the_side(12)];
        }
        let status = policy.update(&scene.inputs(), &config);
        let resumed = status.events.iter().any(|e| matches!(e, PolicyEvent::Resumed { .. }));
        if t < 6.0 + config.resume_s - 1e-9 {
            assert!(status.stopped && !resumed, "t {t}: {status:?}");
        } else if resumed {
            return;
        }
    }
    panic!("never resumed once the lost track was gone");
}

/// A vehicle settling onto a precision stop: it wants no speed, but the
/// speed lag leaves it creeping at `speed_mps` and it may re-approach.
fn settling_scene(t_s: f64, speed_mps: f64) -> Scene {
    let mut scene = Scene::clear(t_s, speed_mps);
    scene.wants_to_move = false;
    scene.settling = true;
    scene
}

#[test]
fn a_settling_vehicle_stops_for_a_person_stepping_to_its_side() {
    let config = PolicyConfig::default();
    let side = FOOTPRINT.half_width_m + 0.25 + 0.05;
    // Creeping below the at-rest speed, and a little faster.
    for speed_mps in [0.015, -0.015, 0.03] {
        let mut policy = ObstaclePolicy::new();
        assert_eq!(
            policy.update(&settling_scene(0.0, speed_mps).inputs(), &config).verdict,
            Verdict::Go,
            "{speed_mps}: nobody near"
        );
        let mut scene = settling_scene(0.05, speed_mps);
        scene.tracks = vec![track(9, 0.3, side, 0.0, 0.0, 0.25)];
        scene.predictions = vec![against_the_side(9)];
        scene.predictions_at_resume = vec![against_the_side(9)];
        let status = policy.update(&scene.inputs(), &config);
        assert!(
            matches!(status.verdict, Verdict::Stop(StopCause::Collision { track_id: 9, .. })),
            "{speed_mps}: {status:?}"
        );
        assert_eq!(count(&status.events, |e| matches!(e, PolicyEvent::Stopped(_))), 1);
    }
}

#[test]
fn a_settling_vehicle_stops_for_a_person_predicted_to_walk_into_it() {
    let config = PolicyConfig::default();
    // Walking at it from the side at 1 m/s, 1.2 m out: contact in ~1 s,
    // within the time to react plus the decision lead (further off, the
    // vehicle is held at rest without a stop:
    // `at_rest_a_walkers_far_prediction_waits_and_a_near_one_stops`).
    let side = FOOTPRINT.half_width_m + 0.25 + 1.2;
    let scene = settling_scene(0.0, 0.0).with_tracks(vec![track(4, 0.3, side, 0.0, -1.0, 0.25)], 0.5);
    assert!(!scene.predictions_at_resume.is_empty(), "the scene predicts a contact");
    let verdict = ObstaclePolicy::new().update(&scene.inputs(), &config).verdict;
    assert!(
        matches!(verdict, Verdict::Stop(StopCause::Collision { track_id: 4, .. })),
        "{verdict:?}"
    );
}

#[test]
fn a_settled_vehicle_with_nobody_near_completes_and_a_parked_one_is_never_blocked() {
    let config = PolicyConfig::default();
    let mut policy = ObstaclePolicy::new();
    for i in 0..100 {
        let status = policy.update(&settling_scene(f64::from(i) * 0.05, 0.0).inputs(), &config);
        assert_eq!(status.verdict, Verdict::Go, "tick {i}");
        assert!(status.events.is_empty() && !status.stopped);
    }
    // Parked at its stop point with nothing to do: someone leaning on it
    // does not hold anything.
    let side = FOOTPRINT.half_width_m + 0.25 + 0.05;
    let mut parked = Scene::clear(5.0, 0.0);
    parked.wants_to_move = false;
    parked.tracks = vec![track(9, 0.3, side, 0.0, 0.0, 0.25)];
    parked.predictions_at_resume = vec![against_the_side(9)];
    assert_eq!(policy.update(&parked.inputs(), &config).verdict, Verdict::Go);
}

#[test]
fn a_stop_while_settling_holds_until_the_way_has_been_clear_for_resume_s() {
    let config = PolicyConfig::default();
    let mut policy = ObstaclePolicy::new();
    let mut scene = settling_scene(0.0, 0.01);
    scene.tracks = vec![track(9, 0.3, 1.0, 0.0, 0.0, 0.25)];
    scene.predictions_at_resume = vec![against_the_side(9)];
    assert!(policy.update(&scene.inputs(), &config).stopped);
    // The person steps away at t 1 s.
    let mut resumed_at = None;
    for i in 1..=100 {
        let t = f64::from(i) * 0.05;
        let mut scene = settling_scene(t, 0.0);
        if t < 1.0 {
            scene.predictions_at_resume = vec![against_the_side(9)];
        }
        let status = policy.update(&scene.inputs(), &config);
        if status.events.iter().any(|e| matches!(e, PolicyEvent::Resumed { .. })) {
            resumed_at = Some(t);
            break;
        }
        assert!(status.stopped, "t {t}");
    }
    let resumed_at = resumed_at.expect("resumes once clear");
    assert!(resumed_at >= 1.0 + config.resume_s - 1e-9, "{resumed_at}");
}

/// Driving, a coasting track that stood still when last seen (a standing
/// thing that dropped out of view beside the body) is stopped for like a
/// confirmed one; a coasting walker, whose velocity has gone stale, is not.
#[test]
fn a_standing_thing_out_of_view_is_stopped_for_while_driving() {
    let config = PolicyConfig::default();
    let side = FOOTPRINT.half_width_m + 0.25 + 0.2;
    for (still_s, stops) in [(10.0, true), (0.0, false)] {
        let mut thing = track(9, 0.5, side, 0.0, 0.0, 0.25);
        thing.status = TrackStatus::Coasting;
        thing.still_s = still_s;
        let mut driving = Scene::clear(0.0, 1.0);
        driving.tracks = vec![thing];
        driving.predictions = vec![prediction(9, 0.5)];
        let verdict = ObstaclePolicy::new().update(&driving.inputs(), &config).verdict;
        assert_eq!(
            matches!(verdict, Verdict::Stop(StopCause::Collision { track_id: 9, .. })),
            stops,
            "still {still_s} s: {verdict:?}"
        );
    }
}
