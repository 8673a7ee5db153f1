//! The obstacle scenario families run through `furrow-bench obstacles`'s own
//! functions (in-process, the whole core, simulated scanners), judged from
//! the simulator's truth: no collision, no false stop, no stall; a family
//! with something in the way must stop, one with everything 0.5 m or more
//! clear must pass without a stop. Both speeds, forwards and in reverse,
//! left and right, seeds 1 and 2 (arcs of 6 and 15 m).
//!
//! An ignored test says in its attribute what still fails it.

use furrow_bench::obstacles::random::{self, RUNS_PER_COURSE};
use furrow_bench::obstacles::{self, Family, Outcome, Scenario};

const SEEDS: u64 = 2;
const SPEEDS_MPS: [f64; 2] = [1.0, 2.0];

/// Randomized runs where someone walking slowly across the lane went into
/// the scanners' blind zone beside the stopped vehicle (their velocity
/// spoilt by the last sliver of returns) and walked on into its side: the
/// vehicle must not start until they have been seen again (seed 595 also
/// needs the obstacle stop to brake to rest, not creep into them).
#[test]
fn no_start_into_someone_lost_beside_the_body() {
    for seed in [595, 617] {
        let o = random::run(seed, &[], None).expect("runs");
        let r = &o.result;
        assert_eq!(r.collisions, r.unavoidable, "seed {seed}: {:?}", r.events);
        assert!(r.completion_s.is_some(), "seed {seed}: {:?}", r.events);
    }
}

/// Randomized runs where someone walked slowly into the side of the
/// stopped vehicle: as they entered the blind zone between the scanners'
/// fields, the last beam showed only their edge, the track shrank to a
/// sliver that stayed where the field ends (so it looked still, and was
/// forgotten once lost), and the vehicle resumed into them. It must hold
/// until they have been seen again.
#[test]
fn no_resume_into_someone_walking_into_the_blind_zone() {
    for seed in [388, 515, 876] {
        assert_resumes_safely(seed);
    }
}

/// The same, where the person (0.47 m/s) comes at the vehicle's side in
/// an arc: the edge-only views while they approach pull the track's
/// velocity down, and a walker this slow is below twice the filter's
/// velocity σ; it must still be predicted at its velocity, not as standing.
#[test]
fn no_resume_into_someone_walking_into_the_side_in_an_arc() {
    assert_resumes_safely(909);
}

fn assert_resumes_safely(seed: u64) {
    let o = random::run(seed, &[], None).expect("runs");
    let r = &o.result;
    assert_eq!(r.collisions, r.unavoidable, "seed {seed}: {:?}", r.events);
    assert!(r.completion_s.is_some(), "seed {seed}: {:?}", r.events);
}

fn families(pick: impl Fn(&Family) -> bool) -> Vec<Scenario> {
    let list: Vec<Scenario> = Family::all()
        .into_iter()
        .filter(|f| pick(f))
        .map(Scenario::Family)
        .collect();
    assert!(!list.is_empty());
    list
}

fn run(scenarios: &[Scenario]) -> Vec<Outcome> {
    let jobs = obstacles::jobs(scenarios, &SPEEDS_MPS, SEEDS);
    obstacles::run_scenarios(scenarios, &jobs, &[], 2).expect("the scenarios run")
}

