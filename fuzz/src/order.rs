//! VDA 5050 orders and instant actions a master control could send, fed to
//! the vehicle's agent (the order state machine: acceptance, updates,
//! cancellation, actions) and stepped with time while a point vehicle
//! drives the legs it commands. Most inputs are well-formed orders built
//! from the fuzzer's bytes (so updates stitch, nodes are reached and
//! actions run); some are cut, retyped or raw bytes.
//!
//! Properties, besides "no panic":
//! - the order held stays a chain: each node left has its incoming edge,
//!   sequence ids run on from the last node reached, the base comes first;
//! - a new order is taken only when the vehicle had nothing left to do, and
//!   an order's `orderUpdateId` never goes back;
//! - a drive command goes along the order's next released edge to its end
//!   node, from the last node reached, with finite coordinates (and the
//!   edge's trajectory as finite chords when it has one), never while
//!   paused, blocked by an action, or not in charge;
//! - a cancelled order has no nodes left at once and the vehicle holds;
//! - an action that finished or failed stays so;
//! - every `state` and `visualization` validates against the official
//!   schema.

use std::collections::BTreeMap;
use std::sync::OnceLock;

use autopilot::fleet::map::MapPose;
use autopilot::fleet::publish::Publisher;
use autopilot::fleet::state::{build_state, build_visualization};
use autopilot::fleet::traversal::Fix;
use autopilot::fleet::{Agent, AgentConfig, Command, Leg, VehicleReport, VehicleView};
use autopilot::vehicle::FleetMessage;
use libfuzzer_sys::arbitrary::{Result, Unstructured};
use serde_json::{Value, json};
use vda5050::state::{ActionStatus, EStop, OperatingMode};
use vda5050::{Topic, TopicPrefix};

const MAP_ID: &str = "yard";
/// Agent step (s).
const DT_S: f64 = 0.1;
/// The point vehicle's speed when the leg sets none (m/s).
const CRUISE_MPS: f64 = 1.5;
/// A node counts as reached within this when it gives no deviation (m).
const ARRIVAL_M: f64 = 0.1;
/// The point vehicle's tightest turn (m): tight fuzzed curves are refused
/// (the rejection is fuzzed too), gentle ones driven.
const MIN_TURN_RADIUS_M: f64 = 2.0;
/// Node positions lie within this of the start (m).
const AREA_M: f64 = 30.0;
const ORDER_IDS: [&str; 3] = ["o1", "o2", "o3"];
const ACTION_TYPES: [&str; 9] = [
    "pick",
    "drop",
    "pick",
    "startPause",
    "stopPause",
    "cancelOrder",
    "stateRequest",
    "initPosition",
    "weld",
];
const BLOCKING: [&str; 3] = ["NONE", "SOFT", "HARD"];

fn validator(name: &str, text: &str) -> jsonschema::Validator {
    let schema: Value = serde_json::from_str(text).unwrap_or_else(|e| panic!("{name} schema: {e}"));
    jsonschema::options()
        .should_validate_formats(true)
        .build(&schema)
        .unwrap_or_else(|e| panic!("{name} schema: {e}"))
}

fn state_schema() -> &'static jsonschema::Validator {
    static SCHEMA: OnceLock<jsonschema::Validator> = OnceLock::new();
    SCHEMA.get_or_init(|| validator("state", include_str!("../../tests/data/vda5050/state.schema")))
}

fn visualization_schema() -> &'static jsonschema::Validator {
    static SCHEMA: OnceLock<jsonschema::Validator> = OnceLock::new();
    SCHEMA.get_or_init(|| {
        validator(
            "visualization",
            include_str!("../../tests/data/vda5050/visualization.schema"),
        )
    })
}

/// The vehicle the agent drives: a point that goes straight at the leg's
/// end node.
struct PointVehicle {
    pose: MapPose,
    boot_s: f64,
    driving: bool,
    arrived_at: Option<u32>,
    operating_mode: OperatingMode,
}

