//! Interacting multiple model (IMM) filter for one tracked obstacle: two
//! constant-velocity [`CvKalman`]s that differ only in their white
//! acceleration, mixed by the textbook IMM cycle (Blom and Bar-Shalom; Bar-
//! Shalom, Li and Kirubarajan, *Estimation with Applications to Tracking
//! and Navigation*, §11.6).
//!
//! # Why two models
//! One constant-velocity filter has to take a single white acceleration
//! `q` for someone walking steadily and for someone starting, stopping or
//! turning. Chosen for the manoeuvre (q ≈ 1.5 m²/s³), it follows every
//! centroid jitter of a steady walk: at 50 Hz its velocity wanders by
//! 0.1–0.2 m/s, which over a 3 s horizon puts a walker who passes 0.5 m
//! clear of the vehicle into its path. Chosen for the steady walk, it takes
//! a second or more to see someone step out. The IMM runs both and weighs
//! them by how well each has predicted the measurements: steady walking is
//! estimated with the low `q`, and a manoeuvre moves the weight to the high
//! one within a few scans.
//!
//! # Cycle (per scan)
//! - Mode switching is a continuous-time Markov chain (mean sojourn
//!   [`ImmConfig::steady_mean_s`] in the steady model,
//!   [`ImmConfig::manoeuvre_mean_s`] in the manoeuvring one), so its
//!   transition matrix over an interval `T` is exact for any `T` (scans get
//!   dropped, two scanners interleave).
//! - Mixing: each model starts the interval from the mixture of both,
//!   weighted by the probability that the object was in the other model
//!   and switched; the spread of the means is added to the covariance.
//! - Each model predicts with its own `q` and is updated with the same
//!   measurement; its mode probability is scaled by the Gaussian likelihood
//!   of its innovation.
//! - The combined estimate is the probability-weighted mean, with the
//!   spread of the means in its covariance: gating, the velocity σ and the
//!   public track use it.
//!
//! A refused step (bad input, a covariance that is not positive definite)
//! leaves the filter as it was.

use nalgebra::{Matrix2, Matrix4, Vector4};

use super::kalman::{CvKalman, KalmanError};
use crate::geo::Ned;

/// A mode probability never falls below this: a model written off entirely
/// could never take the weight back when the object starts to manoeuvre.
const MIN_MODE_PROBABILITY: f64 = 0.02;

/// The two models and how the object switches between them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImmConfig {
    /// White acceleration density of steady motion, m²/s³.
    pub steady_psd_m2ps3: f64,
    /// …and of starting, stopping and turning, m²/s³.
    pub manoeuvre_psd_m2ps3: f64,
    /// Mean time an object keeps moving steadily, s.
    pub steady_mean_s: f64,
    /// Mean time a manoeuvre lasts, s.
    pub manoeuvre_mean_s: f64,
}

/// Indices of the two models.
const STEADY: usize = 0;
const MANOEUVRE: usize = 1;

/// One obstacle's IMM filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImmKalman {
    models: [CvKalman; 2],
    mode_probability: [f64; 2],
    combined: CvKalman,
}

impl ImmKalman {
    /// Both models start at the measured position with zero velocity of σ
    /// `velocity_sigma_mps` (see [`CvKalman::new`]), in the chain's
    /// long-run mode probabilities.
    pub fn new(
        position: Ned,
        r: &Matrix2<f64>,
        velocity_sigma_mps: f64,
        config: &ImmConfig,
    ) -> Result<Self, KalmanError> {
        let kf = CvKalman::new(position, r, velocity_sigma_mps)?;
        let (leave_steady, leave_manoeuvre) = rates(config)?;
        let steady = leave_manoeuvre / (leave_steady + leave_manoeuvre);
        Ok(ImmKalman {
            models: [kf, kf],
            mode_probability: [steady, 1.0 - steady],
            combined: kf,
        })
    }

    /// The combined estimate (gating, position, velocity and their σ).
    pub fn combined(&self) -> &CvKalman {
        &self.combined
    }

