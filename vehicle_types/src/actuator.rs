//! What the core demands of the drive train each tick.

/// Normalised demands in [-1, 1]; values outside are clamped and NaN is 0.
/// Ackermann: `steering` +1 = full right (`max_steer_rad`), `throttle` = signed
/// fraction of `speed_max_mps` (negative = reverse). Differential: each wheel's
/// signed fraction of `wheel_speed_max_mps`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ActuatorDemand {
    Ackermann { steering: f64, throttle: f64 },
    Differential { left: f64, right: f64 },
}

impl ActuatorDemand {
    /// At rest, whatever the vehicle.
    pub const STOP: ActuatorDemand = ActuatorDemand::Ackermann {
        steering: 0.0,
        throttle: 0.0,
    };
}
