//! Constant-velocity Kalman filter for one tracked obstacle (seed 004
//! §III.B, eq. 3–12, with the corrections below), and the interacting
//! multiple model filter ([`ImmKalman`]) a track runs two of them in.
//!
//! State `[n, v_n, e, v_e]` in the local frame (north, east; metres and m/s):
//! the seed's `[x v_x y v_y]` with x = north, y = east. The measurement is a
//! position (a cluster's centroid already moved to the local frame).
//!
//! # Model
//! - Transition (eq. 3): `F = [[1 T 0 0] [0 1 0 0] [0 0 1 T] [0 0 0 1]]` with
//!   `T` the actual interval since the last step (scans get dropped, so it is
//!   not a constant).
//! - Process noise: the continuous white-noise-acceleration model. With a
//!   white acceleration of power spectral density `q` (m²/s³) on each axis,
//!   `Q = q·[[T³/3 T²/2] [T²/2 T]]` per axis. That is the matrix printed as
//!   eq. 6 — but eq. 6 calls it `W(k)`, the noise *vector* of eq. 3, when it is
//!   its covariance `Q` (the name eq. 9 uses), and its `a` is the density `q`
//!   (units m²/s³), not "a factor determined by acceleration". `q` is what
//!   [`process_noise`] and [`CvKalman::predict`] take, as is: the velocity
//!   variance grows by `q` per second (so `√q` m/s after one second of
//!   coasting; a walking person: q ≈ 1–2). An earlier version of this file
//!   took `σ_a = √q` and squared it, which silently turned a configured
//!   `q = 2` into 4. The discrete white-noise variant
//!   (`[[T⁴/4 T³/2] [T³/2 T²]]·σ²`) is a different model and is not used: the
//!   continuous one gives the same filter whatever the scan rate.
//! - Measurement (eq. 4): `H = [[1 0 0 0] [0 0 1 0]]` picks the positions.
//!   The seed prints `C = [[0 1 0 0] [0 0 0 1]]`, which picks the
//!   *velocities*: with it the filter would treat positions as speeds.
//! - Measurement noise: the scanner measures range and bearing, so eq. 7's
//!   `diag(σ_ρ², σ_θ²)` is in polar units (m², rad²) while the update (eq.
//!   10–12) is Cartesian. It must go through the polar→Cartesian Jacobian at
//!   the measured point, `R = J·diag(σ_ρ², σ_θ²)·Jᵀ`,
//!   `J = [[cos β, −ρ sin β] [sin β, ρ cos β]]` (β the bearing in the local
//!   frame, clockwise from north): a 1 mrad bearing σ is 10 mm across the
//!   beam at 10 m, not 1 mm² added to a position variance. See
//!   [`polar_measurement_covariance`].
//! - Update: the Joseph form `P = (I−KH)P(I−KH)ᵀ + KRKᵀ` instead of eq. 12's
//!   `(I−KH)P`, which is only right for the exact optimal gain and loses
//!   symmetry and positive-definiteness to rounding; `P` is symmetrised after
//!   every step.
//!
//! Inputs that are NaN or infinite, a negative interval, or an innovation
//! covariance that is not positive definite are refused with an error and
//! leave the filter unchanged.
//!
//! # Interacting multiple models
//! One density `q` cannot serve a walker both ways: large enough to follow a
//! turn within a few scans, it lets centroid noise swing the velocity (and
//! the line predicted from it) by a good fraction of a walking speed; small
//! enough to hold a steady walker's velocity, it takes seconds to follow a
//! turn. [`ImmKalman`] runs the filter above twice, as two modes `j` of a
//! Markov chain (Blom & Bar-Shalom's IMM): [`mode::STEADY`] with a small
//! density and [`mode::MANOEUVRE`] with the single filter's (`OA_TRK_ACC`).
//! Each mode has a filter `(xⱼ, Pⱼ)` and a probability `μⱼ`. One cycle:
//! - Mode transition over `T`: the chain leaves the steady mode at rate
//!   `a = 1/STEADY_SOJOURN_S` and the manoeuvre at `b =
//!   1/MANOEUVRE_SOJOURN_S`, so with `e = 1 − exp(−(a+b)T)`:
//!   `Π = [[1 − a·e/(a+b), a·e/(a+b)] [b·e/(a+b), 1 − b·e/(a+b)]]`
//!   (`Πᵢⱼ`: from mode i to mode j), exact for any `T` as `Q` is.
//! - Mixing: `c̄ⱼ = Σᵢ Πᵢⱼ μᵢ` (the predicted mode probabilities),
//!   `μᵢ|ⱼ = Πᵢⱼ μᵢ / c̄ⱼ`, and mode j starts its prediction from
//!   `x⁰ⱼ = Σᵢ μᵢ|ⱼ xᵢ`, `P⁰ⱼ = Σᵢ μᵢ|ⱼ (Pᵢ + (xᵢ − x⁰ⱼ)(xᵢ − x⁰ⱼ)ᵀ)`.
//! - Prediction: each mode's filter over `T` with its own `q`; `μⱼ = c̄ⱼ`
//!   (no measurement: no evidence either way).
//! - Update with `z`: each mode's filter updates; its innovation `νⱼ`,
//!   `Sⱼ` gives the likelihood `Λⱼ = N(νⱼ; 0, Sⱼ) ∝ exp(−νⱼᵀSⱼ⁻¹νⱼ/2)/√det Sⱼ`
//!   and `μⱼ ← Λⱼ μⱼ / Σₖ Λₖ μₖ` (computed relative to the larger
//!   log-likelihood, so an outlier underflows neither).
//! - Output: the moment-matched mixture `x = Σⱼ μⱼ xⱼ`,
//!   `P = Σⱼ μⱼ (Pⱼ + (xⱼ − x)(xⱼ − x)ᵀ)`. That is what the track reports
//!   and is gated with: sharp while the walker keeps its line, wide (the
//!   manoeuvre's covariance plus the two modes' disagreement) the moment it
//!   turns.
//!
//! The tracker does not run it yet: with its mixture in the tracks, the
//! vehicle's test of whether a track walks (speed against the velocity σ,
//! sized for the single filter's σ) took the view-made drift of standing
//! objects' centroids for walking, and the obstacle bench's families
//! stopped falsely beside standing people and a parked car.
//!
//! A second scanner's measurement at the same instant is a second update
//! after a zero-length prediction (`Π(0) = I`: no mixing), i.e. sequential
//! Bayes on the same mode hypotheses.
//!
//! Sources: docs/references.md §Seed 004; H. A. P. Blom and Y. Bar-Shalom,
//! "The interacting multiple model algorithm for systems with Markovian
//! switching coefficients", IEEE TAC 33(8), 1988.

