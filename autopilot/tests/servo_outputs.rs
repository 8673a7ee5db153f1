//! `SERVOn_*` and `RELAYn_PIN` through the core: the pulses `Outputs`
//! carries to the PWM driver, with the simulated vehicle driven in MANUAL and
//! AUTO.

mod common;

use autopilot::control::ackermann::AckermannGeometry;
use autopilot::control::mixer::{self, WheelOutputs};
use autopilot::modes::Mode;
use autopilot::sitl::simulation::ModelKind;
use autopilot::time::FrozenTimer;
use common::{Harness, item};
use mavlink::dialects::ardupilotmega::{MANUAL_CONTROL_DATA, MavCmd, MavMessage};
use mission::command::{cmd, frame};
use mission::{ExecState, MissionItem, MissionType, Plan};
use vehicle_types::ActuatorDemand;

const MANUAL: u32 = 0;
const AUTO: u32 = 10;

/// One tick; returns the servo pulses it put out.
fn step(h: &mut Harness) -> [u16; 16] {
    let wall = h.sim.time();
    let out = h.sim.step(wall, &mut FrozenTimer);
    let pwm = out.servo_pwm_us;
    h.received.append(&mut out.mavlink);
    pwm
}

fn steps(h: &mut Harness, n: usize) -> [u16; 16] {
    let mut pwm = step(h);
    for _ in 1..n {
        pwm = step(h);
    }
    pwm
}

fn set(h: &mut Harness, name: &str, value: f64) {
    h.sim
        .core_mut()
        .params_mut()
        .set_by_name(name, value)
        .unwrap_or_else(|e| panic!("{name} = {value}: {e}"));
}

/// Armed in MANUAL with the sticks at `steering_permille`/`throttle_permille`.
fn drive_manual(h: &mut Harness, steering_permille: i16, throttle_permille: i16) -> [u16; 16] {
    h.send(MavMessage::MANUAL_CONTROL(MANUAL_CONTROL_DATA {
        y: steering_permille,
        z: throttle_permille,
        target: 1,
        ..MANUAL_CONTROL_DATA::DEFAULT
    }));
    steps(h, 3)
}

fn armed_in_manual(model: ModelKind) -> Harness {
    let mut h = Harness::new(11, model);
    h.run_for(2.0);
    h.set_mode(MANUAL);
    h.arm();
    step(&mut h);
    assert!(h.sim.core().is_armed(), "{:?}", h.texts());
    assert_eq!(h.sim.core().mode(), Mode::Manual);
    h
}

