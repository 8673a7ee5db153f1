//! `furrow sitl --fleet N`: N simulated vehicles in one process, on one
//! tokio runtime, sharing one world ([`FleetSimulation`]). Vehicle `i` is
//! instance I+i (its own MAVLink ports), keeps its data in
//! `<data-dir>/vehicle-<i>`, has `SYSID_THISMAV` i+1 (unless its data
//! directory keeps another) and VDA 5050 serial number `<serial>-<i>`. The
//! fleet runs on one clock: vehicle 0's `SIM_SPEEDUP`.

use std::time::Duration;

use vda5050::TopicPrefix;

use super::fleet::FleetSimulation;
use super::fleet_homes::{self, FleetHome};
use super::runner::{self, FleetOptions, SitlOptions, VehicleSlot, WorldWatch};
use super::simulation::Simulation;
use crate::edge::clock::{InstantTimer, Pacer};
use crate::edge::fleet::{FleetMember, FleetPlatform};
use crate::edge::mqtt::MqttConfig;
use crate::edge::runner::{EdgeRunner, LinkServed};
use crate::edge::shutdown;
use crate::fleet::AgentConfig;
use crate::storage::file_writer::FileWriterThread;
use crate::vehicle::{Core, Inbound, Inputs, Outbound, Outputs};

/// One SYSID_THISMAV each, 1 to 250.
pub const MAX_FLEET: usize = 250;

/// Runs the fleet until SIGINT/SIGTERM.
pub fn run(options: &SitlOptions, fleet: &FleetOptions) -> Result<(), String> {
    let count = fleet.count;
    if !(1..=MAX_FLEET).contains(&count) {
        return Err(format!("--fleet {count}: from 1 to {MAX_FLEET} vehicles"));
    }
    if options.tlog.is_some() || !options.mavlink.is_empty() || !options.secure_mavlink.is_empty() {
        return Err("--fleet: --tlog, --mavlink and --secure-mavlink are for one vehicle; each vehicle of a fleet has its TCP and UDP links".into());
    }
    let homes = match &fleet.homes {
        Some(path) => fleet_homes::load(path, count).map_err(|e| format!("--fleet-homes {e}"))?,
        None => fleet_homes::in_a_row(count, options.sim.home_heading_deg),
    };
    let mut vehicles = Vec::with_capacity(count);
    let mut members = Vec::with_capacity(count);
    // Each vehicle's data directory stays locked while the fleet runs.
    let mut data_dir_locks = Vec::with_capacity(count);
    // One thread writes every vehicle's files (a thread per vehicle would
    // mostly sleep).
    let writers = FileWriterThread::start();
    for (index, home) in homes.into_iter().enumerate() {
        let slot = slot(options, index, home)?;
        let prepared = runner::prepare(options, &slot, &writers)?;
        println!("furrow sitl ready: vehicle {index}: {}", prepared.ready);
        vehicles.push(prepared.sim);
        data_dir_locks.push(prepared.data_dir);
        members.push(FleetMember {
            sockets: prepared.sockets,
            persistence: prepared.persistence,
            mqtt: slot.vda5050.map(|(mqtt, _)| mqtt),
        });
    }
    // The line scripts wait for: every vehicle is listening.
    println!("furrow sitl fleet ready: {count} vehicles");
    runner::log_start(options);
    let mut platform = SimulatedFleet {
        fleet: FleetSimulation::new(vehicles),
        world_watch: options.world.clone().map(WorldWatch::new),
        pacer: Pacer::default(),
    };
    let result = EdgeRunner::new()?.run_fleet(&mut platform, members, shutdown::signal());
    drop(data_dir_locks);
    result
}

/// Vehicle `index` of the fleet: instance, ports, data, seed and serial of
/// its own.
fn slot(options: &SitlOptions, index: usize, home: FleetHome) -> Result<VehicleSlot, String> {
    let offset = u16::try_from(index).map_err(|_| "fleet too large".to_owned())?;
    let instance = options
        .instance
        .checked_add(offset)
        .filter(|&i| usize::from(i) * 10 + 14550 <= usize::from(u16::MAX))
        .ok_or_else(|| format!("--fleet: instance {} + {index} leaves the port range", options.instance))?;
    // Port 0 asks for a free port for every vehicle; any other moves by 10.
    let port = |base: Option<u16>| base.map(|p| if p == 0 { 0 } else { p.saturating_add(10 * offset) });
    Ok(VehicleSlot {
        data_dir: options.data_dir.join(format!("vehicle-{index}")),
        seed: options.sim.seed.wrapping_add(index as u64),
        instance,
        tcp_port: port(options.tcp_port),
        udp_port: port(options.udp_port),
        sysid: Some(offset as u8 + 1),
        place: Some(home),
        vda5050: options
            .vda5050
            .as_ref()
            .map(|(mqtt, agent)| member_vda5050(mqtt, agent, index))
            .transpose()?,
    })
}

/// The fleet's broker settings for vehicle `index`: serial `<serial>-<i>`.
fn member_vda5050(mqtt: &MqttConfig, agent: &AgentConfig, index: usize) -> Result<(MqttConfig, AgentConfig), String> {
    let p = &mqtt.prefix;
    let serial = format!("{}-{index}", p.serial_number);
    let prefix =
        TopicPrefix::new(&p.interface_name, &p.major_version, &p.manufacturer, &serial).map_err(|e| e.to_string())?;
    let member = MqttConfig {
        client_id: format!("{}-{index}", mqtt.client_id),
        prefix,
        ..mqtt.clone()
    };
    Ok((member, agent.clone()))
}

/// The fleet and its clock, as the edge runner drives it.
struct SimulatedFleet {
    fleet: FleetSimulation,
    world_watch: Option<WorldWatch>,
    pacer: Pacer,
}

impl LinkServed for Simulation {
    fn core(&self) -> &Core {
        Simulation::core(self)
    }

    fn inputs_mut(&mut self) -> &mut Inputs {
        Simulation::inputs_mut(self)
    }

    fn answer_at_edge(&mut self, _message: &Inbound, _wall: Duration, _replies: &mut Vec<Outbound>) -> bool {
        false
    }

    fn service_links(&mut self, wall: Duration) -> &mut Outputs {
        Simulation::service_links(self, wall)
    }
}

impl FleetPlatform for SimulatedFleet {
    type Vehicle = Simulation;

    fn vehicles_mut(&mut self) -> &mut [Simulation] {
        self.fleet.vehicles_mut()
    }

    fn before_ticks(&mut self, wall: Duration) {
        if let Some(watch) = &mut self.world_watch {
            watch.poll(wall, self.fleet.vehicles_mut());
        }
        self.fleet.share_world();
    }

    fn tick(&mut self, index: usize, wall: Duration, timer: &mut InstantTimer) -> &mut Outputs {
        self.fleet.step_one(index, wall, timer)
    }

    fn until_next_tick(&mut self, wall: Duration) -> Option<Duration> {
        let first = &self.fleet.vehicles()[0];
        let period = first.core().loop_period();
        self.pacer.delay(first.time() + period, wall, first.speedup(), period)
    }

    fn stop(&mut self, wall: Duration, dropped_to_links: u64) {
        let vehicles = self.fleet.vehicles();
        let simulated_s = vehicles[0].time().as_secs_f64();
        tracing::info!(
            "SITL fleet of {} stopped after {simulated_s:.1} s simulated in {:.1} s: {} pacing restarts, {} late rounds, {} messages dropped to links",
            vehicles.len(),
            wall.as_secs_f64(),
            self.pacer.late_restarts,
            self.pacer.late_ticks,
            dropped_to_links,
        );
    }
}
