//! The bench's tables.

use super::random::RandomOutcome;
use super::situation::Breakdown;
use super::{Outcome, Scenario};

/// Totals over some runs.
#[derive(Default)]
pub struct Tally {
    pub runs: usize,
    pub completed: usize,
    pub collisions: u32,
    pub unavoidable: u32,
    pub false_stops: u32,
    pub stalls: u32,
    pub stops: u32,
    /// Runs that stopped at least once.
    pub stopped_runs: usize,
    pub min_clearance_m: Option<f64>,
    pub min_rest_clearance_m: Option<f64>,
    /// Over the rests a vehicle braking at once could have ended 0.3 m
    /// clear of: the smallest clearance, and how many.
    pub min_room_rest_clearance_m: Option<f64>,
    pub room_rests: usize,
    pub max_braking_m: Option<f64>,
    pub time_lost_s: Vec<f64>,
    pub kf_error_mps: Vec<f64>,
    pub malformed_scans: u64,
}

fn min_opt(a: Option<f64>, b: f64) -> Option<f64> {
    if !b.is_finite() {
        return a;
    }
    Some(a.map_or(b, |a| a.min(b)))
}

impl Tally {
    pub fn add(&mut self, r: &super::RunResult) {
        self.runs += 1;
        self.completed += usize::from(r.completion_s.is_some());
        self.collisions += r.collisions;
        self.unavoidable += r.unavoidable;
        self.false_stops += r.false_stops;
        self.stalls += r.stalls;
        self.stops += r.stops;
        self.stopped_runs += usize::from(r.stops > 0);
        self.min_clearance_m = min_opt(self.min_clearance_m, r.min_clearance_m);
        for &c in &r.rest_clearance_m {
            self.min_rest_clearance_m = min_opt(self.min_rest_clearance_m, c);
        }
        for &c in &r.rest_clearance_with_room_m {
            self.min_room_rest_clearance_m = min_opt(self.min_room_rest_clearance_m, c);
        }
        self.room_rests += r.rest_clearance_with_room_m.len();
        for &b in &r.braking_m {
            self.max_braking_m = Some(self.max_braking_m.map_or(b, |m| m.max(b)));
        }
        self.time_lost_s.extend(r.time_lost_s);
        self.kf_error_mps.extend(r.kf_velocity_error_mps.iter().copied());
        self.malformed_scans += r.malformed_scans;
    }

    /// Collisions, with the unavoidable ones among them.
    fn collisions_text(&self) -> String {
        format!("{} ({})", self.collisions, self.unavoidable)
    }

    /// The smallest clearance at rest where there was room for 0.3 m, and
    /// over how many rests.
    fn room_rest_text(&self) -> String {
        format!("{} (n={})", fmt(self.min_room_rest_clearance_m), self.room_rests)
    }

    fn lost_text(&self) -> String {
        let mut lost = self.time_lost_s.clone();
        lost.sort_by(f64::total_cmp);
        if lost.is_empty() {
            return "–".into();
        }
        format!("{:.1} / {:.1}", lost[lost.len() / 2], lost[lost.len() - 1])
    }

    fn kf_text(&self) -> String {
        let kf = &self.kf_error_mps;
        if kf.is_empty() {
            return "–".into();
        }
        format!(
            "{:.3} / {:.3} (n={})",
            kf.iter().sum::<f64>() / kf.len() as f64,
            kf.iter().copied().fold(0.0, f64::max),
            kf.len()
        )
    }
}

fn fmt(v: Option<f64>) -> String {
    v.map_or("–".to_string(), |v| format!("{v:.2}"))
}

/// How bad a run was, for picking the worst: avoidable collisions, then
/// stalls, then false stops, then the smallest clearance.
fn badness(r: &super::RunResult) -> (u32, u32, u32, f64) {
    let clearance = if r.min_clearance_m.is_finite() {
        -r.min_clearance_m
    } else {
        f64::NEG_INFINITY
    };
    (r.collisions - r.unavoidable, r.stalls, r.false_stops, clearance)
}

fn worse(a: &super::RunResult, b: &super::RunResult) -> std::cmp::Ordering {
    let (x, y) = (badness(a), badness(b));
    (x.0, x.1, x.2).cmp(&(y.0, y.1, y.2)).then(x.3.total_cmp(&y.3))
}

