//! A simulated inertial unit speaking VectorNav's `$VNIMU` ASCII line (the
//! bytes [`drivers::imu`] reads): the true yaw rate and accelerations of the
//! vehicle on flat ground, with a constant bias drawn at power-on, a slow
//! bias random walk and white noise on every sample, like a MEMS unit.

use std::time::Duration;

use drivers::imu::{GRAVITY_MPS2, ImuSample, write_vnimu};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use super::seed::splitmix_finalise;
use super::vehicle::VehicleTruth;

/// Keeps the unit's noise stream apart from the other devices'.
const IMU_STREAM: u64 = 0x494d_5531;
/// No unit is faster; a mistyped rate must not flood the byte buffer.
const MAX_RATE_HZ: f64 = 1000.0;
/// The Earth's field, north and down components (gauss), mid-latitudes.
const FIELD_NORTH_GAUSS: f64 = 0.2;
const FIELD_DOWN_GAUSS: f64 = 0.45;

/// The unit's output rate and error model (1 σ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSimConfig {
    pub rate_hz: f64,
    /// White noise on each gyro sample.
    pub gyro_noise_rad_s: f64,
    /// Power-on bias of each gyro axis.
    pub gyro_bias_rad_s: f64,
    /// Bias random walk, per √s.
    pub gyro_bias_walk_rad_s_per_sqrt_s: f64,
    pub accel_noise_mps2: f64,
    pub accel_bias_mps2: f64,
    pub mag_noise_gauss: f64,
}

impl Default for ImuSimConfig {
    /// A VN-100-class unit at 50 Hz: 0.06°/s noise per sample, 0.1°/s
    /// turn-on bias (as after a power cycle, uncalibrated), wandering
    /// about 0.1°/s per hour.
    fn default() -> Self {
        ImuSimConfig {
            rate_hz: 50.0,
            gyro_noise_rad_s: 1e-3,
            gyro_bias_rad_s: 2e-3,
            gyro_bias_walk_rad_s_per_sqrt_s: 3e-5,
            accel_noise_mps2: 0.01,
            accel_bias_mps2: 0.03,
            mag_noise_gauss: 0.002,
        }
    }
}

#[derive(Clone, Debug)]
pub(crate) struct ImuSim {
    config: ImuSimConfig,
    rng: ChaCha8Rng,
    gyro_bias_rad_s: [f64; 3],
    accel_bias_mps2: [f64; 3],
    /// Index of the next sample on the rate's grid.
    next_k: u64,
    /// The true forward speed at the last sample: the longitudinal
    /// acceleration is its change over the sample interval, as a unit
    /// that averages between outputs reports it.
    last_speed_mps: Option<f64>,
    bytes: Vec<u8>,
}

impl ImuSim {
    /// A unit powered on at `now`: its first sample is the first on its
    /// rate's grid at or after `now`.
    pub(crate) fn new(config: ImuSimConfig, world_seed: u64, now: Duration) -> ImuSim {
        let mut rng = ChaCha8Rng::seed_from_u64(splitmix_finalise(world_seed ^ IMU_STREAM));
        let mut draw =
            |sigma: f64| -> [f64; 3] { std::array::from_fn(|_| sigma * rng.sample::<f64, _>(StandardNormal)) };
        let gyro_bias_rad_s = draw(config.gyro_bias_rad_s);
        let accel_bias_mps2 = draw(config.accel_bias_mps2);
        let mut imu = ImuSim {
            config,
            rng,
            gyro_bias_rad_s,
            accel_bias_mps2,
            next_k: 0,
            last_speed_mps: None,
            bytes: Vec::new(),
        };
        if let Some(rate) = imu.rate_hz() {
            imu.next_k = (now.as_secs_f64() * rate).ceil() as u64;
            while imu.next_k > 0 && imu.sample_time(imu.next_k - 1).is_some_and(|t| t >= now) {
                imu.next_k -= 1;
            }
        }
        imu
    }

    fn rate_hz(&self) -> Option<f64> {
        let rate = self.config.rate_hz;
        (rate.is_finite() && rate > 0.0).then(|| rate.min(MAX_RATE_HZ))
    }

    fn sample_time(&self, k: u64) -> Option<Duration> {
        self.rate_hz()
            .map(|rate| Duration::from_nanos((k as f64 * 1e9 / rate).round() as u64))
    }

    /// The next sample due, if it is no later than `t`.
    pub(crate) fn due(&self, t: Duration) -> Option<Duration> {
        self.sample_time(self.next_k).filter(|&s| s <= t)
    }

    /// The gyro's power-on bias (for tests of the core's calibration).
    pub(crate) fn gyro_bias_rad_s(&self) -> [f64; 3] {
        self.gyro_bias_rad_s
    }