impl PointVehicle {
    fn view(&self) -> VehicleView {
        VehicleView {
            boot_s: self.boot_s,
            wall_s: self.boot_s,
            pose: Some(self.pose),
            // The point vehicle is exactly where it says, so every node it
            // reaches counts as traversed.
            fix: Some(Fix {
                pose: self.pose,
                position_bound_m: 0.0,
                yaw_bound_rad: 0.0,
            }),
            arrived_at: self.arrived_at,
            at_rest: !self.driving,
            driving: self.driving,
            operating_mode: self.operating_mode,
            e_stop: EStop::None,
            min_turn_radius_m: Some(MIN_TURN_RADIUS_M),
        }
    }

    fn report(&self) -> VehicleReport {
        VehicleReport {
            pose: Some(self.pose),
            position_initialized: true,
            localization_score: 1.0,
            deviation_range_m: 0.02,
            speed_mps: if self.driving { CRUISE_MPS } else { 0.0 },
            yaw_rate_rad_s: 0.0,
            driving: self.driving,
            battery_percent: 80.0,
            battery_voltage_v: Some(25.0),
            operating_mode: self.operating_mode,
            errors: Vec::new(),
            information: Vec::new(),
            field_violation: false,
            e_stop: EStop::None,
        }
    }

    fn drive(&mut self, command: &Command) {
        self.boot_s += DT_S;
        self.arrived_at = None;
        self.driving = false;
        let Command::Drive(leg) = command else {
            return;
        };
        let (dx, dy) = (leg.to.0 - self.pose.x_m, leg.to.1 - self.pose.y_m);
        let distance = dx.hypot(dy);
        let tolerance = if leg.stop {
            leg.allowed_deviation_m.unwrap_or(ARRIVAL_M).max(ARRIVAL_M)
        } else {
            0.5
        };
        if distance <= tolerance {
            self.arrived_at = Some(leg.node_sequence_id);
            return;
        }
        let speed = leg.max_speed_mps.unwrap_or(CRUISE_MPS).clamp(0.05, CRUISE_MPS);
        let step = (speed * DT_S).min(distance);
        self.pose.x_m += dx / distance * step;
        self.pose.y_m += dy / distance * step;
        self.pose.theta_rad = dy.atan2(dx);
        self.driving = true;
    }
}

/// Builds the payloads: well-formed mostly, ids drawn from small pools so
/// that updates meet the order they update.
struct Master {
    next_action: u32,
    header_id: u32,
}

impl Master {
    fn action(&mut self, u: &mut Unstructured, instant: bool) -> Result<Value> {
        self.next_action += 1;
        let kind = if instant {
            *u.choose(&ACTION_TYPES)?
        } else {
            *u.choose(&ACTION_TYPES[..3])?
        };
        let mut action = json!({
            "actionId": format!("a{}", self.next_action),
            "actionType": kind,
            "blockingType": *u.choose(&BLOCKING)?,
        });
        if kind == "initPosition" || u.ratio(1, 8)? {
            action["actionParameters"] = json!([
                {"key": "x", "value": coordinate(u)?},
                {"key": "y", "value": coordinate(u)?},
                {"key": "lastNodeId", "value": "n0"},
            ]);
        }
        Ok(action)
    }

    fn header(&mut self) -> Value {
        self.header_id += 1;
        json!({
            "headerId": self.header_id, "timestamp": "2026-11-27T04:00:00.00Z", "version": "2.1.0",
            "manufacturer": "Furrow", "serialNumber": "R1",
        })
    }

    fn instant_actions(&mut self, u: &mut Unstructured) -> Result<Value> {
        let mut message = self.header();
        let count = u.int_in_range(1..=3)?;
        let actions: Vec<Value> = (0..count).map(|_| self.action(u, true)).collect::<Result<_>>()?;
        message["actions"] = json!(actions);
        Ok(message)
    }

