//! The preview-point PID tracker of seed 000 §2.4 (docs/architecture.md §Path tracking).
//!
//! Each step:
//! 1. rotate the path into the vehicle frame (seed 000 eq. 8: x forward,
//!    y right);
//! 2. put the preview point Q on the path a preview distance L beyond the
//!    vehicle's own projection (P's along-track position), in the driving
//!    direction: behind the vehicle when reversing; round a corner when the
//!    path turns;
//! 3. Δx, Δy are Q's coordinates, Δθ the path's heading at Q (its tangent on
//!    an arc) minus the vehicle's; a PID on Δy gives y', a PID on Δθ gives θ';
//! 4. steering = atan(y'/|Δx|) + θ' forwards, atan(y'/|Δx|) − θ' in reverse.
//!
//! Signs, checked rather than copied: a point to the right (y > 0) needs
//! right steering whichever way the vehicle drives (reversing, steering right
//! swings the rear to the right), which is why |Δx| is used; a heading that
//! must turn clockwise (Δθ > 0) needs right steering forwards and left
//! steering in reverse, the ± of step 4.
//!
//! Beyond the seed:
//! - On a curved path a vehicle that is exactly on it still sees Q off its
//!   axis and the path's heading at Q different from its own, and the seed's
//!   law would steer by gains rather than by the path (and hold a steady
//!   offset on an arc). So Δy and Δθ are taken relative to what a vehicle on
//!   the path at the projection would see, and the path's own curvature is
//!   fed forward: δ = ±atan(wheelbase·κ), κ read a little ahead
//!   (`feedforward_s`) so the steering has turned by the time the arc
//!   begins. On a straight both corrections are zero and the law is the
//!   seed's.
//! - The joint law assumes small errors. Far off the path or pointing away
//!   from it, its two bounded terms can cancel (the path is on the left, the
//!   heading error says turn right) and the vehicle drives on straight. So
//!   the tracker has a capture phase, with hysteresis: pure pursuit of Q, at
//!   full lock once Q is more than 90° off the driving direction, until
//!   heading and offset are small enough for the seed law.
//! - The command is limited in angle and in rate, as the steering gear is.
//!
//! Sources: docs/references.md §Seed 000.

use crate::control::pid::{PidGains, PidState, PidTerms};
use crate::geo::{Ned, wrap_pi};
use crate::guidance::path::{LegPath, PathProjection};

/// Smallest |Δx| used in atan(y'/|Δx|).
const MIN_DX_M: f64 = 0.1;
/// Capture starts beyond this heading error…
const CAPTURE_ENTER_RAD: f64 = 60.0 * std::f64::consts::PI / 180.0;
/// …and ends below this one (with the offset under half the preview).
const CAPTURE_EXIT_RAD: f64 = 20.0 * std::f64::consts::PI / 180.0;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackerConfig {
    /// Lateral PID: Δy (m) → y' (m).
    pub lateral: PidGains,
    /// Yaw PID: Δθ (rad) → θ' (rad).
    pub yaw: PidGains,
    /// Preview distance at standstill (`PVW_DIST`).
    pub preview_min_m: f64,
    /// Added preview per m/s of speed (`PVW_DIST_K`).
    pub preview_s: f64,
    /// How far ahead, in seconds of travel, the path's curvature is fed
    /// forward where a turn begins or tightens (`PVW_FF_TIME`)…
    pub feedforward_s: f64,
    /// …and where it ends or eases (`PVW_FF_EXIT`).
    pub feedforward_exit_s: f64,
    pub steer_max_rad: f64,
    /// Steering rate limit (`VEH_STEER_RATE`); 0 for none.
    pub steer_rate_rad_s: f64,
    /// For the curvature feed-forward and the capture phase's pure pursuit.
    pub wheelbase_m: f64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    Forward,
    Reverse,
}

