//! `furrow run --config FILE`: the core at its loop rate on the wall clock,
//! sensors from the configured devices, pulses to the sysfs PWM outputs,
//! ground stations on the configured MAVLink endpoints.
//!
//! The edge runner drives it; the loop never waits on a device: drivers
//! run on their own threads or as tasks on the edge's runtime and are
//! polled once a tick. Device health changes are announced
//! (STATUSTEXT) and the whole table is sent on request (`furrow status`).

use std::path::Path;
use std::time::Duration;

use mavlink::dialects::ardupilotmega::{COMMAND_ACK_DATA, MavCmd, MavMessage, MavResult, MavSeverity};
use params::ParamTableBuilder;

use super::actuators::PwmActuators;
use super::config::{self, VehicleConfig};
use super::devices::{DeviceReport, Devices};
use crate::control::defaults;
use crate::control::mixer::DriveTrain;
use crate::edge::clock::{InstantTimer, WallTicks};
use crate::edge::persistence::{self, Persistence};
use crate::edge::runner::{EdgeRunner, Platform};
use crate::edge::shutdown;
use crate::link::endpoint::Endpoint;
use crate::link::sockets::{self, LinkEndpoints, LinkSockets};
use crate::sitl::simulation::ModelKind;
use crate::storage::data_dir::{DataDir, Profile};
use crate::storage::file_writer::FileWriterThread;
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
        defaults::apply(&mut builder, DriveTrain::Differential);
    }
    (builder.build(), core)
}

/// Runs until SIGINT/SIGTERM.
pub fn run(config_path: &Path) -> Result<(), String> {
    let config = config::load(config_path).map_err(|e| e.to_string())?;
    let mut edge = EdgeRunner::new()?;
    let model = config.frame.model_kind();
    let data_dir = DataDir::open(&config.data_dir, Profile::Vehicle(model))?;
    let (mut table, core_params) = vehicle_params(model);
    let mut session = SessionParams::load(data_dir.path(), &mut table)?;
    let mut core = Core::new(table, core_params);
    persistence::restore(&data_dir, &mut session, &mut core);
    if config.scanners.is_empty() && core.param_handles().obstacles.avoidance.enable.get(core.params()) {
        core.add_startup_notice(
            MavSeverity::MAV_SEVERITY_WARNING,
            "No scanner configured: set OA_ENABLE 0 to drive",
        );
    }
    if let Some(vda5050) = &config.vda5050 {
        edge = edge.with_vda5050(vda5050.mqtt()?);
        core.enable_vda5050(vda5050.agent.clone());
    }
    let persistence = Persistence::start(&data_dir, session, &mut core, &FileWriterThread::start());
    let sockets = LinkSockets::bind(&link_endpoints(&config)).map_err(|e| format!("MAVLink links: {e}"))?;

    let devices = Devices::start(&config, edge.origin(), edge.handle());
    let period = core.loop_period();
    let trims = servo_trims(&core);
    let actuators = PwmActuators::start(&config.pwm, &trims, 3 * period);

    let tcp = sockets.bound.tcp.map_or("none".into(), |a| a.to_string());
    let udp = sockets.bound.udp_local.map_or("none".into(), |a| a.to_string());
    // One line on stdout that scripts and tests parse for the bound ports.
    let listeners = sockets.bound.ready_suffix();
    println!(
        "furrow run ready: tcp {tcp}, udp {udp}, sysid {}{listeners}",
        core.sysid()
    );
    tracing::info!("vehicle from {}:\n{}", config_path.display(), config.summary());

    let mut vehicle = RealVehicle {
        core,
        inputs: Inputs::default(),
        outputs: Outputs::default(),
        devices,
        actuators,
        ticks: WallTicks::new(period),
        next_health: Duration::ZERO,
    };
    edge.run(&mut vehicle, sockets, persistence, shutdown::signal())
}

/// The core with the configured devices and PWM outputs, ticking at its
/// loop period on the wall clock.
struct RealVehicle {
    core: Core,
    inputs: Inputs,
    outputs: Outputs,
    devices: Devices,
    actuators: PwmActuators,
    ticks: WallTicks,
    next_health: Duration,
}

