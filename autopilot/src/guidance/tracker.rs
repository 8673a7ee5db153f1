//! The preview-point PID tracker of seed 000 §2.4 (DESIGN §5.3).
//!
//! Each step:
//! 1. rotate the path into the vehicle frame (seed 000 eq. 8: x forward,
//!    y right);
//! 2. put the preview point P at distance L along the driving direction
//!    (behind the vehicle when reversing), and find Q, the point of the path
//!    on the line through P perpendicular to the vehicle's x axis;
//! 3. Δx, Δy are Q's coordinates, Δθ the path's heading minus the vehicle's;
//!    a PID on Δy gives y', a PID on Δθ gives θ';
//! 4. steering = atan(y'/|Δx|) + θ' forwards, atan(y'/|Δx|) − θ' in reverse.
//!
//! Signs, checked rather than copied: a point to the right (y > 0) needs
//! right steering whichever way the vehicle drives (reversing, steering right
//! swings the rear to the right), which is why |Δx| is used; a heading that
//! must turn clockwise (Δθ > 0) needs right steering forwards and left
//! steering in reverse, the ± of step 4.
//!
//! Beyond the seed: the joint law assumes small errors. Far off the path
//! or pointing away from it, its two bounded terms can cancel (the path is
//! on the left, the heading error says turn right) and the vehicle drives on
//! straight. So the tracker has a capture phase, with hysteresis: pure
//! pursuit of a point L ahead of the vehicle's projection on the path, at
//! full lock once that point is more than 90° off, until heading and offset
//! are small enough for the seed law. Q is also never taken behind the
//! vehicle's own projection on the path.

use crate::control::pid::{PidGains, PidState, PidTerms};
use crate::geo::{Ned, wrap_pi};
use crate::guidance::path::Segment;

/// Below this |u·x| the path runs almost across the vehicle and the
/// perpendicular through P meets it far away: use P's projection instead.
const MIN_PATH_ALONG_AXIS: f64 = 0.1;
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
    pub steer_max_rad: f64,
    /// For the capture phase's pure pursuit (tan δ = 2·L_wb·sin α / d).
    pub wheelbase_m: f64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    Forward,
    Reverse,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TrackerState {
    lateral: PidState,
    yaw: PidState,
    capturing: bool,
}

impl TrackerState {
    pub fn reset(&mut self) {
        *self = TrackerState::default();
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
    pub lateral: PidTerms,
    pub yaw: PidTerms,
    /// Commanded steering angle after the limit, positive right.
    pub steer_rad: f64,
    /// Reference point's distance from the path, positive right of it.
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

/// One tracker step along a straight leg.
pub fn track_segment(
    config: &TrackerConfig,
    state: &mut TrackerState,
    pose: &VehiclePose,
    speed_mps: f64,
    segment: &Segment,
    direction: Direction,
    dt_s: f64,
) -> TrackerStatus {
    let preview_m = config.preview_min_m + config.preview_s * speed_mps.abs();
    let px = match direction {
        Direction::Forward => preview_m,
        Direction::Reverse => -preview_m,
    };

    let projection = segment.project(&pose.position);
    let (ax, ay) = to_vehicle_frame(
        segment.start.north_m - pose.position.north_m,
        segment.start.east_m - pose.position.east_m,
        pose.yaw_rad,
    );
    let (un, ue) = segment.direction();
    let (ux, uy) = to_vehicle_frame(un, ue, pose.yaw_rad);
    // Q: where the perpendicular through P meets the path (step 2), unless
    // that is nearly parallel to the path or behind the vehicle's own
    // projection; then the point L further along the path.
    let carrot_along = projection.along_m.max(0.0) + preview_m;
    let along_q = if ux.abs() >= MIN_PATH_ALONG_AXIS {
        let s = (px - ax) / ux;
        if s >= projection.along_m { s } else { carrot_along }
    } else {
        carrot_along
    };
    let (qx, qy) = (ax + along_q * ux, ay + along_q * uy);

    let path_yaw = segment.bearing_rad();
    let desired_yaw = match direction {
        Direction::Forward => path_yaw,
        Direction::Reverse => wrap_pi(path_yaw + std::f64::consts::PI),
    };
    let dyaw = wrap_pi(desired_yaw - pose.yaw_rad);

    let offset = projection.crosstrack_m.abs();
    if state.capturing {
        state.capturing = !(dyaw.abs() < CAPTURE_EXIT_RAD && offset < 0.5 * preview_m);
    } else {
        state.capturing = dyaw.abs() > CAPTURE_ENTER_RAD || offset > 2.0 * preview_m;
    }

    let (lateral, yaw, steer) = if state.capturing {
        state.lateral.reset();
        state.yaw.reset();
        let (cx, cy) = to_vehicle_frame(
            segment.point_at(carrot_along).north_m - pose.position.north_m,
            segment.point_at(carrot_along).east_m - pose.position.east_m,
            pose.yaw_rad,
        );
        (
            PidTerms::default(),
            PidTerms::default(),
            pursuit_steer(config, cx, cy, direction),
        )
    } else {
        let lateral = state.lateral.update(&config.lateral, qy, dt_s);
        let yaw = state.yaw.update(&config.yaw, dyaw, dt_s);
        let lateral_angle = lateral.output().atan2(qx.abs().max(MIN_DX_M));
        let steer = match direction {
            Direction::Forward => lateral_angle + yaw.output(),
            Direction::Reverse => lateral_angle - yaw.output(),
        };
        (lateral, yaw, steer)
    };

    TrackerStatus {
        preview_m,
        preview_point: segment.point_at(along_q),
        dx_m: qx,
        dy_m: qy,
        dyaw_rad: dyaw,
        lateral,
        yaw,
        steer_rad: steer.clamp(-config.steer_max_rad, config.steer_max_rad),
        crosstrack_m: projection.crosstrack_m,
        desired_yaw_rad: desired_yaw,
        capturing: state.capturing,
    }
}

/// Pure pursuit of a point at (x, y) in the vehicle frame, in the direction
/// of travel: full lock once the point is more than 90° off that direction.
fn pursuit_steer(config: &TrackerConfig, x: f64, y: f64, direction: Direction) -> f64 {
    let ahead = match direction {
        Direction::Forward => x,
        Direction::Reverse => -x,
    };
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
            steer_max_rad: 30f64.to_radians(),
            wheelbase_m: 2.9,
        }
    }

