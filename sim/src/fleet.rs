//! A fleet's shared world: every vehicle has a [`World`] of its own (its
//! physics, receiver and scanners), all on one home frame, and before each
//! step every vehicle's outline at its true pose is placed in the others'
//! worlds, so their scanners see each other and a collision shows in
//! [`World::clearance_m`].

use super::obstacles::{Rectangle, VehicleOutline};
use super::world::World;

/// The outlines of a fleet's vehicles as they were when last gathered.
#[derive(Clone, Debug, Default)]
pub struct FleetOutlines {
    outlines: Vec<Rectangle>,
}

impl FleetOutlines {
    /// Records where every vehicle is now, in fleet order (call before
    /// stepping any of them, so each sees the others at the same instant
    /// whatever the order they are stepped in).
    pub fn gather<'a>(&mut self, vehicles: impl Iterator<Item = (&'a World, VehicleOutline)>) {
        self.outlines.clear();
        self.outlines
            .extend(vehicles.map(|(world, outline)| world.outline_now(&outline)));
    }

    /// Places every other vehicle's outline in the world of vehicle `index`.
    pub fn share_with(&self, index: usize, world: &mut World) {
        let others = self
            .outlines
            .iter()
            .enumerate()
            .filter(move |(i, _)| *i != index)
            .map(|(_, outline)| *outline);
        world.set_other_vehicles(others);
    }

    /// The outlines as gathered, in fleet order.
    pub fn outlines(&self) -> &[Rectangle] {
        &self.outlines
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{SimScannerConfig, WorldConfig};
    use std::time::Duration;

    fn world_at(north_m: f64, yaw_rad: f64) -> World {
        let mut world = World::new(WorldConfig::default(), 7);
        world.place(north_m, 0.0, yaw_rad);
        world.set_scanners(vec![SimScannerConfig {
            range_sigma_m: 0.0,
            dropout_probability: 0.0,
            ..SimScannerConfig::default()
        }]);
        world
    }

    #[test]
    fn two_vehicles_facing_each_other_see_each_other_and_not_themselves() {
        let outline = VehicleOutline::default();
        // 20 m apart, nose to nose: the gap between the outlines is
        // 20 − 2·3.6 = 12.8 m.
        let mut worlds = [world_at(0.0, 0.0), world_at(20.0, std::f64::consts::PI)];
        let mut fleet = FleetOutlines::default();
        fleet.gather(worlds.iter().map(|w| (w, outline)));
        for (i, world) in worlds.iter_mut().enumerate() {
            fleet.share_with(i, world);
        }
        let clearance_m = worlds[0].clearance_m(&outline).unwrap();
        assert!((clearance_m - 12.8).abs() < 1e-9, "{clearance_m}");
        for world in &mut worlds {
            world.step(Duration::from_millis(200), &vehicle_types::ActuatorDemand::STOP);
            let mut scans = Vec::new();
            world.take_scans(&mut scans);
            let (_, scan) = scans.last().expect("a scan");
            let nearest_m = scan
                .ranges_m
                .iter()
                .filter(|r| r.is_finite())
                .fold(f32::INFINITY, |a, &r| a.min(r));
            let scanner_ahead_m = SimScannerConfig::default().mount_x_m;
            let expected_m = 12.8 + 3.6 - scanner_ahead_m;
            assert!(
                (f64::from(nearest_m) - expected_m).abs() < 0.05,
                "nearest echo {nearest_m} m, expected the other vehicle's nose at {expected_m} m"
            );
        }
    }

    #[test]
    fn other_vehicles_survive_a_new_set_of_obstacles() {
        let outline = VehicleOutline::default();
        let mut worlds = [world_at(0.0, 0.0), world_at(20.0, 0.0)];
        let mut fleet = FleetOutlines::default();
        fleet.gather(worlds.iter().map(|w| (w, outline)));
        fleet.share_with(0, &mut worlds[0]);
        worlds[0].set_obstacles(None);
        assert_eq!(worlds[0].obstacles().map(|o| o.vehicles.len()), Some(1));
    }
}
