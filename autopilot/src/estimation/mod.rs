//! The pose estimate: where the vehicle's reference point (the rear axle
//! centre) is, which way it points and how fast it moves (docs/architecture.md §Estimation).
//!
//! The [`ekf`] fuses GNSS position (σ from GST, else from the fix quality)
//! with the antenna lever arm, GNSS velocity and course, and heading (a
//! dual-antenna receiver's true heading, or a compass plus `COMPASS_DEC`;
//! without either, the course over ground while driving), and an inertial
//! unit's yaw rate when one is fitted ([`imu`]: bias calibrated at rest,
//! fused while moving). The estimator
//! around it owns the local frame (built at the first fix from `GEO_*`),
//! converts true headings into the frame, watches the fix quality, and
//! turns what the filter did into events the vehicle reports: a GPS jump
//! rejected, a reset, a fix downgrade, health lost and regained.

pub mod ekf;
mod gnss_status;
mod imu;
mod params;

use std::time::Duration;

use drivers::gnss::{FixQuality, GnssFix, GnssHeading, GnssSample, GnssVelocity, HeadingReference};

use crate::geo::{FrameKind, GeoPoint, LocalFrame, Ned, PlaneTransform, wrap_pi};
use ekf::{Ekf, EkfConfig, EkfStatus, Fusion};

pub use gnss_status::GnssStatus;
pub use imu::{GyroBias, IMU_STALE_AFTER, ImuState};
pub use params::{DegradedFixAction, EkfParams, GnssQualityParams};

/// A GST σ older than this is not trusted for the current fix.
const ACCURACY_MAX_AGE: Duration = Duration::from_secs(2);
/// Without a heading sensor for this long, the course over ground stands in.
const HEADING_SENSOR_TIMEOUT: Duration = Duration::from_secs(1);
/// Slowest ground speed whose course is used as a heading.
const COURSE_AS_HEADING_MIN_MPS: f64 = 0.5;
/// A vehicle held still whose GNSS speed is below this is at rest: a
/// zero-speed update then pins the speed, so the yaw rate (speed ×
/// curvature) cannot wander and the heading averages down at a stop.
const AT_REST_GNSS_SPEED_MPS: f64 = 0.03;
const AT_REST_SPEED_SIGMA_MPS: f64 = 0.001;
/// A car at rest does not turn: its yaw rate is zero too.
const AT_REST_YAW_RATE_SIGMA_RAD_S: f64 = 1e-4;

/// Everything the estimator needs from the parameters, each tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EstimatorConfig {
    /// The filter's tuning, with the antenna lever arm.
    pub ekf: EkfConfig,
    /// The local frame built at the first fix.
    pub frame_kind: FrameKind,
    pub map: Option<PlaneTransform>,
    pub velocity_sigma_mps: f64,
    pub heading_sigma_rad: f64,
    /// Added to magnetic headings.
    pub declination_rad: f64,
}

impl Default for EstimatorConfig {
    fn default() -> Self {
        EstimatorConfig {
            ekf: EkfConfig::default(),
            frame_kind: FrameKind::TangentPlane,
            map: None,
            velocity_sigma_mps: 0.05,
            heading_sigma_rad: 0.05f64.to_radians(),
            declination_rad: 0.0,
        }
    }
}

/// The estimate at one instant.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    pub position: Ned,
    pub yaw_rad: f64,
    pub yaw_rate_rad_s: f64,
    pub vel_north_mps: f64,
    pub vel_east_mps: f64,
    /// Along the body x axis: negative when reversing.
    pub speed_mps: f64,
    pub position_valid: bool,
    pub heading_valid: bool,
    /// 1-σ horizontal position uncertainty.
    pub horiz_sigma_m: f64,
}

impl Estimate {
    pub fn ground_speed_mps(&self) -> f64 {
        self.vel_north_mps.hypot(self.vel_east_mps)
    }
}

