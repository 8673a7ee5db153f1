//! From normalised steering/throttle to what the drive train takes.
//!
//! Ackermann: centre steering and throttle, and seed 002's kinematics for
//! vehicles that steer and drive each wheel: left and right front wheel
//! angles and left and right rear wheel throttles (the electronic
//! differential). Differential (skid steering): left and right. Which output
//! channel carries which, and with what pulse range, is `SERVOn_*`
//! ([`super::servo`]); the fixed-range helpers here are the RC input scale
//! and the defaults' old 1000–2000 µs layout.
//!
//! Sources: docs/references.md §Seed 002.

use vehicle_types::ActuatorDemand;

use super::ackermann::{AckermannGeometry, front_wheel_angles, rear_wheel_speeds};

/// The drive train Furrow controls (`FRAME_TYPE`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DriveTrain {
    Ackermann,
    Differential,
}

const PWM_MIN_US: f64 = 1000.0;
const PWM_TRIM_US: f64 = 1500.0;
const PWM_MAX_US: f64 = 2000.0;

/// A normalised value in [-1, 1] as a pulse width around 1500 µs.
pub fn to_pwm_us(value: f64) -> u16 {
    let v = if value.is_finite() { value.clamp(-1.0, 1.0) } else { 0.0 };
    (PWM_TRIM_US + v * (PWM_MAX_US - PWM_TRIM_US))
        .clamp(PWM_MIN_US, PWM_MAX_US)
        .round() as u16
}

/// A pulse width as a normalised value (RC override input).
pub fn from_pwm_us(pwm_us: u16) -> f64 {
    ((f64::from(pwm_us) - PWM_TRIM_US) / (PWM_MAX_US - PWM_TRIM_US)).clamp(-1.0, 1.0)
}

/// Steering/throttle for Ackermann; left/right mixing for skid steering the
/// way ArduPilot mixes manual input (left = throttle + steering).
pub fn mix(drive: DriveTrain, steering: f64, throttle: f64) -> ActuatorDemand {
    let steering = if steering.is_finite() {
        steering.clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let throttle = if throttle.is_finite() {
        throttle.clamp(-1.0, 1.0)
    } else {
        0.0
    };
    match drive {
        DriveTrain::Ackermann => ActuatorDemand::Ackermann { steering, throttle },
        DriveTrain::Differential => {
            let left = throttle + steering;
            let right = throttle - steering;
            // Keep the turn when one side saturates.
            let scale = left.abs().max(right.abs()).max(1.0);
            ActuatorDemand::Differential {
                left: left / scale,
                right: right / scale,
            }
        }
    }
}

/// Neutral outputs: what a disarmed vehicle sends.
pub fn neutral(drive: DriveTrain) -> ActuatorDemand {
    mix(drive, 0.0, 0.0)
}

/// Per-wheel commands of an Ackermann vehicle, normalised to [-1, 1]:
/// front wheel angles (1 = the inner wheel's angle at full lock, positive
/// right) and rear wheel throttles.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WheelOutputs {
    pub front_left: f64,
    pub front_right: f64,
    pub rear_left: f64,
    pub rear_right: f64,
}

impl WheelOutputs {
    /// From the normalised centre steering and throttle, by the geometry
    /// (seed 002 eq. 6–9 for the angles, 12–13 for the rear speed ratio).
    pub fn from_demand(geometry: &AckermannGeometry, steer_max_rad: f64, steering: f64, throttle: f64) -> Self {
        let steer = steering.clamp(-1.0, 1.0) * steer_max_rad;
        let angles = front_wheel_angles(geometry, steer);
        let full_lock = front_wheel_angles(geometry, steer_max_rad);
        let scale = full_lock.left_rad.abs().max(full_lock.right_rad.abs()).max(1e-9);
        // Unit rear-axle speed: the wheels' share of the throttle.
        let rear = rear_wheel_speeds(geometry, steer, 1.0);
        WheelOutputs {
            front_left: (angles.left_rad / scale).clamp(-1.0, 1.0),
            front_right: (angles.right_rad / scale).clamp(-1.0, 1.0),
            rear_left: (throttle * rear.left_mps).clamp(-1.0, 1.0),
            rear_right: (throttle * rear.right_mps).clamp(-1.0, 1.0),
        }
    }
}

/// The fixed 1000–2000 µs layout before `SERVOn_*`: steering/left on
/// channel 1, throttle/right on 3, wheels on 5–8, the rest 0. The core's
/// outputs come from [`super::servo::ServoConfig::pulses_us`].
pub fn servo_pwm(demand: &ActuatorDemand, wheels: Option<&WheelOutputs>) -> [u16; 16] {
    let mut pwm = [0u16; 16];
    let (ch1, ch3) = match *demand {
        ActuatorDemand::Ackermann { steering, throttle } => (steering, throttle),
        ActuatorDemand::Differential { left, right } => (left, right),
    };
    pwm[0] = to_pwm_us(ch1);
    pwm[2] = to_pwm_us(ch3);
    if let Some(w) = wheels {
        pwm[4] = to_pwm_us(w.front_left);
        pwm[5] = to_pwm_us(w.front_right);
        pwm[6] = to_pwm_us(w.rear_left);
        pwm[7] = to_pwm_us(w.rear_right);
    }
    pwm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pwm_round_trip() {
        assert_eq!(to_pwm_us(0.0), 1500);
        assert_eq!(to_pwm_us(1.0), 2000);
        assert_eq!(to_pwm_us(-2.0), 1000);
        assert_eq!(to_pwm_us(f64::NAN), 1500);
        assert_eq!(from_pwm_us(1750), 0.5);
    }

    #[test]
    fn wheel_outputs_follow_the_ackermann_geometry() {
        let g = AckermannGeometry::new(2.9, 1.6);
        let max = 30f64.to_radians();
        let straight = WheelOutputs::from_demand(&g, max, 0.0, 0.4);
        assert_eq!(straight.front_left, 0.0);
        assert!((straight.rear_left - 0.4).abs() < 1e-12 && (straight.rear_right - 0.4).abs() < 1e-12);
        // Full right lock: the right (inner) wheel at its full angle, the
        // left (outer) less; the outer rear wheel faster.
        let right = WheelOutputs::from_demand(&g, max, 1.0, 0.4);
        assert!((right.front_right - 1.0).abs() < 1e-12, "{right:?}");
        assert!(right.front_left > 0.0 && right.front_left < right.front_right);
        assert!(right.rear_left > right.rear_right);
        let pwm = servo_pwm(&mix(DriveTrain::Ackermann, 1.0, 0.4), Some(&right));
        assert_eq!(pwm[5], 2000);
        assert!(pwm[4] > 1500 && pwm[4] < 2000);
        assert_eq!(pwm[8], 0, "servo 9 is left to missions");
    }

    #[test]
    fn skid_steering_keeps_the_turn_when_saturated() {
        let ActuatorDemand::Differential { left, right } = mix(DriveTrain::Differential, 0.5, 1.0) else {
            panic!()
        };
        assert_eq!(left, 1.0);
        assert!((right - 1.0 / 3.0).abs() < 1e-12);
    }
}
