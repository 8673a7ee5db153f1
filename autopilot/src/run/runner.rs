//! `furrow run --config FILE`: the core at its loop rate on the wall clock,
//! sensors from the configured devices, pulses to the sysfs PWM outputs,
//! ground stations on the configured MAVLink endpoints.
//!
//! The loop never waits on a device: drivers run on their own threads and
//! are polled once a tick. Device health changes are announced
//! (STATUSTEXT) and the whole table is sent on request (`furrow status`).

use std::path::Path;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::{COMMAND_ACK_DATA, MavCmd, MavMessage, MavResult, MavSeverity};
use mission::MissionType;
use params::ParamTableBuilder;

use super::actuators::PwmActuators;
use super::config::{self, VehicleConfig};
use super::devices::{DeviceReport, Devices};
use crate::link::endpoint::{Endpoint, LinkEndpoint};
use crate::link::hub::{self, LinkConfig, ToCore};
use crate::sitl::runner::{InstantTimer, Persistence, drain, forward, shutdown_on_signal};
use crate::sitl::simulation::ModelKind;
use crate::storage::data_dir::{DataDir, Profile};
use crate::storage::missions;
use crate::storage::session::SessionParams;
use crate::telemetry::statustext::statustext;
use crate::time::Now;
use crate::vehicle::{Core, CoreParams, Destination, Inbound, Inputs, Outbound, Outputs};

/// `MAV_CMD_USER_1` asks for the device table (`furrow status`); each
/// device comes back as a STATUSTEXT starting with [`DEVICE_LINE_PREFIX`],
/// then one ending with [`DEVICE_TABLE_END`].
pub const STATUS_COMMAND: MavCmd = MavCmd::MAV_CMD_USER_1;
pub const DEVICE_LINE_PREFIX: &str = "DEV ";
pub const DEVICE_TABLE_END: &str = "DEV end";

/// Devices get this long after start before a silent one is announced.
const STARTUP_GRACE: Duration = Duration::from_secs(3);
/// Health is checked this often.
const HEALTH_EVERY: Duration = Duration::from_millis(250);

/// The parameter table of a real vehicle: the core's parameters with the
/// drive train's defaults (no `SIM_*`).
pub fn vehicle_params(model: ModelKind) -> (params::ParamTable, CoreParams) {
    let mut builder = ParamTableBuilder::new();
    let core = CoreParams::register(&mut builder);
    if model == ModelKind::Differential {
        builder.override_default("VEH_DRIVE", 1.0);
    }
    (builder.build(), core)
}

