//! The core's side of VDA 5050: steps the fleet agent with what the core
//! knows, drives its legs in AUTO through the same navigator, obstacle
//! protection and failsafes as a mission, sets the outputs its actions
//! drive, and builds the messages it wants sent (docs/architecture.md
//! §Fleets).

use mavlink::dialects::ardupilotmega::MavSeverity;
use vda5050::state::OperatingMode;

use super::pose_goal::{CONFIRM_POSITION_SIGMAS, CONFIRM_YAW_SIGMAS};
use super::{Core, Inputs, Outputs};
use crate::fleet::actions::ActionOutput;
use crate::fleet::factsheet::{VehicleDescription, build_factsheet};
use crate::fleet::map::{MapFrame, MapPose};
use crate::fleet::order::error;
use crate::fleet::state::{build_state, build_visualization};
use crate::fleet::traversal::Fix;
use crate::fleet::{Agent, AgentConfig, Command, Leg, OrderEvent, Publish, VehicleView};
use crate::geo::LocalFrame;
use crate::guidance::navigator::{NavTarget, StopTolerance};
use crate::guidance::path::{LegPath, Piece, Segment};
use crate::guidance::tracker::Direction;
use crate::modes::Mode;

/// A message for the master control; the edge stamps its header.
#[derive(Clone, Debug, PartialEq)]
pub enum FleetMessage {
    State(Box<vda5050::State>),
    Visualization(Box<vda5050::Visualization>),
    Factsheet(Box<vda5050::Factsheet>),
}

/// Moving faster than this counts as driving (m/s).
const DRIVING_SPEED_MPS: f64 = 0.03;
/// Below this measured speed the vehicle rests (the tracking benchmark's
/// line between creeping and resting).
const RESTING_MPS: f64 = 0.01;
/// With the drive neutral and the estimate's speed under
/// [`DRIVING_SPEED_MPS`] this long, the vehicle counts as at rest even
/// when the receiver's speed never settles under [`RESTING_MPS`] (a
/// noisier receiver than the simulated one).
const QUIET_REST_S: f64 = 1.0;

/// The core's fleet state: the agent, and the leg being driven.
pub(super) struct FleetState {
    agent: Agent,
    /// Map coordinates ↔ local positions.
    map: MapFrame,
    command: Command,
    /// The node sequenceId the navigator is driving to.
    leg: Option<u32>,
    /// Along a trajectory: the chord being driven, and the last one.
    chord: usize,
    last_chord: usize,
    /// The stop tolerance of the leg being driven, when the node gives one.
    tolerance: Option<StopTolerance>,
    /// A ground station disarmed the vehicle during the order: a remote
    /// e-stop until the vehicle is armed again.
    remote_stop: bool,
    /// Along a trajectory: the path obstacle protection looks along, built
    /// once per chord (see [`FleetState::trajectory_ahead`]).
    ahead: Option<TrajectoryAhead>,
    /// Since when (vehicle time, s) the drive has been neutral and the
    /// estimate's speed under [`DRIVING_SPEED_MPS`].
    quiet_since_s: Option<f64>,
}

/// The navigator's path for one chord of a trajectory, then the chords
/// after it, in the local frame.
struct TrajectoryAhead {
    /// The leg (node sequenceId), the chord, and the navigator path's
    /// length (a re-approach rebuilds that path).
    key: (u32, usize, u64),
    path: LegPath,
    /// The path ends at a node the vehicle stops at.
    stop: bool,
}

