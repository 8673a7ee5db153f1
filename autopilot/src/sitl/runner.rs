//! `furrow sitl`: the simulated world and its devices around the core, on
//! simulated time paced against the wall clock, run by the edge runner.

use std::path::PathBuf;
use std::time::Duration;

use super::fleet_homes::FleetHome;
use super::simulation::{Simulation, SimulationConfig, SimulationParams};
use crate::edge::clock::{InstantTimer, Pacer};
use crate::edge::mqtt::MqttConfig;
use crate::edge::persistence::{self, Persistence};
use crate::edge::runner::{EdgeRunner, Platform};
use crate::edge::shutdown;
use crate::fleet::AgentConfig;
use crate::link::endpoint::Endpoint;
use crate::link::sockets::{self, LinkEndpoints, LinkSockets};
use crate::storage::data_dir::{DataDir, Profile};
use crate::storage::file_writer::FileWriterThread;
use crate::storage::session::SessionParams;
use crate::vehicle::{Core, Inputs, Outputs};

/// `--speedup`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Speedup {
    Factor(f64),
    Max,
}

#[derive(Clone, Debug)]
pub struct SitlOptions {
    pub sim: SimulationConfig,
    /// Overrides `SIM_SPEEDUP` at start.
    pub speedup: Option<Speedup>,
    pub instance: u16,
    pub data_dir: PathBuf,
    /// TCP server port (default 5760 + 10·instance; 0 picks a free port).
    pub tcp_port: Option<u16>,
    /// Where the UDP link sends (default 127.0.0.1:14550 + 10·instance).
    pub udp_port: Option<u16>,
    pub mavlink: Vec<Endpoint>,
    /// Extra endpoints that are secure links (SETUP_SIGNING accepted,
    /// unsigned packets always accepted); slots after `mavlink`'s.
    pub secure_mavlink: Vec<Endpoint>,
    pub tlog: Option<PathBuf>,
    /// A magnetic tape through a waypoint file's points, corner radius.
    pub tape: Option<(PathBuf, f64)>,
    /// A world file (obstacles, moving people, tape), reloaded when it
    /// changes.
    pub world: Option<PathBuf>,
    /// VDA 5050 over MQTT: the broker, who this vehicle is, its map.
    pub vda5050: Option<(MqttConfig, AgentConfig)>,
    /// Several vehicles in this process, sharing one world.
    pub fleet: Option<FleetOptions>,
}

/// `--fleet N`: N vehicles in one process sharing one world.
#[derive(Clone, Debug)]
pub struct FleetOptions {
    pub count: usize,
    /// `--fleet-homes`: where each starts (default: side by side).
    pub homes: Option<PathBuf>,
}

/// Runs until SIGINT/SIGTERM.
pub fn run(options: SitlOptions) -> Result<(), String> {
    if let Some(fleet) = &options.fleet {
        return super::fleet_runner::run(&options, fleet);
    }
    let world_watch = options.world.clone().map(WorldWatch::new);
    let slot = VehicleSlot {
        data_dir: options.data_dir.clone(),
        seed: options.sim.seed,
        instance: options.instance,
        tcp_port: options.tcp_port,
        udp_port: options.udp_port,
        sysid: None,
        place: None,
        vda5050: options.vda5050.clone(),
    };
    let prepared = prepare(&options, &slot, &FileWriterThread::start())?;
    let mut edge = EdgeRunner::new()?;
    if let Some((mqtt, _)) = options.vda5050.clone() {
        edge = edge.with_vda5050(mqtt);
    }
    // One line on stdout that scripts and tests parse for the bound ports
    // (new fields go at the end).
    println!("furrow sitl ready: {}", prepared.ready);
    log_start(&options);
    let _data_dir_lock = prepared.data_dir;
    let mut platform = SimulatedVehicle {
        sim: prepared.sim,
        world_watch,
        pacer: Pacer::default(),
    };
    edge.run(
        &mut platform,
        prepared.sockets,
        prepared.persistence,
        shutdown::signal(),
    )
}

/// What differs between the vehicles of a fleet.
pub(super) struct VehicleSlot {
    pub data_dir: PathBuf,
    pub seed: u64,
    /// Ports move by 10 per instance.
    pub instance: u16,
    pub tcp_port: Option<u16>,
    pub udp_port: Option<u16>,
    /// `SYSID_THISMAV` unless the data directory keeps one.
    pub sysid: Option<u8>,
    /// Where it starts about the home (default: at home).
    pub place: Option<FleetHome>,
    pub vda5050: Option<(MqttConfig, AgentConfig)>,
}

