//! The path a vehicle off its leg will really drive back onto it: the
//! preview tracker run forward from the vehicle's pose on a kinematic
//! bicycle, for obstacle protection (what the outline sweeps while it
//! rejoins).
//!
//! # Model
//! The reference point (rear axle centre) moves along the direction of
//! travel (the body's heading, plus a half turn in reverse), which turns at
//! the curvature κ = ±tan δ / wheelbase of the steering angle δ (+ forwards,
//! − in reverse: reversing with right lock swings the direction of travel
//! left, as in the tracker's sign rules), the same for both drive trains
//! (a skid-steer vehicle turns its steering command into that curvature).
//! Every `step_m` of path the tracker is asked for δ with the state the
//! navigator has now (its PIDs, capture phase and the wheels' last angle,
//! so the rate limit starts from where they are), and δ is held over the
//! step: the pose is advanced exactly along that step's arc. So the
//! simulated path's curvature is never more than tan(`steer_max`) /
//! wheelbase, which bounds how far the outline moves between two poses
//! (the swept path's sampling bound).
//!
//! The speed goes from the speed now to the speed asked for at the
//! acceleration given (the tracker's preview and the steering rate per
//! metre depend on it); the step's time is its length over that speed
//! (at least [`MIN_SPEED_MPS`], so a start from rest does not let the
//! steering turn fully within a step). What the model leaves out (the
//! steering gear's lag, the speed schedule slowing for arcs, the tracker
//! running every tick rather than every step) are differences of
//! centimetres over the few metres a rejoin takes; they are within the
//! margin the obstacle checks keep.

use crate::geo::{Ned, wrap_pi};
use crate::guidance::path::LegPath;
use crate::guidance::tracker::{Direction, TrackInput, TrackerConfig, TrackerState, VehiclePose, track};

/// Speed used for a step's time when the vehicle starts from rest, m/s.
pub const MIN_SPEED_MPS: f64 = 0.1;

/// The leg the vehicle rejoins and how it drives it.
#[derive(Clone, Copy, Debug)]
pub struct RejoinLeg<'a> {
    pub path: &'a LegPath,
    /// The piece the vehicle was last projected onto.
    pub piece: usize,
    pub direction: Direction,
    /// A stop leg's end: the vehicle is at rest there.
    pub stop: bool,
    /// The tracker's preview at least (the approach to a stop).
    pub min_preview_m: f64,
}

/// How the speed changes while rejoining (magnitudes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RejoinSpeed {
    pub from_mps: f64,
    pub to_mps: f64,
    pub accel_mps2: f64,
}

/// The largest curvature of the simulated path (1/m): full lock.
pub fn max_curvature(config: &TrackerConfig) -> f64 {
    if config.wheelbase_m > 0.0 {
        (config.steer_max_rad.abs().min(1.5).tan() / config.wheelbase_m).abs()
    } else {
        0.0
    }
}

/// Appends to `out` the poses every `step_m` along the path the tracker
/// drives from `start` for `length_m` (the first is `start`), stopping early
/// at a stop leg's end. `state` is a copy of the navigator's tracker state.
pub fn rejoin_poses(
    config: &TrackerConfig,
    mut state: TrackerState,
    leg: &RejoinLeg,
    start: VehiclePose,
    speed: RejoinSpeed,
    (step_m, length_m): (f64, f64),
    out: &mut Vec<VehiclePose>,
) {
    out.push(start);
    if !(step_m > 0.0 && length_m.is_finite() && config.wheelbase_m > 0.0) {
        return;
    }
    let steps = (length_m / step_m).ceil() as usize;
    let mut pose = start;
    let mut piece = leg.piece;
    let mut speed_mps = speed.from_mps.abs();
    for _ in 0..steps {
        let projection = leg.path.project(&pose.position, piece);
        piece = projection.piece;
        if leg.stop && projection.along_m >= leg.path.end_m() {
            return;
        }
        let step_speed = speed_mps.max(MIN_SPEED_MPS);
        let dt_s = step_m / step_speed;
        let status = track(
            config,
            &mut state,
            &pose,
            step_speed * leg.direction.sign(),
            TrackInput {
                path: leg.path,
                projection,
                direction: leg.direction,
                min_preview_m: leg.min_preview_m,
            },
            dt_s,
        );
        let curvature = leg.direction.sign() * status.steer_rad.tan() / config.wheelbase_m;
        pose = advance(&pose, leg.direction, curvature, step_m);
        out.push(pose);
        speed_mps = toward(speed_mps, speed.to_mps.abs(), speed.accel_mps2, step_m);
    }
}

/// The pose after `s` metres of travel at `curvature` (of the direction of
/// travel, positive turning right): along the arc's chord.
fn advance(pose: &VehiclePose, direction: Direction, curvature: f64, s: f64) -> VehiclePose {
    let flip = match direction {
        Direction::Forward => 0.0,
        Direction::Reverse => std::f64::consts::PI,
    };
    let turned = if curvature.is_finite() { curvature * s } else { 0.0 };
    let chord = if turned.abs() < 1e-9 {
        s
    } else {
        2.0 * (0.5 * turned).sin() / curvature
    };
    let mid = pose.yaw_rad + flip + 0.5 * turned;
    VehiclePose {
        position: Ned::new(
            pose.position.north_m + chord * mid.cos(),
            pose.position.east_m + chord * mid.sin(),
        ),
        yaw_rad: wrap_pi(pose.yaw_rad + turned),
    }
}

