//! Arming checks and failsafes through the whole vehicle, in simulated
//! time, with faults injected by their `SIM_*` parameters.

mod common;

use autopilot::modes::Mode;
use autopilot::sitl::gcs::heartbeat as gcs_heartbeat;
use autopilot::sitl::simulation::ModelKind;
use autopilot::vehicle::Failsafe;
use common::Harness;
use mavlink::dialects::ardupilotmega::{MavCmd, MavMessage, MavResult, MavState, MavSysStatusSensor};

const FORCE_ARM_MAGIC: f32 = 21196.0;

fn set(h: &mut Harness, name: &str, value: f64) {
    h.sim.core_mut().params_mut().set_by_name(name, value).expect(name);
}

fn new_texts(h: &Harness, from: usize) -> Vec<String> {
    h.texts()[from..].to_vec()
}

fn last_sys_status(h: &Harness) -> mavlink::dialects::ardupilotmega::SYS_STATUS_DATA {
    h.received
        .iter()
        .rev()
        .find_map(|o| match &o.message {
            MavMessage::SYS_STATUS(s) => Some(s.clone()),
            _ => None,
        })
        .expect("SYS_STATUS is streamed")
}

/// AUTO, armed, driving a mission to a point 200 m north.
fn mission_driving(seed: u64) -> Harness {
    use mission::command::{cmd, frame};
    use mission::{MissionItem, MissionType, Plan};
    let item = |seq: u16, north_m: f64| MissionItem {
        seq,
        frame: frame::LOCAL_NED,
        command: cmd::NAV_WAYPOINT,
        current: false,
        autocontinue: true,
        params: [0.0; 4],
        x: (north_m * 1e4).round() as i32,
        y: 0,
        z: 0.0,
    };
    let mut h = Harness::new(seed, ModelKind::Ackermann);
    let plan = Plan::new(MissionType::Mission, vec![item(0, 0.0), item(1, 200.0)]);
    h.sim.core_mut().load_plan(MissionType::Mission, plan);
    h.run_for(3.0);
    h.set_mode(10);
    h.arm();
    h.step();
    assert!(h.sim.core().is_armed(), "{:?}", h.texts());
    h.run_for(10.0);
    assert!(h.sim.world().truth().speed_mps > 1.0);
    h
}

/// GUIDED, armed, driving to a point 200 m north.
fn driving(seed: u64) -> Harness {
    let mut h = Harness::new(seed, ModelKind::Ackermann);
    h.run_for(3.0);
    h.set_mode(15);
    h.arm();
    h.step();
    assert!(h.sim.core().is_armed(), "{:?}", h.texts());
    h.goto_local(200.0, 0.0);
    h.run_for(10.0);
    assert!(h.sim.world().truth().speed_mps > 1.0);
    h
}

#[test]
fn each_failing_check_is_said_and_only_the_selected_checks_apply() {
    let mut h = Harness::new(11, ModelKind::Ackermann);
    set(&mut h, "SIM_GPS_QUALITY", 5.0);
    set(&mut h, "SIM_SCAN_DISABLE", 1.0);
    set(&mut h, "BATT_LOW_VOLT", 40.0);
    set(&mut h, "BATT_CRT_VOLT", 45.0);
    h.run_for(4.0);
    h.set_mode(15);
    let from = h.texts().len();
    h.arm();
    h.step();
    assert!(!h.sim.core().is_armed());
    let texts = new_texts(&h, from);
    for expected in [
        "PreArm: GPS fix RTK float, need RTK fixed",
        "PreArm: Scanner 1 not sending",
        "PreArm: BATT_CRT_VOLT not below BATT_LOW_VOLT",
    ] {
        assert!(texts.iter().any(|t| t == expected), "{expected:?} in {texts:?}");
    }
    assert_eq!(
        h.acks(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM).last(),
        Some(&MavResult::MAV_RESULT_FAILED)
    );
    h.run_for(2.0);
    let status = last_sys_status(&h);
    assert!(
        status
            .onboard_control_sensors_present
            .contains(MavSysStatusSensor::MAV_SYS_STATUS_PREARM_CHECK)
    );
    assert!(
        !status
            .onboard_control_sensors_health
            .contains(MavSysStatusSensor::MAV_SYS_STATUS_PREARM_CHECK)
    );
    assert!(
        !status
            .onboard_control_sensors_health
            .contains(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_PROXIMITY)
    );

    // ARMING_CHECK 8 (position fix only): the scanner and the parameters
    // are no longer looked at, the fix still is.
    set(&mut h, "ARMING_CHECK", 8.0);
    let from = h.texts().len();
    h.arm();
    h.step();
    let texts = new_texts(&h, from);
    assert!(!h.sim.core().is_armed());
    assert_eq!(
        texts.iter().filter(|t| t.starts_with("PreArm:")).collect::<Vec<_>>(),
        ["PreArm: GPS fix RTK float, need RTK fixed"]
    );
    // ARMING_RTK_REQ 1: float is enough.
    set(&mut h, "ARMING_RTK_REQ", 1.0);
    h.arm();
    h.step();
    assert!(h.sim.core().is_armed(), "{:?}", h.texts());
}

