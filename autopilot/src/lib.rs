//! Furrow's autopilot: the pure core and the edges that feed it
//! (docs/architecture.md has the map).
//!
//! The core first (no I/O, time injected):
//! - [`vehicle`]: the [`vehicle::Core`], a plain struct stepped at
//!   `SCHED_LOOP_RATE`; it owns the parameters and every subsystem below,
//!   handles MAVLink messages, runs the modes, arming and failsafes, and
//!   builds telemetry.
//! - [`time`]: the two clocks a step is given (vehicle time, wall time) and
//!   the injected task timer.
//! - [`sched`]: the scheduler table (task, rate, clock, budget) and its statistics.
//! - [`geo`]: local frames from latitude/longitude.
//! - [`estimation`]: the pose estimate (EKF) from GNSS position and heading.
//! - [`guidance`]: paths, the preview-point tracker, speed scheduling, the
//!   navigator and the magnetic guide.
//! - [`control`]: PID, speed control, kinematics, mixing and servo outputs.
//! - [`obstacles`]: scans to clusters to tracks, collision prediction along
//!   the swept path, the stop/pass/detour policy.
//! - [`modes`]: ArduPilot Rover's mode numbers, names and properties (what
//!   each mode does each tick is in `vehicle/modes/`, one file per mode).
//! - [`fence`]: the geofence geometry.
//! - [`fleet`]: the VDA 5050 agent: orders, actions and the messages a
//!   master control reads, stepped with time.
//! - [`telemetry`]: identity, STATUSTEXT and the per-link stream rates.
//!
//! The edges:
//! - [`edge`]: the runner `furrow sitl` and `furrow run` share: one tokio
//!   runtime, the links, the data directory, the loop and its clocks, the
//!   VDA 5050 MQTT client.
//! - [`link`]: sockets, serial ports, framing, signing, routing, tlog.
//! - [`ftp`]: MAVLink FTP (the protocol pure, its file I/O on a worker
//!   thread at the edge).
//! - [`logging`]: onboard DataFlash logs: records built by the core,
//!   written and served over MAVLink at the edge, read by `furrow logs`.
//! - [`sitl`]: `furrow sitl`: the simulated world stepped with the core, as
//!   a platform of the edge runner paced against the wall clock.
//! - [`run`]: `furrow run --config FILE`: the real vehicle.
//! - [`storage`]: the data directory and atomic persistence.
//! - [`stderr_log`]: the diagnostic log every binary writes to stderr.
//! - [`offline`]: tools on a data directory (`furrow params …`,
//!   `furrow mission …`, `furrow logs …`) and
//!   `furrow config check`.

pub mod control;
pub mod edge;
pub mod estimation;
pub mod fence;
pub mod fleet;
pub mod ftp;
pub mod geo;
pub mod guidance;
pub mod link;
pub mod logging;
pub mod modes;
pub mod obstacles;
pub mod offline;
pub mod run;
pub mod sched;
pub mod shared_thread;
pub mod sitl;
pub mod stderr_log;
pub mod storage;
pub mod telemetry;
pub mod time;
pub mod vehicle;
