//! Load: the AGV course runs in AUTO at real speed while `rate` MAVLink
//! messages per second are flooded in, half over UDP and half over a second
//! TCP client, by paced threads: GCS heartbeats, parameter reads, harmless
//! commands (REQUEST_MESSAGE), mission list requests and garbage bytes; no
//! message that drives the vehicle. An observer ground station on TCP
//! uploads the course, arms, starts AUTO and records what it receives.
//!
//! The same course segment runs twice with the same seed, without and with
//! the flood; compared: deadline misses (the exit report), cross-track
//! error (NAV_CONTROLLER_OUTPUT), the largest gap in the observer's
//! telemetry, the mission item reached.
//!
//! Then a stranger floods the UDP link a GCS listens on with garbage
//! ([`stranger`]): the GCS's HEARTBEAT gaps must not change.

mod stranger;

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream, UdpSocket};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::{
    COMMAND_LONG_DATA, MISSION_REQUEST_LIST_DATA, MavCmd, MavMessage, MavMissionType, MavResult,
    PARAM_REQUEST_READ_DATA,
};
use mavlink::{MavHeader, MavlinkVersion};
use mission::{MissionType, validate_plan};

use super::Row;
use super::gcs_client::{GcsClient, MODE_AUTO, SitlProcess, VEHICLE, gcs_heartbeat};
use super::kill::SeededRng;

/// The bench AGV course (tests/data/bench), built in.
const COURSE: &str = include_str!("../../../tests/data/bench/agv_course.waypoints");
/// Simulated seconds of the course compared (from AUTO).
const SEGMENT: Duration = Duration::from_secs(80);
/// Cross-track p99 may differ by this much, or by [`XTRACK_TOLERANCE_REL`].
const XTRACK_TOLERANCE_M: f64 = 0.01;
const XTRACK_TOLERANCE_REL: f64 = 0.10;
/// The observer's ATTITUDE may pause at most this long; its HEARTBEAT (1 Hz)
/// at most [`MAX_HEARTBEAT_GAP`], i.e. none missed.
const MAX_TELEMETRY_GAP: Duration = Duration::from_secs(1);
const MAX_HEARTBEAT_GAP: Duration = Duration::from_millis(1500);
/// NAV_CONTROLLER_OUTPUT is asked for at this interval (10 Hz), for enough
/// cross-track samples.
const NAV_OUTPUT_INTERVAL_US: f32 = 100_000.0;
/// The flood threads send in batches this far apart.
const BATCH_PERIOD: Duration = Duration::from_millis(2);
/// System ids of the flooding ground stations (not SYSID_MYGCS).
const UDP_FLOOD_SYSID: u8 = 254;
const TCP_FLOOD_SYSID: u8 = 253;

pub fn run(exe: &Path, rate: u32, seed: u64) -> Result<Vec<Row>, String> {
    let quiet = course_run(exe, 0, seed)?;
    let flooded = course_run(exe, rate, seed)?;
    let mut rows = rows(rate, &quiet, &flooded);
    rows.extend(stranger::run(exe, seed)?);
    Ok(rows)
}

/// What the exit report line says.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct ExitReport {
    tick_p99_us: f64,
    overruns: u64,
    pacing_restarts: u64,
    dropped_to_links: u64,
    late_ticks: u64,
}

/// One run of the course segment.
#[derive(Debug, Default)]
struct CourseRun {
    xtrack_p99_m: f64,
    xtrack_samples: usize,
    heartbeat_gap: Duration,
    attitude_gap: Duration,
    item_reached: u16,
    exit: ExitReport,
    flood: FloodCounts,
    /// Frames the flooded links framed (hub report), and inbound messages
    /// dropped because the core's queue was full.
    absorbed_frames: u64,
    dropped_to_core: u64,
    /// The machine's 1-minute load average at the end (other processes
    /// compete for the CPU; a preempted task counts as an overrun).
    load_average: f64,
}

#[derive(Clone, Copy, Debug, Default)]
struct FloodCounts {
    udp_messages: u64,
    tcp_messages: u64,
    garbage_chunks: u64,
    seconds: f64,
}