/// Runs until SIGINT/SIGTERM.
pub fn run(config_path: &Path) -> Result<(), String> {
    let config = config::load(config_path).map_err(|e| e.to_string())?;
    let origin = Instant::now();
    let model = config.frame.model_kind();
    let data_dir = DataDir::open(&config.data_dir, Profile::Vehicle(model))?;
    let (mut table, core_params) = vehicle_params(model);
    let mut session = SessionParams::load(data_dir.path(), &mut table)?;
    let mut core = Core::new(table, core_params);
    for (severity, text) in session.notices.drain(..) {
        core.add_startup_notice(severity, text);
    }
    let (plans, plan_notices) = missions::load(data_dir.path());
    for mission_type in MissionType::ALL {
        core.load_plan(mission_type, plans.get(mission_type).clone());
    }
    for (severity, text) in plan_notices {
        core.add_startup_notice(severity, text);
    }
    if config.scanners.is_empty() && core.param_handles().obstacles.avoidance.enable.get(core.params()) {
        core.add_startup_notice(
            MavSeverity::MAV_SEVERITY_WARNING,
            "No scanner configured: set OA_ENABLE 0 to drive",
        );
    }
    let mut persistence = Persistence::start(&data_dir, &mut core);

    let (tcp_server, udp_out, extra) = split_endpoints(&config);
    let (links, mut channels) = hub::start(LinkConfig {
        sysid: core.sysid(),
        tcp_server,
        udp_out,
        extra,
        tlog: None,
        signing_dir: Some(data_dir.path().to_path_buf()),
        sign_require_mask: core.sign_require_mask(),
    })
    .map_err(|e| format!("MAVLink links: {e}"))?;

    let mut devices = Devices::start(&config, origin)?;
    let period = core.loop_period();
    let trims = servo_trims(&core);
    let actuators = PwmActuators::start(&config.pwm, &trims, 3 * period);

    let mut logger = crate::logging::edge::Logger::start(data_dir.path(), channels.outbound.clone());
    let shutdown = shutdown_on_signal();
    let tcp = links.bound.tcp.map_or("none".into(), |a| a.to_string());
    let udp = links.bound.udp_local.map_or("none".into(), |a| a.to_string());
    // One line on stdout that scripts and tests parse for the bound ports.
    let secure: String = links.bound.secure.iter().map(|s| format!(", secure {s}")).collect();
    println!("furrow run ready: tcp {tcp}, udp {udp}, sysid {}{secure}", core.sysid());
    tracing::info!("vehicle from {}:\n{}", config_path.display(), config.summary());

    let mut timer = InstantTimer::default();
    let mut inputs = Inputs::default();
    let mut outputs = Outputs::default();
    let mut dropped_out = 0u64;
    let mut next_tick = Instant::now();
    let mut next_health = Duration::ZERO;
    let mut late_ticks = 0u64;
    let waiter = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()
        .map_err(|e| format!("runtime: {e}"))?;
    while !shutdown.load(Ordering::Relaxed) {
        let started = Instant::now();
        // A tick more than a period late: the outputs of the last one are
        // stale, so they go to trim before anything else happens.
        if started > next_tick + period {
            late_ticks += 1;
            actuators.to_trim();
            next_tick = started;
        }
        let boot = origin.elapsed();
        let now = Now { boot, wall: boot };
        take_link_traffic(
            &mut channels.inbound,
            &mut inputs,
            &mut devices,
            &actuators,
            &channels.outbound,
            boot,
            None,
        );
        devices.poll(boot, &mut inputs);
        persistence.collect(&mut inputs);
        core.step(now, &inputs, &mut outputs, &mut timer);
        inputs.clear();
        actuators.apply(&outputs.servo_pwm_us);
        if boot >= next_health {
            next_health = boot + HEALTH_EVERY;
            for (report, healthy) in devices.changes(boot, STARTUP_GRACE) {
                announce(&mut core, &report, healthy);
            }
        }
        forward(&mut outputs, &channels.outbound, &mut dropped_out);
        logger.send(&mut outputs.log);
        persistence.save(std::mem::take(&mut outputs.saves), &core, &session);
        links.set_sign_require_mask(core.sign_require_mask());

        next_tick += period;
        // Until the next tick: answer link traffic as it comes.
        while let Some(delay) = next_tick.checked_duration_since(Instant::now()) {
            let deadline = tokio::time::Instant::now() + delay;
            let Some(first) = persistence.wait(&waiter, deadline, &mut channels.inbound, &mut inputs) else {
                break;
            };
            let boot = origin.elapsed();
            take_link_traffic(
                &mut channels.inbound,
                &mut inputs,
                &mut devices,
                &actuators,
                &channels.outbound,
                boot,
                first,
            );
            core.service_links(boot, &inputs, &mut outputs);
            inputs.link_events.clear();
            inputs.messages.clear();
            inputs.undecodable_items.clear();
            inputs.saved.clear();
            forward(&mut outputs, &channels.outbound, &mut dropped_out);
            logger.send(&mut outputs.log);
            persistence.save(std::mem::take(&mut outputs.saves), &core, &session);
            links.set_sign_require_mask(core.sign_require_mask());
        }
    }
    actuators.to_trim();
    persistence.finish();
    crate::logging::edge::report(logger);
    let ticks = core.scheduler().tick_stats();
    tracing::info!(
        "stopped after {:.1} s: tick median {:.2} µs, p99 {:.2} µs, {} overruns, {} late ticks, {} watchdog trims, {} corrections dropped, {} messages dropped to links",
        origin.elapsed().as_secs_f64(),
        ticks.histogram.quantile_ns(0.5) as f64 / 1000.0,
        ticks.histogram.quantile_ns(0.99) as f64 / 1000.0,
        core.scheduler().total_overruns(),
        late_ticks,
        actuators.watchdog_trips(),
        devices.rtcm_dropped(),
        dropped_out,
    );
    drop(actuators);
    drop(devices);
    drop(links);
    Ok(())
}

