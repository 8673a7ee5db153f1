//! The vehicle's VDA 5050 agent: the order, its actions and the instant
//! actions, stepped with time; what the vehicle should drive next; and when
//! a `state` or `visualization` message is due. The core feeds it what it
//! knows of the vehicle ([`VehicleView`]) and carries out its [`Command`].
//!
//! Pure: payloads in, messages out, times given (docs/architecture.md §The
//! pure core and its edges).

use std::collections::BTreeMap;
use std::sync::Arc;

use vda5050::common::Action;
use vda5050::order::{Edge, Node, OrientationType};
use vda5050::state::{ActionStatus, EStop, Error, Load, OperatingMode};
use vda5050::{Order, Topic, parse_instant_actions, parse_order};

use crate::geo::GeoPoint;

use super::actions::{ActionMapping, ActionOutput, ActionRunner, Scope, mapping};
use super::map::MapPose;
use super::order::{OrderBook, OrderContext, Verdict, error};
use super::trajectory::Nurbs;
use super::traversal::{self, Fix, Watch};

/// How the agent is set up.
#[derive(Clone, Debug, PartialEq)]
pub struct AgentConfig {
    /// The map this vehicle drives on (orders on another map are refused),
    /// reported ENABLED in the state's `maps`.
    pub map_id: String,
    pub map_version: String,
    /// Where the map frame's origin is (see [`super::map::MapFrame`]):
    /// every vehicle of a fleet with the same one shares map coordinates.
    /// `None`: the map frame is about this vehicle's first fix.
    pub map_origin: Option<GeoPoint>,
    pub mappings: Vec<ActionMapping>,
    /// `state` at least this often while driving (default 1 s)…
    pub state_interval_driving_s: f64,
    /// …and otherwise (the standard's limit is 30 s).
    pub state_interval_idle_s: f64,
    /// `visualization` this often; 0 sends none.
    pub visualization_interval_s: f64,
}

impl Default for AgentConfig {
    fn default() -> Self {
        AgentConfig {
            map_id: "local".into(),
            map_version: "1".into(),
            map_origin: None,
            mappings: super::actions::default_mappings(),
            state_interval_driving_s: 1.0,
            state_interval_idle_s: 30.0,
            visualization_interval_s: 0.5,
        }
    }
}

/// What the core tells the agent each tick.
#[derive(Clone, Debug, PartialEq)]
pub struct VehicleView {
    /// Vehicle time (actions' durations).
    pub boot_s: f64,
    /// Wall time (message pacing).
    pub wall_s: f64,
    pub pose: Option<MapPose>,
    /// The pose while an order is driven (or an order or instant action
    /// came), with what the estimate is sure of: nodes count as traversed
    /// by it.
    pub fix: Option<Fix>,
    /// The sequenceId of the node whose leg the navigator has finished:
    /// driven through it (it switches legs `WP_RADIUS` ahead of a node, or
    /// in the middle of a corner's arc), or come to rest on it. It moves
    /// the driving on; the node is reported by [`Self::fix`].
    pub arrived_at: Option<u32>,
    /// The vehicle stands still (the drive held neutral and the sensors
    /// agree): blocking actions run from then, and the leg onto a stop
    /// node reported while rolling in is done.
    pub at_rest: bool,
    pub driving: bool,
    pub operating_mode: OperatingMode,
    /// The e-stop the state reports (a change sends a state).
    pub e_stop: EStop,
    /// The tightest turn the vehicle follows (m), `None` when it turns on
    /// the spot: a trajectory that needs tighter is refused.
    pub min_turn_radius_m: Option<f64>,
}

/// One leg to drive: along an edge to its end node.
#[derive(Clone, Debug, PartialEq)]
pub struct Leg {
    /// The end node's sequenceId (the navigator reports arrival by it).
    pub node_sequence_id: u32,
    /// Where the edge starts and ends, map frame (m).
    pub from: (f64, f64),
    pub to: (f64, f64),
    /// The node after `to` when the vehicle drives through.
    pub next: Option<(f64, f64)>,
    pub reverse: bool,
    pub max_speed_mps: Option<f64>,
    /// Stop at `to` (else drive through).
    pub stop: bool,
    /// The node's allowed deviation, the stop tolerance (m, rad).
    pub allowed_deviation_m: Option<f64>,
    pub allowed_deviation_rad: Option<f64>,
    /// The edge's trajectory as chords (map frame, `from` to `to`), when
    /// the order gives one; else the straight line.
    pub path: Option<Arc<[(f64, f64)]>>,
}