impl FloodCounts {
    fn messages(&self) -> u64 {
        self.udp_messages + self.tcp_messages
    }

    fn per_second(&self, n: u64) -> f64 {
        if self.seconds > 0.0 {
            n as f64 / self.seconds
        } else {
            0.0
        }
    }
}

/// A real-time SITL that sends its UDP telemetry to `udp_port` on loopback,
/// with its data under `dir`.
fn sitl_args(udp_port: u16, seed: u64, dir: &Path) -> Vec<String> {
    let data = dir.join("data").display().to_string();
    [
        "--speedup",
        "1",
        "--tcp-port",
        "0",
        "--udp-port",
        &udp_port.to_string(),
        "--seed",
        &seed.to_string(),
        "--data-dir",
        &data,
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

fn course_run(exe: &Path, rate: u32, seed: u64) -> Result<CourseRun, String> {
    let tag = if rate == 0 { "quiet" } else { "flood" };
    let scratch = crate::scratch_dir(&format!("furrow-flood-{tag}-"))?;
    let dir = scratch.path();
    // The SITL's UDP link sends to this socket, which floods it back.
    let udp = UdpSocket::bind("127.0.0.1:0").map_err(|e| format!("udp: {e}"))?;
    let udp_port = udp.local_addr().map_err(|e| e.to_string())?.port();
    let args = sitl_args(udp_port, seed, dir);
    let sitl = SitlProcess::start(exe, &args, &dir.join("furrow.log"))?;
    let result = drive_course(&sitl, udp, rate, seed);
    let stopped = sitl.interrupt(Duration::from_secs(10));
    let log = sitl.stderr();
    let mut driven = result?;
    stopped?;
    driven.run.load_average = std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|l| l.split(' ').next().and_then(|v| v.parse().ok()))
        .unwrap_or(f64::NAN);
    let mut run = driven.run;
    run.exit = parse_exit_report(&log).ok_or_else(|| format!("{tag} run: no exit report in the log"))?;
    (run.absorbed_frames, run.dropped_to_core) = flood_link_counts(&log, &driven.flood_link_names);
    Ok(run)
}

/// A course run and the names the hub gives the flooding links.
struct Driven {
    run: CourseRun,
    flood_link_names: Vec<String>,
}

fn drive_course(sitl: &SitlProcess, udp: UdpSocket, rate: u32, seed: u64) -> Result<Driven, String> {
    let items = mission::files::wpl::parse(COURSE).map_err(|e| format!("course: {e}"))?;
    let plan = validate_plan(MissionType::Mission, items).map_err(|(seq, r)| format!("course item {seq}: {r:?}"))?;
    let mut observer = GcsClient::connect(sitl.tcp_port)?;
    observer.wait_heartbeat(Duration::from_secs(10))?;
    observer.upload_mission(plan.items(), |_| {})?;
    observer.command(
        MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
        [62.0, NAV_OUTPUT_INTERVAL_US, 0.0, 0.0, 0.0, 0.0, 0.0],
    )?;
    // Arming waits for the first position fix.
    let armed_by = Instant::now() + Duration::from_secs(30);
    while observer.arm()? != MavResult::MAV_RESULT_ACCEPTED {
        if Instant::now() > armed_by {
            return Err("not armed within 30 s".into());
        }
        observer.heartbeat()?;
        std::thread::sleep(Duration::from_millis(500));
    }
    let stop = Arc::new(AtomicBool::new(false));
    let mut flood_link_names = vec![format!(
        "udp to 127.0.0.1:{}",
        udp.local_addr().map_err(|e| e.to_string())?.port()
    )];
    let mut threads = Vec::new();
    if rate > 0 {
        let tcp = TcpStream::connect(("127.0.0.1", sitl.tcp_port)).map_err(|e| format!("flood tcp: {e}"))?;
        flood_link_names.push(format!("tcp client {}", tcp.local_addr().map_err(|e| e.to_string())?));
        let udp_rate = f64::from(rate) / 2.0;
        threads.push(spawn_flood(
            Sink::Udp(udp, sitl.udp_local),
            udp_rate,
            UDP_FLOOD_SYSID,
            seed,
            stop.clone(),
        )?);
        threads.push(spawn_flood(
            Sink::Tcp(tcp),
            f64::from(rate) - udp_rate,
            TCP_FLOOD_SYSID,
            seed + 1,
            stop.clone(),
        )?);
    }
    let result = (|| {
        if observer.set_mode(MODE_AUTO)? != MavResult::MAV_RESULT_ACCEPTED {
            return Err("AUTO refused".to_string());
        }
        observe(&mut observer)
    })();
    stop.store(true, Ordering::Relaxed);
    let mut flood = FloodCounts::default();
    for t in threads {
        let (counts, is_udp) = t.join().map_err(|_| "flood thread panicked".to_string())?;
        if is_udp {
            flood.udp_messages = counts.udp_messages;
        } else {
            flood.tcp_messages = counts.tcp_messages;
        }
        flood.garbage_chunks += counts.garbage_chunks;
        flood.seconds = flood.seconds.max(counts.seconds);
    }
    // The hub reports a link's counters every 2 s while its error counts
    // change: the flood's last garbage is reported with complete counts.
    std::thread::sleep(Duration::from_millis(2500));
    let mut run = result?;
    run.flood = flood;
    Ok(Driven { run, flood_link_names })
}

/// Reads the observer's telemetry over the course segment (simulated time
/// from ATTITUDE.time_boot_ms).
fn observe(observer: &mut GcsClient) -> Result<CourseRun, String> {
    let wall_limit = Instant::now() + SEGMENT.mul_f64(1.5) + Duration::from_secs(10);
    let mut start_ms = None;
    let mut xtrack = Vec::new();
    let mut item_reached = 0;
    let mut last_heartbeat = Instant::now();
    let mut last_attitude = Instant::now();
    let mut heartbeat_gap = Duration::ZERO;
    let mut attitude_gap = Duration::ZERO;
    let mut next_gcs_heartbeat = Instant::now();
    loop {
        let now = Instant::now();
        if now > wall_limit {
            return Err(format!("the course segment did not end within {wall_limit:?}"));
        }
        if now >= next_gcs_heartbeat {
            observer.heartbeat()?;
            next_gcs_heartbeat = now + Duration::from_secs(1);
        }
        let Some(message) = observer.recv(now + Duration::from_millis(200))? else {
            continue;
        };
        let at = Instant::now();
        match message {
            MavMessage::HEARTBEAT(h) if h.mavtype != mavlink::dialects::ardupilotmega::MavType::MAV_TYPE_GCS => {
                heartbeat_gap = heartbeat_gap.max(at - last_heartbeat);
                last_heartbeat = at;
            }
            MavMessage::ATTITUDE(a) => {
                attitude_gap = attitude_gap.max(at - last_attitude);
                last_attitude = at;
                let start = *start_ms.get_or_insert(a.time_boot_ms);
                if u64::from(a.time_boot_ms.saturating_sub(start)) >= SEGMENT.as_millis() as u64 {
                    break;
                }
            }
            MavMessage::NAV_CONTROLLER_OUTPUT(n) if start_ms.is_some() => xtrack.push(f64::from(n.xtrack_error.abs())),
            MavMessage::MISSION_CURRENT(c) => item_reached = item_reached.max(c.seq),
            _ => {}
        }
    }
    Ok(CourseRun {
        xtrack_p99_m: quantile(&mut xtrack, 0.99),
        xtrack_samples: xtrack.len(),
        heartbeat_gap,
        attitude_gap,
        item_reached,
        ..CourseRun::default()
    })
}

fn quantile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    values.sort_by(f64::total_cmp);
    let i = ((values.len() - 1) as f64 * q).round() as usize;
    values[i.min(values.len() - 1)]
}