/// Something the vehicle should tell the operator about.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EstimatorEvent {
    /// The receiver's fix quality changed (RTK fixed → float → single…).
    FixQuality {
        from: Option<FixQuality>,
        to: FixQuality,
    },
    /// A GNSS position failed the innovation gate (the first of a streak).
    GpsJumpRejected {
        distance_m: f64,
    },
    /// Rejected long enough to be real: the position moved to the GNSS.
    PositionReset {
        shift_m: f64,
    },
    /// A heading failed the innovation gate (the first of a streak):
    /// measured minus predicted, wrapped.
    HeadingRejected {
        error_rad: f64,
    },
    HeadingReset {
        shift_rad: f64,
    },
    Initialised,
    Healthy(bool),
    /// The gyro's bias was first measured (at rest): its yaw rate is used
    /// from now on.
    GyroCalibrated {
        bias_rad_s: f64,
    },
    /// The frame kind asked for cannot be used at the origin (the haversine
    /// frame near a pole): the frame built is `used`.
    FrameSubstituted {
        requested: FrameKind,
        used: FrameKind,
    },
}

#[derive(Default)]
pub struct Estimator {
    frame: Option<LocalFrame>,
    gnss: GnssStatus,
    ekf: Option<Ekf>,
    estimate: Estimate,
    events: Vec<EstimatorEvent>,
    last_heading_sensor: Option<Duration>,
    /// The heading sensor's last value and when it first read that: a value
    /// that never changes while the vehicle drives is a frozen sensor.
    heading_reading: Option<(f64, Duration)>,
    accuracy_t: Option<Duration>,
    fix_quality: Option<FixQuality>,
    position_rejecting: bool,
    heading_rejecting: bool,
    healthy: bool,
    /// Held still with the GNSS agreeing, as of the last update.
    at_rest: bool,
    imu: ImuState,
    /// The time of the current update (the gyro's pivot noise is current
    /// or not as of then).
    now: Duration,
}

impl Estimator {
    pub fn new() -> Self {
        Self::default()
    }

    /// The local frame, fixed at the first valid fix (ArduPilot's EKF origin).
    pub fn frame(&self) -> Option<&LocalFrame> {
        self.frame.as_ref()
    }

    pub fn gnss(&self) -> &GnssStatus {
        &self.gnss
    }

    pub fn estimate(&self) -> &Estimate {
        &self.estimate
    }

    /// When the heading sensor (dual antenna, compass) last reported.
    pub fn heading_sensor_last(&self) -> Option<Duration> {
        self.last_heading_sensor
    }

    /// Since when the heading sensor has reported exactly the same value.
    pub fn heading_unchanged_since(&self) -> Option<Duration> {
        self.heading_reading.map(|(_, since)| since)
    }

    /// The inertial unit: its last sample, gyro bias and fusion counts.
    pub fn imu(&self) -> &ImuState {
        &self.imu
    }

    /// Held still (no drive demand for a moment) with the GNSS speed
    /// agreeing, as of the last update: a stop's verdict waits for it.
    pub fn at_rest(&self) -> bool {
        self.at_rest
    }

    /// Whether the filter's variances are within bounds (its position is
    /// usable).
    pub fn healthy(&self) -> bool {
        self.healthy
    }

    /// The filter itself, once it runs (the benchmarks time it).
    pub fn ekf(&self) -> Option<&Ekf> {
        self.ekf.as_ref()
    }

    /// The filter's own report (innovations, σ, counters), once it runs.
    pub fn ekf_status(&self) -> Option<EkfStatus> {
        self.ekf.as_ref().map(Ekf::status)
    }

    /// Events since the last call.
    pub fn take_events(&mut self) -> Vec<EstimatorEvent> {
        std::mem::take(&mut self.events)
    }

