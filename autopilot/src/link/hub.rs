//! The link runtime: a tokio runtime on its own thread running one task per
//! link and the hub task that owns the registry and the router.
//!
//! Inbound: link task → frames → hub → routed to other links as raw bytes
//! and, when addressed to us, decoded messages to the core's channel.
//! Outbound: core → hub → each link's bounded queue (`try_send`: a full queue
//! drops and counts, it never waits) → the link's writer, which stamps its
//! own sequence numbers.

use std::collections::BTreeMap;
use std::io;
use std::net::{SocketAddr, ToSocketAddrs};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicU16, Ordering};
use std::time::Duration;

use mavlink::dialects::ardupilotmega::{MavMessage, MavResult};
use mavlink::{MavHeader, Message};
use tokio::io::{AsyncWrite, AsyncWriteExt};
use tokio::net::{TcpListener, UdpSocket};
use tokio::sync::mpsc;

use super::encode::{encode_raw_command_ack, encode_v2};
use super::endpoint::Endpoint;
use super::frame::{FrameStats, ReceivedFrame};
use super::router::Router;
use super::tlog::{self, TlogRecord};
use crate::vehicle::{COMPONENT_ID, Destination, Inbound, LinkEvent, LinkId, Outbound, UndecodableItem};

/// Messages queued per link before new ones are dropped.
pub(super) const LINK_QUEUE: usize = 512;
const CORE_QUEUE: usize = 4096;

/// What a link's writer sends.
pub(super) enum OutItem {
    Message(Arc<MavMessage>),
    /// Forwarded from another link, unchanged.
    Frame(Arc<[u8]>),
    /// COMMAND_ACK(UNSUPPORTED) for a command id the dialect lacks.
    UnknownCommandAck {
        command: u16,
        target_system: u8,
        target_component: u8,
    },
}

/// Serialises a link's outgoing items with its own sequence counter.
pub(super) struct LinkEncoder {
    sysid: u8,
    sequence: u8,
}

impl LinkEncoder {
    pub(super) fn new(sysid: u8) -> Self {
        LinkEncoder { sysid, sequence: 0 }
    }

    fn header(&mut self) -> MavHeader {
        let header = MavHeader {
            system_id: u32::from(self.sysid),
            component_id: COMPONENT_ID,
            sequence: self.sequence,
        };
        self.sequence = self.sequence.wrapping_add(1);
        header
    }

    pub(super) fn encode(&mut self, item: &OutItem) -> Vec<u8> {
        match item {
            OutItem::Message(m) => encode_v2(self.header(), m),
            OutItem::Frame(bytes) => bytes.to_vec(),
            OutItem::UnknownCommandAck {
                command,
                target_system,
                target_component,
            } => {
                let header = self.header();
                encode_raw_command_ack(
                    header,
                    *command,
                    MavResult::MAV_RESULT_UNSUPPORTED as u8,
                    *target_system,
                    *target_component,
                )
            }
        }
    }
}

/// Writes a link's queue to its byte stream until the stream fails.
pub(super) async fn write_loop<W: AsyncWrite + Unpin>(mut write: W, mut rx: mpsc::Receiver<OutItem>, sysid: u8) {
    let mut encoder = LinkEncoder::new(sysid);
    while let Some(item) = rx.recv().await {
        if write.write_all(&encoder.encode(&item)).await.is_err() {
            return;
        }
    }
}

/// Hands out link ids; ids are never reused within a process.
#[derive(Clone, Default)]
pub(super) struct LinkIds(Arc<AtomicU16>);

impl LinkIds {
    pub(super) fn next(&self) -> LinkId {
        LinkId(self.0.fetch_add(1, Ordering::Relaxed))
    }
}

// Frames are the common case; boxing them would allocate per message.
#[allow(clippy::large_enum_variant)]
pub(super) enum HubEvent {
    Opened {
        link: LinkId,
        slot: u8,
        name: String,
        tx: mpsc::Sender<OutItem>,
    },
    Closed {
        link: LinkId,
    },
    Frame {
        link: LinkId,
        frame: ReceivedFrame,
    },
    Stats {
        link: LinkId,
        stats: FrameStats,
    },
}

/// What the core thread receives.
#[derive(Debug)]
#[allow(clippy::large_enum_variant)]
pub enum ToCore {
    Event(LinkEvent),
    Message(Inbound),
    UndecodableItem(UndecodableItem),
}

