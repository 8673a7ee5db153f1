//! What the filter reports: its state, the outcome of each input, and the
//! status snapshot for telemetry and failsafes.

use super::fusion::Kind;
use super::state::*;
use super::{Ekf, StateVector, all_finite};

/// The estimate, at the filter's time.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EkfState {
    /// Reference point, local NED.
    pub north_m: f64,
    pub east_m: f64,
    /// [-π, π), from north, clockwise.
    pub yaw_rad: f64,
    /// Signed forward speed of the reference point: negative in reverse.
    pub speed_mps: f64,
    /// Path curvature, positive turning right (in the direction of travel
    /// when driving forward).
    pub curvature_per_m: f64,
    /// Yaw rate not explained by curvature (turning on the spot).
    pub pivot_rate_rad_s: f64,
    /// Estimated slow GNSS error (antenna fix minus truth).
    pub gnss_bias_north_m: f64,
    pub gnss_bias_east_m: f64,
}

impl EkfState {
    pub(super) fn from_vector(x: &StateVector) -> Self {
        EkfState {
            north_m: x[NORTH],
            east_m: x[EAST],
            yaw_rad: x[YAW],
            speed_mps: x[SPEED],
            curvature_per_m: x[CURVATURE],
            pivot_rate_rad_s: x[PIVOT_RATE],
            gnss_bias_north_m: x[BIAS_NORTH],
            gnss_bias_east_m: x[BIAS_EAST],
        }
    }

    pub(super) fn to_vector(self) -> StateVector {
        StateVector::from([
            self.north_m,
            self.east_m,
            self.yaw_rad,
            self.speed_mps,
            self.curvature_per_m,
            self.pivot_rate_rad_s,
            self.gnss_bias_north_m,
            self.gnss_bias_east_m,
        ])
    }

    /// Clockwise positive.
    pub fn yaw_rate_rad_s(&self) -> f64 {
        self.speed_mps * self.curvature_per_m + self.pivot_rate_rad_s
    }

    pub fn vel_north_mps(&self) -> f64 {
        self.speed_mps * self.yaw_rad.cos()
    }

    pub fn vel_east_mps(&self) -> f64 {
        self.speed_mps * self.yaw_rad.sin()
    }
}

/// One-σ values for [`Ekf::initialise`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EkfSigmas {
    pub position_m: f64,
    pub yaw_rad: f64,
    pub speed_mps: f64,
    pub curvature_per_m: f64,
    pub pivot_rate_rad_s: f64,
}

/// Why an input was refused. A refused input changes nothing but the
/// `refused_inputs` counter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputError {
    /// NaN or infinite value.
    NotFinite,
    /// σ not strictly positive.
    BadSigma,
    /// A negative interval, a target time before the filter's time, or a
    /// negative GNSS speed.
    OutOfRange,
}

/// Why an input was not used although it was valid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Skip {
    /// Waiting for a position fix and a heading.
    NotInitialised,
    /// GNSS speed at or above [`EkfConfig::min_course_speed_mps`] without a
    /// course: nothing to fuse.
    NoCourse,
    /// The innovation covariance was singular or the update produced
    /// non-finite values: nothing was changed (counted in `numerical_faults`).
    Numerical,
}

/// What an update did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fusion {
    /// Fused. `test_ratio` is NIS / gate (1.0 = at the gate).
    Accepted {
        test_ratio: f64,
    },
    /// Failed the innovation gate and was not fused; for a GNSS position this
    /// is a GPS jump to report.
    Rejected {
        test_ratio: f64,
    },
    /// Rejected for longer than the reset time: the state was reset to the
    /// measurement (a relocation to report). `shift` is the change of the
    /// reset quantity (m north/east for position, rad for heading).
    Reset {
        test_ratio: f64,
        shift: [f64; 2],
    },
    /// This sample completed the initialisation.
    Initialised,
    /// Held for initialisation until the other half arrives.
    Held,
    Skipped(Skip),
    Refused(InputError),
}

impl Fusion {
    /// True for a sample that disagreed with the estimate beyond the gate:
    /// rejected or, once persistent, reset to. For a GNSS position this is
    /// the "GPS jump" to report (STATUSTEXT, EKF_STATUS_REPORT).
    pub fn is_jump(&self) -> bool {
        matches!(self, Fusion::Rejected { .. } | Fusion::Reset { .. })
    }
}

/// Innovation bookkeeping for one kind of measurement.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct InnovationStatus {
    /// Last innovation (measurement − prediction), per axis: north/east m for
    /// position, north/east m/s for velocity, rad (wrapped) for heading, m/s
    /// for odometry, rad/s for yaw rate; unused axes are zero.
    pub innovation: [f64; 2],
    /// σ of that innovation predicted by the filter (√ of S's diagonal).
    pub innovation_sigma: [f64; 2],
    /// Normalised innovation squared over the χ² gate: 1.0 = at the gate.
    /// EKF_STATUS_REPORT sends its square root, as ArduPilot does
    /// ([`InnovationStatus::report_value`]).
    pub test_ratio: f64,
    pub accepted: u32,
    pub rejected: u32,
    /// Rejections since the last accepted sample.
    pub consecutive_rejected: u32,
    /// Filter time of the first rejection of the current streak.
    pub rejecting_since_s: Option<f64>,
    /// Filter time of the last accepted (or reset-to) sample.
    pub last_accepted_s: Option<f64>,
    /// Resets to this measurement after persistent rejection.
    pub resets: u32,
}

