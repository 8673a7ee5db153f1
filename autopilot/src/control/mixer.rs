//! From normalised steering/throttle to what the drive train takes, and to
//! servo pulse widths.
//!
//! Ackermann: steering on servo 1, throttle on servo 3 (ArduPilot Rover's
//! default functions 26 and 70). Differential (skid steering): left on
//! servo 1, right on servo 3 (functions 73 and 74).

use drivers::sim::ActuatorDemand;

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

/// Servo outputs for a demand (channels 1 and 3; the rest unused = 0).
pub fn servo_pwm(demand: &ActuatorDemand) -> [u16; 16] {
    let mut pwm = [0u16; 16];
    let (ch1, ch3) = match *demand {
        ActuatorDemand::Ackermann { steering, throttle } => (steering, throttle),
        ActuatorDemand::Differential { left, right } => (left, right),
    };
    pwm[0] = to_pwm_us(ch1);
    pwm[2] = to_pwm_us(ch3);
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
    fn skid_steering_keeps_the_turn_when_saturated() {
        let ActuatorDemand::Differential { left, right } = mix(DriveTrain::Differential, 0.5, 1.0) else {
            panic!()
        };
        assert_eq!(left, 1.0);
        assert!((right - 1.0 / 3.0).abs() < 1e-12);
    }
}