/// What the vehicle should do this tick.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// Stand (no order, paused, a blocking action, the base ended).
    Hold,
    Drive(Leg),
}

/// A message the edge should publish (headers are stamped there).
#[derive(Clone, Debug, PartialEq)]
pub enum Publish {
    State,
    Visualization,
    Factsheet,
}

/// What happened to an order this tick (the core arms and enters AUTO on
/// a new one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OrderEvent {
    Accepted { new_order: bool },
    Cancelled,
}

#[derive(Debug)]
pub struct Agent {
    pub config: AgentConfig,
    pub order: OrderBook,
    pub actions: ActionRunner,
    pub paused: bool,
    /// What the vehicle carries, by its pick and drop actions.
    pub loads: Vec<Load>,
    /// Errors of instant actions and of unreadable payloads, reported until
    /// the next order is accepted.
    pub errors: Vec<Error>,
    /// A cancelOrder waiting for the vehicle to stand still.
    cancelling: Option<String>,
    /// Since when the vehicle has not been driving (vehicle time).
    standing_since_s: Option<f64>,
    inbox: Vec<(Topic, Vec<u8>)>,
    events: Vec<OrderEvent>,
    outputs: Vec<ActionOutput>,
    publish: Vec<Publish>,
    last_state_wall_s: Option<f64>,
    last_visualization_wall_s: Option<f64>,
    /// What the last state said, to send again on a change.
    last_fingerprint: Option<Fingerprint>,
    /// Bumped on every change of the order's progress.
    order_generation: u64,
    /// Nodes at the head of the order the navigator has finished the legs
    /// to and that are not traversed yet: the driving is this far ahead
    /// of the report.
    passed: usize,
    /// How close the vehicle has come to the next node to traverse.
    watch: Watch,
    /// The leg to a node traversed before the navigator finished it,
    /// driven on until it does (or, onto a stop, until the vehicle rests).
    held_leg: Option<Leg>,
    /// The chords of the held edges' trajectories, by edge sequenceId
    /// (cut once, when the edge comes).
    paths: BTreeMap<u32, Arc<[(f64, f64)]>>,
}

#[derive(Clone, Debug, PartialEq)]
struct Fingerprint {
    order_generation: u64,
    action_generation: u64,
    errors: usize,
    driving: bool,
    paused: bool,
    new_base_request: bool,
    operating_mode: OperatingMode,
    e_stop: EStop,
}

/// Not driving for this long is standing still (the speed estimate lags
/// the wheels by a few centimetres per second).
const STANDING_AFTER_S: f64 = 0.5;

/// Instant actions the agent carries out itself.
pub const INSTANT_ACTIONS: [&str; 6] = [
    "startPause",
    "stopPause",
    "cancelOrder",
    "stateRequest",
    "factsheetRequest",
    "initPosition",
];

impl Agent {
    pub fn new(config: AgentConfig) -> Self {
        Agent {
            config,
            order: OrderBook::default(),
            actions: ActionRunner::default(),
            paused: false,
            loads: Vec::new(),
            errors: Vec::new(),
            cancelling: None,
            standing_since_s: None,
            inbox: Vec::new(),
            events: Vec::new(),
            outputs: Vec::new(),
            publish: Vec::new(),
            last_state_wall_s: None,
            last_visualization_wall_s: None,
            last_fingerprint: None,
            order_generation: 0,
            passed: 0,
            watch: Watch::default(),
            held_leg: None,
            paths: BTreeMap::new(),
        }
    }

    /// The action types an order may carry (and factsheets list).
    pub fn supports_action(&self, action_type: &str) -> bool {
        mapping(&self.config.mappings, action_type).is_some()
    }

    /// A payload from the broker, handled at the next step.
    pub fn receive(&mut self, topic: Topic, payload: Vec<u8>) {
        self.inbox.push((topic, payload));
    }

    /// Order accepted or cancelled this step.
    pub fn take_events(&mut self) -> Vec<OrderEvent> {
        std::mem::take(&mut self.events)
    }

    /// Outputs actions set this step.
    pub fn take_outputs(&mut self) -> Vec<ActionOutput> {
        std::mem::take(&mut self.outputs)
    }

