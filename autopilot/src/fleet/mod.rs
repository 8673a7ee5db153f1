//! VDA 5050 2.1: the vehicle as an AGV of a fleet run by a master control
//! over MQTT (docs/architecture.md §Fleets).
//!
//! - [`map`]: the VDA map frame and the local frame;
//! - [`order`]: the order held, its validation, updates and cancellation;
//! - [`actions`]: action states, blocking types and the outputs they drive;
//! - [`agent`]: the whole vehicle side stepped with time: payloads in,
//!   a drive command and messages out;
//! - [`state`]: the `state` and `visualization` messages;
//! - [`factsheet`]: the `factsheet` from the vehicle's parameters;
//! - [`loads`]: the loads on the vehicle, from its pick and drop actions;
//! - [`trajectory`]: an edge's NURBS, checked and cut into chords;
//! - [`traversal`]: when a node counts as traversed;
//! - [`publish`]: headers stamped and topics, QoS and retain for each.
//!
//! All of it is pure; the core steps the agent (`vehicle/fleet.rs`) and the
//! MQTT edge carries the bytes.

pub mod actions;
pub mod agent;
pub mod factsheet;
pub mod loads;
pub mod map;
pub mod order;
pub mod publish;
pub mod state;
pub mod trajectory;
pub mod traversal;

pub use agent::{Agent, AgentConfig, Command, Leg, OrderEvent, Publish, VehicleView};
pub use state::VehicleReport;

#[cfg(test)]
mod tests;
