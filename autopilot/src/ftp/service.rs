//! The FTP worker: a thread off the core's that answers
//! FILE_TRANSFER_PROTOCOL requests straight onto the links, so file I/O
//! never runs on the core's thread. The runners hand it each batch of link
//! messages ([`FtpService::offer`]); the core ignores FTP messages. A
//! fleet's vehicles share one such thread ([`FtpThread`]), each with its
//! own files and clients.

use std::collections::HashMap;
use std::path::Path;

use mavlink::dialects::ardupilotmega::{FILE_TRANSFER_PROTOCOL_DATA, MavMessage};

use super::disk::{DataFiles, Handle, PARAM_DIR};
use super::param_pack;
use super::server::Server;
use super::wire::{FtpError, Opcode, Payload};
use crate::shared_thread::{Client, Session, SharedThread};
use crate::vehicle::{Core, Destination, Inbound, LinkId, Outbound};

/// MAV_COMP_ID_AUTOPILOT1: the component that serves FTP.
const AUTOPILOT_COMPONENT: u8 = 1;

pub struct Job {
    link: LinkId,
    client: (u8, u8),
    request: Result<Payload, Payload>,
    /// Set when the request opens `@PARAM/…`: the table packed now.
    param_pack: Option<(bool, Vec<u8>)>,
}

/// The thread that serves FTP (one per process: a fleet's vehicles share it).
pub type FtpThread = SharedThread<VehicleFiles>;

/// Starts the FTP thread.
pub fn start_thread() -> std::io::Result<FtpThread> {
    SharedThread::start("ftp")
}

/// The handle the runners keep; dropping it ends this vehicle's session.
pub struct FtpService {
    jobs: Client<VehicleFiles>,
}

impl FtpService {
    /// Serves `data_dir` (and its `logs/` as `@LOGS/`) on `thread`, replying
    /// through `outbound`.
    pub fn start(thread: &FtpThread, data_dir: &Path, outbound: tokio::sync::mpsc::Sender<Outbound>) -> FtpService {
        let mut files = DataFiles::new(data_dir);
        files.mount("LOGS", data_dir.join("logs"));
        let session = VehicleFiles {
            files,
            clients: HashMap::new(),
            replies: Vec::new(),
            outbound: Some(outbound),
        };
        FtpService {
            jobs: thread.client(session),
        }
    }

    /// Passes the FTP requests among `messages` addressed to this vehicle to
    /// the worker. An open of `@PARAM/param.pck` carries the table packed
    /// here, at the moment it was asked for (a few kB, microseconds).
    pub fn offer(&self, messages: &[Inbound], core: &Core) {
        for m in messages {
            let MavMessage::FILE_TRANSFER_PROTOCOL(ftp) = &m.message else {
                continue;
            };
            let for_us = ftp.target_system == core.sysid() && matches!(ftp.target_component, 0 | AUTOPILOT_COMPONENT);
            if !for_us {
                continue;
            }
            let request = Payload::decode(&ftp.payload);
            let param_pack = request.as_ref().ok().and_then(|r| {
                let path = r.path()?;
                let opens = [Opcode::OpenFileRO, Opcode::CalcFileCRC32, Opcode::ListDirectory]
                    .iter()
                    .any(|op| r.opcode == *op as u8);
                let with_defaults = path.contains("withdefaults=1");
                (opens && path.trim_start_matches('/').starts_with(PARAM_DIR))
                    .then(|| (with_defaults, param_pack::pack(core.params(), with_defaults)))
            });
            let job = Job {
                link: m.link,
                client: (m.header.system_id as u8, m.header.component_id),
                request,
                param_pack,
            };
            if !self.jobs.send(job) {
                tracing::warn!("FTP worker gone: request dropped");
            }
        }
    }
}

/// One vehicle's files, its FTP clients and where its replies go.
pub struct VehicleFiles {
    files: DataFiles,
    clients: HashMap<(LinkId, u8, u8), Server<Handle>>,
    replies: Vec<Payload>,
    /// `None` once the links have gone: requests are then dropped.
    outbound: Option<tokio::sync::mpsc::Sender<Outbound>>,
}

impl Session for VehicleFiles {
    type Job = Job;

    fn handle(&mut self, job: Job) {
        let Some(outbound) = &self.outbound else {
            return;
        };
        if let Some((with_defaults, bytes)) = job.param_pack {
            self.files.set_param_pack(with_defaults, bytes);
        }
        self.replies.clear();
        match &job.request {
            Ok(req) => self
                .clients
                .entry((job.link, job.client.0, job.client.1))
                .or_default()
                .handle(&mut self.files, req, &mut self.replies),
            // A size past the payload: said so, nothing done.
            Err(req) => self.replies.push(Payload {
                seq: req.seq.wrapping_add(1),
                session: req.session,
                opcode: Opcode::Nak as u8,
                req_opcode: req.opcode,
                burst_complete: false,
                offset: req.offset,
                data: vec![FtpError::InvalidDataSize as u8],
            }),
        }
        for reply in self.replies.drain(..) {
            let message = MavMessage::FILE_TRANSFER_PROTOCOL(FILE_TRANSFER_PROTOCOL_DATA {
                target_network: 0,
                target_system: job.client.0,
                target_component: job.client.1,
                payload: reply.encode(),
            });
            // Waiting here is the worker's back-pressure, never the core's.
            let sent = outbound.blocking_send(Outbound {
                dest: Destination::Link(job.link),
                message,
            });
            if sent.is_err() {
                self.outbound = None;
                return;
            }
        }
    }

    fn pass(&mut self) -> Option<std::time::Duration> {
        None
    }

    fn close(&mut self) {}
}
