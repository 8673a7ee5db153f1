//! MAGNETIC mode in simulated time: the core follows a tape laid in the
//! SITL world with its two guide sensors, needs no GNSS, and refuses to
//! start without sensors.

mod common;

use autopilot::modes::Mode;
use autopilot::sitl::simulation::ModelKind;
use common::Harness;
use mavlink::dialects::ardupilotmega::{MavCmd, MavMessage, MavResult};
use sim::TapeBuilder;

const MAGNETIC: u32 = 20;

#[test]
fn follows_a_tape_round_a_curve_without_gnss() {
    let mut h = Harness::new(3, ModelKind::Ackermann);
    // Straight north from under the vehicle, then a 15 m right arc.
    let tape = TapeBuilder::new(-1.0, 0.0, 0.0)
        .line(20.0)
        .arc(15.0, std::f64::consts::FRAC_PI_2)
        .line(20.0)
        .build(0.03);
    h.sim.world_mut().set_tape(Some(tape.clone()));
    // No GNSS at all: the tape is the reference.
    h.sim
        .core_mut()
        .params_mut()
        .set_by_name("SIM_GPS_DISABLE", 1.0)
        .expect("SIM_GPS_DISABLE");
    h.run_for(1.0);
    h.set_mode(MAGNETIC);
    h.arm();
    h.step();
    assert_eq!(h.sim.core().mode(), Mode::Magnetic, "{:?}", h.texts());
    let mut worst_after_start = 0.0f64;
    let mut t = 0.0;
    while t < 40.0 {
        h.run_for(0.1);
        t += 0.1;
        let truth = *h.sim.world().truth();
        let fix = tape.locate(truth.north_m, truth.east_m).expect("near the tape");
        if t > 3.0 && fix.along_m < tape.length_m() - 3.0 {
            worst_after_start = worst_after_start.max(fix.distance_m);
        }
    }
    let truth = *h.sim.world().truth();
    let fix = tape.locate(truth.north_m, truth.east_m).unwrap();
    assert!(fix.along_m > 40.0, "drove {:.1} m along the tape", fix.along_m);
    assert!(
        worst_after_start < 0.10,
        "strayed {worst_after_start:.3} m from the tape"
    );
    // The wheel kinematics go out on servos 5–8 while it steers.
    let servo = h
        .received
        .iter()
        .rev()
        .find_map(|o| match &o.message {
            MavMessage::SERVO_OUTPUT_RAW(s) => Some(s.clone()),
            _ => None,
        })
        .expect("SERVO_OUTPUT_RAW streamed");
    for pwm in [servo.servo5_raw, servo.servo6_raw, servo.servo7_raw, servo.servo8_raw] {
        assert!((1000..=2000).contains(&pwm), "{servo:?}");
    }
    assert!(servo.servo7_raw > 1500, "rear wheels driving forward: {servo:?}");
}

#[test]
fn refused_without_sensors_and_stops_when_they_go_silent() {
    let mut h = Harness::new(4, ModelKind::Ackermann);
    h.run_for(2.0);
    h.set_mode(MAGNETIC);
    h.step();
    assert_ne!(h.sim.core().mode(), Mode::Magnetic);
    assert_eq!(
        h.acks(MavCmd::MAV_CMD_DO_SET_MODE).last(),
        Some(&MavResult::MAV_RESULT_FAILED)
    );
    assert!(
        h.texts().iter().any(|t| t.contains("no tape sensors")),
        "{:?}",
        h.texts()
    );

    let tape = TapeBuilder::new(-1.0, 0.0, 0.0).line(50.0).build(0.03);
    h.sim.world_mut().set_tape(Some(tape));
    h.step();
    h.set_mode(MAGNETIC);
    h.arm();
    h.run_for(3.0);
    assert_eq!(h.sim.core().mode(), Mode::Magnetic);
    assert!(h.sim.world().truth().speed_mps > 0.3);
    h.sim.world_mut().set_tape(None);
    h.run_for(3.0);
    assert!(h.texts().iter().any(|t| t.contains("Magnetic sensors silent")));
    assert!(h.sim.world().truth().speed_mps.abs() < 0.05, "stopped");
}