#[test]
fn force_arming_with_the_magic_value_arms_and_warns_with_what_it_skipped() {
    let mut h = Harness::new(12, ModelKind::Ackermann);
    set(&mut h, "SIM_SCAN_DISABLE", 1.0);
    h.run_for(4.0);
    h.set_mode(15);
    let from = h.texts().len();
    h.command(
        MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
        [1.0, FORCE_ARM_MAGIC, 0.0, 0.0, 0.0, 0.0, 0.0],
    );
    h.step();
    assert!(h.sim.core().is_armed());
    let texts = new_texts(&h, from);
    assert!(texts.iter().any(|t| t == "Arming checks skipped (forced)"), "{texts:?}");
    assert!(texts.iter().any(|t| t == "Skipped: Scanner 1 not sending"), "{texts:?}");
    // A wrong magic value is an ordinary arm request: refused.
    let mut h = Harness::new(12, ModelKind::Ackermann);
    set(&mut h, "SIM_SCAN_DISABLE", 1.0);
    h.run_for(4.0);
    h.command(
        MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
        [1.0, 21195.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    );
    h.step();
    assert!(!h.sim.core().is_armed());
}

#[test]
fn auto_cannot_be_entered_once_the_mission_is_cleared() {
    let mut h = Harness::new(13, ModelKind::Ackermann);
    h.run_for(4.0);
    h.send(MavMessage::MISSION_COUNT(
        mavlink::dialects::ardupilotmega::MISSION_COUNT_DATA {
            count: 0,
            target_system: 1,
            target_component: 1,
            mission_type: mavlink::dialects::ardupilotmega::MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id: 0,
        },
    ));
    h.step();
    h.set_mode(10);
    h.step();
    assert_ne!(h.sim.core().mode(), Mode::Auto, "AUTO needs a mission to enter");
}

/// While SIM_LINK_DROP cuts the link, no mission download may be answered
/// at the link either: the core withdraws what it published for that.
#[test]
fn a_link_drop_withdraws_the_plans_the_link_answers_downloads_from() {
    let mut h = Harness::new(5, ModelKind::Ackermann);
    h.run_for(1.0);
    assert!(h.published_downloads.is_some());
    set(&mut h, "SIM_LINK_DROP", 2.0);
    h.run_for(1.0);
    assert!(h.published_downloads.is_none(), "while the link is down");
    h.run_for(1.5);
    assert!(h.published_downloads.is_some(), "once it is back");
}

#[test]
fn gcs_heartbeat_loss_holds_and_never_resumes_by_itself() {
    let mut h = driving(21);
    set(&mut h, "FS_GCS_ENABLE", 1.0);
    set(&mut h, "FS_RESUME", 1.0);
    for _ in 0..3 {
        h.send(gcs_heartbeat());
        h.run_for(1.0);
    }
    let from = h.texts().len();
    let silent_at = h.sim.time().as_secs_f64() - 1.0;
    assert!(h.run_until(10.0, |s| s.core().mode() == Mode::Hold));
    let after = h.sim.time().as_secs_f64() - silent_at;
    assert!((5.0..=5.3).contains(&after), "FS_GCS_TIMEOUT 5 s: {after:.2}");
    assert!(
        new_texts(&h, from)
            .iter()
            .any(|t| t == "Failsafe: GCS heartbeat lost: HOLD")
    );
    assert!(h.sim.core().failsafe_is_active(Failsafe::Gcs));
    // The ground station comes back: the failsafe clears, the vehicle stays.
    for _ in 0..5 {
        h.send(gcs_heartbeat());
        h.run_for(1.0);
    }
    assert!(!h.sim.core().failsafe_is_active(Failsafe::Gcs));
    assert!(h.texts().iter().any(|t| t == "Failsafe cleared: GCS heartbeat lost"));
    assert_eq!(h.sim.core().mode(), Mode::Hold);
    assert!(h.sim.world().truth().speed_mps.abs() < 0.05);
}

#[test]
fn a_scanner_stall_stops_and_fs_resume_decides_whether_it_drives_on() {
    for resume in [false, true] {
        let mut h = mission_driving(31);
        set(&mut h, "FS_RESUME", if resume { 1.0 } else { 0.0 });
        set(&mut h, "SIM_SCAN_DISABLE", 1.0);
        assert!(h.run_until(2.0, |s| s.core().mode() == Mode::Hold), "{:?}", h.texts());
        assert!(h.texts().iter().any(|t| t == "Failsafe: scanner stale: HOLD"));
        h.run_for(5.0);
        assert!(h.sim.world().truth().speed_mps.abs() < 0.05);
        set(&mut h, "SIM_SCAN_DISABLE", 0.0);
        h.run_for(3.0);
        assert!(
            h.texts().iter().any(|t| t == "Failsafe cleared: scanner stale"),
            "{:?}",
            h.texts()
        );
        if resume {
            assert_eq!(h.sim.core().mode(), Mode::Auto, "{:?}", h.texts());
            assert!(
                h.texts()
                    .iter()
                    .any(|t| t == "Failsafe over: resuming AUTO (FS_RESUME)")
            );
            h.run_for(5.0);
            assert!(h.sim.world().truth().speed_mps > 1.0);
        } else {
            assert_eq!(h.sim.core().mode(), Mode::Hold);
            assert!(h.sim.world().truth().speed_mps.abs() < 0.05);
        }
    }
}

#[test]
fn a_core_stall_holds_and_the_heartbeat_says_critical() {
    let mut h = driving(41);
    let from = h.texts().len();
    set(&mut h, "SIM_CPU_STALL", 300.0);
    assert!(h.run_until(1.0, |s| s.core().mode() == Mode::Hold));
    assert!(
        new_texts(&h, from)
            .iter()
            .any(|t| t == "Failsafe: core stalled 300 ms: HOLD"),
        "{:?}",
        new_texts(&h, from)
    );
    assert_eq!(h.sim.core().params().value_of("SIM_CPU_STALL"), Some(0.0), "one-shot");
    h.run_for(1.5);
    let critical = h.received.iter().rev().find_map(|o| match &o.message {
        MavMessage::HEARTBEAT(hb) => Some(hb.system_status),
        _ => None,
    });
    assert_eq!(critical, Some(MavState::MAV_STATE_CRITICAL));
    // A 100 ms stall is within FS_LOOP_MS (200): nothing happens.
    let mut h = driving(42);
    set(&mut h, "SIM_CPU_STALL", 100.0);
    h.run_for(2.0);
    assert_eq!(h.sim.core().mode(), Mode::Guided, "{:?}", h.texts());
}

#[test]
fn a_frozen_heading_is_caught_while_driving_but_a_noisy_one_never_is() {
    // 60 s of driving with a live sensor: no false alarm.
    let mut h = driving(51);
    h.run_for(60.0);
    assert!(!h.texts().iter().any(|t| t.starts_with("Failsafe")), "{:?}", h.texts());
    set(&mut h, "SIM_HDG_FREEZE", 1.0);
    assert!(h.run_until(2.0, |s| s.core().mode() == Mode::Hold));
    assert!(h.texts().iter().any(|t| t == "Failsafe: heading lost: HOLD"));
}

#[test]
fn battery_low_then_critical_take_their_own_actions() {
    let mut h = driving(61);
    set(&mut h, "BATT_LOW_VOLT", 46.0);
    set(&mut h, "BATT_CRT_VOLT", 44.0);
    set(&mut h, "BATT_LOW_TIMER", 2.0);
    set(&mut h, "BATT_FS_LOW_ACT", 0.0);
    set(&mut h, "BATT_FS_CRT_ACT", 5.0);
    set(&mut h, "SIM_BATT_VOLT", 45.0);
    h.run_for(1.5);
    assert!(!h.sim.core().failsafe_is_active(Failsafe::BatteryLow), "BATT_LOW_TIMER");
    h.run_for(1.0);
    assert!(h.sim.core().failsafe_is_active(Failsafe::BatteryLow));
    assert!(h.texts().iter().any(|t| t == "Failsafe: battery low: report only"));
    assert_eq!(h.sim.core().mode(), Mode::Guided);
    h.run_for(1.0);
    let status = last_sys_status(&h);
    assert!(
        !status
            .onboard_control_sensors_health
            .contains(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_BATTERY)
    );
    set(&mut h, "SIM_BATT_VOLT", 43.0);
    assert!(h.run_until(3.0, |s| !s.core().is_armed()));
    assert!(h.texts().iter().any(|t| t == "Failsafe: battery critical: disarm"));
}

#[test]
fn a_stuck_steering_leaves_the_path_and_fs_xtrack_m_holds_it() {
    let mut h = driving(71);
    set(&mut h, "FS_XTRACK_M", 2.0);
    // Stuck while turning towards a target to the east.
    h.goto_local(h.sim.world().truth().north_m + 40.0, 40.0);
    h.run_for(1.0);
    set(&mut h, "SIM_ACT_STUCK", 1.0);
    assert!(h.run_until(60.0, |s| s.core().mode() == Mode::Hold), "{:?}", h.texts());
    assert!(h.texts().iter().any(|t| t == "Failsafe: off the path: HOLD"));
    h.run_for(5.0);
    assert!(h.sim.world().truth().speed_mps.abs() < 0.05);
}

#[test]
fn a_stuck_throttle_that_does_not_stop_in_hold_is_disarmed() {
    let mut h = driving(72);
    set(&mut h, "SIM_ACT_STUCK", 2.0);
    h.step();
    h.set_mode(4);
    h.run_for(2.5);
    assert!(h.sim.core().is_armed(), "3 s grace to stop");
    assert!(h.sim.world().truth().speed_mps > 0.5, "the throttle is stuck");
    assert!(h.run_until(1.0, |s| !s.core().is_armed()));
    assert!(h.texts().iter().any(|t| t == "Failsafe: vehicle does not stop: disarm"));
    h.run_for(10.0);
    assert!(
        h.sim.world().truth().speed_mps.abs() < 0.05,
        "power cut: it coasts to rest"
    );
}

#[test]
fn without_obstacle_stopping_a_silent_scanner_is_no_failsafe() {
    let mut h = Harness::new(81, ModelKind::Ackermann);
    set(&mut h, "OA_ENABLE", 0.0);
    set(&mut h, "SIM_SCAN_DISABLE", 3.0);
    h.run_for(4.0);
    h.set_mode(15);
    h.arm();
    h.step();
    assert!(h.sim.core().is_armed(), "{:?}", h.texts());
    h.goto_local(50.0, 0.0);
    h.run_for(5.0);
    assert!(!h.texts().iter().any(|t| t.starts_with("Failsafe")), "{:?}", h.texts());
    assert!(h.sim.world().truth().speed_mps > 1.0);
}

// A failsafe lasts as long as its cause, not as long as the mode that
// needed the sensor: each kind below is held on through the HOLD it
// chose, an operator's mode change and a disarm, refuses what it forbids
// with its name, and clears once when the cause is gone.

const HEARTBEAT_ID: u32 = 0;
const SYS_STATUS_ID: u32 = 1;
const EKF_STATUS_REPORT_ID: u32 = 193;
const CUSTOM_MODE_ENABLED: f32 = 1.0;

fn cleared_text(kind: Failsafe) -> String {
    format!("Failsafe cleared: {}", kind.name())
}

fn count(h: &Harness, text: &str) -> usize {
    h.texts().iter().filter(|t| *t == text).count()
}

/// Asserts, at this tick, that `kind` is on and that every report says so:
/// HEARTBEAT CRITICAL, its SYS_STATUS health bit clear, its EKF flags
/// withheld (each built as the vehicle would send it now).
fn assert_reported(h: &Harness, kind: Failsafe) {
    let core = h.sim.core();
    let t = h.sim.time().as_secs_f64();
    let tail = h.texts().iter().rev().take(8).cloned().collect::<Vec<_>>();
    assert!(core.failsafe_is_active(kind), "{kind:?} off at {t:.2} s: {tail:?}");
    match core.build_requested(HEARTBEAT_ID) {
        Some(MavMessage::HEARTBEAT(hb)) => assert_eq!(hb.system_status, MavState::MAV_STATE_CRITICAL, "at {t:.2} s"),
        other => panic!("no HEARTBEAT: {other:?}"),
    }
    if let Some(sensor) = kind.health_sensor() {
        match core.build_requested(SYS_STATUS_ID) {
            Some(MavMessage::SYS_STATUS(s)) => assert!(
                !s.onboard_control_sensors_health.contains(sensor),
                "{kind:?}: {sensor:?} healthy at {t:.2} s"
            ),
            other => panic!("no SYS_STATUS: {other:?}"),
        }
    }
    match core.build_requested(EKF_STATUS_REPORT_ID) {
        Some(MavMessage::EKF_STATUS_REPORT(e)) => assert!(
            (e.flags & kind.ekf_flags_withheld()).is_empty(),
            "{kind:?}: EKF flags {:?} at {t:.2} s",
            e.flags
        ),
        other => panic!("no EKF_STATUS_REPORT: {other:?}"),
    }
}

/// Steps `seconds`, asserting every tick that `kind` stays on and reported,
/// that every HEARTBEAT sent meanwhile said CRITICAL and that nothing said
/// it cleared.
fn assert_on_for(h: &mut Harness, kind: Failsafe, seconds: f64) {
    let from = h.received.len();
    let end = h.sim.time() + std::time::Duration::from_secs_f64(seconds);
    while h.sim.time() < end {
        h.step();
        assert_reported(h, kind);
    }
    for o in &h.received[from..] {
        match &o.message {
            MavMessage::HEARTBEAT(hb) => assert_eq!(hb.system_status, MavState::MAV_STATE_CRITICAL),
            MavMessage::STATUSTEXT(t) => assert_ne!(t.text.to_str().unwrap_or(""), cleared_text(kind)),
            _ => {}
        }
    }
}

/// DO_SET_MODE as a ground station sends it; its COMMAND_ACK.
fn mode_ack(h: &mut Harness, number: u32) -> MavResult {
    h.command(
        MavCmd::MAV_CMD_DO_SET_MODE,
        [CUSTOM_MODE_ENABLED, number as f32, 0.0, 0.0, 0.0, 0.0, 0.0],
    );
    h.step();
    *h.acks(MavCmd::MAV_CMD_DO_SET_MODE).last().expect("a COMMAND_ACK")
}

fn arm_ack(h: &mut Harness) -> MavResult {
    h.arm();
    h.step();
    *h.acks(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM)
        .last()
        .expect("a COMMAND_ACK")
}

fn disarm(h: &mut Harness) {
    h.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [0.0; 7]);
    h.step();
    assert!(!h.sim.core().is_armed());
}

