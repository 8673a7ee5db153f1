//! The MAVLink mission microservice, vehicle side, as a state machine:
//! messages in, messages out, no I/O, the wall clock passed in. Generic
//! over the caller's link key. Three independent plans (mission, fence,
//! rally), each replaced only by a complete, valid upload.
//!
//! Rules (mavlink.io mission protocol; better than ArduPilot where it
//! falls short):
//! - Upload: MISSION_COUNT → MISSION_REQUEST_INT(0..count-1) → the last
//!   valid item is answered with MISSION_ACK(ACCEPTED, opaque_id of the new
//!   plan). **Atomic**: the plan in force changes only then; a bad item
//!   (answered at once with its precise MAV_MISSION_RESULT), a time-out or
//!   a cancel leaves the old plan, and the caller gets
//!   [`MissionEvent::TransferFailed`] for a STATUSTEXT. `count = 0` clears.
//!   A new MISSION_COUNT from the same partner restarts the upload.
//! - Items arrive in order: another seq is dropped and the expected one
//!   re-requested (not an error). Without the expected item for
//!   [`ITEM_TIMEOUT`] (wall clock) it is requested again, up to
//!   [`MAX_RETRIES`] times, then the upload is cancelled with
//!   MISSION_ACK(OPERATION_CANCELLED). If the final ACK was lost and the
//!   partner sends the last item again within [`FINAL_ACK_LINGER`], the
//!   same ACK is sent again.
//! - One upload at a time: MISSION_COUNT, MISSION_CLEAR_ALL or items from
//!   anyone else (another link, or another system/component id) meanwhile
//!   get MISSION_ACK(DENIED); the upload in progress continues.
//! - A MISSION_ACK other than ACCEPTED from the partner cancels its upload.
//! - Download: MISSION_REQUEST_LIST → MISSION_COUNT(count, opaque_id);
//!   MISSION_REQUEST_INT and the deprecated MISSION_REQUEST → MISSION_ITEM_INT
//!   (past the end: MISSION_ACK(INVALID_SEQUENCE)). Stateless reads of the
//!   plan in force, allowed during someone else's upload. Mission item 0 is
//!   home (ArduPilot): the current home when [`MissionProtocol::set_home`]
//!   gave one. They are answered by [`crate::download::Downloads`], which
//!   [`MissionProtocol::downloads`] shares so that the link layer can
//!   answer them too.
//! - MISSION_CLEAR_ALL → MISSION_ACK(ACCEPTED).
//! - MISSION_TYPE_ALL (255) anywhere, MISSION_CLEAR_ALL included:
//!   MISSION_ACK(UNSUPPORTED), as ArduPilot answers it (no plan changes);
//!   a type the dialect does not know (7, 9…) cannot be decoded, and the
//!   link layer answers it the same way ([`inspect_unknown_mission_type`]);
//!   MISSION_WRITE_PARTIAL_LIST: MISSION_ACK(UNSUPPORTED).
//! - Saved before acknowledged: with [`MissionProtocol::set_save_first`] a
//!   complete upload or a clear is not put in force at once; the caller
//!   gets [`MissionEvent::SaveRequested`], saves the plan and reports with
//!   [`MissionProtocol::saved`]. Only then does the plan replace the old one
//!   and MISSION_ACK(ACCEPTED) go out; a failed save answers
//!   MISSION_ACK(ERROR) and the old plan stays. While a save is pending,
//!   uploads and clears from anyone get DENIED (the partner's repeated last
//!   item is ignored: its ACK is coming).
//! - Every reply goes to the requester's link, addressed to its system and
//!   component. MISSION_ACK.opaque_id is the new plan's id on success, 0
//!   otherwise.
//!
//! The caller filters messages by `target_system`/`target_component`
//! before handing them in, as for the parameter service.

// MISSION_ITEM and MISSION_REQUEST are deprecated, and must still be served.
#![allow(deprecated)]

use std::sync::Arc;
use std::time::Duration;

use mavlink::dialects::ardupilotmega::{
    MISSION_ACK_DATA, MISSION_ITEM_DATA, MISSION_ITEM_INT_DATA, MISSION_REQUEST_INT_DATA, MavCmd, MavFrame, MavMessage,
    MavMissionResult, MavMissionType,
};

