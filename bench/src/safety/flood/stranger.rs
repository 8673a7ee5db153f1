//! A stranger's garbage on the GCS's UDP endpoint: a ground station listens
//! on the port the SITL's UDP link sends to and sends its own 1 Hz
//! HEARTBEAT, as QGroundControl does; another socket then sends
//! [`STRANGER_RATE`] garbage datagrams per second (empty, one byte, random,
//! some starting with a MAVLink marker) to the same link. Measured: the
//! largest pause between the vehicle's HEARTBEATs at the GCS, before and
//! during the flood, and whether anything was sent to the stranger.

use std::net::{SocketAddr, UdpSocket};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::{MavMessage, MavType};
use mavlink::{MavHeader, MavlinkReader, MavlinkVersion};

use super::super::Row;
use super::super::gcs_client::{SitlProcess, gcs_heartbeat};
use super::super::kill::SeededRng;
use super::sitl_args;

/// Garbage datagrams per second from the stranger (the rate the link must survive).
pub const STRANGER_RATE: u32 = 10_000;
/// The GCS's HEARTBEAT gap must stay under this with the flood on.
const MAX_HEARTBEAT_GAP: Duration = Duration::from_millis(1100);
const QUIET_SPAN: Duration = Duration::from_secs(5);
const FLOOD_SPAN: Duration = Duration::from_secs(15);
/// The stranger sends in batches this far apart.
const BATCH_PERIOD: Duration = Duration::from_millis(2);
const GCS_HEADER: MavHeader = MavHeader {
    system_id: 255,
    component_id: 190,
    sequence: 0,
};

/// What the GCS saw over one span.
#[derive(Clone, Copy, Debug, Default)]
struct Heard {
    largest_gap: Duration,
    heartbeats: u32,
}

/// What the stranger did.
#[derive(Clone, Copy, Debug, Default)]
struct Stranger {
    sent: u64,
    received: u64,
    seconds: f64,
}

pub fn run(exe: &Path, seed: u64) -> Result<Vec<Row>, String> {
    let scratch = crate::scratch_dir("furrow-flood-stranger-")?;
    let dir = scratch.path();
    let gcs = UdpSocket::bind("127.0.0.1:0").map_err(|e| format!("gcs udp: {e}"))?;
    gcs.set_read_timeout(Some(Duration::from_millis(20)))
        .map_err(|e| e.to_string())?;
    let gcs_port = gcs.local_addr().map_err(|e| e.to_string())?.port();
    let args = sitl_args(gcs_port, seed, dir);
    let sitl = SitlProcess::start(exe, &args, &dir.join("furrow.log"))?;
    let measured = measure(&gcs, sitl.udp_local, seed);
    let _ = sitl.interrupt(Duration::from_secs(10));
    let (quiet, flooded, stranger) = measured?;
    Ok(rows(&quiet, &flooded, &stranger))
}

fn measure(gcs: &UdpSocket, sitl_udp: SocketAddr, seed: u64) -> Result<(Heard, Heard, Stranger), String> {
    let quiet = listen(gcs, QUIET_SPAN)?;
    let stop = Arc::new(AtomicBool::new(false));
    let flooding = {
        let stop = stop.clone();
        std::thread::Builder::new()
            .name("stranger".into())
            .spawn(move || flood(sitl_udp, seed, &stop))
            .map_err(|e| e.to_string())?
    };
    let flooded = listen(gcs, FLOOD_SPAN);
    stop.store(true, Ordering::Relaxed);
    let stranger = flooding.join().map_err(|_| "stranger thread panicked".to_string())??;
    Ok((quiet, flooded?, stranger))
}

/// The GCS for `span`: sends its HEARTBEAT every second (once it knows the
/// vehicle's address) and times the vehicle's HEARTBEATs; the span's start
/// and end count as gap edges, so silence is never hidden.
fn listen(gcs: &UdpSocket, span: Duration) -> Result<Heard, String> {
    let start = Instant::now();
    let mut last = start;
    let mut heard = Heard::default();
    let mut next_heartbeat = start;
    let mut vehicle = None;
    let mut buf = vec![0u8; 65536];
    let mut sequence = 0u8;
    while start.elapsed() < span {
        if let Some(to) = vehicle
            && Instant::now() >= next_heartbeat
        {
            let header = MavHeader { sequence, ..GCS_HEADER };
            sequence = sequence.wrapping_add(1);
            let mut bytes = Vec::new();
            mavlink::write_versioned_msg(&mut bytes, MavlinkVersion::V2, header, &gcs_heartbeat())
                .map_err(|e| e.to_string())?;
            gcs.send_to(&bytes, to).map_err(|e| format!("gcs send: {e}"))?;
            next_heartbeat += Duration::from_secs(1);
        }
        let Ok((n, from)) = gcs.recv_from(&mut buf) else {
            continue;
        };
        vehicle.get_or_insert(from);
        if is_vehicle_heartbeat(&buf[..n]) {
            heard.largest_gap = heard.largest_gap.max(last.elapsed());
            last = Instant::now();
            heard.heartbeats += 1;
        }
    }
    heard.largest_gap = heard.largest_gap.max(last.elapsed());
    Ok(heard)
}

