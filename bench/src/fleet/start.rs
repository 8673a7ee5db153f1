//! Order → truly moving and node reached → `state`, in-process: one
//! simulated vehicle (the Ackermann car `furrow sitl` runs) is sent orders
//! through its VDA 5050 inputs, and each is timed in simulated time (at
//! speedup 1 simulated time is wall time).
//!
//! A start is timed from the tick the order arrives in: to the first tick
//! whose drive demand moves (what `driving` reports), to the first `state`
//! that says so, to the true body moving, and to its true speed past
//! `driving`'s 3 cm/s. "Moving" is read from the simulator's truth: the
//! simulated drive has no noise, so at rest the true speed is only the
//! fading tail of the last stop; the body moves once its true speed rises
//! above the largest it showed during the rest before the order.
//!
//! A node is timed from the truth reaching it (the vehicle first within the
//! allowed deviation; on the stop, which gives a `theta`, also heading
//! within its allowed deviation) and from the navigator's decision that it
//! has arrived, to the first `state` that names it `lastNodeId` as it
//! leaves the core. A state that names a node the truth has not reached is
//! a false claim, counted apart. The stop is timed once more: from the
//! truth at rest there to the first `state` saying `driving: false`; one
//! saying so while the truth still moves is a false claim too.
//!
//! A real order also waits for the next tick (up to one period) and its
//! MQTT transit: the end-to-end figures above these say what those add.

use std::time::Duration;

use autopilot::fleet::AgentConfig;
use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};
use autopilot::time::FrozenTimer;
use autopilot::vehicle::FleetMessage;
use vehicle_types::ActuatorDemand;

/// `driving`'s speed threshold for an estimate (m/s).
const DRIVING_MPS: f64 = 0.03;
/// Rest before each order (s): the last stop's drive tail fades.
const REST_S: f64 = 5.0;
/// Slower than this the vehicle has come to rest on a stop (m/s): the
/// tracking bench's line between driving and resting.
const RESTING_MPS: f64 = 0.01;
/// The stop node's `allowedDeviationTheta` (rad) about its `theta`, the
/// way the order drives (north).
const ALLOWED_DEVIATION_THETA_RAD: f64 = 0.1;

/// Milliseconds from an order's tick to each mark of its start.
#[derive(Clone, Copy, Debug, Default)]
pub struct Start {
    pub commanded_ms: f64,
    /// The first `state` that says `driving` leaves the core.
    pub state_driving_ms: f64,
    /// The true speed first above its rest floor.
    pub moving_ms: f64,
    /// The true speed first past [`DRIVING_MPS`].
    pub driving_speed_ms: f64,
    /// The largest true speed during the rest before the order (m/s).
    pub rest_floor_mps: f64,
}

/// One node of an order as the vehicle reached it: ms of simulated time
/// from each mark to the first `state` naming it `lastNodeId` (negative:
/// the state came first).
#[derive(Clone, Copy, Debug)]
pub struct NodeReach {
    /// The order's last node: the vehicle stops on it.
    pub stops: bool,
    /// From the navigator's first tick of arrival.
    pub from_decision_ms: f64,
    /// From the truth reaching the node: a pass-through node once the
    /// vehicle is first within the allowed deviation of it, a stop once the
    /// vehicle has slowed below [`RESTING_MPS`] within the allowed
    /// deviation (NaN: the truth never did).
    pub from_truth_ms: f64,
    /// The truth's distance from the node when the state leaves (m).
    pub distance_at_state_m: f64,
    /// The state left before the truth had reached the node.
    pub false_claim: bool,
}

/// The stop at an order's end, as `driving` told it.
#[derive(Clone, Copy, Debug)]
pub struct Standing {
    /// From the truth at rest within the stop's deviation to the first
    /// `state` saying `driving: false` (NaN: none came).
    pub from_rest_ms: f64,
    /// States that said `driving: false` while the truth moved at
    /// [`RESTING_MPS`] or more, once the order had been driving.
    pub false_claims: usize,
}

/// What the in-process orders measured.
#[derive(Default)]
pub struct Measured {
    pub starts: Vec<Start>,
    pub nodes: Vec<NodeReach>,
    pub standing: Vec<Standing>,
}