/// One simulated vehicle ready to run.
pub(super) struct Prepared {
    pub sim: Simulation,
    pub persistence: Persistence,
    pub sockets: LinkSockets,
    /// What `furrow sitl ready:` says about it.
    pub ready: String,
    /// Held while the vehicle runs: its lock keeps `furrow params` and a
    /// second `furrow sitl` out of the directory.
    pub data_dir: DataDir,
}

/// The vehicle of `slot`: its data directory opened (its files written on
/// `writers`), its simulation built, its links bound.
pub(super) fn prepare(
    options: &SitlOptions,
    slot: &VehicleSlot,
    writers: &FileWriterThread,
) -> Result<Prepared, String> {
    let data_dir = DataDir::open(&slot.data_dir, Profile::Sitl(options.sim.model))?;
    let mut params = SimulationParams::new(options.sim.model);
    if let Some(sysid) = slot.sysid {
        params.apply(&[("SYSID_THISMAV".to_owned(), f64::from(sysid))])?;
    }
    let mut session = SessionParams::load(data_dir.path(), &mut params.table)?;
    if let Some(speedup) = options.speedup {
        let value = match speedup {
            Speedup::Factor(f) => f,
            Speedup::Max => 0.0,
        };
        session
            .set_override(&mut params.table, "SIM_SPEEDUP", value)
            .map_err(|e| format!("--speedup: {e}"))?;
    }
    let config = SimulationConfig {
        seed: slot.seed,
        ..options.sim.clone()
    };
    let mut sim = Simulation::new(&config, params);
    if let Some(home) = slot.place {
        let (north_m, east_m) = (home.north_m, home.east_m);
        sim.world_mut().place(north_m, east_m, home.heading_deg.to_radians());
    }
    lay_tape_and_world(options, &mut sim)?;
    persistence::restore(&data_dir, &mut session, sim.core_mut());
    let persistence = Persistence::start(&data_dir, session, sim.core_mut(), writers);

    let offset = 10 * slot.instance;
    let tcp_port = slot.tcp_port.unwrap_or(5760 + offset);
    let udp_port = slot.udp_port.unwrap_or(14550 + offset);
    let sockets = LinkSockets::bind(&LinkEndpoints {
        tcp_server: Some(format!("0.0.0.0:{tcp_port}")),
        udp_out: Some(format!("127.0.0.1:{udp_port}")),
        extra: sockets::extra_links(&options.mavlink, &options.secure_mavlink),
        tlog: options.tlog.clone(),
    })
    .map_err(|e| format!("MAVLink links: {e}"))?;

    let mut fleet_suffix = String::new();
    if let Some((mqtt, agent)) = slot.vda5050.clone() {
        fleet_suffix = format!(", vda5050 {}", mqtt.prefix.topic(vda5050::Topic::State));
        tracing::info!("VDA 5050: broker {}:{}, map {:?}", mqtt.host, mqtt.port, agent.map_id);
        sim.core_mut().enable_vda5050(agent);
    }
    let tcp = sockets.bound.tcp.map_or("none".into(), |a| a.to_string());
    let udp = sockets.bound.udp_local.map_or("none".into(), |a| a.to_string());
    let listeners = sockets.bound.ready_suffix();
    let ready = format!(
        "tcp {tcp}, udp {udp} to 127.0.0.1:{udp_port}, sysid {}{listeners}{fleet_suffix}",
        sim.core().sysid()
    );
    Ok(Prepared {
        sim,
        persistence,
        sockets,
        ready,
        data_dir,
    })
}

/// `--tape` and `--world` into the simulation (each vehicle of a fleet
/// gets the same: they share one home frame).
fn lay_tape_and_world(options: &SitlOptions, sim: &mut Simulation) -> Result<(), String> {
    if let Some((path, radius_m)) = &options.tape {
        let tape = super::tape::load(path, sim.world(), *radius_m).map_err(|e| format!("--tape {e}"))?;
        tracing::info!("magnetic tape laid: {:.1} m from {}", tape.length_m(), path.display());
        sim.world_mut().set_tape(Some(tape));
    }
    if let Some(path) = &options.world {
        let file = sim::load_world_file(path).map_err(|e| format!("--world {}: {e}", path.display()))?;
        if file.tape().is_some() && options.tape.is_some() {
            return Err(format!(
                "--world {} lays a tape and so does --tape: give one",
                path.display()
            ));
        }
        apply_world(sim, &file);
        tracing::info!("world loaded from {}", path.display());
    }
    Ok(())
}

