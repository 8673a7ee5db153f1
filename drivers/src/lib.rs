//! Furrow's device drivers: the real devices and their parsers.
//!
//! - [`gnss`]: GNSS sample types, the NMEA 0183 stream parser that the real
//!   receiver and SITL both feed, and the port thread that reads a receiver.
//! - [`imu`]: inertial samples and the VectorNav ASCII lines that carry
//!   them (read by the NMEA parser, on a port of their own).
//! - [`scanner`]: laser scans, the SICK CoLa-A telegrams and the scanner client.
//! - [`magnetic`], [`magnetic_serial`]: magnetic-tape guide readings and the
//!   sensor pair's serial framing and reader thread.
//! - [`ntrip`], [`rtcm`]: RTK corrections from a caster, and RTCM fragments
//!   reassembled from MAVLink.
//! - [`pwm`]: servo and ESC pulses through Linux sysfs PWM.
//! - [`backoff`]: the reconnect wait every device and link uses.
//! - [`clock`]: the time a device thread reads (the wall, or a test's manual clock).
//! - [`device`]: the health counters each device thread shares with the core's edge.
//! - [`fixed_decimal`]: numbers with a fixed count of decimals, as the simulated devices write them.
//!
//! The simulated world whose devices emit the same bytes lives in the `sim`
//! crate, which depends on this one for the parsers' types.
//!
//! The parsers are pure and deterministic: time is passed in as a
//! [`std::time::Duration`] since start. The device threads and clients (`gnss::port`,
//! `scanner::client`, `magnetic_serial`, `ntrip`, `pwm`) do I/O: they own a
//! port, a socket or files, and are the edges the real vehicle runs.

pub mod backoff;
pub mod clock;
pub mod device;
pub mod fixed_decimal;
pub mod gnss;
pub mod imu;
pub mod magnetic;
pub mod magnetic_serial;
pub mod ntrip;
pub mod pwm;
pub mod rtcm;
pub mod scanner;