enum Sink {
    Udp(UdpSocket, SocketAddr),
    Tcp(TcpStream),
}

/// Starts a paced flooding thread; it returns its counts and whether it was
/// the UDP one.
fn spawn_flood(
    sink: Sink,
    rate: f64,
    sysid: u8,
    seed: u64,
    stop: Arc<AtomicBool>,
) -> Result<JoinHandle<(FloodCounts, bool)>, String> {
    let is_udp = matches!(sink, Sink::Udp(..));
    // The TCP flooder reads what comes back, as a ground station would.
    let drain = match &sink {
        Sink::Tcp(stream) => Some(stream.try_clone().map_err(|e| e.to_string())?),
        Sink::Udp(socket, _) => {
            socket.set_nonblocking(true).map_err(|e| e.to_string())?;
            None
        }
    };
    if let Some(mut reader) = drain {
        let stop = stop.clone();
        reader
            .set_read_timeout(Some(Duration::from_millis(200)))
            .map_err(|e| e.to_string())?;
        std::thread::spawn(move || {
            let mut buf = vec![0u8; 65536];
            while !stop.load(Ordering::Relaxed) {
                match reader.read(&mut buf) {
                    Ok(0) => return,
                    Ok(_) => {}
                    Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {}
                    Err(_) => return,
                }
            }
        });
    }
    std::thread::Builder::new()
        .name("flood".into())
        .spawn(move || (flood(sink, rate, sysid, seed, &stop), is_udp))
        .map_err(|e| e.to_string())
}

