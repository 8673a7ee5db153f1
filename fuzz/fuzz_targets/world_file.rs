//! SITL world files (`sim::parse_world_file`): TOML
//! with static shapes, moving obstacles and a magnetic tape, reloaded while
//! SITL runs.
//!
//! Properties: a world that parses is one the simulation can use: the
//! simulated scanner's ray casts, obstacle positions and the tape's geometry
//! come out finite (NaN there would blind the obstacle avoidance or the
//! magnetic-tape guidance without any error).
#![no_main]

use libfuzzer_sys::fuzz_target;
use sim::parse_world_file;

const MAX_RANGE_M: f64 = 40.0;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(world) = parse_world_file(text) else {
        return;
    };
    let obstacles = world.obstacles();
    for t_s in [0.0, 1.5, 60.0] {
        for (i, _) in obstacles.movers.iter().enumerate() {
            if let Some((position, velocity)) = obstacles.mover_state(i, t_s) {
                assert!(
                    position.iter().chain(&velocity).all(|v| v.is_finite()),
                    "mover {i} at {t_s} s: {position:?} {velocity:?}"
                );
            }
        }
        for bearing_deg in [0.0_f64, 45.0, 90.0, 180.0, 270.0] {
            if let Some(r) = obstacles.raycast([0.0, 0.0], bearing_deg.to_radians(), MAX_RANGE_M, t_s) {
                assert!(
                    (0.0..=MAX_RANGE_M).contains(&r),
                    "ray at {bearing_deg}° and {t_s} s: {r}"
                );
            }
        }
    }
    if let Some(tape) = world.tape() {
        assert!(tape.length_m().is_finite(), "tape length {}", tape.length_m());
        if let Some(fix) = tape.locate(0.0, 0.0) {
            assert!(
                fix.distance_m.is_finite() && fix.heading_rad.is_finite() && fix.along_m.is_finite(),
                "{fix:?}"
            );
        }
    }
});