impl Direction {
    /// +1 forwards, −1 in reverse.
    pub fn sign(self) -> f64 {
        match self {
            Direction::Forward => 1.0,
            Direction::Reverse => -1.0,
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TrackerState {
    lateral: PidState,
    yaw: PidState,
    capturing: bool,
    /// The last command, for the rate limit (None: no limit on the first).
    last_steer_rad: Option<f64>,
}

impl TrackerState {
    /// Forgets the PID history (a new leg). The steering command's rate
    /// limit carries on from where the wheels are.
    pub fn reset(&mut self) {
        *self = TrackerState {
            last_steer_rad: self.last_steer_rad,
            ..TrackerState::default()
        };
    }

    /// The wheels were centred (the vehicle rested with its steering at
    /// neutral): the rate limit starts from there.
    pub fn wheels_centred(&mut self) {
        self.last_steer_rad = Some(0.0);
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VehiclePose {
    pub position: Ned,
    pub yaw_rad: f64,
}

/// Everything one step computed, for telemetry and tuning.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TrackerStatus {
    pub preview_m: f64,
    /// Q in the local frame.
    pub preview_point: Ned,
    pub dx_m: f64,
    pub dy_m: f64,
    pub dyaw_rad: f64,
    /// Δy and Δθ relative to a vehicle on the path: what the PIDs act on.
    pub lateral_error_m: f64,
    pub yaw_error_rad: f64,
    pub lateral: PidTerms,
    pub yaw: PidTerms,
    /// The path's curvature fed forward as a steering angle.
    pub feedforward_rad: f64,
    /// Commanded steering angle after the limits, positive right.
    pub steer_rad: f64,
    /// Reference point's distance from the path, positive right of the
    /// direction of travel.
    pub crosstrack_m: f64,
    /// The heading the vehicle should have at Q.
    pub desired_yaw_rad: f64,
    /// Steering by pure pursuit while getting onto the path.
    pub capturing: bool,
}

/// Rotates a local-frame offset into the vehicle frame (seed 000 eq. 8).
pub fn to_vehicle_frame(offset_north_m: f64, offset_east_m: f64, yaw_rad: f64) -> (f64, f64) {
    let (s, c) = yaw_rad.sin_cos();
    (
        offset_north_m * c + offset_east_m * s,
        -offset_north_m * s + offset_east_m * c,
    )
}

fn relative(p: &Ned, from: &Ned, yaw_rad: f64) -> (f64, f64) {
    to_vehicle_frame(p.north_m - from.north_m, p.east_m - from.east_m, yaw_rad)
}

/// What the tracker is asked to follow: a leg's path, where the vehicle is
/// on it, and which way it drives.
#[derive(Clone, Copy, Debug)]
pub struct TrackInput<'a> {
    pub path: &'a LegPath,
    pub projection: PathProjection,
    pub direction: Direction,
    /// A longer preview than the speed schedule gives (the final approach
    /// to a stop, where heading matters more than millimetres sideways).
    pub min_preview_m: f64,
}

/// One tracker step.
pub fn track(
    config: &TrackerConfig,
    state: &mut TrackerState,
    pose: &VehiclePose,
    speed_mps: f64,
    input: TrackInput<'_>,
    dt_s: f64,
) -> TrackerStatus {
    let TrackInput {
        path,
        projection,
        direction,
        min_preview_m,
    } = input;
    let flip = match direction {
        Direction::Forward => 0.0,
        Direction::Reverse => std::f64::consts::PI,
    };
    let preview_m = (config.preview_min_m + config.preview_s * speed_mps.abs()).max(min_preview_m);
    // The reference point's place on the path; never behind the start, so
    // a vehicle waiting before the leg looks along it.
    let s_ref = projection.along_m.max(0.0);
    let s_q = s_ref + preview_m;
    let q = path.point_at(s_q);
    let (qx, qy) = relative(&q, &pose.position, pose.yaw_rad);
    let desired_yaw = wrap_pi(path.heading_at(s_q) + flip);
    let dyaw = wrap_pi(desired_yaw - pose.yaw_rad);

    // What a vehicle on the path at the reference point would see.
    let on_path = path.point_at(s_ref);
    let on_path_yaw = wrap_pi(path.heading_at(s_ref) + flip);
    let (_, qy_nominal) = relative(&q, &on_path, on_path_yaw);
    let dyaw_nominal = wrap_pi(desired_yaw - on_path_yaw);
    let lateral_error = qy - qy_nominal;
    let yaw_error = wrap_pi(dyaw - dyaw_nominal);

    update_capture(state, yaw_error, projection.crosstrack_m.abs(), preview_m);

    let feedforward = curvature_feedforward_rad(config, path, s_ref, speed_mps, direction);

    let (lateral, yaw, feedforward, demand) = if state.capturing {
        state.lateral.reset();
        state.yaw.reset();
        (
            PidTerms::default(),
            PidTerms::default(),
            0.0,
            pursuit_steer(config, qx, qy, direction),
        )
    } else {
        let lateral = state.lateral.update(&config.lateral, lateral_error, dt_s);
        let yaw = state.yaw.update(&config.yaw, yaw_error, dt_s);
        let lateral_angle = lateral.output().atan2(qx.abs().max(MIN_DX_M));
        let correction = match direction {
            Direction::Forward => lateral_angle + yaw.output(),
            Direction::Reverse => lateral_angle - yaw.output(),
        };
        (lateral, yaw, feedforward, feedforward + correction)
    };

    let steer = rate_limited_steer(config, state, demand, dt_s);

    TrackerStatus {
        preview_m,
        preview_point: q,
        dx_m: qx,
        dy_m: qy,
        dyaw_rad: dyaw,
        lateral_error_m: lateral_error,
        yaw_error_rad: yaw_error,
        lateral,
        yaw,
        feedforward_rad: feedforward,
        steer_rad: steer,
        crosstrack_m: projection.crosstrack_m,
        desired_yaw_rad: desired_yaw,
        capturing: state.capturing,
    }
}

/// Pure pursuit takes over far off the path (capture) until the vehicle is
/// back near it and pointing along it; the thresholds differ (hysteresis).
fn update_capture(state: &mut TrackerState, yaw_error: f64, offset: f64, preview_m: f64) {
    if state.capturing {
        state.capturing = !(yaw_error.abs() < CAPTURE_EXIT_RAD && offset < 0.5 * preview_m);
    } else {
        state.capturing = yaw_error.abs() > CAPTURE_ENTER_RAD || offset > 2.0 * preview_m;
    }
}

/// The path's curvature as a ramp the steering gear can follow: averaged
/// over the distance the wheels need to turn to the path's sharpest arc
/// at the rate limit, and centred ahead for the lags, so the vehicle
/// enters and leaves an arc half early, half late, and the error either
/// side cancels rather than all landing on the outside.
///
/// The lead differs where a turn is taken out: a skid-steer vehicle
/// unwinds a turn by speeding its inner wheels up while it also speeds up
/// out of the corner, which lags more than slowing them down into one.
/// Which lead applies follows from the two windows: if the farther one
/// sees the sharper curvature the turn is growing (`feedforward_s`),
/// otherwise it is easing (`feedforward_exit_s`).
fn curvature_feedforward_rad(
    config: &TrackerConfig,
    path: &LegPath,
    s_ref: f64,
    speed_mps: f64,
    direction: Direction,
) -> f64 {
    let speed = speed_mps.abs();
    let ramp_s = if config.steer_rate_rad_s > 0.0 {
        (config.wheelbase_m * path.max_curvature()).atan() / config.steer_rate_rad_s
    } else {
        0.0
    };
    let half = 0.5 * ramp_s * speed;
    let window = |lead_s: f64| {
        let centre = s_ref + lead_s * speed;
        path.mean_curvature(centre - half, centre + half)
    };
    let (growing, easing) = (window(config.feedforward_s), window(config.feedforward_exit_s));
    let (near, far) = if config.feedforward_s <= config.feedforward_exit_s {
        (growing, easing)
    } else {
        (easing, growing)
    };
    let curvature = if far.abs() > near.abs() { growing } else { easing };
    // Reversing, the yaw rate is v·tan δ / L with v < 0: the opposite lock
    // turns the direction of travel the same way.
    direction.sign() * (config.wheelbase_m * curvature).atan()
}

/// The steering demand within the lock and the steering rate limit (from
/// the last finite angle commanded).
fn rate_limited_steer(config: &TrackerConfig, state: &mut TrackerState, demand: f64, dt_s: f64) -> f64 {
    let mut steer = demand.clamp(-config.steer_max_rad, config.steer_max_rad);
    if let Some(last) = state.last_steer_rad
        && config.steer_rate_rad_s > 0.0
        && dt_s > 0.0
    {
        let step = config.steer_rate_rad_s * dt_s;
        steer = steer.clamp(last - step, last + step);
    }
    if steer.is_finite() {
        state.last_steer_rad = Some(steer);
    }
    steer
}

/// Pure pursuit of a point at (x, y) in the vehicle frame, in the direction
/// of travel: full lock once the point is more than 90° off that direction.
fn pursuit_steer(config: &TrackerConfig, x: f64, y: f64, direction: Direction) -> f64 {
    let ahead = x * direction.sign();
    let alpha = y.atan2(ahead);
    if alpha.abs() >= std::f64::consts::FRAC_PI_2 {
        return config.steer_max_rad.copysign(alpha);
    }
    let distance = x.hypot(y).max(MIN_DX_M);
    (2.0 * config.wheelbase_m * alpha.sin() / distance).atan()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::guidance::path::fit_corner;
    use std::f64::consts::FRAC_PI_2;

    fn config() -> TrackerConfig {
        TrackerConfig {
            lateral: PidGains {
                kp: 1.0,
                ki: 0.0,
                kd: 0.0,
                imax: 0.0,
            },
            yaw: PidGains {
                kp: 0.5,
                ki: 0.0,
                kd: 0.0,
                imax: 0.0,
            },
            preview_min_m: 2.0,
            preview_s: 0.5,
            feedforward_s: 0.0,
            feedforward_exit_s: 0.0,
            steer_max_rad: 30f64.to_radians(),
            steer_rate_rad_s: 0.0,
            wheelbase_m: 2.9,
        }
    }

    fn leg(from: (f64, f64), to: (f64, f64)) -> LegPath {
        LegPath::new(None, Ned::new(from.0, from.1), Ned::new(to.0, to.1), None)
    }

    fn step(
        cfg: &TrackerConfig,
        state: &mut TrackerState,
        pose: &VehiclePose,
        speed: f64,
        path: &LegPath,
        direction: Direction,
    ) -> TrackerStatus {
        let projection = path.project(&pose.position, 0);
        track(
            cfg,
            state,
            pose,
            speed,
            TrackInput {
                path,
                projection,
                direction,
                min_preview_m: 0.0,
            },
            0.02,
        )
    }

    #[test]
    fn vehicle_frame_rotation() {
        // Facing east, a point 1 m north is 1 m to the left.
        let (x, y) = to_vehicle_frame(1.0, 0.0, FRAC_PI_2);
        assert!(x.abs() < 1e-12 && (y + 1.0).abs() < 1e-12);
    }

    #[test]
    fn on_the_path_means_no_steering() {
        let pose = VehiclePose {
            position: Ned::new(10.0, 0.0),
            yaw_rad: 0.0,
        };
        let path = leg((0.0, 0.0), (100.0, 0.0));
        let st = step(
            &config(),
            &mut TrackerState::default(),
            &pose,
            2.0,
            &path,
            Direction::Forward,
        );
        assert_eq!(st.steer_rad, 0.0);
        assert_eq!(st.crosstrack_m, 0.0);
        assert!((st.dx_m - 3.0).abs() < 1e-12, "preview 2 m + 0.5 s × 2 m/s");
        // Reversing down the same line: Q behind, still no steering.
        let back = leg((100.0, 0.0), (0.0, 0.0));
        let st = step(
            &config(),
            &mut TrackerState::default(),
            &pose,
            -2.0,
            &back,
            Direction::Reverse,
        );
        assert_eq!(st.steer_rad, 0.0);
        assert!((st.dx_m + 3.0).abs() < 1e-12);
    }

    /// A vehicle exactly on an arc, on its tangent, steers the arc's own
    /// Ackermann angle and nothing else, forwards and in reverse; the
    /// heading asked for at Q is the arc's tangent there.
    #[test]
    fn on_an_arc_steers_its_curvature_with_the_tangent_yaw() {
        let corner = fit_corner(
            Ned::new(0.0, 0.0),
            Ned::new(30.0, 0.0),
            Ned::new(30.0, 30.0),
            8.0,
            5.0,
            30.0,
            15.0,
        )
        .unwrap();
        let arc = corner.arc;
        let cfg = config();
        let expected = (cfg.wheelbase_m / 8.0).atan();
        for direction in [Direction::Forward, Direction::Reverse] {
            // The same arc driven forwards (north then east) or, reversed,
            // its mirror image travelled backwards.
            let path = LegPath::new(Some(arc), arc.point_at(0.0), arc.end(), None);
            let at = 0.3 * arc.length_m();
            let flip = if direction == Direction::Reverse {
                std::f64::consts::PI
            } else {
                0.0
            };
            let pose = VehiclePose {
                position: arc.point_at(at),
                yaw_rad: wrap_pi(arc.heading_at(at) + flip),
            };
            let speed = direction.sign() * 1.0;
            let st = step(&cfg, &mut TrackerState::default(), &pose, speed, &path, direction);
            let case = format!("{direction:?}: {st:?}");
            assert!(st.crosstrack_m.abs() < 1e-9, "{case}");
            assert!(
                st.lateral_error_m.abs() < 1e-9 && st.yaw_error_rad.abs() < 1e-9,
                "{case}"
            );
            assert!((st.steer_rad - direction.sign() * expected).abs() < 1e-9, "{case}");
            let tangent_at_q = wrap_pi(arc.heading_at(at + st.preview_m) + flip);
            assert!(wrap_pi(st.desired_yaw_rad - tangent_at_q).abs() < 1e-9, "{case}");
            // Travel-right is the vehicle's right forwards, its left reversing.
            assert!(
                st.dy_m * direction.sign() > 0.0,
                "{case}: a right-hand arc curves off to the right"
            );
        }
    }

    #[test]
    fn left_of_the_path_steers_right_forwards_and_in_reverse() {
        //  path x=0 going north; vehicle 0.5 m west (left), facing north
        let pose = VehiclePose {
            position: Ned::new(10.0, -0.5),
            yaw_rad: 0.0,
        };
        let fwd = step(
            &config(),
            &mut TrackerState::default(),
            &pose,
            1.0,
            &leg((0.0, 0.0), (100.0, 0.0)),
            Direction::Forward,
        );
        assert!(fwd.steer_rad > 0.0);
        assert!((fwd.crosstrack_m + 0.5).abs() < 1e-12);
        // Reversing southwards along a south-going leg, still facing north:
        // the path is on the vehicle's right, so steer right.
        let rev = step(
            &config(),
            &mut TrackerState::default(),
            &pose,
            -1.0,
            &leg((100.0, 0.0), (0.0, 0.0)),
            Direction::Reverse,
        );
        assert!(rev.steer_rad > 0.0, "{rev:?}");
        assert!(rev.dx_m < 0.0, "preview point behind");
    }

    #[test]
    fn heading_error_sign_flips_in_reverse() {
        // On the path, heading rotated anticlockwise by 5°.
        let pose = VehiclePose {
            position: Ned::new(10.0, 0.0),
            yaw_rad: -5f64.to_radians(),
        };
        let cfg = TrackerConfig {
            lateral: PidGains::default(),
            ..config()
        };
        let fwd = step(
            &cfg,
            &mut TrackerState::default(),
            &pose,
            1.0,
            &leg((0.0, 0.0), (100.0, 0.0)),
            Direction::Forward,
        );
        assert!(fwd.steer_rad > 0.0);
        let rev = step(
            &cfg,
            &mut TrackerState::default(),
            &pose,
            -1.0,
            &leg((100.0, 0.0), (0.0, 0.0)),
            Direction::Reverse,
        );
        assert!(rev.steer_rad < 0.0);
    }

    #[test]
    fn steering_is_rate_limited() {
        let cfg = TrackerConfig {
            steer_rate_rad_s: 30f64.to_radians(),
            ..config()
        };
        let mut state = TrackerState::default();
        let path = leg((0.0, 0.0), (100.0, 0.0));
        let straight = VehiclePose {
            position: Ned::new(10.0, 0.0),
            yaw_rad: 0.0,
        };
        step(&cfg, &mut state, &straight, 1.0, &path, Direction::Forward);
        let far_left = VehiclePose {
            position: Ned::new(10.0, -2.0),
            yaw_rad: 0.0,
        };
        let st = step(&cfg, &mut state, &far_left, 1.0, &path, Direction::Forward);
        assert!((st.steer_rad - 0.6f64.to_radians()).abs() < 1e-12, "30°/s × 20 ms");
    }

    /// With a longer lead for easing, the feed-forward turns in where it
    /// did and unwinds earlier: at 1 m/s, 0.5 s more lead takes the turn
    /// out 0.5 m sooner.
    #[test]
    fn an_arc_is_taken_out_with_the_exit_lead() {
        let (a, b, c) = (Ned::new(0.0, 0.0), Ned::new(40.0, 0.0), Ned::new(40.0, 40.0));
        let corner = fit_corner(a, b, c, 8.0, 5.0, 40.0, 20.0).unwrap();
        let path = LegPath::new(None, a, b, Some((&corner, c)));
        let (arc_start, arc_end) = (path.piece_start_m(1), path.piece_start_m(2));
        let ff_at = |exit_s: f64, along_m: f64| {
            let cfg = TrackerConfig {
                feedforward_exit_s: exit_s,
                ..config()
            };
            curvature_feedforward_rad(&cfg, &path, along_m, 1.0, Direction::Forward)
        };
        let on_arc = (2.9f64 / 8.0).atan();
        for exit_s in [0.0, 0.5] {
            assert_eq!(
                ff_at(exit_s, arc_start - 0.01),
                0.0,
                "exit lead {exit_s}: not before the arc"
            );
            assert!((ff_at(exit_s, arc_start + 0.01) - on_arc).abs() < 1e-12);
        }
        assert!((ff_at(0.0, arc_end - 0.3) - on_arc).abs() < 1e-12);
        assert_eq!(ff_at(0.5, arc_end - 0.3), 0.0, "taken out 0.5 m early");
        assert_eq!(ff_at(0.0, arc_end + 0.01), 0.0);
    }

    /// Drives a kinematic bicycle (rear-axle reference) along `path`.
    fn drive(path: &LegPath, direction: Direction, start: VehiclePose, speed: f64, seconds: f64) -> Vec<(f64, f64)> {
        let (wheelbase, dt) = (2.9, 0.02);
        let mut pose = start;
        let mut state = TrackerState::default();
        let mut piece = 0;
        let mut trace = Vec::new();
        for _ in 0..(seconds / dt) as usize {
            let projection = path.project(&pose.position, piece);
            piece = projection.piece;
            let st = track(
                &config(),
                &mut state,
                &pose,
                speed,
                TrackInput {
                    path,
                    projection,
                    direction,
                    min_preview_m: 0.0,
                },
                dt,
            );
            trace.push((projection.along_m, st.crosstrack_m));
            pose.position.north_m += speed * pose.yaw_rad.cos() * dt;
            pose.position.east_m += speed * pose.yaw_rad.sin() * dt;
            pose.yaw_rad = wrap_pi(pose.yaw_rad + speed * st.steer_rad.tan() / wheelbase * dt);
        }
        trace
    }

    /// Closed loop on a kinematic bicycle: starting off the path and askew
    /// (a little, or pointing away from it), the tracker converges forwards
    /// and in reverse.
    #[test]
    fn converges_on_a_kinematic_bicycle() {
        let starts = [(1.0, 10.0), (-12.0, 163.0), (8.0, -120.0), (0.0, 180.0)];
        for (direction, (offset_m, yaw_deg)) in [Direction::Forward, Direction::Reverse]
            .into_iter()
            .flat_map(|d| starts.into_iter().map(move |s| (d, s)))
        {
            let (speed, path) = match direction {
                Direction::Forward => (1.5, leg((0.0, 0.0), (1000.0, 0.0))),
                Direction::Reverse => (-1.0, leg((0.0, 0.0), (-1000.0, 0.0))),
            };
            let start = VehiclePose {
                position: Ned::new(0.0, offset_m),
                yaw_rad: f64::to_radians(yaw_deg),
            };
            // Pointing away in reverse takes a wide loop: allow 100 s.
            let trace = drive(&path, direction, start, speed, 100.0);
            let worst_late = trace[4000..].iter().map(|(_, x)| x.abs()).fold(0.0, f64::max);
            let case = format!("{direction:?} from {offset_m} m, {yaw_deg}°");
            assert!(worst_late < 0.01, "{case}: crosstrack {worst_late} m after 80 s");
        }
    }

    /// Round a 90° corner with an 8 m arc, forwards and in reverse: once on
    /// the arc, the error stays at millimetres (the arc's curvature is fed
    /// forward, the PIDs only correct).
    #[test]
    fn follows_a_corner_arc_forwards_and_in_reverse() {
        let (a, b, c) = (Ned::new(0.0, 0.0), Ned::new(40.0, 0.0), Ned::new(40.0, 40.0));
        let corner = fit_corner(a, b, c, 8.0, 5.0, 40.0, 20.0).unwrap();
        let first = LegPath::new(None, a, b, Some((&corner, c)));
        let arc_start = first.piece_start_m(1);
        let arc_end = arc_start + corner.arc.length_m();
        for (direction, speed, yaw) in [
            (Direction::Forward, 1.0, 0.0),
            (Direction::Reverse, -0.5, std::f64::consts::PI),
        ] {
            let start = VehiclePose {
                position: a,
                yaw_rad: yaw,
            };
            let trace = drive(&first, direction, start, speed, (arc_end + 10.0) / speed.abs());
            let on_arc: Vec<f64> = trace
                .iter()
                .filter(|(s, _)| *s > arc_start + 3.0 && *s < arc_end)
                .map(|(_, x)| x.abs())
                .collect();
            assert!(!on_arc.is_empty(), "{direction:?}: never reached the arc");
            let worst = on_arc.iter().copied().fold(0.0, f64::max);
            assert!(worst < 0.05, "{direction:?}: {worst} m on the arc");
            let (last_s, last_x) = *trace.last().unwrap();
            assert!(
                last_s > arc_end + 5.0 && last_x.abs() < 0.01,
                "{direction:?}: ends {last_s}, {last_x}"
            );
        }
    }
}