impl FleetState {
    /// Along a trajectory, the path the vehicle is about to drive: the
    /// navigator's path for the chord being driven (`chord_path`, which
    /// already runs on to the next chord's end), then the chords after it
    /// to the node, and on to the next node when the vehicle drives
    /// through. Obstacle protection looks along it, so it sees the curve
    /// beyond the chord. Returns it and whether it ends at a stop; `None`
    /// off a trajectory.
    pub(super) fn trajectory_ahead(
        &mut self,
        chord_path: &LegPath,
        frame: Option<&LocalFrame>,
    ) -> Option<(&LegPath, bool)> {
        let Command::Drive(leg) = &self.command else {
            return None;
        };
        let points = leg.path.as_deref()?;
        if self.leg != Some(leg.node_sequence_id) || self.chord + 2 >= points.len() {
            return None;
        }
        let key = (leg.node_sequence_id, self.chord, chord_path.end_m().to_bits());
        if self.ahead.as_ref().is_none_or(|a| a.key != key) {
            let following = points[self.chord + 2..]
                .iter()
                .chain(leg.next.iter().filter(|_| !leg.stop));
            let mut pieces = chord_path.pieces().to_vec();
            let mut at = chord_path
                .pieces()
                .last()
                .map_or(chord_path.end(), |p| p.point_at(p.length_m()));
            for &(x, y) in following {
                let point = self.map.to_local(frame, x, y)?;
                if point.distance_to(&at) > 1e-6 {
                    pieces.push(Piece::Line(Segment::new(at, point)));
                    at = point;
                }
            }
            self.ahead = Some(TrajectoryAhead {
                key,
                path: LegPath::from_pieces(pieces),
                stop: leg.stop,
            });
        }
        self.ahead.as_ref().map(|a| (&a.path, a.stop))
    }
}

impl Core {
    /// Makes this vehicle a VDA 5050 AGV: orders and instant actions come in
    /// `Inputs::vda5050`, messages go out in `Outputs::vda5050`.
    pub fn enable_vda5050(&mut self, config: AgentConfig) {
        let (kind, transform) = self.p.geo.settings(&self.params);
        let map = MapFrame::new(config.map_origin, kind, transform);
        self.fleet = Some(Box::new(FleetState {
            map,
            agent: Agent::new(config),
            command: Command::Hold,
            leg: None,
            chord: 0,
            last_chord: 0,
            tolerance: None,
            remote_stop: false,
            ahead: None,
            quiet_since_s: None,
        }));
    }

    /// The fleet agent, when VDA 5050 is on.
    pub fn fleet_agent(&self) -> Option<&Agent> {
        self.fleet.as_ref().map(|f| &f.agent)
    }

    /// AUTO drives the fleet's order rather than the mission.
    pub(super) fn fleet_drives(&self) -> bool {
        self.fleet.as_ref().is_some_and(|f| f.agent.has_order())
    }

    /// The node's allowed deviation replaces `WP_STOP_TOL_*` on its leg.
    pub(super) fn fleet_stop_tolerance(&self) -> Option<StopTolerance> {
        self.fleet.as_ref().and_then(|f| f.tolerance)
    }

    /// A ground station's disarm: during an order it is a remote e-stop.
    pub(super) fn fleet_note_gcs_disarm(&mut self) {
        let during_order = self.armed && self.fleet_drives();
        if let Some(fleet) = self.fleet.as_mut()
            && during_order
        {
            fleet.remote_stop = true;
        }
    }

    /// Who is in charge (§6.10.6): the master control in AUTO, and in HOLD
    /// with no order left; a ground station that took the vehicle (MANUAL,
    /// or any other mode mid-order) pauses the order.
    pub(super) fn operating_mode(&self) -> OperatingMode {
        match self.mode {
            Mode::Auto => OperatingMode::Automatic,
            Mode::Manual => OperatingMode::Manual,
            Mode::Hold if !self.fleet_drives() => OperatingMode::Automatic,
            _ => OperatingMode::Service,
        }
    }

    /// Once a tick, before the tasks: the agent's step and what follows
    /// (the messages wait for [`Core::fleet_messages`]). The pose is worked
    /// out only when an order or an instant action needs it.
    pub(super) fn fleet_tick(&mut self, inputs: &Inputs) {
        let armed = self.armed;
        let Some(fleet) = self.fleet.as_mut() else {
            return;
        };
        fleet.remote_stop &= !armed;
        let remote_stop = fleet.remote_stop;
        let quiet = !self.drive_commanded() && self.estimator.estimate().speed_mps.abs() <= DRIVING_SPEED_MPS;
        let now_s = self.now.boot.as_secs_f64();
        if let Some(fleet) = self.fleet.as_mut() {
            fleet.quiet_since_s = if quiet {
                fleet.quiet_since_s.or(Some(now_s))
            } else {
                None
            };
        }
        let mut view = self.fleet_view(!inputs.vda5050.is_empty(), remote_stop);
        // Nodes are judged by the pose while an order is driven.
        if view.fix.is_none() && self.fleet_drives() {
            view.fix = self.fleet_fix();
        }
        let Some(fleet) = self.fleet.as_mut() else {
            return;
        };
        for (topic, payload) in &inputs.vda5050 {
            fleet.agent.receive(*topic, payload.clone());
        }
        fleet.command = fleet.agent.advance(&view);
        let events = fleet.agent.take_events();
        let outputs = fleet.agent.take_outputs();
        for event in events {
            self.fleet_event(event);
        }
        for output in outputs {
            self.apply_action_output(output);
        }
    }

