//! The edge runner shared by `furrow sitl` and `furrow run`: one tokio
//! runtime, the link layer on sockets bound beforehand, the data directory,
//! and a loop that steps the core and answers link traffic between ticks,
//! until a shutdown future completes.
//!
//! What differs between the simulator and the real vehicle is a
//! [`runner::Platform`]: the core with its devices (a simulated world, or
//! real drivers and outputs) and its clock ([`clock::Pacer`] for simulated
//! time paced against the wall, [`clock::WallTicks`] for a fixed period).
//!
//! - [`clock`]: the task timer and the two tick clocks.
//! - [`persistence`]: stored plans and parameters in, the core's saves out.
//! - [`mqtt`]: the VDA 5050 client, when the vehicle is an AGV of a fleet;
//!   [`mqtt_tls`] its TLS (`mqtts://`).
//! - [`shutdown`]: the shutdown future (SIGINT or SIGTERM).
//! - [`runner`]: the loop.
//! - [`fleet`]: the loop for several vehicles in one process (a simulated
//!   fleet sharing one world).

pub mod clock;
pub mod fleet;
pub mod mqtt;
pub mod mqtt_tls;
pub mod persistence;
pub mod runner;
pub mod shutdown;

/// The one tokio runtime of a running furrow. The core's loop runs on the
/// calling thread (`block_on`); links and async devices run on its worker,
/// so they never wait for a tick and a tick never waits for them.
pub fn runtime() -> std::io::Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .thread_name("edge")
        .enable_all()
        .build()
}
