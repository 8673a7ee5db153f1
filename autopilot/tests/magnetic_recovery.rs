//! MAGNETIC's guide gets back on the tape from the starts of "Path
//! tracking of a wheeled AGV with double magnetic guide" (tilted right of
//! the tape, tilted left of it, off it), on the paper's robot and on the
//! bench AGV, in the simulated scenario (`furrow-bench magnetic` runs the
//! whole grid). Re-acquired: both sensors' true offsets within 10 mm from
//! then to the end of the run.

use autopilot::sitl::magnetic_scenario::{MagneticProfile, MagneticScenario, ScenarioResult, run};

const TOLERANCE_M: f64 = 0.010;

/// `profile` at `speed_mps` on a tape of `radius_m` (infinite: straight),
/// displaced `offset_m` to the right and turned `towards_deg` towards the
/// tape; off an arc it was following it (steering the arc's angle).
fn start(
    profile: &MagneticProfile,
    radius_m: f64,
    speed_mps: f64,
    offset_m: f64,
    towards_deg: f64,
    seed: u64,
) -> MagneticScenario {
    MagneticScenario {
        tape_radius_m: radius_m,
        start_offset_m: offset_m,
        // Towards a tape on the left (offset right) is anticlockwise.
        start_heading_rad: -(offset_m.signum() * towards_deg).to_radians(),
        run_up_on_curve: radius_m.is_finite(),
        duration_s: 12.0,
        tolerance_m: TOLERANCE_M,
        seed,
        ..profile.scenario(speed_mps)
    }
}

fn reacquired(what: &str, r: &ScenarioResult) -> f64 {
    r.reacquire_time_s
        .unwrap_or_else(|| panic!("{what}: not back on the tape"))
}

/// The paper's claim on its own robot: back within 2 s at 1.5 m/s with the
/// correction within ±10°, from each of its three starts (0.1 m and 5°
/// towards the tape either side; 0.15 m, where neither sensor reads it).
#[test]
fn the_papers_robot_is_back_within_two_seconds_from_its_three_starts() {
    let robot = MagneticProfile::double_guide_robot();
    for radius_m in [f64::INFINITY, 25.0, 15.0, 10.0] {
        for (offset_m, off_path) in [(0.1, false), (-0.1, false), (0.15, true), (-0.15, true)] {
            for seed in 1..=2 {
                let r = run(&start(&robot, radius_m, 1.5, offset_m, 5.0, seed));
                let what = format!("radius {radius_m} m, offset {offset_m} m, seed {seed}");
                assert_eq!(r.samples[0].lost, off_path, "{what}: the start is not the one meant");
                let t = reacquired(&what, &r);
                assert!(t <= 2.0, "{what}: {t} s");
                let correction_deg = r.max_correction_reacquiring_rad.to_degrees();
                assert!(correction_deg <= 10.0 + 1e-9, "{what}: {correction_deg}°");
                // Off the path, the front sensor finds the tape alone and can
                // cross it before the rear one arrives: a few steps with
                // neither, which the hold bridges.
                if !off_path {
                    assert_eq!(r.lost_after_found_steps, 0, "{what}");
                }
            }
        }
    }
}

/// The bench AGV's hard case: 0.1 m off at 1.5 m/s, heading 5°
/// towards the tape, either side, used to swing 10° across it and lose it
/// with both sensors. Now it keeps it and is back within 3 s.
#[test]
fn the_bench_agv_is_back_within_three_seconds_from_0_1_m_and_5_degrees() {
    let agv = MagneticProfile::bench_agv();
    for radius_m in [f64::INFINITY, 25.0, 15.0] {
        for offset_m in [0.1, -0.1] {
            for seed in 1..=2 {
                let r = run(&start(&agv, radius_m, 1.5, offset_m, 5.0, seed));
                let what = format!("radius {radius_m} m, offset {offset_m} m, seed {seed}");
                assert_eq!(r.lost_steps, 0, "{what}: both sensors lost the tape");
                let t = reacquired(&what, &r);
                assert!(t <= 3.0, "{what}: {t} s");
            }
        }
    }
}

/// The bench AGV 0.1 m off at 1.5 m/s heading 5° away from the tape,
/// either side, straight and arcs: the rear sensor swings off the tape
/// while the vehicle turns back and both are blind for about a second, so
/// the estimate carried through that stretch must start from where the
/// tape was (the best manoeuvre planned with the truth takes 2.61 s).
#[test]
fn the_bench_agv_is_back_within_three_seconds_from_0_1_m_and_5_degrees_away() {
    let agv = MagneticProfile::bench_agv();
    for radius_m in [f64::INFINITY, 25.0, 15.0, 10.0] {
        for offset_m in [0.1, -0.1] {
            for seed in 1..=2 {
                let r = run(&start(&agv, radius_m, 1.5, offset_m, -5.0, seed));
                let what = format!("radius {radius_m} m, offset {offset_m} m, seed {seed}");
                let t = reacquired(&what, &r);
                assert!(t <= 3.0, "{what}: {t} s");
            }
        }
    }
}

