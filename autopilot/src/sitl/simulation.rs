//! The simulated vehicle: world, NMEA driver and core stepped in lockstep
//! at the core's rate. No threads, no sockets, no clocks: the caller gives
//! the wall time and the link traffic, so the same seed and the same inputs
//! give a bit-identical trajectory.

use std::time::Duration;

use drivers::gnss::NmeaReader;
use drivers::magnetic::MagneticSample;
use drivers::scanner::Scan;
use drivers::scanner::cola::{ColaFramer, ScanTelegram, encode_lmd_scandata_into, parse_lmd_scandata_into};
use params::{ParamTable, ParamTableBuilder};
use sim::{
    AckermannConfig, DifferentialConfig, ImuSimConfig, VehicleModel, VehicleOutline, World, WorldConfig,
    WorldStageTimes,
};
use vehicle_types::{ActuatorDemand, GeoPoint};

use super::faults::Faults;
use super::params::SimParams;
use crate::control::defaults;
use crate::control::mixer::DriveTrain;
use crate::logging::LogCommand;
use crate::time::{Now, TaskTimer};
use crate::vehicle::{Core, CoreParams, Inputs, Outputs, ScanInput, SimTruth};

/// Received scans' buffers kept for reuse: a few ticks' worth of two scanners.
const MAX_SPARE_SCANS: usize = 8;

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
    /// The inertial unit on its own port (`$VNIMU` lines), or none.
    pub imu: Option<ImuSimConfig>,
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
            imu: Some(ImuSimConfig::default()),
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
    /// The inertial unit's port: a reader of its own, as on a vehicle.
    imu_reader: NmeaReader,
    imu_bytes: Vec<u8>,
    core: Core,
    sim: SimParams,
    inputs: Inputs,
    outputs: Outputs,
    gnss_bytes: Vec<u8>,
    /// The simulated scanners' scans, and the CoLa-A bytes they travel as.
    scans: Vec<(usize, Scan)>,
    /// Buffers of scans the core has read, for the next ones received.
    spare_scans: Vec<Scan>,
    stage_times: StageTimes,
    /// Whether [`Self::stage_times`] are taken: each stage's clock reads
    /// cost a simulation run that does not report them.
    timing_stages: bool,
    scanner_links: Vec<ScannerLink>,
    param_generation: u64,
    faults: Faults,
    /// What the actuators did on this step (a stuck one keeps it).
    applied: ActuatorDemand,
}

/// Wall time spent in each stage of the simulation's steps, nanoseconds, as
/// read from the timer each step is given once [`Simulation::time_stages`]
/// asked for them (all zero otherwise, or with a frozen timer; the
/// readings change nothing that is computed).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StageTimes {
    /// Physics, GNSS epochs out (NMEA formatting) and scan ray casting.
    pub world: WorldStageTimes,
    /// The NMEA driver reading the receiver's bytes.
    pub gnss_in_ns: u64,
    /// Scans to CoLa-A telegrams.
    pub scan_encode_ns: u64,
    /// Telegrams framed, parsed and converted back to scans.
    pub scan_parse_ns: u64,
    /// [`Core::step`].
    pub core_ns: u64,
}

/// One simulated scanner's wire: the scan is sent as the LMS1xx's CoLa-A
/// telegram and read back by the real driver's framer and parser, so SITL
/// exercises the same bytes a vehicle does. Its buffers are kept from scan
/// to scan, so carrying one allocates nothing once they have grown.
struct ScannerLink {
    framer: ColaFramer,
    telegram_counter: u32,
    /// The telegram as sent and as parsed back.
    sent: ScanTelegram,
    received: ScanTelegram,
    bytes: Vec<u8>,
    frame: Vec<u8>,
    /// Telegrams the parser refused (never expected; counted for tests).
    malformed: u64,
}

impl ScannerLink {
    fn new() -> Self {
        ScannerLink {
            framer: ColaFramer::new(),
            telegram_counter: 0,
            sent: ScanTelegram::default(),
            received: ScanTelegram::default(),
            bytes: Vec::new(),
            frame: Vec::new(),
            malformed: 0,
        }
    }

