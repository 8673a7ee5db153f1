//! Saved before acknowledged, through the whole core: with durable storage
//! a PARAM_SET is echoed, and an upload acknowledged, only after the edge
//! reports the save; a failed save answers with the old value or
//! MISSION_ACK ERROR and a STATUSTEXT, and the old value or plan stays in
//! force; read-only storage refuses every change and says so at connect.
//! A flight termination stops at once, is acknowledged once saved, and is
//! still in force after a restart on the same data directory.

use std::path::Path;
use std::time::{Duration, Instant};

use autopilot::edge::persistence::{Persistence, restore};
use autopilot::sitl::gcs;
use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};
use autopilot::storage::data_dir::{DataDir, Profile};
use autopilot::storage::file_writer::FileWriterThread;
use autopilot::storage::session::SessionParams;
use autopilot::time::FrozenTimer;
use autopilot::vehicle::{LinkEvent, LinkId, Outbound, SaveDone, SaveRequest, SaveWhat, Storage};
use mavlink::dialects::ardupilotmega::{
    MISSION_COUNT_DATA, MISSION_ITEM_INT_DATA, MavCmd, MavFrame, MavMessage, MavMissionResult, MavMissionType,
    MavParamType, MavResult, PARAM_SET_DATA,
};

struct Vehicle {
    sim: Simulation,
    received: Vec<Outbound>,
    saves: Vec<SaveRequest>,
}

impl Vehicle {
    fn new(storage: Storage) -> Vehicle {
        let model = ModelKind::Ackermann;
        let config = SimulationConfig {
            model,
            ..SimulationConfig::default()
        };
        let mut sim = Simulation::new(&config, SimulationParams::new(model));
        sim.core_mut().set_storage(storage);
        gcs::connect(&mut sim);
        let mut v = Vehicle {
            sim,
            received: Vec::new(),
            saves: Vec::new(),
        };
        v.step();
        v
    }

    fn step(&mut self) {
        let wall = self.sim.time();
        let out = self.sim.step(wall, &mut FrozenTimer);
        self.received.append(&mut out.mavlink);
        self.saves.append(&mut out.saves);
    }

    fn send(&mut self, message: MavMessage) {
        gcs::send(&mut self.sim, message);
        self.step();
    }

    fn report(&mut self, token: u64, result: Result<(), String>) {
        self.sim.inputs_mut().saved.push(SaveDone { token, result });
        self.step();
    }

    /// Reports every save asked for so far as `result`.
    fn report_all(&mut self, result: Result<(), String>) {
        for save in std::mem::take(&mut self.saves) {
            self.report(save.token, result.clone());
        }
    }

    fn take(&mut self) -> Vec<MavMessage> {
        self.received.drain(..).map(|o| o.message).collect()
    }

    fn param(&self, name: &str) -> f64 {
        self.sim.core().params().value_of(name).expect("parameter")
    }
}

fn param_set(name: &str, value: f32) -> MavMessage {
    let mut id = [0u8; 16];
    id[..name.len()].copy_from_slice(name.as_bytes());
    MavMessage::PARAM_SET(PARAM_SET_DATA {
        param_value: value,
        target_system: 1,
        target_component: 1,
        param_id: id.into(),
        param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
    })
}

fn echoes(messages: &[MavMessage], name: &str) -> Vec<f32> {
    messages
        .iter()
        .filter_map(|m| match m {
            MavMessage::PARAM_VALUE(v) if v.param_id.to_str().is_ok_and(|id| id == name) => Some(v.param_value),
            _ => None,
        })
        .collect()
}

/// The STATUSTEXT sent, chunks joined (a long text comes in chunks).
fn texts(messages: &[MavMessage]) -> String {
    messages
        .iter()
        .filter_map(|m| match m {
            MavMessage::STATUSTEXT(t) => Some(t.text.to_str().unwrap_or("?").to_owned()),
            _ => None,
        })
        .collect::<Vec<_>>()
        .join("")
}

fn acks(messages: &[MavMessage]) -> Vec<MavMissionResult> {
    messages
        .iter()
        .filter_map(|m| match m {
            MavMessage::MISSION_ACK(a) => Some(a.mavtype),
            _ => None,
        })
        .collect()
}

