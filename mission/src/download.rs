//! The download half of the mission protocol: MISSION_REQUEST_LIST,
//! MISSION_REQUEST_INT and the deprecated MISSION_REQUEST are stateless
//! reads of the plans in force (and of home, mission item 0), so one
//! [`Downloads`] value answers them wherever it is held. The protocol
//! answers from its own; the link layer answers from the copy the core
//! published, so a ground station's item-by-item download runs at the
//! link's round trip instead of through the core's thread
//! (docs/architecture.md §Mission downloads at the link).

// MISSION_REQUEST is deprecated, and must still be served.
#![allow(deprecated)]

use mavlink::dialects::ardupilotmega::{MISSION_COUNT_DATA, MavMessage, MavMissionResult, MavMissionType};

use crate::item::{MissionItem, MissionType};
use crate::protocol::{HomeItem, Plans, Sender, ack, item_message};

/// What a download reads: the plans in force and the current home.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Downloads {
    plans: Plans,
    home: Option<HomeItem>,
}

impl Downloads {
    pub fn new(plans: Plans, home: Option<HomeItem>) -> Self {
        Downloads { plans, home }
    }

    pub fn plans(&self) -> &Plans {
        &self.plans
    }

    pub fn home(&self) -> Option<HomeItem> {
        self.home
    }

    pub(crate) fn set_plan(&mut self, mission_type: MissionType, plan: crate::item::Plan) {
        self.plans.set(mission_type, plan);
    }

    pub(crate) fn set_home(&mut self, home: Option<HomeItem>) {
        self.home = home;
    }

    /// Whether [`Downloads::answer`] answers this message.
    pub fn is_request(message: &MavMessage) -> bool {
        matches!(
            message,
            MavMessage::MISSION_REQUEST_LIST(_) | MavMessage::MISSION_REQUEST_INT(_) | MavMessage::MISSION_REQUEST(_)
        )
    }

    /// The reply to a download request from `sender` (already known to be
    /// addressed to us); `None` for any other message.
    pub fn answer(&self, sender: Sender, message: &MavMessage) -> Option<MavMessage> {
        Some(match message {
            MavMessage::MISSION_REQUEST_LIST(m) => self.count_reply(sender, m.mission_type),
            MavMessage::MISSION_REQUEST_INT(m) => self.item_reply(sender, m.seq, m.mission_type),
            // Deprecated: answered with MISSION_ITEM_INT, as the XML says.
            MavMessage::MISSION_REQUEST(m) => self.item_reply(sender, m.seq, m.mission_type),
            _ => return None,
        })
    }

    /// How many items a download of `mission_type` has.
    fn count(&self, mission_type: MissionType) -> u16 {
        let len = self.plans.get(mission_type).len() as u16;
        if mission_type == MissionType::Mission && self.home.is_some() {
            len.max(1)
        } else {
            len
        }
    }

    /// The item a download returns at `seq` (< the download count).
    fn item(&self, mission_type: MissionType, seq: u16) -> Option<MissionItem> {
        if mission_type == MissionType::Mission
            && seq == 0
            && let Some(home) = self.home
        {
            return Some(home.to_item());
        }
        self.plans.get(mission_type).items().get(usize::from(seq)).copied()
    }

    fn count_reply(&self, sender: Sender, raw_type: MavMissionType) -> MavMessage {
        match MissionType::from_mavlink(raw_type) {
            Some(mission_type) => MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
                count: self.count(mission_type),
                target_system: sender.system_id,
                target_component: sender.component_id,
                mission_type: raw_type,
                opaque_id: self.plans.get(mission_type).opaque_id(),
            }),
            None => ack(sender, raw_type, MavMissionResult::MAV_MISSION_UNSUPPORTED, 0),
        }
    }

    fn item_reply(&self, sender: Sender, seq: u16, raw_type: MavMissionType) -> MavMessage {
        match MissionType::from_mavlink(raw_type) {
            None => ack(sender, raw_type, MavMissionResult::MAV_MISSION_UNSUPPORTED, 0),
            Some(mission_type) if seq >= self.count(mission_type) => {
                ack(sender, raw_type, MavMissionResult::MAV_MISSION_INVALID_SEQUENCE, 0)
            }
            Some(mission_type) => self
                .item(mission_type, seq)
                .and_then(|item| item_message(&item, mission_type, sender))
                .unwrap_or_else(|| ack(sender, raw_type, MavMissionResult::MAV_MISSION_ERROR, 0)),
        }
    }
}
