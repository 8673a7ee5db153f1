//! Unit tests of the model's derivatives, initialisation and resets.

use super::model::NONLINEAR;
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
