//! The whole core under arbitrary ground-station traffic, for simulated
//! hours: mission uploads whose items carry any params, PARAM_SETs of any
//! value, COMMAND_LONG/COMMAND_INT with any params, mode changes, arming and
//! disarming, with long waits between (AUTO runs what was accepted).
//!
//! Properties: no panic; every command gets exactly one COMMAND_ACK; every
//! PARAM_SET is answered with the value now in force, which is finite and
//! within the parameter's range; every upload ends in one MISSION_ACK; the
//! plan in force always validates; the simulated vehicle's state and the
//! servo outputs stay finite and within their limits.
//!
//! Ticks are cheap: the core runs at SCHED_LOOP_RATE 10 Hz with the
//! simulated scanners off, so a simulated hour is 36 000 steps.

mod common;

use std::time::Duration;

use autopilot::sitl::gcs;
use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};
use autopilot::time::FrozenTimer;
use autopilot::vehicle::Outbound;
use mavlink::dialects::ardupilotmega::{
    COMMAND_INT_DATA, MISSION_COUNT_DATA, MISSION_ITEM_INT_DATA, MavCmd, MavFrame, MavMessage, MavMissionResult,
    MavMissionType, PARAM_SET_DATA,
};
use mission::command::{cmd, frame};
use mission::{MissionItem, MissionType, validate_plan};
use proptest::prelude::*;

/// Values a GCS may send, edges and specials included.
const SPECIAL: [f32; 16] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    -2.0,
    2.0,
    10.0,
    86_400.0,
    86_401.0,
    1e20,
    -1e20,
    f32::MAX,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
    21196.0,
];

fn value() -> impl Strategy<Value = f32> {
    prop_oneof![
        3 => proptest::sample::select(SPECIAL.to_vec()),
        2 => -100.0f32..100.0,
        1 => any::<f32>(),
    ]
}

const COMMANDS: [u16; 13] = [
    cmd::NAV_WAYPOINT,
    cmd::NAV_LOITER_UNLIM,
    cmd::NAV_LOITER_TIME,
    cmd::NAV_RETURN_TO_LAUNCH,
    cmd::NAV_DELAY,
    cmd::CONDITION_DELAY,
    cmd::CONDITION_DISTANCE,
    cmd::DO_JUMP,
    cmd::DO_CHANGE_SPEED,
    cmd::DO_SET_REVERSE,
    cmd::DO_SET_SERVO,
    cmd::DO_REPEAT_SERVO,
    cmd::DO_SET_RELAY,
];

/// What the parameters a GCS changes are called (and one that is not).
const PARAMS: [&str; 10] = [
    "WP_SPEED",
    "WP_RADIUS",
    "ATC_ACCEL_MAX",
    "VEH_STEER_MAX",
    "FS_GCS_TIMEOUT",
    "MIS_RESTART",
    "SR0_POSITION",
    "ATC_TURN_MAX_G",
    "SERVO9_FUNCTION",
    "NO_SUCH_PARAM",
];

const GCS_COMMANDS: [MavCmd; 12] = [
    MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
    MavCmd::MAV_CMD_DO_SET_MODE,
    MavCmd::MAV_CMD_MISSION_START,
    MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT,
    MavCmd::MAV_CMD_DO_REPOSITION,
    MavCmd::MAV_CMD_DO_SET_HOME,
    MavCmd::MAV_CMD_DO_CHANGE_SPEED,
    MavCmd::MAV_CMD_DO_SET_SERVO,
    MavCmd::MAV_CMD_DO_SET_RELAY,
    MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
    MavCmd::MAV_CMD_REQUEST_MESSAGE,
    MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH,
];

#[derive(Clone, Debug)]
enum Gcs {
    /// Items after home: command index, params, north/east in dm.
    Upload(Vec<(usize, [f32; 4], i16, i16)>),
    ParamSet(usize, f32),
    CommandLong(usize, [f32; 7]),
    CommandInt(usize, [f32; 4], i32, i32, f32),
    Mode(u32),
    Arm,
    Disarm,
    /// Simulated seconds.
    Wait(u16),
}

