//! GNSS samples and the NMEA 0183 stream parser.
//!
//! The parser ([`NmeaReader`]) turns a byte stream from a receiver (serial
//! port, TCP, or the SITL world) into [`GnssSample`]s. It keeps no navigation
//! state of its own: each sentence stands alone, so an RTK fix from GGA is never
//! overwritten by a later RMC (the trap in the `nmea` crate's stateful parser).

pub mod port;
mod reader;
mod sentences;
#[cfg(test)]
mod tests;

use std::time::Duration;

pub use reader::{MAX_SENTENCE_LEN, NmeaReader};

/// GGA fix quality (field 6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FixQuality {
    /// 0: no fix.
    NoFix,
    /// 1 (and 3, PPS): autonomous single-point fix.
    Single,
    /// 2: differential (SBAS/DGPS).
    Dgps,
    /// 5: RTK with float ambiguities (decimetres).
    RtkFloat,
    /// 4: RTK with fixed ambiguities (centimetres or better).
    RtkFixed,
    /// 6: estimated (dead reckoning).
    DeadReckoning,
    /// 7: manual input.
    Manual,
    /// 8: simulator.
    Simulation,
}

impl FixQuality {
    /// The GGA quality digit for this fix.
    pub fn gga_digit(self) -> u8 {
        match self {
            FixQuality::NoFix => 0,
            FixQuality::Single => 1,
            FixQuality::Dgps => 2,
            FixQuality::RtkFixed => 4,
            FixQuality::RtkFloat => 5,
            FixQuality::DeadReckoning => 6,
            FixQuality::Manual => 7,
            FixQuality::Simulation => 8,
        }
    }

    /// The NMEA 2.3 FAA mode letter (RMC/VTG/GNS) matching this fix.
    pub fn faa_mode(self) -> char {
        match self {
            FixQuality::NoFix => 'N',
            FixQuality::Single => 'A',
            FixQuality::Dgps => 'D',
            FixQuality::RtkFixed => 'R',
            FixQuality::RtkFloat => 'F',
            FixQuality::DeadReckoning => 'E',
            FixQuality::Manual => 'M',
            FixQuality::Simulation => 'S',
        }
    }

    /// Whether the receiver claims a position computed from satellites.
    pub fn has_position(self) -> bool {
        matches!(
            self,
            FixQuality::Single | FixQuality::Dgps | FixQuality::RtkFloat | FixQuality::RtkFixed
        )
    }
}

/// Position fix from GGA. Without a fix (quality 0 or empty position),
/// `quality` is [`FixQuality::NoFix`] and `lat_deg`/`lon_deg` are NaN so the
/// consumer sees the loss rather than a stale position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssFix {
    pub t: Duration,
    /// UTC seconds since midnight as stamped by the receiver.
    pub utc_time_of_day_s: Option<f64>,
    pub lat_deg: f64,
    pub lon_deg: f64,
    /// Altitude above mean sea level; NaN if the field is empty.
    pub alt_msl_m: f64,
    pub quality: FixQuality,
    /// Satellites used (saturates at 255); 0 if the field is empty.
    pub satellites: u8,
    /// Horizontal dilution of precision; NaN if the field is empty.
    pub hdop: f32,
}

/// Velocity over ground from RMC or VTG (of the antenna).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssVelocity {
    pub t: Duration,
    /// Speed over ground, never negative (NMEA has no sign: see `course_deg`).
    pub speed_mps: f64,
    /// Course over ground, true, 0 = north, clockwise; `None` when the receiver
    /// leaves it empty (typically when nearly stationary).
    pub course_deg: Option<f64>,
}

/// One-sigma position errors from GST.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssAccuracy {
    pub t: Duration,
    pub sigma_north_m: f64,
    pub sigma_east_m: f64,
    pub sigma_up_m: Option<f64>,
}

/// What a heading is measured from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeadingReference {
    /// True north: a dual-antenna receiver (HDT, THS).
    True,
    /// Magnetic north: a compass (HDM, HDG with its deviation applied); the
    /// user of the sample adds the declination.
    Magnetic,
}

/// A heading: true from HDT or THS in autonomous mode, magnetic from HDM
/// or HDG.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssHeading {
    pub t: Duration,
    /// 0 = north, clockwise, as sent (nominally [0, 360)).
    pub heading_deg: f64,
    pub reference: HeadingReference,
}

/// UTC from RMC date and time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GnssTime {
    pub t: Duration,
    /// Microseconds since the Unix epoch (no leap seconds, as NMEA reports UTC).
    pub utc_unix_us: i64,
}

/// One measurement, stamped with the time the bytes were pushed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GnssSample {
    Fix(GnssFix),
    Velocity(GnssVelocity),
    Accuracy(GnssAccuracy),
    Heading(GnssHeading),
    Time(GnssTime),
    /// An inertial unit's rates and accelerations (VectorNav `$VNIMU` or
    /// `$VNYMR`, see [`crate::imu`]), on a port of its own.
    Imu(crate::imu::ImuSample),
}

/// Counters of a reader. Every non-empty line (a `$` also starts a new line,
/// so garbage before it is a line of its own) lands in exactly one counter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NmeaStats {
    /// Sentences of a consumed type (GGA, RMC, VTG, GST, HDT, THS, HDM, HDG)
    /// that parsed.
    pub sentences: u64,
    /// Well-framed sentences whose checksum did not match.
    pub checksum_errors: u64,
    /// Garbage, non-ASCII bytes, missing checksum, truncated or unparsable fields.
    pub malformed: u64,
    /// Well-formed sentences with a valid checksum of a type we do not consume.
    pub unsupported: u64,
    /// Lines longer than [`MAX_SENTENCE_LEN`] (counted once, when they cross it).
    pub overlong: u64,
}

impl NmeaStats {
    /// All lines seen, whatever became of them.
    pub fn total(&self) -> u64 {
        self.sentences + self.checksum_errors + self.malformed + self.unsupported + self.overlong
    }
}

/// XOR of the bytes between `$` and `*`: the NMEA 0183 checksum.
pub fn nmea_checksum(body: &[u8]) -> u8 {
    body.iter().fold(0, |acc, b| acc ^ b)
}
