//! The FTP protocol as a state machine: requests in, replies out, sessions
//! kept. It touches no file itself: every file operation goes through
//! [`Files`], which the edge implements on the data directory and tests
//! implement in memory.
//!
//! Sessions are numbered by the client (the number in its open request is
//! the one the replies carry, as ArduPilot does and MAVProxy relies on).
//! An open on a session that is already open replaces it: a client that
//! restarted without terminating must not be locked out. A request repeating
//! the last one (same seq, session, opcode) gets the same reply again
//! without doing the operation twice (a lost reply to a write or create).

use super::wire::{FtpError, MAX_DATA, Opcode, Payload};

/// Open sessions per client.
pub const MAX_SESSIONS: usize = 4;
/// Packets in one burst before the client must ask for more (it does, from
/// where the burst ended). Replies are never dropped (the link layer paces
/// bulk replies to the link), so this bounds how much one request queues
/// on a slow serial link; on a fast link the extra round trip is a few ms.
const MAX_BURST_PACKETS: usize = 64;

/// Why a file operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FsError {
    NotFound,
    Exists,
    /// Outside what the server exposes, a vehicle-owned file, or a path
    /// that tries to leave the served tree.
    Protected,
    /// Any other failure, with its errno (0 when unknown).
    Errno(u8),
}

/// One directory entry.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Entry {
    File { name: String, size: u64 },
    Dir { name: String },
}

/// The file operations the protocol needs.
pub trait Files {
    type Handle;
    fn list(&mut self, dir: &str) -> Result<Vec<Entry>, FsError>;
    /// Opens for reading: the handle and the file's size.
    fn open_read(&mut self, path: &str) -> Result<(Self::Handle, u32), FsError>;
    /// Opens for writing: `create` makes or empties the file, else it must
    /// exist. Returns the handle and the size it has.
    fn open_write(&mut self, path: &str, create: bool) -> Result<(Self::Handle, u32), FsError>;
    fn read(&mut self, handle: &mut Self::Handle, offset: u32, buf: &mut [u8]) -> Result<usize, FsError>;
    fn write(&mut self, handle: &mut Self::Handle, offset: u32, data: &[u8]) -> Result<(), FsError>;
    fn remove_file(&mut self, path: &str) -> Result<(), FsError>;
    fn create_dir(&mut self, path: &str) -> Result<(), FsError>;
    fn remove_dir(&mut self, path: &str) -> Result<(), FsError>;
    fn truncate(&mut self, path: &str, len: u32) -> Result<(), FsError>;
    fn rename(&mut self, from: &str, to: &str) -> Result<(), FsError>;
    /// ArduPilot's `crc_crc32` of the whole file (seed 0, no final XOR).
    fn crc32(&mut self, path: &str) -> Result<u32, FsError>;
}

struct Session<H> {
    id: u8,
    handle: H,
    writable: bool,
}

/// The sessions of one client (a system/component on one link).
pub struct Server<H> {
    sessions: Vec<Session<H>>,
    last: Option<(Payload, Vec<Payload>)>,
}

impl<H> Default for Server<H> {
    fn default() -> Self {
        Server {
            sessions: Vec::new(),
            last: None,
        }
    }
}

type Reply = Result<(Vec<u8>, u32), FsError>;

fn reply(req: &Payload, seq_step: u16, opcode: Opcode, offset: u32, data: Vec<u8>) -> Payload {
    Payload {
        seq: req.seq.wrapping_add(seq_step),
        session: req.session,
        opcode: opcode as u8,
        req_opcode: req.opcode,
        burst_complete: false,
        offset,
        data,
    }
}

fn nak(req: &Payload, error: FtpError) -> Payload {
    reply(req, 1, Opcode::Nak, req.offset, vec![error as u8])
}

fn nak_fs(req: &Payload, error: FsError) -> Payload {
    match error {
        FsError::NotFound => nak(req, FtpError::FileNotFound),
        FsError::Exists => nak(req, FtpError::FileExists),
        FsError::Protected => nak(req, FtpError::FileProtected),
        FsError::Errno(e) => reply(req, 1, Opcode::Nak, req.offset, vec![FtpError::FailErrno as u8, e]),
    }
}