    /// The manoeuvring model alone (its σ bounds what is known of the
    /// velocity when the object may be changing it).
    pub fn manoeuvre(&self) -> &CvKalman {
        &self.models[MANOEUVRE]
    }

    /// Probability that the object is manoeuvring.
    pub fn manoeuvre_probability(&self) -> f64 {
        self.mode_probability[MANOEUVRE]
    }

    /// Mixing and prediction over `dt_s` (0 is a no-op).
    pub fn predict(&mut self, dt_s: f64, config: &ImmConfig) -> Result<(), KalmanError> {
        if !dt_s.is_finite() {
            return Err(KalmanError::NonFinite);
        }
        if dt_s < 0.0 {
            return Err(KalmanError::NegativeInterval);
        }
        if dt_s == 0.0 {
            return Ok(());
        }
        let switch = transition(dt_s, config)?;
        let mu = self.mode_probability;
        // c_j: probability of model j after the switch.
        let prior = [
            switch[STEADY][STEADY] * mu[STEADY] + switch[MANOEUVRE][STEADY] * mu[MANOEUVRE],
            switch[STEADY][MANOEUVRE] * mu[STEADY] + switch[MANOEUVRE][MANOEUVRE] * mu[MANOEUVRE],
        ];
        let mut models = self.models;
        for (j, model) in models.iter_mut().enumerate() {
            let weights = [
                switch[STEADY][j] * mu[STEADY] / prior[j],
                switch[MANOEUVRE][j] * mu[MANOEUVRE] / prior[j],
            ];
            let (x, p) = mixture(&self.models, weights);
            *model = CvKalman::from_parts(x, p)?;
            let psd = [config.steady_psd_m2ps3, config.manoeuvre_psd_m2ps3][j];
            model.predict(dt_s, psd)?;
        }
        let mode_probability = floored(prior);
        let combined = combine(&models, mode_probability)?;
        self.models = models;
        self.mode_probability = mode_probability;
        self.combined = combined;
        Ok(())
    }

    /// Updates both models with a position `z` of covariance `r` and
    /// reweighs them by the likelihood of their innovations.
    pub fn update(&mut self, z: Ned, r: &Matrix2<f64>) -> Result<(), KalmanError> {
        let mut models = self.models;
        let mut weight = [0.0; 2];
        for (j, model) in models.iter_mut().enumerate() {
            let innovation = model.update(z, r)?;
            weight[j] = self.mode_probability[j] * likelihood(&innovation.covariance, innovation.mahalanobis_sq);
        }
        let total = weight[STEADY] + weight[MANOEUVRE];
        // Both likelihoods underflow only for a measurement far outside any
        // gate: keep the weights as they were rather than divide by zero.
        let mode_probability = if total > 0.0 && total.is_finite() {
            floored([weight[STEADY] / total, weight[MANOEUVRE] / total])
        } else {
            self.mode_probability
        };
        let combined = combine(&models, mode_probability)?;
        self.models = models;
        self.mode_probability = mode_probability;
        self.combined = combined;
        Ok(())
    }
}

/// Rates of leaving the steady and the manoeuvring model, 1/s.
fn rates(config: &ImmConfig) -> Result<(f64, f64), KalmanError> {
    let (steady_s, manoeuvre_s) = (config.steady_mean_s, config.manoeuvre_mean_s);
    if !(steady_s.is_finite() && manoeuvre_s.is_finite()) {
        return Err(KalmanError::NonFinite);
    }
    if !(steady_s > 0.0 && manoeuvre_s > 0.0) {
        return Err(KalmanError::NotPositiveDefinite);
    }
    Ok((1.0 / steady_s, 1.0 / manoeuvre_s))
}

/// `Π[i][j]`: probability of being in model j `dt_s` after being in i, for
/// the two-state chain (exact: `exp(Λ·dt)`).
fn transition(dt_s: f64, config: &ImmConfig) -> Result<[[f64; 2]; 2], KalmanError> {
    let (a, b) = rates(config)?;
    let sum = a + b;
    let decay = (-sum * dt_s).exp();
    let stay_steady = (b + a * decay) / sum;
    let stay_manoeuvre = (a + b * decay) / sum;
    Ok([[stay_steady, 1.0 - stay_steady], [1.0 - stay_manoeuvre, stay_manoeuvre]])
}