/// The first `tcpin:` endpoint is the TCP server (stream slot 0), the first
/// `udp:` the UDP link (slot 1); the rest are extra endpoints, the secure
/// ones last (a secure link never takes slot 0 or 1).
fn split_endpoints(config: &VehicleConfig) -> (Option<String>, Option<String>, Vec<LinkEndpoint>) {
    let mut tcp_server = None;
    let mut udp_out = None;
    let mut plain = Vec::new();
    for endpoint in &config.mavlink {
        match endpoint {
            Endpoint::TcpServer { host, port } if tcp_server.is_none() => tcp_server = Some(format!("{host}:{port}")),
            Endpoint::UdpOut { host, port } if udp_out.is_none() => udp_out = Some(format!("{host}:{port}")),
            other => plain.push(other.clone()),
        }
    }
    (
        tcp_server,
        udp_out,
        crate::sitl::runner::extra_endpoints(&plain, &config.secure_mavlink),
    )
}

/// SERVOn_TRIM for n = 1..16: where each output rests.
fn servo_trims(core: &Core) -> [u16; 16] {
    let config = core.param_handles().servos.config(core.params());
    let mut trims = [1500u16; 16];
    for (slot, channel) in trims.iter_mut().zip(config.channels.iter()) {
        *slot = channel.range.trim_us;
    }
    trims
}

fn announce(core: &mut Core, report: &DeviceReport, healthy: bool) {
    let (severity, text) = if healthy {
        (MavSeverity::MAV_SEVERITY_INFO, format!("{} ok", report.name))
    } else if !report.connected {
        (
            MavSeverity::MAV_SEVERITY_CRITICAL,
            format!("{} lost: disconnected", report.name),
        )
    } else {
        let age = report
            .age_s
            .map_or("never heard".to_string(), |a| format!("no data {a:.1}s"));
        (
            MavSeverity::MAV_SEVERITY_CRITICAL,
            format!("{} lost: {age}", report.name),
        )
    };
    tracing::warn!("{text} ({})", report.place);
    core.announce(severity, &text);
}

/// Moves what the links delivered into the inputs, except what the edge
/// answers itself: GPS_RTCM_DATA (to the receiver) and the device-status
/// request.
fn take_link_traffic(
    inbound: &mut tokio::sync::mpsc::Receiver<ToCore>,
    inputs: &mut Inputs,
    devices: &mut Devices,
    actuators: &PwmActuators,
    outbound: &tokio::sync::mpsc::Sender<Outbound>,
    now: Duration,
    first: Option<ToCore>,
) {
    let before = inputs.messages.len();
    drain(inbound, inputs, first);
    let mut k = 0;
    inputs.messages.retain(|m| {
        k += 1;
        k <= before || !answer_at_edge(m, devices, actuators, outbound, now)
    });
}

/// True when the message was for the edge and has been handled.
fn answer_at_edge(
    m: &Inbound,
    devices: &mut Devices,
    actuators: &PwmActuators,
    outbound: &tokio::sync::mpsc::Sender<Outbound>,
    now: Duration,
) -> bool {
    match &m.message {
        MavMessage::GPS_RTCM_DATA(d) => {
            let len = usize::from(d.len).min(d.data.len());
            devices.mavlink_rtcm(d.flags, &d.data[..len]);
            true
        }
        MavMessage::COMMAND_LONG(c) if c.command == STATUS_COMMAND => {
            let reply = |message: MavMessage| {
                let _ = outbound.try_send(Outbound {
                    dest: Destination::Link(m.link),
                    message,
                });
            };
            reply(MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                command: STATUS_COMMAND,
                result: MavResult::MAV_RESULT_ACCEPTED,
                target_system: u8::try_from(m.header.system_id).unwrap_or(0),
                target_component: m.header.component_id,
                ..COMMAND_ACK_DATA::default()
            }));
            let mut id = 0u16;
            let mut reports = devices.reports(now);
            if let Some(pwm) = actuators.status() {
                reports.push(super::devices::report("PWM", "sysfs", &pwm, false, now));
            }
            let mut lines: Vec<String> = reports
                .iter()
                .map(|r| format!("{DEVICE_LINE_PREFIX}{}", r.line()))
                .collect();
            lines.push(DEVICE_TABLE_END.to_string());
            for line in lines {
                for chunk in statustext(MavSeverity::MAV_SEVERITY_INFO, &line, &mut id) {
                    reply(MavMessage::STATUSTEXT(chunk));
                }
            }
            true
        }
        _ => false,
    }
}
