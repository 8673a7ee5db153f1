//! The MAVLink parameter microservice as a state machine: messages in,
//! messages out, no I/O. Generic over the caller's link key so any link
//! layer can use it.
//!
//! Rules (mavlink.io parameter protocol):
//! - PARAM_REQUEST_LIST streams every parameter with its `param_index` and
//!   `param_count` on the requesting link, all at the next
//!   [`ParamService::poll`]: the link layer paces them to what the link
//!   drains and never drops one (a new request restarts the list).
//! - PARAM_REQUEST_READ answers by index, or by id when the index is -1.
//! - PARAM_SET always answers with a PARAM_VALUE holding the value now in
//!   force, broadcast so every GCS's cache stays coherent — the old value
//!   when the set was refused. Refusals also get a PARAM_ERROR (to the
//!   sender) and a notice the caller turns into a STATUSTEXT.
//! - With [`ParamService::set_save_first`], a new value is not put in
//!   force at once: the caller gets [`ParamNotice::SaveRequested`], saves
//!   it, and calls [`ParamService::apply_saved`] (in force, echoed) or
//!   [`ParamService::refuse_unsaved`] (the old value echoed, with a notice)
//!   — an echo of a new value then means it is on disk.
//! - Ids are up to 16 characters; a full-length id has no terminator.
//! - Values travel with the C-cast encoding: the value converted to `f32`.
//!   The one exception is `_HASH_CHECK` (see [`crate::hash`]), whose 32-bit
//!   CRC is copied bytewise into the float field, as PX4 does.

use std::collections::BTreeMap;

use mavlink::dialects::ardupilotmega::{
    MavMessage, MavParamError, MavParamType, PARAM_ERROR_DATA, PARAM_REQUEST_READ_DATA, PARAM_SET_DATA,
    PARAM_VALUE_DATA,
};

use crate::def::ParamType;
use crate::hash::{HASH_CHECK_ID, table_hash};
use crate::table::{ParamTable, SetError};

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

/// What the caller should know about a request.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamNotice {
    /// A parameter took a new value (persist it).
    Changed { index: u16 },
    /// A new value is stored but used only after a restart.
    RebootRequired { name: String },
    /// A request was refused; the text is for a STATUSTEXT.
    Refused { text: String },
    /// A valid new value waits to be saved (only with
    /// [`ParamService::set_save_first`]); nothing is echoed yet.
    SaveRequested { index: u16, value: f64 },
}

/// Who sent a request (PARAM_ERROR is addressed back to them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sender {
    pub system_id: u8,
    pub component_id: u8,
}

/// List downloads in progress, per link.
#[derive(Clone, Debug)]
pub struct ParamService<L> {
    streams: BTreeMap<L, usize>,
    save_first: bool,
}

impl<L: Copy + Ord> Default for ParamService<L> {
    fn default() -> Self {
        ParamService {
            streams: BTreeMap::new(),
            save_first: false,
        }
    }
}

/// The `f32` a value travels as (C-cast encoding).
pub fn wire_value(value: f64) -> f32 {
    value as f32
}

/// The `MAV_PARAM_TYPE` of a parameter type.
pub fn mav_param_type(ty: ParamType) -> MavParamType {
    match ty {
        ParamType::Uint8 => MavParamType::MAV_PARAM_TYPE_UINT8,
        ParamType::Int8 => MavParamType::MAV_PARAM_TYPE_INT8,
        ParamType::Int16 => MavParamType::MAV_PARAM_TYPE_INT16,
        ParamType::Int32 => MavParamType::MAV_PARAM_TYPE_INT32,
        ParamType::Real32 => MavParamType::MAV_PARAM_TYPE_REAL32,
    }
}

/// PARAM_VALUE for the parameter at `index`.
pub fn value_message(table: &ParamTable, index: u16) -> MavMessage {
    let def = table.def(index);
    MavMessage::PARAM_VALUE(PARAM_VALUE_DATA {
        param_value: wire_value(table.value(index)),
        param_count: table.len() as u16,
        param_index: index,
        param_id: def.name.to_mavlink_id().into(),
        param_type: mav_param_type(def.ty),
    })
}

/// The id of a request as a string: up to the first NUL, or all 16 bytes.
fn request_id(id: &[u8; 16]) -> Option<&str> {
    let len = id.iter().position(|b| *b == 0).unwrap_or(16);
    std::str::from_utf8(&id[..len]).ok()
}