/// Entering `number` is refused while `kind` is on: TEMPORARILY_REJECTED
/// and a STATUSTEXT naming the failsafe.
fn assert_mode_refused(h: &mut Harness, number: u32, name: &str, kind: Failsafe) {
    let before = h.sim.core().mode();
    let from = h.texts().len();
    assert_eq!(mode_ack(h, number), MavResult::MAV_RESULT_TEMPORARILY_REJECTED);
    assert_eq!(h.sim.core().mode(), before);
    let expected = format!("Mode change to {name} failed: {}", kind.name());
    assert!(
        new_texts(h, from).contains(&expected),
        "{expected:?} in {:?}",
        new_texts(h, from)
    );
}

/// Arming is refused while `kind` is on, with its name.
fn assert_arming_refused(h: &mut Harness, kind: Failsafe) {
    let from = h.texts().len();
    assert_eq!(arm_ack(h), MavResult::MAV_RESULT_FAILED);
    assert!(!h.sim.core().is_armed());
    let expected = format!("PreArm: Failsafe on: {}", kind.name());
    assert!(
        new_texts(h, from).contains(&expected),
        "{expected:?} in {:?}",
        new_texts(h, from)
    );
}

/// After the cause ends: cleared within `within_s`, and said exactly once
/// (nothing said it before: see `assert_on_for`).
fn assert_cleared_once(h: &mut Harness, kind: Failsafe, within_s: f64) {
    let from = h.texts().len();
    assert!(
        !h.sim.core().failsafe_is_active(kind) || h.run_until(within_s, |s| !s.core().failsafe_is_active(kind)),
        "{kind:?} still on {within_s} s after its cause ended: {:?}",
        new_texts(h, from)
    );
    assert_eq!(count(h, &cleared_text(kind)), 1, "{:?}", h.texts());
    h.run_for(3.0);
    assert!(!h.sim.core().failsafe_is_active(kind));
    assert_eq!(count(h, &cleared_text(kind)), 1, "{:?}", h.texts());
    match h.sim.core().build_requested(HEARTBEAT_ID) {
        Some(MavMessage::HEARTBEAT(hb)) => assert_ne!(hb.system_status, MavState::MAV_STATE_CRITICAL),
        other => panic!("no HEARTBEAT: {other:?}"),
    }
}

