//! Battery pack: coulomb counting, linear open-circuit voltage, I·R sag.

use super::{BatterySample, BatterySimConfig};

#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Battery {
    consumed_mah: f64,
    current_a: f64,
}

/// 1 mAh is 3.6 A·s.
const AS_PER_MAH: f64 = 3.6;

impl Battery {
    /// Draw for `h_s` seconds while moving at `speed_mps` (magnitude) and
    /// changing speed at `accel_mps2` (magnitude).
    pub(crate) fn step(&mut self, cfg: &BatterySimConfig, speed_mps: f64, accel_mps2: f64, h_s: f64) {
        self.current_a =
            cfg.idle_current_a + cfg.drive_current_a_per_mps * speed_mps + cfg.accel_current_a_per_mps2 * accel_mps2;
        self.consumed_mah += self.current_a * h_s / AS_PER_MAH;
    }

    pub(crate) fn sample(&self, cfg: &BatterySimConfig) -> BatterySample {
        let capacity_mah = cfg.capacity_ah * 1000.0;
        let soc = if capacity_mah > 0.0 {
            (1.0 - self.consumed_mah / capacity_mah).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let open_circuit_v = cfg.empty_voltage_v + (cfg.full_voltage_v - cfg.empty_voltage_v) * soc;
        BatterySample {
            voltage_v: open_circuit_v - self.current_a * cfg.internal_resistance_ohm,
            current_a: self.current_a,
            consumed_mah: self.consumed_mah,
            remaining_pct: soc * 100.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn idle_drain_and_sag() {
        let cfg = BatterySimConfig::default();
        let mut battery = Battery::default();
        // One hour idle at 2 A: 2000 mAh of 100 Ah.
        for _ in 0..3600 {
            battery.step(&cfg, 0.0, 0.0, 1.0);
        }
        let s = battery.sample(&cfg);
        assert!((s.consumed_mah - 2000.0).abs() < 1e-6);
        assert!((s.remaining_pct - 98.0).abs() < 1e-9);
        let ocv = 42.0 + 12.6 * 0.98;
        assert!((s.voltage_v - (ocv - 2.0 * 0.05)).abs() < 1e-9);
        // Driving draws more and sags the voltage further.
        battery.step(&cfg, 2.0, 1.0, 0.01);
        let driving = battery.sample(&cfg);
        assert!((driving.current_a - (2.0 + 16.0 + 25.0)).abs() < 1e-12);
        assert!(driving.voltage_v < s.voltage_v);
    }
}