fn flood(mut sink: Sink, rate: f64, sysid: u8, seed: u64, stop: &AtomicBool) -> FloodCounts {
    let mut rng = SeededRng::new(seed);
    let mut counts = FloodCounts::default();
    let mut sequence = 0u8;
    let mut sent = 0u64;
    let mut batch = Vec::new();
    let mut scratch = vec![0u8; 65536];
    let start = Instant::now();
    while !stop.load(Ordering::Relaxed) {
        let due = (start.elapsed().as_secs_f64() * rate) as u64;
        batch.clear();
        while sent < due {
            let bytes = flood_bytes(&mut rng, sysid, &mut sequence, &mut counts);
            sent += 1;
            match &mut sink {
                Sink::Udp(socket, to) => {
                    let _ = socket.send_to(&bytes, *to);
                }
                Sink::Tcp(_) => batch.extend_from_slice(&bytes),
            }
        }
        match &mut sink {
            Sink::Tcp(stream) => {
                if !batch.is_empty() && stream.write_all(&batch).is_err() {
                    break;
                }
            }
            // Telemetry back to this "ground station": read and dropped.
            Sink::Udp(socket, _) => while socket.recv_from(&mut scratch).is_ok() {},
        }
        std::thread::sleep(BATCH_PERIOD);
    }
    counts.seconds = start.elapsed().as_secs_f64();
    let messages = sent - counts.garbage_chunks;
    match sink {
        Sink::Udp(..) => counts.udp_messages = messages,
        Sink::Tcp(_) => counts.tcp_messages = messages,
    }
    counts
}

/// One item of the flood: a message a ground station might send (none that
/// moves the vehicle), or a chunk of garbage.
fn flood_bytes(rng: &mut SeededRng, sysid: u8, sequence: &mut u8, counts: &mut FloodCounts) -> Vec<u8> {
    let roll = rng.between(0, 99);
    let message = match roll {
        0..40 => gcs_heartbeat(),
        40..60 => MavMessage::PARAM_REQUEST_READ(PARAM_REQUEST_READ_DATA {
            param_index: rng.between(0, 150) as i16,
            target_system: VEHICLE.system_id,
            target_component: VEHICLE.component_id,
            ..PARAM_REQUEST_READ_DATA::DEFAULT
        }),
        60..75 => MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            // AUTOPILOT_VERSION or HOME_POSITION.
            param1: if rng.between(0, 1) == 0 { 148.0 } else { 242.0 },
            command: MavCmd::MAV_CMD_REQUEST_MESSAGE,
            target_system: VEHICLE.system_id,
            target_component: VEHICLE.component_id,
            ..COMMAND_LONG_DATA::DEFAULT
        }),
        75..85 => MavMessage::MISSION_REQUEST_LIST(MISSION_REQUEST_LIST_DATA {
            target_system: VEHICLE.system_id,
            target_component: VEHICLE.component_id,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        }),
        _ => {
            counts.garbage_chunks += 1;
            let n = rng.between(8, 64) as usize;
            // Start markers now and then, so the framer has to resync.
            return (0..n)
                .map(|_| match rng.between(0, 15) {
                    0 => 0xFD,
                    1 => 0xFE,
                    _ => rng.next_u64() as u8,
                })
                .collect();
        }
    };
    let header = MavHeader {
        system_id: u32::from(sysid),
        component_id: 190,
        sequence: *sequence,
    };
    *sequence = sequence.wrapping_add(1);
    let mut bytes = Vec::with_capacity(64);
    let _ = mavlink::write_versioned_msg(&mut bytes, MavlinkVersion::V2, header, &message);
    bytes
}

