//! An extended Kalman filter for a wheeled ground vehicle (docs/architecture.md §Estimation).
//!
//! Pure: no clocks, no I/O, no allocation. The caller owns time and feeds the
//! filter explicit inputs. Cost measured by the `cost_per_step` test in
//! `autopilot/tests/ekf.rs` (release, x86-64, one core of a shared machine):
//! 0.14–0.55 µs per predict, 0.06–0.45 µs per update (heading cheapest,
//! GNSS position and velocity with their second-order terms dearest), under
//! 0.1 µs for `status()`, the spread being the machine's load; a debug build
//! is about 100× slower.
//!
//! # Conventions
//! - Local NED metres (the same plane as `crate::geo::Ned`; this module keeps
//!   plain `f64`s so it depends on nothing but `nalgebra`).
//! - Yaw in radians from north, clockwise, wrapped to [-π, π).
//! - Body x forward, y right, z down; a positive yaw rate turns right.
//! - The state describes the vehicle **reference point** (the rear axle
//!   centre), the point whose velocity lies along body x.
//!
//! # Model
//! The state is [north, east, yaw, v, κ, ω_p, b_north, b_east]:
//! - `v` is the signed forward speed of the reference point (reverse < 0);
//!   it never moves sideways (nonholonomic: no lateral state at all);
//! - the yaw rate is `ω = v·κ + ω_p`: `κ` is the path curvature the steering
//!   sets, `ω_p` a pivot rate for vehicles that turn on the spot
//!   (differential drive). Why curvature instead of a plain yaw-rate state:
//!   an Ackermann vehicle cannot turn without moving, so with `ω_p` held at
//!   zero (its default noise) a stopped vehicle's yaw is constant and the
//!   filter averages the heading sensor down at a stop — what the 0.05°
//!   precision stop needs. A free yaw-rate state keeps fitting a slope to
//!   the heading and stays near the sensor's own σ;
//! - `b` is the slow GNSS position error (first-order Gauss–Markov, the
//!   bench's "5 mm over a minute"): modelling it keeps the filter's σ honest
//!   when it averages a stopped vehicle's fixes, because that part of the
//!   error does not average out.
//!
//! Between samples `v`, `κ` and `ω_p` are constant and the reference point
//! follows the exact arc. Process noise is white and continuous-time, so the
//! filter behaves the same at any predict rate: longitudinal acceleration
//! (m/s² per √Hz), curvature rate (steering, 1/m/s per √Hz), pivot yaw
//! acceleration (rad/s² per √Hz) and an optional position noise for slip.
//!
//! # Updates
//! GNSS antenna position (through the lever arm, σ per axis as the receiver
//! reports it), GNSS antenna velocity (speed and course, with ω × r), heading
//! (wrapped innovation), and optionally wheel-odometry speed and yaw rate.
//! Each is gated on its normalised innovation squared against a χ² threshold
//! ([`chi2_gate`] of a gate in σ); position, velocity and heading samples
//! rejected for longer than a configurable time reset their state to the
//! measurement. The covariance update is the Joseph form, built symmetric.
//! The few products of states in the measurement models (yaw with the lever
//! arm, speed with yaw and curvature) also get their second-order terms,
//! which only matter while those states are still uncertain. Inputs that are
//! NaN, infinite or have a σ ≤ 0 are refused and change nothing.
//!
//! # Time contract
//! Measurements are applied at their own timestamps: before applying a
//! sample stamped `t`, predict to `t` ([`Ekf::predict`] with `t − last`, or
//! [`Ekf::predict_to`]). The filter never looks at a clock; its time is the
//! sum of the predicted intervals. A sample older than the filter's time
//! cannot be applied in order: `predict_to` refuses to go back and the caller
//! decides (apply it late or drop it). To output a pose at a later instant
//! without moving the filter past samples still to come, use
//! [`Ekf::state_after`].
//!
//! # Initialisation
//! The filter starts uninitialised. It needs a position fix and a heading
//! (dual-antenna, or a declination-corrected magnetometer with its σ):
//! whichever arrives first is held ([`Fusion::Held`]); the first of the other
//! kind no older than [`EkfConfig::init_max_age_s`] initialises the filter at
//! the held fix moved through the lever arm with that heading. A GNSS
//! velocity held at that point gives the initial signed speed. Without a
//! heading source the filter does not start; a caller that knows the vehicle
//! drives forward may feed the course over ground as a heading with a large σ.
//! [`Ekf::initialise`] sets any state with explicit σ.

use nalgebra::{SMatrix, SVector};

/// Number of states.
pub const STATE_LEN: usize = 8;

/// Indices into the state vector and covariance.
pub mod state {
    pub const NORTH: usize = 0;
    pub const EAST: usize = 1;
    pub const YAW: usize = 2;
    pub const SPEED: usize = 3;
    pub const CURVATURE: usize = 4;
    pub const PIVOT_RATE: usize = 5;
    pub const BIAS_NORTH: usize = 6;
    pub const BIAS_EAST: usize = 7;
}
use state::*;

pub type StateVector = SVector<f64, STATE_LEN>;
pub type StateCovariance = SMatrix<f64, STATE_LEN, STATE_LEN>;

/// Longest single propagation step: longer gaps are split so the linearised
/// covariance propagation stays close to the continuous one.
const MAX_STEP_S: f64 = 0.1;
/// Bound on the number of substeps: a gap of hours costs no more than this.
const MAX_SUBSTEPS: usize = 100;
/// The white part of a GNSS σ never drops below this fraction of it, even
/// when the configured walk σ is as large as the σ the receiver reports.
const MIN_WHITE_FRACTION: f64 = 0.5;

/// Wraps an angle to [-π, π) (as `crate::geo::wrap_pi`; repeated so this
/// module compiles on its own).
pub fn wrap_pi(angle_rad: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    // In range already (nearly always): leave it bit-exact.
    if (-PI..PI).contains(&angle_rad) {
        return angle_rad;
    }
    (angle_rad + PI).rem_euclid(TAU) - PI
}

/// Complementary error function (Numerical Recipes' Chebyshev fit, relative
/// error below 1.2e-7 everywhere): only used to turn a gate in σ into a χ²
/// threshold, where that error is irrelevant.
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

/// χ² threshold with the same tail probability as a two-sided `n_sigma`
/// Gaussian gate: `n_sigma²` for one degree of freedom, `−2 ln P(|N| > n)` for
/// two (the χ²₂ tail is `exp(−x/2)`). 5σ gives 25.0 and 28.74.
pub fn chi2_gate(dof: usize, n_sigma: f64) -> f64 {
    match dof {
        1 => n_sigma * n_sigma,
        _ => -2.0 * erfc(n_sigma / std::f64::consts::SQRT_2).ln(),
    }
}

/// Tuning and geometry. Every σ is one standard deviation; "per √Hz" σ are
/// continuous white-noise densities: the quantity's random walk grows by that
/// σ after one second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EkfConfig {
    /// GNSS antenna in the body frame (x forward, y right) from the reference
    /// point (`GPS_POS1_X/Y`).
    pub antenna_body_m: (f64, f64),
    /// Longitudinal acceleration noise (per √Hz): how fast the speed may change
    /// unannounced.
    pub long_accel_sigma_mps2: f64,
    /// Curvature rate noise (per √Hz): steering rate / wheelbase.
    pub curvature_rate_sigma_per_m_s: f64,
    /// Yaw acceleration not explained by curvature (per √Hz): zero for
    /// Ackermann vehicles (they cannot pivot), positive for differential drive.
    pub pivot_yaw_accel_sigma_radps2: f64,
    /// Position noise (per √Hz) for unmodelled motion such as sideslip.
    pub position_sigma_m_per_sqrt_s: f64,
    /// The tightest turn the vehicle can drive (tan(max steer)/wheelbase); the
    /// curvature σ is never allowed above it, so a long stop (when curvature
    /// is unobservable) does not leave an absurd uncertainty behind.
    pub max_curvature_per_m: f64,
    /// Stationary σ of the slow GNSS position error (per axis).
    pub gnss_walk_sigma_m: f64,
    /// Correlation time of the slow GNSS position error.
    pub gnss_walk_tau_s: f64,
    /// Innovation gates, in σ (converted to χ² by [`chi2_gate`]).
    pub position_gate_sigma: f64,
    pub velocity_gate_sigma: f64,
    pub heading_gate_sigma: f64,
    /// Gate for wheel odometry speed and yaw rate.
    pub odometry_gate_sigma: f64,
    /// GNSS positions rejected for this long (filter time from the first
    /// rejection of an unbroken streak) are taken as a real relocation: the
    /// position is reset to the GNSS.
    pub position_reset_after_s: f64,
    /// The same for heading (e.g. a dual-antenna solution that re-resolved).
    pub heading_reset_after_s: f64,
    /// The same for GNSS velocity: the speed is reset to the GNSS's.
    pub velocity_reset_after_s: f64,
    /// Below this GNSS speed the course is noise and is not used: the
    /// measurement only bounds the speed (see [`Ekf::update_gnss_velocity`]).
    pub min_course_speed_mps: f64,
    /// A fix or heading held for initialisation is discarded after this.
    pub init_max_age_s: f64,
    /// Speed σ at initialisation (the speed is not measured yet).
    pub init_speed_sigma_mps: f64,
    /// Pivot-rate σ at initialisation (zero for Ackermann).
    pub init_pivot_rate_sigma_rad_s: f64,
    /// `healthy()` limits.
    pub healthy_max_position_sigma_m: f64,
    pub healthy_max_heading_sigma_rad: f64,
    /// `healthy()` needs an accepted GNSS position at most this old.
    pub position_timeout_s: f64,
}