/// Uploads a home item and `n` waypoints: every item but the answer to the
/// last is exchanged.
fn upload(v: &mut Vehicle, n: u16) {
    v.send(MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
        count: n + 1,
        target_system: 1,
        target_component: 1,
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        opaque_id: 0,
    }));
    for seq in 0..=n {
        v.send(MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
            x: 291_330_000 + i32::from(seq) * 100,
            y: 1_196_400_000,
            seq,
            command: MavCmd::MAV_CMD_NAV_WAYPOINT,
            target_system: 1,
            target_component: 1,
            frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
            autocontinue: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            ..MISSION_ITEM_INT_DATA::DEFAULT
        }));
    }
}

#[test]
fn a_param_set_is_echoed_and_in_force_only_once_saved() {
    let mut v = Vehicle::new(Storage::Durable);
    v.report_all(Ok(())); // the table as loaded (boot count)
    v.take();
    v.send(param_set("WP_SPEED", 3.5));
    assert!(echoes(&v.take(), "WP_SPEED").is_empty(), "no echo before the save");
    assert_eq!(v.param("WP_SPEED"), 2.0, "not in force before the save");
    let [save] = &v.saves[..] else {
        panic!("one save: {:?}", v.saves);
    };
    let index = v.sim.core().params().index_of("WP_SPEED").unwrap();
    assert_eq!(
        save.what,
        SaveWhat::Params {
            changes: vec![(index, 3.5)]
        }
    );
    v.report_all(Ok(()));
    assert_eq!(echoes(&v.take(), "WP_SPEED"), vec![3.5]);
    assert_eq!(v.param("WP_SPEED"), 3.5);
}

#[test]
fn a_failed_param_save_echoes_the_old_value_and_says_why() {
    let mut v = Vehicle::new(Storage::Durable);
    v.report_all(Ok(()));
    v.take();
    v.send(param_set("WP_SPEED", 3.5));
    v.report_all(Err("params.parm: No space left on device (os error 28)".into()));
    let messages = v.take();
    assert_eq!(echoes(&messages, "WP_SPEED"), vec![2.0], "the old value echoed");
    assert!(texts(&messages).contains("No space left"), "{:?}", texts(&messages));
    assert_eq!(v.param("WP_SPEED"), 2.0);
    // The next save does not carry the refused change.
    v.send(param_set("WP_RADIUS", 1.5));
    let [save] = &v.saves[..] else {
        panic!("one save: {:?}", v.saves);
    };
    let radius = v.sim.core().params().index_of("WP_RADIUS").unwrap();
    assert_eq!(
        save.what,
        SaveWhat::Params {
            changes: vec![(radius, 1.5)]
        }
    );
}

#[test]
fn a_burst_of_param_sets_waits_for_one_save_in_flight_then_goes_together() {
    let mut v = Vehicle::new(Storage::Durable);
    v.report_all(Ok(()));
    v.send(param_set("WP_SPEED", 3.0));
    v.send(param_set("WP_SPEED", 3.5));
    v.send(param_set("WP_RADIUS", 1.5));
    assert_eq!(v.saves.len(), 1, "one save in flight: {:?}", v.saves);
    let first = v.saves.remove(0);
    v.take();
    v.report(first.token, Ok(()));
    assert_eq!(echoes(&v.take(), "WP_SPEED"), vec![3.0]);
    let [second] = &v.saves[..] else {
        panic!("the rest together: {:?}", v.saves);
    };
    assert!(matches!(&second.what, SaveWhat::Params { changes } if changes.len() == 2));
    v.report_all(Ok(()));
    let messages = v.take();
    assert_eq!(echoes(&messages, "WP_SPEED"), vec![3.5]);
    assert_eq!(echoes(&messages, "WP_RADIUS"), vec![1.5]);
}