fn gcs() -> impl Strategy<Value = Gcs> {
    let upload_item = (
        0..COMMANDS.len(),
        [value(), value(), value(), value()],
        any::<i16>(),
        any::<i16>(),
    );
    prop_oneof![
        2 => proptest::collection::vec(upload_item, 0..8).prop_map(Gcs::Upload),
        2 => (0..PARAMS.len(), value()).prop_map(|(i, v)| Gcs::ParamSet(i, v)),
        2 => (0..GCS_COMMANDS.len(), [value(), value(), value(), value(), value(), value(), value()])
            .prop_map(|(i, p)| Gcs::CommandLong(i, p)),
        1 => (0..GCS_COMMANDS.len(), [value(), value(), value(), value()], any::<i32>(), any::<i32>(), value())
            .prop_map(|(i, p, x, y, z)| Gcs::CommandInt(i, p, x, y, z)),
        2 => prop_oneof![Just(0u32), Just(4), Just(10), Just(11), Just(15), 0u32..40].prop_map(Gcs::Mode),
        1 => Just(Gcs::Arm),
        1 => Just(Gcs::Disarm),
        3 => (1u16..900).prop_map(Gcs::Wait),
    ]
}

struct Vehicle {
    sim: Simulation,
    timer: FrozenTimer,
    received: Vec<Outbound>,
}

impl Vehicle {
    fn new(seed: u64) -> Self {
        let config = SimulationConfig {
            seed,
            model: ModelKind::Ackermann,
            ..SimulationConfig::default()
        };
        let mut params = SimulationParams::new(config.model);
        params
            .apply(&[
                ("SIM_SCAN_DISABLE".to_owned(), 3.0),
                ("SCHED_LOOP_RATE".to_owned(), 10.0),
            ])
            .expect("cheap-tick parameters");
        let mut sim = Simulation::new(&config, params);
        gcs::connect(&mut sim);
        let mut v = Vehicle {
            sim,
            timer: FrozenTimer,
            received: Vec::new(),
        };
        v.run_for(2.0);
        v
    }

    fn step(&mut self) {
        let wall = self.sim.time();
        let out = self.sim.step(wall, &mut self.timer);
        self.received.append(&mut out.mavlink);
        self.check_state();
    }

    fn run_for(&mut self, seconds: f64) {
        let end = self.sim.time() + Duration::from_secs_f64(seconds);
        while self.sim.time() < end {
            self.step();
        }
    }

    /// Sends `message`, steps once and returns what came back.
    fn exchange(&mut self, message: MavMessage) -> Vec<MavMessage> {
        gcs::send(&mut self.sim, message);
        self.received.clear();
        self.step();
        self.received.drain(..).map(|o| o.message).collect()
    }

    fn check_state(&self) {
        let t = self.sim.world().truth();
        for v in [t.north_m, t.east_m, t.yaw_rad, t.speed_mps] {
            assert!(v.is_finite(), "vehicle state not finite: {t:?}");
        }
        assert!(t.speed_mps.abs() < 50.0, "vehicle speed {} m/s", t.speed_mps);
        for m in &self.received {
            if let MavMessage::SERVO_OUTPUT_RAW(s) = &m.message {
                for us in [s.servo1_raw, s.servo2_raw, s.servo3_raw, s.servo4_raw] {
                    // DO_SET_SERVO takes 0–3000 µs on a free channel.
                    assert!(us <= 3000, "servo output {us} µs");
                }
            }
        }
    }

    fn command(&mut self, message: MavMessage, command: MavCmd) {
        let answers = self.exchange(message);
        let acks = answers
            .iter()
            .filter(|m| matches!(m, MavMessage::COMMAND_ACK(a) if a.command == command))
            .count();
        assert_eq!(acks, 1, "{command:?}: one COMMAND_ACK");
    }

    fn param_set(&mut self, name: &str, value: f32) {
        let mut id = [0u8; 16];
        id[..name.len()].copy_from_slice(name.as_bytes());
        let answers = self.exchange(MavMessage::PARAM_SET(PARAM_SET_DATA {
            param_value: value,
            target_system: 1,
            target_component: 1,
            param_id: id.into(),
            param_type: mavlink::dialects::ardupilotmega::MavParamType::MAV_PARAM_TYPE_REAL32,
        }));
        let table = self.sim.core().params();
        let Some(index) = table.index_of(name) else {
            return;
        };
        let in_force = table.value(index);
        let def = table.def(index);
        assert!(
            in_force.is_finite() && in_force >= def.min && in_force <= def.max,
            "{name} = {in_force} after PARAM_SET {value}"
        );
        let echoed: Vec<f32> = answers
            .iter()
            .filter_map(|m| match m {
                MavMessage::PARAM_VALUE(p) if p.param_id.to_str().ok() == Some(name) => Some(p.param_value),
                _ => None,
            })
            .collect();
        assert_eq!(
            echoed,
            vec![in_force as f32],
            "{name}: PARAM_SET {value} echoed as in force"
        );
    }

