//! `furrow-bench obstacles`: obstacle scenarios driven in AUTO in-process at
//! full speed (world with its obstacles, simulated scanners speaking CoLa-A
//! to the real parser, the whole core), judged from the simulator's truth
//! and the world alone, never from Furrow's own figures:
//!
//! - the scenarios of docs/architecture.md §Obstacles on a straight leg ([`classic`]);
//! - the scenario families in turns, S-bends and beside lanes, forwards
//!   and in reverse, left and right ([`families`]);
//! - thousands of randomized runs ([`random`]), each replayable by its seed.
//!
//! Definitions (the code is in [`truth`]): a **collision** is an episode of
//! the vehicle's outline (the `VEH_LEN_*`/`VEH_WIDTH` rectangle at the true
//! pose) and an object's true shape overlapping while the vehicle moves; a
//! collision is **unavoidable** only if, replayed with the vehicle braking
//! as hard as the simulated plant can (its 2 m/s² limit through the drive's
//! 0.3 s lag, from a zero command at once; see [`plant`]) from the first
//! instant the object could be known (the later of when it began the
//! straight line it hit from and when a scanner's beam first reached it),
//! along the path it drove, it would still have touched the object (the
//! code is in [`unavoidable`]); a
//! **false stop** is an obstacle stop decided when no object's true shape,
//! moved in a straight line at its true velocity for up to `OA_HORIZON`,
//! comes within `OA_MARGIN` of the outline swept along the course the
//! vehicle was going to drive (the same run without obstacles, from the
//! true pose onward, for the plant's true stopping distance plus the
//! horizon's travel; Furrow's `OA_REACT_TIME` and `OA_DECEL` play no part);
//! a **stall** is more than 30 s at rest, mission unfinished, with the way
//! clear by that same test. There is no other allowance than 5 mm of
//! numerical tolerance on the margin (see [`truth::ON_THE_MARGIN_M`]). Min clearance is
//! the smallest gap while moving; time lost is against the run without
//! obstacles (same course, same seed).

mod classic;
mod drive;
pub mod families;
mod plant;
pub mod random;
mod report;
mod situation;
mod tick;
mod truth;
mod unavoidable;

use std::collections::HashMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

pub use classic::Classic;
pub use drive::{Course, ROOM_CLEARANCE_M, RunResult, Setup};
pub use families::{Family, Lane, Variant};
pub use truth::TruthLog;

use autopilot::sitl::simulation::{ModelKind, SimulationParams};

#[derive(clap::Args, Debug)]
pub struct ObstacleBenchArgs {
    /// Seeds 1..=N for every scenario, speed and variant.
    #[arg(long, default_value_t = 2)]
    pub seeds: u64,
    /// Only the scenarios whose name contains this.
    #[arg(long)]
    pub only: Option<String>,
    /// Vehicle speeds to run each scenario at, m/s.
    #[arg(long = "speed", default_values_t = vec![1.0, 2.0])]
    pub speeds: Vec<f64>,
    /// Randomized runs (seeds 1..=N); 0 for none.
    #[arg(long, default_value_t = 5000)]
    pub random: u64,
    /// The first randomized seed (with `--random N`: seeds FIRST..=N), to
    /// run again only the seeds of interest.
    #[arg(long, default_value_t = 1)]
    pub random_from: u64,
    /// Run randomized seed SEED alone and print what happened (with
    /// `--verbose`, the true pose every 0.2 s too).
    #[arg(long)]
    pub replay: Option<u64>,
    /// Worker threads (default: the machine's cores).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Run with a parameter changed, NAME=VALUE (repeatable).
    #[arg(long = "param", value_parser = super::tracking::parse_param)]
    pub params: Vec<(String, f64)>,
    /// Print every run, not only the per-scenario summary.
    #[arg(long)]
    pub verbose: bool,
    /// Print the true pose, the people and the tracks every 0.2 s of every
    /// scenario run (with `--only` and `--jobs 1`, to follow one family).
    #[arg(long)]
    pub trace: bool,
    /// Only measure the core tick with 30 people tracked and two 361-beam scanners.
    #[arg(long)]
    pub tick: bool,
}

/// A scenario of the tables.
#[derive(Clone, Debug)]
pub enum Scenario {
    Classic { name: String, kind: Classic },
    Family(Family),
}

impl Scenario {
    pub fn name(&self) -> String {
        match self {
            Scenario::Classic { name, .. } => name.clone(),
            Scenario::Family(f) => f.name(),
        }
    }
}

/// One run of a scenario.
#[derive(Clone, Debug)]
pub struct Job {
    pub row: usize,
    pub course: Course,
    pub variant: Variant,
    /// Print the run as it goes (`--trace`).
    pub trace: bool,
}

/// A run's figures and how it was driven.
#[derive(Clone, Debug)]
pub struct Outcome {
    pub row: usize,
    pub variant: Variant,
    pub result: RunResult,
}

/// Runs `f` over `items` on `jobs` threads; results in order.
pub fn par_map<T: Sync, R: Send>(items: &[T], jobs: usize, f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<R>>> = Mutex::new((0..items.len()).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..jobs.max(1) {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(item) = items.get(i) else { break };
                    let r = f(item);
                    results.lock().unwrap_or_else(|e| e.into_inner())[i] = Some(r);
                }
            });
        }
    });
    results
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .into_iter()
        .map(|r| r.expect("every item is mapped"))
        .collect()
}

