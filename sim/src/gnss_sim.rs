//! The simulated receiver: epoch schedule, measurement noise, NMEA bytes.

use std::time::Duration;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use super::geo::LocalFrame;
use super::nmea_out::{EpochReport, write_epoch};
use super::{GnssSimConfig, VehicleTruth};

/// Below this antenna speed a receiver's course is noise: leave it empty.
const COURSE_MIN_SPEED_MPS: f64 = 0.05;

#[derive(Clone, Debug)]
pub(crate) struct GnssSim {
    rng: ChaCha8Rng,
    /// Gauss–Markov position error (north, east) and the epoch it belongs to.
    walk_m: Option<(f64, f64, Duration)>,
    last_epoch: Option<Duration>,
    next_epoch: Option<Duration>,
    bytes: Vec<u8>,
}

/// No receiver is faster; a mistyped rate must not flood the byte buffer.
const MAX_RATE_HZ: f64 = 1000.0;

/// Epoch k of a receiver at `rate_hz`, rounded to the nanosecond.
fn epoch_time(k: u64, rate_hz: f64) -> Duration {
    Duration::from_nanos((k as f64 * 1e9 / rate_hz).round() as u64)
}

/// The first epoch at or after `t`, if the rate allows any.
fn first_epoch_from(t: Duration, rate_hz: f64) -> Option<Duration> {
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return None;
    }
    let rate_hz = rate_hz.min(MAX_RATE_HZ);
    let mut k = (t.as_secs_f64() * rate_hz).floor() as u64;
    // The float guess can be one off either way.
    while k > 0 && epoch_time(k - 1, rate_hz) >= t {
        k -= 1;
    }
    while epoch_time(k, rate_hz) < t {
        k += 1;
    }
    Some(epoch_time(k, rate_hz))
}

impl GnssSim {
    pub(crate) fn new(seed: u64, cfg: &GnssSimConfig) -> Self {
        Self {
            rng: ChaCha8Rng::seed_from_u64(seed),
            walk_m: None,
            last_epoch: None,
            next_epoch: first_epoch_from(Duration::ZERO, cfg.rate_hz),
            bytes: Vec::new(),
        }
    }

    /// The next epoch due, if it is no later than `t`.
    pub(crate) fn due(&self, t: Duration) -> Option<Duration> {
        self.next_epoch.filter(|&epoch| epoch <= t)
    }

    /// A new configuration (possibly a new rate): the schedule continues from
    /// `now` on the new rate's grid, never repeating an epoch already sent.
    pub(crate) fn reschedule(&mut self, cfg: &GnssSimConfig, now: Duration) {
        let after_last = self.last_epoch.map_or(Duration::ZERO, |t| t + Duration::from_nanos(1));
        self.next_epoch = first_epoch_from(now.max(after_last), cfg.rate_hz);
    }

    /// The walk's σ changed from `old_sigma_m` to `new_sigma_m`: the walk
    /// so far is scaled to the new σ, so it is at once as large as a
    /// receiver with that σ would have it. Kept, it would take the time
    /// constant (a minute) to fade, and a filter told the new σ would be
    /// over-confident all that while. From a zero walk it starts afresh
    /// from the stationary distribution at the next epoch.
    pub(crate) fn rescale_walk(&mut self, old_sigma_m: f64, new_sigma_m: f64) {
        if new_sigma_m == old_sigma_m {
            return;
        }
        self.walk_m = match self.walk_m {
            Some((n, e, t)) if old_sigma_m > 0.0 => {
                let scale = new_sigma_m / old_sigma_m;
                Some((n * scale, e * scale, t))
            }
            _ => None,
        };
    }