impl InnovationStatus {
    /// The value EKF_STATUS_REPORT carries for this measurement
    /// (ArduPilot's `sqrt(testRatio)`).
    pub fn report_value(&self) -> f32 {
        self.test_ratio.max(0.0).sqrt() as f32
    }

    pub(super) fn record(&mut self, innovation: &[f64], s_diag: &[f64], test_ratio: f64) {
        self.innovation = [0.0; 2];
        self.innovation_sigma = [0.0; 2];
        for (slot, v) in self.innovation.iter_mut().zip(innovation) {
            *slot = *v;
        }
        for (slot, v) in self.innovation_sigma.iter_mut().zip(s_diag) {
            *slot = v.max(0.0).sqrt();
        }
        self.test_ratio = test_ratio;
    }

    pub(super) fn accept(&mut self, now_s: f64) {
        self.accepted = self.accepted.saturating_add(1);
        self.consecutive_rejected = 0;
        self.rejecting_since_s = None;
        self.last_accepted_s = Some(now_s);
    }

    pub(super) fn reject(&mut self, now_s: f64) {
        self.rejected = self.rejected.saturating_add(1);
        self.consecutive_rejected = self.consecutive_rejected.saturating_add(1);
        self.rejecting_since_s.get_or_insert(now_s);
    }

    pub(super) fn rejecting_for_s(&self, now_s: f64) -> f64 {
        self.rejecting_since_s.map_or(0.0, |t| now_s - t)
    }
}

/// A snapshot for telemetry and failsafes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EkfStatus {
    pub initialised: bool,
    /// Sum of the predicted intervals.
    pub time_s: f64,
    /// 1-σ of the reference point per axis and horizontally (√(σn² + σe²)).
    pub position_sigma_north_m: f64,
    pub position_sigma_east_m: f64,
    pub position_sigma_m: f64,
    pub speed_sigma_mps: f64,
    pub heading_sigma_rad: f64,
    pub yaw_rate_sigma_rad_s: f64,
    pub gnss_position: InnovationStatus,
    pub gnss_velocity: InnovationStatus,
    pub heading: InnovationStatus,
    pub odometry: InnovationStatus,
    pub yaw_rate: InnovationStatus,
    /// Inputs refused as NaN/inf/out of range.
    pub refused_inputs: u32,
    /// Updates abandoned because the arithmetic went non-finite.
    pub numerical_faults: u32,
    /// Shift (m north, east) of the last position reset, for reporting.
    pub last_position_reset_m: [f64; 2],
    pub healthy: bool,
}

impl Ekf {
    /// Initialised, finite, σ within limits, and a GNSS position accepted
    /// within `position_timeout_s` (a GPS jump being rejected turns this false
    /// once it lasts longer than that; a reset turns it true again).
    pub fn healthy(&self) -> bool {
        if !self.initialised || !all_finite(self.x.as_slice()) || !all_finite(self.p.as_slice()) {
            return false;
        }
        let c = &self.config;
        let pos_sigma = (self.p[(NORTH, NORTH)] + self.p[(EAST, EAST)]).max(0.0).sqrt();
        let heading_sigma = self.p[(YAW, YAW)].max(0.0).sqrt();
        let fused_recently = self.innovations[Kind::Position as usize]
            .last_accepted_s
            .is_some_and(|t| self.time_s - t <= c.position_timeout_s);
        pos_sigma <= c.healthy_max_position_sigma_m
            && heading_sigma <= c.healthy_max_heading_sigma_rad
            && fused_recently
    }

    pub fn status(&self) -> EkfStatus {
        let var = |i: usize| self.p[(i, i)].max(0.0);
        // σ of ω = v·κ + ω_p through its gradient.
        let g = {
            let mut g = StateVector::zeros();
            g[SPEED] = self.x[CURVATURE];
            g[CURVATURE] = self.x[SPEED];
            g[PIVOT_RATE] = 1.0;
            g
        };
        let yaw_rate_var = (g.transpose() * self.p * g)[(0, 0)].max(0.0);
        EkfStatus {
            initialised: self.initialised,
            time_s: self.time_s,
            position_sigma_north_m: var(NORTH).sqrt(),
            position_sigma_east_m: var(EAST).sqrt(),
            position_sigma_m: (var(NORTH) + var(EAST)).sqrt(),
            speed_sigma_mps: var(SPEED).sqrt(),
            heading_sigma_rad: var(YAW).sqrt(),
            yaw_rate_sigma_rad_s: yaw_rate_var.sqrt(),
            gnss_position: self.innovations[Kind::Position as usize],
            gnss_velocity: self.innovations[Kind::Velocity as usize],
            heading: self.innovations[Kind::Heading as usize],
            odometry: self.innovations[Kind::Odometry as usize],
            yaw_rate: self.innovations[Kind::YawRate as usize],
            refused_inputs: self.refused_inputs,
            numerical_faults: self.numerical_faults,
            last_position_reset_m: self.last_position_reset_m,
            healthy: self.healthy(),
        }
    }
}
