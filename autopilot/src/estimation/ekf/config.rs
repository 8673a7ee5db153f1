//! The filter's tuning and geometry, its validation, and the χ² gates.

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
    /// is unobservable) does not leave an absurd uncertainty behind. Zero for
    /// a vehicle whose yaw rate is not set by a curvature (differential
    /// drive): the curvature then stays 0 and the pivot rate is the yaw rate.
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
        non_negative(self.max_curvature_per_m, "max_curvature_per_m")?;
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
