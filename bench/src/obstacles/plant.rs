//! How the simulated plant truly brakes: the judges' only measure of what
//! a vehicle could have done, in place of Furrow's own `OA_REACT_TIME` and
//! `OA_DECEL` (allowances the autopilot chose).
//!
//! The simulated drive is a first-order lag of time constant `tau` whose
//! rate is clipped at `brake_max` while the speed shrinks (`sim`'s
//! actuator). Under a zero command from the tick the stop is decided (the
//! simulation applies a tick's command over the next world step, so there
//! is no further delay), the speed `v0` falls
//! - linearly at `brake_max` while `v > brake_max·tau` (the lag would ask
//!   for more than the limit), then
//! - exponentially, `v·e^(−t/tau)`, below that band,
//!
//! and the vehicle is at rest once under [`MOVING_MPS`] (the judge's rest).
//! Stopping distance `(v0² − b²)/(2·brake_max) + (b − MOVING_MPS)·tau` with
//! `b = min(v0, brake_max·tau)`: 1.09 m from 2 m/s and 0.34 m from 1 m/s
//! with the simulated car's 0.3 s and 2 m/s².

use sim::VehicleModel;

use super::truth::MOVING_MPS;

/// The plant's hardest stop from a zero drive command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantBraking {
    /// The drive's first-order lag, s.
    pub tau_s: f64,
    /// Its deceleration limit, m/s².
    pub brake_max_mps2: f64,
}

impl PlantBraking {
    /// The simulated vehicle's drive (a differential vehicle's wheels brake
    /// alike, so its centre brakes as one wheel).
    pub fn of(model: &VehicleModel) -> Self {
        match model {
            VehicleModel::Ackermann(c) => PlantBraking {
                tau_s: c.speed_tau_s,
                brake_max_mps2: c.brake_max_mps2,
            },
            VehicleModel::Differential(c) => PlantBraking {
                tau_s: c.wheel_tau_s,
                brake_max_mps2: c.brake_max_mps2,
            },
        }
    }

    /// Below this speed the lag, not the limit, sets the braking.
    fn band_mps(&self) -> f64 {
        self.brake_max_mps2 * self.tau_s
    }

    /// Seconds of linear braking before the lag takes over.
    fn linear_s(&self, v0_mps: f64) -> f64 {
        (v0_mps - self.band_mps()).max(0.0) / self.brake_max_mps2
    }

    /// Speed `t_s` after the zero command, from `v0_mps` (magnitudes).
    pub fn speed_mps(&self, v0_mps: f64, t_s: f64) -> f64 {
        let v0 = v0_mps.abs();
        let linear_s = self.linear_s(v0);
        if t_s <= linear_s {
            return v0 - self.brake_max_mps2 * t_s;
        }
        v0.min(self.band_mps()) * (-(t_s - linear_s) / self.tau_s).exp()
    }

    /// Distance run `t_s` after the zero command, from `v0_mps`.
    pub fn distance_m(&self, v0_mps: f64, t_s: f64) -> f64 {
        let v0 = v0_mps.abs();
        let linear_s = self.linear_s(v0);
        let t1 = t_s.min(linear_s);
        let linear_m = v0 * t1 - self.brake_max_mps2 * t1 * t1 / 2.0;
        let lag_s = (t_s - linear_s).max(0.0);
        linear_m + v0.min(self.band_mps()) * self.tau_s * (1.0 - (-lag_s / self.tau_s).exp())
    }

    /// Seconds from the zero command to rest (under [`MOVING_MPS`]).
    pub fn stopping_s(&self, v0_mps: f64) -> f64 {
        let v0 = v0_mps.abs();
        let b = v0.min(self.band_mps());
        if b <= MOVING_MPS {
            return 0.0;
        }
        self.linear_s(v0) + self.tau_s * (b / MOVING_MPS).ln()
    }

    /// Distance from the zero command to rest.
    pub fn stopping_m(&self, v0_mps: f64) -> f64 {
        self.distance_m(v0_mps, self.stopping_s(v0_mps))
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use sim::{World, WorldConfig};
    use vehicle_types::ActuatorDemand;

    use super::*;

    /// The simulated car driven to `v_mps`, then given a zero command:
    /// distance and time until it is under [`MOVING_MPS`].
    fn measured_stop(v_mps: f64) -> (f64, f64) {
        let config = WorldConfig::default();
        let VehicleModel::Ackermann(car) = config.vehicle else {
            panic!("the default world drives the car");
        };
        let mut world = World::new(config, 1);
        let tick = Duration::from_millis(20);
        let cruise = ActuatorDemand::Ackermann {
            steering: 0.0,
            throttle: v_mps / car.speed_max_mps,
        };
        for _ in 0..500 {
            world.step(tick, &cruise);
        }
        assert!((world.truth().speed_mps - v_mps).abs() < 1e-6);
        let stop = ActuatorDemand::STOP;
        let from = *world.truth();
        let mut ticks = 0;
        while world.truth().speed_mps > MOVING_MPS {
            world.step(tick, &stop);
            ticks += 1;
        }
        let to = world.truth();
        let run_m = (to.north_m - from.north_m).hypot(to.east_m - from.east_m);
        (run_m, f64::from(ticks) * 0.02)
    }

    #[test]
    fn the_closed_form_is_the_simulated_drive() {
        let plant = PlantBraking::of(&WorldConfig::default().vehicle);
        for v_mps in [0.3, 1.0, 1.5, 2.0] {
            let (run_m, took_s) = measured_stop(v_mps);
            assert!(
                (plant.stopping_m(v_mps) - run_m).abs() < 0.005,
                "{v_mps} m/s: {} against {run_m}",
                plant.stopping_m(v_mps)
            );
            // The simulation reaches rest within the tick that crosses it.
            let s = plant.stopping_s(v_mps);
            assert!(
                took_s >= s - 1e-9 && took_s < s + 0.02,
                "{v_mps} m/s: {s} against {took_s}"
            );
        }
    }

    #[test]
    fn speed_and_distance_agree() {
        let plant = PlantBraking {
            tau_s: 0.3,
            brake_max_mps2: 2.0,
        };
        // Linear to 0.6 m/s in 0.7 s over 0.91 m, then the lag.
        assert!((plant.speed_mps(2.0, 0.7) - 0.6).abs() < 1e-12);
        assert!((plant.distance_m(2.0, 0.7) - 0.91).abs() < 1e-12);
        assert!((plant.distance_m(2.0, 100.0) - 1.09).abs() < 1e-9);
        let (mut v, mut d, h) = (2.0, 0.0, 1e-4);
        for k in 0..20_000 {
            let v1 = plant.speed_mps(2.0, f64::from(k + 1) * h);
            d += h * (v + v1) / 2.0;
            v = v1;
        }
        assert!((d - plant.distance_m(2.0, 2.0)).abs() < 1e-6);
        assert_eq!(plant.stopping_m(0.005), 0.0);
    }
}