/// A sensor failsafe started from GUIDED: it stays on through its HOLD,
/// MANUAL, the refused GUIDED and a disarm, and clears once the sensor
/// is back (within `clear_within_s` of it).
fn sensor_failsafe_lasts_as_long_as_its_cause(
    seed: u64,
    kind: Failsafe,
    setup: &[(&str, f64)],
    fault: (&str, f64),
    end: (&str, f64),
    clear_within_s: f64,
) {
    let mut h = driving(seed);
    for (name, value) in setup {
        set(&mut h, name, *value);
    }
    set(&mut h, fault.0, fault.1);
    assert!(
        h.run_until(3.0, |s| s.core().failsafe_is_active(kind)
            && s.core().mode() == Mode::Hold),
        "{:?}",
        h.texts()
    );
    assert!(h.texts().contains(&format!("Failsafe: {}: HOLD", kind.name())));
    assert_on_for(&mut h, kind, 3.0);
    // The operator takes over by hand: allowed, and the failsafe stays.
    assert_eq!(mode_ack(&mut h, 0), MavResult::MAV_RESULT_ACCEPTED);
    assert_on_for(&mut h, kind, 1.0);
    assert_mode_refused(&mut h, 15, "GUIDED", kind);
    assert_mode_refused(&mut h, 11, "RTL", kind);
    assert_eq!(mode_ack(&mut h, 4), MavResult::MAV_RESULT_ACCEPTED);
    // Disarmed, the cause is still there to see, and arming is refused.
    disarm(&mut h);
    assert_on_for(&mut h, kind, 1.0);
    assert_arming_refused(&mut h, kind);
    assert_on_for(&mut h, kind, 1.0);
    // Driving by hand needs none of these sensors: MANUAL arms.
    assert_eq!(mode_ack(&mut h, 0), MavResult::MAV_RESULT_ACCEPTED);
    assert_eq!(arm_ack(&mut h), MavResult::MAV_RESULT_ACCEPTED, "{:?}", h.texts());
    assert_on_for(&mut h, kind, 1.0);
    disarm(&mut h);
    set(&mut h, end.0, end.1);
    assert_cleared_once(&mut h, kind, clear_within_s);
}