    /// Messages due this step.
    pub fn take_publish(&mut self) -> Vec<Publish> {
        std::mem::take(&mut self.publish)
    }

    /// Whether the order still has nodes to drive to (or the vehicle is
    /// still coming to rest on one it has reported).
    pub fn has_order(&self) -> bool {
        self.order.has_nodes() || self.held_leg.is_some()
    }

    /// The leg onto the last node reported, driven on after the node
    /// counted as traversed: until the vehicle rests on it (a stop) or the
    /// navigator finishes it (a corner).
    pub fn held_leg(&self) -> Option<&Leg> {
        self.held_leg.as_ref()
    }

    /// Whether the vehicle should ask for more base (§6.10.3): the leg
    /// being driven ends at the last released node (or there is none). The
    /// driving can be a leg ahead of the nodes reported, so it is the leg
    /// that counts, not the next node to report.
    pub fn new_base_request(&self) -> bool {
        // The node after the one the driving heads for: a held leg heads
        // for the last node reported, else the `passed`-th still held.
        let after = if self.held_leg.is_some() { 0 } else { self.passed + 1 };
        let released_after = self.order.nodes.get(after).is_some_and(|n| n.released);
        self.order.has_horizon() && !released_after
    }

    /// One step: the payloads received, node arrivals, actions, the
    /// command for the vehicle, and the messages due.
    pub fn step(&mut self, view: &VehicleView) -> Command {
        let command = self.advance(view);
        self.schedule_messages(view);
        command
    }

    /// [`Self::step`] without the messages: the core schedules them after
    /// its mode update, so the `state` of the tick an order starts in says
    /// what the vehicle does in it.
    pub fn advance(&mut self, view: &VehicleView) -> Command {
        for (topic, payload) in std::mem::take(&mut self.inbox) {
            self.handle(topic, &payload, view);
        }
        self.traverse_nodes(view);
        if view.at_rest && self.held_leg.as_ref().is_some_and(|l| l.stop) {
            // At rest on a stop node already reported: the stop is done
            // (the navigator may settle on longer; nothing waits for it).
            self.held_leg = None;
        }
        let outputs = self
            .actions
            .step(view.boot_s, self.paused, view.at_rest, &self.config.mappings);
        self.outputs.extend(outputs);
        for action in self.actions.take_finished() {
            super::loads::apply(&mut self.loads, &action);
        }
        self.standing_since_s = if view.driving {
            None
        } else {
            self.standing_since_s.or(Some(view.boot_s))
        };
        let standing = self
            .standing_since_s
            .is_some_and(|t| view.boot_s - t >= STANDING_AFTER_S);
        if let Some(id) = &self.cancelling
            && standing
            && !self.actions.busy()
        {
            let id = id.clone();
            self.actions
                .finish(&id, ActionStatus::Finished, "order cancelled, vehicle stopped");
            self.cancelling = None;
        }
        self.command(view)
    }

    /// Judges the nodes again with the pose the tick ended with, before
    /// its messages are scheduled: a node the estimate has just reached is
    /// in this tick's `state`, not the next one's (the pose
    /// [`Self::advance`] sees is the one before the tick's sensors). What
    /// it changes drives the next tick's command, as before.
    pub fn traverse(&mut self, view: &VehicleView) {
        self.traverse_nodes(view);
    }

    fn command(&self, view: &VehicleView) -> Command {
        let in_charge = view.operating_mode == OperatingMode::Automatic;
        if self.paused || !in_charge {
            return Command::Hold;
        }
        // Rolling in onto a stop node reported: the navigator brings the
        // vehicle to rest there, and the node's blocking actions wait for it.
        if let Some(leg) = self.held_leg.as_ref().filter(|l| l.stop) {
            return Command::Drive(leg.clone());
        }
        if self.actions.blocks_driving() {
            return Command::Hold;
        }
        match &self.held_leg {
            Some(leg) => Command::Drive(leg.clone()),
            None => self.leg_command(self.passed).map_or(Command::Hold, Command::Drive),
        }
    }