/// The speed after `s` metres accelerating (or slowing) towards `to` at
/// `accel` (at once without a positive one).
fn toward(from: f64, to: f64, accel: f64, s: f64) -> f64 {
    if accel <= 0.0 {
        return to;
    }
    let reach = (from * from + 2.0 * accel * s).sqrt();
    if from < to {
        reach.min(to)
    } else {
        (from * from - 2.0 * accel * s).max(0.0).sqrt().max(to)
    }
}

/// The tracker at the parameters' defaults (PVW_*, VEH_STEER_*,
/// VEH_WHEELBASE), for tests here and of the swept rejoin path.
#[cfg(test)]
pub fn default_tracker_config() -> TrackerConfig {
    use crate::control::pid::PidGains;
    TrackerConfig {
        lateral: PidGains {
            kp: 2.0,
            ki: 0.0,
            kd: 0.0,
            imax: 0.5,
        },
        yaw: PidGains {
            kp: 0.8,
            ki: 0.0,
            kd: 0.0,
            imax: 0.2,
        },
        preview_min_m: 2.0,
        preview_s: 0.5,
        feedforward_s: 0.12,
        feedforward_exit_s: 0.12,
        steer_max_rad: 30f64.to_radians(),
        steer_rate_rad_s: 30f64.to_radians(),
        wheelbase_m: 2.9,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config() -> TrackerConfig {
        default_tracker_config()
    }

    fn run(direction: Direction, start: VehiclePose, to: Ned) -> Vec<VehiclePose> {
        let path = LegPath::new(None, Ned::new(0.0, 0.0), to, None);
        let leg = RejoinLeg {
            path: &path,
            piece: 0,
            direction,
            stop: false,
            min_preview_m: 0.0,
        };
        let speed = RejoinSpeed {
            from_mps: 0.0,
            to_mps: 1.0,
            accel_mps2: 0.5,
        };
        let mut out = Vec::new();
        rejoin_poses(
            &config(),
            TrackerState::default(),
            &leg,
            start,
            speed,
            (0.05, 30.0),
            &mut out,
        );
        out
    }

    /// Two metres beside a straight leg, pointing along it: the simulated
    /// vehicle turns onto it (forwards and in reverse), its curvature never
    /// beyond full lock, and ends on the leg pointing along it.
    #[test]
    fn rejoins_a_straight_leg_forwards_and_in_reverse() {
        let lock = max_curvature(&config());
        for (direction, yaw_deg, to) in [
            (Direction::Forward, 0.0, Ned::new(100.0, 0.0)),
            (Direction::Reverse, 180.0, Ned::new(100.0, 0.0)),
        ] {
            let start = VehiclePose {
                position: Ned::new(0.0, 2.0),
                yaw_rad: f64::to_radians(yaw_deg),
            };
            let poses = run(direction, start, to);
            assert_eq!(poses.len(), 601);
            let last = poses.last().unwrap();
            assert!(last.position.east_m.abs() < 0.05, "{direction:?}: ends {last:?}");
            assert!(last.position.north_m > 25.0, "{direction:?}: ends {last:?}");
            let along: f64 = if direction == Direction::Forward { 0.0 } else { 180.0 };
            assert!(wrap_pi(last.yaw_rad - along.to_radians()).abs() < 0.02);
            for pair in poses.windows(2) {
                let turned = wrap_pi(pair[1].yaw_rad - pair[0].yaw_rad).abs();
                assert!(turned <= lock * 0.05 + 1e-9, "{direction:?}: turned {turned} in a step");
                let moved = pair[0].position.distance_to(&pair[1].position);
                assert!((moved - 0.05).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn a_stop_leg_ends_the_poses_at_its_end() {
        let path = LegPath::new(None, Ned::new(0.0, 0.0), Ned::new(3.0, 0.0), None);
        let leg = RejoinLeg {
            path: &path,
            piece: 0,
            direction: Direction::Forward,
            stop: true,
            min_preview_m: 0.0,
        };
        let speed = RejoinSpeed {
            from_mps: 1.0,
            to_mps: 1.0,
            accel_mps2: 0.5,
        };
        let start = VehiclePose {
            position: Ned::new(0.0, 0.5),
            yaw_rad: 0.0,
        };
        let mut out = Vec::new();
        rejoin_poses(
            &config(),
            TrackerState::default(),
            &leg,
            start,
            speed,
            (0.1, 10.0),
            &mut out,
        );
        let last = out.last().unwrap();
        assert!(out.len() < 40, "{} poses", out.len());
        assert!((last.position.north_m - 3.0).abs() < 0.15, "{last:?}");
    }

    #[test]
    fn speed_ramps_both_ways() {
        assert!((toward(0.0, 1.0, 0.5, 1.0) - 1.0).abs() < 1e-12);
        assert!((toward(0.0, 2.0, 0.5, 1.0) - 1.0).abs() < 1e-12);
        assert!((toward(2.0, 1.0, 0.5, 1.0) - 3f64.sqrt()).abs() < 1e-12);
        assert_eq!(toward(0.3, 1.0, 0.0, 0.1), 1.0);
    }
}
