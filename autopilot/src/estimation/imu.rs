//! The inertial unit as the estimator uses it: the gyro's z bias measured
//! while the vehicle stands, the bias-corrected yaw rate fused into the
//! filter while it moves (so the heading between heading fixes, and through
//! a heading outage, follows the turn the gyro measures), and the unit's
//! freshness and plausibility for SYS_STATUS.
//!
//! While the gyro is fused, the filter's pivot process noise follows the
//! change of yaw rate the gyro measured over its last interval instead of
//! the vehicle's worst case: with the rate pinned at every sample, the
//! worst-case noise would only let the yaw between samples wander (about
//! 1°/√s at 1 rad/s²/√Hz), so each heading fix would move the estimate by
//! the sensor's whole noise and the gyro would add nothing.
//!
//! The bias is calibrated at rest rather than estimated in the filter: a
//! standing vehicle's true yaw rate is zero, so the mean reading *is* the
//! bias, with no observability question; every stop refreshes it. Until the
//! first calibration the gyro is not fused (its turn-on bias, ~0.1°/s, is
//! unknown).

use std::time::Duration;

use drivers::gnss::GnssSample;
use drivers::imu::{GRAVITY_MPS2, ImuSample};

use super::ekf::Ekf;

/// A unit silent this long is stale: its bits are unhealthy and it is not
/// fused (a few samples of a 40–50 Hz unit lost is not).
pub const IMU_STALE_AFTER: Duration = Duration::from_millis(500);
/// Samples at rest before their mean is taken as the bias (1 s at 50 Hz).
const CALIBRATION_SAMPLES: u32 = 50;
/// Floor under the measured noise: a unit reporting quantised, identical
/// readings at rest must not be believed to 0.
const MIN_GYRO_NOISE_RAD_S: f64 = 5e-4;
/// How fast the bias may wander after its calibration (MEMS class, per √s),
/// added to the yaw rate's σ as the calibration ages.
const BIAS_DRIFT_RAD_S_PER_SQRT_S: f64 = 1e-4;
/// Below this speed an Ackermann vehicle's yaw rate is too small to tell
/// from the gyro's noise, and fusing it would only move the speed through
/// the curvature: not fused (a vehicle that can pivot always is).
const MIN_FUSE_SPEED_MPS: f64 = 0.2;
/// The specific force of a vehicle on the ground stays within this of g
/// (braking, bumps): outside, the accelerometer is implausible.
const ACCEL_PLAUSIBLE_MPS2: f64 = 0.5 * GRAVITY_MPS2;

/// The pivot noise while the gyro is fused, in σ of the measured change of
/// yaw rate per interval: a ramp twice as fast as the last one still passes
/// the yaw-rate gate.
const RATE_CHANGE_SIGMAS: f64 = 2.0;
/// Floor of that noise (rad/s² per √Hz): what the bias left after a
/// calibration and its drift move the heading by, so the heading fixes are
/// still heard while the rate stands still.
const MIN_PIVOT_ACCEL_SIGMA_RADPS2: f64 = 0.02;

/// A finished calibration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroBias {
    pub z_rad_s: f64,
    /// σ of the mean, and of one reading (the unit's noise).
    pub sigma_rad_s: f64,
    pub noise_rad_s: f64,
    /// When the rest it was measured over ended (or its last sample).
    pub t: Duration,
}

/// Sums over the current rest.
#[derive(Clone, Copy, Debug, Default)]
struct RestSums {
    n: u32,
    sum: f64,
    sum_sq: f64,
}

impl RestSums {
    fn add(&mut self, z: f64) {
        self.n = self.n.saturating_add(1);
        self.sum += z;
        self.sum_sq += z * z;
    }

    fn bias(&self, t: Duration) -> Option<GyroBias> {
        if self.n < CALIBRATION_SAMPLES {
            return None;
        }
        let n = f64::from(self.n);
        let mean = self.sum / n;
        let variance = (self.sum_sq / n - mean * mean).max(0.0) * n / (n - 1.0);
        let noise = variance.sqrt().max(MIN_GYRO_NOISE_RAD_S);
        Some(GyroBias {
            z_rad_s: mean,
            sigma_rad_s: noise / n.sqrt(),
            noise_rad_s: noise,
            t,
        })
    }
}

/// What the estimator knows of the unit.
#[derive(Clone, Debug, Default)]
pub struct ImuState {
    last: Option<ImuSample>,
    rest: RestSums,
    bias: Option<GyroBias>,
    /// Yaw-rate samples fused, and refused by the filter's gate.
    fused: u64,
    rejected: u64,
    /// The pivot noise the gyro's last rate change calls for (rad/s² per
    /// √Hz), and the sample it was measured at.
    pivot_accel_sigma: Option<(f64, Duration)>,
}