    /// The leg to the `i`-th node still held.
    fn leg_command(&self, i: usize) -> Option<Leg> {
        let (edge, node) = self.order.leg_at(i)?;
        let from = match i {
            0 => self.order.last_node.as_ref(),
            _ => self.order.nodes.get(i - 1),
        };
        let (from, to) = (from.and_then(map_xy)?, map_xy(node)?);
        let reverse = drives_in_reverse(edge);
        let drive_through = self.drive_through(i);
        let position = node.node_position.as_ref();
        Some(Leg {
            node_sequence_id: node.sequence_id,
            from,
            to,
            // Round the corner onto the next edge's first chord when it
            // follows a trajectory, else towards its end node.
            next: drive_through.and_then(|(e, n)| {
                let first_chord_end = self.paths.get(&e.sequence_id).and_then(|p| p.get(1).copied());
                first_chord_end.or_else(|| map_xy(n))
            }),
            reverse,
            max_speed_mps: edge.max_speed,
            stop: drive_through.is_none(),
            allowed_deviation_m: position.and_then(|p| p.allowed_deviation_x_y).filter(|d| *d > 0.0),
            allowed_deviation_rad: position.and_then(|p| p.allowed_deviation_theta).filter(|d| *d > 0.0),
            path: self.paths.get(&edge.sequence_id).cloned(),
        })
    }

    /// The edge and node after the node at `i` when the vehicle drives
    /// through it onto them (released, the same way, no blocking action
    /// at the node); `None`: it stops there.
    fn drive_through(&self, i: usize) -> Option<(&Edge, &Node)> {
        let (edge, node) = (self.order.edges.get(i)?, self.order.nodes.get(i)?);
        let after = self.order.edges.get(i + 1).zip(self.order.nodes.get(i + 1));
        after.filter(|(e, n)| {
            e.released && n.released && drives_in_reverse(e) == drives_in_reverse(edge) && !has_blocking_action(node)
        })
    }

    /// The navigator's finished legs move the driving on; the nodes the
    /// vehicle has truly come to (see [`traversal`]) are reported, in
    /// order, and one driven past without being within its deviation is
    /// reported with an error saying so.
    fn traverse_nodes(&mut self, view: &VehicleView) {
        if let Some(seq) = view.arrived_at {
            if self.held_leg.as_ref().is_some_and(|l| l.node_sequence_id == seq) {
                self.held_leg = None;
            } else if self.order.nodes.get(self.passed).is_some_and(|n| n.sequence_id == seq) {
                self.passed += 1;
            }
        }
        while let Some(node) = self.order.nodes.first() {
            let stops = self.drive_through(0).is_none();
            let passage = traversal::Passage {
                stops,
                driven_past: self.passed > 0,
                left_behind: self.passed > 1,
                way: self.way_through_next_node(),
            };
            match self.watch.judge(node, view.fix.as_ref(), &passage) {
                traversal::Verdict::No => break,
                traversal::Verdict::Traversed => {}
                traversal::Verdict::Missed { closest_m, allowed_m } => {
                    let text = if closest_m <= allowed_m {
                        format!(
                            "node {} passed {closest_m:.2} m from it, within {allowed_m:.2} m only by the estimate (its uncertainty or heading reaches past the allowed deviation)",
                            node.node_id
                        )
                    } else {
                        format!(
                            "node {} passed {closest_m:.2} m from it: outside its allowedDeviationXY {allowed_m:.2} m",
                            node.node_id
                        )
                    };
                    let refs = vec![
                        ("nodeId", node.node_id.clone()),
                        ("sequenceId", node.sequence_id.to_string()),
                    ];
                    self.errors.push(error("nodeMissed", text, refs));
                }
            }
            if self.passed == 0 && self.held_leg.is_none() {
                // Traversed before the navigator is done with its leg (the
                // middle of a corner's arc comes later; a stop is reported
                // while still rolling in): it drives the leg on as planned.
                self.held_leg = self.leg_command(0);
            }
            self.passed = self.passed.saturating_sub(1);
            self.reach_next_node();
        }
    }