fn is_vehicle_heartbeat(datagram: &[u8]) -> bool {
    let mut reader = MavlinkReader::new(datagram);
    while let Ok((header, message)) = reader.read_any_message::<MavMessage>() {
        if let MavMessage::HEARTBEAT(h) = message
            && h.mavtype != MavType::MAV_TYPE_GCS
            && header.system_id == 1
        {
            return true;
        }
    }
    false
}

/// The stranger: paced batches of garbage until `stop`; it also counts
/// whatever the vehicle sends back to it.
fn flood(to: SocketAddr, seed: u64, stop: &AtomicBool) -> Result<Stranger, String> {
    let socket = UdpSocket::bind("127.0.0.1:0").map_err(|e| format!("stranger udp: {e}"))?;
    socket.set_nonblocking(true).map_err(|e| e.to_string())?;
    // Apart from the course's flood threads (seed, seed + 1).
    let mut rng = SeededRng::new(seed.wrapping_add(2));
    let mut stranger = Stranger::default();
    let mut scratch = vec![0u8; 65536];
    let start = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        let due = (start.elapsed().as_secs_f64() * f64::from(STRANGER_RATE)) as u64;
        while stranger.sent < due {
            // A full socket buffer drops the datagram; it is not counted.
            if socket.send_to(&garbage(&mut rng), to).is_ok() {
                stranger.sent += 1;
            } else {
                break;
            }
        }
        while socket.recv_from(&mut scratch).is_ok() {
            stranger.received += 1;
        }
        std::thread::sleep(BATCH_PERIOD);
    }
    stranger.seconds = start.elapsed().as_secs_f64();
    Ok(stranger)
}

/// Empty, one byte, or 2–64 random bytes, a quarter of them starting with a
/// MAVLink 1 or 2 marker.
fn garbage(rng: &mut SeededRng) -> Vec<u8> {
    let len = match rng.between(0, 9) {
        0 => 0,
        1..=3 => 1,
        _ => rng.between(2, 64) as usize,
    };
    let mut bytes: Vec<u8> = (0..len).map(|_| rng.next_u64() as u8).collect();
    if let Some(first) = bytes.first_mut() {
        *first = match rng.between(0, 7) {
            0 => 0xFD,
            1 => 0xFE,
            _ => *first,
        };
    }
    bytes
}

fn rows(quiet: &Heard, flooded: &Heard, stranger: &Stranger) -> Vec<Row> {
    let rate = if stranger.seconds > 0.0 {
        stranger.sent as f64 / stranger.seconds
    } else {
        0.0
    };
    vec![
        Row {
            part: "flood",
            case: "stranger: garbage datagrams on the GCS's UDP endpoint".into(),
            expected: format!("≥ 95 % of {STRANGER_RATE} datagrams/s"),
            measured: format!("{rate:.0} datagrams/s over {:.0} s", stranger.seconds),
            ok: rate >= 0.95 * f64::from(STRANGER_RATE),
        },
        Row {
            part: "flood",
            case: "stranger: largest HEARTBEAT gap at the UDP GCS".into(),
            expected: format!(
                "< {:.1} s, nothing sent to the stranger",
                MAX_HEARTBEAT_GAP.as_secs_f64()
            ),
            measured: format!(
                "flood {:.3} s ({} in {} s), quiet {:.3} s ({} in {} s); {} datagrams to the stranger",
                flooded.largest_gap.as_secs_f64(),
                flooded.heartbeats,
                FLOOD_SPAN.as_secs(),
                quiet.largest_gap.as_secs_f64(),
                quiet.heartbeats,
                QUIET_SPAN.as_secs(),
                stranger.received
            ),
            ok: flooded.largest_gap < MAX_HEARTBEAT_GAP && flooded.heartbeats > 0 && stranger.received == 0,
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn garbage_is_never_a_frame_the_link_would_take() {
        let mut rng = SeededRng::new(3);
        let mut stats = autopilot::link::frame::FrameStats::default();
        let mut frames = 0;
        let mut lengths = [0usize; 3];
        for _ in 0..10_000 {
            let datagram = garbage(&mut rng);
            lengths[datagram.len().min(2)] += 1;
            autopilot::link::frame::frame_datagram(&datagram, &mut stats, |_| frames += 1);
        }
        assert_eq!(frames, 0);
        assert!(lengths.iter().all(|&n| n > 500), "{lengths:?}");
    }

    #[test]
    fn a_heartbeat_is_recognised_only_from_the_vehicle() {
        let mut bytes = Vec::new();
        let vehicle = MavHeader {
            system_id: 1,
            component_id: 1,
            sequence: 0,
        };
        let rover = MavMessage::HEARTBEAT(mavlink::dialects::ardupilotmega::HEARTBEAT_DATA {
            mavtype: MavType::MAV_TYPE_GROUND_ROVER,
            ..mavlink::dialects::ardupilotmega::HEARTBEAT_DATA::DEFAULT
        });
        mavlink::write_versioned_msg(&mut bytes, MavlinkVersion::V2, vehicle, &rover).unwrap();
        assert!(is_vehicle_heartbeat(&bytes));
        let mut gcs = Vec::new();
        mavlink::write_versioned_msg(&mut gcs, MavlinkVersion::V2, GCS_HEADER, &gcs_heartbeat()).unwrap();
        assert!(!is_vehicle_heartbeat(&gcs));
        assert!(!is_vehicle_heartbeat(&[0xFD]));
    }
}
