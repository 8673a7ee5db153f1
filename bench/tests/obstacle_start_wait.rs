//! A start put off for a walker still far from where the start would meet
//! them: the vehicle stays braked at a standstill, with no stop announced,
//! until it either starts or really stops. Seed 106 (a walker crossing
//! towards the start point): left to a speed limit of 0 instead of the
//! obstacle brake, the vehicle crept ~3 cm at ~4 cm/s towards the walker
//! before the protective field stopped it, and its later stop's tail
//! touched a walker it could have missed.

use furrow_bench::obstacles::random;

/// "… at N,E v …" of a bench event: the vehicle's place then.
fn place_m(event: &str) -> (f64, f64) {
    let after = event.rsplit_once(" at ").map_or("", |(_, a)| a);
    let place = after.split_whitespace().next().unwrap_or("");
    let (north, east) = place.split_once(',').unwrap_or(("nan", "nan"));
    (north.parse().unwrap_or(f64::NAN), east.parse().unwrap_or(f64::NAN))
}

#[test]
fn a_start_put_off_for_a_walker_does_not_creep_towards_them() {
    let seed = 106;
    let o = random::run(seed, &[], None).expect("runs");
    let r = &o.result;
    let first_stop = r
        .events
        .iter()
        .find(|e| e.contains("Obstacle stop:"))
        .unwrap_or_else(|| panic!("seed {seed} stops for the walker at its start: {:?}", r.events));
    let (north_m, east_m) = place_m(first_stop);
    // The start point is the origin; events print the place to 1 cm.
    assert!(north_m.hypot(east_m) < 0.01, "seed {seed}: {first_stop}");
    assert_eq!(r.collisions, r.unavoidable, "seed {seed}: {:?}", r.events);
    assert!(r.completion_s.is_some(), "seed {seed}: {:?}", r.events);
}

/// The same wait is shown to the ground station: one "waiting for it to
/// pass" at the start point, before the stop, not one per tick.
#[test]
fn a_start_put_off_for_a_walker_is_announced_once() {
    let seed = 106;
    let o = random::run(seed, &[], None).expect("runs");
    let events = &o.result.events;
    let waits: Vec<&String> = events.iter().filter(|e| e.contains("waiting for it to pass")).collect();
    let first_wait = waits
        .first()
        .unwrap_or_else(|| panic!("seed {seed}: no wait announced: {events:?}"));
    let (north_m, east_m) = place_m(first_wait);
    assert!(north_m.hypot(east_m) < 0.01, "seed {seed}: {first_wait}");
    let stop = events.iter().position(|e| e.contains("Obstacle stop:"));
    let wait = events.iter().position(|e| e == *first_wait);
    assert!(wait < stop, "seed {seed}: the wait after the stop: {events:?}");
    // Waits at the start point before the stop: one announcement.
    let before_stop = events[..stop.unwrap_or(events.len())]
        .iter()
        .filter(|e| e.contains("waiting for it to pass"))
        .count();
    assert_eq!(before_stop, 1, "seed {seed}: {events:?}");
}
