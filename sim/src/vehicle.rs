//! Vehicle kinematics: the bicycle model at the rear axle (Ackermann) and the
//! unicycle at the axle centre (differential), integrated per sub-step along
//! an exact circular arc, so a constant-curvature turn has no integration
//! error at all.

use std::f64::consts::PI;

use super::actuator::Drive;
use super::{AckermannConfig, ActuatorDemand, DifferentialConfig, VehicleModel};

/// The true state of the vehicle (at its reference point).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VehicleTruth {
    pub north_m: f64,
    pub east_m: f64,
    /// 0 = north, clockwise, in [-π, π).
    pub yaw_rad: f64,
    /// Signed: negative when reversing.
    pub speed_mps: f64,
    pub yaw_rate_rad_s: f64,
    /// Positive = right. Always 0 for a differential vehicle.
    pub steer_rad: f64,
    /// Wheel speeds (the rear wheels of an Ackermann vehicle).
    pub left_mps: f64,
    pub right_mps: f64,
}

/// Speeds that load the battery over one sub-step (magnitudes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Motion {
    pub speed_mps: f64,
    pub accel_mps2: f64,
}

/// Wraps into [-π, π); leaves in-range angles untouched (no rounding drift).
pub(crate) fn wrap_pi(angle_rad: f64) -> f64 {
    if (-PI..PI).contains(&angle_rad) {
        return angle_rad;
    }
    let wrapped = (angle_rad + PI).rem_euclid(2.0 * PI) - PI;
    if wrapped >= PI { wrapped - 2.0 * PI } else { wrapped }
}

fn unit(x: f64) -> f64 {
    if x.is_nan() { 0.0 } else { x.clamp(-1.0, 1.0) }
}

/// Advance `truth` by `h_s` seconds under `demand`.
pub(crate) fn step(model: &VehicleModel, truth: &mut VehicleTruth, demand: &ActuatorDemand, h_s: f64) -> Motion {
    match model {
        VehicleModel::Ackermann(cfg) => step_ackermann(cfg, truth, demand, h_s),
        VehicleModel::Differential(cfg) => step_differential(cfg, truth, demand, h_s),
    }
}

fn step_ackermann(cfg: &AckermannConfig, truth: &mut VehicleTruth, demand: &ActuatorDemand, h_s: f64) -> Motion {
    let (steering, throttle) = match *demand {
        ActuatorDemand::Ackermann { steering, throttle } => (unit(steering), unit(throttle)),
        // The inverse of the skid-steer mix below.
        ActuatorDemand::Differential { left, right } => {
            let (left, right) = (unit(left), unit(right));
            ((left - right) / 2.0, (left + right) / 2.0)
        }
    };
    let max_steer_rad = cfg.max_steer_rad.abs();
    let steer_cmd_rad = steering * max_steer_rad;
    let speed_cmd_mps = throttle * cfg.speed_max_mps.abs();
    let drive = Drive {
        tau_s: cfg.speed_tau_s,
        accel_max_mps2: cfg.accel_max_mps2,
        brake_max_mps2: cfg.brake_max_mps2,
    };

    let (steer0, v0) = (truth.steer_rad, truth.speed_mps);
    let steer1 = super::actuator::lag_limited(steer0, steer_cmd_rad, cfg.steer_tau_s, cfg.steer_rate_rad_s, h_s)
        .clamp(-max_steer_rad, max_steer_rad);
    let v1 = drive.advance(v0, speed_cmd_mps, h_s);
    let yaw_rate = |v: f64, steer: f64| v * steer.tan() / cfg.wheelbase_m;
    let (w0, w1) = (yaw_rate(v0, steer0), yaw_rate(v1, steer1));

    advance_pose(truth, h_s * (v0 + v1) / 2.0, h_s * (w0 + w1) / 2.0);
    truth.speed_mps = v1;
    truth.steer_rad = steer1;
    truth.yaw_rate_rad_s = w1;
    truth.left_mps = v1 + w1 * cfg.track_m / 2.0;
    truth.right_mps = v1 - w1 * cfg.track_m / 2.0;
    Motion {
        speed_mps: v1.abs(),
        accel_mps2: if h_s > 0.0 { (v1 - v0).abs() / h_s } else { 0.0 },
    }
}