    /// An order: new, or an update starting where the agent's order stands
    /// (so that it stitches), with nodes near the vehicle.
    fn order(&mut self, u: &mut Unstructured, agent: &Agent, at: &MapPose) -> Result<Value> {
        let book = &agent.order;
        let update = !book.order_id.is_empty() && u.ratio(2, 3)?;
        let (order_id, update_id, first) = if update {
            let stitch = book.nodes.iter().rev().find(|n| n.released).or(book.last_node.as_ref());
            let first = stitch.map(|n| {
                let p = n.node_position.as_ref();
                (
                    n.node_id.clone(),
                    n.sequence_id,
                    p.map_or(at.x_m, |p| p.x),
                    p.map_or(at.y_m, |p| p.y),
                )
            });
            let bump = u.int_in_range(0..=2)?;
            let first = first.unwrap_or(("n0".into(), 0, at.x_m, at.y_m));
            (book.order_id.clone(), book.order_update_id.saturating_add(bump), first)
        } else {
            let id = (*u.choose(&ORDER_IDS)?).to_owned();
            let seq = 2 * u.int_in_range(0..=3)?;
            (id, u.int_in_range(0..=2)?, (format!("s{seq}"), seq, at.x_m, at.y_m))
        };
        let count = u.int_in_range(0..=5)?;
        let horizon_from = u.int_in_range(1..=count + 1)?;
        let mut nodes = vec![self.node(u, &first.0, first.1, (first.2, first.3), true)?];
        let mut edges = Vec::new();
        for i in 1..=count {
            let seq = first.1 + 2 * i;
            let released = i < horizon_from;
            let id = format!("n{seq}");
            let from = nodes.last().map(|n: &Value| n["nodeId"].clone()).unwrap_or_default();
            edges.push(self.edge(u, seq - 1, &from, &id, released)?);
            let xy = (coordinate(u)?, coordinate(u)?);
            if u.ratio(1, 3)? {
                let start = nodes.last().map(|n: &Value| &n["nodePosition"]);
                let start = start.map_or((0.0, 0.0), |p| {
                    (p["x"].as_f64().unwrap_or(0.0), p["y"].as_f64().unwrap_or(0.0))
                });
                if let Some(edge) = edges.last_mut() {
                    edge["trajectory"] = trajectory(u, start, xy)?;
                }
            }
            nodes.push(self.node(u, &id, seq, xy, released)?);
        }
        let mut message = self.header();
        message["orderId"] = json!(order_id);
        message["orderUpdateId"] = json!(update_id);
        message["nodes"] = json!(nodes);
        message["edges"] = json!(edges);
        Ok(message)
    }

    fn node(&mut self, u: &mut Unstructured, id: &str, seq: u32, xy: (f64, f64), released: bool) -> Result<Value> {
        let mut position = json!({"x": xy.0, "y": xy.1, "mapId": MAP_ID});
        if u.ratio(1, 2)? {
            position["allowedDeviationXY"] = json!(f64::from(u.int_in_range(0u8..=100)?) / 100.0);
        }
        if u.ratio(1, 4)? {
            position["theta"] = json!(f64::from(u.int_in_range(-314i16..=314)?) / 100.0);
            position["allowedDeviationTheta"] = json!(f64::from(u.int_in_range(0u8..=31)?) / 10.0);
        }
        let count = u.int_in_range(0..=2)?;
        let actions: Vec<Value> = (0..count).map(|_| self.action(u, false)).collect::<Result<_>>()?;
        Ok(json!({
            "nodeId": id, "sequenceId": seq, "released": released,
            "nodePosition": position, "actions": actions,
        }))
    }

    fn edge(&mut self, u: &mut Unstructured, seq: u32, from: &Value, to: &str, released: bool) -> Result<Value> {
        let count = u.int_in_range(0..=1)?;
        let actions: Vec<Value> = (0..count).map(|_| self.action(u, false)).collect::<Result<_>>()?;
        let mut edge = json!({
            "edgeId": format!("e{seq}"), "sequenceId": seq, "released": released,
            "startNodeId": from, "endNodeId": to, "actions": actions,
        });
        if u.ratio(1, 2)? {
            edge["maxSpeed"] = json!(f64::from(u.int_in_range(0u8..=30)?) / 10.0);
        }
        if u.ratio(1, 3)? {
            edge["orientation"] = json!(*u.choose(&[0.0, std::f64::consts::PI, -3.0, 1.0])?);
            edge["orientationType"] = json!(*u.choose(&["TANGENTIAL", "GLOBAL"])?);
        }
        Ok(edge)
    }
}