    /// A mission upload as a GCS does it: count, then each item requested.
    fn upload(&mut self, items: &[MissionItem]) {
        let mut answers = self.exchange(MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count: items.len() as u16,
            target_system: 1,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id: 0,
        }));
        for _ in 0..=items.len() {
            let requested = answers.iter().find_map(|m| match m {
                MavMessage::MISSION_REQUEST_INT(r) => Some(r.seq),
                _ => None,
            });
            let acks: Vec<MavMissionResult> = answers
                .iter()
                .filter_map(|m| match m {
                    MavMessage::MISSION_ACK(a) => Some(a.mavtype),
                    _ => None,
                })
                .collect();
            if !acks.is_empty() {
                assert_eq!(acks.len(), 1, "one MISSION_ACK per upload");
                let in_force = self.sim.core().plan(MissionType::Mission).items().to_vec();
                assert!(
                    validate_plan(MissionType::Mission, in_force).is_ok(),
                    "plan in force validates"
                );
                let verdict = validate_plan(MissionType::Mission, items.to_vec());
                assert_eq!(
                    acks[0] == MavMissionResult::MAV_MISSION_ACCEPTED,
                    verdict.is_ok(),
                    "ACK {:?} for a plan whose validation says {verdict:?}",
                    acks[0]
                );
                return;
            }
            let Some(seq) = requested else {
                panic!("upload stalled: {answers:?}");
            };
            let it = items[usize::from(seq)];
            answers = self.exchange(MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
                param1: it.params[0],
                param2: it.params[1],
                param3: it.params[2],
                param4: it.params[3],
                x: it.x,
                y: it.y,
                z: it.z,
                seq: it.seq,
                command: num_cmd(it.command),
                target_system: 1,
                target_component: 1,
                frame: MavFrame::MAV_FRAME_LOCAL_NED,
                current: 0,
                autocontinue: 1,
                mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            }));
        }
        panic!("upload never acknowledged");
    }

    fn apply(&mut self, action: &Gcs) {
        match action {
            Gcs::Upload(rest) => {
                let mut items = vec![mission_item(0, cmd::NAV_WAYPOINT, [0.0; 4], 0, 0)];
                for (i, (c, params, north_dm, east_dm)) in rest.iter().enumerate() {
                    let seq = i as u16 + 1;
                    items.push(mission_item(seq, COMMANDS[*c], *params, *north_dm, *east_dm));
                }
                self.upload(&items);
            }
            Gcs::ParamSet(i, value) => self.param_set(PARAMS[*i], *value),
            Gcs::CommandLong(i, p) => self.command(gcs::command_long(GCS_COMMANDS[*i], *p), GCS_COMMANDS[*i]),
            Gcs::CommandInt(i, p, x, y, z) => {
                let command = GCS_COMMANDS[*i];
                let message = MavMessage::COMMAND_INT(COMMAND_INT_DATA {
                    param1: p[0],
                    param2: p[1],
                    param3: p[2],
                    param4: p[3],
                    x: *x,
                    y: *y,
                    z: *z,
                    command,
                    target_system: 1,
                    target_component: 1,
                    frame: MavFrame::MAV_FRAME_GLOBAL,
                    current: 0,
                    autocontinue: 0,
                });
                self.command(message, command);
            }
            Gcs::Mode(n) => self.command(gcs::set_mode(*n), MavCmd::MAV_CMD_DO_SET_MODE),
            Gcs::Arm => self.command(gcs::arm(), MavCmd::MAV_CMD_COMPONENT_ARM_DISARM),
            Gcs::Disarm => self.command(
                gcs::command_long(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [0.0; 7]),
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            ),
            Gcs::Wait(s) => {
                // The GCS keeps its heartbeat going (no GCS failsafe).
                for _ in 0..*s {
                    gcs::send(&mut self.sim, gcs::heartbeat());
                    self.run_for(1.0);
                    self.received.clear();
                }
            }
        }
    }
}

fn num_cmd(command: u16) -> MavCmd {
    mission::validate::mav_cmd(command).expect("a dialect command")
}

/// Metres × 1e4 in MAV_FRAME_LOCAL_NED from decimetres: within ±3.3 km.
fn mission_item(seq: u16, command: u16, params: [f32; 4], north_dm: i16, east_dm: i16) -> MissionItem {
    MissionItem {
        seq,
        frame: frame::LOCAL_NED,
        command,
        current: false,
        autocontinue: true,
        params,
        x: i32::from(north_dm) * 1000,
        y: i32::from(east_dm) * 1000,
        z: 0.0,
    }
}