use crate::command::{cmd, frame};
use crate::download::Downloads;
use crate::item::{MissionItem, MissionType, Plan};
use crate::validate::{check_item, mav_cmd, mav_frame, max_items, result_text, validate_plan, xy_from_float};

/// How long the vehicle waits for the item it requested before asking again.
pub const ITEM_TIMEOUT: Duration = Duration::from_secs(1);
/// Requests sent again for one item before the upload is cancelled.
pub const MAX_RETRIES: u8 = 5;
/// How long after an upload ends its final MISSION_ACK is sent again when
/// the partner repeats the last item (the ACK was lost).
pub const FINAL_ACK_LINGER: Duration = Duration::from_secs(5);

/// Where a reply goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reply<L> {
    Link(L),
    AllLinks,
}

#[derive(Clone, Debug)]
pub struct Outgoing<L> {
    pub dest: Reply<L>,
    pub message: MavMessage,
}

/// Who sent a message (replies are addressed back to them).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Sender {
    pub system_id: u8,
    pub component_id: u8,
}

/// What the caller should act on.
#[derive(Clone, Debug, PartialEq)]
pub enum MissionEvent {
    /// A plan was replaced (upload, clear): persist it, tell the executor.
    PlanReplaced(MissionType),
    /// An upload failed and the old plan stays in force; the text is for a
    /// STATUSTEXT.
    TransferFailed { mission_type: MissionType, text: String },
    /// A complete plan waits to be saved (only with
    /// [`MissionProtocol::set_save_first`]): save it, then call
    /// [`MissionProtocol::saved`].
    SaveRequested { mission_type: MissionType, plan: Plan },
}

/// The three plans in force.
#[derive(Clone, Debug, PartialEq)]
pub struct Plans {
    pub mission: Plan,
    pub fence: Plan,
    pub rally: Plan,
}

impl Default for Plans {
    /// Three empty plans (each with its own opaque id).
    fn default() -> Self {
        Plans {
            mission: Plan::new(MissionType::Mission, Vec::new()),
            fence: Plan::new(MissionType::Fence, Vec::new()),
            rally: Plan::new(MissionType::Rally, Vec::new()),
        }
    }
}

impl Plans {
    pub fn get(&self, mission_type: MissionType) -> &Plan {
        match mission_type {
            MissionType::Mission => &self.mission,
            MissionType::Fence => &self.fence,
            MissionType::Rally => &self.rally,
        }
    }

    pub fn set(&mut self, mission_type: MissionType, plan: Plan) {
        match mission_type {
            MissionType::Mission => self.mission = plan,
            MissionType::Fence => self.fence = plan,
            MissionType::Rally => self.rally = plan,
        }
    }
}

/// The vehicle's home, which a mission download returns as item 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HomeItem {
    pub lat_e7: i32,
    pub lon_e7: i32,
    /// Metres above mean sea level.
    pub alt_m: f32,
}

impl HomeItem {
    /// Home as mission item 0: NAV_WAYPOINT in MAV_FRAME_GLOBAL, as
    /// ArduPilot sends it.
    pub fn to_item(self) -> MissionItem {
        MissionItem {
            seq: 0,
            frame: frame::GLOBAL,
            command: cmd::NAV_WAYPOINT,
            current: false,
            autocontinue: true,
            params: [0.0; 4],
            x: self.lat_e7,
            y: self.lon_e7,
            z: self.alt_m,
        }
    }
}

/// An upload in progress.
#[derive(Clone, Debug)]
struct Upload<L> {
    link: L,
    sender: Sender,
    mission_type: MissionType,
    count: u16,
    /// Items received so far, in order; the next expected seq is `len()`.
    items: Vec<MissionItem>,
    /// When the expected item was last requested.
    requested_at: Duration,
    retries: u8,
}

impl<L: Copy> Upload<L> {
    fn expected(&self) -> u16 {
        self.items.len() as u16
    }
}

/// The final MISSION_ACK of the last upload, kept a while in case it was
/// lost and the partner repeats its last item.
#[derive(Clone, Debug)]
struct FinalAck<L> {
    link: L,
    sender: Sender,
    mission_type: MissionType,
    last_seq: u16,
    result: MavMissionResult,
    opaque_id: u32,
    at: Duration,
}

/// Who an upload is with, and of which plan.
#[derive(Clone, Copy, Debug)]
struct Partner<L> {
    link: L,
    sender: Sender,
    mission_type: MissionType,
}

