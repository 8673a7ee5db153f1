//! `furrow-bench sitl`: how fast SITL runs with nothing pacing it, how long a
//! core tick takes, and how much memory `furrow sitl` holds.
//!
//! Two measurements:
//! 1. in-process: world + core stepped as fast as possible (no sockets, the
//!    telemetry encoded to MAVLink bytes as a link would), for the
//!    simulated-per-wall ratio, the core tick distribution, each stage's
//!    share of the wall time, the heap allocations per tick (counted by the
//!    benchmark binary's allocator), then the cost of each EKF operation on
//!    the filter that drove;
//! 2. the real process: `furrow sitl --speedup max` started as a child with a
//!    ground station connected over TCP, for its simulated-per-wall ratio
//!    (from SYSTEM_TIME), tick figures (from its exit report) and RSS, with
//!    where the RSS is (its binary's pages, libraries, heap, anonymous).
//!
//! Each runs with the onboard log off and at full rate (every tick;
//! in-process the core encodes the records, the process also writes them),
//! so the logger's cost shows (`--log` picks one).

use std::net::TcpStream;
use std::time::{Duration, Instant};

use mavlink::MavlinkReader;
use mavlink::dialects::ardupilotmega::MavMessage;

use autopilot::edge::clock::InstantTimer;
use autopilot::sitl::gcs;
use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams, StageTimes};
use autopilot::time::TaskTimer;

use crate::safety::gcs_client::SitlProcess;
use sim::WorldStageTimes;
use stats_alloc::Region;

#[derive(clap::Args, Debug)]
pub struct SitlBenchArgs {
    /// Simulated seconds for the in-process run.
    #[arg(long, default_value_t = 3600.0)]
    pub seconds: f64,
    /// Wall seconds to watch the `furrow sitl --speedup max` process.
    #[arg(long, default_value_t = 10.0)]
    pub process_seconds: f64,
    /// The onboard log: off, on at full rate (LOG_FILE_RATEMAX 0), or both runs one after the other.
    #[arg(long, value_enum, default_value_t = LogRuns::Both)]
    pub log: LogRuns,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum LogRuns {
    Off,
    On,
    Both,
}

impl LogRuns {
    fn runs(self) -> &'static [bool] {
        match self {
            LogRuns::Off => &[false],
            LogRuns::On => &[true],
            LogRuns::Both => &[false, true],
        }
    }
}

fn log_label(logging: bool) -> &'static str {
    if logging {
        "onboard log at full rate"
    } else {
        "onboard log off"
    }
}

pub fn run(args: &SitlBenchArgs) -> Result<(), String> {
    if !(args.seconds > 0.0 && args.seconds <= 86_400.0) {
        return Err(format!(
            "--seconds {}: must be a positive number up to a day",
            args.seconds
        ));
    }
    if !(args.process_seconds > 0.0 && args.process_seconds <= 86_400.0) {
        return Err(format!(
            "--process-seconds {}: must be a positive number up to a day",
            args.process_seconds
        ));
    }
    for &logging in args.log.runs() {
        in_process(args.seconds, logging);
    }
    for &logging in args.log.runs() {
        real_process(args.process_seconds, logging)?;
    }
    Ok(())
}

