//! The onboard log from the core's side: one file per arming, holding the
//! parameters, the mission, the mode changes and the drive (course, NTUN
//! cross-track, the precision stop), read back with Furrow's reader.

mod common;

use autopilot::logging::LogCommand;
use autopilot::logging::format::write_header;
use autopilot::logging::messages::ALL;
use autopilot::logging::reader::DataFlashLog;
use autopilot::sitl::simulation::ModelKind;
use autopilot::time::FrozenTimer;
use common::{Harness, item};
use mavlink::dialects::ardupilotmega::MavCmd;
use mission::command::{cmd, frame};
use mission::{ExecState, MissionType, Plan};

fn step(h: &mut Harness, log: &mut Vec<LogCommand>) {
    let wall = h.sim.time();
    let out = h.sim.step(wall, &mut FrozenTimer);
    h.received.append(&mut out.mavlink);
    log.append(&mut out.log);
}

/// The files the commands describe, as the writer would put them on disk.
fn files(commands: &[LogCommand]) -> Vec<Vec<u8>> {
    let mut files = Vec::new();
    let mut open: Option<Vec<u8>> = None;
    for c in commands {
        match c {
            LogCommand::Open(_) => {
                files.extend(open.take());
                let mut header = Vec::new();
                write_header(&mut header, 0, ALL);
                open = Some(header);
            }
            LogCommand::Records(bytes) => open.as_mut().expect("records only into an open file").extend(bytes),
            LogCommand::Close => files.extend(open.take()),
            LogCommand::Request { .. } | LogCommand::LinkClosed(_) => {}
        }
    }
    files.extend(open);
    files
}

#[test]
fn an_auto_drive_is_logged_in_one_file_with_its_course_and_cross_track() {
    let mut h = Harness::new(3, ModelKind::Ackermann);
    let wp = |seq, n, e| item(seq, cmd::NAV_WAYPOINT, frame::LOCAL_NED, [0.0; 4], n, e);
    let plan = Plan::new(
        MissionType::Mission,
        vec![wp(0, 0.0, 0.0), wp(1, 25.0, 0.0), wp(2, 25.0, 20.0)],
    );
    h.sim.core_mut().load_plan(MissionType::Mission, plan);
    let mut log = Vec::new();
    for _ in 0..100 {
        step(&mut h, &mut log);
    }
    assert!(files(&log).is_empty(), "nothing logged while disarmed (LOG_DISARMED 0)");
    h.arm();
    h.set_mode(10);
    let mut done = false;
    for _ in 0..50 * 120 {
        step(&mut h, &mut log);
        if h.sim.core().mission_state() == ExecState::Complete {
            done = true;
            break;
        }
    }
    assert!(done, "mission did not complete: {:?}", h.texts());
    for _ in 0..50 {
        step(&mut h, &mut log);
    }
    h.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [0.0; 7]);
    for _ in 0..100 {
        step(&mut h, &mut log);
    }
    assert!(!h.sim.core().is_armed());

    let files = files(&log);
    assert_eq!(files.len(), 1, "one file for the arming");
    let dflog = DataFlashLog::parse(&files[0]);
    assert_eq!(dflog.skipped_bytes, 0);
    let counts = dflog.counts();
    assert_eq!(counts["PARM"], h.sim.core().params().len());
    assert_eq!(counts["CMD"], 3);
    let events: Vec<f64> = dflog.messages("EV").filter_map(|m| m.get("Id")).collect();
    assert_eq!(events, vec![10.0, 11.0], "armed, then disarmed");
    assert!(
        dflog.messages("MODE").any(|m| m.get("ModeNum") == Some(10.0)),
        "AUTO logged"
    );
    assert!(
        dflog
            .messages("MSG")
            .any(|m| m.text("Message") == Some("Mission Complete"))
    );
    assert!(
        counts["GPS"] > 100 && counts["ATT"] > 1000 && counts["PIDA"] > 1000,
        "{counts:?}"
    );

    // The course: the logged (estimated) positions follow the legs and
    // end where the vehicle truly stopped.
    let frame = autopilot::geo::LocalFrame::new(h.sim.core().home().expect("home"));
    let course: Vec<_> = dflog
        .messages("POS")
        .map(|m| {
            frame.to_local(&autopilot::geo::GeoPoint::new(
                m.get("Lat").unwrap(),
                m.get("Lng").unwrap(),
                0.0,
            ))
        })
        .collect();
    let truth = h.sim.world().truth();
    let end = course.last().expect("POS");
    assert!(
        (end.north_m - truth.north_m).hypot(end.east_m - truth.east_m) < 0.05,
        "logged end {end:?}, truth {truth:?}"
    );
    assert!(
        (end.north_m - 25.0).abs() < 1.0 && (end.east_m - 20.0).abs() < 1.0,
        "{end:?}"
    );
    let on_first_leg = course.iter().filter(|p| p.north_m > 1.0 && p.north_m < 15.0);
    assert!(on_first_leg.clone().count() > 100);
    assert!(on_first_leg.map(|p| p.east_m.abs()).fold(0.0, f64::max) < 0.3);
    // NTUN's cross-track: present all along the drive, and as small as
    // the navigation tests bound it.
    let xtrack: Vec<f64> = dflog.messages("NTUN").filter_map(|m| m.get("XTrack")).collect();
    assert!(xtrack.len() > 500, "{} NTUN", xtrack.len());
    let worst = xtrack.iter().fold(0.0f64, |w, x| w.max(x.abs()));
    assert!(worst < 0.3, "worst cross-track {worst} m");
    assert!(xtrack.iter().any(|x| *x != 0.0));
    let stop = dflog.messages("PSTP").last().expect("the final precision stop");
    assert_eq!(stop.get("Ok"), Some(1.0));
    assert!(
        counts["PREV"] > 500 && counts["PIDL"] > 500 && counts["EKFI"] > 500,
        "{counts:?}"
    );
    // Time runs forwards.
    let times: Vec<f64> = dflog.messages("ATT").filter_map(|m| m.time_s()).collect();
    assert!(times.windows(2).all(|w| w[1] > w[0]));
}

