//! `furrow status --tcp HOST:PORT`: asks a running furrow for its device
//! table over MAVLink (the request `furrow run` answers at its edge) and
//! prints it — a ground station's view, over the same link one uses.

use std::io::{Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega::{COMMAND_LONG_DATA, HEARTBEAT_DATA, MavMessage, MavResult, MavType};

use super::runner::{DEVICE_LINE_PREFIX, DEVICE_TABLE_END, STATUS_COMMAND};
use crate::link::encode::encode_v2;
use crate::link::frame::StreamFramer;

#[derive(clap::Args, Debug)]
pub struct StatusArgs {
    /// The vehicle's TCP MAVLink server, HOST:PORT.
    #[arg(long, default_value = "127.0.0.1:5760")]
    pub tcp: String,
    /// Give up after this many seconds.
    #[arg(long, default_value_t = 5.0)]
    pub timeout_s: f64,
}

/// Connects, asks, prints one line per device; an error if no table came.
pub fn run(args: &StatusArgs) -> Result<(), String> {
    let lines = fetch(
        &args.tcp,
        crate::time::duration_from_secs(args.timeout_s.clamp(0.1, 600.0)),
    )?;
    for line in lines {
        println!("{line}");
    }
    Ok(())
}

/// The device lines (without the prefix) from the vehicle at `address`.
pub fn fetch(address: &str, timeout: Duration) -> Result<Vec<String>, String> {
    let mut stream = connect(address, timeout)?;
    let deadline = Instant::now() + timeout;
    let mut framer = StreamFramer::new();
    let mut buf = [0u8; 4096];
    let mut lines = Vec::new();
    let mut next_request = Instant::now();
    let mut target_system = 0u8;
    while Instant::now() < deadline {
        if Instant::now() >= next_request {
            next_request = Instant::now() + Duration::from_secs(1);
            send_request(&mut stream, address, target_system)?;
        }
        let n = match stream.read(&mut buf) {
            Ok(0) => return Err(format!("{address}: the vehicle closed the connection")),
            Ok(n) => n,
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => continue,
            Err(e) => return Err(format!("{address}: {e}")),
        };
        let mut done = false;
        let mut refused = None;
        framer.push(&buf[..n], |frame| match frame.message {
            Ok(MavMessage::HEARTBEAT(_)) => target_system = u8::try_from(frame.header.system_id).unwrap_or(0),
            Ok(MavMessage::COMMAND_ACK(ack))
                if ack.command == STATUS_COMMAND && ack.result != MavResult::MAV_RESULT_ACCEPTED =>
            {
                refused = Some(ack.result);
            }
            Ok(MavMessage::STATUSTEXT(t)) => {
                let text = t.text.to_str().unwrap_or("").trim_end_matches('\0').to_string();
                if text == DEVICE_TABLE_END {
                    done = true;
                } else if let Some(line) = text.strip_prefix(DEVICE_LINE_PREFIX)
                    && !done
                {
                    lines.push(line.to_string());
                }
            }
            _ => {}
        });
        if let Some(result) = refused {
            return Err(format!(
                "{address}: the vehicle refused the status request ({result:?}); is it `furrow run`?"
            ));
        }
        if done {
            return Ok(lines);
        }
    }
    Err(format!(
        "{address}: no device table within {:.1} s",
        timeout.as_secs_f64()
    ))
}

/// A TCP connection to the vehicle at `address`, with a short read timeout
/// so the caller can resend its request while it waits.
fn connect(address: &str, timeout: Duration) -> Result<TcpStream, String> {
    let target = address
        .to_socket_addrs()
        .map_err(|e| format!("{address}: {e}"))?
        .next()
        .ok_or_else(|| format!("{address}: no address"))?;
    let stream = TcpStream::connect_timeout(&target, timeout).map_err(|e| format!("{address}: {e}"))?;
    stream
        .set_read_timeout(Some(Duration::from_millis(100)))
        .map_err(|e| format!("{address}: {e}"))?;
    Ok(stream)
}

/// A GCS heartbeat (so the vehicle streams to us) and the device-status
/// command, addressed to `target_system` (0 until its heartbeat is heard).
fn send_request(stream: &mut TcpStream, address: &str, target_system: u8) -> Result<(), String> {
    let header = MavHeader {
        system_id: 255,
        component_id: 190,
        sequence: 0,
    };
    let heartbeat = MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        mavtype: MavType::MAV_TYPE_GCS,
        ..HEARTBEAT_DATA::default()
    });
    let request = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
        command: STATUS_COMMAND,
        target_system,
        target_component: 0,
        ..COMMAND_LONG_DATA::default()
    });
    for message in [&heartbeat, &request] {
        stream
            .write_all(&encode_v2(header, message))
            .map_err(|e| format!("{address}: {e}"))?;
    }
    Ok(())
}