/// Drives a 40 m GUIDED square over and over, so the tick includes
/// estimation, tracking and control, not an idle HOLD.
fn in_process(seconds: f64, logging: bool) {
    let (mut sim, mut timer) = armed_in_guided(logging);
    let mut log_bytes = 0usize;
    let corners = [(40.0, 0.0), (40.0, 40.0), (0.0, 40.0), (0.0, 0.0)];
    let mut corner = 0;
    let start = Instant::now();
    let cpu_start_s = crate::fleet::process::cpu_s(std::process::id());
    sim.time_stages(true);
    let stages_before = sim.stage_times();
    let mut driving = false;
    let mut odometer_m = 0.0;
    let mut link = LinkBytes::new();
    let mut allocations = AllocationCount::default();
    while sim.time().as_secs_f64() < seconds {
        let new_leg = !driving || sim.core().navigator().arrived();
        if new_leg {
            let (n, e) = corners[corner % corners.len()];
            let target = gcs::local_target(&sim, n, e);
            gcs::send(&mut sim, target);
            corner += 1;
            driving = true;
        }
        let region = Region::new(crate::GLOBAL);
        let wall = start.elapsed();
        let before = *sim.world().truth();
        let out = sim.step(wall, &mut timer);
        let announces = out
            .mavlink
            .iter()
            .any(|m| matches!(m.message, MavMessage::STATUSTEXT(_)));
        link.send(&mut out.mavlink);
        log_bytes += log_records_bytes(&out.log);
        let after = sim.world().truth();
        odometer_m += (after.north_m - before.north_m).hypot(after.east_m - before.east_m);
        let change = region.change();
        let kind = if new_leg {
            TickKind::LegStart
        } else if announces {
            TickKind::Event
        } else {
            TickKind::Driving
        };
        allocations.add(change.allocations + change.reallocations, kind);
    }
    let wall = start.elapsed().as_secs_f64();
    let cpu_s = crate::fleet::process::cpu_s(std::process::id()) - cpu_start_s;
    let stages = stage_delta(sim.stage_times(), stages_before);
    let ticks = sim.core().scheduler().tick_stats();
    let us = |ns: u64| ns as f64 / 1000.0;
    println!(
        "in-process simulation (world, NMEA and CoLa-A wires, core, telemetry encoded; no sockets), {seconds:.0} s simulated driving a 40 m GUIDED square, {}:",
        log_label(logging)
    );
    if logging {
        println!(
            "  log records encoded by the core: {:.1} MB ({:.1} kB per simulated second)",
            log_bytes as f64 / 1e6,
            log_bytes as f64 / 1e3 / sim.time().as_secs_f64()
        );
    }
    print_speed(sim.time().as_secs_f64(), wall, cpu_s);
    println!("  {} corners reached, odometer {odometer_m:.0} m", corner - 1);
    println!(
        "  core tick: {} ticks, median {:.2} us, p99 {:.2} us, max {:.1} us",
        ticks.runs,
        us(ticks.histogram.quantile_ns(0.5)),
        us(ticks.histogram.quantile_ns(0.99)),
        us(ticks.histogram.max_ns())
    );
    print_breakdown(&stages, link.ns, wall);
    allocations.print();
    match sim.core().estimator().ekf() {
        Some(ekf) => crate::ekf_cost::print(ekf),
        None => println!("EKF cost: the filter never started"),
    }
}

/// Simulated seconds per wall second and per CPU second of this process.
/// Wall time counts the time other processes held the cores; the process's
/// own CPU time (utime + stime, /proc/self/stat) does not.
fn print_speed(simulated_s: f64, wall_s: f64, cpu_s: f64) {
    println!(
        "  {:.0}x real time ({wall_s:.3} s wall); {:.0}x per CPU second of this process ({cpu_s:.3} s CPU; load average {})",
        simulated_s / wall_s,
        simulated_s / cpu_s.max(1e-3),
        crate::fleet::load_average()
    );
}

/// The Ackermann simulation with the onboard log on or off, past its
/// first fixes (as an operator would wait), in GUIDED and armed.
fn armed_in_guided(logging: bool) -> (Simulation, InstantTimer) {
    let config = SimulationConfig {
        model: ModelKind::Ackermann,
        ..SimulationConfig::default()
    };
    let mut sim = Simulation::new(&config, SimulationParams::new(config.model));
    let backend = if logging { 1.0 } else { 0.0 };
    let set = sim.core_mut().params_mut().set_by_name("LOG_BACKEND_TYPE", backend);
    set.expect("LOG_BACKEND_TYPE is declared");
    let mut timer = InstantTimer::default();
    crate::warm_up_and_arm(&mut sim, &mut timer, 2.0, 15);
    (sim, timer)
}

/// The ground station's link as the process would drive it: each message
/// encoded to MAVLink 2 bytes, timed.
struct LinkBytes {
    buffer: Vec<u8>,
    ns: u64,
    timer: InstantTimer,
}

/// The link buffer's size: a tick's burst of frames (a MAVLink 2 frame is at
/// most 280 bytes), so the harness's own buffer never grows in the count.
const LINK_BUFFER_BYTES: usize = 64 * 280;

