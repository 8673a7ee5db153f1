//! Clearance at rest and collisions in a stop's tail, in randomized runs
//! run through `furrow-bench obstacles`'s own functions (in-process, the
//! whole core, simulated scanners), judged from the simulator's truth.

use furrow_bench::obstacles::ROOM_CLEARANCE_M;
use furrow_bench::obstacles::random;

/// Seed 2285: a person stands beside the course of an arc, and the vehicle
/// stops for them five times, creeping closer with each resume (0.42 m →
/// 0.31 m at rest). The last resume leaves them beside the body, in the
/// blind zone between the scanners' fields: their track coasts, then is
/// dropped, and the inner side of the arc sweeps into them at 1.3 m/s;
/// the vehicle then rests against them (0.00 m) though they had stood
/// there, in view, since the start.
#[test]
#[ignore = "still collides: the track of the person beside the body is a sliver (radius 0.07 m) from partial views, so the resume check and the swept path see them clear"]
fn a_person_standing_beside_an_arc_is_not_swept_into() {
    let seed = 2285;
    let o = random::run(seed, &[], None).expect("runs");
    let r = &o.result;
    assert_eq!(r.collisions, r.unavoidable, "seed {seed}: {:?}", r.events);
    for &clearance_m in &r.rest_clearance_with_room_m {
        assert!(
            clearance_m >= ROOM_CLEARANCE_M,
            "seed {seed}: rest {clearance_m:.3} m: {:?}",
            r.events
        );
    }
}

/// Seed 490: someone crossing walks into the vehicle as it comes to rest
/// for them. While it still rolls at 2–4 cm/s (the brake let go at what it
/// reckoned was 2 cm/s) the touch is a collision while moving; a vehicle
/// truly at rest would only have been walked into.
#[test]
#[ignore = "still collides at 0.03 m/s: with the accelerometer's bias taken out the brake still lets go with the truth at about 5 cm/s (--replay 490 --verbose): the dead-reckoned speed is still that far off"]
fn a_stop_is_at_rest_before_someone_crossing_reaches_it() {
    let seed = 490;
    let o = random::run(seed, &[], None).expect("runs");
    let r = &o.result;
    assert_eq!(r.collisions, r.unavoidable, "seed {seed}: {:?}", r.events);
}
