//! A simulated fleet: several simulated vehicles on one home frame, stepped
//! together, each seeing the others' outlines with its scanners (the shared
//! world is [`sim::FleetOutlines`]). No threads, no sockets, no clocks, like
//! [`Simulation`]: the same seeds and inputs give the same fleet.

use std::time::Duration;

use sim::FleetOutlines;

use super::simulation::Simulation;
use crate::time::TaskTimer;
use crate::vehicle::Outputs;

pub struct FleetSimulation {
    vehicles: Vec<Simulation>,
    outlines: FleetOutlines,
}

impl FleetSimulation {
    pub fn new(vehicles: Vec<Simulation>) -> Self {
        FleetSimulation {
            vehicles,
            outlines: FleetOutlines::default(),
        }
    }

    /// Places every vehicle's outline, where it is now, in the others'
    /// worlds (before a round of steps: each then sees the others as they
    /// were at the same instant, whatever order they are stepped in).
    pub fn share_world(&mut self) {
        self.outlines
            .gather(self.vehicles.iter().map(|v| (v.world(), v.outline())));
        for (index, vehicle) in self.vehicles.iter_mut().enumerate() {
            self.outlines.share_with(index, vehicle.world_mut());
        }
    }

    /// One round: the world shared, then every vehicle stepped by one core
    /// period. Each one's outputs wait in it ([`Simulation::outputs_mut`]).
    pub fn step(&mut self, wall: Duration, timer: &mut dyn TaskTimer) {
        self.share_world();
        for vehicle in &mut self.vehicles {
            vehicle.step(wall, timer);
        }
    }

    /// Steps vehicle `index` alone (the runner delivers each vehicle's
    /// outputs as it goes); call [`Self::share_world`] once before a round.
    pub fn step_one(&mut self, index: usize, wall: Duration, timer: &mut dyn TaskTimer) -> &mut Outputs {
        self.vehicles[index].step(wall, timer)
    }

    pub fn vehicles(&self) -> &[Simulation] {
        &self.vehicles
    }

    pub fn vehicles_mut(&mut self) -> &mut [Simulation] {
        &mut self.vehicles
    }

    /// The smallest gap between any vehicle's outline and anything else in
    /// its world, the other vehicles as last shared included (≤ 0: a
    /// collision). Infinite when there is nothing.
    pub fn closest_clearance_m(&self) -> f64 {
        self.vehicles
            .iter()
            .filter_map(|v| v.world().clearance_m(&v.outline()))
            .fold(f64::INFINITY, f64::min)
    }
}
