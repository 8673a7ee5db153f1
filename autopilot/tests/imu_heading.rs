//! The inertial unit's yaw rate in the estimate: its gyro bias is measured
//! at rest, the heading with it is at least as good at rest and in turns as
//! without it (figures from the simulator's truth), and a unit that falls
//! silent is reported (SYS_STATUS health, a failsafe text).

mod common;

use autopilot::geo::wrap_pi;
use autopilot::sitl::simulation::{ModelKind, SimulationConfig};
use common::Harness;
use mavlink::dialects::ardupilotmega::{MavMessage, MavSysStatusSensor};
use sim::ImuSimConfig;

/// RMS heading error (degrees, estimate against the truth) at rest before
/// arming, and while turning (true yaw rate above 0.05 rad/s) on a GUIDED
/// drive to a point beside the vehicle and back towards home.
#[derive(Clone, Copy, Debug)]
struct HeadingErrors {
    at_rest_deg: f64,
    turning_deg: f64,
    turning_samples: usize,
}

fn rms(sum_sq: f64, n: usize) -> f64 {
    (sum_sq / n.max(1) as f64).sqrt()
}

fn heading_errors(seed: u64, model: ModelKind, imu: bool, heading_noise_deg: f64) -> HeadingErrors {
    let mut h = Harness::with_config(SimulationConfig {
        seed,
        model,
        imu: imu.then(ImuSimConfig::default),
        ..SimulationConfig::default()
    });
    h.sim
        .core_mut()
        .params_mut()
        .set_by_name("SIM_HDG_NOISE", heading_noise_deg)
        .expect("SIM_HDG_NOISE");
    let error_deg = |h: &Harness| {
        let truth = h.sim.world().truth().yaw_rad;
        let estimate = h.sim.core().estimator().estimate().yaw_rad;
        wrap_pi(estimate - truth).to_degrees()
    };
    h.run_for(5.0);
    let (mut rest_sq, mut rest_n) = (0.0, 0);
    for _ in 0..(10 * 50) {
        h.step();
        rest_sq += error_deg(&h).powi(2);
        rest_n += 1;
    }
    h.set_mode(15);
    h.arm();
    let (mut turn_sq, mut turn_n) = (0.0, 0);
    for (north_m, east_m) in [(15.0, 15.0), (0.0, 30.0), (-10.0, 5.0)] {
        h.goto_local(north_m, east_m);
        for _ in 0..(40 * 50) {
            h.step();
            if h.sim.world().truth().yaw_rate_rad_s.abs() > 0.05 {
                turn_sq += error_deg(&h).powi(2);
                turn_n += 1;
            }
            if h.distance_to(north_m, east_m) < 0.3 && h.sim.world().truth().speed_mps.abs() < 0.01 {
                break;
            }
        }
    }
    HeadingErrors {
        at_rest_deg: rms(rest_sq, rest_n),
        turning_deg: rms(turn_sq, turn_n),
        turning_samples: turn_n,
    }
}

fn compare(model: ModelKind, heading_noise_deg: f64) -> (Vec<(HeadingErrors, HeadingErrors)>, f64, f64) {
    let runs: Vec<_> = (1..=3)
        .map(|seed| {
            (
                heading_errors(seed, model, false, heading_noise_deg),
                heading_errors(seed, model, true, heading_noise_deg),
            )
        })
        .collect();
    let mean = |f: &dyn Fn(&(HeadingErrors, HeadingErrors)) -> f64| runs.iter().map(f).sum::<f64>() / runs.len() as f64;
    let turn_ratio = mean(&|(without, with)| with.turning_deg / without.turning_deg);
    let rest_ratio = mean(&|(without, with)| with.at_rest_deg / without.at_rest_deg);
    for (without, with) in &runs {
        println!("{model:?} σ_hdg {heading_noise_deg}°: without IMU {without:?}, with {with:?}");
        assert!(
            without.turning_samples > 100 && with.turning_samples > 100,
            "{without:?} {with:?}"
        );
    }
    println!("{model:?} σ_hdg {heading_noise_deg}°: with/without, at rest {rest_ratio:.3}, turning {turn_ratio:.3}");
    (runs, rest_ratio, turn_ratio)
}