#[test]
fn gnss_lost_in_guided_stays_on_through_its_hold_until_the_fix_is_back() {
    sensor_failsafe_lasts_as_long_as_its_cause(
        101,
        Failsafe::GnssLost,
        &[],
        ("SIM_GPS_DISABLE", 1.0),
        ("SIM_GPS_DISABLE", 0.0),
        1.0,
    );
}

#[test]
fn heading_lost_stays_on_until_the_sensor_sends_again() {
    sensor_failsafe_lasts_as_long_as_its_cause(
        102,
        Failsafe::HeadingLost,
        &[],
        ("SIM_HDG_ENABLE", 0.0),
        ("SIM_HDG_ENABLE", 1.0),
        1.0,
    );
}

#[test]
fn a_frozen_heading_stays_lost_in_hold_until_the_value_moves() {
    sensor_failsafe_lasts_as_long_as_its_cause(
        103,
        Failsafe::HeadingLost,
        &[],
        ("SIM_HDG_FREEZE", 1.0),
        ("SIM_HDG_FREEZE", 0.0),
        1.0,
    );
}

#[test]
fn an_unhealthy_ekf_stays_on_until_the_filter_is_healthy() {
    // The GNSS and heading failsafes (the heading comes from the GNSS
    // antennas) only report, so it is the EKF's that stops; the filter
    // needs fixes again before it calls itself healthy.
    sensor_failsafe_lasts_as_long_as_its_cause(
        104,
        Failsafe::Ekf,
        &[("FS_GNSS_ACT", 0.0), ("FS_HDG_ACT", 0.0)],
        ("SIM_GPS_DISABLE", 1.0),
        ("SIM_GPS_DISABLE", 0.0),
        5.0,
    );
}

