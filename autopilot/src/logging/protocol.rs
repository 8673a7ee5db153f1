//! MAVLink's log transfer (LOG_REQUEST_LIST → LOG_ENTRY, LOG_REQUEST_DATA →
//! LOG_DATA, LOG_ERASE, LOG_REQUEST_END) as a state machine: no files, no
//! I/O. The edge gives it the list of logs, reads the chunks it asks for
//! and sends what it returns.

use mavlink::dialects::ardupilotmega::{LOG_DATA_DATA, LOG_ENTRY_DATA, MavMessage};

use crate::vehicle::LinkId;

/// Bytes in one LOG_DATA.
pub const CHUNK: usize = 90;

/// A log as LOG_ENTRY describes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LogInfo {
    pub id: u16,
    pub size_bytes: u32,
    /// UTC seconds of its last change (0: unknown).
    pub time_utc_s: u32,
}

/// What the edge must do for a request.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    Send(LinkId, Box<MavMessage>),
    /// Remove every log (LOG_ERASE).
    EraseAll,
}

/// The bytes to read next for a download: `len` may be 0 (the end-of-file
/// marker, sent when the file's length is a whole number of chunks).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChunkRequest {
    pub link: LinkId,
    pub id: u16,
    pub ofs: u32,
    pub len: usize,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Transfer {
    link: LinkId,
    id: u16,
    next_ofs: u32,
    /// Exclusive end of what was asked, within the file.
    end_ofs: u32,
    /// The file's size when the transfer began.
    size: u32,
    /// The last chunk sent was full (a reader waits for a short one).
    last_full: bool,
}

#[derive(Debug, Default)]
pub struct LogTransfer {
    transfer: Option<Transfer>,
}

impl LogTransfer {
    /// Answers one LOG_* message from `link`, given the logs there are
    /// (sorted by id).
    pub fn handle(&mut self, link: LinkId, message: &MavMessage, logs: &[LogInfo]) -> Vec<Action> {
        match message {
            MavMessage::LOG_REQUEST_LIST(r) => list(link, r.start, r.end, logs),
            MavMessage::LOG_REQUEST_DATA(r) => {
                self.start(link, r.id, r.ofs, r.count, logs);
                if self.transfer.is_none() {
                    // Unknown log: one empty chunk says there is nothing.
                    return vec![Action::Send(link, Box::new(log_data(r.id, r.ofs, &[])))];
                }
                Vec::new()
            }
            MavMessage::LOG_REQUEST_END(_) => {
                self.transfer = None;
                Vec::new()
            }
            MavMessage::LOG_ERASE(_) => {
                self.transfer = None;
                vec![Action::EraseAll]
            }
            _ => Vec::new(),
        }
    }

    fn start(&mut self, link: LinkId, id: u16, ofs: u32, count: u32, logs: &[LogInfo]) {
        self.transfer = logs.iter().find(|l| l.id == id).map(|log| Transfer {
            link,
            id,
            next_ofs: ofs.min(log.size_bytes),
            end_ofs: ofs.saturating_add(count).min(log.size_bytes),
            size: log.size_bytes,
            last_full: true,
        });
    }

    /// Whether a download is under way.
    pub fn busy(&self) -> bool {
        self.transfer.is_some()
    }

    /// What to read next, if anything.
    pub fn next_chunk(&self) -> Option<ChunkRequest> {
        let t = self.transfer?;
        let left = t.end_ofs.saturating_sub(t.next_ofs) as usize;
        Some(ChunkRequest {
            link: t.link,
            id: t.id,
            ofs: t.next_ofs,
            len: left.min(CHUNK),
        })
    }

    /// The LOG_DATA for the bytes read at [`Self::next_chunk`] (fewer than
    /// asked at the end of a file), advancing the transfer. `None` when the
    /// transfer is over without another message (a partial request done).
    pub fn chunk_read(&mut self, request: ChunkRequest, data: &[u8]) -> Option<MavMessage> {
        let t = self
            .transfer
            .as_mut()
            .filter(|t| t.next_ofs == request.ofs && t.id == request.id)?;
        let data = &data[..data.len().min(CHUNK)];
        if data.is_empty() && !(t.end_ofs == t.size && t.last_full) {
            self.transfer = None;
            return None;
        }
        t.next_ofs += data.len() as u32;
        t.last_full = data.len() == CHUNK;
        if data.is_empty() || !t.last_full || (t.next_ofs >= t.end_ofs && t.end_ofs < t.size) {
            self.transfer = None;
        }
        Some(log_data(request.id, request.ofs, data))
    }

    /// A link went away: its download stops.
    pub fn link_closed(&mut self, link: LinkId) {
        if self.transfer.is_some_and(|t| t.link == link) {
            self.transfer = None;
        }
    }
}

fn list(link: LinkId, start: u16, end: u16, logs: &[LogInfo]) -> Vec<Action> {
    let num_logs = logs.len().min(usize::from(u16::MAX)) as u16;
    let last_log_num = logs.iter().map(|l| l.id).max().unwrap_or(0);
    let entry = |log: &LogInfo| {
        Action::Send(
            link,
            Box::new(MavMessage::LOG_ENTRY(LOG_ENTRY_DATA {
                time_utc: log.time_utc_s,
                size: log.size_bytes,
                id: log.id,
                num_logs,
                last_log_num,
            })),
        )
    };
    if logs.is_empty() {
        // ArduPilot's answer when there are none: one entry, id 0.
        return vec![entry(&LogInfo {
            id: 0,
            size_bytes: 0,
            time_utc_s: 0,
        })];
    }
    logs.iter()
        .filter(|l| (start..=end).contains(&l.id))
        .map(entry)
        .collect()
}