    /// Folds in new samples, then predicts the estimate to `now`.
    /// `held_still`: the vehicle is commanded to stand (no drive demand for a
    /// while), so a GNSS speed near zero means it is at rest.
    pub fn update(&mut self, now: Duration, config: &EstimatorConfig, samples: &[GnssSample], held_still: bool) {
        // At rest as the last samples saw it: the vehicle is not commanded to
        // move and the GNSS agrees.
        self.at_rest = held_still && self.gnss_still(now);
        self.imu.note_rate_changes(samples);
        self.now = now;
        let tuning = self.tuning(config);
        let mut ekf = match self.ekf.take() {
            Some(mut ekf) => {
                if *ekf.config() != tuning && ekf.set_config(tuning).is_err() {
                    // A refused tuning keeps the last good one.
                }
                ekf
            }
            None => match Ekf::new(tuning).or_else(|_| Ekf::new(EkfConfig::default())) {
                Ok(ekf) => ekf,
                Err(_) => return,
            },
        };
        for sample in samples {
            self.gnss.apply(sample);
            self.fuse(&mut ekf, config, sample);
        }
        let now_s = now.as_secs_f64();
        if now_s >= ekf.time_s() {
            let _ = ekf.predict_to(now_s);
        }
        // Every tick while at rest, or the speed's process noise between
        // GNSS epochs lets the (unobservable) curvature turn the vehicle.
        if held_still && self.gnss_still(now) && ekf.is_initialised() {
            let _ = ekf.update_odometry_speed(0.0, AT_REST_SPEED_SIGMA_MPS);
            let _ = ekf.update_yaw_rate(0.0, AT_REST_YAW_RATE_SIGMA_RAD_S);
        }
        self.publish(&ekf);
        self.ekf = Some(ekf);
    }

    /// A current fix whose speed says the vehicle stands.
    fn gnss_still(&self, now: Duration) -> bool {
        self.gnss.has_fix(now, Duration::from_secs(1)) && self.gnss.speed_mps.abs() < AT_REST_GNSS_SPEED_MPS
    }

    /// Advances the filter to the sample's time (or keeps it where it is for
    /// a sample stamped a little in the past).
    fn advance(ekf: &mut Ekf, t: Duration) {
        let t_s = t.as_secs_f64();
        if t_s > ekf.time_s() {
            let _ = ekf.predict_to(t_s);
        }
    }

    fn fuse(&mut self, ekf: &mut Ekf, config: &EstimatorConfig, sample: &GnssSample) {
        match sample {
            GnssSample::Fix(fix) => self.fuse_fix(ekf, config, fix),
            GnssSample::Accuracy(a) => self.accuracy_t = Some(a.t),
            GnssSample::Velocity(v) if v.speed_mps.is_finite() => self.fuse_velocity(ekf, config, v),
            GnssSample::Heading(h) if h.heading_deg.is_finite() => self.fuse_heading_sensor(ekf, config, h),
            GnssSample::Imu(imu) => {
                Self::advance(ekf, imu.t);
                let can_pivot = config.ekf.pivot_yaw_accel_sigma_radps2 > 0.0;
                if let Some(bias_rad_s) = self.imu.apply(ekf, imu, self.at_rest, can_pivot) {
                    self.events.push(EstimatorEvent::GyroCalibrated { bias_rad_s });
                }
            }
            _ => {}
        }
    }

    /// A position fix: the antenna's position in the frame (built at the
    /// first fix), with a change of fix quality reported and modelled.
    fn fuse_fix(&mut self, ekf: &mut Ekf, config: &EstimatorConfig, fix: &GnssFix) {
        let p = GeoPoint::new(fix.lat_deg, fix.lon_deg, fix.alt_msl_m);
        if fix.quality == FixQuality::NoFix || !p.is_valid() {
            return;
        }
        let frame = match self.frame {
            Some(frame) => frame,
            None => self.build_frame(config, p),
        };
        let antenna = frame.to_local(&p);
        let sigma = self.position_sigma(fix.t);
        Self::advance(ekf, fix.t);
        if self.fix_quality != Some(fix.quality) {
            self.events.push(EstimatorEvent::FixQuality {
                from: self.fix_quality,
                to: fix.quality,
            });
            let had_fix = self.fix_quality.is_some();
            self.fix_quality = Some(fix.quality);
            // A different kind of fix is a different error, mostly a
            // slow one: model it so, and start the position from the
            // fix rather than gate it against the old one.
            let _ = ekf.set_config(self.tuning(config));
            if ekf.is_initialised() && had_fix {
                let _ = ekf.reset_position_to_gnss(antenna.north_m, antenna.east_m, sigma.0, sigma.1);
            }
        }
        let fusion = ekf.update_gnss_position(antenna.north_m, antenna.east_m, sigma.0, sigma.1);
        self.position_fusion(ekf, fusion);
    }