impl Default for EkfConfig {
    /// Tuned on the bench conditions (RTK 10 mm + 5 mm/60 s walk, 0.05°
    /// heading, 10 Hz; Ackermann, wheelbase 2.9 m, 30° steer at 30°/s,
    /// accel/brake 1/2 m/s²).
    fn default() -> Self {
        EkfConfig {
            antenna_body_m: (0.0, 0.0),
            long_accel_sigma_mps2: 0.3,
            curvature_rate_sigma_per_m_s: 0.1,
            pivot_yaw_accel_sigma_radps2: 0.0,
            position_sigma_m_per_sqrt_s: 0.0,
            max_curvature_per_m: 0.25,
            gnss_walk_sigma_m: 0.005,
            gnss_walk_tau_s: 60.0,
            position_gate_sigma: 5.0,
            velocity_gate_sigma: 5.0,
            heading_gate_sigma: 5.0,
            odometry_gate_sigma: 5.0,
            position_reset_after_s: 1.5,
            heading_reset_after_s: 1.5,
            velocity_reset_after_s: 1.5,
            min_course_speed_mps: 0.1,
            init_max_age_s: 0.5,
            init_speed_sigma_mps: 2.0,
            init_pivot_rate_sigma_rad_s: 0.0,
            healthy_max_position_sigma_m: 1.0,
            healthy_max_heading_sigma_rad: 5f64.to_radians(),
            position_timeout_s: 1.0,
        }
    }
}

/// Why a configuration was refused: the name of the offending field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ConfigError(pub &'static str);

impl std::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "invalid EKF setting {}", self.0)
    }
}

impl std::error::Error for ConfigError {}