/// The bench AGV 0.05 m off at 1.5 m/s heading 8° away, either side,
/// straight and arcs: only the rear sensor reads the tape at the start, at
/// its edge, where the reading sticks; the side of the blind front sensor
/// must come from the rear's rate once it reads inside its trusted range,
/// not from the stuck readings (which said "parallel" and sent the vehicle
/// off the tape for good from the right). The best manoeuvre planned with
/// the truth takes 2.86 s; measured 3.2–4.54 s.
#[test]
fn the_bench_agv_gets_back_from_0_05_m_and_8_degrees_away() {
    let agv = MagneticProfile::bench_agv();
    for radius_m in [f64::INFINITY, 25.0, 15.0, 10.0] {
        for offset_m in [0.05, -0.05] {
            for seed in 1..=2 {
                let r = run(&start(&agv, radius_m, 1.5, offset_m, -8.0, seed));
                let what = format!("radius {radius_m} m, offset {offset_m} m, seed {seed}");
                let t = reacquired(&what, &r);
                assert!(t <= 5.0, "{what}: {t} s");
            }
        }
    }
}

/// On the tape, a straight running into arcs of 10 m and more: neither
/// sensor ever leaves the tape, at any of the speeds. (Settling within 10 mm
/// on the 10 m arc at 0.5 m/s takes longer than the run: the steering it
/// needs, 16°, is beyond the correction limit, and the integral learns it
/// slowly at that speed.)
#[test]
fn the_bench_agv_never_loses_a_tape_running_into_arcs() {
    let agv = MagneticProfile::bench_agv();
    for radius_m in [25.0, 15.0, 10.0] {
        for speed_mps in [0.5, 1.0, 1.5] {
            let scenario = MagneticScenario {
                run_up_on_curve: false,
                lead_in_m: 2.0,
                ..start(&agv, radius_m, speed_mps, 0.0, 0.0, 1)
            };
            let r = run(&scenario);
            let what = format!("radius {radius_m} m at {speed_mps} m/s");
            assert_eq!(r.lost_steps, 0, "{what}");
            let reach_m = agv.guide.sensor_reach_m();
            let worst_m = r
                .samples
                .iter()
                .map(|s| s.front_offset_m.abs().max(s.rear_offset_m.abs()))
                .fold(0.0, f64::max);
            assert!(worst_m < reach_m, "{what}: a sensor {worst_m} m off the tape");
        }
    }
}

/// On a straight tape the sensors stay within 10 mm 99 % of the time.
#[test]
fn the_bench_agv_tracks_a_straight_within_10_mm_p99() {
    let agv = MagneticProfile::bench_agv();
    for speed_mps in [0.5, 1.0, 1.5] {
        let r = run(&start(&agv, f64::INFINITY, speed_mps, 0.0, 0.0, 1));
        assert_eq!(r.reacquire_time_s, Some(0.0), "{speed_mps} m/s");
        assert!(
            r.lateral_p99_after_m <= 0.010,
            "{speed_mps} m/s: {}",
            r.lateral_p99_after_m
        );
    }
}

/// On the tape where an arc begins, with no straight before it: the vehicle
/// drives straight onto the arc (steering 0 where the arc needs it at once)
/// and must follow it, `radius_m` either way at each speed, never with both
/// sensors off the tape and no sensor further from it than `worst_allowed_m`.
fn follows_an_arc_that_begins_under_it(radius_m: f64, worst_allowed_m: f64) {
    let agv = MagneticProfile::bench_agv();
    for curves_right in [true, false] {
        for speed_mps in [0.5, 1.0, 1.5] {
            let scenario = MagneticScenario {
                run_up_on_curve: false,
                lead_in_m: 0.0,
                tape_curves_right: curves_right,
                duration_s: 15.0,
                ..start(&agv, radius_m, speed_mps, 0.0, 0.0, 1)
            };
            let r = run(&scenario);
            let what = format!("radius {radius_m} m, curving right {curves_right}, {speed_mps} m/s");
            assert_eq!(r.lost_steps, 0, "{what}: both sensors lost the tape");
            let worst_m = r
                .samples
                .iter()
                .map(|s| s.front_offset_m.abs().max(s.rear_offset_m.abs()))
                .fold(0.0, f64::max);
            assert!(worst_m < worst_allowed_m, "{what}: a sensor {worst_m} m off the tape");
        }
    }
}

/// 25 and 15 m: both sensors stay within the outermost probes.
#[test]
fn the_bench_agv_follows_25_and_15_m_arcs_that_begin_under_it() {
    let reach_m = MagneticProfile::bench_agv().guide.sensor_reach_m();
    follows_an_arc_that_begins_under_it(25.0, reach_m);
    follows_an_arc_that_begins_under_it(15.0, reach_m);
}

/// 10 m needs 16.2° of steering at once, beyond the 12.3° correction limit
/// about the integral: held by measuring the tape's curvature. While the
/// steering ramps up (30°/s) the front sensor goes past its outermost probe
/// at 1.5 m/s (83 mm measured) but still reads the tape.
#[test]
fn the_bench_agv_follows_a_10_m_arc_that_begins_under_it() {
    let agv = MagneticProfile::bench_agv();
    let read_limit_m =
        agv.guide.sensor_reach_m() + 0.5 * MagneticScenario::default().tape_width_m + agv.sensors.detect_margin_m;
    follows_an_arc_that_begins_under_it(10.0, read_limit_m);
}
