//! Furrow's autopilot: the pure core and the edges that feed it.
//!
//! Layout (the core first, then the edges):
//! - [`vehicle`]: the [`vehicle::Core`], a plain struct stepped at
//!   `SCHED_LOOP_RATE` with injected time; it owns the parameters and every
//!   subsystem below and does no I/O.
//! - [`sched`]: the scheduler table (task, rate, budget) and its statistics.
//! - [`geo`]: local frames from latitude/longitude.
//! - [`estimation`]: the pose estimate from GNSS position and heading.
//! - [`guidance`]: paths, the preview-point tracker, speed scheduling.
//! - [`control`]: PID, speed control, actuator mixing.
//! - [`modes`]: ArduPilot Rover's mode numbers and each mode's behaviour.
//! - [`fence`]: the geofence geometry.
//! - [`telemetry`]: MAVLink messages built from the core's state, and the
//!   per-link stream rates.
//! - [`link`] (edge): sockets, serial ports, framing, routing, tlog.
//! - [`ftp`]: MAVLink FTP (the protocol pure, its file I/O on a worker
//!   thread at the edge).
//! - [`sitl`] (edge): the simulated world stepped with the core, and the
//!   runner that paces both against the wall clock.
//! - [`storage`] (edge): the data directory and parameter persistence.
//! - [`run`] (edge): the real vehicle (`furrow run --config FILE`).
//! - [`offline`]: tools on a data directory (`furrow params …`) and
//!   `furrow config check`.

pub mod bench;
pub mod control;
pub mod estimation;
pub mod fence;
pub mod ftp;
pub mod geo;
pub mod guidance;
pub mod link;
pub mod modes;
pub mod obstacles;
pub mod offline;
pub mod run;
pub mod sched;
pub mod sitl;
pub mod storage;
pub mod telemetry;
pub mod time;
pub mod vehicle;
