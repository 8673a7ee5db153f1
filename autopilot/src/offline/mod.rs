//! Offline tools: commands that work on a data directory while no autopilot
//! runs on it.

pub mod mission;
pub mod params;