/// A plan accepted by the protocol, waiting for its save to be reported.
#[derive(Clone, Debug)]
struct Saving<L> {
    partner: Partner<L>,
    /// The last item's seq (`None`: a clear, which has no final item).
    last_seq: Option<u16>,
    plan: Plan,
}

/// The mission microservice.
#[derive(Clone, Debug)]
pub struct MissionProtocol<L> {
    /// The plans in force and home. Replaced, never changed in place, so a
    /// holder of the old value keeps a consistent one and can tell it is
    /// old (`Arc::ptr_eq`).
    downloads: Arc<Downloads>,
    upload: Option<Upload<L>>,
    final_ack: Option<FinalAck<L>>,
    save_first: bool,
    saving: Option<Saving<L>>,
}

/// An item as it arrived: decoded, or already refused (a deprecated
/// MISSION_ITEM whose coordinates do not convert, an enum value the
/// dialect lacks).
type Arrived = Result<MissionItem, MavMissionResult>;

pub(crate) fn ack(
    sender: Sender,
    mission_type: MavMissionType,
    result: MavMissionResult,
    opaque_id: u32,
) -> MavMessage {
    MavMessage::MISSION_ACK(MISSION_ACK_DATA {
        target_system: sender.system_id,
        target_component: sender.component_id,
        mavtype: result,
        mission_type,
        opaque_id,
    })
}

fn request(sender: Sender, mission_type: MissionType, seq: u16) -> MavMessage {
    MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
        seq,
        target_system: sender.system_id,
        target_component: sender.component_id,
        mission_type: mission_type.to_mavlink(),
    })
}

/// The mission type of a raw number, as far as the dialect knows it
/// (`None`: not even the dialect knows it).
fn raw_mission_type(raw: u8) -> Option<MavMissionType> {
    match raw {
        0 => Some(MavMissionType::MAV_MISSION_TYPE_MISSION),
        1 => Some(MavMissionType::MAV_MISSION_TYPE_FENCE),
        2 => Some(MavMissionType::MAV_MISSION_TYPE_RALLY),
        255 => Some(MavMissionType::MAV_MISSION_TYPE_ALL),
        _ => None,
    }
}

fn title(mission_type: MissionType) -> &'static str {
    match mission_type {
        MissionType::Mission => "Mission",
        MissionType::Fence => "Fence",
        MissionType::Rally => "Rally",
    }
}

/// A deprecated MISSION_ITEM as the stored (integer) item: global
/// coordinates in degrees become degrees × 1e7, local ones metres × 1e4.
pub fn item_from_float(m: &MISSION_ITEM_DATA) -> Arrived {
    let f = m.frame as u8;
    let x = xy_from_float(f, f64::from(m.x)).ok_or(MavMissionResult::MAV_MISSION_INVALID_PARAM5_X)?;
    let y = xy_from_float(f, f64::from(m.y)).ok_or(MavMissionResult::MAV_MISSION_INVALID_PARAM6_Y)?;
    Ok(MissionItem {
        seq: m.seq,
        frame: f,
        command: m.command as u16,
        current: m.current != 0,
        autocontinue: m.autocontinue != 0,
        params: [m.param1, m.param2, m.param3, m.param4],
        x,
        y,
        z: m.z,
    })
}

/// MISSION_ITEM_INT for a stored item, addressed to `to`. `None` if the
/// dialect cannot carry its command or frame (never for a validated plan).
pub fn item_message(item: &MissionItem, mission_type: MissionType, to: Sender) -> Option<MavMessage> {
    let command: MavCmd = mav_cmd(item.command)?;
    let frame: MavFrame = mav_frame(item.frame)?;
    Some(MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
        param1: item.params[0],
        param2: item.params[1],
        param3: item.params[2],
        param4: item.params[3],
        x: item.x,
        y: item.y,
        z: item.z,
        seq: item.seq,
        command,
        target_system: to.system_id,
        target_component: to.component_id,
        frame,
        current: u8::from(item.current),
        autocontinue: u8::from(item.autocontinue),
        mission_type: mission_type.to_mavlink(),
    }))
}

/// What [`MissionProtocol::handle_undecodable_item`] needs from a
/// MISSION_ITEM_INT (id 73) or MISSION_ITEM (id 39) payload that the
/// dialect could not decode (a command, frame or mission type it lacks).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UndecodableItem {
    pub seq: u16,
    pub target_system: u8,
    pub target_component: u8,
    pub mission_type: u8,
    /// The frame is the value the dialect lacks (else the command is).
    pub bad_frame: bool,
}