/// One row per scenario (a classic one per speed).
pub fn scenario_table(scenarios: &[Scenario], outcomes: &[Outcome], verbose: bool) {
    println!(
        "| scenario | runs | completed | collisions (unavoidable) | false stops | stalls | stops | as required | min clearance m | clearance at rest m (min) | at rest with room for 0.3 m, m (min) | stop distance m (max) | time lost s (median / max) | KF |v| err after 1 s m/s (mean / max) | worst run |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---|");
    let mut total = Tally::default();
    let mut clear = Tally::default();
    for (row, scenario) in scenarios.iter().enumerate() {
        let mut speeds: Vec<f64> = outcomes
            .iter()
            .filter(|o| o.row == row)
            .map(|o| o.variant.speed_mps)
            .collect();
        speeds.dedup();
        let groups: Vec<Option<f64>> = match scenario {
            Scenario::Classic { .. } => speeds.into_iter().map(Some).collect(),
            Scenario::Family(_) => vec![None],
        };
        for speed in groups {
            let runs: Vec<&Outcome> = outcomes
                .iter()
                .filter(|o| o.row == row && speed.is_none_or(|s| s == o.variant.speed_mps))
                .collect();
            let mut tally = Tally::default();
            for o in &runs {
                tally.add(&o.result);
                total.add(&o.result);
                if matches!(scenario, Scenario::Family(f) if f.must_pass()) {
                    clear.add(&o.result);
                }
                if verbose {
                    println!(
                        "<!-- {} {}: {:?} -->",
                        scenario.name(),
                        o.variant.label(),
                        o.result.events
                    );
                }
            }
            print_scenario_row(scenario, speed, &runs, &tally);
        }
    }
    println!();
    println!(
        "Scenario total: {} runs, {} collisions ({} unavoidable), {} false stops, {} stalls.",
        total.runs, total.collisions, total.unavoidable, total.false_stops, total.stalls
    );
    print_targets(&total, &clear);
}

/// The two figures: what an object 0.5 m clear costs, and the
/// clearance at rest when there was room to stop.
fn print_targets(total: &Tally, clear: &Tally) {
    if clear.runs > 0 {
        let max_lost = clear.time_lost_s.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        println!(
            "Objects 0.5 m or more clear of the swept outline (families that must pass, {} runs): time lost median / max {} s (target < 1 s); {} runs stopped, {} of {} completed{}.",
            clear.runs,
            clear.lost_text(),
            clear.stopped_runs,
            clear.completed,
            clear.runs,
            if max_lost < 1.0 && clear.completed == clear.runs {
                ""
            } else {
                ": TARGET MISSED"
            }
        );
    }
    println!(
        "Clearance at rest after a stop for an object standing still, known (on its line and in a beam) while the outline was at least the plant's stopping distance + 0.3 m from it: min {} m over {} rests (target ≥ 0.3 m); over all {} stops' rests: min {} m.",
        fmt(total.min_room_rest_clearance_m),
        total.room_rests,
        total.stops,
        fmt(total.min_rest_clearance_m)
    );
}

/// One row of the scenario table: a scenario's runs (at one speed for a
/// classic one) and their tally.
fn print_scenario_row(scenario: &Scenario, speed: Option<f64>, runs: &[&Outcome], tally: &Tally) {
    let name = match speed {
        Some(s) => format!("{} ({s:.1} m/s)", scenario.name()),
        None => scenario.name(),
    };
    let required = match scenario {
        Scenario::Family(f) if f.must_stop() => format!("stopped {}/{}", tally.stopped_runs, tally.runs),
        Scenario::Family(f) if f.must_pass() => {
            format!("no stop {}/{}", tally.runs - tally.stopped_runs, tally.runs)
        }
        _ => "–".into(),
    };
    let worst = runs
        .iter()
        .max_by(|a, b| worse(&a.result, &b.result))
        .filter(|o| o.result.collisions + o.result.stalls + o.result.false_stops > 0)
        .map_or("–".to_string(), |o| o.variant.label());
    let blocked = matches!(
        scenario,
        Scenario::Classic {
            kind: super::Classic::StaticBox { detour: false },
            ..
        }
    ) || matches!(scenario, Scenario::Family(super::Family::Neighbour { gap_m, .. }) if *gap_m < 0.5);
    println!(
        "| {name} | {} | {}/{}{} | {} | {} | {} | {} | {required} | {} | {} | {} | {} | {} | {} | {worst} |{}",
        tally.runs,
        tally.completed,
        tally.runs,
        if blocked { " (blocked by design)" } else { "" },
        tally.collisions_text(),
        tally.false_stops,
        tally.stalls,
        tally.stops,
        fmt(tally.min_clearance_m),
        fmt(tally.min_rest_clearance_m),
        tally.room_rest_text(),
        fmt(tally.max_braking_m),
        tally.lost_text(),
        tally.kf_text(),
        if tally.malformed_scans > 0 {
            format!(" {} malformed scans!", tally.malformed_scans)
        } else {
            String::new()
        }
    );
}

