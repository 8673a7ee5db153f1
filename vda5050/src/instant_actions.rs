//! The `instantActions` topic (§6.9): actions to run now, outside any order.

use serde::{Deserialize, Serialize};

use crate::common::Action;
use crate::header::Header;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct InstantActions {
    #[serde(flatten)]
    pub header: Header,
    pub actions: Vec<Action>,
}