#[test]
fn the_gyro_keeps_the_heading_at_least_as_good_at_rest_and_in_turns() {
    for model in [ModelKind::Ackermann, ModelKind::Differential] {
        // The bench's 0.05° dual antenna, and a 0.5° compass-class sensor
        // where the gyro has more to add.
        let (_, rest, turn) = compare(model, 0.05);
        assert!(
            rest <= 1.05 && turn <= 1.05,
            "{model:?} 0.05°: at rest ×{rest:.3}, turning ×{turn:.3}"
        );
        let (_, rest, turn) = compare(model, 0.5);
        assert!(
            rest <= 1.05 && turn <= 1.0,
            "{model:?} 0.5°: at rest ×{rest:.3}, turning ×{turn:.3}"
        );
    }
}

#[test]
fn the_gyro_bias_is_measured_at_rest() {
    let mut h = Harness::new(4, ModelKind::Ackermann);
    h.run_for(8.0);
    let true_bias = h.sim.world().imu_gyro_bias_rad_s().expect("an IMU")[2];
    let bias = h.sim.core().estimator().imu().gyro_bias().expect("calibrated");
    println!("true {true_bias:.6} rad/s, measured {bias:?}");
    assert!(
        (bias.z_rad_s - true_bias).abs() < 3.0 * bias.sigma_rad_s + 1e-4,
        "{bias:?} vs {true_bias}"
    );
    assert!(
        h.texts().iter().any(|t| t.starts_with("IMU: gyro bias")),
        "{:?}",
        h.texts()
    );
}

fn last_sys_status(h: &Harness) -> Option<mavlink::dialects::ardupilotmega::SYS_STATUS_DATA> {
    h.received.iter().rev().find_map(|o| match &o.message {
        MavMessage::SYS_STATUS(s) => Some(s.clone()),
        _ => None,
    })
}

#[test]
fn a_silent_imu_is_unhealthy_and_reported() {
    let imu_bits =
        MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_ACCEL;
    let mut h = Harness::new(2, ModelKind::Ackermann);
    h.run_for(8.0);
    let status = last_sys_status(&h).expect("SYS_STATUS streamed");
    assert!(status.onboard_control_sensors_present.contains(imu_bits));
    assert!(status.onboard_control_sensors_health.contains(imu_bits));
    h.set_mode(15);
    h.arm();
    h.run_for(1.0);
    h.sim.world_mut().set_imu(None);
    h.run_for(2.0);
    let status = last_sys_status(&h).expect("SYS_STATUS streamed");
    assert!(
        status.onboard_control_sensors_present.contains(imu_bits),
        "still fitted"
    );
    assert!(
        !status.onboard_control_sensors_health.intersects(imu_bits),
        "{status:?}"
    );
    assert!(
        h.texts().iter().any(|t| t == "Failsafe: IMU lost: report only"),
        "{:?}",
        h.texts()
    );
    // Reported only: still armed, still GUIDED.
    assert!(h.sim.core().is_armed());
    // Back: healthy again, the failsafe clears.
    h.sim.world_mut().set_imu(Some(ImuSimConfig::default()));
    h.run_for(2.0);
    let status = last_sys_status(&h).expect("SYS_STATUS streamed");
    assert!(status.onboard_control_sensors_health.contains(imu_bits), "{status:?}");
    assert!(
        h.texts().iter().any(|t| t == "Failsafe cleared: IMU lost"),
        "{:?}",
        h.texts()
    );
}

#[test]
fn without_an_imu_there_are_no_gyro_or_accelerometer_bits() {
    let mut h = Harness::with_config(SimulationConfig {
        imu: None,
        ..SimulationConfig::default()
    });
    h.run_for(5.0);
    let status = last_sys_status(&h).expect("SYS_STATUS streamed");
    let imu_bits =
        MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_ACCEL;
    assert!(
        !status.onboard_control_sensors_present.intersects(imu_bits),
        "{status:?}"
    );
    assert!(h.sim.core().estimator().imu().last().is_none());
}