/// Each session lasts at least this long in simulated time: whatever the
/// GCS left in force (AUTO, a mission, a speed) runs on.
const SESSION_MIN_S: f64 = 1800.0;
const SESSIONS: u32 = 12;

#[test]
fn the_core_survives_any_ground_station_for_simulated_hours() {
    let config = ProptestConfig {
        cases: SESSIONS,
        max_shrink_iters: 200,
        ..ProptestConfig::default()
    };
    let simulated_s = std::cell::Cell::new(0.0);
    let mut runner = proptest::test_runner::TestRunner::new(config);
    let strategy = (0u64..1000, proptest::collection::vec(gcs(), 1..40));
    runner
        .run(&strategy, |(seed, session)| {
            let mut v = Vehicle::new(seed);
            for action in &session {
                v.apply(action);
            }
            let elapsed_s = v.sim.time().as_secs_f64();
            if elapsed_s < SESSION_MIN_S {
                v.apply(&Gcs::Wait((SESSION_MIN_S - elapsed_s).ceil() as u16));
            }
            simulated_s.set(simulated_s.get() + v.sim.time().as_secs_f64());
            Ok(())
        })
        .unwrap();
    let hours = simulated_s.get() / 3600.0;
    eprintln!("{SESSIONS} sessions, {hours:.1} simulated hours (shrinking included)");
    assert!(hours >= f64::from(SESSIONS) * SESSION_MIN_S / 3600.0);
}

/// Command params beyond what the vehicle can use are refused, not cast
/// into something else (a speed of 1e20 m/s, mode 4.5 read as 4, a message
/// id 0.5 read as HEARTBEAT).
#[test]
fn commands_refuse_out_of_range_params() {
    use mavlink::dialects::ardupilotmega::MavResult as R;
    let mut v = Vehicle::new(7);
    let mut ack = |command: MavCmd, params: [f32; 7]| {
        let answers = v.exchange(gcs::command_long(command, params));
        answers
            .iter()
            .find_map(|m| match m {
                MavMessage::COMMAND_ACK(a) if a.command == command => Some(a.result),
                _ => None,
            })
            .expect("a COMMAND_ACK")
    };
    let speed = MavCmd::MAV_CMD_DO_CHANGE_SPEED;
    assert_eq!(ack(speed, [1.0, 1e20, -1.0, 0.0, 0.0, 0.0, 0.0]), R::MAV_RESULT_DENIED);
    assert_eq!(ack(speed, [1.0, 100.5, -1.0, 0.0, 0.0, 0.0, 0.0]), R::MAV_RESULT_DENIED);
    assert_eq!(ack(speed, [1.0, 3.0, -1.0, 0.0, 0.0, 0.0, 0.0]), R::MAV_RESULT_ACCEPTED);
    let mode = MavCmd::MAV_CMD_DO_SET_MODE;
    assert_eq!(ack(mode, [1.0, 4.5, 0.0, 0.0, 0.0, 0.0, 0.0]), R::MAV_RESULT_DENIED);
    assert_eq!(
        ack(mode, [f32::NAN, 4.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        R::MAV_RESULT_DENIED
    );
    assert_eq!(ack(mode, [1.0, 4.0, 0.0, 0.0, 0.0, 0.0, 0.0]), R::MAV_RESULT_ACCEPTED);
    let request = MavCmd::MAV_CMD_REQUEST_MESSAGE;
    assert_eq!(ack(request, [0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]), R::MAV_RESULT_DENIED);
    assert_eq!(
        ack(request, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        R::MAV_RESULT_ACCEPTED
    );
    let home = MavCmd::MAV_CMD_DO_SET_HOME;
    assert_eq!(ack(home, [0.0, 0.0, 0.0, 0.0, 29.2, 119.7, 1e30]), R::MAV_RESULT_DENIED);
    assert_eq!(
        ack(home, [0.0, 0.0, 0.0, 0.0, 29.2, 119.7, 50.0]),
        R::MAV_RESULT_ACCEPTED
    );
    let interval = MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL;
    assert_eq!(
        ack(interval, [33.0, 1e20, 0.0, 0.0, 0.0, 0.0, 0.0]),
        R::MAV_RESULT_DENIED
    );
    assert_eq!(
        ack(interval, [33.0, 1e6, 0.0, 0.0, 0.0, 0.0, 0.0]),
        R::MAV_RESULT_ACCEPTED
    );
}
