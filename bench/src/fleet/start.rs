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
//! saying so while the truth still moves is a false claim too. The order
//! is timed end to end, from its tick to that `state`, and where the truth
//! came to rest is measured: its distance from the stop and its heading
//! error, and whether it ever went backwards (a stop overshot and backed
//! up to).
//!
//! Where a stop node's time goes is printed too: the true speed, the
//! estimate's 95 % radius and its true error at the tick the truth comes
//! within the deviation, and how often that radius held the truth while
//! the vehicle moved. The agent names the node once the estimate is within
//! the deviation less the radius, so at roll-in speed v it comes about
//! radius / v after the truth (1.6 cm at 78 cm/s: ~21 ms); ≤ 50 ms with a
//! true 95 % radius needs v ≥ radius / 50 ms there.
//!
//! A real order also waits for the next tick (up to one period) and its
//! MQTT transit: the end-to-end figures above these say what those add.

use std::time::Duration;

use autopilot::fleet::AgentConfig;
use autopilot::geo::Ned;
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
/// An order not done within this long (simulated s) fails the bench.
const ORDER_S: f64 = 60.0;
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
    /// The order's tick, simulated ms since the simulation began.
    pub tick_ms: f64,
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
    /// From the order's tick to that first `state` saying `driving:
    /// false` at rest on the stop: the order end to end (ms).
    pub order_ms: f64,
    /// Where the truth rests at the end: its distance from the stop (m)…
    pub rest_off_m: f64,
    /// …and its heading's from the stop's theta (rad).
    pub rest_yaw_rad: f64,
    /// The fastest the truth went backwards during the order (m/s; 0: it
    /// never backed up).
    pub backwards_mps: f64,
}

/// Where a stop node's time goes: the truth and the estimate at the tick
/// the truth first comes within the stop's deviation (heading too), and
/// when the agent's two tests (position: the estimate's distance plus its
/// 95 % radius; heading: its error plus 1.96 σ) are first met.
#[derive(Clone, Copy, Debug)]
pub struct StopApproach {
    /// The true speed when the truth comes within the deviation (m/s).
    pub speed_at_truth_mps: f64,
    /// The estimate's 95 % radius then (1.731 σ, m)…
    pub bound_at_truth_m: f64,
    /// …and its true error then (m)…
    pub error_at_truth_m: f64,
    /// …of which this far behind the truth on the way to the stop (the
    /// estimate's distance to it less the truth's; negative: ahead) (m).
    pub behind_at_truth_m: f64,
    /// The heading's bound (1.96 σ) then (rad).
    pub yaw_bound_at_truth_rad: f64,
    /// From the truth within to the estimate's position test met (ms).
    pub position_test_ms: f64,
    /// From the truth within to the heading test met (ms).
    pub heading_test_ms: f64,
}

/// How often the estimate's bounds held the truth while it moved (from the
/// order's start to rest on its stop): the bound is honest when it holds
/// about 95 % of ticks.
#[derive(Clone, Debug, Default)]
pub struct Coverage {
    pub ticks: usize,
    /// The true position within the estimate's 95 % radius.
    pub position_held: usize,
    /// The true heading within the estimate's 1.96 σ.
    pub heading_held: usize,
    /// The true error over the radius, each tick: its 95th percentile is
    /// the share of the radius a calibrated 95 % bound would need.
    pub error_over_bound: Vec<f64>,
}