#[test]
fn a_stale_scanner_stays_on_through_its_hold_until_it_scans_again() {
    sensor_failsafe_lasts_as_long_as_its_cause(
        105,
        Failsafe::Scanner,
        &[],
        ("SIM_SCAN_DISABLE", 1.0),
        ("SIM_SCAN_DISABLE", 0.0),
        1.0,
    );
}

#[test]
fn gcs_loss_stays_on_through_mode_changes_and_a_disarm_until_heartbeats_return() {
    let kind = Failsafe::Gcs;
    let mut h = driving(106);
    set(&mut h, "FS_GCS_ENABLE", 1.0);
    h.send(gcs_heartbeat());
    assert!(h.run_until(7.0, |s| s.core().failsafe_is_active(kind)));
    assert_eq!(h.sim.core().mode(), Mode::Hold);
    assert_on_for(&mut h, kind, 2.0);
    assert_eq!(mode_ack(&mut h, 0), MavResult::MAV_RESULT_ACCEPTED);
    assert_on_for(&mut h, kind, 1.0);
    assert_mode_refused(&mut h, 15, "GUIDED", kind);
    disarm(&mut h);
    assert_on_for(&mut h, kind, 1.0);
    assert_arming_refused(&mut h, kind);
    assert_on_for(&mut h, kind, 1.0);
    h.send(gcs_heartbeat());
    assert_cleared_once(&mut h, kind, 0.1);
    assert_eq!(mode_ack(&mut h, 15), MavResult::MAV_RESULT_ACCEPTED);
}