    /// Once a tick, after the tasks: the messages due, from what the tick
    /// did (the state of the tick an order starts in says `driving`). The
    /// vehicle's report is worked out only when a message goes out.
    pub(super) fn fleet_messages(&mut self, out: &mut Outputs) {
        let Some(remote_stop) = self.fleet.as_ref().map(|f| f.remote_stop) else {
            return;
        };
        let mut view = self.fleet_view(false, remote_stop);
        // The tick's own pose: a node reached now goes out in this state.
        let judge = self.fleet_drives();
        if judge {
            view.fix = self.fleet_fix();
            view.pose = view.fix.map(|f| f.pose);
        }
        let Some(fleet) = self.fleet.as_mut() else {
            return;
        };
        if judge {
            fleet.agent.traverse(&view);
        }
        fleet.agent.schedule_messages(&view);
        let publish = fleet.agent.take_publish();
        if !publish.is_empty() {
            self.fleet_publish(&publish, view.driving, remote_stop, out);
        }
    }

    fn fleet_publish(&self, publish: &[Publish], driving: bool, remote_stop: bool, out: &mut Outputs) {
        let Some(fleet) = self.fleet.as_ref() else {
            return;
        };
        let report = self.vehicle_report(driving, remote_stop);
        for publish in publish {
            out.vda5050.push(match publish {
                Publish::State => FleetMessage::State(Box::new(build_state(&fleet.agent, &report))),
                Publish::Visualization => {
                    FleetMessage::Visualization(Box::new(build_visualization(&fleet.agent, &report)))
                }
                Publish::Factsheet => FleetMessage::Factsheet(Box::new(build_factsheet(
                    &self.vehicle_description(),
                    &fleet.agent.config,
                ))),
            });
        }
    }

    /// The vehicle's pose in the map frame, when it knows where it is.
    pub(super) fn fleet_pose(&self) -> Option<MapPose> {
        let estimate = self.estimator.estimate();
        let map = &self.fleet.as_ref()?.map;
        if !estimate.position_valid {
            return None;
        }
        map.pose(self.estimator.frame(), &estimate.position, estimate.yaw_rad)
    }

    /// The pose with the radius that holds the vehicle with 95 % confidence
    /// and the heading's bound, as a stop's "Reached" is confirmed.
    fn fleet_fix(&self) -> Option<Fix> {
        let pose = self.fleet_pose()?;
        let sigma_m = self.estimator.estimate().horiz_sigma_m;
        let yaw_sigma_rad = self
            .estimator
            .ekf_status()
            .map_or(f64::INFINITY, |s| s.heading_sigma_rad);
        Some(Fix {
            pose,
            position_bound_m: CONFIRM_POSITION_SIGMAS * sigma_m,
            yaw_bound_rad: CONFIRM_YAW_SIGMAS * yaw_sigma_rad,
        })
    }

    /// Standing still (a stop node's blocking actions run from then, and
    /// `driving` goes false): the drive held neutral and the GNSS agreeing
    /// (the estimator's rest, which its speed's zero updates follow) and
    /// the receiver's own speed below [`RESTING_MPS`]; or, for a receiver
    /// noisier than that, the drive neutral and the estimate's speed low
    /// for [`QUIET_REST_S`].
    fn fleet_at_rest(&self) -> bool {
        let quiet_s = self.fleet.as_ref().and_then(|f| f.quiet_since_s);
        let quiet_long = quiet_s.is_some_and(|t| self.now.boot.as_secs_f64() - t >= QUIET_REST_S);
        let resting = self.estimator.at_rest() && self.estimator.gnss().speed_mps.abs() < RESTING_MPS;
        !self.drive_commanded() && (resting || quiet_long)
    }

