//! One reading of the battery monitor.

/// What the battery monitor reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BatterySample {
    pub voltage_v: f64,
    pub current_a: f64,
    pub consumed_mah: f64,
    /// State of charge, 0–100.
    pub remaining_pct: f64,
}