/// `orders` orders, each from rest, each of three nodes 6 m apart north of
/// where the vehicle stands, with `params` set (NAME, value).
pub fn measure(orders: usize, params: &[(String, f64)]) -> Result<Measured, String> {
    let model = ModelKind::Ackermann;
    let config = SimulationConfig {
        model,
        ..SimulationConfig::default()
    };
    let mut sim_params = SimulationParams::new(model);
    sim_params.apply(params)?;
    let mut sim = Simulation::new(&config, sim_params);
    sim.core_mut().enable_vda5050(AgentConfig {
        map_id: super::MAP.into(),
        ..AgentConfig::default()
    });
    run_until(&mut sim, 60.0, |s| {
        let e = s.core().estimator().estimate();
        e.position_valid && e.heading_valid
    })
    .then_some(())
    .ok_or("no fix within 60 s")?;
    let mut measured = Measured::default();
    for k in 0..orders {
        let rest_floor_mps = rest(&mut sim, REST_S);
        let at = sim.core().estimator().estimate().position;
        let (x, y) = (at.east_m, at.north_m);
        let nodes = [("a", x, y), ("b", x, y + 6.0), ("c", x, y + 12.0)];
        let mut order = super::order("start", &format!("start-{k}"), &nodes);
        // The stop faces the way the order drives (north: theta π/2).
        let stop = &mut order["nodes"][nodes.len() - 1]["nodePosition"];
        stop["theta"] = serde_json::json!(std::f64::consts::FRAC_PI_2);
        stop["allowedDeviationTheta"] = serde_json::json!(ALLOWED_DEVIATION_THETA_RAD);
        let payload = serde_json::to_vec(&order).map_err(|e| e.to_string())?;
        sim.inputs_mut().vda5050.push((vda5050::Topic::Order, payload));
        measured.starts.push(time_start(&mut sim, rest_floor_mps)?);
        let (reached, standing) = follow_nodes(&mut sim, &nodes, 60.0)
            .ok_or_else(|| format!("order start-{k} did not finish within 60 s"))?;
        measured.nodes.extend(reached);
        measured.standing.push(standing);
    }
    Ok(measured)
}

/// Steps from the tick the order is in until the true speed passes
/// [`DRIVING_MPS`].
fn time_start(sim: &mut Simulation, rest_floor_mps: f64) -> Result<Start, String> {
    let mut start = Start {
        state_driving_ms: f64::NAN,
        commanded_ms: f64::NAN,
        moving_ms: f64::NAN,
        rest_floor_mps,
        ..Start::default()
    };
    let mut t0_ms = None;
    for _ in 0..500 {
        let wall = sim.time();
        let out = sim.step(wall, &mut FrozenTimer);
        out.mavlink.clear();
        let says_driving = out
            .vda5050
            .drain(..)
            .any(|m| matches!(m, FleetMessage::State(state) if state.driving));
        // The order is in the first tick stepped: its time is 0.
        let now_ms = sim.time().as_secs_f64() * 1e3;
        let since_ms = now_ms - *t0_ms.get_or_insert(now_ms);
        let speed_mps = sim.world().truth().speed_mps.abs();
        let first = |mark: &mut f64, now: bool| {
            if now && mark.is_nan() {
                *mark = since_ms;
            }
        };
        first(&mut start.state_driving_ms, says_driving);
        first(&mut start.commanded_ms, moves(sim.last_demand()));
        first(&mut start.moving_ms, speed_mps > rest_floor_mps);
        if speed_mps > DRIVING_MPS {
            start.driving_speed_ms = since_ms;
            return Ok(start);
        }
    }
    Err("the vehicle did not move within 500 ticks of the order".into())
}

/// Marks of one node, in simulated ms.
#[derive(Clone, Copy)]
struct Marks {
    truth_ms: f64,
    decision_ms: f64,
    state_ms: f64,
    distance_at_state_m: f64,
    false_claim: bool,
}