impl ImuState {
    /// The newest sample, if the unit ever reported.
    pub fn last(&self) -> Option<&ImuSample> {
        self.last.as_ref()
    }

    pub fn gyro_bias(&self) -> Option<GyroBias> {
        self.bias
    }

    /// Yaw-rate samples the filter took, and those its gate refused.
    pub fn fusion_counts(&self) -> (u64, u64) {
        (self.fused, self.rejected)
    }

    /// Reported within [`IMU_STALE_AFTER`] of `now`.
    pub fn fresh(&self, now: Duration) -> bool {
        self.last.is_some_and(|s| now.saturating_sub(s.t) <= IMU_STALE_AFTER)
    }

    /// The gyro: reporting (any rate a unit sends within its range is one
    /// a vehicle can turn at).
    pub fn gyro_healthy(&self, now: Duration) -> bool {
        self.fresh(now)
    }

    /// The accelerometer: reporting, and a specific force a vehicle on the
    /// ground can feel (within g/2 of g).
    pub fn accel_healthy(&self, now: Duration) -> bool {
        let plausible = self.last.is_some_and(|s| {
            let [x, y, z] = s.accel_mps2;
            ((x * x + y * y + z * z).sqrt() - GRAVITY_MPS2).abs() <= ACCEL_PLAUSIBLE_MPS2
        });
        self.fresh(now) && plausible
    }

    /// Looks ahead at a batch's samples before the filter predicts over
    /// them: the largest change of yaw rate between consecutive samples, as
    /// a process-noise density (σ² · interval = (k·Δω)²).
    pub(super) fn note_rate_changes(&mut self, samples: &[GnssSample]) {
        let mut previous = self.last;
        for sample in samples {
            let GnssSample::Imu(imu) = sample else { continue };
            if let Some(before) = previous {
                let dt_s = imu.t.saturating_sub(before.t).as_secs_f64();
                if dt_s > 0.0 && imu.t.saturating_sub(before.t) <= IMU_STALE_AFTER {
                    let change = (imu.gyro_rad_s[2] - before.gyro_rad_s[2]).abs();
                    let sigma = (RATE_CHANGE_SIGMAS * change / dt_s.sqrt()).max(MIN_PIVOT_ACCEL_SIGMA_RADPS2);
                    let sigma = match self.pivot_accel_sigma {
                        Some((s, t)) if t == imu.t => s.max(sigma),
                        _ => sigma,
                    };
                    self.pivot_accel_sigma = Some((sigma, imu.t));
                }
            }
            previous = Some(*imu);
        }
    }

    /// The pivot noise to predict with while the gyro is fused (calibrated,
    /// fresh, a rate change measured); `None` otherwise, and the vehicle's
    /// worst case applies.
    pub(super) fn pivot_accel_sigma(&self, now: Duration) -> Option<f64> {
        let (sigma, t) = self.pivot_accel_sigma?;
        let current = now.saturating_sub(t) <= IMU_STALE_AFTER;
        (self.bias.is_some() && self.fresh(now) && current).then_some(sigma)
    }

    /// One sample: calibrates at rest, otherwise fuses the yaw rate.
    /// Returns the first calibration's bias, once, to be announced.
    pub(super) fn apply(&mut self, ekf: &mut Ekf, sample: &ImuSample, at_rest: bool, can_pivot: bool) -> Option<f64> {
        let first = self.bias.is_none();
        self.last = Some(*sample);
        let z = sample.gyro_rad_s[2];
        if at_rest {
            self.rest.add(z);
            if let Some(bias) = self.rest.bias(sample.t) {
                self.bias = Some(bias);
            }
            return self.bias.filter(|_| first).map(|b| b.z_rad_s);
        }
        self.rest = RestSums::default();
        // Not calibrated yet: its turn-on bias is unknown.
        let bias = self.bias?;
        let moving = ekf.is_initialised() && ekf.state().speed_mps.abs() >= MIN_FUSE_SPEED_MPS;
        if !(moving || can_pivot) {
            return None;
        }
        let age_s = sample.t.saturating_sub(bias.t).as_secs_f64();
        let drift = BIAS_DRIFT_RAD_S_PER_SQRT_S * age_s.sqrt();
        let sigma = (bias.noise_rad_s.powi(2) + bias.sigma_rad_s.powi(2) + drift * drift).sqrt();
        match ekf.update_yaw_rate(z - bias.z_rad_s, sigma) {
            super::ekf::Fusion::Accepted { .. } => self.fused += 1,
            super::ekf::Fusion::Rejected { .. } => self.rejected += 1,
            _ => {}
        }
        None
    }
}
