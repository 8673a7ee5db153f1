//! What the core keeps of the three plans: the mission protocol (which owns
//! the plans in force), the mission being executed, the compiled geofence,
//! and the outputs missions drive.

use mission::{ExecState, MissionExecutor, MissionProtocol, MissionType, Plan, Plans};

use super::LinkId;
use crate::fence::{Breach, Fence};

pub struct MissionState {
    pub protocol: MissionProtocol<LinkId>,
    pub executor: MissionExecutor,
    /// The compiled fence (needs the local frame, so built once it exists).
    pub fence: Option<Fence>,
    /// DO_CHANGE_SPEED in AUTO; cleared when the mission restarts.
    pub speed_mps: Option<f64>,
    /// Servo channels set by DO_SET_SERVO (µs, 0: not driven).
    pub servo_us: [u16; 16],
    /// Relays set by DO_SET_RELAY (bit n = relay n on), and which were used.
    pub relays_on: u16,
    pub relays_used: u16,
    pub breach: Option<Breach>,
    pub breach_count: u16,
    pub breach_time_ms: u32,
    /// The last MISSION_CURRENT seq and state sent, to send again on
    /// change (completion keeps the seq but changes the state).
    pub last_current_sent: Option<(u16, ExecState)>,
    /// The mission stop whose one retry (a manoeuvre back onto it after a
    /// stop out of tolerance) is in use; cleared by each new leg.
    pub stop_retried: Option<u16>,
    /// Bumped whenever a plan in force changes.
    pub generation: u64,
}

impl MissionState {
    pub fn new(plans: Plans) -> MissionState {
        MissionState {
            executor: MissionExecutor::new(&plans.mission),
            protocol: MissionProtocol::new(plans),
            fence: None,
            speed_mps: None,
            servo_us: [0; 16],
            relays_on: 0,
            relays_used: 0,
            breach: None,
            breach_count: 0,
            breach_time_ms: 0,
            last_current_sent: None,
            stop_retried: None,
            generation: 0,
        }
    }

    pub fn plan(&self, mission_type: MissionType) -> &Plan {
        self.protocol.plans().get(mission_type)
    }

    /// Puts a plan in force directly (loaded at start, imported).
    pub fn replace(&mut self, mission_type: MissionType, plan: Plan) {
        self.protocol.replace(mission_type, plan);
        self.changed(mission_type);
    }

    /// Rebuilds what derives from a plan that changed.
    pub fn changed(&mut self, mission_type: MissionType) {
        match mission_type {
            MissionType::Mission => {
                self.executor = MissionExecutor::new(self.protocol.plans().get(MissionType::Mission));
                self.speed_mps = None;
                self.last_current_sent = None;
            }
            MissionType::Fence => {
                self.fence = None;
                self.breach = None;
            }
            MissionType::Rally => {}
        }
        self.generation += 1;
    }
}