use nalgebra::{Matrix2, Matrix2x4, Matrix4, Matrix4x2, Vector2, Vector4};

use crate::geo::Ned;

/// Indices into the state vector and covariance.
pub mod state {
    pub const NORTH: usize = 0;
    pub const VEL_NORTH: usize = 1;
    pub const EAST: usize = 2;
    pub const VEL_EAST: usize = 3;
}
use state::*;

/// Why a step was refused (the filter is left as it was).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KalmanError {
    /// A NaN or infinite input, or a result that would be.
    NonFinite,
    /// A negative time step: the filter never goes back in time.
    NegativeInterval,
    /// A covariance that should be positive definite is not.
    NotPositiveDefinite,
}

/// The innovation of a position measurement against the prediction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Innovation {
    /// Measured minus predicted position, (north, east), metres.
    pub residual_m: Vector2<f64>,
    /// Its covariance `HPHᵀ + R`.
    pub covariance: Matrix2<f64>,
    /// Squared Mahalanobis distance `νᵀS⁻¹ν`: χ² with two degrees of freedom
    /// when the model holds; compare with [`chi2_gate_2dof`].
    pub mahalanobis_sq: f64,
}

/// `F(T)`: constant velocity over `dt_s`.
pub fn transition(dt_s: f64) -> Matrix4<f64> {
    let mut f = Matrix4::identity();
    f[(NORTH, VEL_NORTH)] = dt_s;
    f[(EAST, VEL_EAST)] = dt_s;
    f
}

/// `Q(T)` of the continuous white-noise-acceleration model with power
/// spectral density `q` (m²/s³, eq. 6's `a`) on each axis: exact for any
/// `dt_s`, so long gaps need no substeps.
pub fn process_noise(dt_s: f64, accel_psd_m2ps3: f64) -> Matrix4<f64> {
    let q = accel_psd_m2ps3;
    let t2 = dt_s * dt_s;
    let pp = q * t2 * dt_s / 3.0;
    let pv = q * t2 / 2.0;
    let vv = q * dt_s;
    let mut m = Matrix4::zeros();
    for (p, v) in [(NORTH, VEL_NORTH), (EAST, VEL_EAST)] {
        m[(p, p)] = pp;
        m[(p, v)] = pv;
        m[(v, p)] = pv;
        m[(v, v)] = vv;
    }
    m
}

/// Covariance (north, east; m²) of a point measured at range and bearing
/// from `sensor`, from the σ of each (the corrected eq. 7): the Jacobian of
/// `(n, e) = sensor + ρ·(cos β, sin β)` at the measured point. A point on
/// the sensor itself falls back to the range σ in every direction.
pub fn polar_measurement_covariance(
    sensor: Ned,
    point: Ned,
    range_sigma_m: f64,
    bearing_sigma_rad: f64,
) -> Matrix2<f64> {
    let dn = point.north_m - sensor.north_m;
    let de = point.east_m - sensor.east_m;
    let range_m = dn.hypot(de);
    let var_r = range_sigma_m * range_sigma_m;
    if range_m < 1e-9 {
        return Matrix2::identity() * var_r;
    }
    let (c, s) = (dn / range_m, de / range_m);
    // Range along the beam, ρ·σ_β across it.
    let var_t = (range_m * bearing_sigma_rad).powi(2);
    Matrix2::new(
        c * c * var_r + s * s * var_t,
        c * s * (var_r - var_t),
        c * s * (var_r - var_t),
        s * s * var_r + c * c * var_t,
    )
}

/// χ² threshold with two degrees of freedom for a gate that keeps the true
/// measurement with `probability` (0.99 → 9.21): the χ²₂ tail is `exp(−x/2)`.
pub fn chi2_gate_2dof(probability: f64) -> f64 {
    -2.0 * (1.0 - probability).ln()
}

/// Largest standard deviation of a 2×2 covariance (its major semi-axis).
pub fn major_sigma(cov: &Matrix2<f64>) -> f64 {
    let (a, b, c) = (cov[(0, 0)], cov[(0, 1)], cov[(1, 1)]);
    let half_diff = 0.5 * (a - c);
    (0.5 * (a + c) + half_diff.hypot(b)).max(0.0).sqrt()
}

fn all_finite2(m: &Matrix2<f64>) -> bool {
    m.iter().all(|v| v.is_finite())
}

/// Inverse of a symmetric positive-definite 2×2, or `None`.
fn spd_inverse(s: &Matrix2<f64>) -> Option<Matrix2<f64>> {
    let det = s[(0, 0)] * s[(1, 1)] - s[(0, 1)] * s[(1, 0)];
    // A relative floor: a determinant lost in rounding is not "positive".
    let scale = s[(0, 0)] * s[(1, 1)];
    if !(s[(0, 0)] > 0.0 && s[(1, 1)] > 0.0 && det > 1e-12 * scale && det.is_finite()) {
        return None;
    }
    let inv_det = 1.0 / det;
    Some(Matrix2::new(
        s[(1, 1)] * inv_det,
        -s[(0, 1)] * inv_det,
        -s[(1, 0)] * inv_det,
        s[(0, 0)] * inv_det,
    ))
}

/// `F·P·Fᵀ` with `F` = [`transition`]`(dt_s)`, written out: each position
/// row, then each position column, gains `dt_s` times its velocity's, the
/// same sums the matrix products take (their other terms are zeros), for a
/// fraction of their cost: every track is predicted at every scan.
fn propagate_covariance(p: &Matrix4<f64>, dt_s: f64) -> Matrix4<f64> {
    let mut fp = *p;
    for j in 0..4 {
        fp[(NORTH, j)] += dt_s * p[(VEL_NORTH, j)];
        fp[(EAST, j)] += dt_s * p[(VEL_EAST, j)];
    }
    let mut fpf = fp;
    for i in 0..4 {
        fpf[(i, NORTH)] += dt_s * fp[(i, VEL_NORTH)];
        fpf[(i, EAST)] += dt_s * fp[(i, VEL_EAST)];
    }
    fpf
}

