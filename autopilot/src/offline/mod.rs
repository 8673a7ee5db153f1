//! Offline tools: commands that work on a data directory while no autopilot
//! runs on it.

pub mod config;
pub mod logs;
pub mod mission;
pub mod params;