/// Mode probabilities kept at least [`MIN_MODE_PROBABILITY`], summing to 1.
fn floored(mu: [f64; 2]) -> [f64; 2] {
    let steady = mu[STEADY].clamp(MIN_MODE_PROBABILITY, 1.0 - MIN_MODE_PROBABILITY);
    [steady, 1.0 - steady]
}

/// Weighted mean of the models' states and their covariance, with the
/// spread of the means.
fn mixture(models: &[CvKalman; 2], weights: [f64; 2]) -> (Vector4<f64>, Matrix4<f64>) {
    let x = models[STEADY].state() * weights[STEADY] + models[MANOEUVRE].state() * weights[MANOEUVRE];
    let mut p = Matrix4::zeros();
    for (model, w) in models.iter().zip(weights) {
        let d = model.state() - x;
        p += (model.covariance() + d * d.transpose()) * w;
    }
    (x, p)
}

fn combine(models: &[CvKalman; 2], mode_probability: [f64; 2]) -> Result<CvKalman, KalmanError> {
    let (x, p) = mixture(models, mode_probability);
    CvKalman::from_parts(x, p)
}

/// Gaussian density of an innovation with covariance `s` at squared
/// Mahalanobis distance `d2`.
fn likelihood(s: &Matrix2<f64>, d2: f64) -> f64 {
    let det = s[(0, 0)] * s[(1, 1)] - s[(0, 1)] * s[(1, 0)];
    if !(det > 0.0 && d2.is_finite()) {
        return 0.0;
    }
    (-0.5 * d2).exp() / (std::f64::consts::TAU * det.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    const CONFIG: ImmConfig = ImmConfig {
        steady_psd_m2ps3: 0.1,
        manoeuvre_psd_m2ps3: 1.5,
        steady_mean_s: 0.5,
        manoeuvre_mean_s: 1.0,
    };
    /// Centroid noise per axis, m (a person's cluster at a few metres).
    const NOISE_M: f64 = 0.04;
    const DT_S: f64 = 0.02;

    fn r() -> Matrix2<f64> {
        Matrix2::identity() * NOISE_M * NOISE_M
    }

    /// A person standing until `start_s`, then walking east at `speed_mps`,
    /// measured with noise every scan; the velocity error of the IMM and of
    /// one filter at the manoeuvre `q`, sampled each scan after `from_s`:
    /// (RMS IMM, RMS single, and how long after the start each first comes
    /// within `within` m/s of the true velocity).
    fn walk(seed: u64, start_s: f64, speed_mps: f64, from_s: f64, within: f64) -> (f64, f64, f64, f64) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut imm = ImmKalman::new(Ned::new(5.0, 0.0), &r(), 2.0, &CONFIG).expect("imm");
        let mut single = CvKalman::new(Ned::new(5.0, 0.0), &r(), 2.0).expect("kf");
        let (mut sq_imm, mut sq_single, mut n) = (0.0, 0.0, 0);
        let (mut settle_imm, mut settle_single) = (f64::INFINITY, f64::INFINITY);
        for k in 1..=600 {
            let t = k as f64 * DT_S;
            let (east, v) = if t < start_s {
                (0.0, 0.0)
            } else {
                (speed_mps * (t - start_s), speed_mps)
            };
            let noise_n: f64 = rng.sample(StandardNormal);
            let noise_e: f64 = rng.sample(StandardNormal);
            let z = Ned::new(5.0 + NOISE_M * noise_n, east + NOISE_M * noise_e);
            imm.predict(DT_S, &CONFIG).expect("predict");
            imm.update(z, &r()).expect("update");
            single.predict(DT_S, CONFIG.manoeuvre_psd_m2ps3).expect("predict");
            single.update(z, &r()).expect("update");
            let err = |kf: &CvKalman| {
                let (vn, ve) = kf.velocity_mps();
                vn.hypot(ve - v)
            };
            if t >= start_s {
                if settle_imm.is_infinite() && err(imm.combined()) <= within {
                    settle_imm = t - start_s;
                }
                if settle_single.is_infinite() && err(&single) <= within {
                    settle_single = t - start_s;
                }
            }
            if t >= from_s {
                sq_imm += err(imm.combined()).powi(2);
                sq_single += err(&single).powi(2);
                n += 1;
            }
        }
        let n = f64::from(n);
        ((sq_imm / n).sqrt(), (sq_single / n).sqrt(), settle_imm, settle_single)
    }

    #[test]
    fn a_steady_walk_is_estimated_better_than_by_the_manoeuvre_filter_alone() {
        for seed in 0..5 {
            let (imm, single, _, _) = walk(seed, 0.0, 1.4, 4.0, 0.3);
            // The single filter at q = 1.5 wanders ~0.1–0.2 m/s on this
            // noise; the IMM takes a fifth of that off at least.
            assert!(
                imm < 0.8 * single,
                "seed {seed}: IMM {imm:.3} vs single {single:.3} m/s RMS"
            );
        }
    }

    #[test]
    fn someone_stepping_out_is_seen_nearly_as_soon_as_by_the_manoeuvre_filter() {
        for seed in 0..5 {
            let (_, _, imm_s, single_s) = walk(seed, 6.0, 1.4, 6.0, 0.4);
            assert!(
                single_s < 1.0,
                "seed {seed}: single within 0.4 m/s after {single_s:.2} s"
            );
            assert!(
                imm_s <= single_s + 0.1,
                "seed {seed}: IMM within 0.4 m/s after {imm_s:.2} s, single after {single_s:.2} s"
            );
        }
    }

    #[test]
    fn the_manoeuvre_model_takes_the_weight_when_someone_starts() {
        let mut imm = ImmKalman::new(Ned::new(5.0, 0.0), &r(), 2.0, &CONFIG).expect("imm");
        let mut max_after_start: f64 = 0.0;
        for k in 1..=400 {
            let t = k as f64 * DT_S;
            let east = if t < 5.0 { 0.0 } else { 1.5 * (t - 5.0) };
            imm.predict(DT_S, &CONFIG).expect("predict");
            imm.update(Ned::new(5.0, east), &r()).expect("update");
            if (4.0..5.0).contains(&t) {
                assert!(
                    imm.manoeuvre_probability() < 0.5,
                    "standing at {t:.2}: {}",
                    imm.manoeuvre_probability()
                );
            }
            if t > 5.0 && t < 5.5 {
                max_after_start = max_after_start.max(imm.manoeuvre_probability());
            }
        }
        assert!(max_after_start > 0.9, "{max_after_start}");
    }

    #[test]
    fn refuses_bad_inputs_and_stays_unchanged() {
        let mut imm = ImmKalman::new(Ned::new(1.0, 2.0), &r(), 2.0, &CONFIG).expect("imm");
        imm.predict(0.1, &CONFIG).expect("predict");
        let before = imm;
        assert_eq!(imm.predict(-0.1, &CONFIG), Err(KalmanError::NegativeInterval));
        assert_eq!(imm.predict(f64::NAN, &CONFIG), Err(KalmanError::NonFinite));
        assert!(imm.update(Ned::new(f64::NAN, 0.0), &r()).is_err());
        let bad = ImmConfig {
            steady_mean_s: 0.0,
            ..CONFIG
        };
        assert!(imm.predict(0.1, &bad).is_err());
        assert_eq!(imm, before);
        assert!(ImmKalman::new(Ned::new(0.0, 0.0), &r(), 2.0, &bad).is_err());
    }

    #[test]
    fn the_switching_matrix_is_stochastic_and_exact_over_split_intervals() {
        let whole = transition(0.3, &CONFIG).expect("t");
        let half = transition(0.15, &CONFIG).expect("t");
        for (row_whole, row_half) in whole.iter().zip(&half) {
            assert!((row_whole[0] + row_whole[1] - 1.0).abs() < 1e-12);
            for (j, w) in row_whole.iter().enumerate() {
                let two_halves = row_half[0] * half[0][j] + row_half[1] * half[1][j];
                assert!((two_halves - w).abs() < 1e-12);
            }
        }
    }
}