#[test]
fn an_upload_is_acknowledged_and_in_force_only_once_saved() {
    let mut v = Vehicle::new(Storage::Durable);
    v.report_all(Ok(()));
    v.take();
    upload(&mut v, 3);
    assert!(acks(&v.take()).is_empty(), "no MISSION_ACK before the save");
    assert!(v.sim.core().plan(mission::MissionType::Mission).is_empty());
    let [save] = &v.saves[..] else {
        panic!("one save: {:?}", v.saves);
    };
    assert!(matches!(&save.what, SaveWhat::Plan { plan, .. } if plan.len() == 4));
    v.report_all(Ok(()));
    let messages = v.take();
    assert_eq!(acks(&messages), vec![MavMissionResult::MAV_MISSION_ACCEPTED]);
    assert_eq!(v.sim.core().plan(mission::MissionType::Mission).len(), 4);
}

#[test]
fn a_failed_plan_save_answers_error_and_keeps_the_old_plan() {
    let mut v = Vehicle::new(Storage::Durable);
    v.report_all(Ok(()));
    upload(&mut v, 2);
    v.report_all(Ok(()));
    let old = v.sim.core().plan(mission::MissionType::Mission).opaque_id();
    v.take();
    upload(&mut v, 5);
    v.report_all(Err("mission.waypoints: No space left on device (os error 28)".into()));
    let messages = v.take();
    assert_eq!(acks(&messages), vec![MavMissionResult::MAV_MISSION_ERROR]);
    assert!(texts(&messages).contains("No space left"), "{:?}", texts(&messages));
    assert_eq!(v.sim.core().plan(mission::MissionType::Mission).opaque_id(), old);
}

#[test]
fn read_only_storage_refuses_changes_and_says_so_at_connect() {
    let mut v = Vehicle::new(Storage::ReadOnly("Read-only file system (os error 30)".into()));
    assert!(
        texts(&v.take()).contains("read-only"),
        "said to the link that connected"
    );
    v.send(param_set("WP_SPEED", 3.5));
    let messages = v.take();
    assert_eq!(echoes(&messages, "WP_SPEED"), vec![2.0]);
    assert!(texts(&messages).contains("not saved"), "{:?}", texts(&messages));
    upload(&mut v, 2);
    assert_eq!(acks(&v.take()), vec![MavMissionResult::MAV_MISSION_ERROR]);
    assert!(v.sim.core().plan(mission::MissionType::Mission).is_empty());
    assert!(v.saves.is_empty(), "nothing to write: {:?}", v.saves);
    // A ground station that connects later is told too.
    v.sim.inputs_mut().link_events.push(LinkEvent::Opened {
        link: LinkId(9),
        stream_slot: 1,
    });
    v.sim.inputs_mut().link_events.push(LinkEvent::PeerJoined {
        link: LinkId(9),
        peer: autopilot::vehicle::PeerId(1),
    });
    v.step();
    assert!(texts(&v.take()).contains("read-only"));
}

/// A vehicle on a data directory, its saves written by the edge's
/// persistence on a file writer thread, as `furrow sitl` runs one.
struct DiskVehicle {
    sim: Simulation,
    persistence: Persistence,
    received: Vec<MavMessage>,
    // Dropped last: the writer thread, then the directory's lock.
    _writers: FileWriterThread,
    _data_dir: DataDir,
}

impl DiskVehicle {
    fn open(dir: &Path) -> DiskVehicle {
        let model = ModelKind::Ackermann;
        let data_dir = DataDir::open(dir, Profile::Sitl(model)).expect("data directory");
        let mut params = SimulationParams::new(model);
        let mut session = SessionParams::load(data_dir.path(), &mut params.table).expect("parameters");
        let config = SimulationConfig {
            model,
            ..SimulationConfig::default()
        };
        let mut sim = Simulation::new(&config, params);
        restore(&data_dir, &mut session, sim.core_mut());
        let writers = FileWriterThread::start();
        let persistence = Persistence::start(&data_dir, session, sim.core_mut(), &writers);
        gcs::connect(&mut sim);
        let mut v = DiskVehicle {
            sim,
            persistence,
            received: Vec::new(),
            _writers: writers,
            _data_dir: data_dir,
        };
        v.settle();
        v
    }

