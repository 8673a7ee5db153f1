//! A fleet's shared world: every vehicle has a [`World`] of its own (its
//! physics, receiver and scanners), all on one home frame, and before each
//! step every vehicle's outline at its true pose is placed in the others'
//! worlds, so their scanners see each other and a collision shows in
//! [`World::clearance_m`].

use super::obstacles::{Rectangle, VehicleOutline};
use super::world::World;

/// Vehicles this close are shared even with no scanner fitted, so a
/// collision between them shows in [`World::clearance_m`].
pub const MIN_REACH_M: f64 = 10.0;

fn half_diagonal_m(outline: &Rectangle) -> f64 {
    outline.half_length_m.hypot(outline.half_width_m)
}

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

    /// Places the other vehicles' outlines in the world of vehicle `index`:
    /// those its scanners can reach (at least [`MIN_REACH_M`] about it).
    /// The rest are left out, so a scan of a large fleet tests a handful of
    /// neighbours, not every vehicle.
    pub fn share_with(&self, index: usize, world: &mut World) {
        let Some(own) = self.outlines.get(index) else {
            return;
        };
        let reach_m = world.scan_reach_m().max(MIN_REACH_M) + half_diagonal_m(own);
        let others = self
            .outlines
            .iter()
            .enumerate()
            .filter(move |&(i, other)| {
                let (dn, de) = (other.center[0] - own.center[0], other.center[1] - own.center[1]);
                let within_m = reach_m + half_diagonal_m(other);
                i != index && dn * dn + de * de <= within_m * within_m
            })
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
    fn only_the_vehicles_within_the_scanners_reach_are_shared() {
        let outline = VehicleOutline::default();
        // The scanner reaches 3.6 + 20 m ahead of the reference point.
        let mut worlds = [world_at(0.0, 0.0), world_at(25.0, 0.0), world_at(80.0, 0.0)];
        let mut fleet = FleetOutlines::default();
        fleet.gather(worlds.iter().map(|w| (w, outline)));
        fleet.share_with(0, &mut worlds[0]);
        assert_eq!(worlds[0].obstacles().map(|o| o.vehicles.len()), Some(1));
        fleet.share_with(2, &mut worlds[2]);
        assert_eq!(worlds[2].obstacles().map(|o| o.vehicles.len()), Some(0));
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