    /// Emit the epoch at `epoch_t` for the vehicle in state `truth`.
    pub(crate) fn emit(
        &mut self,
        epoch_t: Duration,
        truth: &VehicleTruth,
        cfg: &GnssSimConfig,
        frame: LocalFrame,
        utc_start_unix_us: i64,
    ) {
        self.last_epoch = Some(epoch_t);
        self.next_epoch = first_epoch_from(epoch_t + Duration::from_nanos(1), cfg.rate_hz);
        if !cfg.enabled {
            return;
        }
        // Always six draws per epoch, in this order, whatever is reported.
        let mut normal = || -> f64 { self.rng.sample(StandardNormal) };
        let white = (normal(), normal());
        let innovation = (normal(), normal());
        let alt_noise = normal();
        let heading_noise = normal();
        let (walk_n, walk_e) = self.advance_walk(epoch_t, innovation, cfg);

        let (ax, ay) = cfg.antenna_body_m;
        let (sin_yaw, cos_yaw) = truth.yaw_rad.sin_cos();
        let (glitch_n, glitch_e) = cfg.glitch_ned_m;
        let antenna_n = truth.north_m + ax * cos_yaw - ay * sin_yaw + cfg.pos_sigma_m * white.0 + walk_n + glitch_n;
        let antenna_e = truth.east_m + ax * sin_yaw + ay * cos_yaw + cfg.pos_sigma_m * white.1 + walk_e + glitch_e;
        let mut position = frame.to_geodetic(antenna_n, antenna_e, 0.0);
        position.alt_m += cfg.alt_sigma_m * alt_noise;

        // Antenna velocity in the body frame: v + ω × r, ω about body z (down).
        let w = truth.yaw_rate_rad_s;
        let (vx, vy) = (truth.speed_mps - w * ay, w * ax);
        let speed_mps = vx.hypot(vy);
        // The truth's yaw is about the home frame's north; the receiver
        // reports both angles from true north where it is (they differ by
        // the meridians' convergence, degrees within a kilometre of a pole).
        let course_deg = (speed_mps >= COURSE_MIN_SPEED_MPS).then(|| {
            frame
                .heading_to_true(&position, truth.yaw_rad + vy.atan2(vx))
                .to_degrees()
        });
        let true_yaw_deg = frame.heading_to_true(&position, truth.yaw_rad).to_degrees();
        let heading_deg = cfg.heading_enabled.then(|| {
            cfg.heading_hold_deg
                .unwrap_or(true_yaw_deg + cfg.heading_sigma_deg * heading_noise)
        });

        let t_us = i64::try_from(epoch_t.as_micros()).unwrap_or(i64::MAX);
        let report = EpochReport {
            utc_unix_us: utc_start_unix_us.saturating_add(t_us),
            quality: cfg.quality,
            position,
            satellites: cfg.satellites,
            hdop: cfg.hdop,
            speed_mps,
            course_deg,
            sigma_horizontal_m: cfg.horizontal_sigma_m(),
            sigma_alt_m: cfg.alt_sigma_m,
            heading_deg,
        };
        write_epoch(&cfg.talker, &report, &mut self.bytes);
    }

    /// First-order Gauss–Markov: x ← φx + σ√(1−φ²)·n with φ = exp(−Δt/τ), so
    /// its σ stays the configured one whatever the epoch spacing. It starts
    /// from its stationary distribution.
    fn advance_walk(&mut self, epoch_t: Duration, innovation: (f64, f64), cfg: &GnssSimConfig) -> (f64, f64) {
        let sigma = cfg.pos_walk_sigma_m;
        let (n, e) = match self.walk_m {
            None => (sigma * innovation.0, sigma * innovation.1),
            Some((n, e, t)) => {
                let dt_s = epoch_t.saturating_sub(t).as_secs_f64();
                let phi = if cfg.pos_walk_tau_s > 0.0 {
                    (-dt_s / cfg.pos_walk_tau_s).exp()
                } else {
                    0.0
                };
                let gain = sigma * (1.0 - phi * phi).sqrt();
                (phi * n + gain * innovation.0, phi * e + gain * innovation.1)
            }
        };
        self.walk_m = Some((n, e, epoch_t));
        (n, e)
    }

    pub(crate) fn take_bytes(&mut self, out: &mut Vec<u8>) {
        out.append(&mut self.bytes);
    }
}

#[cfg(test)]
mod tests {
    use super::super::GeoPoint;
    use super::*;
    use drivers::gnss::{GnssSample, NmeaReader};

    #[test]
    fn epochs_fall_on_the_grid() {
        assert_eq!(first_epoch_from(Duration::ZERO, 10.0), Some(Duration::ZERO));
        let just_after = Duration::from_millis(100) + Duration::from_nanos(1);
        assert_eq!(first_epoch_from(just_after, 10.0), Some(Duration::from_millis(200)));
        assert_eq!(
            first_epoch_from(Duration::from_millis(300), 10.0),
            Some(Duration::from_millis(300))
        );
        assert_eq!(
            first_epoch_from(Duration::from_millis(1), 3.0),
            Some(Duration::from_nanos(333_333_333))
        );
        assert_eq!(first_epoch_from(Duration::ZERO, 0.0), None);
        assert_eq!(first_epoch_from(Duration::ZERO, f64::NAN), None);
    }