impl<H> Server<H> {
    /// Answers one request (a burst read answers with many payloads).
    pub fn handle<F: Files<Handle = H>>(&mut self, files: &mut F, req: &Payload, out: &mut Vec<Payload>) {
        if let Some((last_req, replies)) = &self.last
            && last_req == req
        {
            out.extend(replies.iter().cloned());
            return;
        }
        let start = out.len();
        self.dispatch(files, req, out);
        // Bursts are re-read, not replayed: they can be long.
        if req.opcode != Opcode::BurstReadFile as u8 {
            self.last = Some((req.clone(), out[start..].to_vec()));
        } else {
            self.last = None;
        }
    }

    fn dispatch<F: Files<Handle = H>>(&mut self, files: &mut F, req: &Payload, out: &mut Vec<Payload>) {
        let Some(op) = Opcode::from_u8(req.opcode) else {
            out.push(nak(req, FtpError::UnknownCommand));
            return;
        };
        let path = || req.path().ok_or(FsError::NotFound);
        let done: Reply = match op {
            Opcode::TerminateSession => match self.close(req.session) {
                true => Ok((Vec::new(), req.offset)),
                false => {
                    out.push(nak(req, FtpError::InvalidSession));
                    return;
                }
            },
            Opcode::ResetSessions => {
                self.sessions.clear();
                Ok((Vec::new(), req.offset))
            }
            Opcode::ListDirectory => return out.push(list(files, req)),
            Opcode::OpenFileRO => path().and_then(|p| files.open_read(p)).map(|(h, size)| {
                self.open(req.session, h, false);
                (size.to_le_bytes().to_vec(), 0)
            }),
            Opcode::CreateFile | Opcode::OpenFileWO => path()
                .and_then(|p| files.open_write(p, op == Opcode::CreateFile))
                .map(|(h, size)| {
                    self.open(req.session, h, true);
                    (size.to_le_bytes().to_vec(), 0)
                }),
            Opcode::ReadFile => return out.push(self.read(files, req)),
            Opcode::BurstReadFile => return self.burst(files, req, out),
            Opcode::WriteFile => return out.push(self.write(files, req)),
            Opcode::RemoveFile => path().and_then(|p| files.remove_file(p)).map(|()| (Vec::new(), 0)),
            Opcode::CreateDirectory => path().and_then(|p| files.create_dir(p)).map(|()| (Vec::new(), 0)),
            Opcode::RemoveDirectory => path().and_then(|p| files.remove_dir(p)).map(|()| (Vec::new(), 0)),
            Opcode::TruncateFile => path()
                .and_then(|p| files.truncate(p, req.offset))
                .map(|()| (Vec::new(), req.offset)),
            Opcode::Rename => rename(files, req),
            Opcode::CalcFileCRC32 => path()
                .and_then(|p| files.crc32(p))
                .map(|crc| (crc.to_le_bytes().to_vec(), 0)),
            Opcode::None | Opcode::Ack | Opcode::Nak => {
                out.push(nak(req, FtpError::UnknownCommand));
                return;
            }
        };
        out.push(match done {
            Ok((data, offset)) => reply(req, 1, Opcode::Ack, offset, data),
            Err(e) => nak_fs(req, e),
        });
    }

    fn open(&mut self, id: u8, handle: H, writable: bool) {
        self.close(id);
        if self.sessions.len() >= MAX_SESSIONS {
            // The oldest goes: a client that never terminates must not
            // exhaust the server.
            self.sessions.remove(0);
        }
        self.sessions.push(Session { id, handle, writable });
    }

    fn close(&mut self, id: u8) -> bool {
        let before = self.sessions.len();
        self.sessions.retain(|s| s.id != id);
        self.sessions.len() != before
    }

    fn session(&mut self, id: u8) -> Option<&mut Session<H>> {
        self.sessions.iter_mut().find(|s| s.id == id)
    }