    /// GNSS speed and course; without a heading sensor the course stands
    /// in for the heading while driving, turned round when the filter
    /// knows the vehicle reverses.
    fn fuse_velocity(&mut self, ekf: &mut Ekf, config: &EstimatorConfig, v: &GnssVelocity) {
        let frame = self.frame;
        let at = GeoPoint::new(self.gnss.lat_deg, self.gnss.lon_deg, self.gnss.alt_msl_m);
        let course = v
            .course_deg
            .filter(|c| c.is_finite())
            .map(|c| to_frame_heading(frame.as_ref(), &at, c.to_radians()));
        Self::advance(ekf, v.t);
        let _ = ekf.update_gnss_velocity(v.speed_mps.max(0.0), course, config.velocity_sigma_mps);
        let sensor_quiet = self
            .last_heading_sensor
            .is_none_or(|t| v.t.saturating_sub(t) > HEADING_SENSOR_TIMEOUT);
        if let (true, Some(course)) = (sensor_quiet, course)
            && v.speed_mps >= COURSE_AS_HEADING_MIN_MPS
        {
            let reversing = ekf.is_initialised() && ekf.state().speed_mps < 0.0;
            let yaw = if reversing {
                wrap_pi(course + std::f64::consts::PI)
            } else {
                course
            };
            let sigma = (config.velocity_sigma_mps / v.speed_mps).max(2f64.to_radians());
            let fusion = ekf.update_heading(yaw, sigma);
            self.heading_fusion(ekf, fusion);
        }
    }

    /// A heading sensor's reading (dual antenna, or a compass plus the
    /// declination), remembered to tell a frozen sensor.
    fn fuse_heading_sensor(&mut self, ekf: &mut Ekf, config: &EstimatorConfig, h: &GnssHeading) {
        let true_heading = match h.reference {
            HeadingReference::True => h.heading_deg.to_radians(),
            HeadingReference::Magnetic => h.heading_deg.to_radians() + config.declination_rad,
        };
        let at = GeoPoint::new(self.gnss.lat_deg, self.gnss.lon_deg, self.gnss.alt_msl_m);
        let yaw = to_frame_heading(self.frame.as_ref(), &at, true_heading);
        self.last_heading_sensor = Some(h.t);
        self.heading_reading = match self.heading_reading {
            Some((value, since)) if value == h.heading_deg => Some((value, since)),
            _ => Some((h.heading_deg, h.t)),
        };
        Self::advance(ekf, h.t);
        let fusion = ekf.update_heading(yaw, config.heading_sigma_rad);
        self.heading_fusion(ekf, fusion);
    }

    /// The local frame about the first fix, saying so when its kind cannot
    /// be the one asked for.
    fn build_frame(&mut self, config: &EstimatorConfig, origin: GeoPoint) -> LocalFrame {
        let frame = LocalFrame::with_kind(config.frame_kind, origin, config.map);
        if frame.kind() != config.frame_kind {
            self.events.push(EstimatorEvent::FrameSubstituted {
                requested: config.frame_kind,
                used: frame.kind(),
            });
        }
        self.frame = Some(frame);
        frame
    }

    /// The filter's tuning for the current fix and motion: the slowly
    /// wandering part of the GNSS error is `EKF_GPS_WALK` with RTK fixed, and
    /// most of the error of a float or single fix (which averaging does not
    /// remove). At rest a vehicle that can turn on the spot does not start
    /// pivoting unannounced (that takes a drive demand, which ends the rest):
    /// without pivot noise its heading averages down like a car's instead of
    /// following the heading sensor's noise. Moving, with the gyro fused, the
    /// pivot noise is what the gyro's rate changes call for (see [`imu`]).
    fn tuning(&self, config: &EstimatorConfig) -> EkfConfig {
        let slow = 0.7 * GnssStatus::quality_sigma_floor_m(self.fix_quality);
        EkfConfig {
            pivot_yaw_accel_sigma_radps2: match (self.at_rest, self.imu.pivot_accel_sigma(self.now)) {
                (true, _) => 0.0,
                (false, Some(gyro)) => gyro.min(config.ekf.pivot_yaw_accel_sigma_radps2),
                (false, None) => config.ekf.pivot_yaw_accel_sigma_radps2,
            },
            curvature_rate_sigma_per_m_s: if self.at_rest {
                0.0
            } else {
                config.ekf.curvature_rate_sigma_per_m_s
            },
            long_accel_sigma_mps2: if self.at_rest {
                0.0
            } else {
                config.ekf.long_accel_sigma_mps2
            },
            gnss_walk_sigma_m: if self.fix_quality == Some(FixQuality::RtkFixed) || self.fix_quality.is_none() {
                config.ekf.gnss_walk_sigma_m
            } else {
                config.ekf.gnss_walk_sigma_m.max(slow)
            },
            ..config.ekf
        }
    }