impl EkfConfig {
    pub fn validate(&self) -> Result<(), ConfigError> {
        let finite = |v: f64, name| if v.is_finite() { Ok(()) } else { Err(ConfigError(name)) };
        let non_negative = |v: f64, name| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(ConfigError(name))
            }
        };
        let positive = |v: f64, name| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(ConfigError(name))
            }
        };
        finite(self.antenna_body_m.0, "antenna_body_m.0")?;
        finite(self.antenna_body_m.1, "antenna_body_m.1")?;
        non_negative(self.long_accel_sigma_mps2, "long_accel_sigma_mps2")?;
        non_negative(self.curvature_rate_sigma_per_m_s, "curvature_rate_sigma_per_m_s")?;
        non_negative(self.pivot_yaw_accel_sigma_radps2, "pivot_yaw_accel_sigma_radps2")?;
        non_negative(self.position_sigma_m_per_sqrt_s, "position_sigma_m_per_sqrt_s")?;
        positive(self.max_curvature_per_m, "max_curvature_per_m")?;
        non_negative(self.gnss_walk_sigma_m, "gnss_walk_sigma_m")?;
        positive(self.gnss_walk_tau_s, "gnss_walk_tau_s")?;
        positive(self.position_gate_sigma, "position_gate_sigma")?;
        positive(self.velocity_gate_sigma, "velocity_gate_sigma")?;
        positive(self.heading_gate_sigma, "heading_gate_sigma")?;
        positive(self.odometry_gate_sigma, "odometry_gate_sigma")?;
        non_negative(self.position_reset_after_s, "position_reset_after_s")?;
        non_negative(self.heading_reset_after_s, "heading_reset_after_s")?;
        non_negative(self.velocity_reset_after_s, "velocity_reset_after_s")?;
        non_negative(self.min_course_speed_mps, "min_course_speed_mps")?;
        non_negative(self.init_max_age_s, "init_max_age_s")?;
        non_negative(self.init_speed_sigma_mps, "init_speed_sigma_mps")?;
        non_negative(self.init_pivot_rate_sigma_rad_s, "init_pivot_rate_sigma_rad_s")?;
        positive(self.healthy_max_position_sigma_m, "healthy_max_position_sigma_m")?;
        positive(self.healthy_max_heading_sigma_rad, "healthy_max_heading_sigma_rad")?;
        positive(self.position_timeout_s, "position_timeout_s")?;
        Ok(())
    }
}

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
    fn from_vector(x: &StateVector) -> Self {
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

    fn to_vector(self) -> StateVector {
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

    fn record(&mut self, innovation: &[f64], s_diag: &[f64], test_ratio: f64) {
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

    fn accept(&mut self, now_s: f64) {
        self.accepted = self.accepted.saturating_add(1);
        self.consecutive_rejected = 0;
        self.rejecting_since_s = None;
        self.last_accepted_s = Some(now_s);
    }

    fn reject(&mut self, now_s: f64) {
        self.rejected = self.rejected.saturating_add(1);
        self.consecutive_rejected = self.consecutive_rejected.saturating_add(1);
        self.rejecting_since_s.get_or_insert(now_s);
    }

    fn rejecting_for_s(&self, now_s: f64) -> f64 {
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

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Position = 0,
    Velocity = 1,
    Heading = 2,
    Odometry = 3,
    YawRate = 4,
}

/// A sample held until the filter can start.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Held<T> {
    at_s: f64,
    value: T,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct HeldFix {
    antenna_north_m: f64,
    antenna_east_m: f64,
    sigma_north_m: f64,
    sigma_east_m: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct HeldHeading {
    yaw_rad: f64,
    sigma_rad: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct HeldVelocity {
    speed_mps: f64,
    course_rad: f64,
}

enum Gate {
    Accepted(f64),
    Rejected(f64),
    Numerical,
}

/// The filter. See the module documentation for the model and the contract.
#[derive(Clone, Debug)]
pub struct Ekf {
    config: EkfConfig,
    gate_chi2_1dof: [f64; 5],
    gate_chi2_2dof: [f64; 5],
    initialised: bool,
    time_s: f64,
    x: StateVector,
    p: StateCovariance,
    innovations: [InnovationStatus; 5],
    held_fix: Option<Held<HeldFix>>,
    held_heading: Option<Held<HeldHeading>>,
    held_velocity: Option<Held<HeldVelocity>>,
    refused_inputs: u32,
    numerical_faults: u32,
    last_position_reset_m: [f64; 2],
}

fn all_finite(values: &[f64]) -> bool {
    values.iter().all(|v| v.is_finite())
}

fn sigma_ok(sigma: f64) -> bool {
    sigma.is_finite() && sigma > 0.0
}

/// Averages the two triangles (rounding leaves them a few ulps apart).
fn symmetrise(p: &mut StateCovariance) {
    for i in 0..STATE_LEN {
        for j in i + 1..STATE_LEN {
            let v = 0.5 * (p[(i, j)] + p[(j, i)]);
            p[(i, j)] = v;
            p[(j, i)] = v;
        }
    }
}

/// sin(h)/h and its derivative, with series near zero where the closed forms
/// lose all their digits.
fn sinc_and_derivative(h: f64) -> (f64, f64) {
    if h.abs() < 1e-4 {
        let h2 = h * h;
        (1.0 - h2 / 6.0, -h / 3.0 + h * h2 / 30.0)
    } else {
        let (s, c) = h.sin_cos();
        (s / h, (h * c - s) / (h * h))
    }
}

/// One propagation step of `dt_s` with `v`, `κ`, `ω_p` constant: the
/// reference point moves along the exact arc. Returns the new state and the
/// Jacobian of the motion (the bias decay is applied by the caller).
pub fn propagate(x: &StateVector, dt_s: f64) -> (StateVector, StateCovariance) {
    let (yaw, v, k, wp) = (x[YAW], x[SPEED], x[CURVATURE], x[PIVOT_RATE]);
    let w = v * k + wp;
    let half = 0.5 * w * dt_s;
    let (sinc, dsinc) = sinc_and_derivative(half);
    // Chord of the arc and its direction (the mid-arc heading).
    let chord = v * dt_s * sinc;
    let (s_mid, c_mid) = (yaw + half).sin_cos();

    let mut next = *x;
    next[NORTH] += chord * c_mid;
    next[EAST] += chord * s_mid;
    next[YAW] = wrap_pi(yaw + w * dt_s);

    // d(half)/d(v, κ, ω_p) and d(chord)/d(v, κ, ω_p).
    let d_half = [0.5 * k * dt_s, 0.5 * v * dt_s, 0.5 * dt_s];
    let d_chord = [
        dt_s * sinc + v * dt_s * dsinc * d_half[0],
        v * dt_s * dsinc * d_half[1],
        v * dt_s * dsinc * d_half[2],
    ];
    let mut f = StateCovariance::identity();
    f[(NORTH, YAW)] = -chord * s_mid;
    f[(EAST, YAW)] = chord * c_mid;
    for (j, col) in [SPEED, CURVATURE, PIVOT_RATE].into_iter().enumerate() {
        f[(NORTH, col)] = d_chord[j] * c_mid - chord * s_mid * d_half[j];
        f[(EAST, col)] = d_chord[j] * s_mid + chord * c_mid * d_half[j];
        f[(YAW, col)] = 2.0 * d_half[j];
    }
    (next, f)
}

/// Rows of the motion Jacobian that differ from the identity, and the
/// columns where they do (the bias decay aside).
const MOVED_ROWS: [usize; 3] = [NORTH, EAST, YAW];
const DRIVING_COLS: [usize; 4] = [YAW, SPEED, CURVATURE, PIVOT_RATE];

/// `F·P·Fᵀ + Q` for the motion Jacobian `f` from [`propagate`] with the bias
/// decay `phi` and its exact noise `bias_q`, and continuous white noise of
/// densities `qc` integrated through the (locally linear) dynamics: with
/// M = F − I ≈ A·dt, Q ≈ dt·(Qc + (M Qc + Qc Mᵀ)/2 + M Qc Mᵀ/3), exact for
/// the double integrator (the dt³/3, dt²/2, dt terms). F − I is zero outside
/// a 3×4 block and the bias diagonal, so the products are written out: a
/// dense 8×8 triple product costs ten times more (a hundred in debug builds).
pub fn propagate_covariance(
    p: &StateCovariance,
    f: &StateCovariance,
    phi: f64,
    bias_q: f64,
    qc: &[f64; STATE_LEN],
    dt_s: f64,
) -> StateCovariance {
    let m = |i: usize, j: usize| f[(i, j)] - if i == j { 1.0 } else { 0.0 };
    // A = F·P, rows first (reading the old P only).
    let mut a = *p;
    for &i in &MOVED_ROWS {
        for k in 0..STATE_LEN {
            a[(i, k)] += DRIVING_COLS.iter().map(|&j| m(i, j) * p[(j, k)]).sum::<f64>();
        }
    }
    for b in [BIAS_NORTH, BIAS_EAST] {
        for k in 0..STATE_LEN {
            a[(b, k)] *= phi;
        }
    }
    // F·P·Fᵀ = A·Fᵀ, columns (reading A only).
    let mut out = a;
    for &i in &MOVED_ROWS {
        for k in 0..STATE_LEN {
            out[(k, i)] += DRIVING_COLS.iter().map(|&j| a[(k, j)] * m(i, j)).sum::<f64>();
        }
    }
    for b in [BIAS_NORTH, BIAS_EAST] {
        for k in 0..STATE_LEN {
            out[(k, b)] *= phi;
        }
    }
    // Q: Qc is diagonal and only v, κ, ω_p (among the driving columns) carry
    // noise into the moved rows.
    for (j, q) in qc.iter().enumerate() {
        out[(j, j)] += q * dt_s;
    }
    const NOISY: [usize; 3] = [SPEED, CURVATURE, PIVOT_RATE];
    for &i in &MOVED_ROWS {
        for &j in &NOISY {
            let half = 0.5 * m(i, j) * qc[j] * dt_s;
            out[(i, j)] += half;
            out[(j, i)] += half;
        }
        for &k in &MOVED_ROWS {
            out[(i, k)] += NOISY.iter().map(|&j| m(i, j) * qc[j] * m(k, j)).sum::<f64>() * dt_s / 3.0;
        }
    }
    out[(BIAS_NORTH, BIAS_NORTH)] += bias_q;
    out[(BIAS_EAST, BIAS_EAST)] += bias_q;
    out
}

/// The antenna position the state predicts, and its Jacobian.
pub fn antenna_position(x: &StateVector, antenna_body_m: (f64, f64)) -> (SVector<f64, 2>, SMatrix<f64, 2, STATE_LEN>) {
    let (ax, ay) = antenna_body_m;
    let (s, c) = x[YAW].sin_cos();
    let z = SVector::<f64, 2>::new(
        x[NORTH] + c * ax - s * ay + x[BIAS_NORTH],
        x[EAST] + s * ax + c * ay + x[BIAS_EAST],
    );
    let mut h = SMatrix::<f64, 2, STATE_LEN>::zeros();
    h[(0, NORTH)] = 1.0;
    h[(1, EAST)] = 1.0;
    h[(0, YAW)] = -s * ax - c * ay;
    h[(1, YAW)] = c * ax - s * ay;
    h[(0, BIAS_NORTH)] = 1.0;
    h[(1, BIAS_EAST)] = 1.0;
    (z, h)
}

/// The antenna's NED velocity the state predicts (reference-point velocity
/// plus ω × r), and its Jacobian.
pub fn antenna_velocity(x: &StateVector, antenna_body_m: (f64, f64)) -> (SVector<f64, 2>, SMatrix<f64, 2, STATE_LEN>) {
    let (ax, ay) = antenna_body_m;
    let (v, k, wp) = (x[SPEED], x[CURVATURE], x[PIVOT_RATE]);
    let w = v * k + wp;
    // Body-frame antenna velocity: (v, 0) + (0, 0, ω) × (ax, ay, 0).
    let (u, lat) = (v - w * ay, w * ax);
    let (s, c) = x[YAW].sin_cos();
    let vn = c * u - s * lat;
    let ve = s * u + c * lat;
    // dω/d(v, κ, ω_p)
    let dw = [k, v, 1.0];
    let mut h = SMatrix::<f64, 2, STATE_LEN>::zeros();
    h[(0, YAW)] = -ve;
    h[(1, YAW)] = vn;
    for (j, col) in [SPEED, CURVATURE, PIVOT_RATE].into_iter().enumerate() {
        let du = if col == SPEED { 1.0 } else { 0.0 } - dw[j] * ay;
        let dlat = dw[j] * ax;
        h[(0, col)] = c * du - s * dlat;
        h[(1, col)] = s * du + c * dlat;
    }
    (SVector::<f64, 2>::new(vn, ve), h)
}

/// Hessian of one measurement component over the states whose effect is
/// nonlinear: yaw, v, κ, ω_p (contiguous in the state, from [`YAW`]).
type Hessian = SMatrix<f64, 4, 4>;
const NONLINEAR: usize = YAW;

/// Second-order EKF terms: the expected value of the second-order part of
/// the measurement (½ tr(A_i P)) and its covariance (½ tr(A_i P A_j P)),
/// with P the block over [`NONLINEAR`]. Negligible once yaw and speed are
/// known (σ_yaw² ~ 1e-7), they keep the first fusions after a poor start
/// from, e.g., turning a cross-track velocity into a 100° yaw change at an
/// uncertain low speed.
fn second_order<const M: usize>(p: &StateCovariance, hessians: &[Hessian; M]) -> (SVector<f64, M>, SMatrix<f64, M, M>) {
    // A_i·P over the 4×4 block, then traces as sums: tr(X·Y) = Σ X_ab·Y_ba.
    let ap: [[[f64; 4]; 4]; M] = std::array::from_fn(|i| {
        std::array::from_fn(|a| {
            std::array::from_fn(|b| {
                (0..4)
                    .map(|k| hessians[i][(a, k)] * p[(NONLINEAR + k, NONLINEAR + b)])
                    .sum()
            })
        })
    });
    let trace_of_product = |x: &[[f64; 4]; 4], y: &[[f64; 4]; 4]| -> f64 {
        (0..4).map(|a| (0..4).map(|b| x[a][b] * y[b][a]).sum::<f64>()).sum()
    };
    let mean = SVector::<f64, M>::from_fn(|i, _| 0.5 * (0..4).map(|a| ap[i][a][a]).sum::<f64>());
    let cov = SMatrix::<f64, M, M>::from_fn(|i, j| 0.5 * trace_of_product(&ap[i], &ap[j]));
    (mean, cov)
}

/// Hessians of the antenna position: only yaw² (−R(yaw)·r).
pub fn antenna_position_hessians(x: &StateVector, antenna_body_m: (f64, f64)) -> [SMatrix<f64, 4, 4>; 2] {
    let (ax, ay) = antenna_body_m;
    let (s, c) = x[YAW].sin_cos();
    let rho = [c * ax - s * ay, s * ax + c * ay];
    std::array::from_fn(|i| {
        let mut a = Hessian::zeros();
        a[(0, 0)] = -rho[i];
        a
    })
}

/// Hessians of the antenna velocity h = R(yaw)·b(v, κ, ω_p) over
/// (yaw, v, κ, ω_p): yaw² gives −h, yaw×q the rotated Jacobian column, and
/// v×κ (ω = v·κ + ω_p) the lever-arm direction R(yaw)·(−a_y, a_x).
pub fn antenna_velocity_hessians(x: &StateVector, antenna_body_m: (f64, f64)) -> [SMatrix<f64, 4, 4>; 2] {
    let (ax, ay) = antenna_body_m;
    let (h, jac) = antenna_velocity(x, antenna_body_m);
    let (s, c) = x[YAW].sin_cos();
    let lever_dir = [c * -ay - s * ax, s * -ay + c * ax];
    std::array::from_fn(|i| {
        let mut a = Hessian::zeros();
        a[(0, 0)] = -h[i];
        for q in 1..4 {
            let col = NONLINEAR + q;
            // d/dyaw of R·db/dq: the column rotated by +90° (north ← −east).
            let d = if i == 0 { -jac[(1, col)] } else { jac[(0, col)] };
            a[(0, q)] = d;
            a[(q, 0)] = d;
        }
        a[(1, 2)] = lever_dir[i];
        a[(2, 1)] = lever_dir[i];
        a
    })
}

impl Ekf {
    pub fn new(config: EkfConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let mut ekf = Ekf {
            config,
            gate_chi2_1dof: [0.0; 5],
            gate_chi2_2dof: [0.0; 5],
            initialised: false,
            time_s: 0.0,
            x: StateVector::zeros(),
            p: StateCovariance::zeros(),
            innovations: [InnovationStatus::default(); 5],
            held_fix: None,
            held_heading: None,
            held_velocity: None,
            refused_inputs: 0,
            numerical_faults: 0,
            last_position_reset_m: [0.0; 2],
        };
        ekf.set_gates();
        Ok(ekf)
    }

    /// New tuning or lever arm (e.g. a parameter change); the state is kept.
    pub fn set_config(&mut self, config: EkfConfig) -> Result<(), ConfigError> {
        config.validate()?;
        self.config = config;
        self.set_gates();
        Ok(())
    }

    fn set_gates(&mut self) {
        let c = &self.config;
        let sigmas = [
            c.position_gate_sigma,
            c.velocity_gate_sigma,
            c.heading_gate_sigma,
            c.odometry_gate_sigma,
            c.odometry_gate_sigma,
        ];
        for (i, g) in sigmas.into_iter().enumerate() {
            self.gate_chi2_1dof[i] = chi2_gate(1, g);
            self.gate_chi2_2dof[i] = chi2_gate(2, g);
        }
    }

    pub fn config(&self) -> &EkfConfig {
        &self.config
    }

    pub fn is_initialised(&self) -> bool {
        self.initialised
    }

    /// The filter's time: the sum of the predicted intervals.
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    pub fn state(&self) -> EkfState {
        EkfState::from_vector(&self.x)
    }

    pub fn state_vector(&self) -> &StateVector {
        &self.x
    }

    pub fn covariance(&self) -> &StateCovariance {
        &self.p
    }

    /// The state extrapolated `dt_s` ahead by the motion model, without
    /// touching the filter (for output between samples).
    pub fn state_after(&self, dt_s: f64) -> EkfState {
        let usable = dt_s.is_finite() && dt_s > 0.0 && self.initialised;
        if !usable {
            return self.state();
        }
        let (x, _) = propagate(&self.x, dt_s);
        EkfState::from_vector(&x)
    }

    /// Back to uninitialised, forgetting held samples; counters are kept.
    pub fn reset(&mut self) {
        self.initialised = false;
        self.x = StateVector::zeros();
        self.p = StateCovariance::zeros();
        self.held_fix = None;
        self.held_heading = None;
        self.held_velocity = None;
    }

    /// Starts (or restarts) the filter at `state` with independent errors of
    /// the given σ; the GNSS bias starts at its stationary σ.
    pub fn initialise(&mut self, state: EkfState, sigmas: EkfSigmas) -> Result<(), InputError> {
        let s = &sigmas;
        let values = [
            s.position_m,
            s.yaw_rad,
            s.speed_mps,
            s.curvature_per_m,
            s.pivot_rate_rad_s,
        ];
        let x = state.to_vector();
        if !all_finite(x.as_slice()) || !all_finite(&values) {
            self.refused_inputs = self.refused_inputs.saturating_add(1);
            return Err(InputError::NotFinite);
        }
        if values.iter().any(|v| *v < 0.0) {
            self.refused_inputs = self.refused_inputs.saturating_add(1);
            return Err(InputError::BadSigma);
        }
        self.x = x;
        self.x[YAW] = wrap_pi(self.x[YAW]);
        let bias_var = self.config.gnss_walk_sigma_m.powi(2);
        self.p = StateCovariance::from_diagonal(&StateVector::from([
            s.position_m.powi(2),
            s.position_m.powi(2),
            s.yaw_rad.powi(2),
            s.speed_mps.powi(2),
            s.curvature_per_m.powi(2),
            s.pivot_rate_rad_s.powi(2),
            bias_var,
            bias_var,
        ]));
        self.initialised = true;
        self.held_fix = None;
        self.held_heading = None;
        self.held_velocity = None;
        Ok(())
    }

    /// Propagates the state and covariance by `dt_s` (≥ 0). Before
    /// initialisation only the filter time advances.
    pub fn predict(&mut self, dt_s: f64) -> Result<(), InputError> {
        if !dt_s.is_finite() {
            return Err(self.refuse(InputError::NotFinite));
        }
        if dt_s < 0.0 {
            return Err(self.refuse(InputError::OutOfRange));
        }
        self.time_s += dt_s;
        if !self.initialised || dt_s == 0.0 {
            return Ok(());
        }
        let steps = ((dt_s / MAX_STEP_S).ceil() as usize).clamp(1, MAX_SUBSTEPS);
        let step_s = dt_s / steps as f64;
        let (mut x, mut p) = (self.x, self.p);
        for _ in 0..steps {
            (x, p) = self.propagate_step(&x, &p, step_s);
        }
        if all_finite(x.as_slice()) && all_finite(p.as_slice()) {
            self.x = x;
            self.p = p;
        } else {
            self.numerical_faults = self.numerical_faults.saturating_add(1);
        }
        Ok(())
    }

    /// Predicts to the absolute filter time `t_s` (the caller's sample time in
    /// seconds on the same clock as every earlier call). Refuses to go back.
    pub fn predict_to(&mut self, t_s: f64) -> Result<(), InputError> {
        if !t_s.is_finite() {
            return Err(self.refuse(InputError::NotFinite));
        }
        if t_s < self.time_s {
            return Err(self.refuse(InputError::OutOfRange));
        }
        self.predict(t_s - self.time_s)?;
        // Land exactly on t: `time + (t − time)` can overshoot by an ulp, and
        // the next sample of the same epoch (same t) would look like the past.
        self.time_s = t_s;
        Ok(())
    }

    /// Continuous noise densities (variance per second) on the diagonal.
    fn process_noise_density(&self) -> [f64; STATE_LEN] {
        let c = &self.config;
        let mut qc = [0.0; STATE_LEN];
        qc[NORTH] = c.position_sigma_m_per_sqrt_s.powi(2);
        qc[EAST] = qc[NORTH];
        qc[SPEED] = c.long_accel_sigma_mps2.powi(2);
        qc[CURVATURE] = c.curvature_rate_sigma_per_m_s.powi(2);
        qc[PIVOT_RATE] = c.pivot_yaw_accel_sigma_radps2.powi(2);
        qc
    }

    fn propagate_step(&self, x: &StateVector, p: &StateCovariance, dt_s: f64) -> (StateVector, StateCovariance) {
        let c = &self.config;
        let (mut next, f) = propagate(x, dt_s);
        let phi = (-dt_s / c.gnss_walk_tau_s).exp();
        next[BIAS_NORTH] *= phi;
        next[BIAS_EAST] *= phi;
        let bias_q = c.gnss_walk_sigma_m.powi(2) * (1.0 - phi * phi);
        let mut p_next = propagate_covariance(p, &f, phi, bias_q, &self.process_noise_density(), dt_s);
        symmetrise(&mut p_next);
        // Curvature is unobservable at a stop: cap its σ by scaling its row
        // and column (D·P·D with D diagonal keeps P positive semi-definite).
        let kk = p_next[(CURVATURE, CURVATURE)];
        let kk_max = c.max_curvature_per_m.powi(2);
        if kk > kk_max {
            let scale = (kk_max / kk).sqrt();
            for j in 0..STATE_LEN {
                p_next[(CURVATURE, j)] *= scale;
                p_next[(j, CURVATURE)] *= scale;
            }
        }
        (next, p_next)
    }

    fn refuse(&mut self, error: InputError) -> InputError {
        self.refused_inputs = self.refused_inputs.saturating_add(1);
        error
    }

    fn refused(&mut self, error: InputError) -> Fusion {
        Fusion::Refused(self.refuse(error))
    }

    /// Gates and fuses one measurement with Joseph-form covariance update; the
    /// state and covariance change only if the result is finite.
    fn fuse<const M: usize>(
        &mut self,
        kind: Kind,
        innovation: SVector<f64, M>,
        h: SMatrix<f64, M, STATE_LEN>,
        r: SMatrix<f64, M, M>,
    ) -> Gate {
        let gate = if M == 1 {
            self.gate_chi2_1dof[kind as usize]
        } else {
            self.gate_chi2_2dof[kind as usize]
        };
        let pht = self.p * h.transpose();
        let s = h * pht + r;
        let s = (s + s.transpose()) * 0.5;
        let Some(s_inv) = s.try_inverse() else {
            self.numerical_faults = self.numerical_faults.saturating_add(1);
            return Gate::Numerical;
        };
        let nis = (innovation.transpose() * s_inv * innovation)[(0, 0)];
        let test_ratio = nis / gate;
        if !test_ratio.is_finite() || test_ratio < 0.0 {
            self.numerical_faults = self.numerical_faults.saturating_add(1);
            return Gate::Numerical;
        }
        let s_diag = s.diagonal();
        let record = &mut self.innovations[kind as usize];
        record.record(innovation.as_slice(), s_diag.as_slice(), test_ratio);
        if test_ratio > 1.0 {
            record.reject(self.time_s);
            return Gate::Rejected(test_ratio);
        }
        let k = pht * s_inv;
        let mut x = self.x + k * innovation;
        x[YAW] = wrap_pi(x[YAW]);
        // Joseph form (I − KH)·P·(I − KH)ᵀ + K·R·Kᵀ, expanded with B = P·Hᵀ
        // and S = H·P·Hᵀ + R into P − K·Bᵀ − B·Kᵀ + K·S·Kᵀ: the same
        // polynomial in K (so a rounding error in K still only enters to
        // second order), at rank-M cost instead of two 8×8 products.
        let kbt = k * pht.transpose();
        let ksk = k * s * k.transpose();
        let mut p = self.p;
        for i in 0..STATE_LEN {
            for j in i..STATE_LEN {
                // Built symmetric: both triangles get the same value.
                let v = self.p[(i, j)] - kbt[(i, j)] - kbt[(j, i)] + 0.5 * (ksk[(i, j)] + ksk[(j, i)]);
                p[(i, j)] = v;
                p[(j, i)] = v;
            }
        }
        let diagonal_ok = p.diagonal().iter().all(|v| *v >= 0.0);
        if !(all_finite(x.as_slice()) && all_finite(p.as_slice()) && diagonal_ok) {
            self.numerical_faults = self.numerical_faults.saturating_add(1);
            return Gate::Numerical;
        }
        self.x = x;
        self.p = p;
        self.innovations[kind as usize].accept(self.time_s);
        Gate::Accepted(test_ratio)
    }

    /// White part of a GNSS position σ: the receiver's σ (GST) covers its
    /// whole error, of which the filter models `gnss_walk_sigma_m` as a state.
    fn white_variance(&self, sigma_m: f64) -> f64 {
        let total = sigma_m * sigma_m;
        (total - self.config.gnss_walk_sigma_m.powi(2)).max(MIN_WHITE_FRACTION.powi(2) * total)
    }

    /// GNSS antenna position (local NED) with its receiver-reported 1-σ per
    /// axis (from GST, else from the fix quality). Gated; persistent
    /// rejection resets the position to the fix.
    pub fn update_gnss_position(
        &mut self,
        antenna_north_m: f64,
        antenna_east_m: f64,
        sigma_north_m: f64,
        sigma_east_m: f64,
    ) -> Fusion {
        if !all_finite(&[antenna_north_m, antenna_east_m, sigma_north_m, sigma_east_m]) {
            return self.refused(InputError::NotFinite);
        }
        if !(sigma_ok(sigma_north_m) && sigma_ok(sigma_east_m)) {
            return self.refused(InputError::BadSigma);
        }
        let fix = HeldFix {
            antenna_north_m,
            antenna_east_m,
            sigma_north_m,
            sigma_east_m,
        };
        if !self.initialised {
            self.held_fix = Some(Held {
                at_s: self.time_s,
                value: fix,
            });
            return self.try_start();
        }
        let (predicted, h) = antenna_position(&self.x, self.config.antenna_body_m);
        let hessians = antenna_position_hessians(&self.x, self.config.antenna_body_m);
        let (mean2, cov2) = second_order(&self.p, &hessians);
        let innovation = SVector::<f64, 2>::new(antenna_north_m, antenna_east_m) - predicted - mean2;
        let r = SMatrix::<f64, 2, 2>::from_diagonal(&SVector::<f64, 2>::new(
            self.white_variance(sigma_north_m),
            self.white_variance(sigma_east_m),
        )) + cov2;
        match self.fuse(Kind::Position, innovation, h, r) {
            Gate::Accepted(test_ratio) => Fusion::Accepted { test_ratio },
            Gate::Numerical => Fusion::Skipped(Skip::Numerical),
            Gate::Rejected(test_ratio) => {
                let record = &self.innovations[Kind::Position as usize];
                if record.rejecting_for_s(self.time_s) >= self.config.position_reset_after_s {
                    let shift = self.reset_position_to_gnss_fix(&fix);
                    let record = &mut self.innovations[Kind::Position as usize];
                    record.resets = record.resets.saturating_add(1);
                    record.accept(self.time_s);
                    Fusion::Reset { test_ratio, shift }
                } else {
                    Fusion::Rejected { test_ratio }
                }
            }
        }
    }

    /// Resets the position to a GNSS antenna fix (a relocation, e.g. after a
    /// fix type change), keeping yaw and the rest. Returns the shift (m).
    pub fn reset_position_to_gnss(
        &mut self,
        antenna_north_m: f64,
        antenna_east_m: f64,
        sigma_north_m: f64,
        sigma_east_m: f64,
    ) -> Result<[f64; 2], InputError> {
        if !all_finite(&[antenna_north_m, antenna_east_m, sigma_north_m, sigma_east_m]) {
            return Err(self.refuse(InputError::NotFinite));
        }
        if !(sigma_ok(sigma_north_m) && sigma_ok(sigma_east_m)) {
            return Err(self.refuse(InputError::BadSigma));
        }
        if !self.initialised {
            return Err(self.refuse(InputError::OutOfRange));
        }
        Ok(self.reset_position_to_gnss_fix(&HeldFix {
            antenna_north_m,
            antenna_east_m,
            sigma_north_m,
            sigma_east_m,
        }))
    }

    /// Sets the reference point from an antenna fix through the lever arm and
    /// rebuilds the position and bias rows of P: with the error
    /// e_p = −J·e_yaw − b − w (J = d(R(yaw)·r)/d yaw, b the slow GNSS error,
    /// w the white one) the new rows follow exactly from the yaw row.
    fn reset_position_to_gnss_fix(&mut self, fix: &HeldFix) -> [f64; 2] {
        let (ax, ay) = self.config.antenna_body_m;
        let (s, c) = self.x[YAW].sin_cos();
        let old = [self.x[NORTH], self.x[EAST]];
        self.x[NORTH] = fix.antenna_north_m - (c * ax - s * ay);
        self.x[EAST] = fix.antenna_east_m - (s * ax + c * ay);
        self.x[BIAS_NORTH] = 0.0;
        self.x[BIAS_EAST] = 0.0;
        let j = [-s * ax - c * ay, c * ax - s * ay];
        let bias_var = self.config.gnss_walk_sigma_m.powi(2);
        let white = [
            self.white_variance(fix.sigma_north_m),
            self.white_variance(fix.sigma_east_m),
        ];
        let yaw_row = self.p.row(YAW).into_owned();
        let yaw_var = self.p[(YAW, YAW)];
        let (pos, bias) = ([NORTH, EAST], [BIAS_NORTH, BIAS_EAST]);
        for i in [NORTH, EAST, BIAS_NORTH, BIAS_EAST] {
            for k in 0..STATE_LEN {
                self.p[(i, k)] = 0.0;
                self.p[(k, i)] = 0.0;
            }
        }
        for (a, &row) in pos.iter().enumerate() {
            for col in [YAW, SPEED, CURVATURE, PIVOT_RATE] {
                self.p[(row, col)] = -j[a] * yaw_row[col];
                self.p[(col, row)] = self.p[(row, col)];
            }
            for (b, &col) in pos.iter().enumerate() {
                self.p[(row, col)] = j[a] * j[b] * yaw_var;
            }
            self.p[(row, row)] += white[a] + bias_var;
            self.p[(row, bias[a])] = -bias_var;
            self.p[(bias[a], row)] = -bias_var;
            self.p[(bias[a], bias[a])] = bias_var;
        }
        let shift = [self.x[NORTH] - old[0], self.x[EAST] - old[1]];
        self.last_position_reset_m = shift;
        shift
    }

    /// GNSS speed over ground (≥ 0) and course over ground (rad, from north,
    /// clockwise; `None` when the receiver leaves it empty) of the antenna,
    /// with the velocity σ per axis (the antenna velocity includes ω × r).
    ///
    /// Below `min_course_speed_mps` the course is noise and is not used: the
    /// sample then says only that the antenna moves no faster than the
    /// reported speed, fused as a zero velocity with variance σ² + speed²/2
    /// per axis (the true velocity has that magnitude in an unknown
    /// direction). That is what lets a stopped vehicle's fixes average down.
    pub fn update_gnss_velocity(&mut self, speed_mps: f64, course_rad: Option<f64>, sigma_mps: f64) -> Fusion {
        if !all_finite(&[speed_mps, course_rad.unwrap_or(0.0), sigma_mps]) {
            return self.refused(InputError::NotFinite);
        }
        if !sigma_ok(sigma_mps) {
            return self.refused(InputError::BadSigma);
        }
        if speed_mps < 0.0 {
            return self.refused(InputError::OutOfRange);
        }
        let low_speed = speed_mps < self.config.min_course_speed_mps;
        if !self.initialised {
            if let Some(course_rad) = course_rad.filter(|_| !low_speed) {
                self.held_velocity = Some(Held {
                    at_s: self.time_s,
                    value: HeldVelocity { speed_mps, course_rad },
                });
            }
            return Fusion::Skipped(Skip::NotInitialised);
        }
        let (measured, variance) = match course_rad {
            _ if low_speed => (
                SVector::<f64, 2>::zeros(),
                sigma_mps * sigma_mps + 0.5 * speed_mps * speed_mps,
            ),
            Some(course) => {
                let (s, c) = course.sin_cos();
                (
                    SVector::<f64, 2>::new(speed_mps * c, speed_mps * s),
                    sigma_mps * sigma_mps,
                )
            }
            None => return Fusion::Skipped(Skip::NoCourse),
        };
        let (predicted, h) = antenna_velocity(&self.x, self.config.antenna_body_m);
        let hessians = antenna_velocity_hessians(&self.x, self.config.antenna_body_m);
        let (mean2, cov2) = second_order(&self.p, &hessians);
        let innovation = measured - predicted - mean2;
        let r = SMatrix::<f64, 2, 2>::identity() * variance + cov2;
        match self.fuse(Kind::Velocity, innovation, h, r) {
            Gate::Accepted(test_ratio) => Fusion::Accepted { test_ratio },
            Gate::Numerical => Fusion::Skipped(Skip::Numerical),
            Gate::Rejected(test_ratio) => {
                let record = &self.innovations[Kind::Velocity as usize];
                if record.rejecting_for_s(self.time_s) < self.config.velocity_reset_after_s {
                    return Fusion::Rejected { test_ratio };
                }
                // The speed that makes the antenna's along-body velocity
                // match: u = v − ω·a_y, with ω kept.
                let (sy, cy) = self.x[YAW].sin_cos();
                let along = measured[0] * cy + measured[1] * sy;
                let w = self.x[SPEED] * self.x[CURVATURE] + self.x[PIVOT_RATE];
                let speed = along + w * self.config.antenna_body_m.1;
                let old = self.x[SPEED];
                self.reset_speed_unchecked(speed, variance.sqrt());
                let record = &mut self.innovations[Kind::Velocity as usize];
                record.resets = record.resets.saturating_add(1);
                record.accept(self.time_s);
                Fusion::Reset {
                    test_ratio,
                    shift: [speed - old, 0.0],
                }
            }
        }
    }

    /// True heading of the body x axis (dual-antenna, or magnetometer already
    /// corrected for declination), rad from north clockwise, any wrap, with
    /// its σ. Gated on the wrapped innovation; persistent rejection resets.
    pub fn update_heading(&mut self, yaw_rad: f64, sigma_rad: f64) -> Fusion {
        if !all_finite(&[yaw_rad, sigma_rad]) {
            return self.refused(InputError::NotFinite);
        }
        if !sigma_ok(sigma_rad) {
            return self.refused(InputError::BadSigma);
        }
        let yaw_rad = wrap_pi(yaw_rad);
        if !self.initialised {
            self.held_heading = Some(Held {
                at_s: self.time_s,
                value: HeldHeading { yaw_rad, sigma_rad },
            });
            return self.try_start();
        }
        let mut h = SMatrix::<f64, 1, STATE_LEN>::zeros();
        h[(0, YAW)] = 1.0;
        let innovation = SVector::<f64, 1>::new(wrap_pi(yaw_rad - self.x[YAW]));
        let r = SMatrix::<f64, 1, 1>::new(sigma_rad * sigma_rad);
        match self.fuse(Kind::Heading, innovation, h, r) {
            Gate::Accepted(test_ratio) => Fusion::Accepted { test_ratio },
            Gate::Numerical => Fusion::Skipped(Skip::Numerical),
            Gate::Rejected(test_ratio) => {
                let record = &self.innovations[Kind::Heading as usize];
                if record.rejecting_for_s(self.time_s) >= self.config.heading_reset_after_s {
                    let old = self.x[YAW];
                    self.reset_heading_unchecked(yaw_rad, sigma_rad);
                    let record = &mut self.innovations[Kind::Heading as usize];
                    record.resets = record.resets.saturating_add(1);
                    record.accept(self.time_s);
                    Fusion::Reset {
                        test_ratio,
                        shift: [wrap_pi(yaw_rad - old), 0.0],
                    }
                } else {
                    Fusion::Rejected { test_ratio }
                }
            }
        }
    }

    /// Sets the yaw with its σ, forgetting its correlations; the vehicle turns
    /// about the GNSS antenna (see the automatic reset in `update_heading`).
    pub fn reset_heading(&mut self, yaw_rad: f64, sigma_rad: f64) -> Result<(), InputError> {
        if !all_finite(&[yaw_rad, sigma_rad]) {
            return Err(self.refuse(InputError::NotFinite));
        }
        if !sigma_ok(sigma_rad) {
            return Err(self.refuse(InputError::BadSigma));
        }
        if !self.initialised {
            return Err(self.refuse(InputError::OutOfRange));
        }
        self.reset_heading_unchecked(yaw_rad, sigma_rad);
        Ok(())
    }

    /// Rotates the vehicle about the GNSS antenna, the point the fixes
    /// measure: rotating about the reference point would move the predicted
    /// antenna by lever arm × angle and make the next fixes look like a jump.
    fn reset_heading_unchecked(&mut self, yaw_rad: f64, sigma_rad: f64) {
        let (ax, ay) = self.config.antenna_body_m;
        let lever_ned = |yaw: f64| {
            let (s, c) = yaw.sin_cos();
            [c * ax - s * ay, s * ax + c * ay]
        };
        let (old, new) = (lever_ned(self.x[YAW]), lever_ned(yaw_rad));
        self.x[NORTH] += old[0] - new[0];
        self.x[EAST] += old[1] - new[1];
        self.x[YAW] = wrap_pi(yaw_rad);
        for k in 0..STATE_LEN {
            self.p[(YAW, k)] = 0.0;
            self.p[(k, YAW)] = 0.0;
        }
        self.p[(YAW, YAW)] = sigma_rad * sigma_rad;
        // The reference point now hangs off the antenna through the new yaw:
        // its error gains −J·e_yaw (J = d(R·r)/d yaw), independent of the rest.
        let (s, c) = self.x[YAW].sin_cos();
        let j = [-s * ax - c * ay, c * ax - s * ay];
        let var = sigma_rad * sigma_rad;
        for (a, &row) in [NORTH, EAST].iter().enumerate() {
            self.p[(row, YAW)] = -j[a] * var;
            self.p[(YAW, row)] = -j[a] * var;
            for (b, &col) in [NORTH, EAST].iter().enumerate() {
                self.p[(row, col)] += j[a] * j[b] * var;
            }
        }
    }

    /// Sets the signed speed with its σ, forgetting its correlations.
    pub fn reset_speed(&mut self, speed_mps: f64, sigma_mps: f64) -> Result<(), InputError> {
        if !all_finite(&[speed_mps, sigma_mps]) {
            return Err(self.refuse(InputError::NotFinite));
        }
        if !sigma_ok(sigma_mps) {
            return Err(self.refuse(InputError::BadSigma));
        }
        if !self.initialised {
            return Err(self.refuse(InputError::OutOfRange));
        }
        self.reset_speed_unchecked(speed_mps, sigma_mps);
        Ok(())
    }

    fn reset_speed_unchecked(&mut self, speed_mps: f64, sigma_mps: f64) {
        self.x[SPEED] = speed_mps;
        for k in 0..STATE_LEN {
            self.p[(SPEED, k)] = 0.0;
            self.p[(k, SPEED)] = 0.0;
        }
        self.p[(SPEED, SPEED)] = sigma_mps * sigma_mps;
    }

    /// Signed forward speed of the reference point from wheel odometry.
    pub fn update_odometry_speed(&mut self, speed_mps: f64, sigma_mps: f64) -> Fusion {
        self.update_scalar(Kind::Odometry, speed_mps, sigma_mps)
    }

    /// Yaw rate (gyro z, clockwise positive, bias already removed).
    pub fn update_yaw_rate(&mut self, rate_rad_s: f64, sigma_rad_s: f64) -> Fusion {
        self.update_scalar(Kind::YawRate, rate_rad_s, sigma_rad_s)
    }

    fn update_scalar(&mut self, kind: Kind, value: f64, sigma: f64) -> Fusion {
        if !all_finite(&[value, sigma]) {
            return self.refused(InputError::NotFinite);
        }
        if !sigma_ok(sigma) {
            return self.refused(InputError::BadSigma);
        }
        if !self.initialised {
            return Fusion::Skipped(Skip::NotInitialised);
        }
        let mut h = SMatrix::<f64, 1, STATE_LEN>::zeros();
        let predicted = match kind {
            Kind::YawRate => {
                h[(0, SPEED)] = self.x[CURVATURE];
                h[(0, CURVATURE)] = self.x[SPEED];
                h[(0, PIVOT_RATE)] = 1.0;
                self.x[SPEED] * self.x[CURVATURE] + self.x[PIVOT_RATE]
            }
            _ => {
                h[(0, SPEED)] = 1.0;
                self.x[SPEED]
            }
        };
        // ω = v·κ + ω_p is bilinear: its v×κ Hessian entry is 1.
        let mut hessian = Hessian::zeros();
        if kind == Kind::YawRate {
            hessian[(1, 2)] = 1.0;
            hessian[(2, 1)] = 1.0;
        }
        let (mean2, cov2) = second_order(&self.p, &[hessian]);
        let innovation = SVector::<f64, 1>::new(value - predicted) - mean2;
        let r = SMatrix::<f64, 1, 1>::new(sigma * sigma) + cov2;
        match self.fuse(kind, innovation, h, r) {
            Gate::Accepted(test_ratio) => Fusion::Accepted { test_ratio },
            Gate::Rejected(test_ratio) => Fusion::Rejected { test_ratio },
            Gate::Numerical => Fusion::Skipped(Skip::Numerical),
        }
    }

    /// Starts the filter once a fresh fix and a fresh heading are both held.
    fn try_start(&mut self) -> Fusion {
        let now = self.time_s;
        let max_age = self.config.init_max_age_s;
        let fresh = |at_s: f64| now - at_s <= max_age;
        let (Some(fix), Some(heading)) = (self.held_fix, self.held_heading) else {
            return Fusion::Held;
        };
        if !(fresh(fix.at_s) && fresh(heading.at_s)) {
            return Fusion::Held;
        }
        let yaw = heading.value.yaw_rad;
        // A held GNSS velocity gives the signed speed: its projection on the
        // heading (negative when the course points backwards).
        let speed = match self.held_velocity {
            Some(v) if fresh(v.at_s) && v.value.speed_mps >= self.config.min_course_speed_mps => {
                v.value.speed_mps * (v.value.course_rad - yaw).cos()
            }
            _ => 0.0,
        };
        // The fix may be older than the heading (or the reverse); the vehicle
        // may have moved meanwhile: widen the position σ by the speed σ × age.
        let age_s = (fix.at_s - heading.at_s).abs();
        let widen = self.config.init_speed_sigma_mps * age_s;
        let mut fix = fix.value;
        fix.sigma_north_m = fix.sigma_north_m.hypot(widen);
        fix.sigma_east_m = fix.sigma_east_m.hypot(widen);
        let c = self.config;
        self.x = StateVector::zeros();
        self.x[YAW] = yaw;
        self.x[SPEED] = speed;
        self.p = StateCovariance::from_diagonal(&StateVector::from([
            0.0,
            0.0,
            heading.value.sigma_rad.powi(2),
            c.init_speed_sigma_mps.powi(2),
            c.max_curvature_per_m.powi(2),
            c.init_pivot_rate_sigma_rad_s.powi(2),
            0.0,
            0.0,
        ]));
        self.reset_position_to_gnss_fix(&fix);
        self.last_position_reset_m = [0.0; 2];
        self.initialised = true;
        self.held_fix = None;
        self.held_heading = None;
        self.held_velocity = None;
        let now = self.time_s;
        self.innovations[Kind::Position as usize].last_accepted_s = Some(now);
        self.innovations[Kind::Heading as usize].last_accepted_s = Some(now);
        Fusion::Initialised
    }

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

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_state() -> StateVector {
        StateVector::from([3.0, -2.0, 2.5, 1.7, 0.12, 0.03, 0.004, -0.002])
    }

    /// Central differences of `f` at `x`, column by column.
    fn numeric_jacobian<const M: usize>(
        x: &StateVector,
        f: impl Fn(&StateVector) -> SVector<f64, M>,
        wrap_rows: &[usize],
    ) -> SMatrix<f64, M, STATE_LEN> {
        let mut j = SMatrix::<f64, M, STATE_LEN>::zeros();
        for col in 0..STATE_LEN {
            let step = 1e-6;
            let (mut plus, mut minus) = (*x, *x);
            plus[col] += step;
            minus[col] -= step;
            let mut d = f(&plus) - f(&minus);
            for &r in wrap_rows {
                d[r] = wrap_pi(d[r]);
            }
            j.set_column(col, &(d / (2.0 * step)));
        }
        j
    }

    #[test]
    fn propagation_jacobian_matches_finite_differences() {
        for (x, dt) in [
            (sample_state(), 0.02),
            (sample_state(), 0.7),
            // Straight and stopped: the sinc series branch.
            (StateVector::from([0.0, 0.0, -3.1, 2.0, 0.0, 0.0, 0.0, 0.0]), 0.1),
            (StateVector::from([0.0, 0.0, 0.3, 0.0, 0.2, 0.0, 0.0, 0.0]), 0.1),
        ] {
            let (_, f) = propagate(&x, dt);
            let numeric = numeric_jacobian(&x, |s| propagate(s, dt).0, &[YAW]);
            assert!((f - numeric).abs().max() < 1e-6, "dt {dt}: {}", f - numeric);
        }
    }

    #[test]
    fn sparse_covariance_propagation_matches_the_dense_formula() {
        let x = sample_state();
        let dt = 0.05;
        let (_, mut f) = propagate(&x, dt);
        let phi = 0.99;
        // Any symmetric positive definite P.
        let l = StateCovariance::from_fn(|i, j| if i >= j { 0.1 + 0.01 * (i * 8 + j) as f64 } else { 0.0 });
        let p = l * l.transpose();
        let qc = [1e-6, 1e-6, 0.0, 0.09, 0.01, 0.002, 0.0, 0.0];
        let sparse = propagate_covariance(&p, &f, phi, 1e-7, &qc, dt);
        f[(BIAS_NORTH, BIAS_NORTH)] = phi;
        f[(BIAS_EAST, BIAS_EAST)] = phi;
        let qc_m = StateCovariance::from_diagonal(&StateVector::from(qc));
        let m = f - StateCovariance::identity();
        let mq = m * qc_m;
        let mut q = (qc_m + (mq + mq.transpose()) * 0.5 + mq * m.transpose() / 3.0) * dt;
        q[(BIAS_NORTH, BIAS_NORTH)] += 1e-7;
        q[(BIAS_EAST, BIAS_EAST)] += 1e-7;
        let dense = f * p * f.transpose() + q;
        assert!((sparse - dense).abs().max() < 1e-12, "{}", sparse - dense);
    }

    #[test]
    fn propagation_follows_the_exact_arc() {
        // Radius 5 m right turn from heading north: a quarter circle ends
        // 5 m north, 5 m east, heading east.
        let x = StateVector::from([0.0, 0.0, 0.0, 2.0, 0.2, 0.0, 0.0, 0.0]);
        let quarter_s = std::f64::consts::FRAC_PI_2 * 5.0 / 2.0;
        let (next, _) = propagate(&x, quarter_s);
        assert!(
            (next[NORTH] - 5.0).abs() < 1e-12 && (next[EAST] - 5.0).abs() < 1e-12,
            "{next}"
        );
        assert!((next[YAW] - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn measurement_jacobians_match_finite_differences() {
        let lever = (0.5, -0.2);
        let x = sample_state();
        let (_, h) = antenna_position(&x, lever);
        let numeric = numeric_jacobian(&x, |s| antenna_position(s, lever).0, &[]);
        assert!((h - numeric).abs().max() < 1e-7, "{}", h - numeric);
        let (_, h) = antenna_velocity(&x, lever);
        let numeric = numeric_jacobian(&x, |s| antenna_velocity(s, lever).0, &[]);
        assert!((h - numeric).abs().max() < 1e-7, "{}", h - numeric);
    }

    /// Central second differences over (yaw, v, κ, ω_p).
    fn numeric_hessians(x: &StateVector, f: impl Fn(&StateVector) -> SVector<f64, 2>) -> [SMatrix<f64, 4, 4>; 2] {
        let step = 1e-4;
        let mut out = [SMatrix::<f64, 4, 4>::zeros(); 2];
        for a in 0..4 {
            for b in 0..4 {
                let at = |da: f64, db: f64| {
                    let mut y = *x;
                    y[NONLINEAR + a] += da;
                    y[NONLINEAR + b] += db;
                    f(&y)
                };
                let d = (at(step, step) - at(step, -step) - at(-step, step) + at(-step, -step)) / (4.0 * step * step);
                for (i, h) in out.iter_mut().enumerate() {
                    h[(a, b)] = d[i];
                }
            }
        }
        out
    }

    #[test]
    fn measurement_hessians_match_finite_differences() {
        let lever = (0.5, -0.2);
        let x = sample_state();
        let analytic = antenna_position_hessians(&x, lever);
        let numeric = numeric_hessians(&x, |s| antenna_position(s, lever).0);
        for i in 0..2 {
            assert!(
                (analytic[i] - numeric[i]).abs().max() < 1e-5,
                "{}",
                analytic[i] - numeric[i]
            );
        }
        let analytic = antenna_velocity_hessians(&x, lever);
        let numeric = numeric_hessians(&x, |s| antenna_velocity(s, lever).0);
        for i in 0..2 {
            assert!(
                (analytic[i] - numeric[i]).abs().max() < 1e-5,
                "{}",
                analytic[i] - numeric[i]
            );
        }
    }

    #[test]
    fn antenna_velocity_includes_the_lever_arm_term() {
        // Turning right at 0.5 rad/s on the spot (pivot), facing north: an
        // antenna 0.5 m ahead moves east at 0.25 m/s.
        let x = StateVector::from([0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0]);
        let (v, _) = antenna_velocity(&x, (0.5, 0.0));
        assert!(v[0].abs() < 1e-12 && (v[1] - 0.25).abs() < 1e-12, "{v}");
    }

    #[test]
    fn chi2_gates() {
        assert_eq!(chi2_gate(1, 5.0), 25.0);
        // Same tail probability as 5σ (5.733e-7): -2 ln p.
        assert!((chi2_gate(2, 5.0) - 28.744).abs() < 2e-3, "{}", chi2_gate(2, 5.0));
        // 3σ: p = 2.6998e-3.
        assert!((chi2_gate(2, 3.0) - 11.829).abs() < 2e-3, "{}", chi2_gate(2, 3.0));
    }

    #[test]
    fn wrap_matches_geo_convention() {
        assert_eq!(wrap_pi(std::f64::consts::PI), -std::f64::consts::PI);
        assert!((wrap_pi(3.0 * std::f64::consts::PI / 2.0) + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((wrap_pi(-0.1) + 0.1).abs() < 1e-15);
    }

    fn config() -> EkfConfig {
        EkfConfig {
            antenna_body_m: (0.5, 0.0),
            ..EkfConfig::default()
        }
    }

    #[test]
    fn heading_first_then_fix_initialises_through_the_lever_arm() {
        let mut ekf = Ekf::new(config()).unwrap();
        assert_eq!(ekf.update_heading(90f64.to_radians(), 1e-3), Fusion::Held);
        assert_eq!(
            ekf.update_odometry_speed(0.0, 0.01),
            Fusion::Skipped(Skip::NotInitialised)
        );
        ekf.predict(0.05).unwrap();
        assert_eq!(ekf.update_gnss_position(10.0, 20.0, 0.01, 0.01), Fusion::Initialised);
        let s = ekf.state();
        // Facing east: the reference point is 0.5 m west of the antenna.
        assert!(
            (s.north_m - 10.0).abs() < 1e-12 && (s.east_m - 19.5).abs() < 1e-12,
            "{s:?}"
        );
        assert!(ekf.healthy());
    }

    #[test]
    fn fix_first_then_heading_initialises_and_stale_halves_are_dropped() {
        let mut ekf = Ekf::new(config()).unwrap();
        assert_eq!(ekf.update_gnss_position(1.0, 1.0, 0.01, 0.01), Fusion::Held);
        ekf.predict(1.0).unwrap();
        // The fix is a second old: too old to start from.
        assert_eq!(ekf.update_heading(0.0, 1e-3), Fusion::Held);
        assert!(!ekf.is_initialised());
        assert_eq!(ekf.update_gnss_position(2.0, 1.0, 0.01, 0.01), Fusion::Initialised);
        let s = ekf.state();
        assert!(
            (s.north_m - 1.5).abs() < 1e-12 && (s.east_m - 1.0).abs() < 1e-12,
            "{s:?}"
        );
    }

    #[test]
    fn held_velocity_gives_the_signed_initial_speed() {
        let mut ekf = Ekf::new(config()).unwrap();
        // Facing north, moving south: reversing.
        ekf.update_gnss_velocity(0.8, Some(std::f64::consts::PI), 0.02);
        ekf.update_heading(0.0, 1e-3);
        assert_eq!(ekf.update_gnss_position(0.0, 0.0, 0.01, 0.01), Fusion::Initialised);
        assert!((ekf.state().speed_mps + 0.8).abs() < 1e-12);
    }

    fn initialised(config: EkfConfig, state: EkfState, sigmas: EkfSigmas) -> Ekf {
        let mut ekf = Ekf::new(config).unwrap();
        ekf.initialise(state, sigmas).unwrap();
        ekf
    }

    const TIGHT: EkfSigmas = EkfSigmas {
        position_m: 0.01,
        yaw_rad: 1e-3,
        speed_mps: 0.001,
        curvature_per_m: 0.01,
        pivot_rate_rad_s: 0.0,
    };

    #[test]
    fn persistent_velocity_rejection_resets_the_speed() {
        // The filter is sure of 2 m/s (and that it hardly accelerates); the
        // GNSS insists on 0.5 m/s ahead.
        let state = EkfState {
            speed_mps: 2.0,
            ..EkfState::default()
        };
        let stiff = EkfConfig {
            long_accel_sigma_mps2: 0.01,
            ..config()
        };
        let mut ekf = initialised(stiff, state, TIGHT);
        let mut outcomes = Vec::new();
        for _ in 0..20 {
            ekf.predict(0.1).unwrap();
            outcomes.push(ekf.update_gnss_velocity(0.5, Some(0.0), 0.02));
        }
        let reset_at = outcomes.iter().position(|f| matches!(f, Fusion::Reset { .. })).unwrap();
        // First rejection at 0.1 s, reset 1.5 s later.
        assert_eq!(reset_at, 15, "{outcomes:?}");
        assert!(
            outcomes[..reset_at]
                .iter()
                .all(|f| matches!(f, Fusion::Rejected { .. }))
        );
        assert!(matches!(outcomes[reset_at + 1], Fusion::Accepted { .. }));
        assert!((ekf.state().speed_mps - 0.5).abs() < 0.01);
        assert_eq!(ekf.status().gnss_velocity.resets, 1);
    }

    #[test]
    fn explicit_position_reset_goes_through_the_lever_arm() {
        let state = EkfState {
            yaw_rad: std::f64::consts::FRAC_PI_2,
            ..EkfState::default()
        };
        let mut ekf = initialised(config(), state, TIGHT);
        let shift = ekf.reset_position_to_gnss(3.0, 4.5, 0.02, 0.02).unwrap();
        let s = ekf.state();
        // Facing east, antenna 0.5 m ahead: the reference point is 0.5 m west.
        assert!((s.north_m - 3.0).abs() < 1e-12 && (s.east_m - 4.0).abs() < 1e-12);
        assert_eq!(shift, [3.0, 4.0]);
        assert_eq!(ekf.status().last_position_reset_m, [3.0, 4.0]);
        let without_pivot = ekf.covariance().remove_row(PIVOT_RATE).remove_column(PIVOT_RATE);
        assert!(without_pivot.cholesky().is_some());
        // Variance: the fix's (white part + walk = σ²) plus, north only here,
        // the lever arm swung by the yaw σ: (0.5 m × 1 mrad)².
        let p = ekf.covariance();
        assert!((p[(NORTH, NORTH)] - (0.02f64.powi(2) + (0.5 * 1e-3f64).powi(2))).abs() < 1e-15);
        assert!((p[(EAST, EAST)] - 0.02f64.powi(2)).abs() < 1e-15);
        assert!((p[(NORTH, BIAS_NORTH)] + 0.005f64.powi(2)).abs() < 1e-15);
    }

    #[test]
    fn heading_reset_turns_about_the_antenna() {
        let mut ekf = initialised(config(), EkfState::default(), TIGHT);
        let before = antenna_position(ekf.state_vector(), config().antenna_body_m).0;
        ekf.reset_heading(0.3, 1e-3).unwrap();
        let after = antenna_position(ekf.state_vector(), config().antenna_body_m).0;
        assert!((after - before).norm() < 1e-12, "{before} {after}");
        assert_eq!(ekf.state().yaw_rad, 0.3);
        let without_pivot = ekf.covariance().remove_row(PIVOT_RATE).remove_column(PIVOT_RATE);
        assert!(without_pivot.cholesky().is_some());
    }

    #[test]
    fn state_after_extrapolates_without_touching_the_filter() {
        let state = EkfState {
            speed_mps: 2.0,
            curvature_per_m: 0.2,
            ..EkfState::default()
        };
        let ekf = initialised(config(), state, TIGHT);
        let quarter_s = std::f64::consts::FRAC_PI_2 * 5.0 / 2.0;
        let ahead = ekf.state_after(quarter_s);
        assert!(
            (ahead.north_m - 5.0).abs() < 1e-9 && (ahead.east_m - 5.0).abs() < 1e-9,
            "{ahead:?}"
        );
        assert_eq!(ekf.state(), state);
        assert_eq!(ekf.time_s(), 0.0);
    }

    #[test]
    fn invalid_config_is_refused() {
        let bad = EkfConfig {
            gnss_walk_tau_s: 0.0,
            ..EkfConfig::default()
        };
        assert_eq!(Ekf::new(bad).unwrap_err(), ConfigError("gnss_walk_tau_s"));
        let bad = EkfConfig {
            antenna_body_m: (f64::NAN, 0.0),
            ..EkfConfig::default()
        };
        assert!(Ekf::new(bad).is_err());
    }

    #[test]
    fn predict_refuses_bad_intervals_and_going_back() {
        let mut ekf = Ekf::new(config()).unwrap();
        assert_eq!(ekf.predict(f64::NAN), Err(InputError::NotFinite));
        assert_eq!(ekf.predict(-0.1), Err(InputError::OutOfRange));
        ekf.predict_to(2.0).unwrap();
        assert_eq!(ekf.predict_to(1.9), Err(InputError::OutOfRange));
        assert_eq!(ekf.time_s(), 2.0);
        assert_eq!(ekf.status().refused_inputs, 3);
    }

    #[test]
    fn samples_of_one_epoch_share_their_time() {
        // `time + (t − time)` rounds past t when the gap exceeds the time
        // already elapsed (e.g. 1 ms then 9 ms): the second sample stamped t
        // must still be accepted.
        for first_ms in 1..20u64 {
            for then_ms in first_ms + 1..200 {
                let mut ekf = Ekf::new(config()).unwrap();
                let (t0, t1) = (first_ms as f64 * 1e-3, then_ms as f64 * 1e-3);
                ekf.predict_to(t0).unwrap();
                ekf.predict_to(t1).unwrap();
                assert_eq!(ekf.predict_to(t1), Ok(()), "{t0} then {t1}");
                assert_eq!(ekf.time_s(), t1);
            }
        }
    }

    #[test]
    fn long_gaps_are_split_and_keep_covariance_symmetric() {
        let mut ekf = Ekf::new(config()).unwrap();
        let state = EkfState {
            speed_mps: 1.0,
            curvature_per_m: 0.1,
            ..EkfState::default()
        };
        let sigmas = EkfSigmas {
            position_m: 0.01,
            yaw_rad: 0.001,
            speed_mps: 0.01,
            curvature_per_m: 0.01,
            pivot_rate_rad_s: 0.0,
        };
        ekf.initialise(state, sigmas).unwrap();
        ekf.predict(3600.0).unwrap();
        let p = ekf.covariance();
        assert!((p - p.transpose()).abs().max() == 0.0);
        assert!(p.cholesky().is_some() || p.diagonal().iter().all(|v| *v >= 0.0));
        // Curvature σ capped at the vehicle's limit.
        assert!(p[(CURVATURE, CURVATURE)] <= config().max_curvature_per_m.powi(2) * (1.0 + 1e-12));
    }
}