/// What the in-process orders measured.
#[derive(Default)]
pub struct Measured {
    pub starts: Vec<Start>,
    pub nodes: Vec<NodeReach>,
    pub standing: Vec<Standing>,
    pub stop_approaches: Vec<StopApproach>,
    pub coverage: Coverage,
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
        let start = time_start(&mut sim, rest_floor_mps)?;
        measured.starts.push(start);
        let (reached, standing, approach) = follow_nodes(&mut sim, &nodes, start.tick_ms, &mut measured.coverage)
            .ok_or_else(|| format!("order start-{k} did not finish within 60 s"))?;
        measured.nodes.extend(reached);
        measured.standing.push(standing);
        measured.stop_approaches.extend(approach);
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
        start.tick_ms = *t0_ms.get_or_insert(now_ms);
        let since_ms = now_ms - start.tick_ms;
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

impl Marks {
    const UNSEEN: Marks = Marks {
        truth_ms: f64::NAN,
        decision_ms: f64::NAN,
        state_ms: f64::NAN,
        distance_at_state_m: f64::NAN,
        false_claim: false,
    };
}

impl StopApproach {
    /// The first tick each of the agent's two tests passes, `since_ms`
    /// after the truth came within the stop's deviation.
    fn note_tests(&mut self, check: &EstimateCheck, since_ms: f64) {
        if check.position_test && self.position_test_ms.is_nan() {
            self.position_test_ms = since_ms;
        }
        if check.heading_test && self.heading_test_ms.is_nan() {
            self.heading_test_ms = since_ms;
        }
    }
}

/// Steps until the order (in the tick at `order_tick_ms`) is done and the
/// vehicle at rest, at most [`ORDER_S`], timing each of `nodes` after the
/// first (id, map x, map y: the map is the estimator's frame here), and the
/// stop's `driving: false`.
fn follow_nodes(
    sim: &mut Simulation,
    nodes: &[(&str, f64, f64)],
    order_tick_ms: f64,
    coverage: &mut Coverage,
) -> Option<(Vec<NodeReach>, Standing, Option<StopApproach>)> {
    let frame = sim.core().estimator().frame().copied()?;
    let stop_at = nodes.len() - 1;
    let mut marks = vec![Marks::UNSEEN; nodes.len()];
    let mut was_arrived = sim.core().navigator().arrived();
    let mut approach: Option<StopApproach> = None;
    let (mut drove, mut rest_ms, mut standing_ms, mut false_standing) = (false, f64::NAN, f64::NAN, 0);
    let (mut rest_off_m, mut rest_yaw_rad, mut backwards_mps) = (f64::NAN, f64::NAN, 0f64);
    let end = sim.time() + Duration::from_secs_f64(ORDER_S);
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
        let (_, stop_x, stop_y) = nodes[stop_at];
        rest_off_m = (at.east_m - stop_x).hypot(at.north_m - stop_y);
        rest_yaw_rad = truth.yaw_rad.abs();
        backwards_mps = backwards_mps.max(-truth.speed_mps);
        let check = EstimateCheck::of(sim, at, truth.yaw_rad, (stop_x, stop_y));
        if rest_ms.is_nan() && !resting {
            check.count(coverage);
        }
        if let Some(a) = approach.as_mut() {
            a.note_tests(&check, now_ms - marks[stop_at].truth_ms);
        }
        let truth_now = TruthNow {
            at,
            heading_fits,
            resting,
            now_ms,
        };
        if mark_truth(&mut marks, nodes, &truth_now, &mut rest_ms) {
            approach = Some(check.approach(truth.speed_mps.abs()));
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
        mark_named(&mut marks, nodes, &named, arrived && !was_arrived, &truth_now);
        was_arrived = arrived;
        let done = sim.core().fleet_agent().is_some_and(|a| !a.has_order());
        if done && truth.speed_mps.abs() < 1e-3 && !standing_ms.is_nan() {
            break;
        }
    }
    let reached = reaches(&marks)?;
    let standing = Standing {
        from_rest_ms: standing_ms - rest_ms,
        false_claims: false_standing,
        order_ms: standing_ms - order_tick_ms,
        rest_off_m,
        rest_yaw_rad,
        backwards_mps,
    };
    Some((reached, standing, approach))
}

/// Each node after the first as its marks time it (the last one stops);
/// `None` if one was never named.
fn reaches(marks: &[Marks]) -> Option<Vec<NodeReach>> {
    marks[1..]
        .iter()
        .enumerate()
        .map(|(k, m)| {
            (!m.state_ms.is_nan()).then(|| NodeReach {
                stops: k + 2 == marks.len(),
                from_decision_ms: m.state_ms - m.decision_ms,
                from_truth_ms: m.state_ms - m.truth_ms,
                distance_at_state_m: m.distance_at_state_m,
                false_claim: m.false_claim,
            })
        })
        .collect()
}

/// The truth on one tick, as the node marks need it.
struct TruthNow {
    at: Ned,
    /// Facing the stop node's theta within its deviation.
    heading_fits: bool,
    resting: bool,
    now_ms: f64,
}

/// Marks each node the truth comes within its deviation of (the last, the
/// stop, also with the heading) and the truth's rest on the stop; true when
/// the stop is first truly reached on this tick.
fn mark_truth(marks: &mut [Marks], nodes: &[(&str, f64, f64)], truth: &TruthNow, rest_ms: &mut f64) -> bool {
    let stop_at = nodes.len() - 1;
    let mut stop_reached = false;
    for i in 1..nodes.len() {
        let (_, x, y) = nodes[i];
        let (dx, dy) = (truth.at.east_m - x, truth.at.north_m - y);
        let within = dx.hypot(dy) <= super::ALLOWED_DEVIATION_M;
        let truly = within && (i < stop_at || truth.heading_fits);
        if truly && marks[i].truth_ms.is_nan() {
            marks[i].truth_ms = truth.now_ms;
            stop_reached |= i == stop_at;
        }
        if i == stop_at && within && truth.resting && rest_ms.is_nan() {
            *rest_ms = truth.now_ms;
        }
    }
    stop_reached
}

/// Marks the node at the end of the leg being driven (the first not yet
/// named): the navigator's arrival, and the state that names it with how
/// far the truth was from it then.
fn mark_named(marks: &mut [Marks], nodes: &[(&str, f64, f64)], named: &[&String], arrived_now: bool, truth: &TruthNow) {
    let stop_at = nodes.len() - 1;
    let Some(i) = (1..nodes.len()).find(|&i| marks[i].state_ms.is_nan()) else {
        return;
    };
    let (id, x, y) = nodes[i];
    let m = &mut marks[i];
    if arrived_now && m.decision_ms.is_nan() {
        m.decision_ms = truth.now_ms;
    }
    if named.iter().any(|named| *named == id) {
        m.state_ms = truth.now_ms;
        m.distance_at_state_m = (truth.at.east_m - x).hypot(truth.at.north_m - y);
        let faces = i < stop_at || truth.heading_fits;
        m.false_claim = !(m.distance_at_state_m <= super::ALLOWED_DEVIATION_M && faces);
    }
}

/// The estimate against the truth this tick, and the agent's two tests of
/// the stop node as the estimate stands.
struct EstimateCheck {
    error_m: f64,
    behind_m: f64,
    bound_m: f64,
    yaw_error_rad: f64,
    yaw_bound_rad: f64,
    position_test: bool,
    heading_test: bool,
}

impl EstimateCheck {
    /// `at`: the truth in the estimator's frame; `true_yaw_rad` clockwise
    /// from north, as the estimate's; `stop`: the stop node (east, north),
    /// whose theta is north.
    fn of(sim: &Simulation, at: autopilot::geo::Ned, true_yaw_rad: f64, stop: (f64, f64)) -> EstimateCheck {
        let estimate = sim.core().estimator().estimate();
        let p = estimate.position;
        let bound_m = 1.731 * estimate.horiz_sigma_m;
        let yaw_sigma_rad = sim
            .core()
            .estimator()
            .ekf_status()
            .map_or(f64::INFINITY, |s| s.heading_sigma_rad);
        let yaw_bound_rad = 1.96 * yaw_sigma_rad;
        let distance_m = (p.east_m - stop.0).hypot(p.north_m - stop.1);
        let true_distance_m = (at.east_m - stop.0).hypot(at.north_m - stop.1);
        EstimateCheck {
            error_m: (p.east_m - at.east_m).hypot(p.north_m - at.north_m),
            behind_m: distance_m - true_distance_m,
            bound_m,
            yaw_error_rad: autopilot::geo::wrap_pi(estimate.yaw_rad - true_yaw_rad).abs(),
            yaw_bound_rad,
            position_test: distance_m + bound_m <= super::ALLOWED_DEVIATION_M,
            heading_test: autopilot::geo::wrap_pi(estimate.yaw_rad).abs() + yaw_bound_rad
                <= ALLOWED_DEVIATION_THETA_RAD,
        }
    }

    fn count(&self, coverage: &mut Coverage) {
        coverage.ticks += 1;
        coverage.position_held += usize::from(self.error_m <= self.bound_m);
        coverage.heading_held += usize::from(self.yaw_error_rad <= self.yaw_bound_rad);
        coverage.error_over_bound.push(self.error_m / self.bound_m);
    }

    fn approach(&self, speed_mps: f64) -> StopApproach {
        StopApproach {
            speed_at_truth_mps: speed_mps,
            bound_at_truth_m: self.bound_m,
            error_at_truth_m: self.error_m,
            behind_at_truth_m: self.behind_m,
            yaw_bound_at_truth_rad: self.yaw_bound_rad,
            position_test_ms: if self.position_test { 0.0 } else { f64::NAN },
            heading_test_ms: if self.heading_test { 0.0 } else { f64::NAN },
        }
    }
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
