//! The core: a plain struct stepped at `SCHED_LOOP_RATE` with injected time.
//! It owns the parameters, the estimator, guidance, control and the mode
//! logic, answers MAVLink messages and builds telemetry. It does no I/O: the
//! caller hands it this tick's inputs and takes its outputs.

mod arming;
mod commands;
mod drive;
mod estimation;
mod failsafe;
mod fleet;
mod fleet_report;
mod geofence;
mod io;
mod messages;
mod mission_protocol;
mod mission_state;
mod modes;
mod obstacles;
mod onboard_log;
mod param_protocol;
pub mod params;
mod persistence;
mod pose_goal;
mod sim_truth;
mod telemetry;
mod termination;

use std::collections::BTreeMap;
use std::time::Duration;

use ::params::ParamTable;
use ::params::service::ParamService;
use drivers::magnetic::MagneticSample;
use mavlink::dialects::ardupilotmega::{MavMessage, MavSeverity};
use vehicle_types::BatterySample;

use crate::control::mixer::DriveTrain;
use crate::control::speed::SpeedController;
use crate::estimation::Estimator;
use crate::geo::{GeoPoint, LocalFrame};
use crate::guidance::navigator::Navigator;
use crate::modes::Mode;
use crate::sched::{Scheduler, TASKS, TaskId};
use crate::telemetry::statustext::statustext;
use crate::telemetry::streams::LinkStreams;
use crate::time::{Now, TaskTimer};

pub use drive::DriveState;
pub use failsafe::{Failsafe, FailsafeAction};
pub use fleet::FleetMessage;
pub use io::{
    Destination, Inbound, Inputs, LinkEvent, LinkId, Outbound, Outputs, PeerId, ScanInput, SimTruth, UndecodableItem,
};
pub use messages::addressed_to;
pub use obstacles::ObstacleStatus;
pub use params::CoreParams;
pub use persistence::{SaveDone, SaveRequest, SaveWhat, Storage};
pub use pose_goal::CONFIRM_WAIT_S;

/// After this long without a drive demand the vehicle counts as held still.
const HELD_STILL_AFTER: Duration = Duration::from_millis(500);

/// MAVLink component id of the autopilot (MAV_COMP_ID_AUTOPILOT1).
pub const COMPONENT_ID: u8 = 1;

/// Operator input from MANUAL_CONTROL or RC_CHANNELS_OVERRIDE.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct ManualInput {
    steering: f64,
    throttle: f64,
    /// Wall time of the last update (input is GCS-paced).
    updated_wall: Option<Duration>,
}

/// Counters a status view and the tests read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CoreCounters {
    pub messages_handled: u64,
    pub messages_not_for_us: u64,
    pub commands: u64,
}

pub struct Core {
    params: ParamTable,
    p: CoreParams,
    /// Fixed at start: both are reboot-required parameters.
    sysid: u8,
    drive_train: DriveTrain,
    sched: Scheduler,
    estimator: Estimator,
    navigator: Navigator,
    speed_control: SpeedController,
    mode: Mode,
    armed: bool,
    /// A ground station's flight termination holds the vehicle disarmed
    /// until it is cleared.
    terminated: bool,
    home: Option<GeoPoint>,
    home_set_by_gcs: bool,
    /// GUIDED/RTL's goal, home's heading, a missed mission stop.
    goals: pose_goal::PoseGoalState,
    /// DO_CHANGE_SPEED for the current mode; cleared on a mode change.
    speed_override_mps: Option<f64>,
    manual: ManualInput,
    drive: DriveState,
    links: BTreeMap<LinkId, LinkStreams>,
    /// The telemetry due on a link this tick (kept: refilled every tick).
    due_streams: Vec<crate::telemetry::streams::StreamMsg>,
    missions: mission_state::MissionState,
    battery: Option<BatterySample>,
    magnetic_sample: Option<MagneticSample>,
    /// The simulator's true pose of this tick (SITL only).
    sim_truth: Option<SimTruth>,
    magnetic: modes::magnetic::MagneticState,
    obstacles: obstacles::ObstacleState,
    failsafes: failsafe::FailsafeState,
    /// Since when the drive demand has been neutral.
    neutral_since: Option<Duration>,
    last_gcs_heartbeat_wall: Option<Duration>,
    statustext_id: u16,
    /// The pulses of the last tick (SERVO_OUTPUT_RAW reports them).
    servo_pwm_us: [u16; 16],
    param_service: ParamService<LinkId>,
    /// Said to every link when it opens (a reset parameter file, say): there
    /// is nobody to tell when the process starts.
    startup_notices: Vec<(MavSeverity, String)>,
    last_boot: Option<Duration>,
    persist: persistence::PersistState,
    onboard_log: onboard_log::LogState,
    now: Now,
    outbox: Vec<Outbound>,
    counters: CoreCounters,
    /// VDA 5050, when this vehicle is an AGV of a fleet.
    fleet: Option<Box<fleet::FleetState>>,
}

