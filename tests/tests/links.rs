//! The link layer from outside: MAVLink 1 in, MAVLink 2 out; the UDP link
//! answers whoever talks to it; garbage is survived.

use std::io::Write;
use std::net::UdpSocket;
use std::time::Duration;

use mavlink::dialects::ardupilotmega::{COMMAND_LONG_DATA, HEARTBEAT_DATA, MavCmd, MavMessage, MavResult, MavType};
use mavlink::{MavlinkReader, MavlinkVersion};
use tests::{Sitl, encode, wait_for};

fn request_autopilot_version() -> MavMessage {
    MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
        param1: 148.0,
        command: MavCmd::MAV_CMD_REQUEST_MESSAGE,
        target_system: 1,
        target_component: 1,
        ..COMMAND_LONG_DATA::DEFAULT
    })
}

#[test]
fn mavlink1_request_gets_a_mavlink2_answer_over_tcp() {
    let sitl = Sitl::start(9, &[]);
    let (mut stream, mut reader) = sitl.connect();
    let hb = wait_for(&mut reader, Duration::from_secs(5), |_, m| {
        matches!(m, MavMessage::HEARTBEAT(_))
    });
    match hb {
        Some(MavMessage::HEARTBEAT(h)) => assert_eq!(h.mavtype, MavType::MAV_TYPE_GROUND_ROVER),
        other => panic!("no heartbeat: {other:?}"),
    }
    stream
        .write_all(&encode(MavlinkVersion::V1, &request_autopilot_version()))
        .unwrap();
    let ack = wait_for(
        &mut reader,
        Duration::from_secs(5),
        |_, m| matches!(m, MavMessage::COMMAND_ACK(a) if a.command == MavCmd::MAV_CMD_REQUEST_MESSAGE),
    );
    assert!(matches!(ack, Some(MavMessage::COMMAND_ACK(a)) if a.result == MavResult::MAV_RESULT_ACCEPTED));
    assert!(
        wait_for(&mut reader, Duration::from_secs(5), |_, m| matches!(
            m,
            MavMessage::AUTOPILOT_VERSION(_)
        ))
        .is_some()
    );
}

#[test]
fn udp_link_answers_the_address_that_talks_to_it() {
    // Nobody listens on the default peer port; a GCS on another port speaks
    // first and from then on gets the telemetry.
    let sitl = Sitl::start(9, &[]);
    let gcs = UdpSocket::bind("127.0.0.1:0").unwrap();
    gcs.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let hb = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        mavtype: MavType::MAV_TYPE_GCS,
        ..HEARTBEAT_DATA::DEFAULT
    });
    gcs.send_to(&encode(MavlinkVersion::V2, &hb), sitl.udp_local).unwrap();
    let mut buf = [0u8; 2048];
    let mut heard = false;
    for _ in 0..50 {
        let Ok(n) = gcs.recv(&mut buf) else { continue };
        let mut reader = MavlinkReader::new(&buf[..n]);
        if let Ok((h, MavMessage::HEARTBEAT(_))) = reader.read_any_message::<MavMessage>() {
            assert_eq!(h.system_id, 1);
            heard = true;
            break;
        }
    }
    assert!(heard, "no telemetry on the new UDP peer");
}

#[test]
fn garbage_on_one_link_leaves_the_others_talking() {
    let mut sitl = Sitl::start(9, &[]);
    let (mut bad, _) = sitl.connect();
    let (_good, mut reader) = sitl.connect();
    let mut x: u32 = 12345;
    let mut junk = vec![0u8; 200_000];
    for b in junk.iter_mut() {
        // xorshift: arbitrary bytes, deterministic, with MAVLink markers in.
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        *b = x as u8;
    }
    bad.write_all(&junk).unwrap();
    let mut heartbeats = 0;
    for _ in 0..3 {
        if wait_for(&mut reader, Duration::from_secs(3), |_, m| {
            matches!(m, MavMessage::HEARTBEAT(_))
        })
        .is_some()
        {
            heartbeats += 1;
        }
    }
    assert_eq!(heartbeats, 3);
    assert!(sitl.is_running());
}