impl LinkBytes {
    fn new() -> Self {
        LinkBytes {
            buffer: Vec::with_capacity(LINK_BUFFER_BYTES),
            ns: 0,
            timer: InstantTimer::default(),
        }
    }

    fn send(&mut self, outbound: &mut Vec<autopilot::vehicle::Outbound>) {
        let started_ns = self.timer.now_ns();
        self.buffer.clear();
        for message in outbound.iter() {
            // Writing to a Vec cannot fail.
            let _ = mavlink::write_v2_msg(&mut self.buffer, gcs::GCS_HEADER, &message.message);
        }
        outbound.clear();
        self.ns += self.timer.now_ns().saturating_sub(started_ns);
    }
}

/// What a tick did besides driving on: the ticks that are not steady state.
#[derive(Clone, Copy, PartialEq, Eq)]
enum TickKind {
    /// Steady driving along a leg.
    Driving,
    /// A leg starts: a target arrives and its path is planned.
    LegStart,
    /// Something is announced (a STATUSTEXT: a stop report, an arrival, a
    /// retry): the text is formatted then.
    Event,
}

/// Heap allocations per tick, apart for the ticks that start a leg or
/// announce something (not steady state).
#[derive(Default)]
struct AllocationCount {
    ticks: u64,
    allocations: u64,
    allocating_ticks: u64,
    leg_ticks: u64,
    leg_allocations: u64,
    event_ticks: u64,
    event_allocations: u64,
}

impl AllocationCount {
    fn add(&mut self, allocations: usize, kind: TickKind) {
        let allocations = allocations as u64;
        match kind {
            TickKind::LegStart => {
                self.leg_ticks += 1;
                self.leg_allocations += allocations;
            }
            TickKind::Event => {
                self.event_ticks += 1;
                self.event_allocations += allocations;
            }
            TickKind::Driving => {
                self.ticks += 1;
                self.allocations += allocations;
                self.allocating_ticks += u64::from(allocations > 0);
            }
        }
    }

    fn print(&self) {
        let per = |allocations: u64, ticks: u64| allocations as f64 / ticks.max(1) as f64;
        println!(
            "  heap allocations: {:.3} per steady driving tick ({} of {} ticks allocated); {:.1} per tick that starts a leg ({} ticks); {:.1} per tick that announces an event ({} ticks)",
            per(self.allocations, self.ticks),
            self.allocating_ticks,
            self.ticks,
            per(self.leg_allocations, self.leg_ticks),
            self.leg_ticks,
            per(self.event_allocations, self.event_ticks),
            self.event_ticks
        );
    }
}

fn stage_delta(after: StageTimes, before: StageTimes) -> StageTimes {
    StageTimes {
        world: WorldStageTimes {
            physics_ns: after.world.physics_ns - before.world.physics_ns,
            gnss_out_ns: after.world.gnss_out_ns - before.world.gnss_out_ns,
            scan_render_ns: after.world.scan_render_ns - before.world.scan_render_ns,
        },
        gnss_in_ns: after.gnss_in_ns - before.gnss_in_ns,
        scan_encode_ns: after.scan_encode_ns - before.scan_encode_ns,
        scan_parse_ns: after.scan_parse_ns - before.scan_parse_ns,
        core_ns: after.core_ns - before.core_ns,
    }
}

/// Each stage's share of the loop's wall time; the rest is the loop itself
/// (timer reads, the simulation's bookkeeping, the bench's odometer).
fn print_breakdown(stages: &StageTimes, link_ns: u64, wall_s: f64) {
    let total_ns = wall_s * 1e9;
    let rows = [
        ("world physics", stages.world.physics_ns),
        ("GNSS NMEA out", stages.world.gnss_out_ns),
        ("GNSS NMEA in", stages.gnss_in_ns),
        ("scanners: render (ray casting)", stages.world.scan_render_ns),
        ("scanners: CoLa-A encode", stages.scan_encode_ns),
        ("scanners: frame + parse", stages.scan_parse_ns),
        ("core step", stages.core_ns),
        ("links (MAVLink 2 encode)", link_ns),
    ];
    let staged_ns: u64 = rows.iter().map(|(_, ns)| ns).sum();
    println!("  wall time by stage:");
    for (name, ns) in rows {
        println!("    {name:<32} {:5.1} %", 100.0 * ns as f64 / total_ns);
    }
    println!(
        "    {:<32} {:5.1} %",
        "other (loop, timers)",
        100.0 * (total_ns - staged_ns as f64).max(0.0) / total_ns
    );
}

