//! The link layer from outside: MAVLink 1 in, MAVLink 2 out; the UDP link
//! answers every ground station that talks to it and no stranger; garbage
//! is survived.

use std::io::Write;
use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

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
        if is_vehicle_heartbeat(&buf[..n]) {
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

fn gcs_heartbeat() -> Vec<u8> {
    encode(
        MavlinkVersion::V2,
        &MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            mavtype: MavType::MAV_TYPE_GCS,
            ..HEARTBEAT_DATA::DEFAULT
        }),
    )
}

/// A ground station's UDP socket (short reads, so loops keep their pace).
fn udp_gcs() -> UdpSocket {
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    socket.set_read_timeout(Some(Duration::from_millis(20))).unwrap();
    socket
}

/// Whether `datagram` holds the vehicle's HEARTBEAT.
/// Whether a datagram carries a vehicle HEARTBEAT (a datagram may carry
/// several frames: the vehicle gathers them up to one datagram's size).
fn is_vehicle_heartbeat(datagram: &[u8]) -> bool {
    let mut reader = MavlinkReader::new(datagram);
    while let Ok((h, message)) = reader.read_any_message::<MavMessage>() {
        if h.system_id == 1 && matches!(message, MavMessage::HEARTBEAT(_)) {
            return true;
        }
    }
    false
}

/// Reads `socket` for `span`: the vehicle HEARTBEATs' largest gap (wall
/// clock; from the start and to the end too) and how many came.
fn heartbeat_gap(socket: &UdpSocket, span: Duration) -> (Duration, usize) {
    let start = Instant::now();
    let mut last = start;
    let mut largest = Duration::ZERO;
    let mut count = 0;
    let mut buf = [0u8; 4096];
    while start.elapsed() < span {
        if let Ok(n) = socket.recv(&mut buf)
            && is_vehicle_heartbeat(&buf[..n])
        {
            largest = largest.max(last.elapsed());
            last = Instant::now();
            count += 1;
        }
    }
    (largest.max(last.elapsed()), count)
}

/// Sends empty, 1-byte and random datagrams to `to` at 100/s from its own
/// socket for `span`; returns how many datagrams came back to it.
fn stranger_floods(to: SocketAddr, span: Duration) -> std::thread::JoinHandle<usize> {
    std::thread::spawn(move || {
        let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
        socket.set_nonblocking(true).unwrap();
        let mut x: u32 = 0x9e37_79b9;
        let mut received = 0;
        let mut buf = [0u8; 4096];
        let start = Instant::now();
        let mut i = 0u32;
        while start.elapsed() < span {
            let len = match i % 4 {
                0 => 0,
                1 | 2 => 1,
                _ => 48,
            };
            let datagram: Vec<u8> = (0..len)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 17;
                    x ^= x << 5;
                    x as u8
                })
                .collect();
            socket.send_to(&datagram, to).unwrap();
            i += 1;
            while socket.recv(&mut buf).is_ok() {
                received += 1;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        received
    })
}

#[test]
fn a_strangers_garbage_never_diverts_udp_telemetry() {
    // The GCS listens on the UDP link's port and speaks once; a stranger
    // then sends garbage at 100 datagrams/s. Before the fix, the first
    // datagram took the link and the GCS heard nothing more.
    let gcs = udp_gcs();
    let sitl = Sitl::start(gcs.local_addr().unwrap().port(), &[]);
    let (gap, count) = heartbeat_gap(&gcs, Duration::from_secs(2));
    assert!(count > 0, "no telemetry before the flood");
    gcs.send_to(&gcs_heartbeat(), sitl.udp_local).unwrap();
    let stranger = stranger_floods(sitl.udp_local, Duration::from_secs(4));
    let (flood_gap, flood_count) = heartbeat_gap(&gcs, Duration::from_secs(4));
    let stranger_received = stranger.join().unwrap();
    assert!(
        flood_gap < Duration::from_millis(1100),
        "HEARTBEAT gap {flood_gap:?} under garbage ({flood_count} heard; {gap:?} before)"
    );
    assert_eq!(stranger_received, 0, "the stranger drew the telemetry");
}

#[test]
fn ground_stations_on_several_addresses_of_one_udp_endpoint_are_all_served() {
    // One GCS only listens on the configured port; two more speak from
    // their own ports. Before the fix, the last to speak took the link.
    let listener = udp_gcs();
    let sitl = Sitl::start(listener.local_addr().unwrap().port(), &[]);
    let speakers = [udp_gcs(), udp_gcs()];
    for speaker in &speakers {
        speaker.send_to(&gcs_heartbeat(), sitl.udp_local).unwrap();
    }
    for (name, socket) in [
        ("listener", &listener),
        ("first", &speakers[0]),
        ("second", &speakers[1]),
    ] {
        let (gap, count) = heartbeat_gap(socket, Duration::from_secs(2));
        assert!(
            count >= 2 && gap < Duration::from_millis(1100),
            "{name}: {count} heartbeats, gap {gap:?}"
        );
    }
}
