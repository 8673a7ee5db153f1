//! A simulated fleet in stepped time: vehicles that share one world see
//! each other with their scanners, so two meeting head-on both stop short
//! of each other; they share one VDA 5050 map frame whatever their first
//! fixes; and the same seeds give the same fleet.

use std::time::Duration;

use autopilot::fleet::AgentConfig;
use autopilot::sitl::fleet::FleetSimulation;
use autopilot::sitl::gcs;
use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};
use autopilot::time::FrozenTimer;
use autopilot::vehicle::FleetMessage;
use test_support::vda5050::{N, order};
use vda5050::Topic;

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

/// Two vehicles started 22 m apart, each an AGV on map "yard" about the
/// fleet's home: the map positions they report are where they truly are
/// (map x east, y north of home), and each drives an order whose nodes are
/// given in that one map frame to the true place.
#[test]
fn vehicles_at_different_homes_share_one_map_frame() {
    let starts = [(0.0, 0.0), (20.0, 10.0)];
    let vehicles = starts
        .iter()
        .enumerate()
        .map(|(i, &(north_m, east_m))| {
            let config = SimulationConfig {
                seed: 11 + i as u64,
                model: ModelKind::Ackermann,
                ..SimulationConfig::default()
            };
            let mut sim = Simulation::new(&config, SimulationParams::new(ModelKind::Ackermann));
            sim.world_mut().place(north_m, east_m, 0.0);
            sim.core_mut().enable_vda5050(AgentConfig {
                map_id: "yard".into(),
                map_origin: Some(config.home),
                ..AgentConfig::default()
            });
            gcs::connect(&mut sim);
            sim
        })
        .collect();
    let mut fleet = FleetSimulation::new(vehicles);
    let mut states: Vec<Vec<vda5050::State>> = vec![Vec::new(), Vec::new()];
    let run = |fleet: &mut FleetSimulation, seconds: f64, states: &mut Vec<Vec<vda5050::State>>| {
        run_for(fleet, seconds, |_| {});
        for (i, vehicle) in fleet.vehicles_mut().iter_mut().enumerate() {
            for message in vehicle.outputs_mut().vda5050.drain(..) {
                if let FleetMessage::State(state) = message {
                    states[i].push(*state);
                }
            }
        }
    };
    let ask_state = |fleet: &mut FleetSimulation| {
        for vehicle in fleet.vehicles_mut() {
            let request = test_support::vda5050::instant("s1", "stateRequest");
            vehicle
                .inputs_mut()
                .vda5050
                .push((Topic::InstantActions, request.to_string().into_bytes()));
        }
    };
    // Stepped in slices: run_for clears only MAVLink, states are read after.
    for _ in 0..10 {
        run(&mut fleet, 1.0, &mut states);
    }
    ask_state(&mut fleet);
    run(&mut fleet, 0.5, &mut states);
    for (i, vehicle) in fleet.vehicles().iter().enumerate() {
        let truth = vehicle.world().truth();
        let position = states[i]
            .last()
            .and_then(|s| s.agv_position.clone())
            .expect("a position");
        let off_m = (position.x - truth.east_m).hypot(position.y - truth.north_m);
        println!(
            "vehicle {i}: map ({:.3}, {:.3}), truth east/north ({:.3}, {:.3})",
            position.x, position.y, truth.east_m, truth.north_m
        );
        assert!(off_m < 0.1, "vehicle {i} reports {off_m:.3} m from where it is");
        assert!(
            (position.theta - std::f64::consts::FRAC_PI_2).abs() < 0.05,
            "facing north is theta π/2: {}",
            position.theta
        );
    }
    // Each 12 m north of where it started, in the shared map frame.
    for (i, vehicle) in fleet.vehicles_mut().iter_mut().enumerate() {
        let (north_m, east_m) = starts[i];
        let nodes = [
            N("a", east_m, north_m, true, None),
            N("b", east_m, north_m + 12.0, true, None),
        ];
        let message = order(&format!("job{i}"), 0, 0, &nodes, &[]);
        vehicle
            .inputs_mut()
            .vda5050
            .push((Topic::Order, message.to_string().into_bytes()));
    }
    for _ in 0..60 {
        run(&mut fleet, 1.0, &mut states);
        if states
            .iter()
            .all(|s| s.last().is_some_and(|s| s.last_node_id == "b" && !s.driving))
        {
            break;
        }
    }
    for (i, vehicle) in fleet.vehicles().iter().enumerate() {
        let last = states[i].last().expect("states");
        assert!(last.errors.is_empty(), "vehicle {i}: {:?}", last.errors);
        assert_eq!(last.last_node_id, "b", "vehicle {i} did not reach b");
        let truth = vehicle.world().truth();
        let (north_m, east_m) = starts[i];
        let off_m = (truth.east_m - east_m).hypot(truth.north_m - (north_m + 12.0));
        println!("vehicle {i}: stopped {off_m:.3} m from node b");
        assert!(
            off_m < test_support::vda5050::ALLOWED_DEVIATION_XY_M + 0.05,
            "vehicle {i} stopped {off_m:.3} m from b"
        );
    }
}
