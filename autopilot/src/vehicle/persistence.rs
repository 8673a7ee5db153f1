//! Saved before acknowledged: the core does no I/O, so a change that must
//! survive a restart (a PARAM_SET, an uploaded or cleared plan) leaves the
//! core as a [`SaveRequest`] with a token; the edge writes it (fsynced,
//! renamed, directory fsynced) and hands back a [`SaveDone`] with the same
//! token. Only then is the change put in force and acknowledged (PARAM_VALUE
//! echo, MISSION_ACK ACCEPTED, the COMMAND_ACK of a flight termination,
//! which itself is in force at once); a failed save answers with the old value or
//! MISSION_ACK ERROR and a STATUSTEXT naming the error.
//!
//! One parameter save is in flight at a time: the changes that arrive
//! meanwhile wait and go together in the next one, which holds the table in
//! force plus all of them (so each echo waits for a write that includes its
//! change, and a failed write never lands in a later one).

use mavlink::dialects::ardupilotmega::MavSeverity;
use mission::{MissionType, Plan};

use super::Core;
use super::commands::AckTo;

/// Where the core's changes go.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum Storage {
    /// Nowhere (in-process simulations, tests): a change is in force and
    /// acknowledged at once, and nothing claims it survives a restart.
    #[default]
    Volatile,
    /// A data directory: a change is acknowledged once its save is reported.
    Durable,
    /// A data directory that cannot be written (the reason): the vehicle
    /// runs with what it loaded and refuses changes with a failure result.
    ReadOnly(String),
}

/// A save the edge must do, then report with [`SaveDone`].
#[derive(Clone, Debug, PartialEq)]
pub struct SaveRequest {
    pub token: u64,
    pub what: SaveWhat,
}

#[derive(Clone, Debug, PartialEq)]
pub enum SaveWhat {
    /// The parameter table in force, with these `(index, value)` changes
    /// applied in order (none: the table changed by itself, a boot count).
    Params { changes: Vec<(u16, f64)> },
    /// A plan that replaces the stored one.
    Plan { mission_type: MissionType, plan: Plan },
    /// Whether a flight termination is in force.
    Termination { terminated: bool },
}

/// How a [`SaveRequest`] ended (`Err`: why, for the operator).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SaveDone {
    pub token: u64,
    pub result: Result<(), String>,
}

/// The core's side of the saves.
#[derive(Debug, Default)]
pub(super) struct PersistState {
    pub storage: Storage,
    next_token: u64,
    /// Parameter changes waiting for the next save.
    staged: Vec<(u16, f64)>,
    /// The parameter save in flight and the changes it holds.
    params_in_flight: Option<(u64, Vec<(u16, f64)>)>,
    /// The table generation the last parameter save held (`None`: none yet,
    /// so the first tick saves what was loaded, boot count included).
    saved_generation: Option<u64>,
    plan_in_flight: Option<u64>,
    /// Flight termination saves in flight: what each saves (terminated or
    /// cleared) and where its COMMAND_ACK goes.
    termination_in_flight: Vec<(u64, bool, AckTo)>,
    requests: Vec<SaveRequest>,
}

impl PersistState {
    fn token(&mut self) -> u64 {
        self.next_token += 1;
        self.next_token
    }

    /// The saves asked for since the last call.
    pub fn take_requests(&mut self) -> Vec<SaveRequest> {
        std::mem::take(&mut self.requests)
    }

    /// Whether a change waits for its save.
    pub fn is_waiting(&self) -> bool {
        !self.staged.is_empty()
            || self.params_in_flight.is_some()
            || self.plan_in_flight.is_some()
            || !self.termination_in_flight.is_empty()
    }
}

impl Core {
    /// Where changes are saved (the edge sets it once, before the first
    /// step). A read-only store is said to every GCS that connects.
    pub fn set_storage(&mut self, storage: Storage) {
        let save_first = storage != Storage::Volatile;
        self.param_service.set_save_first(save_first);
        self.missions.protocol.set_save_first(save_first);
        if let Storage::ReadOnly(why) = &storage {
            self.add_startup_notice(
                MavSeverity::MAV_SEVERITY_CRITICAL,
                format!("Storage read-only ({why}): running on what was loaded; changes refused"),
            );
        }
        self.persist.storage = storage;
    }

    /// Whether a change waits for its save (the edge, before it exits,
    /// finishes the saves it was given).
    pub fn is_waiting_for_saves(&self) -> bool {
        self.persist.is_waiting()
    }