#[test]
fn a_low_battery_holds_until_disarmed_and_recharged() {
    let kind = Failsafe::BatteryLow;
    let mut h = driving(107);
    set(&mut h, "BATT_LOW_VOLT", 46.0);
    set(&mut h, "BATT_CRT_VOLT", 44.0);
    set(&mut h, "BATT_LOW_TIMER", 1.0);
    set(&mut h, "BATT_FS_LOW_ACT", 2.0);
    set(&mut h, "SIM_BATT_VOLT", 45.0);
    assert!(h.run_until(2.0, |s| s.core().failsafe_is_active(kind)));
    assert_eq!(h.sim.core().mode(), Mode::Hold);
    assert_on_for(&mut h, kind, 2.0);
    assert_mode_refused(&mut h, 10, "AUTO", kind);
    assert_mode_refused(&mut h, 15, "GUIDED", kind);
    // Latched: the voltage recovering under no load does not end it while
    // armed; a disarm does, once the battery reads good.
    set(&mut h, "SIM_BATT_VOLT", 0.0);
    assert_on_for(&mut h, kind, 2.0);
    disarm(&mut h);
    assert_cleared_once(&mut h, kind, 0.1);
}

#[test]
fn a_critical_battery_stays_on_after_its_disarm_while_the_voltage_is_low() {
    let kind = Failsafe::BatteryCritical;
    let mut h = driving(108);
    set(&mut h, "BATT_LOW_VOLT", 46.0);
    set(&mut h, "BATT_CRT_VOLT", 44.0);
    set(&mut h, "BATT_LOW_TIMER", 1.0);
    set(&mut h, "BATT_FS_CRT_ACT", 5.0);
    set(&mut h, "SIM_BATT_VOLT", 43.0);
    assert!(h.run_until(2.0, |s| !s.core().is_armed()));
    assert_on_for(&mut h, kind, 2.0);
    // In any mode: it cut the power.
    assert_eq!(mode_ack(&mut h, 0), MavResult::MAV_RESULT_ACCEPTED);
    assert_arming_refused(&mut h, kind);
    assert_on_for(&mut h, kind, 1.0);
    set(&mut h, "SIM_BATT_VOLT", 0.0);
    assert_cleared_once(&mut h, kind, 0.1);
}

#[test]
fn a_core_stall_stays_on_until_disarmed_and_refuses_driving_meanwhile() {
    let kind = Failsafe::CoreStall;
    let mut h = driving(109);
    set(&mut h, "SIM_CPU_STALL", 300.0);
    assert!(h.run_until(1.0, |s| s.core().failsafe_is_active(kind)));
    assert_eq!(h.sim.core().mode(), Mode::Hold);
    assert_on_for(&mut h, kind, 3.0);
    assert_eq!(mode_ack(&mut h, 0), MavResult::MAV_RESULT_ACCEPTED);
    assert_on_for(&mut h, kind, 1.0);
    assert_mode_refused(&mut h, 15, "GUIDED", kind);
    assert_mode_refused(&mut h, 11, "RTL", kind);
    disarm(&mut h);
    assert_cleared_once(&mut h, kind, 0.1);
    assert_eq!(arm_ack(&mut h), MavResult::MAV_RESULT_ACCEPTED, "{:?}", h.texts());
}