impl Core {
    /// A core with `params` (built with [`CoreParams::register`]) and the
    /// handles `p` into it.
    pub fn new(params: ParamTable, p: CoreParams) -> Self {
        let sysid = p.system.sysid.get(&params).clamp(1, 255) as u8;
        let drive_train = match p.vehicle.drive_train.get(&params) {
            1 => DriveTrain::Differential,
            _ => DriveTrain::Ackermann,
        };
        let initial = Mode::from_number(p.system.initial_mode.get(&params).max(0) as u32)
            .filter(|m| m.is_available() && !m.requires_position())
            .unwrap_or(Mode::Hold);
        Core {
            sysid,
            drive_train,
            sched: Scheduler::new(),
            estimator: Estimator::new(),
            navigator: Navigator::default(),
            speed_control: SpeedController::default(),
            mode: initial,
            armed: false,
            terminated: false,
            home: None,
            home_set_by_gcs: false,
            goals: pose_goal::PoseGoalState::default(),
            speed_override_mps: None,
            manual: ManualInput::default(),
            drive: DriveState::neutral(drive_train),
            links: BTreeMap::new(),
            due_streams: Vec::new(),
            missions: mission_state::MissionState::new(mission::Plans::default()),
            battery: None,
            magnetic_sample: None,
            sim_truth: None,
            magnetic: modes::magnetic::MagneticState::default(),
            obstacles: obstacles::ObstacleState::default(),
            failsafes: failsafe::FailsafeState::default(),
            neutral_since: None,
            last_gcs_heartbeat_wall: None,
            statustext_id: 0,
            servo_pwm_us: [0; 16],
            param_service: ParamService::new(),
            startup_notices: Vec::new(),
            last_boot: None,
            persist: persistence::PersistState::default(),
            onboard_log: onboard_log::LogState::default(),
            now: Now::default(),
            outbox: Vec::new(),
            counters: CoreCounters::default(),
            fleet: None,
            params,
            p,
        }
    }