fn disarm(h: &mut Harness) {
    h.command(
        MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
        [0.0, 21196.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    );
    step(h);
    assert!(!h.sim.core().is_armed(), "{:?}", h.texts());
}

/// The old fixed layout squeezed onto ArduPilot's 1100–1900 µs default
/// range: same channels, same sign, 0.8 of the travel about 1500.
fn on_ardupilot_range(old: [u16; 16]) -> [u16; 16] {
    old.map(|p| {
        if p == 0 {
            0
        } else {
            (1500.0 + (f64::from(p) - 1500.0) * 0.8).round() as u16
        }
    })
}

#[test]
fn defaults_keep_the_old_channel_layout_on_ardupilots_range() {
    let mut h = armed_in_manual(ModelKind::Ackermann);
    let pwm = drive_manual(&mut h, -600, 400);
    let ActuatorDemand::Ackermann { steering, throttle } = h.sim.last_demand() else {
        panic!("Ackermann demand expected");
    };
    assert!((steering + 0.6).abs() < 1e-9 && (throttle - 0.4).abs() < 1e-9);
    let t = h.sim.core().params();
    let value = |name: &str| t.value_of(name).expect(name);
    let geometry = AckermannGeometry::new(value("VEH_WHEELBASE"), value("VEH_TRACK"));
    let wheels = WheelOutputs::from_demand(&geometry, value("VEH_STEER_MAX").to_radians(), steering, throttle);
    let old = mixer::servo_pwm(&h.sim.last_demand(), Some(&wheels));
    assert_eq!(pwm, on_ardupilot_range(old), "old layout {old:?}");
    // Steering left below trim, throttle forward above it, the wheels
    // turned: channels 1, 3 and 5–8 really moved.
    assert!(
        pwm[0] < 1500 && pwm[2] > 1500 && pwm[4] < 1500 && pwm[6] > 1500,
        "{pwm:?}"
    );

    let mut h = armed_in_manual(ModelKind::Differential);
    let pwm = drive_manual(&mut h, 300, 500);
    let ActuatorDemand::Differential { left, right } = h.sim.last_demand() else {
        panic!("Differential demand expected");
    };
    assert!(left > right, "turning right: {left} {right}");
    let old = mixer::servo_pwm(&h.sim.last_demand(), None);
    assert_eq!(pwm, on_ardupilot_range(old), "old layout {old:?}");
    assert!(pwm[0] > pwm[2], "left track faster: {pwm:?}");
    assert_eq!(&pwm[4..8], &[0, 0, 0, 0], "no wheel outputs on skid steering");
}

#[test]
fn reversing_servo1_and_moving_servo3_trim_change_the_pulses() {
    let mut h = armed_in_manual(ModelKind::Ackermann);
    let before = drive_manual(&mut h, 500, 500);
    set(&mut h, "SERVO1_REVERSED", 1.0);
    set(&mut h, "SERVO3_TRIM", 1420.0);
    let after = drive_manual(&mut h, 500, 500);
    // Steering mirrored about its trim.
    assert_ne!(after[0], before[0]);
    assert_eq!(
        i32::from(after[0]) - 1500,
        1500 - i32::from(before[0]),
        "{before:?} {after:?}"
    );
    // Throttle: the same fraction of the (now longer) way from trim to MAX.
    let fraction_before = (f64::from(before[2]) - 1500.0) / (1900.0 - 1500.0);
    let fraction_after = (f64::from(after[2]) - 1420.0) / (1900.0 - 1420.0);
    assert!(
        (fraction_before - fraction_after).abs() < 0.003,
        "{fraction_before} {fraction_after}"
    );
    assert_ne!(after[2], before[2]);
    // Other channels untouched.
    assert_eq!(&after[3..], &before[3..]);
    // Reverse throttle goes below the new trim towards MIN.
    let reverse = drive_manual(&mut h, 0, -1000);
    assert_eq!((reverse[0], reverse[2]), (1500, 1100));
}

#[test]
fn disarmed_channels_sit_at_their_trims() {
    let mut h = armed_in_manual(ModelKind::Ackermann);
    for (name, trim) in [
        ("SERVO1_TRIM", 1530.0),
        ("SERVO3_TRIM", 1440.0),
        ("SERVO5_TRIM", 1510.0),
        ("SERVO6_TRIM", 1480.0),
        ("SERVO7_TRIM", 1460.0),
        ("SERVO8_TRIM", 1550.0),
    ] {
        set(&mut h, name, trim);
    }
    // A reversed channel still rests at its trim.
    set(&mut h, "SERVO7_REVERSED", 1.0);
    let driving = drive_manual(&mut h, 800, 700);
    assert!(driving[0] > 1530 && driving[2] > 1440, "{driving:?}");
    disarm(&mut h);
    let pwm = steps(&mut h, 2);
    assert_eq!(pwm, [1530, 0, 1440, 0, 1510, 1480, 1460, 1550, 0, 0, 0, 0, 0, 0, 0, 0]);
    // Sticks are ignored while disarmed.
    let pwm = drive_manual(&mut h, -900, 900);
    assert_eq!((pwm[0], pwm[2]), (1530, 1440));
}

fn wp(seq: u16, north_m: f64) -> MissionItem {
    item(seq, cmd::NAV_WAYPOINT, frame::LOCAL_NED, [0.0; 4], north_m, 0.0)
}

fn do_item(seq: u16, command: u16, params: [f32; 4]) -> MissionItem {
    item(seq, command, frame::MISSION, params, 0.0, 0.0)
}

#[test]
fn do_set_servo_sets_a_free_channel_and_is_refused_on_steering() {
    let mut h = Harness::new(12, ModelKind::Ackermann);
    // Servo 10 as a relay pin for relay 1 (DO_SET_RELAY 0).
    set(&mut h, "SERVO10_FUNCTION", -1.0);
    set(&mut h, "RELAY1_PIN", 10.0);
    let plan = Plan::new(
        MissionType::Mission,
        vec![
            wp(0, 0.0),
            wp(1, 8.0),
            do_item(2, cmd::DO_SET_SERVO, [9.0, 1234.0, 0.0, 0.0]),
            do_item(3, cmd::DO_SET_SERVO, [1.0, 2000.0, 0.0, 0.0]),
            do_item(4, cmd::DO_SET_RELAY, [0.0, 1.0, 0.0, 0.0]),
            wp(5, 16.0),
        ],
    );
    h.sim.core_mut().load_plan(MissionType::Mission, plan);
    h.run_for(2.0);
    let idle = step(&mut h);
    assert_eq!((idle[8], idle[9]), (0, 1100), "servo 9 not driven, relay 1 off");
    h.arm();
    h.set_mode(AUTO);
    step(&mut h);
    assert_eq!(h.sim.core().mode(), Mode::Auto, "{:?}", h.texts());

    let mut pwm = [0u16; 16];
    let mut steering_range = (u16::MAX, 0u16);
    let mut ticks = 0;
    while h.sim.core().mission_state() != ExecState::Complete && ticks < 60 * 50 {
        pwm = step(&mut h);
        steering_range = (steering_range.0.min(pwm[0]), steering_range.1.max(pwm[0]));
        ticks += 1;
    }
    assert_eq!(h.sim.core().mission_state(), ExecState::Complete, "{:?}", h.texts());
    assert_eq!(pwm[8], 1234, "DO_SET_SERVO on the free servo 9");
    assert_eq!(pwm[9], 1900, "relay 1 on: servo 10 at its MAX");
    assert!(
        steering_range.0 >= 1100 && steering_range.1 <= 1900,
        "steering never left its range for the refused 2000 µs: {steering_range:?}"
    );
    let texts = h.texts();
    assert_eq!(
        texts
            .iter()
            .filter(|t| t.as_str() == "DO_SET_SERVO refused: servo 1 is GroundSteering")
            .count(),
        1,
        "{texts:?}"
    );
    assert!(!texts.iter().any(|t| t.contains("servo 9")), "{texts:?}");
    // Disarmed: the drive channels go to trim, the mission's servo and
    // relay keep their values.
    disarm(&mut h);
    let pwm = steps(&mut h, 2);
    assert_eq!((pwm[0], pwm[2], pwm[8], pwm[9]), (1500, 1500, 1234, 1900));
}

#[test]
fn gcs_set_servo_and_relay_commands_obey_the_channel_functions() {
    use mavlink::dialects::ardupilotmega::MavResult;
    let mut h = armed_in_manual(ModelKind::Ackermann);
    // Servo 9 is free: the GCS may set it.
    h.command(MavCmd::MAV_CMD_DO_SET_SERVO, [9.0, 1700.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let pwm = steps(&mut h, 2);
    assert_eq!(
        h.acks(MavCmd::MAV_CMD_DO_SET_SERVO),
        vec![MavResult::MAV_RESULT_ACCEPTED]
    );
    assert_eq!(pwm[8], 1700);
    // Servo 1 steers: denied, and its pulse is the steering's.
    h.command(MavCmd::MAV_CMD_DO_SET_SERVO, [1.0, 2000.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let pwm = steps(&mut h, 2);
    assert_eq!(
        h.acks(MavCmd::MAV_CMD_DO_SET_SERVO),
        vec![MavResult::MAV_RESULT_ACCEPTED, MavResult::MAV_RESULT_DENIED]
    );
    assert_ne!(pwm[0], 2000);
    // A relay with no output: denied; once RELAY1_PIN names a GPIO servo, on
    // and off move it between that servo's MAX and MIN.
    h.command(MavCmd::MAV_CMD_DO_SET_RELAY, [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    steps(&mut h, 2);
    assert_eq!(h.acks(MavCmd::MAV_CMD_DO_SET_RELAY), vec![MavResult::MAV_RESULT_DENIED]);
    set(&mut h, "SERVO10_FUNCTION", -1.0);
    set(&mut h, "RELAY1_PIN", 10.0);
    h.command(MavCmd::MAV_CMD_DO_SET_RELAY, [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let on = steps(&mut h, 2);
    h.command(MavCmd::MAV_CMD_DO_SET_RELAY, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let off = steps(&mut h, 2);
    assert_eq!(
        h.acks(MavCmd::MAV_CMD_DO_SET_RELAY)[1..],
        [MavResult::MAV_RESULT_ACCEPTED, MavResult::MAV_RESULT_ACCEPTED]
    );
    assert_eq!((on[9], off[9]), (1900, 1100));
}