/// The numbers in "SITL stopped after … tick median M µs, p99 P µs, O
/// overruns, R pacing restarts, D messages dropped to links, L late ticks".
fn parse_exit_report(log: &str) -> Option<ExitReport> {
    let line = log.lines().rev().find(|l| l.contains("SITL stopped after"))?;
    let before = |marker: &str| -> Option<f64> {
        let head = &line[..line.find(marker)?];
        head.rsplit([' ', ',']).find(|s| !s.is_empty())?.parse().ok()
    };
    Some(ExitReport {
        tick_p99_us: line.split("p99 ").nth(1)?.split(' ').next()?.parse().ok()?,
        overruns: before(" overruns")? as u64,
        pacing_restarts: before(" pacing restarts")? as u64,
        dropped_to_links: before(" messages dropped to links")? as u64,
        late_ticks: before(" late ticks")? as u64,
    })
}

/// From the hub's reports: frames received on the named links (their last
/// report), and inbound messages dropped with the core's queue full.
fn flood_link_counts(log: &str, names: &[String]) -> (u64, u64) {
    let mut frames = 0;
    for name in names {
        let needle = format!("({name}): rx ");
        if let Some(n) = log
            .lines()
            .rev()
            .find_map(|l| l.split(&needle).nth(1))
            .and_then(|rest| rest.split(' ').next())
            .and_then(|n| n.parse::<u64>().ok())
        {
            frames += n;
        }
    }
    let dropped = log
        .lines()
        .rev()
        .find_map(|l| {
            l.split("WARN")
                .nth(1)
                .filter(|r| r.contains("inbound messages dropped so far"))
        })
        .and_then(|rest| rest.split_whitespace().find_map(|w| w.parse::<u64>().ok()))
        .unwrap_or(0);
    (frames, dropped)
}

/// The flood part's rows, one per target, in report order.
fn rows(rate: u32, quiet: &CourseRun, flooded: &CourseRun) -> Vec<Row> {
    vec![
        offered_row(rate, &flooded.flood),
        absorbed_row(flooded),
        deadline_row(quiet, flooded),
        xtrack_row(quiet, flooded),
        telemetry_gap_row(quiet, flooded),
        progress_row(quiet, flooded),
    ]
}

fn offered_row(rate: u32, f: &FloodCounts) -> Row {
    let offered = f.per_second(f.messages() + f.garbage_chunks);
    Row {
        part: "flood",
        case: "offered: UDP + TCP, paced threads".into(),
        expected: format!("≥ 95 % of {rate} msgs/s"),
        measured: format!(
            "{offered:.0} msgs/s over {:.0} s (UDP {:.0}, TCP {:.0} MAVLink msgs/s, {:.0} garbage chunks/s)",
            f.seconds,
            f.per_second(f.udp_messages),
            f.per_second(f.tcp_messages),
            f.per_second(f.garbage_chunks)
        ),
        ok: offered >= 0.95 * f64::from(rate),
    }
}

