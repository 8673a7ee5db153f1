//! The FTP worker: a thread of its own that answers FILE_TRANSFER_PROTOCOL
//! requests straight onto the links, so file I/O never runs on the core's
//! thread. The runners hand it each batch of link messages
//! ([`FtpService::offer`]); the core ignores FTP messages.

use std::collections::HashMap;
use std::path::Path;
use std::sync::mpsc;

use mavlink::dialects::ardupilotmega::{FILE_TRANSFER_PROTOCOL_DATA, MavMessage};

use super::disk::{DataFiles, Handle, PARAM_DIR};
use super::param_pack;
use super::server::Server;
use super::wire::{FtpError, Opcode, Payload};
use crate::vehicle::{Core, Destination, Inbound, LinkId, Outbound};

/// MAV_COMP_ID_AUTOPILOT1: the component that serves FTP.
const AUTOPILOT_COMPONENT: u8 = 1;

struct Job {
    link: LinkId,
    client: (u8, u8),
    request: Result<Payload, Payload>,
    /// Set when the request opens `@PARAM/…`: the table packed now.
    param_pack: Option<(bool, Vec<u8>)>,
}

/// The handle the runners keep; dropping it stops the worker.
pub struct FtpService {
    jobs: mpsc::Sender<Job>,
}

impl FtpService {
    /// Serves `data_dir` (and its `logs/` as `@LOGS/`), replying through
    /// `outbound`.
    pub fn start(data_dir: &Path, outbound: tokio::sync::mpsc::Sender<Outbound>) -> FtpService {
        let mut files = DataFiles::new(data_dir);
        files.mount("LOGS", data_dir.join("logs"));
        let (jobs, rx) = mpsc::channel();
        std::thread::Builder::new()
            .name("ftp".into())
            .spawn(move || serve(files, &rx, &outbound))
            .expect("spawn ftp thread");
        FtpService { jobs }
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
            if self.jobs.send(job).is_err() {
                tracing::warn!("FTP worker gone: request dropped");
            }
        }
    }
}

fn serve(mut files: DataFiles, jobs: &mpsc::Receiver<Job>, outbound: &tokio::sync::mpsc::Sender<Outbound>) {
    let mut clients: HashMap<(LinkId, u8, u8), Server<Handle>> = HashMap::new();
    let mut replies = Vec::new();
    while let Ok(job) = jobs.recv() {
        if let Some((with_defaults, bytes)) = job.param_pack {
            files.set_param_pack(with_defaults, bytes);
        }
        replies.clear();
        match &job.request {
            Ok(req) => clients
                .entry((job.link, job.client.0, job.client.1))
                .or_default()
                .handle(&mut files, req, &mut replies),
            // A size past the payload: said so, nothing done.
            Err(req) => replies.push(Payload {
                seq: req.seq.wrapping_add(1),
                session: req.session,
                opcode: Opcode::Nak as u8,
                req_opcode: req.opcode,
                burst_complete: false,
                offset: req.offset,
                data: vec![FtpError::InvalidDataSize as u8],
            }),
        }
        for reply in replies.drain(..) {
            let message = MavMessage::FILE_TRANSFER_PROTOCOL(FILE_TRANSFER_PROTOCOL_DATA {
                target_network: 0,
                target_system: job.client.0,
                target_component: job.client.1,
                payload: reply.encode(),
            });
            // Waiting here is the worker's back-pressure, never the core's.
            if outbound
                .blocking_send(Outbound {
                    dest: Destination::Link(job.link),
                    message,
                })
                .is_err()
            {
                return;
            }
        }
    }
}
