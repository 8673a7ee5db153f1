//! Magnetic-tape guide sensors: two 16-probe bars (front and rear) that each
//! report which probes are over the tape as a bitmask.

use std::time::Duration;

/// One reading of both sensors. Bit i−1 of a mask is probe i; probe 1 is
/// the rightmost, so a tape to the vehicle's right triggers low probes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MagneticSample {
    pub t: Duration,
    pub front_mask: u16,
    pub rear_mask: u16,
}
