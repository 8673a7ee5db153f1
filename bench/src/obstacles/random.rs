//! The randomized generator: random courses of legs and arcs and random
//! people with random start times, speeds and headings, each run
//! reproducible from its seed (ChaCha8). Seeds share a course in groups of
//! [`RUNS_PER_COURSE`] (one empty run serves them all); `--replay SEED`
//! runs one again with its events.
//!
//! A person's timing is **feasible** when it walks its straight line for
//! at least the vehicle's stopping time plus 1 s before reaching the point
//! it aims at (or stands there from the start): a vehicle that sees it can
//! stop. Shorter leads (someone stepping out at the last moment) are
//! **infeasible**; their runs are counted apart.

use std::f64::consts::{PI, TAU};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim::{MovingObstacle, Shape, VehicleOutline};

use super::classic::{PERSON_RADIUS_M, person};
use super::drive::{Course, Setup, Waypoint};
use super::families::tightest_turn_m;
use super::truth::{Limits, TruthLog, rectangle};

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

/// The people of run `seed` on its course (the empty run's `log`), and
/// whether every one's timing is feasible.
pub fn people(seed: u64, log: &TruthLog, outline: &VehicleOutline, limits: &Limits) -> (Setup, bool) {
    let mut rng = ChaCha8Rng::seed_from_u64(0x009E_091E ^ seed);
    let moving: Vec<usize> = (0..log.poses.len())
        .filter(|&i| log.poses[i].speed_mps.abs() > 0.3)
        .collect();
    let mut setup = Setup::default();
    let mut feasible = true;
    if moving.len() < 100 {
        return (setup, feasible);
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
            let v = pose.speed_mps.abs();
            let stopping_s = limits.reaction_s + v / limits.decel_mps2;
            feasible &= lead_s >= stopping_s + 1.0;
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
    (setup, feasible)
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
    drop(sim);
    let (setup, feasible) = people(seed, log, &outline, &limits);
    let result = super::drive::drive_with(&course, course_seed, params, &setup, log)?;
    Ok(RandomOutcome { seed, feasible, result })
}

/// Seeds 1..=`runs`, a course (its empty run, then its runs) per job.
pub fn run_many(runs: u64, params: &[(String, f64)], threads: usize) -> Result<Vec<RandomOutcome>, String> {
    let courses: Vec<u64> = (0..=course_of(runs)).collect();
    let per_course = super::par_map(&courses, threads, |&c| -> Result<Vec<RandomOutcome>, String> {
        let first = c * RUNS_PER_COURSE + 1;
        let last = (first + RUNS_PER_COURSE - 1).min(runs);
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
    let (mut setup, feasible) = people(seed, &log, &outline, &limits);
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