pub(super) fn log_start(options: &SitlOptions) {
    tracing::info!(
        "SITL: home {:.7},{:.7} heading {:.1}°, model {:?}, seed {}, data {}",
        options.sim.home.lat_deg,
        options.sim.home.lon_deg,
        options.sim.home_heading_deg,
        options.sim.model,
        options.sim.seed,
        options.data_dir.display()
    );
}

/// The simulated world and its devices around the core, on simulated time
/// paced against the wall clock by `SIM_SPEEDUP`.
struct SimulatedVehicle {
    sim: Simulation,
    world_watch: Option<WorldWatch>,
    pacer: Pacer,
}

impl Platform for SimulatedVehicle {
    fn core(&self) -> &Core {
        self.sim.core()
    }

    fn inputs_mut(&mut self) -> &mut Inputs {
        self.sim.inputs_mut()
    }

    fn tick(&mut self, wall: Duration, timer: &mut InstantTimer) -> &mut Outputs {
        if let Some(watch) = &mut self.world_watch {
            watch.poll(wall, std::slice::from_mut(&mut self.sim));
        }
        self.sim.step(wall, timer)
    }

    fn service_links(&mut self, wall: Duration) -> &mut Outputs {
        self.sim.service_links(wall)
    }

    fn until_next_tick(&mut self, wall: Duration) -> Option<Duration> {
        let period = self.sim.core().loop_period();
        let next_sim = self.sim.time() + period;
        self.pacer.delay(next_sim, wall, self.sim.speedup(), period)
    }

    fn stop(&mut self, wall: Duration, dropped_to_links: u64) {
        let core = self.sim.core();
        let ticks = core.scheduler().tick_stats();
        tracing::info!(
            "SITL stopped after {:.1} s simulated in {:.1} s: tick median {:.2} µs, p99 {:.2} µs, {} overruns, {} pacing restarts, {} messages dropped to links, {} late ticks",
            self.sim.time().as_secs_f64(),
            wall.as_secs_f64(),
            ticks.histogram.quantile_ns(0.5) as f64 / 1000.0,
            ticks.histogram.quantile_ns(0.99) as f64 / 1000.0,
            core.scheduler().total_overruns(),
            self.pacer.late_restarts,
            dropped_to_links,
            self.pacer.late_ticks,
        );
    }
}

/// Puts a world file's obstacles (and tape, if it has one) into the
/// simulation.
pub(super) fn apply_world(sim: &mut Simulation, file: &sim::WorldFile) {
    sim.world_mut().set_obstacles(Some(file.obstacles()));
    if let Some(tape) = file.tape() {
        sim.world_mut().set_tape(Some(tape));
    }
}

/// Reloads the world file when its modification time changes (checked
/// once a wall second). A file that no longer parses keeps the old world
/// and says why.
pub(super) struct WorldWatch {
    path: PathBuf,
    modified: Option<std::time::SystemTime>,
    next_check: Duration,
}

impl WorldWatch {
    const EVERY: Duration = Duration::from_secs(1);

    pub(super) fn new(path: PathBuf) -> Self {
        let modified = std::fs::metadata(&path).and_then(|m| m.modified()).ok();
        WorldWatch {
            path,
            modified,
            next_check: Self::EVERY,
        }
    }

    /// Every vehicle of a fleet gets the reloaded world.
    pub(super) fn poll(&mut self, wall: Duration, sims: &mut [Simulation]) {
        if wall < self.next_check {
            return;
        }
        self.next_check = wall + Self::EVERY;
        let modified = std::fs::metadata(&self.path).and_then(|m| m.modified()).ok();
        if modified.is_none() || modified == self.modified {
            return;
        }
        self.modified = modified;
        use mavlink::dialects::ardupilotmega::MavSeverity;
        match sim::load_world_file(&self.path) {
            Ok(file) => {
                tracing::info!("world reloaded from {}", self.path.display());
                for sim in sims {
                    apply_world(sim, &file);
                    sim.core_mut()
                        .announce(MavSeverity::MAV_SEVERITY_INFO, "SIM: world reloaded");
                }
            }
            Err(e) => {
                tracing::warn!("world file {}: {e}; keeping the old world", self.path.display());
                for sim in sims {
                    sim.core_mut().announce(
                        MavSeverity::MAV_SEVERITY_WARNING,
                        "SIM: world file invalid, kept old world",
                    );
                }
            }
        }
    }
}