#[test]
fn off_the_path_stays_on_until_disarmed_even_once_the_steering_is_free() {
    let kind = Failsafe::Control;
    let mut h = driving(110);
    set(&mut h, "FS_XTRACK_M", 2.0);
    h.goto_local(h.sim.world().truth().north_m + 40.0, 40.0);
    h.run_for(1.0);
    set(&mut h, "SIM_ACT_STUCK", 1.0);
    assert!(
        h.run_until(60.0, |s| s.core().failsafe_is_active(kind)),
        "{:?}",
        h.texts()
    );
    assert_eq!(h.sim.core().mode(), Mode::Hold);
    assert_on_for(&mut h, kind, 2.0);
    assert_mode_refused(&mut h, 15, "GUIDED", kind);
    set(&mut h, "SIM_ACT_STUCK", 0.0);
    assert_on_for(&mut h, kind, 2.0);
    disarm(&mut h);
    assert_cleared_once(&mut h, kind, 0.1);
}

#[test]
fn a_runaway_stays_on_while_it_coasts_after_its_disarm() {
    let kind = Failsafe::Runaway;
    let mut h = driving(111);
    set(&mut h, "SIM_ACT_STUCK", 2.0);
    h.step();
    h.set_mode(4);
    assert!(h.run_until(4.0, |s| !s.core().is_armed()));
    assert!(h.texts().iter().any(|t| t == "Failsafe: vehicle does not stop: disarm"));
    // Still coasting faster than the threshold: the cause is still there.
    assert!(h.sim.world().truth().speed_mps > 0.6);
    assert_reported(&h, kind);
    assert_arming_refused(&mut h, kind);
    assert!(h.run_until(10.0, |s| !s.core().failsafe_is_active(kind)));
    let speed = h.sim.world().truth().speed_mps.abs();
    assert!(speed < 0.4, "cleared at {speed:.2} m/s: the cause was still there");
    h.run_for(3.0);
    assert_eq!(count(&h, &cleared_text(kind)), 1);
}

#[test]
fn a_report_only_failsafe_acts_once_its_action_is_set_while_it_lasts() {
    let kind = Failsafe::HeadingLost;
    let mut h = driving(112);
    set(&mut h, "FS_HDG_ACT", 0.0);
    set(&mut h, "SIM_HDG_ENABLE", 0.0);
    assert!(h.run_until(2.0, |s| s.core().failsafe_is_active(kind)));
    assert!(h.texts().contains(&"Failsafe: heading lost: report only".to_string()));
    // Report only: it neither stops GUIDED nor refuses it.
    assert_on_for(&mut h, kind, 2.0);
    assert_eq!(h.sim.core().mode(), Mode::Guided);
    assert_eq!(mode_ack(&mut h, 15), MavResult::MAV_RESULT_ACCEPTED);
    set(&mut h, "FS_HDG_ACT", 2.0);
    h.step();
    assert_eq!(h.sim.core().mode(), Mode::Hold);
    assert!(h.texts().contains(&"Failsafe: heading lost: HOLD".to_string()));
    assert_on_for(&mut h, kind, 1.0);
    set(&mut h, "SIM_HDG_ENABLE", 1.0);
    assert_cleared_once(&mut h, kind, 1.0);
}

/// SYS_STATUS reports what the vehicle has, as a ground station reads
/// "ready": the GNSS, the heading sensor in the magnetometer slot, the EKF
/// as AHRS, the simulated IMU as gyro and accelerometer, each present,
/// enabled and healthy (without an IMU: `imu_heading.rs`). A silent heading
/// sensor stays present and turns unhealthy.
#[test]
fn sys_status_reports_the_sensors_the_vehicle_has_and_their_health() {
    let mut h = Harness::new(7, ModelKind::Ackermann);
    h.run_for(5.0);
    let status = last_sys_status(&h);
    let ready = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_GPS
        | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_MAG
        | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO
        | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_ACCEL
        | MavSysStatusSensor::MAV_SYS_STATUS_AHRS
        | MavSysStatusSensor::MAV_SYS_STATUS_PREARM_CHECK;
    assert!(status.onboard_control_sensors_present.contains(ready), "{status:?}");
    assert!(status.onboard_control_sensors_enabled.contains(ready), "{status:?}");
    assert!(status.onboard_control_sensors_health.contains(ready), "{status:?}");

    set(&mut h, "SIM_HDG_ENABLE", 0.0);
    h.run_for(3.0);
    let status = last_sys_status(&h);
    let mag = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_MAG;
    assert!(status.onboard_control_sensors_present.contains(mag));
    assert!(!status.onboard_control_sensors_health.contains(mag), "{status:?}");
    set(&mut h, "SIM_HDG_ENABLE", 1.0);
    h.run_for(3.0);
    assert!(last_sys_status(&h).onboard_control_sensors_health.contains(mag));
}