/// Steps until the order is done and the vehicle at rest, timing each of
/// `nodes` after the first (id, map x, map y: the map is the estimator's
/// frame here), and the stop's `driving: false`.
fn follow_nodes(sim: &mut Simulation, nodes: &[(&str, f64, f64)], seconds: f64) -> Option<(Vec<NodeReach>, Standing)> {
    let frame = sim.core().estimator().frame().copied()?;
    let stop_at = nodes.len() - 1;
    let mut marks = vec![
        Marks {
            truth_ms: f64::NAN,
            decision_ms: f64::NAN,
            state_ms: f64::NAN,
            distance_at_state_m: f64::NAN,
            false_claim: false,
        };
        nodes.len()
    ];
    let mut was_arrived = sim.core().navigator().arrived();
    let (mut drove, mut rest_ms, mut standing_ms, mut false_standing) = (false, f64::NAN, f64::NAN, 0);
    let end = sim.time() + Duration::from_secs_f64(seconds);
    while sim.time() < end {
        let wall = sim.time();
        let out = sim.step(wall, &mut FrozenTimer);
        out.mavlink.clear();
        let states: Vec<(String, bool)> = out
            .vda5050
            .drain(..)
            .filter_map(|m| match m {
                FleetMessage::State(state) => Some((state.last_node_id, state.driving)),
                _ => None,
            })
            .collect();
        let named: Vec<&String> = states.iter().map(|(id, _)| id).collect();
        let now_ms = sim.time().as_secs_f64() * 1e3;
        let truth = *sim.world().truth();
        let at = crate::tracking::true_local(sim, &frame, truth.north_m, truth.east_m);
        let arrived = sim.core().navigator().arrived();
        // The stop's theta is north: the truth's yaw (clockwise from north).
        let heading_fits = truth.yaw_rad.abs() <= ALLOWED_DEVIATION_THETA_RAD;
        let resting = truth.speed_mps.abs() < RESTING_MPS;
        for i in 1..nodes.len() {
            let (_, x, y) = nodes[i];
            let (dx, dy) = (at.east_m - x, at.north_m - y);
            let within = dx.hypot(dy) <= super::ALLOWED_DEVIATION_M;
            let truly = within && (i + 1 < nodes.len() || heading_fits);
            if truly && marks[i].truth_ms.is_nan() {
                marks[i].truth_ms = now_ms;
            }
            if i == stop_at && within && resting && rest_ms.is_nan() {
                rest_ms = now_ms;
            }
        }
        for &(_, driving) in &states {
            drove |= driving;
            if drove && !driving {
                false_standing += usize::from(!resting);
                if standing_ms.is_nan() && !rest_ms.is_nan() {
                    standing_ms = now_ms;
                }
            }
        }
        // The leg being driven ends at the first node not yet named.
        if let Some(i) = (1..nodes.len()).find(|&i| marks[i].state_ms.is_nan()) {
            let (id, x, y) = nodes[i];
            let m = &mut marks[i];
            if arrived && !was_arrived && m.decision_ms.is_nan() {
                m.decision_ms = now_ms;
            }
            if named.iter().any(|named| *named == id) {
                m.state_ms = now_ms;
                m.distance_at_state_m = (at.east_m - x).hypot(at.north_m - y);
                let faces = i < stop_at || heading_fits;
                m.false_claim = !(m.distance_at_state_m <= super::ALLOWED_DEVIATION_M && faces);
            }
        }
        was_arrived = arrived;
        let done = sim.core().fleet_agent().is_some_and(|a| !a.has_order());
        if done && truth.speed_mps.abs() < 1e-3 && !standing_ms.is_nan() {
            break;
        }
    }
    let reached = marks[1..]
        .iter()
        .enumerate()
        .map(|(k, m)| {
            (!m.state_ms.is_nan()).then(|| NodeReach {
                stops: k + 2 == nodes.len(),
                from_decision_ms: m.state_ms - m.decision_ms,
                from_truth_ms: m.state_ms - m.truth_ms,
                distance_at_state_m: m.distance_at_state_m,
                false_claim: m.false_claim,
            })
        })
        .collect::<Option<Vec<_>>>()?;
    let standing = Standing {
        from_rest_ms: standing_ms - rest_ms,
        false_claims: false_standing,
    };
    Some((reached, standing))
}

fn moves(demand: ActuatorDemand) -> bool {
    match demand {
        ActuatorDemand::Ackermann { throttle, .. } => throttle != 0.0,
        ActuatorDemand::Differential { left, right } => left != 0.0 || right != 0.0,
    }
}

/// Steps `seconds` at rest; the largest true speed seen (m/s).
fn rest(sim: &mut Simulation, seconds: f64) -> f64 {
    let mut floor_mps: f64 = 0.0;
    run_until(sim, seconds, |s| {
        floor_mps = floor_mps.max(s.world().truth().speed_mps.abs());
        false
    });
    floor_mps
}

/// Steps (wall time following simulated time) until `done` or `seconds`.
fn run_until(sim: &mut Simulation, seconds: f64, mut done: impl FnMut(&Simulation) -> bool) -> bool {
    let end = sim.time() + Duration::from_secs_f64(seconds);
    while sim.time() < end {
        let wall = sim.time();
        let out = sim.step(wall, &mut FrozenTimer);
        out.mavlink.clear();
        out.vda5050.clear();
        if done(sim) {
            return true;
        }
    }
    false
}