/// A NURBS from `start` to `end` through fuzzed control points between
/// them: mostly well-formed (clamped knots, positive weights), sometimes
/// not (a knot out of order, a weight of 0, an end off its node).
fn trajectory(u: &mut Unstructured, start: (f64, f64), end: (f64, f64)) -> Result<Value> {
    let degree = u.int_in_range(1u32..=3)?;
    let inner = u.int_in_range(0usize..=4)?;
    let mut points = vec![json!({"x": start.0, "y": start.1})];
    for _ in 0..degree as usize + inner - 1 {
        let mut point = json!({"x": coordinate(u)?, "y": coordinate(u)?});
        if u.ratio(1, 3)? {
            point["weight"] = json!(f64::from(u.int_in_range(0u8..=40)?) / 10.0);
        }
        points.push(point);
    }
    let end = if u.ratio(1, 10)? { (end.0 + 1.0, end.1) } else { end };
    points.push(json!({"x": end.0, "y": end.1}));
    let p = degree as usize;
    let mut inner_knots: Vec<f64> = (0..points.len() - p - 1)
        .map(|_| u.int_in_range(0u8..=100).map(|k| f64::from(k) / 100.0))
        .collect::<Result<_>>()?;
    if !u.ratio(1, 10)? {
        inner_knots.sort_by(f64::total_cmp);
    }
    let mut knots = vec![0.0; p + 1];
    knots.extend(inner_knots);
    knots.extend(vec![1.0; p + 1]);
    Ok(json!({"degree": degree, "knotVector": knots, "controlPoints": points}))
}

fn coordinate(u: &mut Unstructured) -> Result<f64> {
    Ok(f64::from(u.int_in_range(-(AREA_M as i16) * 10..=(AREA_M as i16) * 10)?) / 10.0)
}

/// Damages a well-formed message: a field dropped, a value of another
/// type, an id changed.
fn damage(u: &mut Unstructured, message: &mut Value) -> Result<()> {
    let replacement = match u.int_in_range(0u8..=5)? {
        0 => Value::Null,
        1 => json!(-1),
        2 => json!("x"),
        3 => json!([]),
        4 => json!(1e300),
        _ => json!({}),
    };
    // Walk down to a value (a JSON pointer), then change it.
    let mut pointer = String::new();
    let mut at: &Value = message;
    let mut drop_key = None;
    for _ in 0..u.int_in_range(1..=4)? {
        match at {
            Value::Object(map) if !map.is_empty() => {
                let keys: Vec<&String> = map.keys().collect();
                let key = (*u.choose(&keys)?).clone();
                if u.ratio(1, 4)? {
                    drop_key = Some(key);
                    break;
                }
                pointer.push('/');
                pointer.push_str(&key.replace('~', "~0").replace('/', "~1"));
                at = &map[&key];
            }
            Value::Array(items) if !items.is_empty() => {
                let i = u.choose_index(items.len())?;
                pointer.push_str(&format!("/{i}"));
                at = &items[i];
            }
            _ => break,
        }
    }
    let Some(target) = message.pointer_mut(&pointer) else {
        return Ok(());
    };
    match drop_key {
        Some(key) => {
            if let Value::Object(map) = target {
                map.remove(&key);
            }
        }
        None => *target = replacement,
    }
    Ok(())
}

/// The agent, its vehicle and what the properties need to remember.
struct Run {
    agent: Agent,
    vehicle: PointVehicle,
    publisher: Publisher,
    /// The last status seen of each action (ids are unique per input).
    statuses: BTreeMap<String, ActionStatus>,
}

