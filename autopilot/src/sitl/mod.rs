//! SITL: the same core, with the device drivers replaced by a simulated
//! world whose devices emit the real bytes, and wall time replaced by
//! simulated time.
//!
//! - [`params`]: the `SIM_*` parameters (settable at run time);
//!   [`faults`]: the faults some of them inject.
//! - [`simulation`]: world + NMEA driver + core stepped together, no I/O;
//!   used by the runner, the benchmarks and the in-process tests.
//! - [`runner`]: `furrow sitl`: the simulation as a platform of the edge
//!   runner ([`crate::edge`]), paced against the wall clock by `SIM_SPEEDUP`.
//! - [`fleet`], [`fleet_homes`], [`fleet_runner`]: `furrow sitl --fleet N`,
//!   several simulated vehicles in one process sharing one world.
//! - [`magnetic_scenario`]: the world's vehicle driven by the magnetic guide
//!   alone, no core: tape re-acquisition for tests and `furrow-bench magnetic`.

pub mod faults;
pub mod fleet;
pub mod fleet_homes;
pub mod fleet_runner;
pub mod gcs;
pub mod magnetic_scenario;
pub mod params;
pub mod runner;
pub mod simulation;
pub mod tape;