/// Every run collision-free, without false stops or stalls, stopping or
/// passing as its family requires.
fn assert_safe(scenarios: &[Scenario], outcomes: &[Outcome]) {
    let mut failures = Vec::new();
    for o in outcomes {
        let Scenario::Family(family) = &scenarios[o.row] else {
            continue;
        };
        let r = &o.result;
        let what = format!("{} {}", family.name(), o.variant.label());
        if r.collisions > 0 {
            failures.push(format!("{what}: {} collisions {:?}", r.collisions, r.events));
        }
        if r.false_stops > 0 {
            failures.push(format!("{what}: {} false stops {:?}", r.false_stops, r.events));
        }
        if r.stalls > 0 {
            failures.push(format!("{what}: stalled {:?}", r.events));
        }
        if family.must_stop() && r.stops == 0 {
            failures.push(format!("{what}: did not stop"));
        }
        if family.must_pass() && r.stops > 0 {
            failures.push(format!("{what}: stopped {} times {:?}", r.stops, r.events));
        }
    }
    assert_eq!(outcomes.len(), scenarios.len() * 8 * SEEDS as usize);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

fn check(pick: impl Fn(&Family) -> bool) {
    let scenarios = families(pick);
    let outcomes = run(&scenarios);
    assert_safe(&scenarios, &outcomes);
}

use obstacles::families::{Object, Where};

fn neighbours(object: Object, at: Where) {
    check(|f| matches!(f, Family::Neighbour { object: o, at: w, .. } if *o == object && *w == at));
}

#[test]
fn person_standing_inside_the_arc() {
    check(|f| *f == Family::InsideArc);
}

#[test]
fn person_standing_outside_the_arc() {
    check(|f| *f == Family::OutsideArc);
}

#[test]
fn person_beside_the_arc_is_passed() {
    check(|f| *f == Family::BesideArcOutside);
}

#[test]
fn person_beside_the_arc_entry_is_passed() {
    check(|f| *f == Family::BesideEntry);
}

#[test]
#[ignore = "one false stop left: the person 0.5 m outside the arc exit, in reverse at 2 m/s (seed 2), is predicted to enter the swept outline in 0.7 s while its true line stays 0.52 m clear; the field-edge sliver that caused the others is handled, this one is not yet traced"]
fn person_beside_the_arc_exit_is_passed() {
    check(|f| *f == Family::BesideExit);
}

#[test]
fn person_under_the_overhang_swing() {
    check(|f| *f == Family::TailSwing);
}

#[test]
fn person_walking_across_the_arc() {
    check(|f| *f == Family::CrossingArc);
}

#[test]
fn person_stepping_out_mid_turn() {
    check(|f| *f == Family::StepOut);
}

#[test]
fn s_bend_person_inside_the_second_bend() {
    check(|f| *f == Family::SBendInside);
}

#[test]
fn s_bend_person_beside_the_first_bend_is_passed() {
    check(|f| *f == Family::SBendBeside);
}

#[test]
fn boxes_beside_a_straight_lane() {
    neighbours(Object::Box, Where::Straight);
}

#[test]
fn boxes_inside_an_arc() {
    neighbours(Object::Box, Where::ArcInside);
}

#[test]
fn boxes_outside_an_arc() {
    neighbours(Object::Box, Where::ArcOutside);
}

#[test]
fn posts_beside_a_straight_lane() {
    neighbours(Object::Post, Where::Straight);
}

#[test]
fn posts_inside_an_arc() {
    neighbours(Object::Post, Where::ArcInside);
}

#[test]
fn posts_outside_an_arc() {
    neighbours(Object::Post, Where::ArcOutside);
}

#[test]
fn parked_cars_beside_a_straight_lane() {
    neighbours(Object::ParkedCar, Where::Straight);
}

#[test]
fn parked_cars_inside_an_arc() {
    neighbours(Object::ParkedCar, Where::ArcInside);
}

#[test]
fn parked_cars_outside_an_arc() {
    neighbours(Object::ParkedCar, Where::ArcOutside);
}

/// Randomized courses and people (seeds 1..=40, four courses): no
/// collision the vehicle could have stopped for (judged from the truth),
/// no false stop, no stall; each run replays identically from its seed.
#[test]
#[ignore = "avoidable collisions at start and resume and false stops remain in the randomized runs (furrow-bench obstacles --random)"]
fn randomized_runs() {
    let outcomes = random::run_many(1..=4 * RUNS_PER_COURSE, &[], 2).expect("the runs run");
    let mut failures = Vec::new();
    for o in &outcomes {
        let r = &o.result;
        if r.collisions > r.unavoidable || r.false_stops > 0 || r.stalls > 0 {
            failures.push(format!("seed {}: {:?}", o.seed, r.events));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn a_randomized_run_replays_from_its_seed() {
    let seed = 6;
    let a = random::run(seed, &[], None).expect("runs");
    let b = random::run(seed, &[], None).expect("runs");
    assert_eq!(a.result.events, b.result.events);
    assert_eq!(a.result.completion_s, b.result.completion_s);
    assert_eq!(a.result.min_clearance_m.to_bits(), b.result.min_clearance_m.to_bits());
}
