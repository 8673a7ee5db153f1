//! Order → truly moving, in-process: one simulated vehicle (the Ackermann
//! car `furrow sitl` runs) is sent orders through its VDA 5050 inputs, and
//! each start is timed in simulated time from the tick the order arrives in
//! (at speedup 1 simulated time is wall time): to the first tick whose
//! drive demand moves (what `driving` reports), to the first `state` that
//! says so, to the wheels turning (the simulator's true speed above
//! 1 mm/s), and to the true speed past 3 cm/s.
//! A real order also waits for the next tick (up to one period) and its
//! MQTT transit: the end-to-end figures above it say what those add.

use std::time::Duration;

use autopilot::fleet::AgentConfig;
use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};
use autopilot::time::FrozenTimer;
use autopilot::vehicle::FleetMessage;
use vehicle_types::ActuatorDemand;

/// The true speed that counts as moving (m/s): `driving`'s threshold.
const MOVING_MPS: f64 = 0.03;
/// The wheels turn (m/s).
const TURNING_MPS: f64 = 0.001;

/// Milliseconds from an order's tick to each mark of its start.
#[derive(Clone, Copy, Debug, Default)]
pub struct Start {
    pub commanded_ms: f64,
    /// The first `state` that says `driving` leaves the core.
    pub state_driving_ms: f64,
    pub turning_ms: f64,
    pub moving_ms: f64,
}

/// `orders` starts, each from rest, each order 12 m north of where the
/// vehicle stands.
pub fn starts(orders: usize) -> Result<Vec<Start>, String> {
    let model = ModelKind::Ackermann;
    let config = SimulationConfig {
        model,
        ..SimulationConfig::default()
    };
    let mut sim = Simulation::new(&config, SimulationParams::new(model));
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
    let mut starts = Vec::new();
    for k in 0..orders {
        // At rest, and the estimate settled.
        run_until(&mut sim, 5.0, |_| false);
        let at = sim.core().estimator().estimate().position;
        let (x, y) = (at.east_m, at.north_m);
        let nodes = [("a", x, y), ("b", x, y + 6.0), ("c", x, y + 12.0)];
        let order = super::order("start", &format!("start-{k}"), &nodes);
        let payload = serde_json::to_vec(&order).map_err(|e| e.to_string())?;
        sim.inputs_mut().vda5050.push((vda5050::Topic::Order, payload));
        starts.push(time_start(&mut sim)?);
        let finished = run_until(&mut sim, 60.0, |s| {
            s.core().fleet_agent().is_some_and(|a| !a.has_order()) && s.world().truth().speed_mps.abs() < 1e-3
        });
        if !finished {
            return Err(format!("order start-{k} did not finish within 60 s"));
        }
    }
    Ok(starts)
}

/// Steps from the tick the order is in until the true speed passes
/// [`MOVING_MPS`].
fn time_start(sim: &mut Simulation) -> Result<Start, String> {
    let mut start = Start {
        state_driving_ms: f64::NAN,
        ..Start::default()
    };
    let (mut commanded, mut turning) = (false, false);
    let mut t0 = None;
    for _ in 0..500 {
        let wall = sim.time();
        let out = sim.step(wall, &mut FrozenTimer);
        out.mavlink.clear();
        let says_driving = out
            .vda5050
            .drain(..)
            .any(|m| matches!(m, FleetMessage::State(state) if state.driving));
        let now_ms = sim.time().as_secs_f64() * 1e3;
        let t0 = *t0.get_or_insert(now_ms);
        let since_ms = now_ms - t0;
        let speed_mps = sim.world().truth().speed_mps.abs();
        if says_driving && start.state_driving_ms.is_nan() {
            start.state_driving_ms = since_ms;
        }
        if !commanded && moves(sim.last_demand()) {
            commanded = true;
            start.commanded_ms = since_ms;
        }
        if !turning && speed_mps > TURNING_MPS {
            turning = true;
            start.turning_ms = since_ms;
        }
        if speed_mps > MOVING_MPS {
            start.moving_ms = since_ms;
            return Ok(start);
        }
    }
    Err("the vehicle did not move within 500 ticks of the order".into())
}

fn moves(demand: ActuatorDemand) -> bool {
    match demand {
        ActuatorDemand::Ackermann { throttle, .. } => throttle != 0.0,
        ActuatorDemand::Differential { left, right } => left != 0.0 || right != 0.0,
    }
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