    /// One tick: runs every due task of [`TASKS`] in order. Outbound
    /// messages are appended to `out.mavlink`; actuators are set every tick.
    pub fn step(&mut self, now: Now, inputs: &Inputs, out: &mut Outputs, timer: &mut dyn TaskTimer) {
        let tick_start = timer.now_ns();
        let dt_s = self
            .last_boot
            .map(|b| now.boot.saturating_sub(b).as_secs_f64())
            .unwrap_or(0.0);
        self.last_boot = Some(now.boot);
        self.now = now;
        // A gap this long means the core did not run on time (a stalled
        // thread, a stopped process): the vehicle drove on unattended.
        let stall_after = Duration::from_millis(self.p.failsafe.loop_overrun_ms.get(&self.params).max(1) as u64);
        if dt_s > stall_after.as_secs_f64() {
            self.failsafes.stall = Some(crate::time::duration_from_secs(dt_s));
        }
        self.saves_done(&inputs.saved);
        // Before the tasks: an order that arrived starts (armed, AUTO) in
        // this tick's mode update, not the next one's.
        self.fleet_tick(inputs);
        for (i, spec) in TASKS.iter().enumerate() {
            if !self.sched.is_due(i, now.boot, now.wall) {
                continue;
            }
            let started = timer.now_ns();
            match spec.id {
                TaskId::LinkEvents => self.handle_link_events(&inputs.link_events),
                TaskId::GcsReceive => self.receive(inputs),
                TaskId::ReadSensors => self.read_sensors(inputs),
                TaskId::UpdateMode => self.update_mode(dt_s),
                TaskId::SetServos => self.set_servos(out),
                TaskId::GcsStreams => {
                    self.send_streams();
                    self.stream_params();
                    self.poll_mission_protocol();
                }
                TaskId::Heartbeat => self.send_heartbeat(),
                TaskId::OneSecond => {}
            }
            self.sched.record(i, timer.now_ns().saturating_sub(started));
        }
        self.fleet_messages(out);
        self.log_tick(inputs.gnss.len());
        self.request_param_save();
        out.saves.append(&mut self.persist.take_requests());
        out.mission_downloads = Some(self.missions.protocol.downloads().clone());
        out.mavlink.append(&mut self.outbox);
        self.onboard_log.drain_commands_into(&mut out.log);
        self.sched.record_tick(timer.now_ns().saturating_sub(tick_start));
    }

    /// Hands back the buffer of a [`crate::logging::LogCommand::Records`] once its records
    /// are written out, so later steps reuse it rather than allocate.
    pub fn recycle_log_records(&mut self, buffer: Vec<u8>) {
        self.onboard_log.recycle_records(buffer);
    }

    /// Between ticks: answers what the links brought (link events and
    /// messages) at once, without stepping estimation or control. A ground
    /// station's request–reply exchanges (mission items, parameters,
    /// commands) then run at the link's pace, not the loop rate's; the
    /// vehicle time stays the last tick's.
    pub fn service_links(&mut self, wall: Duration, inputs: &Inputs, out: &mut Outputs) {
        self.now.wall = wall;
        self.saves_done(&inputs.saved);
        self.handle_link_events(&inputs.link_events);
        self.receive(inputs);
        // A list requested now starts now, not at the next stream tick.
        self.stream_params();
        self.request_param_save();
        out.saves.append(&mut self.persist.take_requests());
        out.mission_downloads = Some(self.missions.protocol.downloads().clone());
        out.mavlink.append(&mut self.outbox);
        self.onboard_log.drain_commands_into(&mut out.log);
    }

    fn receive(&mut self, inputs: &Inputs) {
        for message in &inputs.messages {
            self.handle_message(message);
        }
        self.handle_undecodable_items(&inputs.undecodable_items);
    }

    pub fn params(&self) -> &ParamTable {
        &self.params
    }

    pub fn params_mut(&mut self) -> &mut ParamTable {
        &mut self.params
    }

    /// A message for every ground station that connects (start-up problems
    /// such as a parameter file that had to be set aside).
    pub fn add_startup_notice(&mut self, severity: MavSeverity, text: impl Into<String>) {
        self.startup_notices.push((severity, text.into()));
    }

    /// A STATUSTEXT from the edge to every link (a simulated world reloaded,
    /// a device lost): it goes out with the next step's messages.
    pub fn announce(&mut self, severity: MavSeverity, text: &str) {
        self.send_text(severity, text);
    }

    pub fn param_handles(&self) -> &CoreParams {
        &self.p
    }

    pub fn sysid(&self) -> u8 {
        self.sysid
    }

    /// `SIGN_REQUIRE`: stream slots whose links act only on signed packets
    /// once a key is set (the link layer enforces it).
    pub fn sign_require_mask(&self) -> u8 {
        self.p.signing.require.get(&self.params).clamp(0, 15) as u8
    }

    pub fn mode(&self) -> Mode {
        self.mode
    }

    pub fn is_armed(&self) -> bool {
        self.armed
    }

    pub fn home(&self) -> Option<GeoPoint> {
        self.home
    }

