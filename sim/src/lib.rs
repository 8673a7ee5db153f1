//! The SITL world. Its simulated devices emit what real ones do: the GNSS
//! receiver writes NMEA bytes for [`drivers::gnss::NmeaReader`], as does
//! the inertial unit (VectorNav `$VNIMU` lines); the laser
//! scanners ray-cast the obstacles into [`drivers::scanner::Scan`]s.
//!
//! Frames: NED about the home point (`north_m`, `east_m`); yaw 0 = north,
//! clockwise, in [-π, π); body x forward, y right; the vehicle reference point
//! is the rear axle centre (Ackermann) or the wheel-axle centre
//! (differential); steering positive = right.

mod actuator;
mod battery;
mod config;
mod fleet;
mod geo;
mod gnss_sim;
mod imu_sim;
mod magnetic;
mod nmea_out;
mod obstacles;
mod scanner;
mod seed;
mod vehicle;
mod world;
mod world_file;

#[cfg(test)]
mod tests;

// The values the world shares with the core: their one home is vehicle_types.
use vehicle_types::{ActuatorDemand, BatterySample, GeoPoint};

pub use config::{AckermannConfig, BatterySimConfig, DifferentialConfig, GnssSimConfig, VehicleModel, WorldConfig};
pub use fleet::FleetOutlines;
pub use imu_sim::ImuSimConfig;
pub use magnetic::{
    MAGNETIC_PROBES, MagneticSensor, MagneticSensorConfig, MagneticTape, TapeBuilder, TapeFix, TapeSegment,
};
pub use obstacles::{MovingObstacle, ObstacleWorld, Rectangle, Shape, VehicleOutline};
pub use scanner::{
    MAX_BEAMS, RenderScratch, ScanStamp, SimScanner, SimScannerConfig, SimScannerConfigError, render_scan,
    render_scan_into,
};
pub use vehicle::VehicleTruth;
pub use world::{World, WorldStageTimes};
pub use world_file::{PERSON_RADIUS_M, WorldFile, WorldFileError, load_world_file, parse_world_file};