fn absorbed_row(flooded: &CourseRun) -> Row {
    let f = &flooded.flood;
    let absorbed_share = if f.messages() > 0 {
        flooded.absorbed_frames as f64 / f.messages() as f64
    } else {
        0.0
    };
    Row {
        part: "flood",
        case: "absorbed: frames the links decoded".into(),
        expected: "≥ 99 % of MAVLink msgs sent, none dropped before the core".into(),
        measured: format!(
            "{:.0} msgs/s ({:.1} %), {} dropped with the core queue full",
            f.per_second(flooded.absorbed_frames),
            absorbed_share * 100.0,
            flooded.dropped_to_core
        ),
        ok: absorbed_share >= 0.99 && flooded.dropped_to_core == 0,
    }
}

fn deadline_row(quiet: &CourseRun, flooded: &CourseRun) -> Row {
    Row {
        part: "flood",
        // A deadline is missed when a tick starts a whole loop period (or
        // more) after its paced time. A task over its time budget (an
        // overrun, wall clock, so a preempted thread counts one) is shown
        // beside it but is not a missed deadline.
        case: "deadline misses: ticks started ≥ 1 period late".into(),
        expected: "0 with the flood".into(),
        measured: format!(
            "quiet {}, flood {} (pacing restarts {} / {}; task budget overruns {} / {}); tick p99 {:.1} µs → {:.1} µs; load average {:.1}, {:.1}",
            quiet.exit.late_ticks,
            flooded.exit.late_ticks,
            quiet.exit.pacing_restarts,
            flooded.exit.pacing_restarts,
            quiet.exit.overruns,
            flooded.exit.overruns,
            quiet.exit.tick_p99_us,
            flooded.exit.tick_p99_us,
            quiet.load_average,
            flooded.load_average
        ),
        ok: flooded.exit.late_ticks == 0 && flooded.exit.pacing_restarts == 0,
    }
}

fn xtrack_row(quiet: &CourseRun, flooded: &CourseRun) -> Row {
    let cm = |m: f64| format!("{:.2} cm", m * 100.0);
    let xtrack_diff = (flooded.xtrack_p99_m - quiet.xtrack_p99_m).abs();
    let xtrack_ok = xtrack_diff <= XTRACK_TOLERANCE_M.max(XTRACK_TOLERANCE_REL * quiet.xtrack_p99_m);
    Row {
        part: "flood",
        case: format!("xtrack p99, first {} s of the AGV course", SEGMENT.as_secs()),
        expected: format!(
            "flood within {} or {:.0} % of quiet",
            cm(XTRACK_TOLERANCE_M),
            XTRACK_TOLERANCE_REL * 100.0
        ),
        measured: format!(
            "quiet {} ({} samples), flood {} ({} samples)",
            cm(quiet.xtrack_p99_m),
            quiet.xtrack_samples,
            cm(flooded.xtrack_p99_m),
            flooded.xtrack_samples
        ),
        ok: xtrack_ok && flooded.xtrack_samples > 0,
    }
}

fn telemetry_gap_row(quiet: &CourseRun, flooded: &CourseRun) -> Row {
    Row {
        part: "flood",
        case: "largest telemetry gap at the observer (HEARTBEAT, ATTITUDE)".into(),
        expected: format!(
            "< {:.1} s, < {:.0} s, none dropped to links",
            MAX_HEARTBEAT_GAP.as_secs_f64(),
            MAX_TELEMETRY_GAP.as_secs_f64()
        ),
        measured: format!(
            "flood {:.2} s, {:.2} s ({} dropped to links); quiet {:.2} s, {:.2} s",
            flooded.heartbeat_gap.as_secs_f64(),
            flooded.attitude_gap.as_secs_f64(),
            flooded.exit.dropped_to_links,
            quiet.heartbeat_gap.as_secs_f64(),
            quiet.attitude_gap.as_secs_f64()
        ),
        ok: flooded.heartbeat_gap < MAX_HEARTBEAT_GAP
            && flooded.attitude_gap < MAX_TELEMETRY_GAP
            && flooded.exit.dropped_to_links == 0,
    }
}

