//! `furrow run`: the real vehicle, with the same core as SITL and real
//! device drivers in place of the simulated world.

pub mod actuators;
pub mod config;
pub mod devices;
pub mod runner;
pub mod status;
