//! Configuration of the simulated world; defaults are the bench vehicle and
//! receiver of `tests/data/bench/README.md`.

use drivers::gnss::FixQuality;

use super::{GeoPoint, MagneticSensorConfig};

/// Car-like vehicle; the reference point is the rear axle centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AckermannConfig {
    pub wheelbase_m: f64,
    pub track_m: f64,
    pub max_steer_rad: f64,
    pub steer_rate_rad_s: f64,
    /// First-order lag of the steering actuator.
    pub steer_tau_s: f64,
    /// First-order lag of the drive.
    pub speed_tau_s: f64,
    pub accel_max_mps2: f64,
    pub brake_max_mps2: f64,
    pub speed_max_mps: f64,
}

impl Default for AckermannConfig {
    fn default() -> Self {
        Self {
            wheelbase_m: 2.9,
            track_m: 1.6,
            max_steer_rad: 30f64.to_radians(),
            steer_rate_rad_s: 30f64.to_radians(),
            steer_tau_s: 0.1,
            speed_tau_s: 0.3,
            accel_max_mps2: 1.0,
            brake_max_mps2: 2.0,
            speed_max_mps: 4.0,
        }
    }
}

/// Skid-steer vehicle; the reference point is the wheel-axle centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DifferentialConfig {
    pub track_m: f64,
    /// First-order lag of each wheel drive.
    pub wheel_tau_s: f64,
    pub accel_max_mps2: f64,
    pub brake_max_mps2: f64,
    pub wheel_speed_max_mps: f64,
}

impl Default for DifferentialConfig {
    fn default() -> Self {
        Self {
            track_m: 0.6,
            wheel_tau_s: 0.2,
            accel_max_mps2: 1.0,
            brake_max_mps2: 2.0,
            wheel_speed_max_mps: 2.0,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum VehicleModel {
    Ackermann(AckermannConfig),
    Differential(DifferentialConfig),
}

impl Default for VehicleModel {
    fn default() -> Self {
        VehicleModel::Ackermann(AckermannConfig::default())
    }
}

/// Simulated GNSS receiver.
#[derive(Clone, Debug, PartialEq)]
pub struct GnssSimConfig {
    pub enabled: bool,
    /// Epochs per second of simulated time, capped at 1000; ≤ 0 or NaN sends none.
    pub rate_hz: f64,
    /// Antenna position in the body frame (x forward, y right) from the
    /// vehicle reference point.
    pub antenna_body_m: (f64, f64),
    /// White noise per horizontal axis.
    pub pos_sigma_m: f64,
    /// Stationary σ of the first-order Gauss–Markov term per horizontal axis.
    pub pos_walk_sigma_m: f64,
    /// Correlation time of the Gauss–Markov term.
    pub pos_walk_tau_s: f64,
    pub alt_sigma_m: f64,
    /// Dual-antenna heading (HDT).
    pub heading_enabled: bool,
    pub heading_sigma_deg: f64,
    pub quality: FixQuality,
    pub satellites: u8,
    pub hdop: f32,
    /// Two-character talker id; anything else falls back to "GN".
    pub talker: String,
    /// Added to every reported position (north, east): a position jump.
    pub glitch_ned_m: (f64, f64),
    /// Reported instead of the true heading, without noise: a receiver
    /// whose heading output froze.
    pub heading_hold_deg: Option<f64>,
}

impl Default for GnssSimConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            rate_hz: 10.0,
            antenna_body_m: (0.5, 0.0),
            pos_sigma_m: 0.010,
            pos_walk_sigma_m: 0.005,
            pos_walk_tau_s: 60.0,
            alt_sigma_m: 0.02,
            heading_enabled: true,
            heading_sigma_deg: 0.05,
            quality: FixQuality::RtkFixed,
            satellites: 20,
            hdop: 0.6,
            talker: "GN".to_owned(),
            glitch_ned_m: (0.0, 0.0),
            heading_hold_deg: None,
        }
    }
}

impl GnssSimConfig {
    /// The horizontal σ per axis the receiver reports (white and walk in quadrature).
    pub fn horizontal_sigma_m(&self) -> f64 {
        self.pos_sigma_m.hypot(self.pos_walk_sigma_m)
    }
}

/// A 48 V (13s Li-ion) AGV pack.
#[derive(Clone, Debug, PartialEq)]
pub struct BatterySimConfig {
    pub full_voltage_v: f64,
    pub empty_voltage_v: f64,
    pub capacity_ah: f64,
    pub idle_current_a: f64,
    pub drive_current_a_per_mps: f64,
    pub accel_current_a_per_mps2: f64,
    pub internal_resistance_ohm: f64,
}

impl Default for BatterySimConfig {
    fn default() -> Self {
        Self {
            full_voltage_v: 54.6,
            empty_voltage_v: 42.0,
            capacity_ah: 100.0,
            idle_current_a: 2.0,
            drive_current_a_per_mps: 8.0,
            accel_current_a_per_mps2: 25.0,
            internal_resistance_ohm: 0.05,
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct WorldConfig {
    pub home: GeoPoint,
    /// Initial heading, 0 = north, clockwise.
    pub home_heading_deg: f64,
    pub vehicle: VehicleModel,
    pub gnss: GnssSimConfig,
    pub battery: BatterySimConfig,
    /// The magnetic guide sensors; they read only once a tape is laid
    /// ([`super::World::set_tape`]).
    pub magnetic: MagneticSensorConfig,
    /// Physics sub-steps per second, capped at 100 kHz; ≤ 0 or NaN means 400.
    pub physics_rate_hz: f64,
    /// UTC at simulated time zero.
    pub utc_start_unix_us: i64,
}

impl Default for WorldConfig {
    fn default() -> Self {
        Self {
            // The bench course's home (tests/data/bench/README.md).
            home: GeoPoint {
                lat_deg: 29.1330,
                lon_deg: 119.6400,
                alt_m: 50.0,
            },
            home_heading_deg: 0.0,
            vehicle: VehicleModel::default(),
            gnss: GnssSimConfig::default(),
            battery: BatterySimConfig::default(),
            magnetic: MagneticSensorConfig::default(),
            physics_rate_hz: 400.0,
            // 2025-01-01T00:00:00Z: a fixed date keeps runs reproducible.
            utc_start_unix_us: 1_735_689_600_000_000,
        }
    }
}
