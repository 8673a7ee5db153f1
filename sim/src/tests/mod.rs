//! World tests through the public API (plus the NMEA formatter directly).

mod determinism;
mod gnss_output;
mod vehicle;

use std::time::Duration;

use super::*;
use drivers::gnss::{GnssSample, NmeaReader};

/// A world whose receiver is off, for physics-only tests.
fn quiet_world(vehicle: VehicleModel, home_heading_deg: f64) -> World {
    let config = WorldConfig {
        vehicle,
        home_heading_deg,
        gnss: GnssSimConfig {
            enabled: false,
            ..GnssSimConfig::default()
        },
        ..WorldConfig::default()
    };
    World::new(config, 1)
}

/// A receiver without noise, so its output can be compared with the truth.
fn noiseless_gnss() -> GnssSimConfig {
    GnssSimConfig {
        pos_sigma_m: 0.0,
        pos_walk_sigma_m: 0.0,
        alt_sigma_m: 0.0,
        heading_sigma_deg: 0.0,
        ..GnssSimConfig::default()
    }
}

fn ackermann(steering: f64, throttle: f64) -> ActuatorDemand {
    ActuatorDemand::Ackermann { steering, throttle }
}

/// Run for `seconds` in steps of `step`.
fn run(world: &mut World, demand: ActuatorDemand, seconds: f64, step: Duration) {
    let end = world.time() + Duration::from_secs_f64(seconds);
    while world.time() < end {
        world.step(step.min(end - world.time()), &demand);
    }
}

/// True antenna position (north, east) for the world's current state.
fn antenna_truth(world: &World) -> (f64, f64) {
    let truth = world.truth();
    let (ax, ay) = world.config().gnss.antenna_body_m;
    let (sin, cos) = truth.yaw_rad.sin_cos();
    (truth.north_m + ax * cos - ay * sin, truth.east_m + ax * sin + ay * cos)
}

/// Drain the world's GNSS bytes through a reader.
fn read_gnss(world: &mut World, reader: &mut NmeaReader) -> Vec<GnssSample> {
    let mut bytes = Vec::new();
    world.take_gnss_bytes(&mut bytes);
    let mut samples = Vec::new();
    reader.push(world.time(), &bytes, &mut samples);
    samples
}

/// Sample standard deviation about zero (the errors have zero mean by construction).
fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}
