//! The receiver's own report, kept for GPS_RAW_INT and arming checks.

use std::time::Duration;

use drivers::gnss::{FixQuality, GnssSample};

/// What the GNSS receiver last said.
#[derive(Clone, Debug, Default)]
pub struct GnssStatus {
    pub last_fix_t: Option<Duration>,
    pub quality: Option<FixQuality>,
    pub lat_deg: f64,
    pub lon_deg: f64,
    pub alt_msl_m: f64,
    pub satellites: u8,
    pub hdop: f32,
    pub speed_mps: f64,
    pub course_deg: Option<f64>,
    pub heading_deg: Option<f64>,
    pub sigma_north_m: Option<f64>,
    pub sigma_east_m: Option<f64>,
    pub sigma_up_m: Option<f64>,
    /// UTC (µs since the Unix epoch) at `utc_t`.
    pub utc_unix_us: Option<i64>,
    pub utc_t: Duration,
}

impl GnssStatus {
    pub fn apply(&mut self, sample: &GnssSample) {
        match sample {
            GnssSample::Fix(f) => {
                self.last_fix_t = Some(f.t);
                self.quality = Some(f.quality);
                self.lat_deg = f.lat_deg;
                self.lon_deg = f.lon_deg;
                self.alt_msl_m = f.alt_msl_m;
                self.satellites = f.satellites;
                self.hdop = f.hdop;
            }
            GnssSample::Velocity(v) => {
                self.speed_mps = v.speed_mps;
                self.course_deg = v.course_deg;
            }
            GnssSample::Accuracy(a) => {
                self.sigma_north_m = Some(a.sigma_north_m);
                self.sigma_east_m = Some(a.sigma_east_m);
                self.sigma_up_m = a.sigma_up_m;
            }
            GnssSample::Heading(h) => self.heading_deg = Some(h.heading_deg),
            GnssSample::Time(t) => {
                self.utc_unix_us = Some(t.utc_unix_us);
                self.utc_t = t.t;
            }
            // Not the receiver's: the estimator reads the IMU itself.
            GnssSample::Imu(_) => {}
        }
    }

    /// Whether a usable position fix arrived within `max_age` of `now`.
    pub fn has_fix(&self, now: Duration, max_age: Duration) -> bool {
        let fresh = self.last_fix_t.is_some_and(|t| now.saturating_sub(t) <= max_age);
        fresh && self.quality.is_some_and(|q| q != FixQuality::NoFix)
    }

    /// 1-σ horizontal accuracy: from GST when the receiver sends it, else the
    /// typical figure for the fix quality.
    pub fn horizontal_sigma_m(&self) -> f64 {
        if let (Some(n), Some(e)) = (self.sigma_north_m, self.sigma_east_m) {
            return n.hypot(e) / std::f64::consts::SQRT_2;
        }
        Self::quality_sigma_m(self.quality)
    }

    /// The least 1-σ per axis a fix of this quality can have.
    pub fn quality_sigma_floor_m(quality: Option<FixQuality>) -> f64 {
        match quality {
            Some(FixQuality::RtkFixed) => 0.002,
            Some(FixQuality::RtkFloat) => 0.05,
            Some(FixQuality::Dgps) => 0.3,
            Some(FixQuality::Single) => 1.0,
            _ => 10.0,
        }
    }

    /// Typical 1-σ per axis of a fix of this quality.
    pub fn quality_sigma_m(quality: Option<FixQuality>) -> f64 {
        match quality {
            Some(FixQuality::RtkFixed) => 0.02,
            Some(FixQuality::RtkFloat) => 0.3,
            Some(FixQuality::Dgps) => 0.7,
            Some(FixQuality::Single) => 2.5,
            _ => 99.0,
        }
    }

    /// UTC now, extrapolated from the last time message.
    pub fn utc_now_us(&self, now: Duration) -> Option<i64> {
        self.utc_unix_us
            .map(|u| u + now.saturating_sub(self.utc_t).as_micros() as i64)
    }

    /// GPS_FIX_TYPE for GPS_RAW_INT.
    pub fn mavlink_fix_type(&self, now: Duration) -> u8 {
        match self.quality {
            None => 0,
            Some(_) if !self.has_fix(now, Duration::from_secs(2)) => 1,
            Some(FixQuality::NoFix) => 1,
            Some(FixQuality::RtkFixed) => 6,
            Some(FixQuality::RtkFloat) => 5,
            Some(FixQuality::Dgps) => 4,
            Some(_) => 3,
        }
    }
}