impl Run {
    fn new() -> Run {
        Run {
            agent: Agent::new(AgentConfig {
                map_id: MAP_ID.into(),
                // Fewer visualizations to check: it holds no order data.
                visualization_interval_s: 5.0,
                ..AgentConfig::default()
            }),
            vehicle: PointVehicle {
                pose: MapPose {
                    x_m: 0.0,
                    y_m: 0.0,
                    theta_rad: 0.0,
                },
                boot_s: 0.0,
                driving: false,
                arrived_at: None,
                operating_mode: OperatingMode::Automatic,
            },
            publisher: Publisher::new(TopicPrefix::uagv_v2("Furrow", "R1").expect("a valid prefix")),
            statuses: BTreeMap::new(),
        }
    }

    /// Delivers one payload and steps once; checks what the step did.
    fn deliver(&mut self, topic: Topic, payload: Vec<u8>, cancels: bool) {
        let before = (self.agent.order.order_id.clone(), self.agent.order.order_update_id);
        let was_idle = !self.agent.has_order() && !self.agent.actions.busy();
        let had_order = self.agent.has_order();
        self.agent.receive(topic, payload);
        let command = self.step();
        let book = &self.agent.order;
        if book.order_id != before.0 {
            assert!(
                was_idle,
                "order {} taken over the unfinished {}",
                book.order_id, before.0
            );
        } else {
            assert!(book.order_update_id >= before.1, "orderUpdateId went back");
        }
        if cancels && had_order {
            assert!(!self.agent.has_order(), "a cancelled order kept nodes");
            assert_eq!(command, Command::Hold, "drives after a cancel");
        }
    }

    fn step(&mut self) -> Command {
        let view = self.vehicle.view();
        let command = self.agent.step(&view);
        self.check_order_chain();
        self.check_command(&command, &view);
        self.check_actions();
        self.publish();
        self.vehicle.drive(&command);
        command
    }

    fn check_order_chain(&self) {
        let book = &self.agent.order;
        assert_eq!(book.edges.len(), book.nodes.len(), "a node without its edge");
        let mut previous = book.last_node_sequence_id;
        for (edge, node) in book.edges.iter().zip(&book.nodes) {
            assert_eq!(edge.sequence_id, previous + 1, "edge sequence ids do not run on");
            assert_eq!(
                node.sequence_id,
                edge.sequence_id + 1,
                "node sequence ids do not run on"
            );
            previous = node.sequence_id;
        }
        let released = book.nodes.iter().take_while(|n| n.released).count();
        assert!(
            book.nodes[released..].iter().all(|n| !n.released),
            "the base is not first"
        );
    }

    fn check_command(&self, command: &Command, view: &VehicleView) {
        let Command::Drive(leg) = command else {
            return;
        };
        let Leg { from, to, .. } = leg;
        assert!([from.0, from.1, to.0, to.1].iter().all(|v| v.is_finite()), "{leg:?}");
        assert!(!self.agent.paused, "drives while paused");
        assert_eq!(
            view.operating_mode,
            OperatingMode::Automatic,
            "drives while not in charge"
        );
        assert!(
            !self.agent.actions.runs_blocking(),
            "drives while a blocking action runs"
        );
        let book = &self.agent.order;
        if self.agent.held_leg() == Some(leg) {
            // Driven on onto the last node reported (rolling in on a stop,
            // whose blocking actions wait for rest; or a corner's arc).
            assert_eq!(leg.node_sequence_id, book.last_node_sequence_id, "a held leg elsewhere");
            assert!(
                leg.stop || !self.agent.actions.blocks_driving(),
                "drives on during a blocking action"
            );
            return;
        }
        assert!(!self.agent.actions.blocks_driving(), "drives during a blocking action");
        let (edge, node) = book.next_leg().expect("a drive command without a released leg");
        assert_eq!(leg.node_sequence_id, node.sequence_id);
        let end = node.node_position.as_ref().map(|p| (p.x, p.y));
        assert_eq!(Some(leg.to), end, "the leg does not end at its node");
        let start = book
            .last_node
            .as_ref()
            .and_then(|n| n.node_position.as_ref())
            .map(|p| (p.x, p.y));
        assert_eq!(Some(leg.from), start, "the leg does not start at the last node");
        assert_eq!(leg.reverse, autopilot::fleet::agent::drives_in_reverse(edge));
        assert_eq!(
            leg.path.is_some(),
            edge.trajectory.is_some(),
            "a trajectory lost or made up"
        );
        if let Some(path) = leg.path.as_deref() {
            assert!(path.len() >= 2, "a trajectory of {} points", path.len());
            assert!(path.iter().all(|p| p.0.is_finite() && p.1.is_finite()), "{path:?}");
        }
    }

