//! `furrow-bench obstacles --tick`: what the obstacle pipeline costs the
//! core tick under load. Thirty people walk small loops beside a straight
//! leg (five rows of six, 3–7 m either side of it, all within the scanners'
//! 20 m) while the vehicle drives up the leg in AUTO at 0.5 m/s; both
//! scanners send 361 beams (270° at 0.75°) at 50 Hz. The figure is the
//! scheduler's own tick histogram over the whole run, with how many tracks
//! the core held, sampled every tick, beside it.

use std::time::{Duration, Instant};

use mission::ExecState;
use sim::ObstacleWorld;

use super::classic::person;
use super::drive::{self, Course, Waypoint};
use autopilot::edge::clock::InstantTimer;
use autopilot::obstacles::TrackStatus;

/// Beams per scan asked for: 270° at 0.75°.
const BEAMS: usize = 361;
const STEP_DEG: f64 = 0.75;
/// People beside the leg, and how far either side of it the columns stand.
const ROWS_NORTH_M: [f64; 5] = [4.0, 8.0, 12.0, 16.0, 20.0];
const COLUMNS_EAST_M: [f64; 6] = [-7.0, -5.0, -3.0, 3.0, 5.0, 7.0];
/// Each walks a looped square of this side at this speed.
const LOOP_M: f64 = 0.8;
const WALK_MPS: f64 = 0.5;
/// The leg and its speed.
const LEG_M: f64 = 24.0;
const DRIVE_MPS: f64 = 0.5;

pub fn run(params: &[(String, f64)]) -> Result<(), String> {
    let course = Course {
        waypoints: vec![Waypoint {
            north_m: LEG_M,
            east_m: 0.0,
            reverse: false,
        }],
        speed_mps: DRIVE_MPS,
        params: Vec::new(),
    };
    let mut sim = drive::build_sim(&course, 1, params)?;
    let scanners: Vec<_> = sim
        .world()
        .scanner_configs()
        .map(|c| sim::SimScannerConfig {
            step_rad: STEP_DEG.to_radians(),
            ..c.clone()
        })
        .collect();
    if scanners.len() != 2 || scanners.iter().any(|c| c.beam_count() != BEAMS) {
        return Err(format!("the tick bench needs two scanners of {BEAMS} beams"));
    }
    sim.world_mut().set_scanners(scanners);
    sim.world_mut().set_obstacles(Some(crowd()));
    let start_s = drive::arm(&mut sim);
    let mut timer = InstantTimer::default();
    let wall = Instant::now();
    let (mut ticks, mut tracks, mut confirmed, mut fewest) = (0u64, 0usize, 0usize, usize::MAX);
    let limit_s = start_s + 20.0 + LEG_M / DRIVE_MPS;
    while sim.time().as_secs_f64() < limit_s {
        sim.step(Duration::ZERO, &mut timer).mavlink.clear();
        let held = sim.core().obstacle_tracks();
        let acted_on = held.iter().filter(|t| t.status != TrackStatus::Tentative).count();
        ticks += 1;
        tracks += held.len();
        confirmed += acted_on;
        if sim.time().as_secs_f64() > start_s + 2.0 {
            fewest = fewest.min(acted_on);
        }
        if sim.core().mission_state() == ExecState::Complete {
            break;
        }
    }
    let stats = sim.core().scheduler().tick_stats();
    let us = |ns: u64| ns as f64 / 1000.0;
    println!(
        "Core tick with {} people walking beside the leg, two scanners of {BEAMS} beams at 50 Hz, driving AUTO at {DRIVE_MPS} m/s ({:.0} s simulated, {:.1} s wall):",
        ROWS_NORTH_M.len() * COLUMNS_EAST_M.len(),
        sim.time().as_secs_f64(),
        wall.elapsed().as_secs_f64()
    );
    println!(
        "  tracks held per tick: {:.1} on average ({:.1} confirmed or coasting; at least {} after the first 2 s)",
        tracks as f64 / ticks.max(1) as f64,
        confirmed as f64 / ticks.max(1) as f64,
        if fewest == usize::MAX { 0 } else { fewest }
    );
    println!(
        "  core tick: {} ticks, median {:.2} us, p99 {:.2} us, max {:.1} us (to within 1.6 %)",
        stats.runs,
        us(stats.histogram.quantile_ns(0.5)),
        us(stats.histogram.quantile_ns(0.99)),
        us(stats.histogram.max_ns())
    );
    Ok(())
}

/// Thirty people on small looped squares beside the leg.
fn crowd() -> ObstacleWorld {
    let mut world = ObstacleWorld::default();
    for north_m in ROWS_NORTH_M {
        for east_m in COLUMNS_EAST_M {
            // Away from the leg, so no loop comes nearer it than the column.
            let out = east_m.signum() * LOOP_M;
            let corners = vec![
                [north_m, east_m],
                [north_m + LOOP_M, east_m],
                [north_m + LOOP_M, east_m + out],
                [north_m, east_m + out],
            ];
            let mut walker = person("walker", corners, WALK_MPS, 0.0);
            walker.looped = true;
            world.movers.push(walker);
        }
    }
    world
}
