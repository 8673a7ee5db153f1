//! An extended Kalman filter for a wheeled ground vehicle (docs/architecture.md §Estimation).
//!
//! Pure: no clocks, no I/O, no allocation. The caller owns time and feeds the
//! filter explicit inputs. Cost printed by `furrow-bench sitl` (release,
//! x86-64, one core of a shared machine):
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

mod config;
mod fusion;
mod model;
mod status;
#[cfg(test)]
mod tests;

pub use config::{ConfigError, EkfConfig, chi2_gate};
pub use model::{
    antenna_position, antenna_position_hessians, antenna_velocity, antenna_velocity_hessians, propagate,
    propagate_covariance,
};
pub use status::{EkfSigmas, EkfState, EkfStatus, Fusion, InnovationStatus, InputError, Skip};

use fusion::{Held, HeldFix, HeldHeading, HeldVelocity};
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

    /// New tuning or lever arm (e.g. a parameter change, or process noise
    /// that follows the motion every tick); the state is kept.
    pub fn set_config(&mut self, config: EkfConfig) -> Result<(), ConfigError> {
        config.validate()?;
        let gates = |c: &EkfConfig| {
            [
                c.position_gate_sigma,
                c.velocity_gate_sigma,
                c.heading_gate_sigma,
                c.odometry_gate_sigma,
            ]
        };
        let same_gates = gates(&config) == gates(&self.config);
        self.config = config;
        if !same_gates {
            self.set_gates();
        }
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
        // and column (D·P·D with D diagonal keeps P positive semi-definite);
        // a cap of 0 keeps it known at its value (no curvature state).
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
}