/// Reads the fields of an undecodable mission item from its raw payload
/// (MAVLink 2 trailing zeros may be truncated). `None` for other messages,
/// and for items the dialect can decode.
pub fn inspect_undecodable_item(message_id: u32, payload: &[u8]) -> Option<UndecodableItem> {
    if message_id != 73 && message_id != 39 {
        return None;
    }
    let mut p = [0u8; 38];
    let n = payload.len().min(p.len());
    p[..n].copy_from_slice(&payload[..n]);
    let command = u16::from_le_bytes([p[30], p[31]]);
    let frame = p[34];
    let mission_type = p[37];
    let bad_frame = mav_frame(frame).is_none();
    if mav_cmd(command).is_some() && !bad_frame && raw_mission_type(mission_type).is_some() {
        return None;
    }
    Some(UndecodableItem {
        seq: u16::from_le_bytes([p[28], p[29]]),
        target_system: p[32],
        target_component: p[33],
        mission_type,
        bad_frame,
    })
}

/// A mission message (not an item) whose `mission_type` is none the dialect
/// knows (7, 9…): it cannot be decoded, and is answered
/// MISSION_ACK(UNSUPPORTED) with that type, as ArduPilot answers any type
/// it has no plan for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UnknownMissionType {
    pub target_system: u8,
    pub target_component: u8,
    pub mission_type: u8,
}

/// Reads an undecodable MISSION_REQUEST_LIST, MISSION_COUNT,
/// MISSION_CLEAR_ALL, MISSION_REQUEST(_INT) or MISSION_WRITE_PARTIAL_LIST
/// payload whose mission type is unknown. `None` for other messages and
/// for known types (MISSION_ACK is never answered).
pub fn inspect_unknown_mission_type(message_id: u32, payload: &[u8]) -> Option<UnknownMissionType> {
    // Offsets of target_system (target_component follows) and mission_type.
    let (target, mission_type) = match message_id {
        43 | 45 => (0, 2),      // REQUEST_LIST, CLEAR_ALL
        40 | 44 | 51 => (2, 4), // REQUEST, COUNT, REQUEST_INT
        38 => (4, 6),           // WRITE_PARTIAL_LIST
        _ => return None,
    };
    let mut p = [0u8; 8];
    let n = payload.len().min(p.len());
    p[..n].copy_from_slice(&payload[..n]);
    if raw_mission_type(p[mission_type]).is_some() {
        return None;
    }
    Some(UnknownMissionType {
        target_system: p[target],
        target_component: p[target + 1],
        mission_type: p[mission_type],
    })
}

impl<L: Copy + Ord + Eq + std::fmt::Debug> MissionProtocol<L> {
    pub fn new(plans: Plans) -> Self {
        MissionProtocol {
            downloads: Arc::new(Downloads::new(plans, None)),
            upload: None,
            final_ack: None,
            save_first: false,
            saving: None,
        }
    }

    /// Whether a new plan must be saved before it is in force and
    /// acknowledged (see the module rules).
    pub fn set_save_first(&mut self, on: bool) {
        self.save_first = on;
    }

    /// Whether a plan waits for [`MissionProtocol::saved`].
    pub fn is_saving(&self) -> bool {
        self.saving.is_some()
    }

    /// The save of the pending plan ended: `Ok` puts it in force and
    /// acknowledges it; `Err(why)` keeps the old plan and answers
    /// MISSION_ACK(ERROR), with a [`MissionEvent::TransferFailed`] naming
    /// `why`. Without a pending plan, nothing happens.
    pub fn saved(
        &mut self,
        now: Duration,
        result: Result<(), String>,
        out: &mut Vec<Outgoing<L>>,
        events: &mut Vec<MissionEvent>,
    ) {
        let Some(Saving {
            partner,
            last_seq,
            plan,
        }) = self.saving.take()
        else {
            return;
        };
        let (result, opaque_id) = match result {
            Ok(()) => {
                let id = plan.opaque_id();
                self.change_downloads(|d| d.set_plan(partner.mission_type, plan));
                events.push(MissionEvent::PlanReplaced(partner.mission_type));
                (MavMissionResult::MAV_MISSION_ACCEPTED, id)
            }
            Err(why) => {
                events.push(MissionEvent::TransferFailed {
                    mission_type: partner.mission_type,
                    text: format!(
                        "{} not saved ({why}): old {} kept",
                        title(partner.mission_type),
                        partner.mission_type.name()
                    ),
                });
                (MavMissionResult::MAV_MISSION_ERROR, 0)
            }
        };
        self.acknowledge(now, partner, last_seq, result, opaque_id, out);
    }

