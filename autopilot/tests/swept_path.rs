//! Swept-path protection in the running core: a person inside a turn, a
//! box beside the lane, and the tick's cost with a crowd of tracks.

mod common;

use std::time::Duration;

use autopilot::sitl::gcs;
use autopilot::sitl::runner::InstantTimer;
use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};
use drivers::sim::{MovingObstacle, ObstacleWorld, Shape};

/// 30 people around a 40 m square, half of them walking, two 361-beam scans
/// (270° at 0.75°): the tick's median and p99, printed for the report.
#[test]
#[ignore = "a measurement: run with --ignored --nocapture"]
fn tick_cost_with_thirty_tracks() {
    let config = SimulationConfig {
        model: ModelKind::Ackermann,
        ..SimulationConfig::default()
    };
    let mut params = SimulationParams::new(config.model);
    params
        .apply(&[("SIM_SCAN_STEP".to_string(), 0.75), ("SIM_SCAN_FOV".to_string(), 270.0)])
        .expect("scan parameters");
    let mut sim = Simulation::new(&config, params);
    let mut statics = Vec::new();
    let mut movers = Vec::new();
    for i in 0..30 {
        let along = 4.0 + 2.4 * f64::from(i % 15);
        let side = if i < 15 { 4.5 } else { -4.5 };
        let center = [along, side];
        let shape = Shape::Circle { center, radius_m: 0.25 };
        if i % 2 == 0 {
            statics.push(shape);
        } else {
            movers.push(MovingObstacle {
                name: format!("walker{i}"),
                shape,
                path: vec![center, [along, side * 1.6]],
                speed_mps: 0.6,
                start_s: 0.0,
                looped: true,
                vanish_at_end: false,
            });
        }
    }
    sim.world_mut().set_obstacles(Some(ObstacleWorld::new(statics, movers)));
    gcs::connect(&mut sim);
    let mut timer = InstantTimer::default();
    while sim.time().as_secs_f64() < 3.0 {
        sim.step(Duration::ZERO, &mut timer).mavlink.clear();
    }
    gcs::send(&mut sim, gcs::set_mode(15));
    gcs::send(&mut sim, gcs::arm());
    let corners = [(40.0, 0.0), (40.0, 40.0), (0.0, 40.0), (0.0, 0.0)];
    let mut corner = 0;
    let mut max_tracks = 0;
    let mut sent = false;
    while sim.time().as_secs_f64() < 120.0 {
        if !sent || sim.core().navigator().arrived() {
            let (n, e) = corners[corner % corners.len()];
            let target = gcs::local_target(&sim, n, e);
            gcs::send(&mut sim, target);
            corner += 1;
            sent = true;
        }
        sim.step(Duration::ZERO, &mut timer).mavlink.clear();
        max_tracks = max_tracks.max(sim.core().obstacle_tracks().len());
    }
    let ticks = sim.core().scheduler().tick_stats();
    println!(
        "tick with {max_tracks} tracks (max seen), two 361-beam scans: {} ticks, median {:.2} us, p99 {:.2} us",
        ticks.runs,
        ticks.histogram.quantile_ns(0.5) as f64 / 1000.0,
        ticks.histogram.quantile_ns(0.99) as f64 / 1000.0,
    );
}