fn step_differential(cfg: &DifferentialConfig, truth: &mut VehicleTruth, demand: &ActuatorDemand, h_s: f64) -> Motion {
    let (left, right) = match *demand {
        ActuatorDemand::Differential { left, right } => (unit(left), unit(right)),
        // Skid-steer mix: steering right speeds up the left wheel.
        ActuatorDemand::Ackermann { steering, throttle } => {
            let (steering, throttle) = (unit(steering), unit(throttle));
            (
                (throttle + steering).clamp(-1.0, 1.0),
                (throttle - steering).clamp(-1.0, 1.0),
            )
        }
    };
    let max_mps = cfg.wheel_speed_max_mps.abs();
    let drive = Drive {
        tau_s: cfg.wheel_tau_s,
        accel_max_mps2: cfg.accel_max_mps2,
        brake_max_mps2: cfg.brake_max_mps2,
    };
    let (l0, r0) = (truth.left_mps, truth.right_mps);
    let l1 = drive.advance(l0, left * max_mps, h_s);
    let r1 = drive.advance(r0, right * max_mps, h_s);
    let (v0, v1) = ((l0 + r0) / 2.0, (l1 + r1) / 2.0);
    let (w0, w1) = ((l0 - r0) / cfg.track_m, (l1 - r1) / cfg.track_m);

    advance_pose(truth, h_s * (v0 + v1) / 2.0, h_s * (w0 + w1) / 2.0);
    truth.speed_mps = v1;
    truth.steer_rad = 0.0;
    truth.yaw_rate_rad_s = w1;
    truth.left_mps = l1;
    truth.right_mps = r1;
    Motion {
        speed_mps: (l1.abs() + r1.abs()) / 2.0,
        accel_mps2: if h_s > 0.0 {
            ((l1 - l0).abs() + (r1 - r0).abs()) / (2.0 * h_s)
        } else {
            0.0
        },
    }
}

/// Move along a circular arc of length `distance_m` turning by `dyaw_rad`:
/// the chord has length distance·sinc(dyaw/2) and points along the mean yaw.
/// Exact for constant curvature, and well-defined when turning on the spot.
fn advance_pose(truth: &mut VehicleTruth, distance_m: f64, dyaw_rad: f64) {
    let half = dyaw_rad / 2.0;
    let sinc = if half.abs() < 1e-4 {
        1.0 - half * half / 6.0
    } else {
        half.sin() / half
    };
    let chord_m = distance_m * sinc;
    let mid_yaw = truth.yaw_rad + half;
    truth.north_m += chord_m * mid_yaw.cos();
    truth.east_m += chord_m * mid_yaw.sin();
    truth.yaw_rad = wrap_pi(truth.yaw_rad + dyaw_rad);
}

/// Carry the motion over to a new model as far as it can express it, within
/// its limits, so a runtime model change is not a jolt.
pub(crate) fn adapt(model: &VehicleModel, truth: &mut VehicleTruth) {
    let v = truth.speed_mps;
    let w = truth.yaw_rate_rad_s;
    match model {
        VehicleModel::Ackermann(cfg) => {
            let max_v = cfg.speed_max_mps.abs();
            let max_steer = cfg.max_steer_rad.abs();
            truth.speed_mps = v.clamp(-max_v, max_v);
            truth.steer_rad = if v.abs() > 1e-9 {
                (w * cfg.wheelbase_m / v).atan().clamp(-max_steer, max_steer)
            } else {
                truth.steer_rad.clamp(-max_steer, max_steer)
            };
            truth.yaw_rate_rad_s = truth.speed_mps * truth.steer_rad.tan() / cfg.wheelbase_m;
            truth.left_mps = truth.speed_mps + truth.yaw_rate_rad_s * cfg.track_m / 2.0;
            truth.right_mps = truth.speed_mps - truth.yaw_rate_rad_s * cfg.track_m / 2.0;
        }
        VehicleModel::Differential(cfg) => {
            let max_v = cfg.wheel_speed_max_mps.abs();
            truth.left_mps = (v + w * cfg.track_m / 2.0).clamp(-max_v, max_v);
            truth.right_mps = (v - w * cfg.track_m / 2.0).clamp(-max_v, max_v);
            truth.speed_mps = (truth.left_mps + truth.right_mps) / 2.0;
            truth.yaw_rate_rad_s = (truth.left_mps - truth.right_mps) / cfg.track_m;
            truth.steer_rad = 0.0;
        }
    }
}
