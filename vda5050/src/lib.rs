//! VDA 5050 2.1 message layer: the typed messages exchanged between a master
//! control and an AGV, the MQTT topic layout with its QoS/retain rules, and
//! parsing of incoming `order` / `instantActions` with clear errors.
//!
//! Pure: no I/O, no clock. Timestamps are handed in by the caller (the MQTT
//! edge), so the order logic built on top stays deterministic.
//!
//! Field names and enum values are spelled exactly as the official JSON
//! schemas spell them; the crate's tests validate every message type against
//! those schemas (vendored in `tests/data/vda5050`).

pub mod common;
pub mod connection;
pub mod factsheet;
pub mod header;
pub mod instant_actions;
pub mod order;
pub mod parse;
pub mod state;
pub mod topic;
pub mod visualization;

pub use connection::{Connection, ConnectionState};
pub use factsheet::Factsheet;
pub use header::{Header, PROTOCOL_VERSION, timestamp_from_unix_ms};
pub use instant_actions::InstantActions;
pub use order::Order;
pub use parse::{ParseError, parse_instant_actions, parse_order};
pub use state::State;
pub use topic::{Qos, Topic, TopicPrefix};
pub use visualization::Visualization;