    /// Puts `plan` in force and acknowledges it, or (saving first) asks
    /// for it to be saved and waits.
    fn accept(
        &mut self,
        now: Duration,
        partner: Partner<L>,
        last_seq: Option<u16>,
        plan: Plan,
        out: &mut Vec<Outgoing<L>>,
        events: &mut Vec<MissionEvent>,
    ) {
        if self.save_first {
            events.push(MissionEvent::SaveRequested {
                mission_type: partner.mission_type,
                plan: plan.clone(),
            });
            self.saving = Some(Saving {
                partner,
                last_seq,
                plan,
            });
            return;
        }
        self.saving = Some(Saving {
            partner,
            last_seq,
            plan,
        });
        self.saved(now, Ok(()), out, events);
    }

    /// Sends an upload's or a clear's final MISSION_ACK and, for an upload,
    /// remembers it in case it is lost.
    fn acknowledge(
        &mut self,
        now: Duration,
        partner: Partner<L>,
        last_seq: Option<u16>,
        result: MavMissionResult,
        opaque_id: u32,
        out: &mut Vec<Outgoing<L>>,
    ) {
        let Partner {
            link,
            sender,
            mission_type,
        } = partner;
        out.push(Outgoing {
            dest: Reply::Link(link),
            message: ack(sender, mission_type.to_mavlink(), result, opaque_id),
        });
        if let Some(last_seq) = last_seq {
            self.final_ack = Some(FinalAck {
                link,
                sender,
                mission_type,
                last_seq,
                result,
                opaque_id,
                at: now,
            });
        }
    }

    /// The plans in force.
    pub fn plans(&self) -> &Plans {
        self.downloads.plans()
    }

    /// What downloads read, to answer them elsewhere exactly as
    /// [`MissionProtocol::handle`] does; a new value after every change of
    /// a plan in force or of home.
    pub fn downloads(&self) -> &Arc<Downloads> {
        &self.downloads
    }

    fn change_downloads(&mut self, change: impl FnOnce(&mut Downloads)) {
        let mut next = Downloads::clone(&self.downloads);
        change(&mut next);
        self.downloads = Arc::new(next);
    }

    /// The current home, returned as mission item 0 by downloads (`None`:
    /// the stored item 0 is returned).
    pub fn set_home(&mut self, home: Option<HomeItem>) {
        if home != self.downloads.home() {
            self.change_downloads(|d| d.set_home(home));
        }
    }

    pub fn home(&self) -> Option<HomeItem> {
        self.downloads.home()
    }

    /// Puts a plan in force directly (e.g. a file imported while running).
    /// The plan must have passed [`validate_plan`]. An upload in progress
    /// continues and, if it completes, replaces this plan in turn.
    pub fn replace(&mut self, mission_type: MissionType, plan: Plan) {
        debug_assert!(validate_plan(mission_type, plan.items().to_vec()).is_ok());
        self.change_downloads(|d| d.set_plan(mission_type, plan));
    }

    pub fn is_uploading(&self) -> bool {
        self.upload.is_some()
    }

    /// Which plan is being uploaded, from which link.
    pub fn upload_in_progress(&self) -> Option<(MissionType, L)> {
        self.upload.as_ref().map(|u| (u.mission_type, u.link))
    }

    /// Forgets an upload from a link that went away (the old plan stays).
    pub fn link_closed(&mut self, link: L, events: &mut Vec<MissionEvent>) {
        if let Some(up) = self.upload.take_if(|u| u.link == link) {
            events.push(MissionEvent::TransferFailed {
                mission_type: up.mission_type,
                text: format!("{} upload abandoned: link closed", title(up.mission_type)),
            });
        }
        if self.final_ack.as_ref().is_some_and(|f| f.link == link) {
            self.final_ack = None;
        }
    }