impl<L: Copy + Ord> ParamService<L> {
    pub fn new() -> Self {
        Self::default()
    }

    /// Whether a list download is in progress on `link`.
    pub fn is_streaming(&self, link: L) -> bool {
        self.streams.contains_key(&link)
    }

    pub fn link_closed(&mut self, link: L) {
        self.streams.remove(&link);
    }

    /// Whether a new value must be saved before it is in force and echoed.
    pub fn set_save_first(&mut self, on: bool) {
        self.save_first = on;
    }

    /// Puts a saved value in force and echoes it to every link.
    pub fn apply_saved(
        &mut self,
        table: &mut ParamTable,
        index: u16,
        value: f64,
        out: &mut Vec<Outgoing<L>>,
        notices: &mut Vec<ParamNotice>,
    ) {
        let before = table.value(index);
        if let Ok(now) = table.set(index, value)
            && now != before
        {
            notices.push(ParamNotice::Changed { index });
            if table.def(index).flags.reboot_required {
                notices.push(ParamNotice::RebootRequired {
                    name: table.def(index).name.to_string(),
                });
            }
        }
        out.push(Outgoing {
            dest: Reply::AllLinks,
            message: value_message(table, index),
        });
    }

    /// A value that could not be saved: the old one stays in force and is
    /// echoed to every link, with a notice saying why.
    pub fn refuse_unsaved(
        &self,
        table: &ParamTable,
        index: u16,
        why: &str,
        out: &mut Vec<Outgoing<L>>,
        notices: &mut Vec<ParamNotice>,
    ) {
        notices.push(ParamNotice::Refused {
            text: format!(
                "{} not saved ({why}), kept {}",
                table.def(index).name,
                table.value(index)
            ),
        });
        out.push(Outgoing {
            dest: Reply::AllLinks,
            message: value_message(table, index),
        });
    }

    /// Handles a PARAM_* message (already known to be addressed to us).
    /// Returns false for any other message.
    pub fn handle(
        &mut self,
        table: &mut ParamTable,
        link: L,
        sender: Sender,
        message: &MavMessage,
        out: &mut Vec<Outgoing<L>>,
        notices: &mut Vec<ParamNotice>,
    ) -> bool {
        match message {
            MavMessage::PARAM_REQUEST_LIST(_) => {
                self.streams.insert(link, 0);
            }
            MavMessage::PARAM_REQUEST_READ(r) => self.read(table, link, sender, r, out, notices),
            MavMessage::PARAM_SET(s) => self.set(table, link, sender, s, out, notices),
            _ => return false,
        }
        true
    }

    /// Sends the rest of every list download in progress.
    pub fn poll(&mut self, table: &ParamTable, out: &mut Vec<Outgoing<L>>) {
        for (link, next) in std::mem::take(&mut self.streams) {
            for index in next..table.len() {
                out.push(Outgoing {
                    dest: Reply::Link(link),
                    message: value_message(table, index as u16),
                });
            }
        }
    }

    fn read(
        &mut self,
        table: &ParamTable,
        link: L,
        sender: Sender,
        r: &PARAM_REQUEST_READ_DATA,
        out: &mut Vec<Outgoing<L>>,
        notices: &mut Vec<ParamNotice>,
    ) {
        let id: [u8; 16] = r.param_id.into();
        let index = if r.param_index >= 0 {
            let index = r.param_index as usize;
            if index >= table.len() {
                self.refuse(
                    link,
                    sender,
                    r.param_index,
                    id,
                    MavParamError::MAV_PARAM_ERROR_DOES_NOT_EXIST,
                    format!("Param read: no parameter #{index}"),
                    out,
                    notices,
                );
                return;
            }
            index as u16
        } else {
            let Some(name) = request_id(&id) else {
                self.refuse(
                    link,
                    sender,
                    -1,
                    id,
                    MavParamError::MAV_PARAM_ERROR_DOES_NOT_EXIST,
                    "Param read: id is not text".into(),
                    out,
                    notices,
                );
                return;
            };
            if name == HASH_CHECK_ID {
                out.push(Outgoing {
                    dest: Reply::Link(link),
                    message: hash_message(table),
                });
                return;
            }
            match table.index_of(name) {
                Some(index) => index,
                None => {
                    self.refuse(
                        link,
                        sender,
                        -1,
                        id,
                        MavParamError::MAV_PARAM_ERROR_DOES_NOT_EXIST,
                        format!("Param read: unknown {name}"),
                        out,
                        notices,
                    );
                    return;
                }
            }
        };
        out.push(Outgoing {
            dest: Reply::Link(link),
            message: value_message(table, index),
        });
    }