    pub fn estimator(&self) -> &Estimator {
        &self.estimator
    }

    pub fn navigator(&self) -> &Navigator {
        &self.navigator
    }

    /// What the obstacle pipeline concluded on the last tick.
    pub fn obstacle_status(&self) -> ObstacleStatus {
        *self.obstacles.status()
    }

    /// The obstacle tracks (confirmed and tentative).
    pub fn obstacle_tracks(&self) -> &[crate::obstacles::Track] {
        self.obstacles.tracks()
    }

    pub fn scheduler(&self) -> &Scheduler {
        &self.sched
    }

    /// The plan in force of a type.
    pub fn plan(&self, mission_type: mission::MissionType) -> &mission::Plan {
        self.missions.plan(mission_type)
    }

    /// Changes whenever a plan in force does.
    pub fn plans_generation(&self) -> u64 {
        self.missions.generation
    }

    /// Puts a plan in force (plans loaded from the data directory at start,
    /// files imported), without saving it. The plan must be valid
    /// (`mission::validate_plan`).
    pub fn load_plan(&mut self, mission_type: mission::MissionType, plan: mission::Plan) {
        self.missions.replace(mission_type, plan);
        self.plan_changed(mission_type);
    }

    /// The mission executor's state (tests and status views).
    pub fn mission_state(&self) -> mission::ExecState {
        self.missions.executor.state()
    }

    /// The current mission item.
    pub fn mission_current_seq(&self) -> u16 {
        self.missions.executor.current()
    }

    pub fn counters(&self) -> CoreCounters {
        self.counters
    }

    /// The loop rate the caller must step at.
    pub fn loop_period(&self) -> Duration {
        let hz = self.p.system.loop_rate_hz.get(&self.params).clamp(10, 400);
        crate::time::duration_from_secs(1.0 / f64::from(hz))
    }

    fn frame(&self) -> Option<LocalFrame> {
        self.estimator.frame().copied()
    }

    fn handle_link_events(&mut self, events: &[LinkEvent]) {
        for event in events {
            match *event {
                LinkEvent::Opened { link, stream_slot } => {
                    self.links.insert(link, LinkStreams::new(stream_slot));
                }
                // Told per ground station, not per link: one that starts
                // listening after boot must hear them too.
                LinkEvent::PeerJoined { link, peer } => {
                    for (severity, text) in self.startup_notices.clone() {
                        for chunk in statustext(severity, &text, &mut self.statustext_id) {
                            self.send(Destination::Peer { link, peer }, MavMessage::STATUSTEXT(chunk));
                        }
                    }
                }
                LinkEvent::Closed { link } => {
                    self.links.remove(&link);
                    self.param_service.link_closed(link);
                    self.onboard_log.link_closed(link);
                    let mut events = Vec::new();
                    self.missions.protocol.link_closed(link, &mut events);
                    self.mission_events(events);
                }
            }
        }
    }

    fn read_sensors(&mut self, inputs: &Inputs) {
        let config = self.estimator_config();
        // Held still: disarmed, or no drive demand for a moment (the last
        // tick's outputs; the estimator still checks the GNSS speed).
        let neutral = !self.armed || (self.drive.throttle == 0.0 && self.drive.steering == 0.0);
        self.neutral_since = if neutral {
            self.neutral_since.or(Some(self.now.boot))
        } else {
            None
        };
        let held_still = self
            .neutral_since
            .is_some_and(|t| self.now.boot.saturating_sub(t) >= HELD_STILL_AFTER);
        self.estimator.update(self.now.boot, &config, &inputs.gnss, held_still);
        self.report_estimator_events();
        if let Some(b) = inputs.battery {
            self.battery = Some(b);
        }
        if let Some(m) = inputs.magnetic {
            self.magnetic_sample = Some(m);
        }
        self.sim_truth = inputs.sim_truth;
        self.read_scans(&inputs.scans);
        if self.home.is_none() && self.estimator.estimate().position_valid {
            self.set_home_to_current(false);
        }
    }