    /// A PARAM_SET's new value that must be saved before it is in force.
    pub(super) fn param_save_requested(&mut self, index: u16, value: f64) {
        match self.persist.storage.clone() {
            Storage::ReadOnly(why) => {
                let (mut out, mut notices) = (Vec::new(), Vec::new());
                let why = format!("storage read-only: {why}");
                self.param_service
                    .refuse_unsaved(&self.params, index, &why, &mut out, &mut notices);
                self.send_param_replies(out);
                self.param_notices(notices);
            }
            _ => self.persist.staged.push((index, value)),
        }
    }

    /// A plan the mission protocol accepted, to be saved before it is in
    /// force.
    pub(super) fn plan_save_requested(&mut self, mission_type: MissionType, plan: Plan) {
        match self.persist.storage.clone() {
            Storage::ReadOnly(why) => self.plan_saved(Err(format!("storage read-only: {why}"))),
            _ => {
                let token = self.persist.token();
                self.persist.plan_in_flight = Some(token);
                self.persist.requests.push(SaveRequest {
                    token,
                    what: SaveWhat::Plan { mission_type, plan },
                });
            }
        }
    }

    /// A flight termination (or its clear) to save before it is
    /// acknowledged.
    pub(super) fn termination_save_requested(&mut self, terminated: bool, ack_to: AckTo) {
        let token = self.persist.token();
        self.persist.termination_in_flight.push((token, terminated, ack_to));
        self.persist.requests.push(SaveRequest {
            token,
            what: SaveWhat::Termination { terminated },
        });
    }

    /// Whether a save of `terminated` waits.
    pub(super) fn termination_save_pending(&self, terminated: bool) -> bool {
        self.persist
            .termination_in_flight
            .iter()
            .any(|(_, t, _)| *t == terminated)
    }

    fn plan_saved(&mut self, result: Result<(), String>) {
        let (mut out, mut events) = (Vec::new(), Vec::new());
        self.missions
            .protocol
            .saved(self.now.wall, result, &mut out, &mut events);
        self.mission_replies(out);
        self.mission_events(events);
    }

    /// Acts on the saves the edge finished.
    pub(super) fn saves_done(&mut self, done: &[SaveDone]) {
        for d in done {
            if self.persist.plan_in_flight == Some(d.token) {
                self.persist.plan_in_flight = None;
                self.plan_saved(d.result.clone());
            } else if self
                .persist
                .params_in_flight
                .as_ref()
                .is_some_and(|(t, _)| *t == d.token)
            {
                self.params_saved(&d.result);
            } else if let Some(i) = self
                .persist
                .termination_in_flight
                .iter()
                .position(|(t, ..)| *t == d.token)
            {
                let (_, terminated, ack_to) = self.persist.termination_in_flight.remove(i);
                self.termination_saved(terminated, ack_to, &d.result);
            }
        }
    }

    fn params_saved(&mut self, result: &Result<(), String>) {
        let Some((_, changes)) = self.persist.params_in_flight.take() else {
            return;
        };
        let (mut out, mut notices) = (Vec::new(), Vec::new());
        let generation_saved = self.persist.saved_generation == Some(self.params.generation());
        match result {
            Ok(()) => {
                for (index, value) in changes {
                    self.param_service
                        .apply_saved(&mut self.params, index, value, &mut out, &mut notices);
                }
                // What was just put in force is what the file holds.
                if generation_saved {
                    self.persist.saved_generation = Some(self.params.generation());
                }
            }
            Err(why) => {
                for (index, _) in &changes {
                    self.param_service
                        .refuse_unsaved(&self.params, *index, why, &mut out, &mut notices);
                }
                if changes.is_empty() {
                    self.send_text(
                        MavSeverity::MAV_SEVERITY_CRITICAL,
                        &format!("Parameters not saved ({why})"),
                    );
                }
            }
        }
        self.send_param_replies(out);
        self.param_notices(notices);
    }

    /// Asks for a parameter save when changes wait and none is in flight.
    pub(super) fn request_param_save(&mut self) {
        if self.persist.storage != Storage::Durable || self.persist.params_in_flight.is_some() {
            return;
        }
        let generation = self.params.generation();
        if self.persist.staged.is_empty() && self.persist.saved_generation == Some(generation) {
            return;
        }
        // A failed save is not retried by itself: the next change retries.
        self.persist.saved_generation = Some(generation);
        let changes = std::mem::take(&mut self.persist.staged);
        let token = self.persist.token();
        self.persist.params_in_flight = Some((token, changes.clone()));
        self.persist.requests.push(SaveRequest {
            token,
            what: SaveWhat::Params { changes },
        });
    }
}