    /// Emits the sample at `t` (from [`Self::due`]) for the vehicle in `truth`.
    pub(crate) fn emit(&mut self, t: Duration, truth: &VehicleTruth) {
        let dt_s = self.rate_hz().map_or(0.0, |rate| 1.0 / rate);
        self.next_k += 1;
        let walk = self.config.gyro_bias_walk_rad_s_per_sqrt_s * dt_s.sqrt();
        let mut normal = || -> f64 { self.rng.sample(StandardNormal) };
        // Always the same draws per sample, in this order.
        let gyro_noise: [f64; 3] = std::array::from_fn(|_| normal());
        let bias_steps: [f64; 3] = std::array::from_fn(|_| normal());
        let accel_noise: [f64; 3] = std::array::from_fn(|_| normal());
        let mag_noise: [f64; 3] = std::array::from_fn(|_| normal());
        let c = self.config;
        let true_rate = [0.0, 0.0, truth.yaw_rate_rad_s];
        let long_accel = match self.last_speed_mps {
            Some(last) if dt_s > 0.0 => (truth.speed_mps - last) / dt_s,
            _ => 0.0,
        };
        self.last_speed_mps = Some(truth.speed_mps);
        // Flat ground: forward acceleration, the centripetal one to the
        // right in a right turn, and the ground's push up (−z).
        let true_accel = [long_accel, truth.speed_mps * truth.yaw_rate_rad_s, -GRAVITY_MPS2];
        let (sin_yaw, cos_yaw) = truth.yaw_rad.sin_cos();
        let true_mag = [
            FIELD_NORTH_GAUSS * cos_yaw,
            -FIELD_NORTH_GAUSS * sin_yaw,
            FIELD_DOWN_GAUSS,
        ];
        let sample = ImuSample {
            t,
            gyro_rad_s: std::array::from_fn(|i| {
                true_rate[i] + self.gyro_bias_rad_s[i] + c.gyro_noise_rad_s * gyro_noise[i]
            }),
            accel_mps2: std::array::from_fn(|i| {
                true_accel[i] + self.accel_bias_mps2[i] + c.accel_noise_mps2 * accel_noise[i]
            }),
            mag_gauss: std::array::from_fn(|i| true_mag[i] + c.mag_noise_gauss * mag_noise[i]),
        };
        for (bias, step) in self.gyro_bias_rad_s.iter_mut().zip(bias_steps) {
            *bias += walk * step;
        }
        write_vnimu(&mut self.bytes, &sample, 25.0, 101.325);
    }

    pub(crate) fn take_bytes(&mut self, out: &mut Vec<u8>) {
        out.append(&mut self.bytes);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drivers::gnss::{GnssSample, NmeaReader};

    fn samples(sim: &mut ImuSim) -> Vec<ImuSample> {
        let mut bytes = Vec::new();
        sim.take_bytes(&mut bytes);
        let mut out = Vec::new();
        let mut reader = NmeaReader::new();
        reader.push(Duration::ZERO, &bytes, &mut out);
        assert_eq!(reader.stats().sentences, out.len() as u64);
        out.iter()
            .filter_map(|s| match s {
                GnssSample::Imu(i) => Some(*i),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn a_turn_reads_as_yaw_rate_and_centripetal_acceleration() {
        let mut sim = ImuSim::new(ImuSimConfig::default(), 7, Duration::ZERO);
        let truth = VehicleTruth {
            speed_mps: 2.0,
            yaw_rate_rad_s: 0.5,
            ..VehicleTruth::default()
        };
        let n = 500;
        for k in 0..n {
            let t = sim.due(Duration::from_secs(100)).expect("due");
            assert_eq!(t, Duration::from_millis(20 * k));
            sim.emit(t, &truth);
        }
        let got = samples(&mut sim);
        assert_eq!(got.len(), n as usize);
        let mean = |f: &dyn Fn(&ImuSample) -> f64| got.iter().map(f).sum::<f64>() / got.len() as f64;
        let bias = sim.gyro_bias_rad_s()[2];
        // The mean is the truth plus the bias, within the noise's and the
        // walk's few 1e-4.
        assert!((mean(&|s| s.gyro_rad_s[2]) - 0.5 - bias).abs() < 5e-4);
        assert!((mean(&|s| s.accel_mps2[1]) - 1.0).abs() < 0.1);
        assert!((mean(&|s| s.accel_mps2[2]) + GRAVITY_MPS2).abs() < 0.1);
    }

    #[test]
    fn the_same_seed_gives_the_same_bytes() {
        let run = |seed| {
            let mut sim = ImuSim::new(ImuSimConfig::default(), seed, Duration::ZERO);
            for k in 0..10 {
                sim.emit(Duration::from_millis(20 * k), &VehicleTruth::default());
            }
            let mut bytes = Vec::new();
            sim.take_bytes(&mut bytes);
            bytes
        };
        assert_eq!(run(3), run(3));
        assert_ne!(run(3), run(4));
    }
}
