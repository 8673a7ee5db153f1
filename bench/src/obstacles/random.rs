//! The randomized generator: random courses of legs and arcs and random
//! people with random start times, speeds and headings, each run
//! reproducible from its seed (ChaCha8). Seeds share a course in groups of
//! [`RUNS_PER_COURSE`] (one empty run serves them all); `--replay SEED`
//! runs one again with its events.
//!
//! A run's timing is **feasible** when a vehicle with this plant could
//! have stopped for everyone, judged from the truth on the course (the
//! run without people) and nothing of Furrow's: for each person whose
//! true shape the course's outline would touch while moving, braking as
//! hard as the plant can (see [`super::plant`]) from the instant they could
//! first be known (the later of when they began the straight line they
//! touch from and when a scanner's beam first reached them unoccluded, see
//! [`super::unavoidable`]) must come to rest without touching them. A
//! person the course never touches needs nothing. Otherwise (someone
//! stepping out closer than the plant's braking) the timing is
//! **infeasible**, and the run is counted apart.

use std::f64::consts::{PI, TAU};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim::{MovingObstacle, Shape, SimScannerConfig, VehicleOutline};

use super::classic::{PERSON_RADIUS_M, person};
use super::drive::{Course, Setup, Waypoint};
use super::families::tightest_turn_m;
use super::truth::{Limits, MOVING_MPS, TruthLog, rectangle};
use super::unavoidable::{ObjectId, RunTruth, WorldHistory};

/// Consecutive seeds that share one course.
pub const RUNS_PER_COURSE: u64 = 10;

/// The course of run `seed`.
pub fn course_of(seed: u64) -> u64 {
    (seed.max(1) - 1) / RUNS_PER_COURSE
}

/// A random course: 2–3 legs of 8–18 m from home, turning 30–110° either
/// way, with arcs of 6–15 m, at 1–2 m/s, one in five in reverse.
pub fn course(course_seed: u64) -> Course {
    let mut rng = ChaCha8Rng::seed_from_u64(0x00C0_55E5 ^ course_seed);
    let reverse = rng.random_bool(0.2);
    let legs = rng.random_range(2..=3);
    let mut bearing_rad: f64 = if reverse { PI } else { 0.0 };
    let mut at = [0.0, 0.0];
    let mut waypoints = Vec::new();
    for leg in 0..legs {
        if leg > 0 {
            let turn_rad = rng.random_range(30.0_f64..110.0).to_radians();
            bearing_rad += if rng.random_bool(0.5) { turn_rad } else { -turn_rad };
        }
        let length_m = rng.random_range(8.0..18.0);
        at = [
            at[0] + length_m * bearing_rad.cos(),
            at[1] + length_m * bearing_rad.sin(),
        ];
        waypoints.push(Waypoint {
            north_m: at[0],
            east_m: at[1],
            reverse,
        });
    }
    let radius_m = rng.random_range(6.0..15.0);
    Course {
        waypoints,
        speed_mps: rng.random_range(1.0..2.0),
        params: vec![(
            "WP_ARC_MARGIN".to_string(),
            (radius_m / tightest_turn_m()).clamp(1.0, 5.0),
        )],
    }
}

