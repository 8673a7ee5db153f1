//! Stored items: the fields of MISSION_ITEM_INT with the command and frame
//! as raw numbers, so a plan downloads exactly as it was uploaded.

use mavlink::dialects::ardupilotmega::{MISSION_ITEM_INT_DATA, MavMissionType};

/// Which of the three independent plans (`mission_type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum MissionType {
    Mission,
    Fence,
    Rally,
}

impl MissionType {
    pub const ALL: [MissionType; 3] = [MissionType::Mission, MissionType::Fence, MissionType::Rally];

    pub fn from_mavlink(t: MavMissionType) -> Option<MissionType> {
        match t {
            MavMissionType::MAV_MISSION_TYPE_MISSION => Some(MissionType::Mission),
            MavMissionType::MAV_MISSION_TYPE_FENCE => Some(MissionType::Fence),
            MavMissionType::MAV_MISSION_TYPE_RALLY => Some(MissionType::Rally),
            _ => None,
        }
    }

    pub fn to_mavlink(self) -> MavMissionType {
        match self {
            MissionType::Mission => MavMissionType::MAV_MISSION_TYPE_MISSION,
            MissionType::Fence => MavMissionType::MAV_MISSION_TYPE_FENCE,
            MissionType::Rally => MavMissionType::MAV_MISSION_TYPE_RALLY,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            MissionType::Mission => "mission",
            MissionType::Fence => "fence",
            MissionType::Rally => "rally",
        }
    }
}

/// One item as MISSION_ITEM_INT carries it. For global frames `x`/`y` are
/// degrees × 1e7; for local frames metres × 1e4 (0.1 mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MissionItem {
    pub seq: u16,
    /// `MAV_FRAME` number.
    pub frame: u8,
    /// `MAV_CMD` number.
    pub command: u16,
    pub current: bool,
    pub autocontinue: bool,
    pub params: [f32; 4],
    pub x: i32,
    pub y: i32,
    pub z: f32,
}

impl MissionItem {
    pub fn from_mavlink(m: &MISSION_ITEM_INT_DATA) -> MissionItem {
        MissionItem {
            seq: m.seq,
            frame: m.frame as u8,
            command: m.command as u16,
            current: m.current != 0,
            autocontinue: m.autocontinue != 0,
            params: [m.param1, m.param2, m.param3, m.param4],
            x: m.x,
            y: m.y,
            z: m.z,
        }
    }

    /// `param5`/`param6` as MISSION_ITEM (float) would carry them.
    pub fn x_float(&self) -> f64 {
        f64::from(self.x) * 1e-7
    }

    /// Bytes that identify the item's content (for plan ids).
    pub fn content_bytes(&self) -> [u8; 38] {
        let mut b = [0u8; 38];
        b[0..2].copy_from_slice(&self.seq.to_le_bytes());
        b[2] = self.frame;
        b[3..5].copy_from_slice(&self.command.to_le_bytes());
        b[5] = u8::from(self.current);
        b[6] = u8::from(self.autocontinue);
        for (i, p) in self.params.iter().enumerate() {
            b[7 + 4 * i..11 + 4 * i].copy_from_slice(&p.to_bits().to_le_bytes());
        }
        b[23..27].copy_from_slice(&self.x.to_le_bytes());
        b[27..31].copy_from_slice(&self.y.to_le_bytes());
        b[31..35].copy_from_slice(&self.z.to_bits().to_le_bytes());
        b
    }
}

/// A plan and its opaque id (mavlink.io "Detecting Plan Changes"): a CRC of
/// its content, so the same plan always has the same id and any change to
/// it gives another. Never 0 ("not supported").
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Plan {
    items: Vec<MissionItem>,
    opaque_id: u32,
}

impl Plan {
    pub fn new(mission_type: MissionType, items: Vec<MissionItem>) -> Plan {
        let mut crc = crc32fast::Hasher::new();
        crc.update(&[mission_type as u8]);
        for item in &items {
            crc.update(&item.content_bytes());
        }
        let opaque_id = crc.finalize().max(1);
        Plan { items, opaque_id }
    }

    pub fn items(&self) -> &[MissionItem] {
        &self.items
    }

    pub fn len(&self) -> usize {
        self.items.len()
    }

    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    pub fn opaque_id(&self) -> u32 {
        self.opaque_id
    }
}