/// Runs every job of `scenarios`: the empty run of each distinct course
/// and seed once, then each job against it.
pub fn run_scenarios(
    scenarios: &[Scenario],
    jobs: &[Job],
    params: &[(String, f64)],
    threads: usize,
) -> Result<Vec<Outcome>, String> {
    let mut keys: Vec<(Course, u64)> = Vec::new();
    let mut index: HashMap<String, usize> = HashMap::new();
    for job in jobs {
        let key = format!("{:?} {}", job.course, job.variant.seed);
        index.entry(key).or_insert_with(|| {
            keys.push((job.course.clone(), job.variant.seed));
            keys.len() - 1
        });
    }
    let logs = par_map(&keys, threads, |(course, seed)| {
        drive::drive_empty(course, *seed, params)
    });
    let logs: Vec<TruthLog> = logs.into_iter().collect::<Result<_, _>>()?;
    let outcomes = par_map(jobs, threads, |job| {
        let key = format!("{:?} {}", job.course, job.variant.seed);
        let log = &logs[index[&key]];
        run_job(&scenarios[job.row], job, log, params).map(|result| Outcome {
            row: job.row,
            variant: job.variant,
            result,
        })
    });
    outcomes.into_iter().collect()
}

/// One job against its course's empty run.
pub fn run_job(scenario: &Scenario, job: &Job, log: &TruthLog, params: &[(String, f64)]) -> Result<RunResult, String> {
    let sim = drive::build_sim(&job.course, job.variant.seed, params)?;
    let (outline, _) = drive::outline_and_limits(&sim);
    drop(sim);
    let mut setup = match scenario {
        Scenario::Classic { kind, .. } => kind.setup(log, &outline),
        Scenario::Family(family) => family
            .setup(log, &outline, &job.variant)
            .map_err(|e| format!("{} {}: {e}", family.name(), job.variant.label()))?,
    };
    if job.trace {
        println!("## {} {}", scenario.name(), job.variant.label());
        setup.trace = true;
    }
    drive::drive_with(&job.course, job.variant.seed, params, &setup, log)
}

/// The scenarios (classic first, then the families) whose name contains
/// `only`.
pub fn scenarios(only: Option<&str>) -> Vec<Scenario> {
    let classic = Classic::all()
        .into_iter()
        .map(|(name, kind)| Scenario::Classic { name, kind });
    let families = Family::all().into_iter().map(Scenario::Family);
    classic
        .chain(families)
        .filter(|s| only.is_none_or(|o| s.name().contains(o)))
        .collect()
}

/// Every run of `scenarios`: classic ones at each speed and seed; families
/// forwards and in reverse, left and right, at each speed and seed.
pub fn jobs(scenarios: &[Scenario], speeds: &[f64], seeds: u64) -> Vec<Job> {
    let mut jobs = Vec::new();
    for (row, scenario) in scenarios.iter().enumerate() {
        for &speed_mps in speeds {
            for seed in 1..=seeds {
                match scenario {
                    Scenario::Classic { kind, .. } => jobs.push(Job {
                        row,
                        course: kind.course(speed_mps),
                        variant: Variant {
                            reverse: false,
                            right: false,
                            speed_mps,
                            seed,
                        },
                        trace: false,
                    }),
                    Scenario::Family(family) => {
                        for reverse in [false, true] {
                            for right in [false, true] {
                                let variant = Variant {
                                    reverse,
                                    right,
                                    speed_mps,
                                    seed,
                                };
                                jobs.push(Job {
                                    row,
                                    course: families::course(family.lane(), &variant),
                                    variant,
                                    trace: false,
                                });
                            }
                        }
                    }
                }
            }
        }
    }
    jobs
}

pub fn run(args: &ObstacleBenchArgs) -> Result<(), String> {
    if args.tick {
        return tick::run(&args.params);
    }
    if args.seeds == 0 && args.random == 0 && args.replay.is_none() {
        return Err("nothing to run: --seeds and --random are both 0".into());
    }
    if args.speeds.iter().any(|s| !(s.is_finite() && *s > 0.0 && *s <= 5.0)) {
        return Err("--speed must be in (0, 5] m/s".into());
    }
    // Parameters are checked once before hours of runs.
    SimulationParams::new(ModelKind::Ackermann).apply(&args.params)?;
    let threads = args
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from));
    if let Some(seed) = args.replay {
        return random::replay(seed, &args.params, args.verbose);
    }
    println!("# furrow-bench obstacles");
    println!();
    let wall = Instant::now();
    if args.seeds > 0 {
        let scenarios = scenarios(args.only.as_deref());
        if scenarios.is_empty() {
            return Err("--only matches no scenario".into());
        }
        let mut jobs = jobs(&scenarios, &args.speeds, args.seeds);
        for job in &mut jobs {
            job.trace = args.trace;
        }
        println!(
            "{} scenarios, {} runs (families forwards and reverse, left and right) × speeds {:?} m/s × {} seeds; Ackermann AGV 4.4 × 2.0 m, scanners front and rear (LMS1xx-like, 50 Hz, 0.5°, 270°); {threads} threads.",
            scenarios.len(),
            jobs.len(),
            args.speeds,
            args.seeds
        );
        println!();
        let outcomes = run_scenarios(&scenarios, &jobs, &args.params, threads)?;
        report::scenario_table(&scenarios, &outcomes, args.verbose);
        println!();
        println!("Scenarios: {:.1} s wall.", wall.elapsed().as_secs_f64());
    }
    if args.random > 0 {
        let random_wall = Instant::now();
        let seeds = args.random_from.max(1)..=args.random;
        let outcomes = random::run_many(seeds, &args.params, threads)?;
        println!();
        report::random_table(&outcomes, args.verbose);
        println!();
        println!(
            "Randomized: {} runs, {:.1} s wall ({threads} threads).",
            outcomes.len(),
            random_wall.elapsed().as_secs_f64()
        );
    }
    println!();
    println!("Total: {:.1} s wall.", wall.elapsed().as_secs_f64());
    Ok(())
}