    fn north_leg() -> Segment {
        Segment::new(Ned::new(0.0, 0.0), Ned::new(100.0, 0.0))
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
        let st = track_segment(
            &config(),
            &mut TrackerState::default(),
            &pose,
            2.0,
            &north_leg(),
            Direction::Forward,
            0.02,
        );
        assert_eq!(st.steer_rad, 0.0);
        assert_eq!(st.crosstrack_m, 0.0);
        assert!((st.dx_m - 3.0).abs() < 1e-12, "preview 2 m + 0.5 s × 2 m/s");
    }

    #[test]
    fn left_of_the_path_steers_right_forwards_and_in_reverse() {
        //  path x=0 going north; vehicle 0.5 m west (left), facing north
        let pose = VehiclePose {
            position: Ned::new(10.0, -0.5),
            yaw_rad: 0.0,
        };
        let fwd = track_segment(
            &config(),
            &mut TrackerState::default(),
            &pose,
            1.0,
            &north_leg(),
            Direction::Forward,
            0.02,
        );
        assert!(fwd.steer_rad > 0.0);
        assert!((fwd.crosstrack_m + 0.5).abs() < 1e-12);
        // Reversing southwards along a south-going leg, still facing north:
        // the path is on the vehicle's right, so steer right.
        let south_leg = Segment::new(Ned::new(100.0, 0.0), Ned::new(0.0, 0.0));
        let rev = track_segment(
            &config(),
            &mut TrackerState::default(),
            &pose,
            -1.0,
            &south_leg,
            Direction::Reverse,
            0.02,
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
        let fwd = track_segment(
            &cfg,
            &mut TrackerState::default(),
            &pose,
            1.0,
            &north_leg(),
            Direction::Forward,
            0.02,
        );
        assert!(fwd.steer_rad > 0.0);
        let south_leg = Segment::new(Ned::new(100.0, 0.0), Ned::new(0.0, 0.0));
        let rev = track_segment(
            &cfg,
            &mut TrackerState::default(),
            &pose,
            -1.0,
            &south_leg,
            Direction::Reverse,
            0.02,
        );
        assert!(rev.steer_rad < 0.0);
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
            let (speed, leg) = match direction {
                Direction::Forward => (1.5, Segment::new(Ned::new(0.0, 0.0), Ned::new(1000.0, 0.0))),
                Direction::Reverse => (-1.0, Segment::new(Ned::new(0.0, 0.0), Ned::new(-1000.0, 0.0))),
            };
            let mut pose = VehiclePose {
                position: Ned::new(0.0, offset_m),
                yaw_rad: f64::to_radians(yaw_deg),
            };
            let mut state = TrackerState::default();
            let (wheelbase, dt) = (2.9, 0.02);
            let mut worst_late = 0.0f64;
            // Pointing away in reverse takes a wide loop: allow 100 s.
            for k in 0..5000 {
                let st = track_segment(&config(), &mut state, &pose, speed, &leg, direction, dt);
                pose.position.north_m += speed * pose.yaw_rad.cos() * dt;
                pose.position.east_m += speed * pose.yaw_rad.sin() * dt;
                pose.yaw_rad = wrap_pi(pose.yaw_rad + speed * st.steer_rad.tan() / wheelbase * dt);
                if k > 4000 {
                    worst_late = worst_late.max(st.crosstrack_m.abs());
                }
            }
            let case = format!("{direction:?} from {offset_m} m, {yaw_deg}°");
            assert!(worst_late < 0.01, "{case}: crosstrack {worst_late} m after 80 s");
            assert!(pose.yaw_rad.abs() < 0.01, "{case}: yaw {}", pose.yaw_rad);
        }
    }
}