    /// The way through the next node to traverse (map frame): the unit
    /// direction of the edge's last chord into it plus that of the next
    /// edge's first chord out of it (none when it is the last).
    fn way_through_next_node(&self) -> (f64, f64) {
        let unit = |(x0, y0): (f64, f64), (x1, y1): (f64, f64)| {
            let length = (x1 - x0).hypot(y1 - y0);
            if length > 1e-9 {
                ((x1 - x0) / length, (y1 - y0) / length)
            } else {
                (0.0, 0.0)
            }
        };
        let order = &self.order;
        let (Some(node), Some(edge)) = (order.nodes.first().and_then(map_xy), order.edges.first()) else {
            return (0.0, 0.0);
        };
        let chord_in = self
            .paths
            .get(&edge.sequence_id)
            .and_then(|p| p.len().checked_sub(2).map(|i| p[i]));
        let into = chord_in.or_else(|| order.last_node.as_ref().and_then(map_xy));
        let out_edge = order.edges.get(1);
        let chord_out = out_edge
            .and_then(|e| self.paths.get(&e.sequence_id))
            .and_then(|p| p.get(1).copied());
        let out_of = chord_out.or_else(|| order.nodes.get(1).and_then(map_xy));
        let way_in = into.map_or((0.0, 0.0), |from| unit(from, node));
        let way_out = out_of.map_or((0.0, 0.0), |to| unit(node, to));
        (way_in.0 + way_out.0, way_in.1 + way_out.1)
    }

    fn reach_next_node(&mut self) {
        let Some((node, edge)) = self.order.reach_next() else {
            return;
        };
        self.watch = Watch::default();
        if let Some(edge) = edge {
            self.actions.leave_edge(edge.sequence_id);
            self.paths.remove(&edge.sequence_id);
        }
        self.actions.trigger(Scope::Node(node.sequence_id));
        if let Some(next) = self.order.edges.first().filter(|e| e.released) {
            self.actions.trigger(Scope::Edge(next.sequence_id));
        }
        self.order_generation += 1;
    }

    fn handle(&mut self, topic: Topic, payload: &[u8], view: &VehicleView) {
        match topic {
            Topic::Order => match parse_order(payload) {
                Ok(order) => self.handle_order(order, view),
                Err(e) => self.payload_error("order", e.to_string()),
            },
            Topic::InstantActions => match parse_instant_actions(payload) {
                Ok(instant) => {
                    for action in &instant.actions {
                        self.instant_action(action, view);
                    }
                }
                Err(e) => self.payload_error("instantActions", e.to_string()),
            },
            // The edge (re)connected to the broker: the master control may
            // have missed everything, so the factsheet and a state go out.
            Topic::Connection => {
                self.publish.push(Publish::Factsheet);
                self.publish.push(Publish::State);
            }
            _ => {}
        }
    }

    fn payload_error(&mut self, topic: &str, description: String) {
        self.errors
            .push(error("validationError", description, vec![("topic", topic.to_owned())]));
    }

    fn handle_order(&mut self, order: Order, view: &VehicleView) {
        let mappings = self.config.mappings.clone();
        let supports = move |t: &str| mapping(&mappings, t).is_some();
        let ctx = OrderContext {
            map_id: &self.config.map_id,
            position: view.pose.map(|p| (p.x_m, p.y_m)),
            actions_busy: self.actions.busy(),
            supports_action: &supports,
            min_turn_radius_m: view.min_turn_radius_m,
        };
        let known_nodes = self.order.nodes.len();
        let verdict = self.order.receive(order, &ctx);
        self.order_generation += 1;
        let Verdict::Accepted { new_order } = verdict else {
            return;
        };
        self.errors.clear();
        self.cut_trajectories(new_order);
        if new_order {
            self.passed = 0;
            self.watch = Watch::default();
            self.held_leg = None;
            self.actions.forget_done();
            self.set_paused(false, view.boot_s);
            self.add_order_actions(0);
            if let Some(first) = self.order.last_node.clone() {
                self.add_actions_of(&first.actions, Scope::Node(first.sequence_id));
                self.actions.trigger(Scope::Node(first.sequence_id));
            }
            if let Some(edge) = self.order.edges.first().filter(|e| e.released) {
                self.actions.trigger(Scope::Edge(edge.sequence_id));
            }
        } else {
            // Actions of nodes and edges already held were added when they
            // came (the stitching node keeps the first order's).
            let kept = known_nodes.min(self.order.nodes.len());
            self.add_order_actions(kept);
            self.drive_on_from_a_reported_stop();
        }
        self.events.push(OrderEvent::Accepted { new_order });
    }

    /// The vehicle is rolling in onto the decision point, already reported,
    /// and an update released the way on from it: it drives on instead of
    /// stopping (the same way, and nothing at the node blocks).
    fn drive_on_from_a_reported_stop(&mut self) {
        let Some(held) = self.held_leg.as_ref().filter(|l| l.stop) else {
            return;
        };
        let same_way = self
            .order
            .next_leg()
            .is_some_and(|(edge, _)| drives_in_reverse(edge) == held.reverse);
        let unblocked = self.order.last_node.as_ref().is_some_and(|n| !has_blocking_action(n));
        if same_way && unblocked {
            self.held_leg = None;
        }
    }