fn symmetrise(p: &mut Matrix4<f64>) {
    for i in 0..4 {
        for j in (i + 1)..4 {
            let m = 0.5 * (p[(i, j)] + p[(j, i)]);
            p[(i, j)] = m;
            p[(j, i)] = m;
        }
    }
}

/// `H`: the positions out of the state.
fn h() -> Matrix2x4<f64> {
    let mut h = Matrix2x4::zeros();
    h[(0, NORTH)] = 1.0;
    h[(1, EAST)] = 1.0;
    h
}

/// One obstacle's constant-velocity filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CvKalman {
    x: Vector4<f64>,
    p: Matrix4<f64>,
}

impl CvKalman {
    /// Starts at a measured position (covariance `r`) with zero velocity of
    /// σ `velocity_sigma_mps` per axis: the first updates then work out the
    /// velocity, weighted against that prior (a two-point difference alone
    /// would be ~3 m/s noisy at 50 Hz).
    pub fn new(position: Ned, r: &Matrix2<f64>, velocity_sigma_mps: f64) -> Result<Self, KalmanError> {
        if !(position.north_m.is_finite()
            && position.east_m.is_finite()
            && all_finite2(r)
            && velocity_sigma_mps.is_finite())
        {
            return Err(KalmanError::NonFinite);
        }
        if spd_inverse(r).is_none() || velocity_sigma_mps <= 0.0 {
            return Err(KalmanError::NotPositiveDefinite);
        }
        let x = Vector4::new(position.north_m, 0.0, position.east_m, 0.0);
        let mut p = Matrix4::zeros();
        let var_v = velocity_sigma_mps * velocity_sigma_mps;
        p[(NORTH, NORTH)] = r[(0, 0)];
        p[(NORTH, EAST)] = r[(0, 1)];
        p[(EAST, NORTH)] = r[(1, 0)];
        p[(EAST, EAST)] = r[(1, 1)];
        p[(VEL_NORTH, VEL_NORTH)] = var_v;
        p[(VEL_EAST, VEL_EAST)] = var_v;
        Ok(CvKalman { x, p })
    }

    /// Any state and covariance (tests, restoring a saved track).
    pub fn from_parts(x: Vector4<f64>, p: Matrix4<f64>) -> Result<Self, KalmanError> {
        if !(x.iter().all(|v| v.is_finite()) && p.iter().all(|v| v.is_finite())) {
            return Err(KalmanError::NonFinite);
        }
        let mut p = p;
        symmetrise(&mut p);
        if p.cholesky().is_none() {
            return Err(KalmanError::NotPositiveDefinite);
        }
        Ok(CvKalman { x, p })
    }

    pub fn state(&self) -> &Vector4<f64> {
        &self.x
    }

    pub fn covariance(&self) -> &Matrix4<f64> {
        &self.p
    }

    pub fn position(&self) -> Ned {
        Ned::new(self.x[NORTH], self.x[EAST])
    }

    /// (north, east) m/s.
    pub fn velocity_mps(&self) -> (f64, f64) {
        (self.x[VEL_NORTH], self.x[VEL_EAST])
    }

    pub fn position_covariance(&self) -> Matrix2<f64> {
        Matrix2::new(
            self.p[(NORTH, NORTH)],
            self.p[(NORTH, EAST)],
            self.p[(EAST, NORTH)],
            self.p[(EAST, EAST)],
        )
    }

    pub fn velocity_covariance(&self) -> Matrix2<f64> {
        Matrix2::new(
            self.p[(VEL_NORTH, VEL_NORTH)],
            self.p[(VEL_NORTH, VEL_EAST)],
            self.p[(VEL_EAST, VEL_NORTH)],
            self.p[(VEL_EAST, VEL_EAST)],
        )
    }

    /// 1-σ along the position's major axis.
    pub fn position_sigma_m(&self) -> f64 {
        major_sigma(&self.position_covariance())
    }

    /// 1-σ along the velocity's major axis.
    pub fn velocity_sigma_mps(&self) -> f64 {
        major_sigma(&self.velocity_covariance())
    }

    /// Eq. 8–9 over `dt_s` (0 is a no-op) with white acceleration of density
    /// `accel_psd_m2ps3` (q, m²/s³).
    pub fn predict(&mut self, dt_s: f64, accel_psd_m2ps3: f64) -> Result<(), KalmanError> {
        if !(dt_s.is_finite() && accel_psd_m2ps3.is_finite()) {
            return Err(KalmanError::NonFinite);
        }
        if accel_psd_m2ps3 < 0.0 {
            return Err(KalmanError::NotPositiveDefinite);
        }
        if dt_s < 0.0 {
            return Err(KalmanError::NegativeInterval);
        }
        if dt_s == 0.0 {
            return Ok(());
        }
        let mut x = self.x;
        x[NORTH] += dt_s * x[VEL_NORTH];
        x[EAST] += dt_s * x[VEL_EAST];
        let mut p = propagate_covariance(&self.p, dt_s) + process_noise(dt_s, accel_psd_m2ps3);
        symmetrise(&mut p);
        if !(x.iter().all(|v| v.is_finite()) && p.iter().all(|v| v.is_finite())) {
            return Err(KalmanError::NonFinite);
        }
        self.x = x;
        self.p = p;
        Ok(())
    }

    /// The innovation of measuring `z` with covariance `r` now (for gating).
    pub fn innovation(&self, z: Ned, r: &Matrix2<f64>) -> Result<Innovation, KalmanError> {
        if !(z.north_m.is_finite() && z.east_m.is_finite() && all_finite2(r)) {
            return Err(KalmanError::NonFinite);
        }
        let residual_m = Vector2::new(z.north_m - self.x[NORTH], z.east_m - self.x[EAST]);
        let covariance = self.position_covariance() + r;
        let s_inv = spd_inverse(&covariance).ok_or(KalmanError::NotPositiveDefinite)?;
        let mahalanobis_sq = (residual_m.transpose() * s_inv * residual_m)[(0, 0)];
        Ok(Innovation {
            residual_m,
            covariance,
            mahalanobis_sq,
        })
    }

    /// Whether `z` is surely outside the gate `mahalanobis_sq ≤ gate`,
    /// without inverting anything: d² = rᵀS⁻¹r ≥ |r|²/λ_max(S) and λ_max(S)
    /// ≤ trace(S) for a positive definite S, so |r|² > gate·trace(S) is
    /// outside (a factor 2 keeps rounding from ever deciding it). `false`
    /// says nothing: compute the distance.
    pub fn surely_outside_gate(&self, z: Ned, r: &Matrix2<f64>, gate: f64) -> bool {
        let (dn, de) = (z.north_m - self.x[NORTH], z.east_m - self.x[EAST]);
        let trace = self.p[(NORTH, NORTH)] + self.p[(EAST, EAST)] + r[(0, 0)] + r[(1, 1)];
        dn * dn + de * de > 2.0 * gate * trace
    }

