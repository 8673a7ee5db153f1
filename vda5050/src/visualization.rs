//! The `visualization` topic (§6.13): position and velocity at a higher rate
//! than `state`, for display only.

use serde::{Deserialize, Serialize};

use crate::common::{AgvPosition, Velocity};
use crate::header::Header;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Visualization {
    #[serde(flatten)]
    pub header: Header,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub agv_position: Option<AgvPosition>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity: Option<Velocity>,
}