/// Which links to open.
#[derive(Clone, Debug, Default)]
pub struct LinkConfig {
    pub sysid: u8,
    /// The TCP server (stream slot 0): `host:port`, port 0 for any.
    pub tcp_server: Option<String>,
    /// The UDP link (stream slot 1): where to send until someone answers.
    pub udp_out: Option<String>,
    /// Extra endpoints (stream slots 2, 3, then 3 again).
    pub extra: Vec<Endpoint>,
    pub tlog: Option<PathBuf>,
}

/// The core thread's end of the link layer.
pub struct CoreChannels {
    pub inbound: mpsc::Receiver<ToCore>,
    pub outbound: mpsc::Sender<Outbound>,
}

/// Addresses actually bound (ports may have been 0).
#[derive(Clone, Debug, Default)]
pub struct BoundAddresses {
    pub tcp: Option<SocketAddr>,
    pub udp_local: Option<SocketAddr>,
}

/// The running link layer; dropping it stops the runtime thread.
pub struct LinkRuntime {
    pub bound: BoundAddresses,
    _thread: std::thread::JoinHandle<()>,
}

fn resolve(spec: &str) -> io::Result<SocketAddr> {
    spec.to_socket_addrs()?
        .next()
        .ok_or_else(|| io::Error::new(io::ErrorKind::NotFound, format!("{spec}: no address")))
}

/// Binds every configured endpoint (so a busy port is an error now, not
/// later) and starts the runtime thread.
pub fn start(config: LinkConfig) -> io::Result<(LinkRuntime, CoreChannels)> {
    let runtime = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
    let (hub_tx, hub_rx) = mpsc::channel::<HubEvent>(1024);
    let (core_tx, core_rx) = mpsc::channel::<ToCore>(CORE_QUEUE);
    let (out_tx, out_rx) = mpsc::channel::<Outbound>(CORE_QUEUE);
    let ids = LinkIds::default();
    let sysid = config.sysid;
    let mut bound = BoundAddresses::default();

    let setup = runtime.block_on(async {
        let mut tasks: Vec<std::pin::Pin<Box<dyn std::future::Future<Output = ()> + Send>>> = Vec::new();
        if let Some(spec) = &config.tcp_server {
            let listener = TcpListener::bind(resolve(spec)?).await?;
            bound.tcp = Some(listener.local_addr()?);
            tasks.push(Box::pin(super::tcp::serve(
                listener,
                0,
                ids.clone(),
                hub_tx.clone(),
                sysid,
            )));
        }
        if let Some(spec) = &config.udp_out {
            let peer = resolve(spec)?;
            let socket = UdpSocket::bind(unspecified_like(peer)).await?;
            bound.udp_local = Some(socket.local_addr()?);
            let name = format!("udp to {peer}");
            tasks.push(Box::pin(super::udp::run(
                socket,
                Some(peer),
                ids.next(),
                1,
                name,
                hub_tx.clone(),
                sysid,
            )));
        }
        for (i, endpoint) in config.extra.iter().enumerate() {
            let slot = (2 + i).min(3) as u8;
            match endpoint {
                Endpoint::UdpOut { host, port } => {
                    let peer = resolve(&format!("{host}:{port}"))?;
                    let socket = UdpSocket::bind(unspecified_like(peer)).await?;
                    tasks.push(Box::pin(super::udp::run(
                        socket,
                        Some(peer),
                        ids.next(),
                        slot,
                        endpoint.to_string(),
                        hub_tx.clone(),
                        sysid,
                    )));
                }
                Endpoint::UdpIn { host, port } => {
                    let socket = UdpSocket::bind(resolve(&format!("{host}:{port}"))?).await?;
                    tasks.push(Box::pin(super::udp::run(
                        socket,
                        None,
                        ids.next(),
                        slot,
                        endpoint.to_string(),
                        hub_tx.clone(),
                        sysid,
                    )));
                }
                Endpoint::TcpServer { host, port } => {
                    let listener = TcpListener::bind(resolve(&format!("{host}:{port}"))?).await?;
                    tasks.push(Box::pin(super::tcp::serve(
                        listener,
                        slot,
                        ids.clone(),
                        hub_tx.clone(),
                        sysid,
                    )));
                }
                Endpoint::TcpClient { host, port } => {
                    tasks.push(Box::pin(super::tcp::connect_forever(
                        format!("{host}:{port}"),
                        slot,
                        ids.clone(),
                        hub_tx.clone(),
                        sysid,
                    )));
                }
                Endpoint::Serial { device, baud } => {
                    super::serial::spawn(device.clone(), *baud, slot, ids.clone(), hub_tx.clone(), sysid);
                }
            }
        }
        let tlog = match &config.tlog {
            Some(path) => {
                let (tx, task) =
                    tlog::open(path).map_err(|e| io::Error::new(e.kind(), format!("tlog {}: {e}", path.display())))?;
                tasks.push(Box::pin(task));
                Some(tx)
            }
            None => None,
        };
        Ok::<_, io::Error>((tasks, tlog))
    });
    let (tasks, tlog) = setup?;
    drop(hub_tx);

    let thread = std::thread::Builder::new().name("links".into()).spawn(move || {
        runtime.block_on(async move {
            for task in tasks {
                tokio::spawn(task);
            }
            Hub::new(sysid, core_tx, tlog).run(hub_rx, out_rx).await;
        });
    })?;
    Ok((
        LinkRuntime { bound, _thread: thread },
        CoreChannels {
            inbound: core_rx,
            outbound: out_tx,
        },
    ))
}