    /// The chords of every held edge's trajectory not cut yet (an update's
    /// edges replace the horizon's, so those are cut again).
    fn cut_trajectories(&mut self, new_order: bool) {
        if new_order {
            self.paths.clear();
        }
        let held: Vec<u32> = self.order.edges.iter().map(|e| e.sequence_id).collect();
        self.paths.retain(|seq, _| held.contains(seq));
        for edge in &self.order.edges {
            let Some(trajectory) = &edge.trajectory else {
                self.paths.remove(&edge.sequence_id);
                continue;
            };
            if edge.released && self.paths.contains_key(&edge.sequence_id) {
                continue;
            }
            // Checked when the order was accepted.
            if let Ok(curve) = Nurbs::new(trajectory) {
                let chords = curve.chords(super::trajectory::CHORD_TOLERANCE_M);
                self.paths.insert(edge.sequence_id, chords.into());
            }
        }
    }

    /// Adds the actions of the nodes from index `from` on, and of their edges.
    fn add_order_actions(&mut self, from: usize) {
        let nodes: Vec<Node> = self.order.nodes[from..].to_vec();
        let edges: Vec<Edge> = self.order.edges[from.min(self.order.edges.len())..].to_vec();
        for (i, node) in nodes.iter().enumerate() {
            if let Some(edge) = edges.get(i) {
                self.add_actions_of(&edge.actions, Scope::Edge(edge.sequence_id));
            }
            self.add_actions_of(&node.actions, Scope::Node(node.sequence_id));
        }
    }

    fn add_actions_of(&mut self, actions: &[Action], scope: Scope) {
        for action in actions {
            self.actions.add_waiting(action, scope);
        }
    }

    fn instant_action(&mut self, action: &Action, view: &VehicleView) {
        let done = |agent: &mut Agent, status, result: &str| agent.actions.add_done(action, status, result.into());
        match action.action_type.as_str() {
            "startPause" => {
                self.set_paused(true, view.boot_s);
                done(self, ActionStatus::Finished, "paused");
            }
            "stopPause" => {
                self.set_paused(false, view.boot_s);
                done(self, ActionStatus::Finished, "resumed");
            }
            "cancelOrder" => self.cancel_order(action),
            "stateRequest" => {
                self.publish.push(Publish::State);
                done(self, ActionStatus::Finished, "state sent");
            }
            "factsheetRequest" => {
                self.publish.push(Publish::Factsheet);
                done(self, ActionStatus::Finished, "factsheet sent");
            }
            "initPosition" => self.init_position(action, view),
            kind if self.supports_action(kind) => self.actions.add_instant(action),
            kind => {
                let text = format!("instant action type {kind:?} is not supported");
                done(self, ActionStatus::Failed, &text);
                let refs = vec![("actionId", action.action_id.clone()), ("actionType", kind.to_owned())];
                self.errors.push(error("orderError", text, refs));
            }
        }
        self.order_generation += 1;
    }

    /// Pauses (startPause) or resumes (stopPause, a new order) the vehicle
    /// and, with it, the running actions (§6.11: PAUSED).
    fn set_paused(&mut self, paused: bool, now_s: f64) {
        if paused == self.paused {
            return;
        }
        self.paused = paused;
        let outputs = if paused {
            self.actions.pause(now_s, &self.config.mappings)
        } else {
            self.actions.resume(now_s, &self.config.mappings)
        };
        self.outputs.extend(outputs);
    }

    /// cancelOrder (§6.6.3): stop now, fail what is left, keep the ids.
    fn cancel_order(&mut self, action: &Action) {
        if !self.order.has_nodes() && !self.actions.busy() {
            self.actions
                .add_done(action, ActionStatus::Failed, "no order to cancel".into());
            let refs = vec![("actionId", action.action_id.clone())];
            self.errors
                .push(error("noOrderToCancel", "there is no order to cancel".into(), refs));
            return;
        }
        self.order.cancel();
        self.passed = 0;
        self.watch = Watch::default();
        self.held_leg = None;
        self.paths.clear();
        self.actions.cancel_all();
        self.actions.add_done(action, ActionStatus::Running, "stopping".into());
        self.cancelling = Some(action.action_id.clone());
        self.events.push(OrderEvent::Cancelled);
    }