    /// The true azimuth (degrees) of the home-frame direction `yaw_rad` at
    /// (`north_m`, `east_m`), by central differences in latitude and
    /// longitude on the ellipsoid's radii: no ECEF, unlike the code under
    /// test. Good to ~1e-5° one metre or more from a pole.
    fn azimuth_by_differences(frame: LocalFrame, north_m: f64, east_m: f64, yaw_rad: f64) -> f64 {
        const STEP_M: f64 = 1e-3;
        const A_M: f64 = 6_378_137.0;
        const E2: f64 = 6.694_379_990_141_3e-3;
        let (sin, cos) = yaw_rad.sin_cos();
        let ahead = frame.to_geodetic(north_m + STEP_M * cos, east_m + STEP_M * sin, 0.0);
        let behind = frame.to_geodetic(north_m - STEP_M * cos, east_m - STEP_M * sin, 0.0);
        let lat = ((ahead.lat_deg + behind.lat_deg) / 2.0).to_radians();
        let w2 = 1.0 - E2 * lat.sin().powi(2);
        let (meridian_m, normal_m) = (A_M * (1.0 - E2) / (w2 * w2.sqrt()), A_M / w2.sqrt());
        let dlon_deg = (ahead.lon_deg - behind.lon_deg + 180.0).rem_euclid(360.0) - 180.0;
        let north = meridian_m * (ahead.lat_deg - behind.lat_deg).to_radians();
        let east = normal_m * lat.cos() * dlon_deg.to_radians();
        east.atan2(north).to_degrees()
    }

    #[test]
    fn course_and_heading_are_true_where_the_receiver_is_even_near_a_pole() {
        let cfg = GnssSimConfig {
            antenna_body_m: (0.0, 0.0),
            pos_sigma_m: 0.0,
            pos_walk_sigma_m: 0.0,
            alt_sigma_m: 0.0,
            heading_sigma_deg: 0.0,
            ..GnssSimConfig::default()
        };
        let homes = [
            (-89.999, 30.0, 2800.0),
            (90.0, 0.0, 10.0),
            (89.99, 45.0, 0.0),
            (-17.8, 179.99985, 5.0),
            (0.0, 0.0, 0.0),
        ];
        // (north, east, yaw): beside home, and for the first two homes
        // around and past the pole.
        let states = [
            (0.0, 5.0, 0.3),
            (30.0, -20.0, 2.0),
            (-150.0, 20.0, -1.2),
            (3.0, 1.0, 3.1),
        ];
        let mut worst_deg = 0.0f64;
        for (lat_deg, lon_deg, alt_m) in homes {
            let frame = LocalFrame::new(GeoPoint {
                lat_deg,
                lon_deg,
                alt_m,
            });
            for (north_m, east_m, yaw_rad) in states {
                let truth = VehicleTruth {
                    north_m,
                    east_m,
                    yaw_rad,
                    speed_mps: 1.0,
                    ..VehicleTruth::default()
                };
                let mut sim = GnssSim::new(1, &cfg);
                sim.emit(Duration::ZERO, &truth, &cfg, frame, 0);
                let mut bytes = Vec::new();
                sim.take_bytes(&mut bytes);
                let mut samples = Vec::new();
                NmeaReader::new().push(Duration::ZERO, &bytes, &mut samples);
                let course = samples.iter().find_map(|s| match s {
                    GnssSample::Velocity(v) => v.course_deg,
                    _ => None,
                });
                let heading = samples.iter().find_map(|s| match s {
                    GnssSample::Heading(h) => Some(h.heading_deg),
                    _ => None,
                });
                let expected = azimuth_by_differences(frame, north_m, east_m, yaw_rad);
                for got in [course, heading] {
                    let got = got.unwrap_or_else(|| panic!("{samples:?}"));
                    let gap = ((got - expected + 180.0).rem_euclid(360.0) - 180.0).abs();
                    // HDT and RMC carry 0.001°.
                    assert!(
                        gap < 1e-3,
                        "home {lat_deg},{lon_deg} at ({north_m}, {east_m}): {got} vs {expected}"
                    );
                    worst_deg = worst_deg.max(gap);
                }
            }
        }
        println!("simulated course/heading vs true azimuth: worst {worst_deg:.1e}°");
    }
}