/// Binds loopback for a loopback peer (so nothing else on the network can
/// inject), any address otherwise.
fn unspecified_like(peer: SocketAddr) -> SocketAddr {
    match peer {
        SocketAddr::V4(a) if a.ip().is_loopback() => "127.0.0.1:0".parse().expect("literal"),
        SocketAddr::V4(_) => "0.0.0.0:0".parse().expect("literal"),
        SocketAddr::V6(a) if a.ip().is_loopback() => "[::1]:0".parse().expect("literal"),
        SocketAddr::V6(_) => "[::]:0".parse().expect("literal"),
    }
}

struct LinkEntry {
    name: String,
    tx: mpsc::Sender<OutItem>,
    rx_stats: FrameStats,
    dropped_out: u64,
    /// (unframed bytes, undecodable frames, tx dropped) at the last report.
    reported: (u64, u64, u64),
}

struct Hub {
    links: BTreeMap<LinkId, LinkEntry>,
    router: Router,
    to_core: mpsc::Sender<ToCore>,
    tlog: Option<mpsc::Sender<TlogRecord>>,
    tlog_encoder: LinkEncoder,
    dropped_to_core: u64,
    reported_to_core: u64,
}

impl Hub {
    fn new(sysid: u8, to_core: mpsc::Sender<ToCore>, tlog: Option<mpsc::Sender<TlogRecord>>) -> Self {
        Hub {
            links: BTreeMap::new(),
            router: Router::new(sysid, COMPONENT_ID),
            to_core,
            tlog,
            tlog_encoder: LinkEncoder::new(sysid),
            dropped_to_core: 0,
            reported_to_core: 0,
        }
    }

    async fn run(mut self, mut events: mpsc::Receiver<HubEvent>, mut from_core: mpsc::Receiver<Outbound>) {
        let mut report = tokio::time::interval(Duration::from_secs(2));
        loop {
            tokio::select! {
                event = events.recv() => match event {
                    Some(event) => self.on_event(event).await,
                    None => return,
                },
                out = from_core.recv() => match out {
                    Some(out) => self.on_outbound(out),
                    None => return,
                },
                _ = report.tick() => self.report(),
            }
        }
    }

    async fn on_event(&mut self, event: HubEvent) {
        match event {
            HubEvent::Opened { link, slot, name, tx } => {
                tracing::info!("link {}: {name} (stream slot SR{slot})", link.0);
                self.links.insert(
                    link,
                    LinkEntry {
                        name,
                        tx,
                        rx_stats: FrameStats::default(),
                        dropped_out: 0,
                        reported: Default::default(),
                    },
                );
                // Link events must not be lost: wait for room.
                let _ = self
                    .to_core
                    .send(ToCore::Event(LinkEvent::Opened {
                        link,
                        stream_slot: slot,
                    }))
                    .await;
            }
            HubEvent::Closed { link } => {
                self.links.remove(&link);
                self.router.remove_link(link);
                let _ = self.to_core.send(ToCore::Event(LinkEvent::Closed { link })).await;
            }
            HubEvent::Stats { link, stats } => {
                if let Some(entry) = self.links.get_mut(&link) {
                    entry.rx_stats = stats;
                }
            }
            HubEvent::Frame { link, frame } => self.on_frame(link, frame),
        }
    }