    /// Squared Mahalanobis distance of `z`, +∞ when it cannot be computed (so
    /// a bad input never passes a gate).
    pub fn mahalanobis_sq(&self, z: Ned, r: &Matrix2<f64>) -> f64 {
        self.innovation(z, r).map_or(f64::INFINITY, |i| i.mahalanobis_sq)
    }

    /// Eq. 10–11 and the Joseph form of eq. 12 with a position `z` of
    /// covariance `r`. Returns the innovation it used. No gate here: the
    /// caller gates (it knows which cluster competes for which track).
    pub fn update(&mut self, z: Ned, r: &Matrix2<f64>) -> Result<Innovation, KalmanError> {
        let innovation = self.innovation(z, r)?;
        let s_inv = spd_inverse(&innovation.covariance).ok_or(KalmanError::NotPositiveDefinite)?;
        let h = h();
        let k: Matrix4x2<f64> = self.p * h.transpose() * s_inv;
        let x = self.x + k * innovation.residual_m;
        let i_kh = Matrix4::identity() - k * h;
        let mut p = i_kh * self.p * i_kh.transpose() + k * r * k.transpose();
        symmetrise(&mut p);
        if !(x.iter().all(|v| v.is_finite()) && p.iter().all(|v| v.is_finite())) {
            return Err(KalmanError::NonFinite);
        }
        if (0..4).any(|i| p[(i, i)] <= 0.0) {
            return Err(KalmanError::NotPositiveDefinite);
        }
        self.x = x;
        self.p = p;
        Ok(innovation)
    }
}

/// The two motion models of [`ImmKalman`], by index.
pub mod mode {
    /// Walking on at a steady velocity: white acceleration of a small density.
    pub const STEADY: usize = 0;
    /// Turning, starting or stopping: the density of the single-model filter.
    pub const MANOEUVRE: usize = 1;
}
use mode::*;

/// How long (s) a steady walker walks on, on average, before manoeuvring,
/// and how long a manoeuvre lasts: the mean sojourns of the mode chain. A
/// walker in a yard keeps a line for several seconds; a turn or a start
/// takes about one.
const STEADY_SOJOURN_S: f64 = 4.0;
const MANOEUVRE_SOJOURN_S: f64 = 1.0;

/// White-acceleration densities (q, m²/s³ per axis) of the two modes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModeNoise {
    pub steady_m2ps3: f64,
    pub manoeuvre_m2ps3: f64,
}

impl ModeNoise {
    fn of(&self, mode: usize) -> f64 {
        if mode == STEADY {
            self.steady_m2ps3
        } else {
            self.manoeuvre_m2ps3
        }
    }
}

/// `Π(T)`: `[i][j]` the probability of mode `j` after `dt_s` in mode `i`,
/// exact for the two-state chain with rates `1/sojourn` (so rate-independent
/// like the process noise: `Π(a)·Π(b) = Π(a+b)`).
pub fn mode_transition(dt_s: f64) -> [[f64; 2]; 2] {
    let leave_steady = 1.0 / STEADY_SOJOURN_S;
    let leave_manoeuvre = 1.0 / MANOEUVRE_SOJOURN_S;
    let total = leave_steady + leave_manoeuvre;
    let settled = -(-total * dt_s).exp_m1();
    let to_manoeuvre = leave_steady / total * settled;
    let to_steady = leave_manoeuvre / total * settled;
    [[1.0 - to_manoeuvre, to_manoeuvre], [to_steady, 1.0 - to_steady]]
}

/// The moment-matched mixture `Σ wᵢ·N(xᵢ, Pᵢ)` as one Gaussian: the weighted
/// mean, and the weighted covariances plus the spread of the means about it.
fn mixture(models: &[CvKalman; 2], weights: [f64; 2]) -> Result<CvKalman, KalmanError> {
    let x = models[0].x * weights[0] + models[1].x * weights[1];
    let mut p = Matrix4::zeros();
    for (model, w) in models.iter().zip(weights) {
        let d = model.x - x;
        p += (model.p + d * d.transpose()) * w;
    }
    symmetrise(&mut p);
    if !(x.iter().all(|v| v.is_finite()) && p.iter().all(|v| v.is_finite())) {
        return Err(KalmanError::NonFinite);
    }
    Ok(CvKalman { x, p })
}

/// `ln(√det S · N(ν; 0, S))` up to a constant: the log-likelihood of an
/// innovation, for comparing the modes.
fn log_likelihood(innovation: &Innovation) -> f64 {
    let s = &innovation.covariance;
    let det = s[(0, 0)] * s[(1, 1)] - s[(0, 1)] * s[(1, 0)];
    -0.5 * (innovation.mahalanobis_sq + det.ln())
}

/// One obstacle's interacting-multiple-model filter: a steady and a
/// manoeuvring constant-velocity filter, mixed (see the module header).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImmKalman {
    models: [CvKalman; 2],
    /// `μ`: each mode's probability, summing to 1.
    probability: [f64; 2],
    /// The mixture of the models under `probability`: the estimate.
    estimate: CvKalman,
}

impl ImmKalman {
    /// Both models start as [`CvKalman::new`]; neither mode is favoured.
    pub fn new(position: Ned, r: &Matrix2<f64>, velocity_sigma_mps: f64) -> Result<Self, KalmanError> {
        let kf = CvKalman::new(position, r, velocity_sigma_mps)?;
        Ok(ImmKalman {
            models: [kf; 2],
            probability: [0.5; 2],
            estimate: kf,
        })
    }

    /// Any two models and mode probabilities (tests, restoring a track):
    /// the probabilities must be finite, non-negative and not both zero;
    /// they are normalised.
    pub fn from_models(models: [CvKalman; 2], probability: [f64; 2]) -> Result<Self, KalmanError> {
        let total = probability[0] + probability[1];
        if !(probability.iter().all(|p| p.is_finite() && *p >= 0.0) && total > 0.0) {
            return Err(KalmanError::NonFinite);
        }
        let probability = [probability[0] / total, probability[1] / total];
        let estimate = mixture(&models, probability)?;
        Ok(ImmKalman {
            models,
            probability,
            estimate,
        })
    }