fn log_data(id: u16, ofs: u32, data: &[u8]) -> MavMessage {
    let mut buf = [0u8; CHUNK];
    buf[..data.len()].copy_from_slice(data);
    MavMessage::LOG_DATA(LOG_DATA_DATA {
        ofs,
        id,
        count: data.len() as u8,
        data: buf,
    })
}

#[cfg(test)]
mod tests {
    use mavlink::dialects::ardupilotmega::{LOG_REQUEST_DATA_DATA, LOG_REQUEST_END_DATA, LOG_REQUEST_LIST_DATA};

    use super::*;

    const LINK: LinkId = LinkId(1);

    fn logs() -> Vec<LogInfo> {
        vec![
            LogInfo {
                id: 3,
                size_bytes: 200,
                time_utc_s: 7,
            },
            LogInfo {
                id: 4,
                size_bytes: 180,
                time_utc_s: 8,
            },
        ]
    }

    fn request(id: u16, ofs: u32, count: u32) -> MavMessage {
        MavMessage::LOG_REQUEST_DATA(LOG_REQUEST_DATA_DATA {
            ofs,
            count,
            id,
            target_system: 1,
            target_component: 1,
        })
    }

    /// Runs a download against `file`, returning (ofs, count) of each LOG_DATA.
    fn download(p: &mut LogTransfer, file: &[u8]) -> Vec<(u32, u8)> {
        let mut sent = Vec::new();
        while let Some(c) = p.next_chunk() {
            let start = (c.ofs as usize).min(file.len());
            let end = (start + c.len).min(file.len());
            match p.chunk_read(c, &file[start..end]) {
                Some(MavMessage::LOG_DATA(d)) => {
                    assert_eq!(
                        &d.data[..usize::from(d.count)],
                        &file[start..start + usize::from(d.count)]
                    );
                    sent.push((d.ofs, d.count));
                }
                Some(other) => panic!("{other:?}"),
                None => {}
            }
            assert!(sent.len() < 100, "runaway");
        }
        sent
    }

    #[test]
    fn the_list_names_every_log_in_range() {
        let mut p = LogTransfer::default();
        let list = MavMessage::LOG_REQUEST_LIST(LOG_REQUEST_LIST_DATA {
            start: 0,
            end: u16::MAX,
            target_system: 1,
            target_component: 1,
        });
        let replies = p.handle(LINK, &list, &logs());
        let entries: Vec<_> = replies
            .iter()
            .map(|a| match a {
                Action::Send(LINK, m) => match &**m {
                    MavMessage::LOG_ENTRY(e) => (e.id, e.size, e.num_logs, e.last_log_num),
                    other => panic!("{other:?}"),
                },
                other => panic!("{other:?}"),
            })
            .collect();
        assert_eq!(entries, vec![(3, 200, 2, 4), (4, 180, 2, 4)]);
        let none = p.handle(LINK, &list, &[]);
        assert!(
            matches!(&none[..], [Action::Send(_, m)] if matches!(&**m, MavMessage::LOG_ENTRY(e) if e.id == 0 && e.num_logs == 0))
        );
    }

    #[test]
    fn a_whole_file_download_ends_with_a_short_chunk() {
        let mut p = LogTransfer::default();
        let file: Vec<u8> = (0..200u32).map(|i| i as u8).collect();
        assert!(p.handle(LINK, &request(3, 0, u32::MAX), &logs()).is_empty());
        assert_eq!(download(&mut p, &file), vec![(0, 90), (90, 90), (180, 20)]);
        assert!(!p.busy());
    }

    #[test]
    fn a_file_of_whole_chunks_ends_with_an_empty_one() {
        let mut p = LogTransfer::default();
        let file = vec![7u8; 180];
        p.handle(LINK, &request(4, 0, u32::MAX), &logs());
        assert_eq!(download(&mut p, &file), vec![(0, 90), (90, 90), (180, 0)]);
    }

    #[test]
    fn a_partial_request_sends_just_that_range() {
        let mut p = LogTransfer::default();
        let file = vec![1u8; 200];
        p.handle(LINK, &request(3, 45, 90), &logs());
        assert_eq!(download(&mut p, &file), vec![(45, 90)]);
        p.handle(LINK, &request(3, 150, 1000), &logs());
        assert_eq!(download(&mut p, &file), vec![(150, 50)]);
    }

    #[test]
    fn an_unknown_log_is_answered_empty_and_end_stops_a_transfer() {
        let mut p = LogTransfer::default();
        let replies = p.handle(LINK, &request(9, 0, 100), &logs());
        assert!(
            matches!(&replies[..], [Action::Send(_, m)] if matches!(&**m, MavMessage::LOG_DATA(d) if d.id == 9 && d.count == 0))
        );
        p.handle(LINK, &request(3, 0, u32::MAX), &logs());
        assert!(p.busy());
        let end = MavMessage::LOG_REQUEST_END(LOG_REQUEST_END_DATA {
            target_system: 1,
            target_component: 1,
        });
        p.handle(LINK, &end, &logs());
        assert!(!p.busy());
        p.handle(LINK, &request(3, 0, u32::MAX), &logs());
        p.link_closed(LinkId(2));
        assert!(p.busy());
        p.link_closed(LINK);
        assert!(!p.busy());
    }

    #[test]
    fn a_stale_read_does_not_advance_the_transfer() {
        let mut p = LogTransfer::default();
        p.handle(LINK, &request(3, 0, u32::MAX), &logs());
        let c = p.next_chunk().unwrap();
        p.handle(LINK, &request(3, 90, u32::MAX), &logs());
        assert_eq!(p.chunk_read(c, &[0; 90]), None);
        assert_eq!(p.next_chunk().unwrap().ofs, 90);
    }
}