    /// Handles a mission-protocol message (already known to be addressed to
    /// us). Returns false for any other message.
    pub fn handle(
        &mut self,
        now: Duration,
        link: L,
        sender: Sender,
        message: &MavMessage,
        out: &mut Vec<Outgoing<L>>,
        events: &mut Vec<MissionEvent>,
    ) -> bool {
        match message {
            MavMessage::MISSION_COUNT(m) => self.on_count(now, link, sender, m.mission_type, m.count, out, events),
            MavMessage::MISSION_ITEM_INT(m) => {
                let item = Ok(MissionItem::from_mavlink(m));
                self.on_item(now, link, sender, m.seq, m.mission_type as u8, item, out, events);
            }
            MavMessage::MISSION_ITEM(m) => {
                let item = item_from_float(m);
                self.on_item(now, link, sender, m.seq, m.mission_type as u8, item, out, events);
            }
            MavMessage::MISSION_REQUEST_LIST(_)
            | MavMessage::MISSION_REQUEST_INT(_)
            | MavMessage::MISSION_REQUEST(_) => {
                if let Some(message) = self.downloads.answer(sender, message) {
                    out.push(Outgoing {
                        dest: Reply::Link(link),
                        message,
                    });
                }
            }
            MavMessage::MISSION_ACK(m) => self.on_ack(link, sender, m, events),
            MavMessage::MISSION_CLEAR_ALL(m) => self.on_clear(now, link, sender, m.mission_type, out, events),
            MavMessage::MISSION_WRITE_PARTIAL_LIST(m) => out.push(Outgoing {
                dest: Reply::Link(link),
                message: ack(sender, m.mission_type, MavMissionResult::MAV_MISSION_UNSUPPORTED, 0),
            }),
            _ => return false,
        }
        true
    }

    /// An item whose command or frame enum value the dialect lacks (the
    /// caller could not decode it): answered as UNSUPPORTED, or
    /// UNSUPPORTED_FRAME when `bad_frame`, as any bad item would be.
    #[allow(clippy::too_many_arguments)]
    pub fn handle_undecodable_item(
        &mut self,
        now: Duration,
        link: L,
        sender: Sender,
        seq: u16,
        mission_type: u8,
        bad_frame: bool,
        out: &mut Vec<Outgoing<L>>,
        events: &mut Vec<MissionEvent>,
    ) {
        let result = if bad_frame {
            MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME
        } else {
            MavMissionResult::MAV_MISSION_UNSUPPORTED
        };
        self.on_item(now, link, sender, seq, mission_type, Err(result), out, events);
    }

    /// Re-requests overdue items and gives up on silent partners. Call it
    /// often (the core calls it at 50 Hz) with the wall clock.
    pub fn poll(&mut self, now: Duration, out: &mut Vec<Outgoing<L>>, events: &mut Vec<MissionEvent>) {
        if self
            .final_ack
            .as_ref()
            .is_some_and(|f| now.saturating_sub(f.at) > FINAL_ACK_LINGER)
        {
            self.final_ack = None;
        }
        let Some(up) = &mut self.upload else {
            return;
        };
        if now.saturating_sub(up.requested_at) < ITEM_TIMEOUT {
            return;
        }
        if up.retries < MAX_RETRIES {
            up.retries += 1;
            up.requested_at = now;
            out.push(Outgoing {
                dest: Reply::Link(up.link),
                message: request(up.sender, up.mission_type, up.expected()),
            });
            return;
        }
        let (link, sender, mission_type) = (up.link, up.sender, up.mission_type);
        let text = format!(
            "{} upload timed out at item {} of {}",
            title(mission_type),
            up.expected(),
            up.count
        );
        self.upload = None;
        out.push(Outgoing {
            dest: Reply::Link(link),
            message: ack(
                sender,
                mission_type.to_mavlink(),
                MavMissionResult::MAV_MISSION_OPERATION_CANCELLED,
                0,
            ),
        });
        events.push(MissionEvent::TransferFailed { mission_type, text });
    }

    fn is_partner(&self, link: L, sender: Sender) -> bool {
        self.upload
            .as_ref()
            .is_some_and(|u| u.link == link && u.sender == sender)
    }

    /// Someone other than the uploading partner while an upload runs, or
    /// anyone while a plan is being saved.
    fn busy_for(&self, link: L, sender: Sender) -> bool {
        self.saving.is_some() || (self.upload.is_some() && !self.is_partner(link, sender))
    }