    fn read<F: Files<Handle = H>>(&mut self, files: &mut F, req: &Payload) -> Payload {
        let Some(session) = self.session(req.session).filter(|s| !s.writable) else {
            return nak(req, FtpError::InvalidSession);
        };
        let want = chunk_len(req.data.len());
        let mut buf = vec![0u8; want];
        match files.read(&mut session.handle, req.offset, &mut buf) {
            Ok(0) => nak(req, FtpError::EndOfFile),
            Ok(n) => {
                buf.truncate(n);
                reply(req, 1, Opcode::Ack, req.offset, buf)
            }
            Err(e) => nak_fs(req, e),
        }
    }

    fn burst<F: Files<Handle = H>>(&mut self, files: &mut F, req: &Payload, out: &mut Vec<Payload>) {
        let Some(session) = self.session(req.session).filter(|s| !s.writable) else {
            return out.push(nak(req, FtpError::InvalidSession));
        };
        let chunk = chunk_len(req.data.len());
        let mut offset = req.offset;
        for k in 0..MAX_BURST_PACKETS {
            let step = u16::try_from(k + 1).unwrap_or(u16::MAX);
            let mut buf = vec![0u8; chunk];
            let n = match files.read(&mut session.handle, offset, &mut buf) {
                Ok(n) => n,
                Err(e) => {
                    let mut r = nak_fs(req, e);
                    r.seq = req.seq.wrapping_add(step);
                    r.burst_complete = true;
                    return out.push(r);
                }
            };
            if n == 0 {
                let mut r = reply(req, step, Opcode::Nak, offset, vec![FtpError::EndOfFile as u8]);
                r.burst_complete = true;
                return out.push(r);
            }
            buf.truncate(n);
            let mut r = reply(req, step, Opcode::Ack, offset, buf);
            r.burst_complete = n < chunk || k + 1 == MAX_BURST_PACKETS;
            let last = r.burst_complete;
            out.push(r);
            if last {
                return;
            }
            offset = offset.saturating_add(n as u32);
        }
    }

    fn write<F: Files<Handle = H>>(&mut self, files: &mut F, req: &Payload) -> Payload {
        let Some(session) = self.session(req.session).filter(|s| s.writable) else {
            return nak(req, FtpError::InvalidSession);
        };
        match files.write(&mut session.handle, req.offset, &req.data) {
            Ok(()) => reply(req, 1, Opcode::Ack, req.offset, Vec::new()),
            Err(e) => nak_fs(req, e),
        }
    }
}

/// A read's length: the request's size field (its data length: a read
/// request's data is `size` unused bytes), or a full payload when 0.
fn chunk_len(asked: usize) -> usize {
    if asked == 0 || asked > MAX_DATA {
        MAX_DATA
    } else {
        asked
    }
}

fn rename<F: Files>(files: &mut F, req: &Payload) -> Reply {
    let mut parts = req.data.split(|&b| b == 0).map(std::str::from_utf8);
    match (parts.next(), parts.next()) {
        (Some(Ok(from)), Some(Ok(to))) if !from.is_empty() && !to.is_empty() => {
            files.rename(from, to).map(|()| (Vec::new(), 0))
        }
        _ => Err(FsError::NotFound),
    }
}

/// ListDirectory: entries from index `offset`, as many as fit, each
/// `F<name>\t<size>` or `D<name>`, NUL-terminated; EOF past the last.
fn list<F: Files>(files: &mut F, req: &Payload) -> Payload {
    let Some(dir) = req.path() else {
        return nak(req, FtpError::FileNotFound);
    };
    let entries = match files.list(dir) {
        Ok(e) => e,
        Err(e) => return nak_fs(req, e),
    };
    let mut data = Vec::new();
    for entry in entries.iter().skip(req.offset as usize) {
        let text = match entry {
            Entry::File { name, size } => format!("F{name}\t{size}"),
            Entry::Dir { name } => format!("D{name}"),
        };
        if data.len() + text.len() + 1 > MAX_DATA {
            break;
        }
        data.extend_from_slice(text.as_bytes());
        data.push(0);
    }
    if data.is_empty() {
        return nak(req, FtpError::EndOfFile);
    }
    reply(req, 1, Opcode::Ack, req.offset, data)
}