    /// Sends `scan` over the wire; the scan read back lands in `out`
    /// (whose buffer is reused). False if nothing usable arrived.
    fn carry(
        &mut self,
        scan: &Scan,
        rate_hz: f64,
        out: &mut Scan,
        clock: &mut StageClock<'_>,
        times: &mut StageTimes,
    ) -> bool {
        let started_ns = clock.now_ns();
        self.telegram_counter = self.telegram_counter.wrapping_add(1);
        self.sent.set_from_scan(scan, rate_hz, self.telegram_counter);
        encode_lmd_scandata_into(&self.sent, &mut self.bytes);
        let encoded_ns = clock.now_ns();
        times.scan_encode_ns += encoded_ns.saturating_sub(started_ns);
        self.framer.push(&self.bytes);
        let mut received = false;
        while self.framer.pop_into(&mut self.frame) {
            match parse_lmd_scandata_into(&self.frame, &mut self.received) {
                Ok(()) => {
                    self.received.to_scan_into(scan.t, out);
                    received = true;
                }
                Err(_) => self.malformed += 1,
            }
        }
        times.scan_parse_ns += clock.now_ns().saturating_sub(encoded_ns);
        received
    }
}

/// The step's timer as read for [`StageTimes`]: 0 without reading it when
/// the stages are not being timed.
struct StageClock<'a> {
    timer: &'a mut dyn TaskTimer,
    on: bool,
}