    /// The mixture: what the track reports and is gated with.
    pub fn estimate(&self) -> &CvKalman {
        &self.estimate
    }

    /// One mode's filter ([`mode::STEADY`] or [`mode::MANOEUVRE`]).
    pub fn model(&self, mode: usize) -> &CvKalman {
        &self.models[mode]
    }

    /// One mode's probability `μ`.
    pub fn probability(&self, mode: usize) -> f64 {
        self.probability[mode]
    }

    /// Mixing and each model's prediction over `dt_s` (0 is a no-op). Errors
    /// as [`CvKalman::predict`], leaving the filter unchanged.
    pub fn predict(&mut self, dt_s: f64, noise: &ModeNoise) -> Result<(), KalmanError> {
        if !(dt_s.is_finite() && noise.steady_m2ps3.is_finite() && noise.manoeuvre_m2ps3.is_finite()) {
            return Err(KalmanError::NonFinite);
        }
        if dt_s < 0.0 {
            return Err(KalmanError::NegativeInterval);
        }
        if dt_s == 0.0 {
            return Ok(());
        }
        let pi = mode_transition(dt_s);
        let mu = self.probability;
        let predicted = [0, 1].map(|j| pi[0][j] * mu[0] + pi[1][j] * mu[1]);
        let mut models = self.models;
        for (j, model) in models.iter_mut().enumerate() {
            // μ_{i|j}: where mode j's hypothesis came from; a mode nothing
            // leads to (rounded to zero) keeps its own filter.
            let weights = if predicted[j] > 0.0 {
                [0, 1].map(|i| pi[i][j] * mu[i] / predicted[j])
            } else {
                [0, 1].map(|i| if i == j { 1.0 } else { 0.0 })
            };
            *model = mixture(&self.models, weights)?;
            model.predict(dt_s, noise.of(j))?;
        }
        self.commit(models, predicted)
    }

    /// Each model's update with `z` of covariance `r`, the modes reweighted
    /// by how well each predicted it. Returns the mixture's innovation
    /// (before the update); errors leave the filter unchanged.
    pub fn update(&mut self, z: Ned, r: &Matrix2<f64>) -> Result<Innovation, KalmanError> {
        let innovation = self.estimate.innovation(z, r)?;
        let mut models = self.models;
        let mut log_l = [0.0; 2];
        for (model, log_l) in models.iter_mut().zip(log_l.iter_mut()) {
            *log_l = log_likelihood(&model.update(z, r)?);
        }
        // Relative to the larger, so a far outlier underflows neither.
        let best = log_l[0].max(log_l[1]);
        let weighted = [0, 1].map(|j| self.probability[j] * (log_l[j] - best).exp());
        let total = weighted[0] + weighted[1];
        if !(total > 0.0 && total.is_finite()) {
            return Err(KalmanError::NonFinite);
        }
        self.commit(models, [weighted[0] / total, weighted[1] / total])?;
        Ok(innovation)
    }

    fn commit(&mut self, models: [CvKalman; 2], probability: [f64; 2]) -> Result<(), KalmanError> {
        let estimate = mixture(&models, probability)?;
        self.models = models;
        self.probability = probability;
        self.estimate = estimate;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    /// A standard normal sample from the test's seeded stream.
    fn gauss(rng: &mut ChaCha8Rng) -> f64 {
        rng.sample(StandardNormal)
    }

    #[test]
    fn process_noise_is_the_integral_of_white_acceleration() {
        // Q = ∫₀ᵀ e^{Fτ} G q Gᵀ e^{Fᵀτ} dτ, G = [0 1]ᵀ, by the midpoint rule.
        let (dt, psd) = (0.37, 1.69);
        let q = process_noise(dt, psd);
        let n = 20_000;
        let (mut pp, mut pv, mut vv) = (0.0, 0.0, 0.0);
        for i in 0..n {
            let tau = (i as f64 + 0.5) * dt / n as f64;
            let w = psd * dt / n as f64;
            pp += tau * tau * w;
            pv += tau * w;
            vv += w;
        }
        for (p, v) in [(NORTH, VEL_NORTH), (EAST, VEL_EAST)] {
            assert!((q[(p, p)] - pp).abs() < 1e-9);
            assert!((q[(p, v)] - pv).abs() < 1e-9);
            assert!((q[(v, v)] - vv).abs() < 1e-9);
        }
        assert_eq!(q[(NORTH, EAST)], 0.0);
        // Two half steps make one whole step (the model is rate-independent).
        let f = transition(dt / 2.0);
        let two = f * process_noise(dt / 2.0, psd) * f.transpose() + process_noise(dt / 2.0, psd);
        assert!((two - q).abs().max() < 1e-12);
    }

    #[test]
    fn polar_covariance_is_range_along_the_beam_and_bearing_across() {
        let sensor = Ned::new(1.0, 1.0);
        // A point due east (bearing 90°) at 10 m: range σ along east, 10·σ_β along north.
        let r = polar_measurement_covariance(sensor, Ned::new(1.0, 11.0), 0.02, 0.001);
        assert!((r[(1, 1)] - 0.02f64.powi(2)).abs() < 1e-12);
        assert!((r[(0, 0)] - 0.01f64.powi(2)).abs() < 1e-12);
        assert!(r[(0, 1)].abs() < 1e-12);
        // At 45° the cross term carries the difference of the two variances.
        let p = Ned::new(1.0 + 5.0 * 2f64.sqrt(), 1.0 + 5.0 * 2f64.sqrt());
        let r = polar_measurement_covariance(sensor, p, 0.02, 0.001);
        assert!((r[(0, 1)] - 0.5 * (0.0004 - 0.0001)).abs() < 1e-12);
        assert!((major_sigma(&r) - 0.02).abs() < 1e-12);
    }

    #[test]
    fn the_cheap_gate_test_never_rejects_what_the_gate_passes() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let gate = chi2_gate_2dof(0.99);
        let (mut rejected, mut tried) = (0, 0);
        for _ in 0..20_000 {
            let r = polar_measurement_covariance(
                Ned::new(0.0, 0.0),
                Ned::new(rng.random_range(-15.0..15.0), rng.random_range(-15.0..15.0)),
                rng.random_range(0.005..0.05),
                rng.random_range(0.0005..0.01),
            );
            let mut kf = CvKalman::new(Ned::new(1.0, -2.0), &r, 1.0).unwrap();
            // A scan or a few apart, as between updates.
            kf.predict(rng.random_range(0.0..0.1), rng.random_range(0.1..4.0))
                .unwrap();
            let z = Ned::new(1.0 + rng.random_range(-3.0..3.0), -2.0 + rng.random_range(-3.0..3.0));
            let outside = kf.surely_outside_gate(z, &r, gate);
            assert!(!(outside && kf.mahalanobis_sq(z, &r) <= gate), "{z:?} {r:?}");
            rejected += usize::from(outside);
            tried += 1;
        }
        // It must also be worth having: most far pairs are settled cheaply.
        assert!(rejected > tried / 4, "{rejected} of {tried}");
    }