    /// initPosition: this vehicle localises by GNSS and cannot be told where
    /// it is; the pose given is checked against the estimate and, when it
    /// agrees, `lastNodeId` is set.
    fn init_position(&mut self, action: &Action, view: &VehicleView) {
        let number = |key: &str| {
            let parameters = action.action_parameters.as_deref().unwrap_or_default();
            parameters.iter().find(|p| p.key == key).and_then(|p| p.value.as_f64())
        };
        let text = |key: &str| {
            let parameters = action.action_parameters.as_deref().unwrap_or_default();
            parameters
                .iter()
                .find(|p| p.key == key)
                .and_then(|p| p.value.as_str().map(str::to_owned))
        };
        let verdict = match (number("x"), number("y"), view.pose) {
            (Some(x), Some(y), Some(pose)) if text("mapId").is_none_or(|m| m == self.config.map_id) => {
                let off = (pose.x_m - x).hypot(pose.y_m - y);
                if off <= super::order::DEFAULT_START_DEVIATION_M {
                    if let Some(node) = text("lastNodeId") {
                        self.order.last_node_id = node;
                    }
                    Ok(format!("pose agrees with the GNSS estimate ({off:.2} m)"))
                } else {
                    Err(format!(
                        "GNSS-localised: the pose given is {off:.2} m from the estimate"
                    ))
                }
            }
            (_, _, None) => Err("no position estimate to check the pose against".to_owned()),
            _ => Err("x, y (numbers) and this vehicle's mapId are needed".to_owned()),
        };
        match verdict {
            Ok(result) => self.actions.add_done(action, ActionStatus::Finished, result),
            Err(result) => self.actions.add_done(action, ActionStatus::Failed, result),
        }
    }

    fn fingerprint(&self, view: &VehicleView) -> Fingerprint {
        Fingerprint {
            order_generation: self.order_generation,
            action_generation: self.actions.generation,
            errors: self.errors.len() + self.order.errors.len(),
            driving: view.driving,
            paused: self.paused,
            new_base_request: self.new_base_request(),
            operating_mode: view.operating_mode,
            e_stop: view.e_stop,
        }
    }

    /// `state` on every change and at its interval; `visualization` at its.
    pub fn schedule_messages(&mut self, view: &VehicleView) {
        let fingerprint = self.fingerprint(view);
        let interval = if view.driving {
            self.config.state_interval_driving_s
        } else {
            self.config.state_interval_idle_s
        };
        let due = self.last_state_wall_s.is_none_or(|t| view.wall_s - t >= interval);
        let changed = self.last_fingerprint.as_ref() != Some(&fingerprint);
        let requested = self.publish.contains(&Publish::State);
        if (due || changed) && !requested {
            self.publish.push(Publish::State);
        }
        if due || changed || requested {
            // A periodic state keeps to its grid (the tick would stretch
            // each interval by up to a period, and 1 Hz read 0.98 Hz); one
            // sent for a change restarts the interval.
            let on_grid = self
                .last_state_wall_s
                .map(|t| t + interval)
                .filter(|&next| due && !changed && !requested && view.wall_s - next < interval);
            self.last_state_wall_s = Some(on_grid.unwrap_or(view.wall_s));
            self.last_fingerprint = Some(fingerprint);
        }
        let every = self.config.visualization_interval_s;
        if every > 0.0 && self.last_visualization_wall_s.is_none_or(|t| view.wall_s - t >= every) {
            self.last_visualization_wall_s = Some(view.wall_s);
            self.publish.push(Publish::Visualization);
        }
    }
}

fn map_xy(node: &Node) -> Option<(f64, f64)> {
    node.node_position.as_ref().map(|p| (p.x, p.y))
}

/// TANGENTIAL (or no type) with an orientation near π: the edge is driven
/// backwards (§6.6.6).
pub fn drives_in_reverse(edge: &Edge) -> bool {
    let tangential = edge.orientation_type.is_none_or(|t| t == OrientationType::Tangential);
    tangential && edge.orientation.is_some_and(|o| o.abs() > std::f64::consts::FRAC_PI_2)
}

fn has_blocking_action(node: &Node) -> bool {
    node.actions
        .iter()
        .any(|a| a.blocking_type != vda5050::common::BlockingType::None)
}
