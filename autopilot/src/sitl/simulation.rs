//! The simulated vehicle: world, NMEA driver and core stepped in lockstep
//! at the core's rate. No threads, no sockets, no clocks: the caller gives
//! the wall time and the link traffic, so the same seed and the same inputs
//! give a bit-identical trajectory.

use std::time::Duration;

use drivers::gnss::NmeaReader;
use drivers::magnetic::MagneticSample;
use drivers::scanner::Scan;
use drivers::scanner::cola::{ColaFramer, encode_lmd_scandata, parse_lmd_scandata, telegram_from_scan};
use drivers::sim::{AckermannConfig, ActuatorDemand, DifferentialConfig, GeoPoint, VehicleModel, World, WorldConfig};
use params::{ParamTable, ParamTableBuilder};

use super::faults::Faults;
use super::params::SimParams;
use crate::control::defaults;
use crate::control::mixer::DriveTrain;
use crate::time::{Now, TaskTimer};
use crate::vehicle::{Core, CoreParams, Inputs, Outputs, ScanInput, SimTruth};

/// The simulated vehicle type (`--model`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelKind {
    Ackermann,
    Differential,
}

/// Everything fixed at the start of a simulation.
#[derive(Clone, Debug)]
pub struct SimulationConfig {
    pub home: GeoPoint,
    pub home_heading_deg: f64,
    pub model: ModelKind,
    pub seed: u64,
    /// UTC at simulated time zero (the GNSS clock).
    pub utc_start_unix_us: i64,
}

impl Default for SimulationConfig {
    fn default() -> Self {
        let world = WorldConfig::default();
        SimulationConfig {
            home: world.home,
            home_heading_deg: 0.0,
            model: ModelKind::Ackermann,
            seed: 1,
            utc_start_unix_us: world.utc_start_unix_us,
        }
    }
}

/// The parameter table of a simulated vehicle: the core's parameters plus
/// `SIM_*`, with the defaults of the chosen model (like ArduPilot's
/// per-frame defaults files).
pub struct SimulationParams {
    pub table: ParamTable,
    pub core: CoreParams,
    pub sim: SimParams,
}

impl SimulationParams {
    pub fn new(model: ModelKind) -> Self {
        let mut builder = ParamTableBuilder::new();
        let core = CoreParams::register(&mut builder);
        let sim = SimParams::register(&mut builder);
        // The bench antenna sits 0.5 m ahead of the rear axle.
        builder.override_default("GPS_POS1_X", 0.5);
        if model == ModelKind::Differential {
            let diff = DifferentialConfig::default();
            defaults::apply(&mut builder, DriveTrain::Differential);
            builder.override_default("VEH_TRACK", diff.track_m);
            builder.override_default("VEH_WHEELBASE", 1.0);
            builder.override_default("CRUISE_SPEED", diff.wheel_speed_max_mps / 2.0);
            builder.override_default("WP_SPEED", 1.0);
            // A small skid-steer rover with its scanners on the bumpers.
            builder.override_default("VEH_LEN_FRONT", 0.5);
            builder.override_default("VEH_LEN_REAR", 0.5);
            builder.override_default("VEH_WIDTH", 0.7);
            builder.override_default("SCAN1_POS_X", 0.5);
            builder.override_default("SCAN2_POS_X", -0.5);
        }
        SimulationParams {
            table: builder.build(),
            core,
            sim,
        }
    }

    /// Sets each NAME to VALUE, as a GCS would (same checks).
    pub fn apply(&mut self, values: &[(String, f64)]) -> Result<(), String> {
        for (name, value) in values {
            let index = self
                .table
                .index_of(name)
                .ok_or_else(|| format!("{name}: no such parameter"))?;
            self.table
                .set(index, *value)
                .map_err(|e| format!("{name} = {value}: {e:?}"))?;
        }
        Ok(())
    }
}

pub struct Simulation {
    world: World,
    nmea: NmeaReader,
    core: Core,
    sim: SimParams,
    inputs: Inputs,
    outputs: Outputs,
    gnss_bytes: Vec<u8>,
    /// The simulated scanners' scans, and the CoLa-A bytes they travel as.
    scans: Vec<(usize, Scan)>,
    scanner_links: Vec<ScannerLink>,
    param_generation: u64,
    faults: Faults,
    /// What the actuators did on this step (a stuck one keeps it).
    applied: ActuatorDemand,
}