    #[test]
    fn the_written_out_propagation_is_the_matrix_product_to_the_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for case in 0..1000 {
            let mut p = Matrix4::from_fn(|_, _| gauss(&mut rng));
            // Some exact zeros, as a new track's cross terms are.
            p[(NORTH, VEL_NORTH)] = 0.0;
            p[(VEL_EAST, EAST)] = 0.0;
            let dt_s = 0.001 + 0.2 * rng.random::<f64>();
            let f = transition(dt_s);
            let product = f * p * f.transpose();
            let written = propagate_covariance(&p, dt_s);
            for (a, b) in product.iter().zip(written.iter()) {
                // Equal, the sign of a zero aside.
                assert!(
                    a.to_bits() == b.to_bits() || (*a == 0.0 && *b == 0.0),
                    "case {case}: {a} vs {b}"
                );
            }
        }
    }

    #[test]
    fn chi2_gate_matches_tables() {
        assert!((chi2_gate_2dof(0.99) - 9.2103).abs() < 1e-3);
        assert!((chi2_gate_2dof(0.9) - 4.6052).abs() < 1e-3);
    }

    #[test]
    fn refuses_bad_inputs_and_stays_unchanged() {
        let r = Matrix2::identity() * 0.01;
        let mut kf = CvKalman::new(Ned::new(1.0, 2.0), &r, 1.0).unwrap();
        let before = kf;
        assert_eq!(kf.predict(f64::NAN, 1.0), Err(KalmanError::NonFinite));
        assert_eq!(kf.predict(-0.1, 1.0), Err(KalmanError::NegativeInterval));
        assert_eq!(kf.predict(0.1, -1.0), Err(KalmanError::NotPositiveDefinite));
        assert_eq!(kf.update(Ned::new(f64::NAN, 0.0), &r), Err(KalmanError::NonFinite));
        let bad_r = Matrix2::new(1.0, 2.0, 2.0, 1.0);
        assert_eq!(
            kf.update(Ned::new(1.0, 2.0), &(bad_r - kf.position_covariance())),
            Err(KalmanError::NotPositiveDefinite)
        );
        assert_eq!(kf, before);
        assert_eq!(kf.mahalanobis_sq(Ned::new(f64::INFINITY, 0.0), &r), f64::INFINITY);
        assert!(CvKalman::new(Ned::new(0.0, 0.0), &Matrix2::zeros(), 1.0).is_err());
    }

    #[test]
    fn covariance_stays_symmetric_and_positive_over_many_steps() {
        let rng = &mut ChaCha8Rng::seed_from_u64(7);
        let r = Matrix2::new(0.0025, 0.0012, 0.0012, 0.0009);
        let mut kf = CvKalman::new(Ned::new(0.0, 0.0), &r, 2.0).unwrap();
        for i in 0..100_000 {
            kf.predict(if i % 97 == 0 { 0.5 } else { 0.02 }, 1.0).unwrap();
            let z = Ned::new(0.05 * gauss(rng), 0.03 * gauss(rng));
            kf.update(z, &r).unwrap();
        }
        let p = kf.covariance();
        assert_eq!(*p, p.transpose());
        assert!(p.cholesky().is_some());
    }

    /// The seed's claim in numbers: a constant-velocity target, positions at
    /// 50 Hz with 30 mm of white noise per axis (a leg-sized cluster's centroid
    /// at a few metres), 1 s after the first measurement.
    #[test]
    fn converges_to_a_constant_velocity() {
        let (vn, ve) = (1.2, -0.7);
        let sigma_m = 0.03;
        let r = Matrix2::identity() * sigma_m * sigma_m;
        let mut sq_err = 0.0;
        let mut sq_sigma = 0.0;
        let runs = 200;
        for seed in 0..runs {
            let rng = &mut ChaCha8Rng::seed_from_u64(seed);
            let truth = |t: f64| Ned::new(3.0 + vn * t, -2.0 + ve * t);
            let noisy = |rng: &mut ChaCha8Rng, p: Ned| {
                Ned::new(p.north_m + sigma_m * gauss(rng), p.east_m + sigma_m * gauss(rng))
            };
            let mut kf = CvKalman::new(noisy(rng, truth(0.0)), &r, 2.0).unwrap();
            for k in 1..=50 {
                kf.predict(0.02, 1.0).unwrap();
                kf.update(noisy(rng, truth(k as f64 * 0.02)), &r).unwrap();
            }
            let (en, ee) = (kf.velocity_mps().0 - vn, kf.velocity_mps().1 - ve);
            sq_err += en * en + ee * ee;
            sq_sigma += kf.velocity_covariance().trace();
        }
        let rms = (sq_err / runs as f64).sqrt();
        let predicted = (sq_sigma / runs as f64).sqrt();
        println!(
            "KF alone, 50 Hz, σ 30 mm/axis, after 1 s: velocity error RMS {rms:.3} m/s (filter's σ {predicted:.3})"
        );
        assert!(rms < 0.25, "{rms}");
        // The filter budgets for accelerations this target never makes, so
        // its σ over-states the error (≈ 2× here) — it must never under-state
        // it. (An earlier version asserted they matched; they only match when
        // the truth has the modelled acceleration: see the next test.)
        assert!(rms < predicted, "{rms} vs {predicted}");
    }

    /// With a truth driven by exactly the modelled white acceleration, the
    /// filter's covariance is the covariance of its error (NEES ≈ state
    /// dimension).
    #[test]
    fn is_consistent_when_the_truth_follows_the_model() {
        let (q, sigma_m, dt) = (1.5, 0.03, 0.02);
        let r = Matrix2::identity() * sigma_m * sigma_m;
        let q_chol = process_noise(dt, q).cholesky().unwrap().l();
        let runs = 400;
        let mut nees = 0.0;
        for seed in 0..runs {
            let rng = &mut ChaCha8Rng::seed_from_u64(10_000 + seed);
            // The prior: velocity σ 2 m/s about zero, drawn accordingly.
            let mut truth = Vector4::new(2.0, 2.0 * gauss(rng), -1.0, 2.0 * gauss(rng));
            let first = Ned::new(truth[NORTH] + sigma_m * gauss(rng), truth[EAST] + sigma_m * gauss(rng));
            let mut kf = CvKalman::new(first, &r, 2.0).unwrap();
            for _ in 0..100 {
                let w = q_chol * Vector4::new(gauss(rng), gauss(rng), gauss(rng), gauss(rng));
                truth = transition(dt) * truth + w;
                kf.predict(dt, q).unwrap();
                let z = Ned::new(truth[NORTH] + sigma_m * gauss(rng), truth[EAST] + sigma_m * gauss(rng));
                kf.update(z, &r).unwrap();
            }
            let e = kf.state() - truth;
            nees += (e.transpose() * kf.covariance().try_inverse().unwrap() * e)[(0, 0)];
        }
        let mean_nees = nees / runs as f64;
        println!("KF with truth from the model: mean NEES {mean_nees:.2} (expected 4)");
        // χ²₄ mean 4; over 400 runs its standard error is √(8/400) ≈ 0.14.
        assert!((mean_nees - 4.0).abs() < 0.6, "{mean_nees}");
    }
    const WALKER_NOISE: ModeNoise = ModeNoise {
        steady_m2ps3: 0.05,
        manoeuvre_m2ps3: 1.5,
    };

    /// A filter under test: one 20 ms step with a measurement, returning
    /// the estimated velocity (north, east).
    type Step<'a> = dyn FnMut(Ned) -> (f64, f64) + 'a;

    /// A person walking at `velocity(t)` from (3, −2), seen at 50 Hz with
    /// 30 mm of white noise per axis for `seconds`: each tick's time and
    /// velocity error (m/s) of the filter `make` builds on the first
    /// measurement.
    fn walk(
        seed: u64,
        seconds: f64,
        velocity: impl Fn(f64) -> (f64, f64),
        make: &dyn Fn(Ned, &Matrix2<f64>) -> Box<Step<'static>>,
    ) -> Vec<(f64, f64)> {
        let sigma_m = 0.03;
        let r = Matrix2::identity() * sigma_m * sigma_m;
        let rng = &mut ChaCha8Rng::seed_from_u64(seed);
        let mut truth = Ned::new(3.0, -2.0);
        let noisy =
            |rng: &mut ChaCha8Rng, p: Ned| Ned::new(p.north_m + sigma_m * gauss(rng), p.east_m + sigma_m * gauss(rng));
        let mut step = make(noisy(rng, truth), &r);
        let ticks = (seconds / 0.02).round() as u64;
        (1..=ticks)
            .map(|k| {
                let t = k as f64 * 0.02;
                let (vn, ve) = velocity(t - 0.01);
                truth = Ned::new(truth.north_m + vn * 0.02, truth.east_m + ve * 0.02);
                let (en, ee) = step(noisy(rng, truth));
                let (vn, ve) = velocity(t);
                (t, (en - vn).hypot(ee - ve))
            })
            .collect()
    }

    fn single(q: f64) -> impl Fn(Ned, &Matrix2<f64>) -> Box<Step<'static>> {
        move |first, r| {
            let mut kf = CvKalman::new(first, r, 2.0).unwrap();
            let r = *r;
            Box::new(move |z| {
                kf.predict(0.02, q).unwrap();
                kf.update(z, &r).unwrap();
                kf.velocity_mps()
            })
        }
    }

    fn imm(first: Ned, r: &Matrix2<f64>) -> Box<Step<'static>> {
        let mut kf = ImmKalman::new(first, r, 2.0).unwrap();
        let r = *r;
        Box::new(move |z| {
            kf.predict(0.02, &WALKER_NOISE).unwrap();
            kf.update(z, &r).unwrap();
            kf.estimate().velocity_mps()
        })
    }

    /// RMS velocity error of a steady walker (1.0, 0.6) m/s from 3 s to
    /// 10 s, over 20 walks.
    fn steady_rms(make: &dyn Fn(Ned, &Matrix2<f64>) -> Box<Step<'static>>) -> f64 {
        let (mut sq, mut n) = (0.0, 0);
        for seed in 0..20 {
            for (t, e) in walk(seed, 10.0, |_| (1.0, 0.6), make) {
                if t >= 3.0 {
                    sq += e * e;
                    n += 1;
                }
            }
        }
        (sq / f64::from(n)).sqrt()
    }

    #[test]
    fn imm_holds_a_steady_walkers_velocity_closer_than_the_single_filter() {
        let imm_rms = steady_rms(&imm);
        let single_rms = steady_rms(&single(WALKER_NOISE.manoeuvre_m2ps3));
        println!("steady walker, velocity error RMS after 3 s: single {single_rms:.3} m/s, IMM {imm_rms:.3} m/s");
        // Measured: single 0.250, IMM 0.080. The single filter (OA_TRK_ACC
        // alone) misses this bound.
        const BOUND_MPS: f64 = 0.12;
        assert!(imm_rms < BOUND_MPS, "{imm_rms}");
        assert!(single_rms > BOUND_MPS, "{single_rms}");
    }

    /// Ticks after a 90° turn (1.2 m/s north, then east, at 5 s) until the
    /// velocity error is below 0.3 m/s, the worst of 20 walks.
    fn ticks_to_follow_a_turn(make: &dyn Fn(Ned, &Matrix2<f64>) -> Box<Step<'static>>) -> usize {
        let turn = |t: f64| if t < 5.0 { (1.2, 0.0) } else { (0.0, 1.2) };
        (0..20)
            .map(|seed| {
                let errors = walk(seed, 8.0, turn, make);
                let turn_tick = errors.iter().position(|&(t, _)| t >= 5.0).unwrap();
                errors[turn_tick..]
                    .iter()
                    .position(|&(_, e)| e < 0.3)
                    .unwrap_or(errors.len())
            })
            .max()
            .unwrap()
    }

    #[test]
    fn imm_follows_a_turn_about_as_fast_as_the_manoeuvring_filter() {
        let imm_ticks = ticks_to_follow_a_turn(&imm);
        let manoeuvring = ticks_to_follow_a_turn(&single(WALKER_NOISE.manoeuvre_m2ps3));
        let steady = ticks_to_follow_a_turn(&single(WALKER_NOISE.steady_m2ps3));
        println!(
            "90° turn at 1.2 m/s, ticks to within 0.3 m/s: manoeuvring {manoeuvring}, steady {steady}, IMM {imm_ticks}"
        );
        // Measured: manoeuvring 9, steady 18, IMM 8. The single filter as
        // sharp on a steady walker as the IMM (the steady mode alone: RMS
        // 0.071 m/s against the IMM's 0.080) misses this bound.
        const BOUND_TICKS: usize = 10;
        assert!(imm_ticks <= BOUND_TICKS, "{imm_ticks}");
        assert!(steady > BOUND_TICKS, "{steady}");
        assert!(steady_rms(&single(WALKER_NOISE.steady_m2ps3)) < steady_rms(&imm));
    }

    #[test]
    fn the_modes_follow_the_walker() {
        let sigma_m = 0.03;
        let r = Matrix2::identity() * sigma_m * sigma_m;
        let rng = &mut ChaCha8Rng::seed_from_u64(3);
        let mut truth = Ned::new(0.0, 0.0);
        let mut kf = ImmKalman::new(truth, &r, 2.0).unwrap();
        let mut manoeuvre_after_turn: f64 = 0.0;
        for k in 1..=300 {
            let (vn, ve) = if k <= 250 { (1.2, 0.0) } else { (0.0, 1.2) };
            truth = Ned::new(truth.north_m + vn * 0.02, truth.east_m + ve * 0.02);
            kf.predict(0.02, &WALKER_NOISE).unwrap();
            let z = Ned::new(
                truth.north_m + sigma_m * gauss(rng),
                truth.east_m + sigma_m * gauss(rng),
            );
            kf.update(z, &r).unwrap();
            assert!((kf.probability(STEADY) + kf.probability(MANOEUVRE) - 1.0).abs() < 1e-12);
            if k == 250 {
                assert!(kf.probability(STEADY) > 0.9, "{}", kf.probability(STEADY));
            }
            if (251..=265).contains(&k) {
                manoeuvre_after_turn = manoeuvre_after_turn.max(kf.probability(MANOEUVRE));
            }
        }
        assert!(manoeuvre_after_turn > 0.9, "{manoeuvre_after_turn}");
    }

    #[test]
    fn mode_transition_is_a_rate_independent_chain() {
        assert_eq!(mode_transition(0.0), [[1.0, 0.0], [0.0, 1.0]]);
        let product =
            |a: [[f64; 2]; 2], b: [[f64; 2]; 2]| [0, 1].map(|i| [0, 1].map(|j| a[i][0] * b[0][j] + a[i][1] * b[1][j]));
        let two_halves = product(mode_transition(0.13), mode_transition(0.13));
        let whole = mode_transition(0.26);
        for i in 0..2 {
            assert!((whole[i][0] + whole[i][1] - 1.0).abs() < 1e-12);
            for j in 0..2 {
                assert!((two_halves[i][j] - whole[i][j]).abs() < 1e-12);
            }
        }
        // Long after, the chain forgets: steady 1/(1 + sojourn ratio).
        let settled = mode_transition(1e3);
        let steady = STEADY_SOJOURN_S / (STEADY_SOJOURN_S + MANOEUVRE_SOJOURN_S);
        assert!((settled[1][STEADY] - steady).abs() < 1e-12);
    }

    #[test]
    fn the_estimate_is_the_moment_matched_mixture() {
        let r = Matrix2::identity() * 0.01;
        let base = CvKalman::new(Ned::new(1.0, 2.0), &r, 0.1).unwrap();
        let mut x = *base.state();
        x[VEL_NORTH] = 1.0;
        let moving = CvKalman::from_parts(x, *base.covariance()).unwrap();
        let imm = ImmKalman::from_models([base, moving], [3.0, 1.0]).unwrap();
        assert_eq!(imm.probability(STEADY), 0.75);
        let estimate = imm.estimate();
        assert!((estimate.velocity_mps().0 - 0.25).abs() < 1e-12);
        // 0.1² of each model plus the means' spread 0.75·0.25² + 0.25·0.75².
        let var = estimate.covariance()[(VEL_NORTH, VEL_NORTH)];
        assert!((var - (0.01 + 0.1875)).abs() < 1e-12, "{var}");
        assert_eq!(estimate.covariance()[(EAST, EAST)], 0.01);
        assert!(ImmKalman::from_models([base, moving], [0.0, 0.0]).is_err());
        assert!(ImmKalman::from_models([base, moving], [f64::NAN, 1.0]).is_err());
    }

    #[test]
    fn imm_refuses_bad_inputs_and_stays_unchanged() {
        let r = Matrix2::identity() * 0.01;
        let mut kf = ImmKalman::new(Ned::new(1.0, 2.0), &r, 1.0).unwrap();
        kf.predict(0.1, &WALKER_NOISE).unwrap();
        kf.update(Ned::new(1.05, 2.0), &r).unwrap();
        let before = kf;
        assert_eq!(kf.predict(0.0, &WALKER_NOISE), Ok(()));
        assert_eq!(kf.predict(f64::NAN, &WALKER_NOISE), Err(KalmanError::NonFinite));
        assert_eq!(kf.predict(-0.1, &WALKER_NOISE), Err(KalmanError::NegativeInterval));
        let negative = ModeNoise {
            steady_m2ps3: -1.0,
            ..WALKER_NOISE
        };
        assert_eq!(kf.predict(0.1, &negative), Err(KalmanError::NotPositiveDefinite));
        let infinite = ModeNoise {
            manoeuvre_m2ps3: f64::INFINITY,
            ..WALKER_NOISE
        };
        assert_eq!(kf.predict(0.1, &infinite), Err(KalmanError::NonFinite));
        assert_eq!(kf.update(Ned::new(f64::NAN, 0.0), &r), Err(KalmanError::NonFinite));
        assert_eq!(
            kf.update(Ned::new(1.0, 2.0), &Matrix2::new(1.0, 2.0, 2.0, 1.0)),
            Err(KalmanError::NotPositiveDefinite)
        );
        assert_eq!(kf, before);
        // A far outlier underflows neither mode's likelihood.
        kf.update(Ned::new(1e4, -1e4), &r).unwrap();
        assert!(kf.probability(STEADY).is_finite() && kf.probability(MANOEUVRE).is_finite());
    }
}
