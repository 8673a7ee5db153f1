//! Telemetry: which messages each link gets and when, and the helpers that
//! build the identity and text messages every ground station expects.

pub mod identity;
pub mod statustext;
pub mod streams;