/// One simulated scanner's wire: the scan is sent as the LMS1xx's CoLa-A
/// telegram and read back by the real driver's framer and parser, so SITL
/// exercises the same bytes a vehicle does.
struct ScannerLink {
    framer: ColaFramer,
    telegram_counter: u32,
    bytes: Vec<u8>,
    /// Telegrams the parser refused (never expected; counted for tests).
    malformed: u64,
}

impl ScannerLink {
    fn new() -> Self {
        ScannerLink {
            framer: ColaFramer::new(),
            telegram_counter: 0,
            bytes: Vec::new(),
            malformed: 0,
        }
    }

    fn carry(&mut self, scan: &Scan, rate_hz: f64) -> Option<Scan> {
        self.telegram_counter = self.telegram_counter.wrapping_add(1);
        let telegram = telegram_from_scan(scan, rate_hz, self.telegram_counter);
        self.bytes = encode_lmd_scandata(&telegram);
        self.framer.push(&self.bytes);
        let mut received = None;
        while let Some(frame) = self.framer.pop() {
            match parse_lmd_scandata(&frame) {
                Ok(t) => received = Some(t.to_scan(scan.t)),
                Err(_) => self.malformed += 1,
            }
        }
        received
    }
}

impl Simulation {
    pub fn new(config: &SimulationConfig, params: SimulationParams) -> Self {
        let vehicle = match config.model {
            ModelKind::Ackermann => VehicleModel::Ackermann(AckermannConfig::default()),
            ModelKind::Differential => VehicleModel::Differential(DifferentialConfig::default()),
        };
        let world_config = WorldConfig {
            home: config.home,
            home_heading_deg: config.home_heading_deg,
            vehicle,
            gnss: params.sim.gnss_config(&params.table),
            utc_start_unix_us: config.utc_start_unix_us,
            ..WorldConfig::default()
        };
        let generation = params.table.generation();
        let mut sim = Simulation {
            world: World::new(world_config, config.seed),
            nmea: NmeaReader::new(),
            core: Core::new(params.table, params.core),
            sim: params.sim,
            inputs: Inputs::default(),
            outputs: Outputs::default(),
            gnss_bytes: Vec::new(),
            scans: Vec::new(),
            scanner_links: Vec::new(),
            param_generation: generation,
            faults: Faults::default(),
            applied: ActuatorDemand::STOP,
        };
        sim.configure_scanners();
        sim
    }

    /// The inputs of the next step, as gathered so far.
    pub fn inputs(&self) -> &Inputs {
        &self.inputs
    }

    /// The inputs of the next step: add link events and messages here.
    pub fn inputs_mut(&mut self) -> &mut Inputs {
        &mut self.inputs
    }

    /// Advances world and core by one core period. `wall` is the wall time
    /// since start (what GCS-facing timers use). Returns this step's outputs
    /// (their MAVLink messages accumulate until the caller drains them).
    pub fn step(&mut self, wall: Duration, timer: &mut dyn TaskTimer) -> &mut Outputs {
        // The log's commands are this call's alone (a caller that wants
        // them takes them after each call).
        self.outputs.log.clear();
        let period = self.core.loop_period();
        let actuators = self.faults.actuate(self.outputs.actuators, self.core.is_armed());
        let speed_before_mps = self.world.truth().speed_mps;
        self.world.step(period, &actuators);
        self.applied = actuators;
        let now = Now {
            boot: self.world.time(),
            wall,
        };

        self.gnss_bytes.clear();
        self.world.take_gnss_bytes(&mut self.gnss_bytes);
        self.nmea.push(now.boot, &self.gnss_bytes, &mut self.inputs.gnss);
        let mut battery = self.world.battery();
        let forced_v = f64::from(self.sim.battery_volt.get(self.core.params()));
        if forced_v > 0.0 {
            battery.voltage_v = forced_v;
        }
        self.inputs.battery = Some(battery);
        self.inputs.sim_truth = Some(self.sim_truth(speed_before_mps, period));
        self.inputs.magnetic = self
            .world
            .magnetic_sensors()
            .map(|(front_mask, rear_mask)| MagneticSample {
                t: now.boot,
                front_mask,
                rear_mask,
            });

        self.scans.clear();
        self.world.take_scans(&mut self.scans);
        let rate_hz = f64::from(self.sim.scan_rate_hz.get(self.core.params()));
        for (scanner, scan) in &self.scans {
            if self.scanner_links.len() <= *scanner {
                self.scanner_links.resize_with(*scanner + 1, ScannerLink::new);
            }
            if let Some(scan) = self.scanner_links[*scanner].carry(scan, rate_hz) {
                self.inputs.scans.push(ScanInput {
                    scanner: *scanner,
                    scan,
                });
            }
        }

        // A stalled core reads nothing: its inputs wait in the queues (as
        // bytes in a serial buffer would) while the world drives on.
        if self.faults.core_stalled(now.boot) {
            return &mut self.outputs;
        }
        if self.faults.link_lost(now.boot) {
            self.lose_link_traffic();
        }
        let sent_before = self.outputs.mavlink.len();
        self.core.step(now, &self.inputs, &mut self.outputs, timer);
        self.inputs.clear();
        if self.faults.link_lost(now.boot) {
            self.outputs.mavlink.truncate(sent_before);
        }

        if self.core.params().generation() != self.param_generation {
            self.params_changed(now.boot);
        }
        &mut self.outputs
    }

