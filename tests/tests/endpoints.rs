//! Extra `--mavlink` endpoints: a serial telemetry radio (a pseudo-terminal
//! pair stands in for it), a TCP client that connects out, a UDP listener;
//! and the `--instance` port offset.

use std::io::Write;
use std::net::{TcpListener, UdpSocket};
use std::time::Duration;

use mavlink::dialects::ardupilotmega::{COMMAND_LONG_DATA, HEARTBEAT_DATA, MavCmd, MavMessage, MavResult};
use mavlink::{MavlinkReader, MavlinkVersion};
use serialport::{SerialPort, TTYPort};
use tests::{Sitl, encode, wait_for};

fn is_heartbeat(m: &MavMessage) -> bool {
    matches!(m, MavMessage::HEARTBEAT(_))
}

#[test]
fn serial_endpoint_speaks_mavlink_both_ways() {
    let (mut master, slave) = TTYPort::pair().expect("pty pair");
    let device = slave.name().expect("pty name");
    let _sitl = Sitl::start(9, &["--mavlink", &format!("serial:{device}:57600")]);
    master.set_timeout(Duration::from_secs(5)).unwrap();
    let mut reader = MavlinkReader::new(master.try_clone_native().unwrap());
    assert!(
        wait_for(&mut reader, Duration::from_secs(10), |_, m| is_heartbeat(m)).is_some(),
        "no heartbeat on the serial link"
    );
    let request = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
        param1: 148.0,
        command: MavCmd::MAV_CMD_REQUEST_MESSAGE,
        target_system: 1,
        target_component: 1,
        ..COMMAND_LONG_DATA::DEFAULT
    });
    master.write_all(&encode(MavlinkVersion::V2, &request)).unwrap();
    let ack = wait_for(&mut reader, Duration::from_secs(5), |_, m| {
        matches!(m, MavMessage::COMMAND_ACK(_))
    });
    assert!(matches!(ack, Some(MavMessage::COMMAND_ACK(a)) if a.result == MavResult::MAV_RESULT_ACCEPTED));
}

#[test]
fn tcp_client_endpoint_connects_out() {
    let server = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = server.local_addr().unwrap().port();
    let _sitl = Sitl::start(9, &["--mavlink", &format!("tcp:127.0.0.1:{port}")]);
    let (stream, _) = server.accept().expect("furrow connects");
    stream.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let mut reader = MavlinkReader::new(stream);
    assert!(wait_for(&mut reader, Duration::from_secs(5), |_, m| is_heartbeat(m)).is_some());
}

#[test]
fn udpin_endpoint_answers_its_sender() {
    // Port 0: the OS picks it, and the ready line says which.
    let sitl = Sitl::start(9, &["--mavlink", "udpin:127.0.0.1:0"]);
    let port: u16 = sitl
        .ready_field(", listening udpin:127.0.0.1:")
        .parse()
        .expect("a port");
    let gcs = UdpSocket::bind("127.0.0.1:0").unwrap();
    gcs.set_read_timeout(Some(Duration::from_millis(500))).unwrap();
    let hb = encode(MavlinkVersion::V2, &MavMessage::HEARTBEAT(HEARTBEAT_DATA::DEFAULT));
    let mut buf = [0u8; 2048];
    for _ in 0..20 {
        gcs.send_to(&hb, ("127.0.0.1", port)).unwrap();
        if let Ok(n) = gcs.recv(&mut buf) {
            let mut reader = MavlinkReader::new(&buf[..n]);
            if reader.read_message::<MavMessage>(MavlinkVersion::V2).is_ok() {
                return;
            }
        }
    }
    panic!("udpin endpoint never answered");
}

#[test]
fn instance_offsets_the_ports_by_ten() {
    // Instance 417: TCP 5760 + 4170 = 9930. The test harness normally asks
    // for port 0; here the default must come from the instance.
    let data = tempfile::Builder::new().prefix("furrow-instance-").tempdir().unwrap();
    let mut child = std::process::Command::new(tests::furrow_bin())
        .args(["sitl", "--instance", "417", "--data-dir"])
        .arg(data.path())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufRead::read_line(&mut std::io::BufReader::new(child.stdout.take().unwrap()), &mut line).unwrap();
    let _ = child.kill();
    let _ = child.wait();
    assert!(line.contains("tcp 0.0.0.0:9930"), "{line}");
    assert!(line.contains("to 127.0.0.1:18720"), "{line}");
}
