//! What Furrow's tests share, reachable from unit tests (`#[cfg(test)]`
//! modules) and integration tests alike: a dev-dependency of the crates
//! that use it, never built into a shipping binary.
//!
//! - [`noise`]: seeded Gaussian noise (ChaCha8), the same seed giving the
//!   same samples on every machine.
//! - [`vda5050`]: VDA 5050 orders and instant actions as a master control
//!   would send them.
//! - [`net`]: a loopback address that refuses connections, its port held.
//!
//! Scratch directories come from `tempfile` directly.

pub mod net;
pub mod noise;
pub mod vda5050;