    /// The mission type of a request that starts a change (a count, a
    /// clear), or `None` once it is answered UNSUPPORTED (a type not kept)
    /// or DENIED (busy for this sender).
    fn admit(
        &self,
        link: L,
        sender: Sender,
        raw_type: MavMissionType,
        out: &mut Vec<Outgoing<L>>,
    ) -> Option<MissionType> {
        let result = match MissionType::from_mavlink(raw_type) {
            None => MavMissionResult::MAV_MISSION_UNSUPPORTED,
            Some(_) if self.busy_for(link, sender) => MavMissionResult::MAV_MISSION_DENIED,
            Some(mission_type) => return Some(mission_type),
        };
        out.push(Outgoing {
            dest: Reply::Link(link),
            message: ack(sender, raw_type, result, 0),
        });
        None
    }

    #[allow(clippy::too_many_arguments)]
    fn on_count(
        &mut self,
        now: Duration,
        link: L,
        sender: Sender,
        raw_type: MavMissionType,
        count: u16,
        out: &mut Vec<Outgoing<L>>,
        events: &mut Vec<MissionEvent>,
    ) {
        let Some(mission_type) = self.admit(link, sender, raw_type, out) else {
            return;
        };
        // The same partner starting again: the old upload is abandoned.
        self.upload = None;
        self.final_ack = None;
        let max = max_items(mission_type);
        if usize::from(count) > max {
            out.push(Outgoing {
                dest: Reply::Link(link),
                message: ack(sender, raw_type, MavMissionResult::MAV_MISSION_NO_SPACE, 0),
            });
            events.push(MissionEvent::TransferFailed {
                mission_type,
                text: format!("{} upload refused: {count} items, max {max}", title(mission_type)),
            });
            return;
        }
        if count == 0 {
            let partner = Partner {
                link,
                sender,
                mission_type,
            };
            self.accept(now, partner, None, Plan::new(mission_type, Vec::new()), out, events);
            return;
        }
        self.upload = Some(Upload {
            link,
            sender,
            mission_type,
            count,
            items: Vec::with_capacity(usize::from(count)),
            requested_at: now,
            retries: 0,
        });
        out.push(Outgoing {
            dest: Reply::Link(link),
            message: request(sender, mission_type, 0),
        });
    }

    #[allow(clippy::too_many_arguments)]
    fn on_item(
        &mut self,
        now: Duration,
        link: L,
        sender: Sender,
        seq: u16,
        raw_type: u8,
        item: Arrived,
        out: &mut Vec<Outgoing<L>>,
        events: &mut Vec<MissionEvent>,
    ) {
        let ack_type = raw_mission_type(raw_type).unwrap_or(MavMissionType::MAV_MISSION_TYPE_MISSION);
        let reply = |out: &mut Vec<Outgoing<L>>, result| {
            out.push(Outgoing {
                dest: Reply::Link(link),
                message: ack(sender, ack_type, result, 0),
            })
        };
        let mission_type = raw_mission_type(raw_type).and_then(MissionType::from_mavlink);
        if self
            .saving
            .as_ref()
            .is_some_and(|s| s.partner.link == link && s.partner.sender == sender)
        {
            // Its last item again: the ACK follows the save.
            return;
        }
        if self.busy_for(link, sender) {
            reply(out, MavMissionResult::MAV_MISSION_DENIED);
            return;
        }
        let Some(up) = &mut self.upload else {
            self.answer_item_without_upload(now, link, sender, seq, raw_type, out);
            return;
        };
        if mission_type != Some(up.mission_type) || seq != up.expected() {
            // Not the item we asked for: drop it, ask again.
            up.requested_at = now;
            out.push(Outgoing {
                dest: Reply::Link(link),
                message: request(sender, up.mission_type, up.expected()),
            });
            return;
        }
        let partner = Partner {
            link,
            sender,
            mission_type: up.mission_type,
        };
        let verdict = item.and_then(|item| check_item(partner.mission_type, &item, up.count).map(|()| item));
        let item = match verdict {
            Ok(item) => item,
            Err(result) => {
                self.upload = None;
                self.finish(now, partner, seq, Err((seq, result)), out, events);
                return;
            }
        };
        up.items.push(item);
        up.retries = 0;
        up.requested_at = now;
        if up.items.len() < usize::from(up.count) {
            out.push(Outgoing {
                dest: Reply::Link(link),
                message: request(sender, partner.mission_type, up.expected()),
            });
            return;
        }
        let Some(up) = self.upload.take() else {
            return;
        };
        let outcome = validate_plan(partner.mission_type, up.items);
        self.finish(now, partner, seq, outcome, out, events);
    }