    /// Steps until no change waits for its save.
    fn settle(&mut self) {
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            self.persistence.collect(self.sim.inputs_mut());
            let wall = self.sim.time();
            let out = self.sim.step(wall, &mut FrozenTimer);
            self.received.extend(out.mavlink.drain(..).map(|o| o.message));
            let saves = std::mem::take(&mut out.saves);
            self.persistence.save(saves, self.sim.core());
            if !self.sim.core().is_waiting_for_saves() {
                return;
            }
            assert!(Instant::now() < deadline, "a save never finished");
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    fn command(&mut self, command: MavCmd, p1: f32) {
        gcs::send(
            &mut self.sim,
            gcs::command_long(command, [p1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        );
    }

    fn take(&mut self) -> Vec<MavMessage> {
        std::mem::take(&mut self.received)
    }
}

fn command_acks(messages: &[MavMessage], command: MavCmd) -> Vec<MavResult> {
    messages
        .iter()
        .filter_map(|m| match m {
            MavMessage::COMMAND_ACK(a) if a.command == command => Some(a.result),
            _ => None,
        })
        .collect()
}

#[test]
fn a_flight_termination_is_saved_before_its_ack_and_kept_across_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let terminate = MavCmd::MAV_CMD_DO_FLIGHTTERMINATION;
    {
        let mut v = DiskVehicle::open(dir.path());
        v.take();
        v.command(terminate, 1.0);
        // In force at once; the ACK waits for the file.
        let wall = v.sim.time();
        let out = v.sim.step(wall, &mut FrozenTimer);
        let first: Vec<MavMessage> = out.mavlink.drain(..).map(|o| o.message).collect();
        let saves = std::mem::take(&mut out.saves);
        assert!(v.sim.core().is_terminated());
        assert!(
            command_acks(&first, terminate).is_empty(),
            "acknowledged before the save"
        );
        assert!(matches!(
            &saves[..],
            [SaveRequest {
                what: SaveWhat::Termination { terminated: true },
                ..
            }]
        ));
        v.persistence.save(saves, v.sim.core());
        v.settle();
        assert_eq!(command_acks(&v.take(), terminate), [MavResult::MAV_RESULT_ACCEPTED]);
        assert_eq!(autopilot::storage::termination::load(dir.path()), Ok(true));
    }
    // The restart: still terminated, and says so; arming is refused.
    let mut v = DiskVehicle::open(dir.path());
    assert!(v.sim.core().is_terminated());
    assert!(texts(&v.take()).contains("Flight terminated before the restart"));
    v.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 1.0);
    v.settle();
    assert!(!v.sim.core().is_armed());
    // Cleared: in force once saved, and the next restart is not terminated.
    v.command(terminate, 0.0);
    v.settle();
    assert!(!v.sim.core().is_terminated());
    assert_eq!(command_acks(&v.take(), terminate), [MavResult::MAV_RESULT_ACCEPTED]);
    drop(v);
    let v = DiskVehicle::open(dir.path());
    assert!(!v.sim.core().is_terminated());
}

#[test]
fn a_termination_not_saved_still_stops_and_a_clear_not_saved_keeps_it() {
    let terminate = MavCmd::MAV_CMD_DO_FLIGHTTERMINATION;
    let mut v = Vehicle::new(Storage::Durable);
    v.report_all(Ok(()));
    v.take();
    v.send(gcs::command_long(terminate, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]));
    assert!(v.sim.core().is_terminated(), "in force before the save");
    v.report_all(Err("terminated: No space left on device (os error 28)".into()));
    let messages = v.take();
    assert_eq!(command_acks(&messages, terminate), [MavResult::MAV_RESULT_FAILED]);
    assert!(
        texts(&messages).contains("a restart would clear it"),
        "{}",
        texts(&messages)
    );
    assert!(v.sim.core().is_terminated());
    v.send(gcs::command_long(terminate, [0.0; 7]));
    assert!(v.sim.core().is_terminated(), "cleared before the save");
    v.report_all(Err("terminated: No space left on device (os error 28)".into()));
    assert_eq!(command_acks(&v.take(), terminate), [MavResult::MAV_RESULT_FAILED]);
    assert!(
        v.sim.core().is_terminated(),
        "a clear that is not saved is not in force"
    );
}