    /// Sets home to the current position and announces it.
    fn set_home_to_current(&mut self, by_gcs: bool) -> bool {
        let (Some(frame), true) = (self.frame(), self.estimator.estimate().position_valid) else {
            return false;
        };
        let mut home = frame.to_geodetic(&self.estimator.estimate().position);
        home.alt_m = self.estimator.gnss().alt_msl_m;
        self.set_home(home, by_gcs);
        let estimate = self.estimator.estimate();
        self.goals.home_yaw_rad = estimate.heading_valid.then_some(estimate.yaw_rad);
        true
    }

    fn set_home(&mut self, home: GeoPoint, by_gcs: bool) {
        self.home = Some(home);
        self.goals.home_yaw_rad = None;
        self.home_set_by_gcs |= by_gcs;
        self.update_protocol_home();
        if let Some(msg) = self.build_home_position() {
            self.send(Destination::AllLinks, msg);
        }
    }

    fn set_servos(&mut self, out: &mut Outputs) {
        if !self.armed {
            self.drive = DriveState::neutral(self.drive_train);
        }
        let servos = self.p.servos.config(&self.params);
        // A DO_SET_SERVO on a channel a function owns is dropped, and said so
        // once (ArduPilot refuses it the same way).
        for (channel, function) in servos.refuse_direct_pulses(&mut self.missions.servo_us) {
            self.send_text(
                MavSeverity::MAV_SEVERITY_WARNING,
                &format!("DO_SET_SERVO refused: servo {channel} is {function}"),
            );
        }
        out.actuators = self.drive.actuators;
        self.servo_pwm_us = servos.pulses_us(&crate::control::servo::OutputDemand {
            actuators: self.drive.actuators,
            wheels: self.drive.wheels,
            direct_us: self.missions.servo_us,
            relays_on: self.missions.relays_on,
        });
        out.servo_pwm_us = self.servo_pwm_us;
    }

    fn send(&mut self, dest: Destination, message: MavMessage) {
        self.outbox.push(Outbound { dest, message });
    }

    /// Broadcasts a STATUSTEXT (chunked when longer than 50 characters).
    fn send_text(&mut self, severity: MavSeverity, text: &str) {
        self.log_text(text);
        for chunk in statustext(severity, text, &mut self.statustext_id) {
            self.send(Destination::AllLinks, MavMessage::STATUSTEXT(chunk));
        }
    }
}

#[cfg(test)]
mod tests {
    use mavlink::dialects::ardupilotmega::{MavMessage, MavSeverity};

    use super::{Destination, LinkEvent, LinkId, PeerId};
    use crate::sitl::simulation::{Simulation, SimulationConfig, SimulationParams};
    use crate::time::FrozenTimer;

    /// Where the notice went over a few steps.
    fn notices(sim: &mut Simulation) -> Vec<Destination> {
        let mut dests = Vec::new();
        for _ in 0..5 {
            let wall = sim.time();
            let out = sim.step(wall, &mut FrozenTimer);
            for o in out.mavlink.drain(..) {
                if let MavMessage::STATUSTEXT(t) = &o.message
                    && t.text.starts_with(b"Parameter file unreadable")
                {
                    dests.push(o.dest);
                }
            }
        }
        dests
    }

    #[test]
    fn a_ground_station_that_appears_is_told_the_startup_notices_alone() {
        let config = SimulationConfig::default();
        let mut sim = Simulation::new(&config, SimulationParams::new(config.model));
        sim.core_mut()
            .add_startup_notice(MavSeverity::MAV_SEVERITY_WARNING, "Parameter file unreadable");
        let link = LinkId(3);
        sim.inputs_mut()
            .link_events
            .push(LinkEvent::Opened { link, stream_slot: 1 });
        assert!(notices(&mut sim).is_empty(), "a link without a ground station");
        for peer in [PeerId(7), PeerId(8)] {
            sim.inputs_mut().link_events.push(LinkEvent::PeerJoined { link, peer });
            assert_eq!(notices(&mut sim), vec![Destination::Peer { link, peer }]);
        }
    }
}