impl StageClock<'_> {
    fn now_ns(&mut self) -> u64 {
        if self.on { self.timer.now_ns() } else { 0 }
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
        let mut world = World::new(world_config, config.seed);
        world.set_imu(config.imu);
        let mut sim = Simulation {
            world,
            nmea: NmeaReader::new(),
            imu_reader: NmeaReader::new(),
            imu_bytes: Vec::new(),
            core: Core::new(params.table, params.core),
            sim: params.sim,
            inputs: Inputs::default(),
            outputs: Outputs::default(),
            gnss_bytes: Vec::new(),
            scans: Vec::new(),
            spare_scans: Vec::new(),
            stage_times: StageTimes::default(),
            timing_stages: false,
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
        self.recycle_log_commands();
        let period = self.core.loop_period();
        let actuators = self.faults.actuate(self.outputs.actuators, self.core.is_armed());
        let speed_before_mps = self.world.truth().speed_mps;
        let timing_stages = self.timing_stages;
        let mut clock = StageClock {
            timer: &mut *timer,
            on: timing_stages,
        };
        self.world.step_timed(period, &actuators, &mut || clock.now_ns());
        self.applied = actuators;
        let now = Now {
            boot: self.world.time(),
            wall,
        };

        let gnss_in_started_ns = clock.now_ns();
        self.gnss_bytes.clear();
        self.world.take_gnss_bytes(&mut self.gnss_bytes);
        self.nmea.push(now.boot, &self.gnss_bytes, &mut self.inputs.gnss);
        self.imu_bytes.clear();
        self.world.take_imu_bytes(&mut self.imu_bytes);
        self.imu_reader.push(now.boot, &self.imu_bytes, &mut self.inputs.gnss);
        self.stage_times.gnss_in_ns += clock.now_ns().saturating_sub(gnss_in_started_ns);
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

        self.carry_scans(&mut clock);

        // A stalled core reads nothing: its inputs wait in the queues (as
        // bytes in a serial buffer would) while the world drives on.
        if self.faults.core_stalled(now.boot) {
            return &mut self.outputs;
        }
        if self.faults.link_lost(now.boot) {
            self.lose_link_traffic();
        }
        let sent_before = self.outputs.mavlink.len();
        let core_started_ns = clock.now_ns();
        self.core.step(now, &self.inputs, &mut self.outputs, timer);
        let mut clock = StageClock {
            timer,
            on: timing_stages,
        };
        self.stage_times.core_ns += clock.now_ns().saturating_sub(core_started_ns);
        self.recycle_inputs();
        if self.faults.link_lost(now.boot) {
            self.cut_off_links(sent_before);
        }

        if self.core.params().generation() != self.param_generation {
            self.params_changed(now.boot);
        }
        &mut self.outputs
    }

    /// The scans the world took, over the simulated wires into the inputs.
    fn carry_scans(&mut self, clock: &mut StageClock<'_>) {
        self.world.take_scans(&mut self.scans);
        let rate_hz = f64::from(self.sim.scan_rate_hz.get(self.core.params()));
        for (scanner, scan) in &self.scans {
            if self.scanner_links.len() <= *scanner {
                self.scanner_links.resize_with(*scanner + 1, ScannerLink::new);
            }
            let mut received = self.spare_scans.pop().unwrap_or_else(|| scan.clone());
            let link = &mut self.scanner_links[*scanner];
            if link.carry(scan, rate_hz, &mut received, clock, &mut self.stage_times) {
                self.inputs.scans.push(ScanInput {
                    scanner: *scanner,
                    scan: received,
                });
            } else {
                self.spare_scans.push(received);
            }
        }
        self.world.recycle_scans(&mut self.scans);
    }

    /// Drops the last call's log commands, handing their record buffers
    /// back to the core for the next records.
    fn recycle_log_commands(&mut self) {
        for command in self.outputs.log.drain(..) {
            if let LogCommand::Records(buffer) = command {
                self.core.recycle_log_records(buffer);
            }
        }
    }

    /// Clears the inputs for the next step, keeping the scans' buffers.
    fn recycle_inputs(&mut self) {
        let room = MAX_SPARE_SCANS.saturating_sub(self.spare_scans.len());
        self.spare_scans
            .extend(self.inputs.scans.drain(..).map(|input| input.scan).take(room));
        self.inputs.clear();
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

    /// Nothing the core sent from `sent_before` on reaches the links, nor
    /// does a download request get answered at the link from its plans.
    fn cut_off_links(&mut self, sent_before: usize) {
        self.outputs.mavlink.truncate(sent_before);
        self.outputs.mission_downloads = None;
    }

    /// Between steps: the core answers the link traffic queued in the inputs
    /// at once (link events and messages); sensors wait for the next step.
    pub fn service_links(&mut self, wall: Duration) -> &mut Outputs {
        self.recycle_log_commands();
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
            self.cut_off_links(sent_before);
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

    /// Times each stage of [`Self::step`] from now on (or not): a
    /// benchmark's breakdown; off by default.
    pub fn time_stages(&mut self, on: bool) {
        self.timing_stages = on;
    }

    /// Wall time spent so far in each stage of [`Self::step`] while
    /// [`Self::time_stages`] was on.
    pub fn stage_times(&self) -> StageTimes {
        StageTimes {
            world: self.world.stage_times(),
            ..self.stage_times
        }
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

    /// The simulated vehicle's outline: as big as its parameters say
    /// (`VEH_LEN_FRONT`, `VEH_LEN_REAR`, `VEH_WIDTH`).
    pub fn outline(&self) -> VehicleOutline {
        let footprint = &self.core.param_handles().obstacles.footprint;
        let p = self.core.params();
        VehicleOutline {
            front_m: f64::from(footprint.front_m.get(p)),
            rear_m: f64::from(footprint.rear_m.get(p)),
            half_width_m: f64::from(footprint.width_m.get(p)) / 2.0,
        }
    }

    /// The outputs of the last step, as the caller left them.
    pub fn outputs_mut(&mut self) -> &mut Outputs {
        &mut self.outputs
    }

    /// The demand the world received on the last step.
    pub fn last_demand(&self) -> ActuatorDemand {
        self.outputs.actuators
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edge::clock::InstantTimer;

    /// The clock is read for the stage times only once they are asked
    /// for: a run that does not report them does not pay for them.
    #[test]
    fn stages_are_timed_only_when_asked() {
        let config = SimulationConfig::default();
        let mut sim = Simulation::new(&config, SimulationParams::new(config.model));
        let mut timer = InstantTimer::default();
        let mut wall = Duration::ZERO;
        let mut run = |sim: &mut Simulation, ticks: usize| {
            for _ in 0..ticks {
                wall += sim.core().loop_period();
                sim.step(wall, &mut timer);
            }
        };
        run(&mut sim, 100);
        assert_eq!(sim.stage_times(), StageTimes::default());
        sim.time_stages(true);
        run(&mut sim, 100);
        let times = sim.stage_times();
        assert!(times.core_ns > 0, "{times:?}");
        assert!(
            times.world.physics_ns > 0 && times.world.scan_render_ns > 0,
            "{times:?}"
        );
        assert!(times.scan_encode_ns > 0 && times.scan_parse_ns > 0, "{times:?}");
        assert!(times.gnss_in_ns > 0, "{times:?}");
    }
}