/// Bytes of records in a step's log commands.
fn log_records_bytes(commands: &[autopilot::logging::LogCommand]) -> usize {
    commands
        .iter()
        .map(|c| match c {
            autopilot::logging::LogCommand::Records(bytes) => bytes.len(),
            _ => 0,
        })
        .sum()
}

fn real_process(seconds: f64, logging: bool) -> Result<(), String> {
    let exe = crate::furrow_exe()?;
    let scratch = crate::scratch_dir("furrow-bench-sitl-")?;
    let data = scratch.path().to_path_buf();
    let args = ["--speedup", "max", "--tcp-port", "0", "--udp-port", "9", "--data-dir"]
        .map(String::from)
        .into_iter()
        .chain([data.display().to_string()])
        .collect::<Vec<_>>();
    let sitl = SitlProcess::start(&exe, &args, &scratch.path().join("stderr.log"))?;
    let result = watch(&sitl, seconds, logging);
    // SIGINT so it prints its tick report.
    let stopped = sitl.interrupt(Duration::from_secs(10));
    let logs = autopilot::logging::store::LogStore::new(&data).list();
    let log_bytes: u64 = logs.iter().map(|l| l.size_bytes).sum();
    let (speed, rss_kb, peak_kb, rss_breakdown) = result?;
    println!(
        "furrow sitl --speedup max, a ground station on TCP, {seconds:.0} s wall, {}:",
        log_label(logging)
    );
    if logging {
        println!(
            "  {} log file(s), {:.1} MB written (LOG_DISARMED 1: logging from the start)",
            logs.len(),
            log_bytes as f64 / 1e6
        );
    }
    println!(
        "  {:.0}x real time (SYSTEM_TIME.time_boot_ms over wall time); {:.0}x per CPU second of the process (load average {})",
        speed.per_wall_s,
        speed.per_cpu_s,
        crate::fleet::load_average()
    );
    println!(
        "  RSS {:.1} MB (peak {:.1} MB)",
        rss_kb as f64 / 1024.0,
        peak_kb as f64 / 1024.0
    );
    println!("  {rss_breakdown}");
    let stderr = sitl.stderr();
    if let Some(line) = stderr.lines().find(|l| l.contains("SITL stopped after")) {
        let report = line.split("SITL stopped after").nth(1).unwrap_or("");
        println!("  exit report: SITL stopped after{report}");
    }
    if let Some(line) = stderr.lines().find(|l| l.contains("onboard log:")) {
        println!("  {}", line.split("onboard log:").nth(1).map_or("", str::trim));
    }
    stopped
}

/// Sets a parameter over the bench's connection (no reply awaited: the
/// telemetry read next shows its effect).
fn param_set(stream: &mut TcpStream, name: &str, value: f32) -> Result<(), String> {
    let msg = MavMessage::PARAM_SET(mavlink::dialects::ardupilotmega::PARAM_SET_DATA {
        param_value: value,
        target_system: 1,
        target_component: 1,
        param_id: crate::safety::gcs_client::param_id(name).into(),
        param_type: mavlink::dialects::ardupilotmega::MavParamType::MAV_PARAM_TYPE_REAL32,
    });
    mavlink::write_v2_msg(stream, gcs::GCS_HEADER, &msg).map_err(|e| format!("PARAM_SET {name}: {e}"))?;
    Ok(())
}

/// Simulated seconds per wall second and per CPU second of the process.
struct Speed {
    per_wall_s: f64,
    per_cpu_s: f64,
}