fn progress_row(quiet: &CourseRun, flooded: &CourseRun) -> Row {
    Row {
        part: "flood",
        case: "mission progress over the segment".into(),
        expected: "same item reached".into(),
        measured: format!("quiet item {}, flood item {}", quiet.item_reached, flooded.item_reached),
        ok: quiet.item_reached == flooded.item_reached && quiet.item_reached > 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_row_judges_its_own_figures() {
        let quiet = CourseRun {
            xtrack_p99_m: 0.0123,
            xtrack_samples: 800,
            heartbeat_gap: Duration::from_millis(1020),
            attitude_gap: Duration::from_millis(310),
            item_reached: 7,
            ..Default::default()
        };
        let clean = CourseRun {
            xtrack_p99_m: 0.0131,
            xtrack_samples: 790,
            flood: FloodCounts {
                udp_messages: 800_000,
                tcp_messages: 800_000,
                garbage_chunks: 40_000,
                seconds: 80.0,
            },
            absorbed_frames: 1_590_000,
            ..quiet
        };
        let verdicts = |flooded: &CourseRun| rows(20_000, &quiet, flooded).iter().map(|r| r.ok).collect::<Vec<_>>();
        assert_eq!(verdicts(&clean), [true; 6]);
        // Three messages dropped before the core fail the absorbed row only.
        let dropped = CourseRun {
            dropped_to_core: 3,
            ..clean
        };
        assert_eq!(verdicts(&dropped), [true, false, true, true, true, true]);
        // A tick a period late fails the deadline row only.
        let mut late = CourseRun { ..clean };
        late.exit.late_ticks = 1;
        assert_eq!(verdicts(&late), [true, true, false, true, true, true]);
    }

    #[test]
    fn the_exit_report_is_parsed() {
        let log = "2026-01-01T00:00:00Z  INFO furrow::sitl: SITL stopped after 80.3 s simulated in 81.0 s: \
                   tick median 41.20 µs, p99 97.51 µs, 3 overruns, 1 pacing restarts, 12 messages dropped to links, 2 late ticks\n";
        assert_eq!(
            parse_exit_report(log),
            Some(ExitReport {
                tick_p99_us: 97.51,
                overruns: 3,
                pacing_restarts: 1,
                dropped_to_links: 12,
                late_ticks: 2
            })
        );
        assert_eq!(parse_exit_report("nothing"), None);
    }

    #[test]
    fn link_counts_come_from_the_last_report_of_each_link() {
        let log = "WARN link 1 (udp to 127.0.0.1:5000): rx 10 frames (0 MAVLink 1), 5 bytes unframed, 0 undecodable; 0 tx dropped\n\
                   WARN link 3 (tcp client 127.0.0.1:6000): rx 7 frames (0 MAVLink 1), 1 bytes unframed, 0 undecodable; 0 tx dropped\n\
                   WARN link 1 (udp to 127.0.0.1:5000): rx 25 frames (0 MAVLink 1), 9 bytes unframed, 0 undecodable; 0 tx dropped\n\
                   WARN 42 inbound messages dropped so far: core queue full\n";
        let names = [
            "udp to 127.0.0.1:5000".to_string(),
            "tcp client 127.0.0.1:6000".to_string(),
        ];
        assert_eq!(flood_link_counts(log, &names), (32, 42));
    }

    #[test]
    fn flood_items_are_frames_or_counted_garbage() {
        let mut rng = SeededRng::new(1);
        let mut counts = FloodCounts::default();
        let mut seq = 0;
        let mut frames = 0;
        for _ in 0..1000 {
            let bytes = flood_bytes(&mut rng, 254, &mut seq, &mut counts);
            let mut reader = mavlink::MavlinkReader::new(&bytes[..]);
            if bytes[0] == 0xFD && reader.read_message::<MavMessage>(MavlinkVersion::V2).is_ok() {
                frames += 1;
            }
        }
        assert_eq!(frames + counts.garbage_chunks, 1000);
        assert!((100..200).contains(&counts.garbage_chunks), "{}", counts.garbage_chunks);
    }

    #[test]
    fn p99_of_a_known_distribution() {
        let mut v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(quantile(&mut v, 0.99), 99.0);
        assert!(quantile(&mut [], 0.5).is_nan());
    }
}