    /// Per-axis σ of the fix: GST when it is current, else the typical
    /// figure for the fix quality; never less than the quality allows (a
    /// receiver whose GST stays at centimetres after losing RTK is not
    /// believed).
    fn position_sigma(&self, t: Duration) -> (f64, f64) {
        let fresh = self.accuracy_t.is_some_and(|a| t.saturating_sub(a) <= ACCURACY_MAX_AGE);
        let floor = GnssStatus::quality_sigma_floor_m(self.gnss.quality);
        match (fresh, self.gnss.sigma_north_m, self.gnss.sigma_east_m) {
            (true, Some(n), Some(e)) if n > 0.0 && e > 0.0 => (n.max(floor), e.max(floor)),
            _ => {
                let s = GnssStatus::quality_sigma_m(self.gnss.quality);
                (s, s)
            }
        }
    }

    fn position_fusion(&mut self, ekf: &Ekf, fusion: Fusion) {
        match fusion {
            Fusion::Rejected { .. } => {
                if !self.position_rejecting {
                    let innovation = ekf.status().gnss_position.innovation;
                    self.events.push(EstimatorEvent::GpsJumpRejected {
                        distance_m: innovation[0].hypot(innovation[1]),
                    });
                }
                self.position_rejecting = true;
            }
            Fusion::Reset { shift, .. } => {
                self.position_rejecting = false;
                self.events.push(EstimatorEvent::PositionReset {
                    shift_m: shift[0].hypot(shift[1]),
                });
            }
            Fusion::Accepted { .. } => self.position_rejecting = false,
            Fusion::Initialised => self.events.push(EstimatorEvent::Initialised),
            _ => {}
        }
    }

    fn heading_fusion(&mut self, ekf: &Ekf, fusion: Fusion) {
        match fusion {
            Fusion::Rejected { .. } => {
                if !self.heading_rejecting {
                    let error_rad = ekf.status().heading.innovation[0];
                    self.events.push(EstimatorEvent::HeadingRejected { error_rad });
                }
                self.heading_rejecting = true;
            }
            Fusion::Reset { shift, .. } => {
                self.heading_rejecting = false;
                self.events.push(EstimatorEvent::HeadingReset { shift_rad: shift[0] });
            }
            Fusion::Accepted { .. } => self.heading_rejecting = false,
            Fusion::Initialised => self.events.push(EstimatorEvent::Initialised),
            _ => {}
        }
    }

    fn publish(&mut self, ekf: &Ekf) {
        if !ekf.is_initialised() {
            self.estimate.position_valid = false;
            self.estimate.heading_valid = false;
            return;
        }
        let s = ekf.state();
        let status = ekf.status();
        let healthy = ekf.healthy();
        if healthy != self.healthy {
            self.healthy = healthy;
            self.events.push(EstimatorEvent::Healthy(healthy));
        }
        let (sin, cos) = s.yaw_rad.sin_cos();
        self.estimate = Estimate {
            position: Ned::new(s.north_m, s.east_m),
            yaw_rad: s.yaw_rad,
            yaw_rate_rad_s: s.speed_mps * s.curvature_per_m + s.pivot_rate_rad_s,
            vel_north_mps: s.speed_mps * cos,
            vel_east_mps: s.speed_mps * sin,
            speed_mps: s.speed_mps,
            position_valid: healthy,
            heading_valid: status.heading_sigma_rad <= ekf.config().healthy_max_heading_sigma_rad,
            horiz_sigma_m: status.position_sigma_m,
        };
    }
}

