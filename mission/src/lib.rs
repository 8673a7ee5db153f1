//! Furrow's missions: the three plans a ground station uploads (mission,
//! geofence, rally), in the MAVLink mission protocol's terms.
//!
//! - [`item`]: a stored item, exactly as MISSION_ITEM_INT carries it, and the
//!   plan types;
//! - [`command`]: what an item means (typed), and the validation that gives
//!   each bad item its precise MAV_MISSION_RESULT;
//! - [`protocol`]: the mission microservice (uploads, downloads, clears) as
//!   a state machine; [`download`]: its download half, a value that answers
//!   downloads wherever it is held;
//! - [`executor`]: runs a mission plan (AUTO mode), as actions for the vehicle;
//! - [`seconds`]: float seconds to a `Duration` that never panics (shared by
//!   every crate that converts outside numbers to time).

pub mod command;
pub mod download;
pub mod executor;
pub mod files;
pub mod item;
pub mod protocol;
pub mod seconds;
pub mod validate;

pub use command::{
    FenceItem, MissionCommand, Position, RallyItem, interpret_fence, interpret_mission, interpret_rally,
};
pub use download::Downloads;
pub use executor::{Action, ExecState, MissionExecutor, NavLeg, VehicleReport};
pub use item::{MissionItem, MissionType, Plan};
pub use protocol::{HomeItem, MissionEvent, MissionProtocol, Outgoing, Plans, Reply, Sender};
pub use validate::validate_plan;