/// The people of run `seed` on its course (the empty run's `log`).
pub fn people(seed: u64, log: &TruthLog, outline: &VehicleOutline) -> Setup {
    let mut rng = ChaCha8Rng::seed_from_u64(0x009E_091E ^ seed);
    let moving: Vec<usize> = (0..log.poses.len())
        .filter(|&i| log.poses[i].speed_mps.abs() > 0.3)
        .collect();
    let mut setup = Setup::default();
    if moving.len() < 100 {
        return setup;
    }
    let home = rectangle(outline, &log.poses[0]);
    let count = rng.random_range(1..=3);
    while setup.world.movers.len() < count {
        // Aim at a point near where the vehicle will be, some time after
        // the start.
        let pose = log.poses[moving[rng.random_range(50..moving.len())]];
        let aim = [
            pose.north_m + rng.random_range(-3.0..3.0),
            pose.east_m + rng.random_range(-4.0..4.0),
        ];
        let heading_rad = rng.random_range(0.0..TAU);
        let dir = [heading_rad.cos(), heading_rad.sin()];
        let arrive_s = pose.t_s + rng.random_range(-3.0..3.0);
        let mover = if rng.random_bool(0.25) {
            // Stands at the aim from the start and walks off after a while.
            let leave_s = arrive_s + rng.random_range(0.0..30.0);
            let away = [aim[0] + dir[0] * 8.0, aim[1] + dir[1] * 8.0];
            vanishing(person("person", vec![aim, away], 1.0, leave_s.max(0.0)))
        } else {
            let speed_mps = rng.random_range(0.3..2.0);
            let lead_s = rng.random_range(0.5..10.0);
            let lead_m = speed_mps * lead_s;
            let from = [aim[0] - dir[0] * lead_m, aim[1] - dir[1] * lead_m];
            let to = [aim[0] + dir[0] * 15.0, aim[1] + dir[1] * 15.0];
            vanishing(person("person", vec![from, to], speed_mps, arrive_s - lead_s))
        };
        // Nobody starts under or against the vehicle at home.
        let start = Shape::Circle {
            center: mover.path[0],
            radius_m: PERSON_RADIUS_M,
        };
        if start.distance_to_rectangle_m(&home) < 1.0 {
            continue;
        }
        setup.world.movers.push(mover);
    }
    setup
}

/// Whether a vehicle with this plant and these scanners could have stopped
/// for everyone of `setup` its course touches (see the module header).
pub fn feasible(
    setup: &Setup,
    log: &TruthLog,
    scanners: &[SimScannerConfig],
    limits: &Limits,
    outline: VehicleOutline,
) -> bool {
    let history = WorldHistory::new(setup.world.clone());
    let course = RunTruth {
        poses: &log.poses,
        history: &history,
        scanners,
        outline,
        plant: limits.plant,
    };
    (0..setup.world.movers.len()).all(|i| {
        let person = ObjectId::Mover(i);
        first_touch_s(log, &history, &outline, person).is_none_or(|t_s| course.unavoidable(person, t_s).is_none())
    })
}

/// When the course's outline, while moving, first touches `object`.
fn first_touch_s(log: &TruthLog, history: &WorldHistory, outline: &VehicleOutline, object: ObjectId) -> Option<f64> {
    log.poses
        .iter()
        .filter(|p| p.speed_mps.abs() > MOVING_MPS)
        .find(|p| {
            object
                .shape_at(history, p.t_s)
                .is_some_and(|s| s.distance_to_rectangle_m(&rectangle(outline, p)) <= 0.0)
        })
        .map(|p| p.t_s)
}

/// Walks off the scanners' world at the end of its path (nobody stays on
/// the course for good).
fn vanishing(mut mover: MovingObstacle) -> MovingObstacle {
    mover.vanish_at_end = true;
    mover
}

/// A randomized run's figures.
#[derive(Clone, Debug)]
pub struct RandomOutcome {
    pub seed: u64,
    pub feasible: bool,
    pub result: super::drive::RunResult,
}

/// Runs seed `seed`, against `log` when its course's empty run is at hand.
pub fn run(seed: u64, params: &[(String, f64)], log: Option<&TruthLog>) -> Result<RandomOutcome, String> {
    let course = course(course_of(seed));
    let course_seed = course_of(seed) + 1;
    let own;
    let log = match log {
        Some(log) => log,
        None => {
            own = super::drive::drive_empty(&course, course_seed, params)?;
            &own
        }
    };
    let sim = super::drive::build_sim(&course, course_seed, params)?;
    let (outline, limits) = super::drive::outline_and_limits(&sim);
    let scanners: Vec<SimScannerConfig> = sim.world().scanner_configs().cloned().collect();
    drop(sim);
    let setup = people(seed, log, &outline);
    let feasible = feasible(&setup, log, &scanners, &limits, outline);
    let result = super::drive::drive_with(&course, course_seed, params, &setup, log)?;
    Ok(RandomOutcome { seed, feasible, result })
}

