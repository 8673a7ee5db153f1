//! The plain values the core exchanges with its devices, real or simulated.
//!
//! The core (`autopilot`) reads battery readings and positions and demands
//! actuator settings; the simulated world (`sim`) produces and consumes the
//! same values. They live here, in a crate that depends on nothing, so the
//! simulator need not depend on the autopilot nor the autopilot's core on the
//! simulator. Values only: no behaviour beyond conversions of units.

mod actuator;
mod battery;
mod geo_point;

pub use actuator::ActuatorDemand;
pub use battery::BatterySample;
pub use geo_point::GeoPoint;
