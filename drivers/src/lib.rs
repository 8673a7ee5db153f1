//! Furrow device drivers and the simulated world.
//!
//! - [`backoff`]: the reconnect wait every device and link uses.
//! - [`gnss`]: GNSS sample types and the NMEA 0183 stream parser that the real
//!   serial driver and SITL both feed.
//! - [`magnetic`]: magnetic-tape guide sensor readings.
//! - [`sim`]: the SITL world (vehicle physics, battery) whose simulated GNSS
//!   receiver writes the same NMEA bytes a real RTK receiver would, so SITL
//!   exercises the real parser.
//!
//! Everything here is pure and deterministic: time is passed in as a
//! [`std::time::Duration`] since start, randomness comes from a caller's seed.

pub mod backoff;
pub mod device;
pub mod gnss;
pub mod magnetic;
pub mod magnetic_serial;
pub mod ntrip;
pub mod pwm;
pub mod rtcm;
pub mod scanner;
pub mod sim;