    fn on_frame(&mut self, link: LinkId, frame: ReceivedFrame) {
        if let Some(tlog) = &self.tlog {
            let _ = tlog.try_send(TlogRecord::now(frame.bytes().to_vec()));
        }
        let (target_system, target_component) = match &frame.message {
            Ok(m) => (m.target_system_id(), m.target_component_id()),
            Err(_) => command_targets(&frame).map_or((None, None), |(_, s, c)| (Some(s), Some(c))),
        };
        let decision = self.router.route(
            link,
            frame.header.system_id,
            frame.header.component_id,
            frame.message_id(),
            target_system,
            target_component,
        );
        if !decision.forward_to.is_empty() {
            let bytes: Arc<[u8]> = Arc::from(frame.bytes());
            for to in decision.forward_to {
                self.queue(to, OutItem::Frame(bytes.clone()));
            }
        }
        if !decision.deliver_locally {
            return;
        }
        match frame.message {
            Ok(message) => {
                let inbound = Inbound {
                    link,
                    header: frame.header,
                    version: frame.version,
                    message,
                };
                if self.to_core.try_send(ToCore::Message(inbound)).is_err() {
                    self.dropped_to_core += 1;
                }
            }
            Err(_) => {
                if let Some(item) = mission::protocol::inspect_undecodable_item(frame.message_id(), frame.raw.payload())
                {
                    let item = UndecodableItem {
                        link,
                        header: frame.header,
                        seq: item.seq,
                        mission_type: item.mission_type,
                        target_system: item.target_system,
                        target_component: item.target_component,
                        bad_frame: item.bad_frame,
                    };
                    if self.to_core.try_send(ToCore::UndecodableItem(item)).is_err() {
                        self.dropped_to_core += 1;
                    }
                } else if let Some((command, _, _)) = command_targets(&frame) {
                    let ack = OutItem::UnknownCommandAck {
                        command,
                        target_system: frame.header.system_id as u8,
                        target_component: frame.header.component_id,
                    };
                    self.queue(link, ack);
                }
            }
        }
    }

    fn on_outbound(&mut self, out: Outbound) {
        if let Some(tlog) = &self.tlog {
            let bytes = self
                .tlog_encoder
                .encode(&OutItem::Message(Arc::new(out.message.clone())));
            let _ = tlog.try_send(TlogRecord::now(bytes));
        }
        let message = Arc::new(out.message);
        match out.dest {
            Destination::Link(link) => self.queue(link, OutItem::Message(message)),
            Destination::AllLinks => {
                let links: Vec<LinkId> = self.links.keys().copied().collect();
                for link in links {
                    self.queue(link, OutItem::Message(message.clone()));
                }
            }
        }
    }

    fn queue(&mut self, link: LinkId, item: OutItem) {
        if let Some(entry) = self.links.get_mut(&link)
            && entry.tx.try_send(item).is_err()
        {
            if entry.dropped_out == 0 {
                tracing::warn!("link {} ({}): not keeping up, dropping messages", link.0, entry.name);
            }
            entry.dropped_out += 1;
        }
    }

    /// Logs links whose error counters changed since the last report: quiet
    /// while all is well, prompt when a link delivers garbage or cannot keep up.
    fn report(&mut self) {
        for (id, entry) in &mut self.links {
            let s = entry.rx_stats;
            let errors = (s.bytes_unframed, s.decode_errors, entry.dropped_out);
            if errors == entry.reported {
                continue;
            }
            tracing::warn!(
                "link {} ({}): rx {} frames ({} MAVLink 1), {} bytes unframed, {} undecodable; {} tx dropped",
                id.0,
                entry.name,
                s.frames,
                s.frames_v1,
                s.bytes_unframed,
                s.decode_errors,
                entry.dropped_out
            );
            entry.reported = errors;
        }
        if self.dropped_to_core != self.reported_to_core {
            tracing::warn!(
                "{} inbound messages dropped so far: core queue full",
                self.dropped_to_core
            );
            self.reported_to_core = self.dropped_to_core;
        }
    }
}

/// COMMAND_LONG and COMMAND_INT both carry the command id at byte 28 and
/// the target at bytes 30–31 (MAVLink 2 trims trailing zeros, so pad).
fn command_targets(frame: &ReceivedFrame) -> Option<(u16, u8, u8)> {
    const COMMAND_INT: u32 = 75;
    const COMMAND_LONG: u32 = 76;
    if !matches!(frame.message_id(), COMMAND_INT | COMMAND_LONG) {
        return None;
    }
    let mut payload = [0u8; 35];
    let raw = frame.raw.payload();
    let n = raw.len().min(payload.len());
    payload[..n].copy_from_slice(&raw[..n]);
    Some((u16::from_le_bytes([payload[28], payload[29]]), payload[30], payload[31]))
}
