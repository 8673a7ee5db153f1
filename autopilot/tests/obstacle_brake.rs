//! How an obstacle stop brakes, in the running core against the simulated
//! drive: it comes to a real standstill about as fast as the drive can
//! brake, and stays there (an AGV's safety stop, ArduPilot's HOLD), rather
//! than creeping the last centimetres per second for a second or more,
//! while someone may walk into it.
//!
//! The brake used to act on the estimator's speed alone, which changes
//! only with each 10 Hz GNSS velocity, 60–160 ms behind the truth and with
//! about 2 cm/s of noise: below about 0.3 m/s the drive's lag decayed the
//! rest and the noise pushed it either way, 1.22 s to rest from 1.48 m/s
//! where the drive could stop in 0.74 s. It now carries the speed on with
//! the IMU's acceleration (`SpeedController::brake`).

mod common;

use autopilot::sitl::simulation::ModelKind;
use common::{Harness, speed_then_waypoints};
use mission::MissionType;
use sim::{ObstacleWorld, Shape};

/// The simulated drive's braking limit (`sim::AckermannConfig`'s and
/// `DifferentialConfig`'s `brake_max_mps2`): the hardest any stop can be.
const PLANT_BRAKE_MPS2: f64 = 2.0;
/// Below this true speed the vehicle is at rest (the bench's judge counts
/// a collision only above it).
const AT_REST_MPS: f64 = 0.01;
/// What the brake may leave once at rest, a moment's roll either way: the
/// speed it brakes on starts from a GNSS speed up to a tenth of a second
/// old and carries an accelerometer bias (0.03 m/s² in the simulator)
/// over the stop.
const ROLL_AFTER_REST_MPS: f64 = 0.02;

/// How a stop went, from the truth: the speed when the stop was decided,
/// how long it took to come to rest, and the fastest it moved afterwards
/// while the stop was held.
#[derive(Debug)]
struct Stop {
    from_mps: f64,
    to_rest_s: f64,
    moved_after_mps: f64,
}

/// Drives the straight mission in AUTO towards a person standing in the
/// lane `at_m` ahead, and watches the first obstacle stop for up to
/// `hold_s`, while it is held (a stop decided 3 s short of them resumes
/// once the start is judged clear, to stop again nearer).
fn stop_for_person(seed: u64, model: ModelKind, speed_mps: f32, at_m: f64, hold_s: f64) -> Stop {
    let mut h = Harness::new(seed, model);
    let person = Shape::Circle {
        center: [at_m, 0.0],
        radius_m: 0.25,
    };
    h.sim
        .world_mut()
        .set_obstacles(Some(ObstacleWorld::new(vec![person], Vec::new())));
    h.sim.core_mut().load_plan(
        MissionType::Mission,
        speed_then_waypoints(speed_mps, &[(at_m + 20.0, 0.0)]),
    );
    h.run_for(3.0);
    h.arm();
    h.set_mode(10);
    let stopped = h.run_until(60.0, |sim| sim.core().obstacle_status().stopped);
    assert!(stopped, "never stopped for the person: {:?}", h.texts());
    let decided_s = h.sim.time().as_secs_f64();
    let from_mps = h.sim.world().truth().speed_mps.abs();
    let mut to_rest_s = None;
    let mut moved_after_mps: f64 = 0.0;
    while h.sim.time().as_secs_f64() - decided_s < hold_s {
        h.step();
        if !h.sim.core().obstacle_status().stopped {
            break;
        }
        let t = h.sim.time().as_secs_f64() - decided_s;
        let v = h.sim.world().truth().speed_mps.abs();
        match to_rest_s {
            None if v <= AT_REST_MPS => to_rest_s = Some(t),
            None => {}
            Some(_) => moved_after_mps = moved_after_mps.max(v),
        }
    }
    Stop {
        from_mps,
        to_rest_s: to_rest_s.unwrap_or(f64::INFINITY),
        moved_after_mps,
    }
}

/// The time the drive itself needs to brake from `from_mps`, plus a few
/// ticks for the speed to be measured and the drive to answer.
fn brake_bound_s(from_mps: f64) -> f64 {
    from_mps / PLANT_BRAKE_MPS2 + 0.15
}

#[test]
fn an_obstacle_stop_comes_to_rest_about_as_fast_as_the_drive_brakes_and_stays() {
    let mut failures = Vec::new();
    for (seed, model, speed_mps) in [
        (1, ModelKind::Ackermann, 1.5),
        (2, ModelKind::Ackermann, 1.0),
        (3, ModelKind::Ackermann, 2.0),
        (4, ModelKind::Differential, 1.0),
        (5, ModelKind::Differential, 1.5),
    ] {
        let stop = stop_for_person(seed, model, speed_mps, 25.0, 3.0);
        println!("seed {seed} {model:?} {speed_mps} m/s: {stop:?}");
        if stop.from_mps < 0.3 {
            failures.push(format!("seed {seed}: stopped already slow, nothing measured: {stop:?}"));
        }
        if stop.to_rest_s > brake_bound_s(stop.from_mps) {
            failures.push(format!(
                "seed {seed} {model:?}: {:.2} s to rest from {:.2} m/s (bound {:.2} s)",
                stop.to_rest_s,
                stop.from_mps,
                brake_bound_s(stop.from_mps)
            ));
        }
        if stop.moved_after_mps > ROLL_AFTER_REST_MPS {
            failures.push(format!(
                "seed {seed} {model:?}: moved at {:.3} m/s after coming to rest",
                stop.moved_after_mps
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