    fn check_actions(&mut self) {
        for state in self.agent.actions.states() {
            let done = |s: ActionStatus| matches!(s, ActionStatus::Finished | ActionStatus::Failed);
            if let Some(before) = self.statuses.get(&state.action_id) {
                assert!(
                    !done(*before) || done(state.action_status),
                    "action {} went from {before:?} to {:?}",
                    state.action_id,
                    state.action_status
                );
            }
            self.statuses.insert(state.action_id, state.action_status);
        }
    }

    fn publish(&mut self) {
        let report = self.vehicle.report();
        let unix_ms = 1_795_000_000_000 + (self.vehicle.boot_s * 1000.0) as u64;
        for publish in self.agent.take_publish() {
            let (message, schema) = match publish {
                autopilot::fleet::Publish::State => (
                    FleetMessage::State(Box::new(build_state(&self.agent, &report))),
                    state_schema(),
                ),
                autopilot::fleet::Publish::Visualization => (
                    FleetMessage::Visualization(Box::new(build_visualization(&self.agent, &report))),
                    visualization_schema(),
                ),
                // The factsheet depends on the vehicle's parameters, not on
                // the orders fuzzed here.
                autopilot::fleet::Publish::Factsheet => continue,
            };
            let publication = self.publisher.message(message, unix_ms);
            let value: Value = serde_json::from_slice(&publication.payload).expect("published JSON");
            let errors: Vec<String> = schema.iter_errors(&value).map(|e| e.to_string()).collect();
            assert!(errors.is_empty(), "{}: {errors:?}\n{value}", publication.topic);
        }
    }
}

/// One input: payloads and pauses, then driving on until the order ends.
pub fn run(data: &[u8]) -> Result<()> {
    let mut u = Unstructured::new(data);
    let mut run = Run::new();
    let mut master = Master {
        next_action: 0,
        header_id: 0,
    };
    for _ in 0..u.int_in_range(1..=16)? {
        match u.int_in_range(0u8..=9)? {
            0..=3 => {
                let mut order = master.order(&mut u, &run.agent, &run.vehicle.pose)?;
                if u.ratio(1, 6)? {
                    damage(&mut u, &mut order)?;
                }
                run.deliver(Topic::Order, order.to_string().into_bytes(), false);
            }
            4 | 5 => {
                let mut actions = master.instant_actions(&mut u)?;
                if u.ratio(1, 8)? {
                    damage(&mut u, &mut actions)?;
                }
                let cancels = actions["actions"]
                    .as_array()
                    .is_some_and(|a| a.iter().any(|a| a["actionType"] == "cancelOrder"));
                run.deliver(Topic::InstantActions, actions.to_string().into_bytes(), cancels);
            }
            6 => {
                let topic = *u.choose(&[Topic::Order, Topic::InstantActions])?;
                let len = u.int_in_range(0..=64)?;
                let bytes = u.bytes(len)?.to_vec();
                run.deliver(topic, bytes, false);
            }
            7 => {
                // A ground station takes the vehicle, or gives it back.
                run.vehicle.operating_mode = *u.choose(&[
                    OperatingMode::Automatic,
                    OperatingMode::Automatic,
                    OperatingMode::Service,
                    OperatingMode::Manual,
                ])?;
            }
            _ => {
                for _ in 0..u.int_in_range(1..=100)? {
                    run.step();
                }
            }
        }
    }
    // Let the order run out (at most as long as the longest order takes):
    // every node reached, every action done.
    run.vehicle.operating_mode = OperatingMode::Automatic;
    for _ in 0..3000 {
        if !run.agent.has_order() && !run.agent.actions.busy() {
            break;
        }
        run.step();
    }
    Ok(())
}