    /// An item with no upload under way: a repeat of the last item of one
    /// that just ended gets its final ACK again; late duplicates are
    /// ignored; anything else is refused.
    fn answer_item_without_upload(
        &self,
        now: Duration,
        link: L,
        sender: Sender,
        seq: u16,
        raw_type: u8,
        out: &mut Vec<Outgoing<L>>,
    ) {
        let ack_type = raw_mission_type(raw_type).unwrap_or(MavMissionType::MAV_MISSION_TYPE_MISSION);
        let reply = |out: &mut Vec<Outgoing<L>>, result| {
            out.push(Outgoing {
                dest: Reply::Link(link),
                message: ack(sender, ack_type, result, 0),
            })
        };
        let mission_type = raw_mission_type(raw_type).and_then(MissionType::from_mavlink);
        match &self.final_ack {
            Some(f)
                if f.link == link
                    && f.sender == sender
                    && Some(f.mission_type) == mission_type
                    && now.saturating_sub(f.at) <= FINAL_ACK_LINGER =>
            {
                if seq == f.last_seq {
                    out.push(Outgoing {
                        dest: Reply::Link(link),
                        message: ack(sender, ack_type, f.result, f.opaque_id),
                    });
                }
            }
            _ => reply(
                out,
                if mission_type.is_some() {
                    MavMissionResult::MAV_MISSION_ERROR
                } else {
                    MavMissionResult::MAV_MISSION_UNSUPPORTED
                },
            ),
        }
    }

    /// Ends an upload (already taken out of `self.upload`) whose last item
    /// received was `last_seq`: puts the plan in force, or reports the bad
    /// item, and remembers the final ACK in case it is lost.
    fn finish(
        &mut self,
        now: Duration,
        partner: Partner<L>,
        last_seq: u16,
        outcome: Result<Plan, (u16, MavMissionResult)>,
        out: &mut Vec<Outgoing<L>>,
        events: &mut Vec<MissionEvent>,
    ) {
        let mission_type = partner.mission_type;
        match outcome {
            Ok(plan) => self.accept(now, partner, Some(last_seq), plan, out, events),
            Err((bad_seq, result)) => {
                events.push(MissionEvent::TransferFailed {
                    mission_type,
                    text: format!(
                        "{} rejected: {} item {bad_seq} {}",
                        title(mission_type),
                        mission_type.name(),
                        result_text(result)
                    ),
                });
                self.acknowledge(now, partner, Some(last_seq), result, 0, out);
            }
        }
    }

    fn on_ack(&mut self, link: L, sender: Sender, m: &MISSION_ACK_DATA, events: &mut Vec<MissionEvent>) {
        // ACCEPTED ends a download (nothing to do); anything else from the
        // uploading partner, for the plan being uploaded, cancels it.
        if m.mavtype == MavMissionResult::MAV_MISSION_ACCEPTED || !self.is_partner(link, sender) {
            return;
        }
        if let Some(up) = self
            .upload
            .take_if(|u| Some(u.mission_type) == MissionType::from_mavlink(m.mission_type))
        {
            events.push(MissionEvent::TransferFailed {
                mission_type: up.mission_type,
                text: format!(
                    "{} upload cancelled by GCS ({})",
                    title(up.mission_type),
                    result_text(m.mavtype)
                ),
            });
        }
    }

    fn on_clear(
        &mut self,
        now: Duration,
        link: L,
        sender: Sender,
        raw_type: MavMissionType,
        out: &mut Vec<Outgoing<L>>,
        events: &mut Vec<MissionEvent>,
    ) {
        // MISSION_TYPE_ALL included: ArduPilot answers it UNSUPPORTED too.
        let Some(mission_type) = self.admit(link, sender, raw_type, out) else {
            return;
        };
        // The partner clearing instead of finishing: its upload is abandoned.
        self.upload = None;
        self.final_ack = None;
        let partner = Partner {
            link,
            sender,
            mission_type,
        };
        self.accept(now, partner, None, Plan::new(mission_type, Vec::new()), out, events);
    }
}