    fn fleet_view(&self, with_pose: bool, remote_stop: bool) -> VehicleView {
        let fleet = self.fleet.as_ref();
        // Along a trajectory, only the last chord's end is the node.
        let leg = fleet.filter(|f| f.chord == f.last_chord).and_then(|f| f.leg);
        let arrived = self.mode == Mode::Auto && self.navigator.arrived() && !self.obstacles.detouring();
        // Only orders and initPosition look at the pose.
        let fix = if with_pose { self.fleet_fix() } else { None };
        VehicleView {
            boot_s: self.now.boot.as_secs_f64(),
            wall_s: self.now.wall.as_secs_f64(),
            pose: fix.map(|f| f.pose),
            fix,
            arrived_at: leg.filter(|_| arrived),
            at_rest: self.fleet_at_rest(),
            driving: self.fleet_driving(),
            operating_mode: self.operating_mode(),
            e_stop: self.fleet_e_stop(remote_stop),
            // Only orders look at it.
            min_turn_radius_m: if with_pose { self.min_turn_radius_m() } else { None },
        }
    }

    /// The tightest turn the navigator drives (its smallest arc, with room
    /// for the tracker's corrections); none for a differential drive, which
    /// turns on the spot.
    fn min_turn_radius_m(&self) -> Option<f64> {
        let differential = self.drive_train == crate::control::mixer::DriveTrain::Differential;
        (!differential).then(|| self.nav_config().min_arc_radius_m)
    }

    /// Driving or rotating (§6.10.6's `driving`): the drive is commanded to
    /// move (the motors push from this tick on; the speed estimate lags the
    /// wheels by a few hundred milliseconds), or the vehicle is not yet at
    /// rest (see [`Core::fleet_at_rest`]).
    fn fleet_driving(&self) -> bool {
        self.armed && !self.fleet_at_rest()
    }

    /// The drive is commanded to move or, a differential one, to turn.
    fn drive_commanded(&self) -> bool {
        let pivoting =
            self.drive_train == crate::control::mixer::DriveTrain::Differential && self.drive.steering != 0.0;
        self.drive.throttle != 0.0 || pivoting
    }

    fn vehicle_description(&self) -> VehicleDescription {
        let t = &self.params;
        let nav = &self.p.nav;
        let footprint = self.footprint();
        VehicleDescription {
            differential: self.drive_train == crate::control::mixer::DriveTrain::Differential,
            speed_max_mps: f64::from(nav.wp_speed_mps.get(t)),
            accel_max_mps2: f64::from(nav.accel_max_mps2.get(t)),
            decel_max_mps2: self.decel_limit_mps2(),
            front_m: footprint.front_m,
            rear_m: footprint.rear_m,
            width_m: 2.0 * footprint.half_width_m,
        }
    }

    /// A new order in HOLD (the master control in charge) arms the vehicle
    /// and enters AUTO; a cancel stops at once.
    fn fleet_event(&mut self, event: OrderEvent) {
        match event {
            OrderEvent::Accepted { new_order: true } if self.mode == Mode::Hold => self.start_fleet_order(),
            OrderEvent::Accepted { .. } => {}
            OrderEvent::Cancelled => {
                if let Some(fleet) = self.fleet.as_mut() {
                    fleet.leg = None;
                    fleet.tolerance = None;
                }
                self.navigator.clear();
                self.send_text(MavSeverity::MAV_SEVERITY_INFO, "VDA 5050: order cancelled");
            }
        }
    }

    fn start_fleet_order(&mut self) {
        if !self.armed && !self.arm(false) {
            let reasons = self.arming_failures().join(", ");
            self.fleet_error("vehicleNotReady", format!("cannot arm: {reasons}"));
            return;
        }
        if let Err(why) = self.request_mode(Mode::Auto) {
            self.fleet_error("vehicleNotReady", format!("cannot enter AUTO: {why:?}"));
        }
    }

    fn fleet_error(&mut self, kind: &str, text: String) {
        self.send_text(MavSeverity::MAV_SEVERITY_WARNING, &format!("VDA 5050: {text}"));
        if let Some(fleet) = self.fleet.as_mut() {
            fleet.agent.errors.push(error(kind, text, Vec::new()));
        }
    }

