//! Furrow's missions: the three plans a ground station uploads (mission,
//! geofence, rally), in the MAVLink mission protocol's terms.
//!
//! - [`item`]: a stored item, exactly as MISSION_ITEM_INT carries it, and the
//!   plan types;
//! - [`command`]: what an item means (typed), and the validation that gives
//!   each bad item its precise MAV_MISSION_RESULT.

pub mod command;
pub mod item;

pub use command::{
    FenceItem, MissionCommand, Position, RallyItem, interpret_fence, interpret_mission, interpret_rally,
};
pub use item::{MissionItem, MissionType, Plan};
