//! A simulated fleet in stepped time: vehicles that share one world see
//! each other with their scanners, so two meeting head-on both stop short
//! of each other; and the same seeds give the same fleet.

use std::time::Duration;

use autopilot::sitl::fleet::FleetSimulation;
use autopilot::sitl::gcs;
use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};
use autopilot::time::FrozenTimer;

/// Two bench AGVs 40 m apart on one line, facing each other (the gap
/// between their bumpers is 40 − 2·3.6 = 32.8 m).
fn head_on() -> FleetSimulation {
    let vehicles = [(1, 0.0, 0.0), (2, 40.0, 180.0)]
        .into_iter()
        .map(|(seed, north_m, heading_deg): (u64, f64, f64)| {
            let config = SimulationConfig {
                seed,
                model: ModelKind::Ackermann,
                ..SimulationConfig::default()
            };
            let mut sim = Simulation::new(&config, SimulationParams::new(ModelKind::Ackermann));
            sim.world_mut().place(north_m, 0.0, heading_deg.to_radians());
            gcs::connect(&mut sim);
            sim
        })
        .collect();
    FleetSimulation::new(vehicles)
}

fn run_for(fleet: &mut FleetSimulation, seconds: f64, mut each: impl FnMut(&FleetSimulation)) {
    let end = fleet.vehicles()[0].time() + Duration::from_secs_f64(seconds);
    while fleet.vehicles()[0].time() < end {
        let wall = fleet.vehicles()[0].time();
        fleet.step(wall, &mut FrozenTimer);
        for vehicle in fleet.vehicles_mut() {
            vehicle.outputs_mut().mavlink.clear();
        }
        each(fleet);
    }
}

/// Each vehicle in GUIDED, sent to where the other one started.
fn drive_at_each_other(fleet: &mut FleetSimulation) {
    run_for(fleet, 3.0, |_| {});
    for (vehicle, target_north_m) in fleet.vehicles_mut().iter_mut().zip([40.0, 0.0]) {
        gcs::send(vehicle, gcs::set_mode(15));
        gcs::send(vehicle, gcs::arm());
        let target = gcs::local_target(vehicle, target_north_m, 0.0);
        gcs::send(vehicle, target);
    }
}

#[test]
fn two_vehicles_meeting_head_on_both_stop_short_of_each_other() {
    let mut fleet = head_on();
    drive_at_each_other(&mut fleet);
    let mut closest_m = f64::INFINITY;
    let mut fastest_mps = 0f64;
    run_for(&mut fleet, 60.0, |f| {
        closest_m = closest_m.min(f.closest_clearance_m());
        for v in f.vehicles() {
            fastest_mps = fastest_mps.max(v.world().truth().speed_mps.abs());
        }
    });
    let speeds: Vec<f64> = fleet
        .vehicles()
        .iter()
        .map(|v| v.world().truth().speed_mps.abs())
        .collect();
    let travelled_m = [
        fleet.vehicles()[0].world().truth().north_m,
        40.0 - fleet.vehicles()[1].world().truth().north_m,
    ];
    let gap_m = fleet.closest_clearance_m();
    println!(
        "closest {closest_m:.2} m, gap at rest {gap_m:.2} m, travelled {travelled_m:?} m, fastest {fastest_mps:.2} m/s"
    );
    assert!(fastest_mps > 0.5, "they drove ({fastest_mps:.2} m/s)");
    assert!(
        travelled_m.iter().all(|&d| d > 3.0),
        "both drove towards each other: {travelled_m:?} m"
    );
    // Each stops for the other as for an obstacle coming at it; both
    // closing at once eat into OA_MARGIN (0.3 m): 0.24 m on these seeds.
    assert!(closest_m > 0.1, "they came within {closest_m:.2} m of each other");
    assert!(
        speeds.iter().all(|&s| s < 0.05),
        "both stopped and stay stopped: {speeds:?} m/s"
    );
}

#[test]
fn the_same_seeds_give_the_same_fleet() {
    let poses = || {
        let mut fleet = head_on();
        drive_at_each_other(&mut fleet);
        run_for(&mut fleet, 20.0, |_| {});
        fleet.vehicles().iter().map(|v| *v.world().truth()).collect::<Vec<_>>()
    };
    assert_eq!(poses(), poses());
}