/// Seeds `seeds`, a course (its empty run, then its runs) per job.
pub fn run_many(
    seeds: std::ops::RangeInclusive<u64>,
    params: &[(String, f64)],
    threads: usize,
) -> Result<Vec<RandomOutcome>, String> {
    let (from, to) = (*seeds.start(), *seeds.end());
    let courses: Vec<u64> = (course_of(from)..=course_of(to)).collect();
    let per_course = super::par_map(&courses, threads, |&c| -> Result<Vec<RandomOutcome>, String> {
        let first = (c * RUNS_PER_COURSE + 1).max(from);
        let last = ((c + 1) * RUNS_PER_COURSE).min(to);
        let log = super::drive::drive_empty(&course(c), c + 1, params)?;
        (first..=last).map(|seed| run(seed, params, Some(&log))).collect()
    });
    let mut all = Vec::new();
    for outcomes in per_course {
        all.extend(outcomes?);
    }
    Ok(all)
}

/// `--replay SEED`: the course, the people and every event of one run.
/// With `trace`, the true pose and clearance every 0.2 s as well.
pub fn replay(seed: u64, params: &[(String, f64)], trace: bool) -> Result<(), String> {
    let c = course(course_of(seed));
    println!("# furrow-bench obstacles --replay {seed}");
    println!();
    println!(
        "course {} (seed {}): {:.2} m/s, {}, waypoints {:?}",
        course_of(seed),
        course_of(seed) + 1,
        c.speed_mps,
        c.params
            .iter()
            .map(|(n, v)| format!("{n} {v:.3}"))
            .collect::<Vec<_>>()
            .join(", "),
        c.waypoints
            .iter()
            .map(|w| format!(
                "({:.1}, {:.1}{})",
                w.north_m,
                w.east_m,
                if w.reverse { " R" } else { "" }
            ))
            .collect::<Vec<_>>()
    );
    let log = super::drive::drive_empty(&c, course_of(seed) + 1, params)?;
    let sim = super::drive::build_sim(&c, course_of(seed) + 1, params)?;
    let (outline, limits) = super::drive::outline_and_limits(&sim);
    let scanners: Vec<SimScannerConfig> = sim.world().scanner_configs().cloned().collect();
    let mut setup = people(seed, &log, &outline);
    let feasible = feasible(&setup, &log, &scanners, &limits, outline);
    for m in &setup.world.movers {
        println!(
            "person: path {:?} at {:.2} m/s from t {:.2} s",
            m.path
                .iter()
                .map(|p| format!("({:.2}, {:.2})", p[0], p[1]))
                .collect::<Vec<_>>(),
            m.speed_mps,
            m.start_s
        );
    }
    println!("timing {}", if feasible { "feasible" } else { "infeasible" });
    setup.trace = trace;
    let r = super::drive::drive_with(&c, course_of(seed) + 1, params, &setup, &log)?;
    for event in &r.events {
        println!("{event}");
    }
    println!(
        "completed {:?} s (empty {:?} s), collisions {} ({} unavoidable), stops {}, false stops {}, stalls {}, min clearance {:.3} m",
        r.completion_s,
        log.completion_s,
        r.collisions,
        r.unavoidable,
        r.stops,
        r.false_stops,
        r.stalls,
        r.min_clearance_m
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::obstacles::plant::PlantBraking;
    use crate::obstacles::truth::tests::straight;
    use crate::obstacles::unavoidable::tests::walker;

    fn label(world: sim::ObstacleWorld) -> bool {
        let log = TruthLog {
            poses: straight(2.0, 20.0),
            completion_s: Some(20.0),
        };
        let setup = Setup {
            world,
            ..Setup::default()
        };
        let limits = Limits {
            margin_m: 0.3,
            horizon_s: 3.0,
            plant: PlantBraking {
                tau_s: 0.3,
                brake_max_mps2: 2.0,
            },
        };
        feasible(
            &setup,
            &log,
            &[SimScannerConfig::default()],
            &limits,
            VehicleOutline::default(),
        )
    }

    // The course drives north at 2 m/s; the walkers reach its lane beside
    // the front at 5.1 s.
    #[test]
    fn someone_stepping_out_closer_than_the_plant_brakes_is_infeasible() {
        assert!(!label(walker(4.6, 13.6, 2.0)));
    }

    #[test]
    fn someone_walking_in_from_afar_is_feasible() {
        assert!(label(walker(0.6, 13.6, 8.0)));
    }

    #[test]
    fn someone_the_course_never_touches_needs_nothing() {
        // Crossing 3 s after the vehicle has passed.
        assert!(label(walker(7.5, 13.6, 2.0)));
    }
}