    /// An action's output, as DO_SET_SERVO / DO_SET_RELAY set it.
    fn apply_action_output(&mut self, output: ActionOutput) {
        match output {
            ActionOutput::Servo { channel, pwm_us } => {
                if let Some(slot) = self.missions.servo_us.get_mut(usize::from(channel).wrapping_sub(1)) {
                    *slot = pwm_us;
                }
            }
            ActionOutput::Relay { relay, on } => {
                let bit = 1u16 << relay.min(15);
                self.missions.relays_used |= bit;
                if on {
                    self.missions.relays_on |= bit;
                } else {
                    self.missions.relays_on &= !bit;
                }
            }
        }
    }

    /// AUTO entered with an order: the next leg is set on the next tick.
    pub(super) fn start_order(&mut self) {
        if let Some(fleet) = self.fleet.as_mut() {
            fleet.leg = None;
        }
    }

    /// One AUTO step of the order: the agent's command to the navigator.
    pub(super) fn run_order(&mut self) {
        let Some((command, current)) = self.fleet.as_ref().map(|f| (f.command.clone(), f.leg)) else {
            return;
        };
        match command {
            Command::Hold if current.is_some() => {
                if let Some(fleet) = self.fleet.as_mut() {
                    fleet.leg = None;
                    fleet.tolerance = None;
                }
                self.navigator.clear();
            }
            Command::Drive(leg) if current != Some(leg.node_sequence_id) => {
                // A new leg, as an AUTO mission's: its changes of direction
                // count from here.
                self.navigator.count_directions_afresh();
                let tolerance = self.leg_tolerance(&leg);
                if let Some(fleet) = self.fleet.as_mut() {
                    fleet.leg = Some(leg.node_sequence_id);
                    fleet.tolerance = tolerance;
                    fleet.chord = 0;
                    fleet.ahead = None;
                    fleet.last_chord = leg.path.as_ref().map_or(0, |p| p.len().saturating_sub(2));
                }
                self.drive_leg(&leg, 0);
            }
            // Along a trajectory: round one chord's corner, onto the next.
            Command::Drive(leg) if self.navigator.arrived() => {
                let next = self.fleet.as_mut().filter(|f| f.chord < f.last_chord).map(|f| {
                    f.chord += 1;
                    f.chord
                });
                if let Some(chord) = next {
                    self.drive_leg(&leg, chord);
                }
            }
            _ => {}
        }
    }

    fn leg_tolerance(&self, leg: &Leg) -> Option<StopTolerance> {
        if leg.allowed_deviation_m.is_none() && leg.allowed_deviation_rad.is_none() {
            return None;
        }
        let nav = &self.p.nav;
        Some(StopTolerance {
            position_m: leg
                .allowed_deviation_m
                .unwrap_or(f64::from(nav.stop_tol_mm.get(&self.params)) / 1000.0),
            yaw_rad: leg
                .allowed_deviation_rad
                .unwrap_or(f64::from(nav.stop_tol_deg.get(&self.params)).to_radians()),
        })
    }

    /// Drives chord `chord` of the leg's trajectory, or the leg's straight
    /// line: each chord but the last is driven through, onto the next.
    fn drive_leg(&mut self, leg: &Leg, chord: usize) {
        let Some(fleet) = self.fleet.as_ref() else {
            return;
        };
        let frame = self.estimator.frame();
        let local = |(x, y): (f64, f64)| fleet.map.to_local(frame, x, y);
        let (from, to, next, stop) = match leg.path.as_deref() {
            Some(points) if chord + 2 < points.len() => {
                (points[chord], points[chord + 1], Some(points[chord + 2]), false)
            }
            Some(points) if chord + 1 < points.len() => (points[chord], points[chord + 1], leg.next, leg.stop),
            _ => (leg.from, leg.to, leg.next, leg.stop),
        };
        let (Some(from), Some(to)) = (local(from), local(to)) else {
            // No local frame yet (no fix): nothing to drive along.
            self.navigator.clear();
            return;
        };
        let next = next.and_then(local);
        let cruise_mps = f64::from(self.p.nav.wp_speed_mps.get(&self.params));
        let target = NavTarget {
            point: to,
            speed_mps: leg.max_speed_mps.map(|max| max.min(cruise_mps)),
            direction: if leg.reverse {
                Direction::Reverse
            } else {
                Direction::Forward
            },
            stop,
            next,
            seq: None,
        };
        self.navigator.set_target(from, target);
    }
}
