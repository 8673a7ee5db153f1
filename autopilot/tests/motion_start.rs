//! The estimator at the start of motion: a vehicle that stood still for a
//! long time and then drives away at full steering lock moves a few
//! centimetres before the GNSS speed shows it; that disagreement is motion,
//! not a GPS jump, and must not be rejected (nor trip the EKF failsafe).

mod common;

use autopilot::sitl::simulation::ModelKind;
use common::Harness;
use mavlink::dialects::ardupilotmega::{MavMessage, RC_CHANNELS_OVERRIDE_DATA};

fn rc(steer: u16, throttle: u16) -> MavMessage {
    MavMessage::RC_CHANNELS_OVERRIDE(RC_CHANNELS_OVERRIDE_DATA {
        chan1_raw: steer,
        chan3_raw: throttle,
        target_system: 1,
        target_component: 1,
        ..RC_CHANNELS_OVERRIDE_DATA::DEFAULT
    })
}

/// Rests `rest_s` armed in MANUAL at neutral, then drives away for 6 s at
/// full lock (`steer` 1100 or 1900) and `throttle`; returns the estimator's
/// complaints over the whole run: its texts and the filter's rejection counters.
fn drive_away(seed: u64, model: ModelKind, rest_s: f64, steer: u16, throttle: u16) -> Vec<String> {
    let mut h = Harness::new(seed, model);
    h.run_for(2.0);
    h.set_mode(0);
    h.arm();
    h.run_for(rest_s);
    let end = h.sim.time() + std::time::Duration::from_secs(6);
    while h.sim.time() < end {
        h.send(rc(steer, throttle));
        h.step();
    }
    let mut complaints: Vec<String> = h
        .texts()
        .into_iter()
        .filter(|t| t.contains("GPS jump") || t.contains("unhealthy") || t.contains("reset") || t.contains("rejected"))
        .collect();
    let status = h.sim.core().estimator().ekf_status().expect("the filter runs");
    for (name, record) in [
        ("position", status.gnss_position),
        ("velocity", status.gnss_velocity),
        ("heading", status.heading),
    ] {
        if record.rejected > 0 || record.resets > 0 {
            complaints.push(format!(
                "{name}: {} rejected, {} resets",
                record.rejected, record.resets
            ));
        }
    }
    complaints
}

#[test]
fn drive_away_at_full_lock_after_a_long_rest_is_never_a_jump() {
    let mut failures = Vec::new();
    for seed in 0..100u64 {
        let model = if seed % 2 == 0 {
            ModelKind::Ackermann
        } else {
            ModelKind::Differential
        };
        let steer = if seed % 4 < 2 { 1100 } else { 1900 };
        let throttle = [1600, 1800, 2000][(seed % 3) as usize];
        let complaints = drive_away(seed, model, 30.0, steer, throttle);
        if !complaints.is_empty() {
            failures.push(format!(
                "seed {seed} {model:?} steer {steer} throttle {throttle}: {complaints:?}"
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of 100 runs rejected:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