impl Platform for RealVehicle {
    fn core(&self) -> &Core {
        &self.core
    }

    fn inputs_mut(&mut self) -> &mut Inputs {
        &mut self.inputs
    }

    fn answer_at_edge(&mut self, message: &Inbound, wall: Duration, replies: &mut Vec<Outbound>) -> bool {
        answer_at_edge(message, &mut self.devices, &self.actuators, replies, wall)
    }

    fn tick(&mut self, wall: Duration, timer: &mut InstantTimer) -> &mut Outputs {
        // A tick more than a period late: the outputs of the last one are
        // stale, so they go to trim before anything else happens.
        if self.ticks.start(wall) {
            self.actuators.to_trim();
        }
        self.devices.poll(wall, &mut self.inputs);
        let now = Now { boot: wall, wall };
        self.core.step(now, &self.inputs, &mut self.outputs, timer);
        self.inputs.clear();
        self.actuators.apply(&self.outputs.servo_pwm_us);
        if wall >= self.next_health {
            self.next_health = wall + HEALTH_EVERY;
            for (report, healthy) in self.devices.changes(wall, STARTUP_GRACE) {
                announce(&mut self.core, &report, healthy);
            }
        }
        &mut self.outputs
    }

    fn service_links(&mut self, wall: Duration) -> &mut Outputs {
        self.core.service_links(wall, &self.inputs, &mut self.outputs);
        self.inputs.link_events.clear();
        self.inputs.messages.clear();
        self.inputs.undecodable_items.clear();
        self.inputs.saved.clear();
        &mut self.outputs
    }

    fn until_next_tick(&mut self, wall: Duration) -> Option<Duration> {
        self.ticks.until_next(wall)
    }

    fn stop(&mut self, wall: Duration, dropped_to_links: u64) {
        self.actuators.to_trim();
        let ticks = self.core.scheduler().tick_stats();
        tracing::info!(
            "stopped after {:.1} s: tick median {:.2} µs, p99 {:.2} µs, {} overruns, {} late ticks, {} watchdog trims, {} corrections dropped, {} messages dropped to links",
            wall.as_secs_f64(),
            ticks.histogram.quantile_ns(0.5) as f64 / 1000.0,
            ticks.histogram.quantile_ns(0.99) as f64 / 1000.0,
            self.core.scheduler().total_overruns(),
            self.ticks.late_ticks,
            self.actuators.watchdog_trips(),
            self.devices.rtcm_dropped(),
            dropped_to_links,
        );
    }
}

/// The first `tcpin:` endpoint is the TCP server (stream slot 0), the first
/// `udp:` the UDP link (slot 1); the rest are extra endpoints, the secure
/// ones last (a secure link never takes slot 0 or 1).
fn link_endpoints(config: &VehicleConfig) -> LinkEndpoints {
    let mut endpoints = LinkEndpoints::default();
    let mut plain = Vec::new();
    for endpoint in &config.mavlink {
        match endpoint {
            Endpoint::TcpServer { host, port } if endpoints.tcp_server.is_none() => {
                endpoints.tcp_server = Some(format!("{host}:{port}"));
            }
            Endpoint::UdpOut { host, port } if endpoints.udp_out.is_none() => {
                endpoints.udp_out = Some(format!("{host}:{port}"));
            }
            other => plain.push(other.clone()),
        }
    }
    endpoints.extra = sockets::extra_links(&plain, &config.secure_mavlink);
    endpoints
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

/// True when the message was for the edge and has been handled.
fn answer_at_edge(
    m: &Inbound,
    devices: &mut Devices,
    actuators: &PwmActuators,
    replies: &mut Vec<Outbound>,
    now: Duration,
) -> bool {
    match &m.message {
        MavMessage::GPS_RTCM_DATA(d) => {
            let len = usize::from(d.len).min(d.data.len());
            devices.mavlink_rtcm(d.flags, &d.data[..len]);
            true
        }
        MavMessage::COMMAND_LONG(c) if c.command == STATUS_COMMAND => {
            let mut reply = |message: MavMessage| {
                replies.push(Outbound {
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