/// The randomized runs: feasible and infeasible timings apart, and the
/// worst run with its seed.
pub fn random_table(outcomes: &[RandomOutcome], verbose: bool) {
    println!(
        "| randomized | runs | completed | collisions (unavoidable) | false stops | stalls | stops | min clearance m | at rest with room for 0.3 m, m (min) | time lost s (median / max) | worst run |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|");
    let mut breakdown = Breakdown::default();
    for o in outcomes {
        for &(situation, unavoidable) in &o.result.collision_situations {
            breakdown.collision(situation, unavoidable);
        }
        for &situation in &o.result.false_stop_situations {
            breakdown.false_stop(situation);
        }
    }
    for (label, feasible) in [("feasible timings", true), ("infeasible timings", false)] {
        let runs: Vec<&RandomOutcome> = outcomes.iter().filter(|o| o.feasible == feasible).collect();
        let mut tally = Tally::default();
        for o in &runs {
            tally.add(&o.result);
            if verbose && o.result.collisions + o.result.stalls + o.result.false_stops > 0 {
                println!("<!-- seed {}: {:?} -->", o.seed, o.result.events);
            }
        }
        let worst = runs
            .iter()
            .max_by(|a, b| worse(&a.result, &b.result))
            .map_or("–".to_string(), |o| {
                format!(
                    "seed {} ({} collisions ({} unavoidable), {} stalls, {} false stops, min clearance {})",
                    o.seed,
                    o.result.collisions,
                    o.result.unavoidable,
                    o.result.stalls,
                    o.result.false_stops,
                    fmt(Some(o.result.min_clearance_m).filter(|c| c.is_finite()))
                )
            });
        println!(
            "| {label} | {} | {}/{} | {} | {} | {} | {} | {} | {} | {} | {worst} |",
            tally.runs,
            tally.completed,
            tally.runs,
            tally.collisions_text(),
            tally.false_stops,
            tally.stalls,
            tally.stops,
            fmt(tally.min_clearance_m),
            tally.room_rest_text(),
            tally.lost_text()
        );
    }
    print_lowest_rests(outcomes);
    print_avoidable(outcomes);
    println!();
    println!("Where the randomized collisions and false stops happened (both timings):");
    println!();
    breakdown.print();
    println!();
    println!(
        "Collisions (unavoidable): all collisions while moving, and in brackets those the vehicle could not have prevented: replayed braking as hard as the simulated plant can (its braking limit through the drive's lag, from a zero command at once) from the first instant the object could be known (the later of when it began the straight line it hit from and when a scanner's beam first reached it), along the path driven, it still touches the object."
    );
    println!(
        "Timings: feasible when, on the course driven without people, braking the same way from the instant each person could be known avoids everyone the course would touch; infeasible otherwise. False stops: a stop when no true shape, moved on its true velocity for the horizon, comes within OA_MARGIN of the outline swept along the course for the plant's true stopping distance plus the horizon's travel (no OA_REACT_TIME or OA_DECEL in either rule)."
    );
    println!("Replay a run with `furrow-bench obstacles --replay SEED`.");
}

/// Every avoidable collision of the randomized runs with its seed and
/// situation, to replay.
fn print_avoidable(outcomes: &[RandomOutcome]) {
    let avoidable: Vec<String> = outcomes
        .iter()
        .flat_map(|o| {
            (o.result.collision_situations)
                .iter()
                .filter(|(_, unavoidable)| !unavoidable)
                .map(|(situation, _)| {
                    format!(
                        "seed {} ({}, {})",
                        o.seed,
                        if o.feasible { "feasible" } else { "infeasible" },
                        situation.label()
                    )
                })
        })
        .collect();
    if !avoidable.is_empty() {
        println!();
        println!("Avoidable collisions ({}): {}.", avoidable.len(), avoidable.join("; "));
    }
}

/// How many of the lowest clearances at rest with room for 0.3 m are
/// listed with their seeds.
const LOWEST_RESTS: usize = 8;

/// The randomized runs' lowest clearances at rest where a stop 0.3 m
/// clear was possible, with their seeds, to replay.
fn print_lowest_rests(outcomes: &[RandomOutcome]) {
    let mut rests: Vec<(f64, u64, bool)> = outcomes
        .iter()
        .flat_map(|o| {
            (o.result.rest_clearance_with_room_m)
                .iter()
                .map(|&c| (c, o.seed, o.feasible))
        })
        .collect();
    rests.sort_by(|a, b| a.0.total_cmp(&b.0));
    let lowest: Vec<String> = rests
        .iter()
        .take(LOWEST_RESTS)
        .map(|(c, seed, feasible)| {
            format!(
                "seed {seed} {c:.2} m ({})",
                if *feasible { "feasible" } else { "infeasible" }
            )
        })
        .collect();
    if !lowest.is_empty() {
        println!();
        println!("Lowest clearances at rest with room for 0.3 m: {}.", lowest.join(", "));
    }
}
