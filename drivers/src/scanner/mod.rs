//! 2D laser scanners (SICK LMS1xx class): one scan as measured, the CoLa-A
//! protocol the real scanner speaks over TCP, and the client that keeps a
//! connection to it.
//!
//! Angles are in the scanner's own frame: radians from its forward axis,
//! positive clockwise seen from above (the same sense as the vehicle's
//! headings), so a beam at +90° looks to the scanner's right.

pub mod client;
pub mod cola;

use std::time::Duration;

/// One scan: beam `i` points at `start_angle_rad + i·step_rad`.
#[derive(Clone, Debug, PartialEq)]
pub struct Scan {
    /// When the scan was received (the clock of the reader that pushed it).
    pub t: Duration,
    /// The scanner's own scan counter (gaps show lost scans).
    pub scan_counter: u32,
    pub start_angle_rad: f64,
    /// Signed: negative when successive beams go anticlockwise.
    pub step_rad: f64,
    /// Metres; `f32::NAN` where the beam saw nothing (no echo, dropout,
    /// beyond range).
    pub ranges_m: Vec<f32>,
}

impl Scan {
    pub fn angle_rad(&self, beam: usize) -> f64 {
        self.start_angle_rad + beam as f64 * self.step_rad
    }

    /// (angle, range) of every beam with an echo.
    pub fn returns(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.ranges_m
            .iter()
            .enumerate()
            .filter(|(_, r)| r.is_finite())
            .map(|(i, r)| (self.angle_rad(i), f64::from(*r)))
    }
}