    /// The world's true pose for the core to report (SIMSTATE, a stop's
    /// true error); the acceleration over the step just taken.
    fn sim_truth(&self, speed_before_mps: f64, period: Duration) -> SimTruth {
        let truth = self.world.truth();
        let at = self.world.truth_geodetic();
        let dt_s = period.as_secs_f64();
        SimTruth {
            lat_deg: at.lat_deg,
            lon_deg: at.lon_deg,
            yaw_rad: truth.yaw_rad,
            yaw_rate_rad_s: truth.yaw_rate_rad_s,
            speed_mps: truth.speed_mps,
            accel_mps2: if dt_s > 0.0 {
                (truth.speed_mps - speed_before_mps) / dt_s
            } else {
                0.0
            },
        }
    }

    fn params_changed(&mut self, now: Duration) {
        let yaw_deg = self.world.truth().yaw_rad.to_degrees();
        let resets = self
            .faults
            .on_params(&self.sim, self.core.params(), now, yaw_deg, self.applied);
        let table = self.core.params_mut();
        if resets.link_drop {
            let _ = table.set_by_name("SIM_LINK_DROP", 0.0);
        }
        if resets.cpu_stall {
            let _ = table.set_by_name("SIM_CPU_STALL", 0.0);
        }
        self.param_generation = self.core.params().generation();
        let mut gnss = self.sim.gnss_config(self.core.params());
        gnss.heading_hold_deg = self.faults.heading_hold_deg;
        self.world.set_gnss_config(gnss);
        self.configure_scanners();
    }

    /// Messages from the links are lost; link events (a client connecting)
    /// still come, as the sockets themselves are fine.
    fn lose_link_traffic(&mut self) {
        self.inputs.messages.clear();
        self.inputs.undecodable_items.clear();
    }

    /// Between steps: the core answers the link traffic queued in the inputs
    /// at once (link events and messages); sensors wait for the next step.
    pub fn service_links(&mut self, wall: Duration) -> &mut Outputs {
        self.outputs.log.clear();
        let now = self.world.time();
        if self.faults.core_stalled(now) {
            return &mut self.outputs;
        }
        if self.faults.link_lost(now) {
            self.lose_link_traffic();
        }
        let sent_before = self.outputs.mavlink.len();
        self.core.service_links(wall, &self.inputs, &mut self.outputs);
        if self.faults.link_lost(now) {
            self.outputs.mavlink.truncate(sent_before);
        }
        self.inputs.link_events.clear();
        self.inputs.messages.clear();
        self.inputs.undecodable_items.clear();
        &mut self.outputs
    }

    fn configure_scanners(&mut self) {
        let configs = self
            .sim
            .scanner_configs(self.core.params(), &self.core.param_handles().obstacles.scanners);
        self.world.set_scanners(configs);
    }

    /// Telegrams the scanner parser refused on the simulated wire.
    pub fn malformed_scans(&self) -> u64 {
        self.scanner_links.iter().map(|l| l.malformed).sum()
    }

    pub fn world(&self) -> &World {
        &self.world
    }

    /// The world, to lay a magnetic tape or change the GNSS between steps.
    pub fn world_mut(&mut self) -> &mut World {
        &mut self.world
    }

    pub fn core(&self) -> &Core {
        &self.core
    }

    pub fn core_mut(&mut self) -> &mut Core {
        &mut self.core
    }

    pub fn nmea(&self) -> &NmeaReader {
        &self.nmea
    }

    /// `SIM_SPEEDUP` now (None: as fast as possible).
    pub fn speedup(&self) -> Option<f64> {
        self.sim.speedup(self.core.params())
    }

    /// Simulated time.
    pub fn time(&self) -> Duration {
        self.world.time()
    }

    /// The demand the world received on the last step.
    pub fn last_demand(&self) -> ActuatorDemand {
        self.outputs.actuators
    }
}