/// A true heading as a heading in the local frame (meridian convergence,
/// plant-grid rotation); as it is before there is a frame.
fn to_frame_heading(frame: Option<&LocalFrame>, at: &GeoPoint, true_heading_rad: f64) -> f64 {
    match frame {
        Some(f) if at.is_valid() => f.heading_to_local(at, true_heading_rad),
        _ => wrap_pi(true_heading_rad),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fix(t_ms: u64, lat: f64, lon: f64, quality: FixQuality) -> GnssSample {
        GnssSample::Fix(GnssFix {
            t: Duration::from_millis(t_ms),
            utc_time_of_day_s: None,
            lat_deg: lat,
            lon_deg: lon,
            alt_msl_m: 40.0,
            quality,
            satellites: 20,
            hdop: 0.6,
        })
    }

    fn heading(t_ms: u64, deg: f64, reference: HeadingReference) -> GnssSample {
        GnssSample::Heading(GnssHeading {
            t: Duration::from_millis(t_ms),
            heading_deg: deg,
            reference,
        })
    }

    fn config(antenna_x: f64) -> EstimatorConfig {
        EstimatorConfig {
            ekf: EkfConfig {
                antenna_body_m: (antenna_x, 0.0),
                ..EkfConfig::default()
            },
            ..EstimatorConfig::default()
        }
    }

    #[test]
    fn lever_arm_moves_the_fix_to_the_reference_point() {
        let mut est = Estimator::new();
        // Origin at the first fix, vehicle facing east: the reference point
        // is 0.5 m west of the antenna.
        est.update(
            Duration::ZERO,
            &config(0.5),
            &[
                heading(0, 90.0, HeadingReference::True),
                fix(0, 29.133, 119.64, FixQuality::RtkFixed),
            ],
            false,
        );
        let e = est.estimate();
        assert!(e.position_valid && e.heading_valid, "{e:?}");
        assert!((e.position.east_m + 0.5).abs() < 1e-6, "{:?}", e.position);
        assert!(e.position.north_m.abs() < 1e-6);
        assert!(est.take_events().contains(&EstimatorEvent::Initialised));
    }

    #[test]
    fn a_true_heading_at_the_pole_itself_is_used() {
        // True north at 90° N is the limit along the reported meridian; at
        // the origin it is the frame's north axis.
        let mut est = Estimator::new();
        for k in 0..5u64 {
            est.update(
                Duration::from_millis(100 * k),
                &config(0.0),
                &[
                    heading(100 * k, 30.0, HeadingReference::True),
                    fix(100 * k, 90.0, 0.0, FixQuality::RtkFixed),
                ],
                false,
            );
        }
        let e = est.estimate();
        assert!(e.heading_valid && e.position_valid, "{e:?}");
        assert!(
            (e.yaw_rad.to_degrees() - 30.0).abs() < 1e-6,
            "{}",
            e.yaw_rad.to_degrees()
        );
        assert!(
            !est.take_events()
                .iter()
                .any(|e| matches!(e, EstimatorEvent::HeadingRejected { .. }))
        );
    }

    #[test]
    fn a_rejected_heading_reports_how_far_off_it_was() {
        let mut est = Estimator::new();
        for k in 0..20u64 {
            let true_heading_deg = if k < 10 { 30.0 } else { 70.0 };
            est.update(
                Duration::from_millis(100 * k),
                &config(0.0),
                &[
                    heading(100 * k, true_heading_deg, HeadingReference::True),
                    fix(100 * k, 45.0, 7.0, FixQuality::RtkFixed),
                ],
                false,
            );
        }
        let rejected: Vec<f64> = est
            .take_events()
            .iter()
            .filter_map(|e| match e {
                EstimatorEvent::HeadingRejected { error_rad } => Some(error_rad.to_degrees()),
                _ => None,
            })
            .collect();
        assert_eq!(rejected.len(), 1, "one event for the streak: {rejected:?}");
        assert!((rejected[0] - 40.0).abs() < 1.0, "{rejected:?}");
    }

    #[test]
    fn the_haversine_frame_is_replaced_and_reported_near_a_pole() {
        let mut est = Estimator::new();
        let cfg = EstimatorConfig {
            frame_kind: FrameKind::Haversine,
            ..config(0.0)
        };
        est.update(
            Duration::ZERO,
            &cfg,
            &[fix(0, -89.999, 30.0, FixQuality::RtkFixed)],
            false,
        );
        assert_eq!(est.frame().map(LocalFrame::kind), Some(FrameKind::TangentPlane));
        assert!(est.take_events().contains(&EstimatorEvent::FrameSubstituted {
            requested: FrameKind::Haversine,
            used: FrameKind::TangentPlane
        }));
        // Once: later fixes keep the frame quietly.
        est.update(
            Duration::from_millis(100),
            &cfg,
            &[fix(100, -89.999, 30.0, FixQuality::RtkFixed)],
            false,
        );
        assert!(
            !est.take_events()
                .iter()
                .any(|e| matches!(e, EstimatorEvent::FrameSubstituted { .. }))
        );
    }

    #[test]
    fn compass_heading_gets_the_declination() {
        let mut est = Estimator::new();
        let cfg = EstimatorConfig {
            declination_rad: 5f64.to_radians(),
            ..config(0.0)
        };
        est.update(
            Duration::ZERO,
            &cfg,
            &[
                heading(0, 40.0, HeadingReference::Magnetic),
                fix(0, 29.133, 119.64, FixQuality::RtkFixed),
            ],
            false,
        );
        assert!((est.estimate().yaw_rad.to_degrees() - 45.0).abs() < 1e-6);
    }

    #[test]
    fn fix_downgrade_is_reported_and_a_stale_fix_invalidates_position() {
        let mut est = Estimator::new();
        let cfg = config(0.0);
        let mut samples = vec![heading(0, 0.0, HeadingReference::True)];
        samples.push(fix(0, 29.133, 119.64, FixQuality::RtkFixed));
        est.update(Duration::ZERO, &cfg, &samples, false);
        for k in 1..5 {
            est.update(
                Duration::from_millis(100 * k),
                &cfg,
                &[
                    heading(100 * k, 0.0, HeadingReference::True),
                    fix(100 * k, 29.133, 119.64, FixQuality::RtkFixed),
                ],
                false,
            );
        }
        est.take_events();
        est.update(
            Duration::from_millis(500),
            &cfg,
            &[fix(500, 29.133, 119.64, FixQuality::RtkFloat)],
            false,
        );
        assert_eq!(
            est.take_events(),
            vec![EstimatorEvent::FixQuality {
                from: Some(FixQuality::RtkFixed),
                to: FixQuality::RtkFloat
            }]
        );
        assert!(est.estimate().position_valid);
        est.update(Duration::from_millis(2500), &cfg, &[], false);
        assert!(!est.estimate().position_valid);
        assert!(est.take_events().contains(&EstimatorEvent::Healthy(false)));
    }

    #[test]
    fn course_over_ground_stands_in_for_a_missing_heading_sensor() {
        let mut est = Estimator::new();
        let cfg = config(0.0);
        // Driving east at 2 m/s, no heading sensor.
        for k in 0..30u64 {
            let t = 100 * k;
            let east = 2.0 * (t as f64 / 1000.0);
            let lon = 119.64 + east / (111_320.0 * 29.133f64.to_radians().cos());
            est.update(
                Duration::from_millis(t),
                &cfg,
                &[
                    fix(t, 29.133, lon, FixQuality::RtkFixed),
                    GnssSample::Velocity(GnssVelocity {
                        t: Duration::from_millis(t),
                        speed_mps: 2.0,
                        course_deg: Some(90.0),
                    }),
                ],
                false,
            );
        }
        let e = est.estimate();
        assert!(e.heading_valid && e.position_valid, "{e:?}");
        assert!(
            (e.yaw_rad.to_degrees() - 90.0).abs() < 1.0,
            "{}",
            e.yaw_rad.to_degrees()
        );
        assert!((e.speed_mps - 2.0).abs() < 0.1);
    }
}