    fn set(
        &mut self,
        table: &mut ParamTable,
        link: L,
        sender: Sender,
        s: &PARAM_SET_DATA,
        out: &mut Vec<Outgoing<L>>,
        notices: &mut Vec<ParamNotice>,
    ) {
        let id: [u8; 16] = s.param_id.into();
        let Some(name) = request_id(&id) else {
            self.refuse(
                link,
                sender,
                -1,
                id,
                MavParamError::MAV_PARAM_ERROR_DOES_NOT_EXIST,
                "Param set: id is not text".into(),
                out,
                notices,
            );
            return;
        };
        if name == HASH_CHECK_ID {
            // PX4's scheme: the GCS's cache is valid, stop the list stream.
            self.streams.remove(&link);
            return;
        }
        let Some(index) = table.index_of(name) else {
            self.refuse(
                link,
                sender,
                -1,
                id,
                MavParamError::MAV_PARAM_ERROR_DOES_NOT_EXIST,
                format!("Param set: unknown {name}"),
                out,
                notices,
            );
            return;
        };
        // param_type is ignored (as ArduPilot does): the declared type rules.
        let before = table.value(index);
        if self.save_first
            && let Ok(value) = table.check(index, f64::from(s.param_value))
            && value != before
        {
            notices.push(ParamNotice::SaveRequested { index, value });
            return;
        }
        match table.set(index, f64::from(s.param_value)) {
            Ok(now) => {
                if now != before {
                    notices.push(ParamNotice::Changed { index });
                    if table.def(index).flags.reboot_required {
                        notices.push(ParamNotice::RebootRequired { name: name.to_owned() });
                    }
                }
            }
            Err(e) => {
                let (error, why) = set_error_reply(e, s.param_value);
                self.refuse(
                    link,
                    sender,
                    index as i16,
                    id,
                    error,
                    format!("{name}: {why}, kept {}", table.value(index)),
                    out,
                    notices,
                );
            }
        }
        // Always echo the value in force, to every link.
        out.push(Outgoing {
            dest: Reply::AllLinks,
            message: value_message(table, index),
        });
    }

    #[allow(clippy::too_many_arguments)]
    fn refuse(
        &self,
        link: L,
        sender: Sender,
        param_index: i16,
        id: [u8; 16],
        error: MavParamError,
        text: String,
        out: &mut Vec<Outgoing<L>>,
        notices: &mut Vec<ParamNotice>,
    ) {
        out.push(Outgoing {
            dest: Reply::Link(link),
            message: MavMessage::PARAM_ERROR(PARAM_ERROR_DATA {
                param_index,
                target_system: sender.system_id,
                target_component: sender.component_id,
                param_id: id.into(),
                error,
            }),
        });
        notices.push(ParamNotice::Refused { text });
    }
}

/// PARAM_VALUE carrying the table hash (bytewise in the float field).
pub fn hash_message(table: &ParamTable) -> MavMessage {
    let mut id = [0u8; 16];
    id[..HASH_CHECK_ID.len()].copy_from_slice(HASH_CHECK_ID.as_bytes());
    MavMessage::PARAM_VALUE(PARAM_VALUE_DATA {
        param_value: f32::from_bits(table_hash(table)),
        param_count: table.len() as u16,
        param_index: u16::MAX,
        param_id: id.into(),
        param_type: MavParamType::MAV_PARAM_TYPE_UINT32,
    })
}

/// The PARAM_ERROR code and the text that explain a refused set of
/// `param_value`.
fn set_error_reply(e: SetError, param_value: f32) -> (MavParamError, String) {
    match e {
        SetError::NotFinite => (
            MavParamError::MAV_PARAM_ERROR_VALUE_OUT_OF_RANGE,
            format!("{param_value} is not a number"),
        ),
        SetError::OutOfRange { min, max } => (
            MavParamError::MAV_PARAM_ERROR_VALUE_OUT_OF_RANGE,
            format!("{param_value} outside {min}..{max}"),
        ),
        SetError::ReadOnly => (MavParamError::MAV_PARAM_ERROR_READ_ONLY, "read-only".to_string()),
        SetError::UnknownName(_) => (MavParamError::MAV_PARAM_ERROR_DOES_NOT_EXIST, "unknown".to_string()),
    }
}