#[test]
fn log_disarmed_logs_from_start_and_each_arming_starts_a_file() {
    let mut h = Harness::new(4, ModelKind::Ackermann);
    h.sim.core_mut().params_mut().set_by_name("LOG_DISARMED", 1.0).unwrap();
    let mut log = Vec::new();
    for _ in 0..150 {
        step(&mut h, &mut log);
    }
    assert_eq!(files(&log).len(), 1, "logging from start-up");
    for _ in 0..2 {
        h.arm();
        for _ in 0..50 {
            step(&mut h, &mut log);
        }
        assert!(h.sim.core().is_armed(), "{:?}", h.texts());
        h.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [0.0; 7]);
        for _ in 0..50 {
            step(&mut h, &mut log);
        }
    }
    let files = files(&log);
    assert_eq!(files.len(), 3, "start-up, then one per arming");
    let events = |bytes: &Vec<u8>| -> Vec<f64> {
        DataFlashLog::parse(bytes)
            .messages("EV")
            .filter_map(|m| m.get("Id"))
            .collect()
    };
    assert!(events(&files[0]).is_empty());
    assert_eq!(
        events(&files[1]),
        vec![10.0, 11.0],
        "the disarm is in the arming's file"
    );
    assert_eq!(events(&files[2]), vec![10.0, 11.0]);
    // With the backend off nothing more is logged.
    h.sim
        .core_mut()
        .params_mut()
        .set_by_name("LOG_BACKEND_TYPE", 0.0)
        .unwrap();
    let mut after = Vec::new();
    step(&mut h, &mut after);
    assert!(
        matches!(
            after.as_slice(),
            [LogCommand::Records(_), LogCommand::Close] | [LogCommand::Close]
        ),
        "{after:?}"
    );
    step(&mut h, &mut after);
    assert!(after.len() <= 2);
}
