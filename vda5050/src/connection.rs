//! The `connection` topic (§6.14): ONLINE, OFFLINE, or the last will.

use serde::{Deserialize, Serialize};

use crate::header::Header;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum ConnectionState {
    Online,
    Offline,
    /// Sent by the broker as the vehicle's last will.
    ConnectionBroken,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Connection {
    #[serde(flatten)]
    pub header: Header,
    pub connection_state: ConnectionState,
}