/// Connects, sets the log on or off, measures simulated time over `seconds`
/// of wall time, reads RSS.
fn watch(sitl: &SitlProcess, seconds: f64, logging: bool) -> Result<(Speed, u64, u64, String), String> {
    let port = sitl.tcp_port;
    let stream = TcpStream::connect(("127.0.0.1", port)).map_err(|e| format!("connect: {e}"))?;
    stream
        .set_read_timeout(Some(Duration::from_secs(5)))
        .map_err(|e| e.to_string())?;
    let mut control = stream.try_clone().map_err(|e| e.to_string())?;
    param_set(&mut control, "LOG_BACKEND_TYPE", if logging { 1.0 } else { 0.0 })?;
    param_set(&mut control, "LOG_DISARMED", if logging { 1.0 } else { 0.0 })?;
    let mut reader = MavlinkReader::new(stream);
    // Read everything as it comes (telemetry queued in the socket would be
    // stale) and keep the newest SYSTEM_TIME at the start and at the end.
    let mut latest = |until: Instant| -> Result<(Instant, u32), String> {
        let mut newest = None;
        while newest.is_none() || Instant::now() < until {
            let (_, msg) = reader
                .read_any_message::<MavMessage>()
                .map_err(|e| format!("reading telemetry: {e}"))?;
            if let MavMessage::SYSTEM_TIME(t) = msg {
                newest = Some((Instant::now(), t.time_boot_ms));
            }
        }
        newest.ok_or_else(|| "no SYSTEM_TIME".to_string())
    };
    let (t0, b0) = latest(Instant::now() + Duration::from_secs(1))?;
    let cpu0_s = crate::fleet::process::cpu_s(sitl.pid());
    let (t1, b1) = latest(t0 + autopilot::time::duration_from_secs(seconds))?;
    let cpu_s = crate::fleet::process::cpu_s(sitl.pid()) - cpu0_s;
    let simulated_s = f64::from(b1.wrapping_sub(b0)) / 1000.0;
    let speed = Speed {
        per_wall_s: simulated_s / (t1 - t0).as_secs_f64(),
        per_cpu_s: simulated_s / cpu_s.max(1e-3),
    };
    let status = std::fs::read_to_string(format!("/proc/{}/status", sitl.pid())).unwrap_or_default();
    let field = |name: &str| {
        status
            .lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse::<u64>().ok())
            .unwrap_or(0)
    };
    let breakdown = rss_breakdown(sitl.pid());
    Ok((speed, field("VmRSS:"), field("VmHWM:"), breakdown))
}

/// Where the process's resident memory is, from /proc/PID/smaps: its own
/// binary's pages (code, read-only data, data), the shared libraries', the
/// heap, and anonymous mappings (thread stacks, the allocator's arenas).
fn rss_breakdown(pid: u32) -> String {
    let Ok(smaps) = std::fs::read_to_string(format!("/proc/{pid}/smaps")) else {
        return "RSS by mapping: /proc/PID/smaps unreadable".to_owned();
    };
    let exe = std::fs::read_link(format!("/proc/{pid}/exe")).ok();
    let exe = exe.as_ref().and_then(|p| p.to_str()).unwrap_or("");
    let mut kinds = [
        ("furrow binary", 0u64),
        ("shared libraries", 0),
        ("heap", 0),
        ("anonymous (thread stacks, arenas)", 0),
        ("main stack and the rest", 0),
    ];
    let mut kind = 4;
    for line in smaps.lines() {
        let mut words = line.split_whitespace();
        let first = words.next().unwrap_or("");
        if first.contains('-') && first.chars().all(|c| c.is_ascii_hexdigit() || c == '-') {
            let name = words.nth(4).unwrap_or("");
            kind = match name {
                n if !exe.is_empty() && n == exe => 0,
                n if n.starts_with('/') => 1,
                "[heap]" => 2,
                "" => 3,
                _ => 4,
            };
        } else if first == "Rss:" {
            kinds[kind].1 += words.next().and_then(|v| v.parse::<u64>().ok()).unwrap_or(0);
        }
    }
    let threads = std::fs::read_dir(format!("/proc/{pid}/task")).map_or(0, Iterator::count);
    let parts: Vec<String> = kinds
        .iter()
        .map(|(name, kb)| format!("{name} {:.2} MB", *kb as f64 / 1024.0))
        .collect();
    format!("RSS by mapping: {}; {threads} threads", parts.join(", "))
}
