//! The link layer at run time: one task per link and the hub task that
//! owns the registry and the router, on the runtime the caller gives (the
//! edge's), over sockets the caller bound ([`super::sockets`]).
//!
//! Inbound: link task → frames → hub (signature checked, see
//! [`super::sign_policy`]) → routed to other links as raw bytes and, when
//! addressed to us, decoded messages to the core's channel.
//! Outbound: core → hub, which encodes per link (its own sequence numbers,
//! signed where the link needs it) → each link's bounded queue (`try_send`:
//! a full queue drops and counts, it never waits) → the link's writer, which
//! writes what is queued in as few writes (datagrams) as it fits in.
//! Bulk replies (parameter lists, mission items, FTP and log data, see
//! [`super::pacing`]) are never dropped: they wait in the link's backlog
//! and enter its queue as fast as the link drains it.
//!
//! Mission download requests for us are answered here, from the plans the
//! core published ([`mission::Downloads`], docs/architecture.md §Mission
//! downloads at the link), as the core would answer them: an item-by-item
//! download then costs one round trip through the hub per item, not one
//! through the core's thread.
//!
//! Who a link answers is the hub's too ([`super::peers`]): a UDP link
//! sends to every address that sent it an admitted frame, never to one that
//! merely sent a datagram. Each new ground station (a TCP client, a new UDP
//! address, a serial port heard after a silence) is reported to the core,
//! which tells it the start-up notices.
//!
//! SETUP_SIGNING is the hub's own: taken only from a secure link and only
//! when addressed to us, never forwarded, never given to the core or the
//! tlog. The key is kept in the data directory
//! ([`crate::storage::signing_key`]).

use std::collections::{BTreeMap, VecDeque};
use std::io;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, AtomicU16, AtomicUsize, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use mavlink::dialects::ardupilotmega::{MavMessage, MavMissionResult, MavResult};
use mavlink::{MavHeader, Message};
use tokio::io::{AsyncWrite, AsyncWriteExt};
use tokio::net::{TcpListener, UdpSocket};
use tokio::runtime::Handle;
use tokio::sync::{mpsc, oneshot, watch};

use super::encode::{encode_raw_command_ack, encode_raw_mission_ack, encode_v2};
use super::frame::{FrameStats, ReceivedFrame};
use super::pacing::{BulkPacer, LinkPace, is_bulk};
use super::peers::Peers;
use super::router::Router;
use super::sign_policy::{Admission, DropReason, LinkSecurity, admit, makes_peer};
use super::signing::{KeyChange, SecretKey, SigningState, TimestampSaver, Verdict};
use super::sockets::{BoundAddresses, LinkSocket, LinkSockets};
use super::tlog::TlogRecord;
use crate::storage::signing_key::{self, KeyFileThread, KeyFileWriter, StoredSigning};
use crate::vehicle::{
    COMPONENT_ID, Destination, Inbound, LinkEvent, LinkId, Outbound, PeerId, UndecodableItem, addressed_to,
};

/// Messages queued per link before new ones are dropped.
pub(super) const LINK_QUEUE: usize = 512;
/// Bulk replies a link's backlog holds at most: far more than a parameter
/// table or a burst; only a client that floods requests reaches it, and
/// then the surplus is dropped and counted rather than memory growing.
const BACKLOG_LIMIT: usize = 2048;
/// How often the hub moves backlogged bulk replies into drained queues.
const PUMP_PERIOD: Duration = Duration::from_millis(1);
/// A byte-stream writer gathers queued frames into writes of this size.
const WRITE_CHUNK: usize = 16 * 1024;
const CORE_QUEUE: usize = 4096;
const SETUP_SIGNING_ID: u32 = 256;
/// How long dropping the runtime waits for the last timestamp save.
const STOP_WAIT: Duration = Duration::from_secs(3);

/// A finished frame for a link's writer, and (for a UDP link) the
/// addresses it goes to; a byte-stream link has one peer and ignores `to`.
#[derive(Clone, Debug)]
pub(super) struct LinkFrame {
    pub bytes: Vec<u8>,
    pub to: Arc<[SocketAddr]>,
}

/// How a link learns its ground stations (see [`super::peers`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum PeerPolicy {
    /// A TCP client: its own link, a peer from the moment it connects.
    Connection,
    /// A serial port: a peer once a frame is heard, again after a silence.
    FirstFrame,
    /// UDP: every address that sends an admitted frame, and `fixed` (the
    /// configured destination) always.
    Addresses { fixed: Option<SocketAddr> },
}

/// What a link is for: its stream slot (`SRn_*`, `SIGN_REQUIRE` bit) and
/// whether it is secure (SETUP_SIGNING and unsigned packets accepted).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct LinkRole {
    pub slot: u8,
    pub secure: bool,
}

/// What the hub sends on a link, before encoding.
enum OutItem {
    Message(Arc<MavMessage>),
    /// Forwarded from another link, unchanged.
    Frame(Arc<[u8]>),
    /// COMMAND_ACK(UNSUPPORTED) for a command id the dialect lacks.
    UnknownCommandAck {
        command: u16,
        target_system: u8,
        target_component: u8,
    },
    /// MISSION_ACK(UNSUPPORTED) for a mission type the dialect lacks.
    UnknownMissionTypeAck {
        mission_type: u8,
        target_system: u8,
        target_component: u8,
    },
}

/// Serialises a link's outgoing items with its own sequence counter.
struct LinkEncoder {
    sysid: u8,
    sequence: u8,
}

impl LinkEncoder {
    fn new(sysid: u8) -> Self {
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

    fn encode(&mut self, item: &OutItem) -> Vec<u8> {
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
            OutItem::UnknownMissionTypeAck {
                mission_type,
                target_system,
                target_component,
            } => {
                let header = self.header();
                encode_raw_mission_ack(
                    header,
                    MavMissionResult::MAV_MISSION_UNSUPPORTED as u8,
                    *mission_type,
                    *target_system,
                    *target_component,
                )
            }
        }
    }
}

/// Bytes queued for a link and not yet written: the hub adds, the link's
/// writer subtracts what it wrote (a serial link's pacing reads it).
#[derive(Clone, Debug, Default)]
pub(super) struct QueuedBytes(Arc<AtomicUsize>);

impl QueuedBytes {
    fn add(&self, bytes: usize) {
        self.0.fetch_add(bytes, Ordering::Relaxed);
    }

    pub(super) fn written(&self, bytes: usize) {
        self.0.fetch_sub(bytes, Ordering::Relaxed);
    }

    fn get(&self) -> usize {
        self.0.load(Ordering::Relaxed)
    }
}

/// Bulk replies waiting in the links' backlogs, for producers that stream
/// (the log download) to wait on rather than pile up.
#[derive(Clone, Debug, Default)]
pub struct BulkBacklog(Arc<AtomicUsize>);

impl BulkBacklog {
    pub fn waiting(&self) -> usize {
        self.0.load(Ordering::Relaxed)
    }
}

/// Gathers the frames already queued after `first` into `buf` (up to
/// [`WRITE_CHUNK`]): one write for a burst instead of one per frame.
pub(super) fn gather(first: LinkFrame, rx: &mut mpsc::Receiver<LinkFrame>, buf: &mut Vec<u8>) {
    buf.clear();
    buf.extend_from_slice(&first.bytes);
    while buf.len() < WRITE_CHUNK
        && let Ok(frame) = rx.try_recv()
    {
        buf.extend_from_slice(&frame.bytes);
    }
}

/// Writes a link's queue to its byte stream until the stream fails.
pub(super) async fn write_loop<W: AsyncWrite + Unpin>(
    mut write: W,
    mut rx: mpsc::Receiver<LinkFrame>,
    queued: QueuedBytes,
) {
    let mut buf = Vec::with_capacity(WRITE_CHUNK);
    while let Some(frame) = rx.recv().await {
        gather(frame, &mut rx, &mut buf);
        if write.write_all(&buf).await.is_err() {
            return;
        }
        queued.written(buf.len());
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

/// A link task's opening: the event announcing it to the hub, the link's
/// end of the queue the hub sends its frames on, and the byte count of what
/// is queued, which the hub reads to pace the link.
pub(super) fn open_link(
    link: LinkId,
    role: LinkRole,
    peers: PeerPolicy,
    name: String,
    pace: LinkPace,
) -> (HubEvent, mpsc::Receiver<LinkFrame>, QueuedBytes) {
    let (tx, rx) = mpsc::channel(LINK_QUEUE);
    let queued = QueuedBytes::default();
    let opened = HubEvent::Opened {
        link,
        role,
        peers,
        name,
        tx,
        pace,
        queued: queued.clone(),
    };
    (opened, rx, queued)
}

// Frames are the common case; boxing them would allocate per message.
#[allow(clippy::large_enum_variant)]
pub(super) enum HubEvent {
    Opened {
        link: LinkId,
        role: LinkRole,
        peers: PeerPolicy,
        name: String,
        tx: mpsc::Sender<LinkFrame>,
        pace: LinkPace,
        queued: QueuedBytes,
    },
    Closed {
        link: LinkId,
    },
    /// A valid frame, and the address it came from on a UDP link.
    Frame {
        link: LinkId,
        frame: ReceivedFrame,
        from: Option<SocketAddr>,
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

/// What the hub needs besides the sockets.
#[derive(Clone, Debug, Default)]
pub struct HubConfig {
    pub sysid: u8,
    /// Where the signing key is kept (the data directory). `None`: no key
    /// is loaded and a new one lasts until exit.
    pub signing_dir: Option<PathBuf>,
    /// The thread that writes the key file (a fleet's vehicles share one);
    /// `None`: a thread of its own.
    pub key_files: Option<KeyFileThread>,
    /// `SIGN_REQUIRE` at start; [`LinkRuntime::set_sign_require_mask`]
    /// follows changes.
    pub sign_require_mask: u8,
}

/// What mission downloads read, as the core last published it (`None`:
/// the core answers download requests itself).
pub type PublishedDownloads = Option<Arc<mission::Downloads>>;

/// The core thread's end of the link layer.
pub struct CoreChannels {
    pub inbound: mpsc::Receiver<ToCore>,
    pub outbound: mpsc::Sender<Outbound>,
    pub backlog: BulkBacklog,
    /// Publish here, before the messages sent after a change of plan or
    /// home, what download requests are answered from.
    pub downloads: watch::Sender<PublishedDownloads>,
}

/// The running link layer. Dropping it saves the signing timestamp and
/// stops the hub.
pub struct LinkRuntime {
    pub bound: BoundAddresses,
    sign_require: Arc<AtomicU8>,
    stop: Option<oneshot::Sender<()>>,
    stopped: std::sync::mpsc::Receiver<()>,
}

impl LinkRuntime {
    /// `SIGN_REQUIRE` as the core has it now (the runners pass it every tick).
    pub fn set_sign_require_mask(&self, mask: u8) {
        self.sign_require.store(mask, Ordering::Relaxed);
    }
}

impl Drop for LinkRuntime {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
            let _ = self.stopped.recv_timeout(STOP_WAIT);
        }
    }
}

/// The wall clock, read at the edge and handed to the signing state.
fn wall_clock() -> Duration {
    SystemTime::now().duration_since(UNIX_EPOCH).unwrap_or_default()
}

/// The signing state as stored in `dir`. A damaged or unreadable key file
/// is reported and left alone: signing stays off until a new key is set.
fn load_signing(dir: Option<&std::path::Path>, now: Duration) -> SigningState {
    let Some(dir) = dir else {
        return SigningState::start(None, 0, now);
    };
    match signing_key::load(dir) {
        Ok(Some(stored)) => {
            tracing::info!("MAVLink signing on (key from {})", signing_key::path(dir).display());
            SigningState::start(Some(stored.key), stored.timestamp, now)
        }
        Ok(None) => SigningState::start(None, 0, now),
        Err(e) => {
            tracing::error!("signing key not loaded: {e}; signing is off until SETUP_SIGNING sets a key");
            SigningState::start(None, 0, now)
        }
    }
}

/// Starts the hub and one task per link on `runtime` (the sockets were
/// bound by the caller). Dropping the returned [`LinkRuntime`] stops them.
pub fn spawn(runtime: &Handle, sockets: LinkSockets, config: HubConfig) -> io::Result<(LinkRuntime, CoreChannels)> {
    let (hub_tx, hub_rx) = mpsc::channel::<HubEvent>(1024);
    let (core_tx, core_rx) = mpsc::channel::<ToCore>(CORE_QUEUE);
    let (out_tx, out_rx) = mpsc::channel::<Outbound>(CORE_QUEUE);
    let (downloads_tx, downloads_rx) = watch::channel(None);
    let signing = load_signing(config.signing_dir.as_deref(), wall_clock());
    let key_writer = match (config.signing_dir.clone(), &config.key_files) {
        (Some(dir), Some(thread)) => Some(KeyFileWriter::on(thread, dir)),
        (Some(dir), None) => Some(KeyFileWriter::start(dir)?),
        (None, _) => None,
    };
    let sign_require = Arc::new(AtomicU8::new(config.sign_require_mask));
    let LinkSockets { links, tlog, bound } = sockets;
    let tlog = tlog.map(|(tx, task)| {
        runtime.spawn(task);
        tx
    });
    let ids = LinkIds::default();
    {
        // Sockets become tokio's inside the runtime's context.
        let _context = runtime.enter();
        for (socket, role) in links {
            spawn_link(socket, role, &ids, &hub_tx)?;
        }
    }
    drop(hub_tx);

    let (stop_tx, stop_rx) = oneshot::channel();
    let (stopped_tx, stopped_rx) = std::sync::mpsc::channel();
    let hub = Hub::new(
        config.sysid,
        core_tx,
        tlog,
        signing,
        key_writer,
        sign_require.clone(),
        downloads_rx,
    );
    let backlog = hub.backlog.clone();
    runtime.spawn(async move {
        hub.run(hub_rx, out_rx, stop_rx).await;
        let _ = stopped_tx.send(());
    });
    Ok((
        LinkRuntime {
            bound,
            sign_require,
            stop: Some(stop_tx),
            stopped: stopped_rx,
        },
        CoreChannels {
            inbound: core_rx,
            outbound: out_tx,
            backlog,
            downloads: downloads_tx,
        },
    ))
}

/// Starts one link's task (a serial port: its thread).
fn spawn_link(socket: LinkSocket, role: LinkRole, ids: &LinkIds, hub: &mpsc::Sender<HubEvent>) -> io::Result<()> {
    match socket {
        LinkSocket::TcpServer(listener) => {
            listener.set_nonblocking(true)?;
            let listener = TcpListener::from_std(listener)?;
            tokio::spawn(super::tcp::serve(listener, role, ids.clone(), hub.clone()));
        }
        LinkSocket::Udp { socket, fixed, name } => {
            socket.set_nonblocking(true)?;
            let socket = UdpSocket::from_std(socket)?;
            tokio::spawn(super::udp::run(socket, fixed, ids.next(), role, name, hub.clone()));
        }
        LinkSocket::TcpClient(address) => {
            tokio::spawn(super::tcp::connect_forever(address, role, ids.clone(), hub.clone()));
        }
        LinkSocket::Serial { device, baud } => {
            super::serial::spawn(device, baud, role, ids.clone(), hub.clone());
        }
    }
    Ok(())
}

/// Frames a link dropped for their signature, by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct SigningDrops {
    unsigned: u64,
    bad_signature: u64,
    replayed: u64,
    out_of_window: u64,
}

impl SigningDrops {
    fn count(&mut self, reason: DropReason) {
        let counter = match reason {
            DropReason::Unsigned => &mut self.unsigned,
            DropReason::BadSignature => &mut self.bad_signature,
            DropReason::Replayed => &mut self.replayed,
            DropReason::OutOfWindow => &mut self.out_of_window,
        };
        *counter += 1;
    }
}

struct LinkEntry {
    name: String,
    role: LinkRole,
    policy: PeerPolicy,
    peers: Peers,
    tx: mpsc::Sender<LinkFrame>,
    queued: QueuedBytes,
    pacer: BulkPacer,
    /// Bulk replies waiting for room, oldest first, and the next one
    /// already encoded (its sequence number taken) when it did not fit.
    backlog: VecDeque<(Option<PeerId>, Arc<MavMessage>)>,
    ready: Option<LinkFrame>,
    bulk_dropped: u64,
    encoder: LinkEncoder,
    /// A correctly signed packet came in here: what we send is signed too,
    /// even where signing is not required, as the peer checks signatures.
    peer_signs: bool,
    rx_stats: FrameStats,
    dropped_out: u64,
    signing_drops: SigningDrops,
    /// (unframed bytes, undecodable frames, tx dropped) at the last report.
    reported: (u64, u64, u64, u64),
    reported_signing_drops: SigningDrops,
}

impl LinkEntry {
    /// Records an admitted frame from `from`; returns the peer if new.
    fn hear(&mut self, from: Option<SocketAddr>, now: Duration, link: LinkId) -> Option<PeerId> {
        let key = match self.policy {
            PeerPolicy::Connection => return None,
            PeerPolicy::FirstFrame => None,
            PeerPolicy::Addresses { .. } => from,
        };
        let joined = self.peers.heard(key, now);
        if joined.is_some()
            && let Some(addr) = key
        {
            tracing::info!("link {} ({}): answering {addr}", link.0, self.name);
        }
        joined
    }

    fn security(&self, sign_require_mask: u8) -> LinkSecurity {
        LinkSecurity {
            secure: self.role.secure,
            require_signed: !self.role.secure && sign_require_mask & (1 << self.role.slot.min(7)) != 0,
        }
    }
}

/// The link id carried in our signatures: the low byte of the hub's id.
fn signature_link_id(link: LinkId) -> u8 {
    link.0.to_le_bytes()[0]
}

struct Hub {
    sysid: u8,
    links: BTreeMap<LinkId, LinkEntry>,
    router: Router,
    to_core: mpsc::Sender<ToCore>,
    tlog: Option<mpsc::Sender<TlogRecord>>,
    tlog_encoder: LinkEncoder,
    dropped_to_core: u64,
    reported_to_core: u64,
    signing: SigningState,
    key_writer: Option<KeyFileWriter>,
    timestamp_saver: TimestampSaver,
    sign_require: Arc<AtomicU8>,
    /// The peers' clock (monotonic).
    started: Instant,
    backlog: BulkBacklog,
    downloads: watch::Receiver<PublishedDownloads>,
}

impl Hub {
    fn new(
        sysid: u8,
        to_core: mpsc::Sender<ToCore>,
        tlog: Option<mpsc::Sender<TlogRecord>>,
        signing: SigningState,
        key_writer: Option<KeyFileWriter>,
        sign_require: Arc<AtomicU8>,
        downloads: watch::Receiver<PublishedDownloads>,
    ) -> Self {
        // The start timestamp (stored + margin) counts as saved only once
        // written: a crash right after start must not reuse it.
        let timestamp_saver = TimestampSaver::new(0, wall_clock());
        Hub {
            sysid,
            links: BTreeMap::new(),
            router: Router::new(sysid, COMPONENT_ID),
            to_core,
            tlog,
            tlog_encoder: LinkEncoder::new(sysid),
            dropped_to_core: 0,
            reported_to_core: 0,
            signing,
            key_writer,
            timestamp_saver,
            sign_require,
            started: Instant::now(),
            backlog: BulkBacklog::default(),
            downloads,
        }
    }

    fn since_start(&self) -> Duration {
        self.started.elapsed()
    }

    async fn run(
        mut self,
        mut events: mpsc::Receiver<HubEvent>,
        mut from_core: mpsc::Receiver<Outbound>,
        mut stop: oneshot::Receiver<()>,
    ) {
        let mut report = tokio::time::interval(Duration::from_secs(2));
        let mut pump = tokio::time::interval(PUMP_PERIOD);
        pump.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            let backlogged = self.backlog.waiting() > 0;
            tokio::select! {
                event = events.recv() => match event {
                    Some(event) => self.on_event(event).await,
                    None => break,
                },
                out = from_core.recv() => match out {
                    Some(out) => self.on_outbound(out),
                    None => break,
                },
                _ = pump.tick(), if backlogged => self.pump_all(),
                _ = report.tick() => {
                    self.report();
                    self.save_timestamp_when_due();
                    self.refresh_peers();
                }
                _ = &mut stop => break,
            }
        }
        self.save_timestamp();
        // Dropping the writer finishes the save before the process goes.
        self.key_writer.take();
    }

    async fn on_event(&mut self, event: HubEvent) {
        match event {
            HubEvent::Opened {
                link,
                role,
                peers: policy,
                name,
                tx,
                pace,
                queued,
            } => {
                let secure = if role.secure { ", secure" } else { "" };
                tracing::info!("link {}: {name} (stream slot SR{}{secure})", link.0, role.slot);
                let fixed = match policy {
                    PeerPolicy::Addresses { fixed } => fixed,
                    PeerPolicy::Connection | PeerPolicy::FirstFrame => None,
                };
                let mut peers = Peers::new(fixed);
                // A TCP client is there as it connects; a configured UDP
                // destination may be listening without ever speaking.
                let joined = match policy {
                    PeerPolicy::Connection => peers.heard(None, self.since_start()),
                    PeerPolicy::Addresses { .. } => peers.fixed(),
                    PeerPolicy::FirstFrame => None,
                };
                self.links.insert(
                    link,
                    LinkEntry {
                        name,
                        role,
                        policy,
                        peers,
                        tx,
                        queued,
                        pacer: BulkPacer::new(pace),
                        backlog: VecDeque::new(),
                        ready: None,
                        bulk_dropped: 0,
                        encoder: LinkEncoder::new(self.sysid),
                        peer_signs: false,
                        rx_stats: FrameStats::default(),
                        dropped_out: 0,
                        signing_drops: SigningDrops::default(),
                        reported: Default::default(),
                        reported_signing_drops: SigningDrops::default(),
                    },
                );
                // Link events must not be lost: wait for room.
                let _ = self
                    .to_core
                    .send(ToCore::Event(LinkEvent::Opened {
                        link,
                        stream_slot: role.slot,
                    }))
                    .await;
                if let Some(peer) = joined {
                    self.peer_joined(link, peer).await;
                }
            }
            HubEvent::Closed { link } => {
                self.links.remove(&link);
                self.publish_backlog();
                self.router.remove_link(link);
                let _ = self.to_core.send(ToCore::Event(LinkEvent::Closed { link })).await;
            }
            HubEvent::Stats { link, stats } => {
                if let Some(entry) = self.links.get_mut(&link) {
                    entry.rx_stats = stats;
                }
            }
            HubEvent::Frame { link, frame, from } => {
                if let Some(peer) = self.on_frame(link, frame, from) {
                    self.peer_joined(link, peer).await;
                }
            }
        }
    }

    /// Like link events, a new peer must not be lost: wait for room.
    async fn peer_joined(&self, link: LinkId, peer: PeerId) {
        let _ = self
            .to_core
            .send(ToCore::Event(LinkEvent::PeerJoined { link, peer }))
            .await;
    }

    /// Handles one frame; returns the peer that sent it when that peer is
    /// new on its link.
    fn on_frame(&mut self, link: LinkId, frame: ReceivedFrame, from: Option<SocketAddr>) -> Option<PeerId> {
        let now = wall_clock();
        if frame.message_id() == SETUP_SIGNING_ID {
            self.on_setup_signing(link, &frame, now);
            return None;
        }
        let since_start = self.since_start();
        let entry = self.links.get_mut(&link)?;
        let verdict = self.signing.verify(&frame.raw, now);
        let security = entry.security(self.sign_require.load(Ordering::Relaxed));
        let admission = admit(verdict, security, frame.message_id(), frame.header.component_id);
        if let Admission::Drop(reason) = admission {
            entry.signing_drops.count(reason);
            return None;
        }
        if verdict == Verdict::Signed {
            entry.peer_signs = true;
        }
        if let Ok(MavMessage::RADIO_STATUS(radio)) = &frame.message {
            entry.pacer.radio_status(radio.txbuf, since_start);
        }
        let joined = if makes_peer(verdict, security) {
            entry.hear(from, since_start, link)
        } else {
            None
        };
        if let Some(tlog) = &self.tlog {
            let _ = tlog.try_send(TlogRecord::now(frame.bytes().to_vec()));
        }
        if !self.route_frame(link, &frame) || admission == Admission::RouteOnly {
            return joined;
        }
        self.deliver_to_core(link, frame);
        joined
    }

    /// Forwards the frame to the links the router picks; true when it is
    /// also for this vehicle.
    fn route_frame(&mut self, link: LinkId, frame: &ReceivedFrame) -> bool {
        let (target_system, target_component) = match &frame.message {
            Ok(m) => (m.target_system_id(), m.target_component_id()),
            Err(_) => command_targets(frame).map_or((None, None), |(_, s, c)| (Some(s), Some(c))),
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
        decision.deliver_locally
    }

    /// Hands a frame for this vehicle to the core; one that does not decode
    /// goes to `answer_undecodable`.
    fn deliver_to_core(&mut self, link: LinkId, frame: ReceivedFrame) {
        match frame.message {
            Ok(message) => {
                if self.answer_download(link, &frame.header, &message) {
                    return;
                }
                if matches!(message, MavMessage::PARAM_REQUEST_LIST(_)) {
                    self.restart_param_list(link);
                }
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
            Err(_) => self.answer_undecodable(link, &frame),
        }
    }

    /// A mission download request for us, answered from the plans the core
    /// published, exactly as the core's protocol would: true when it was
    /// one and is answered.
    fn answer_download(&mut self, link: LinkId, header: &MavHeader, message: &MavMessage) -> bool {
        if !mission::Downloads::is_request(message) || !addressed_to(self.sysid, message) {
            return false;
        }
        let sender = mission::Sender {
            system_id: header.system_id as u8,
            component_id: header.component_id,
        };
        let reply = match self.downloads.borrow().as_deref() {
            Some(downloads) => downloads.answer(sender, message),
            None => None,
        };
        let Some(reply) = reply else {
            return false;
        };
        self.on_outbound(Outbound {
            dest: Destination::Link(link),
            message: reply,
        });
        true
    }

    /// A new PARAM_REQUEST_LIST restarts the list rather than queueing a
    /// second one behind the first: the PARAM_VALUEs still waiting in the
    /// link's backlog are dropped, as the core sends every value again, as
    /// it is now (so an echo of a set that was waiting is in the new list).
    /// Those already in the link's queue (or framed for it) still go out.
    fn restart_param_list(&mut self, link: LinkId) {
        if let Some(entry) = self.links.get_mut(&link) {
            entry
                .backlog
                .retain(|(_, message)| !matches!(**message, MavMessage::PARAM_VALUE(_)));
        }
        self.publish_backlog();
    }

    /// A frame whose payload does not decode: a mission item the core must
    /// reject by sequence, an unknown mission type or an unknown command,
    /// each answered with its NACK.
    fn answer_undecodable(&mut self, link: LinkId, frame: &ReceivedFrame) {
        if let Some(item) = mission::protocol::inspect_undecodable_item(frame.message_id(), frame.raw.payload()) {
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
        } else if let Some(unknown) =
            mission::protocol::inspect_unknown_mission_type(frame.message_id(), frame.raw.payload())
        {
            let ours = (unknown.target_system == 0 || unknown.target_system == self.sysid)
                && (unknown.target_component == 0 || unknown.target_component == COMPONENT_ID);
            if ours {
                let ack = OutItem::UnknownMissionTypeAck {
                    mission_type: unknown.mission_type,
                    target_system: frame.header.system_id as u8,
                    target_component: frame.header.component_id,
                };
                self.queue(link, ack);
            }
        } else if let Some((command, _, _)) = command_targets(frame) {
            let ack = OutItem::UnknownCommandAck {
                command,
                target_system: frame.header.system_id as u8,
                target_component: frame.header.component_id,
            };
            self.queue(link, ack);
        }
    }

    /// SETUP_SIGNING: acted on only from a secure link and only when
    /// addressed to us; never forwarded, never recorded (it holds the key).
    fn on_setup_signing(&mut self, link: LinkId, frame: &ReceivedFrame, now: Duration) {
        if !self.links.get(&link).is_some_and(|e| e.role.secure) {
            tracing::warn!("SETUP_SIGNING refused on insecure link {}", link.0);
            return;
        }
        let Ok(MavMessage::SETUP_SIGNING(setup)) = &frame.message else {
            tracing::warn!("link {}: undecodable SETUP_SIGNING ignored", link.0);
            return;
        };
        if setup.target_system != self.sysid || !matches!(setup.target_component, 0 | COMPONENT_ID) {
            tracing::warn!(
                "link {}: SETUP_SIGNING for {}/{} ignored: not for us, and never forwarded",
                link.0,
                setup.target_system,
                setup.target_component
            );
            return;
        }
        let change = self
            .signing
            .set_key(SecretKey::new(setup.secret_key), setup.initial_timestamp, now);
        // Peers that signed with the old key cannot check the new one.
        for entry in self.links.values_mut() {
            entry.peer_signs = false;
        }
        match change {
            KeyChange::Set => {
                tracing::info!("signing key set (SETUP_SIGNING on link {})", link.0);
                if self.key_writer.is_none() {
                    tracing::warn!("no data directory: the signing key lasts until exit");
                }
                self.save_timestamp();
            }
            KeyChange::Disabled => {
                tracing::info!("signing disabled (SETUP_SIGNING on link {})", link.0);
                if let Some(writer) = &self.key_writer {
                    writer.remove();
                }
            }
        }
    }

    /// Writes the key and our timestamp (nothing when signing is off).
    fn save_timestamp(&mut self) {
        let (Some(writer), Some(key)) = (&self.key_writer, self.signing.key()) else {
            return;
        };
        writer.save(StoredSigning {
            key: key.clone(),
            timestamp: self.signing.timestamp(),
        });
        self.timestamp_saver = TimestampSaver::new(self.signing.timestamp(), wall_clock());
    }

    fn save_timestamp_when_due(&mut self) {
        if self.signing.is_enabled() && self.timestamp_saver.due(self.signing.timestamp(), wall_clock()) {
            self.save_timestamp();
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
            Destination::Link(link) => self.queue_message(link, None, message),
            Destination::Peer { link, peer } => self.queue_message(link, Some(peer), message),
            Destination::AllLinks => {
                let links: Vec<LinkId> = self.links.keys().copied().collect();
                for link in links {
                    self.queue_message(link, None, message.clone());
                }
            }
        }
        self.publish_backlog();
    }

    /// A message of ours for a link: bulk replies through its backlog,
    /// everything else straight to its queue.
    fn queue_message(&mut self, link: LinkId, peer: Option<PeerId>, message: Arc<MavMessage>) {
        if !is_bulk(&message) {
            self.queue_for(link, peer, OutItem::Message(message));
            return;
        }
        let Some(entry) = self.links.get_mut(&link) else {
            return;
        };
        if entry.backlog.len() >= BACKLOG_LIMIT {
            if entry.bulk_dropped == 0 {
                tracing::warn!("link {} ({}): bulk backlog full, dropping replies", link.0, entry.name);
            }
            entry.bulk_dropped += 1;
            return;
        }
        entry.backlog.push_back((peer, message));
        self.pump(link);
    }

    /// Moves a link's backlog into its queue while its pacing admits.
    fn pump(&mut self, link: LinkId) {
        let now = self.since_start();
        loop {
            let Some(entry) = self.links.get_mut(&link) else {
                return;
            };
            let frame = match entry.ready.take() {
                Some(frame) => frame,
                None => {
                    let Some((peer, message)) = entry.backlog.pop_front() else {
                        return;
                    };
                    match self.frame_for(link, peer, &OutItem::Message(message)) {
                        Some(frame) => frame,
                        None => continue,
                    }
                }
            };
            let Some(entry) = self.links.get_mut(&link) else {
                return;
            };
            let len = frame.bytes.len();
            if !entry.pacer.admits(now, entry.tx.capacity(), entry.queued.get(), len) {
                entry.ready = Some(frame);
                return;
            }
            entry.queued.add(len);
            match entry.tx.try_send(frame) {
                Ok(()) => {}
                Err(mpsc::error::TrySendError::Full(frame)) => {
                    entry.queued.written(len);
                    entry.ready = Some(frame);
                    return;
                }
                // The writer is gone; the link's Closed event follows.
                Err(mpsc::error::TrySendError::Closed(_)) => return,
            }
        }
    }

    fn pump_all(&mut self) {
        let waiting: Vec<LinkId> = self
            .links
            .iter()
            .filter(|(_, e)| e.ready.is_some() || !e.backlog.is_empty())
            .map(|(id, _)| *id)
            .collect();
        for link in waiting {
            self.pump(link);
        }
        self.publish_backlog();
    }

    fn publish_backlog(&self) {
        let waiting = self
            .links
            .values()
            .map(|e| e.backlog.len() + usize::from(e.ready.is_some()))
            .sum();
        self.backlog.0.store(waiting, Ordering::Relaxed);
    }

    /// Encodes for one link (its sequence, its signature) and queues.
    fn queue(&mut self, link: LinkId, item: OutItem) {
        self.queue_for(link, None, item);
    }

    /// Queues for one peer of a link (`None`: all its peers); a full queue
    /// drops and counts.
    fn queue_for(&mut self, link: LinkId, peer: Option<PeerId>, item: OutItem) {
        let Some(frame) = self.frame_for(link, peer, &item) else {
            return;
        };
        let Some(entry) = self.links.get_mut(&link) else {
            return;
        };
        let len = frame.bytes.len();
        entry.queued.add(len);
        if entry.tx.try_send(frame).is_err() {
            entry.queued.written(len);
            if entry.dropped_out == 0 {
                tracing::warn!("link {} ({}): not keeping up, dropping messages", link.0, entry.name);
            }
            entry.dropped_out += 1;
        }
    }

    /// Encodes for one peer of a link (`None`: all its peers). A peer that
    /// is gone gets nothing, and nothing goes elsewhere in its place.
    fn frame_for(&mut self, link: LinkId, peer: Option<PeerId>, item: &OutItem) -> Option<LinkFrame> {
        let entry = self.links.get_mut(&link)?;
        let to = match peer.map(|id| entry.peers.address(id)) {
            None | Some(Some(None)) => entry.peers.targets().clone(),
            Some(Some(Some(addr))) => Arc::from([addr]),
            Some(None) => return None,
        };
        let mut bytes = entry.encoder.encode(item);
        let ours = !matches!(item, OutItem::Frame(_));
        if ours
            && self.signing.is_enabled()
            && (entry.peer_signs || entry.security(self.sign_require.load(Ordering::Relaxed)).require_signed)
            && let Some(signed) = self.signing.sign(&bytes, signature_link_id(link), wall_clock())
        {
            bytes = signed;
        }
        Some(LinkFrame { bytes, to })
    }

    /// Lets peers that went quiet age out of the links' destinations.
    fn refresh_peers(&mut self) {
        let now = self.since_start();
        for entry in self.links.values_mut() {
            entry.peers.refresh(now);
        }
    }

    /// Logs links whose error counters changed since the last report: quiet
    /// while all is well, prompt when a link delivers garbage, cannot keep
    /// up or sends what signing rejects (no key material is ever logged).
    fn report(&mut self) {
        for (id, entry) in &mut self.links {
            let s = entry.rx_stats;
            let errors = (s.bytes_unframed, s.decode_errors, entry.dropped_out, entry.bulk_dropped);
            if errors != entry.reported {
                tracing::warn!(
                    "link {} ({}): rx {} frames ({} MAVLink 1), {} bytes unframed, {} undecodable; {} tx dropped, {} bulk replies dropped (backlog full)",
                    id.0,
                    entry.name,
                    s.frames,
                    s.frames_v1,
                    s.bytes_unframed,
                    s.decode_errors,
                    entry.dropped_out,
                    entry.bulk_dropped
                );
                entry.reported = errors;
            }
            let d = entry.signing_drops;
            if d != entry.reported_signing_drops {
                tracing::warn!(
                    "link {} ({}): signing dropped {} unsigned, {} badly signed, {} replayed, {} out-of-window packets so far",
                    id.0,
                    entry.name,
                    d.unsigned,
                    d.bad_signature,
                    d.replayed,
                    d.out_of_window
                );
                entry.reported_signing_drops = d;
            }
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

#[cfg(test)]
mod tests {
    //! The runtime in-process, on loopback sockets bound to port 0: no core
    //! runs, so only what a test sends as the core goes out.

    use std::net::UdpSocket as StdUdpSocket;

    use mavlink::dialects::ardupilotmega::{
        COMMAND_LONG_DATA, HEARTBEAT_DATA, MavCmd, MavSeverity, MavType, RADIO_STATUS_DATA, STATUSTEXT_DATA,
    };

    use super::super::frame::frame_datagram;
    use super::*;

    const WAIT: Duration = Duration::from_secs(3);
    /// How long a socket that must receive nothing is watched.
    const QUIET: Duration = Duration::from_millis(500);

    fn gcs_socket() -> StdUdpSocket {
        let socket = StdUdpSocket::bind("127.0.0.1:0").expect("bind");
        socket
            .set_read_timeout(Some(Duration::from_millis(50)))
            .expect("timeout");
        socket
    }

    /// The hub on a runtime of its own; dropping it stops both.
    struct Running {
        links: LinkRuntime,
        _runtime: tokio::runtime::Runtime,
    }

    fn start_hub(fixed: &StdUdpSocket, sign_require_mask: u8, signing_dir: Option<PathBuf>) -> (Running, CoreChannels) {
        let runtime = crate::edge::runtime().expect("runtime");
        let mut sockets = LinkSockets::default();
        let udp = StdUdpSocket::bind("127.0.0.1:0").expect("bind");
        sockets
            .udp(udp, Some(fixed.local_addr().expect("addr")))
            .expect("udp link");
        let config = HubConfig {
            sysid: 1,
            sign_require_mask,
            signing_dir,
            key_files: None,
        };
        let (links, channels) = spawn(runtime.handle(), sockets, config).expect("links start");
        (
            Running {
                links,
                _runtime: runtime,
            },
            channels,
        )
    }

    fn frame_of(message: &MavMessage, sequence: u8) -> Vec<u8> {
        let header = MavHeader {
            system_id: 255,
            component_id: 190,
            sequence,
        };
        encode_v2(header, message)
    }

    fn gcs_heartbeat() -> Vec<u8> {
        frame_of(
            &MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                mavtype: MavType::MAV_TYPE_GCS,
                ..HEARTBEAT_DATA::DEFAULT
            }),
            0,
        )
    }

    fn text(words: &str) -> MavMessage {
        let mut data = STATUSTEXT_DATA {
            severity: MavSeverity::MAV_SEVERITY_WARNING,
            ..STATUSTEXT_DATA::DEFAULT
        };
        data.text[..words.len()].copy_from_slice(words.as_bytes());
        MavMessage::STATUSTEXT(data)
    }

    /// The next link event the core would get, skipping messages.
    fn next_event(channels: &mut CoreChannels, wait: Duration) -> Option<LinkEvent> {
        let deadline = Instant::now() + wait;
        while Instant::now() < deadline {
            match channels.inbound.try_recv() {
                Ok(ToCore::Event(event)) => return Some(event),
                Ok(_) => {}
                Err(_) => std::thread::sleep(Duration::from_millis(5)),
            }
        }
        None
    }

    fn joined(channels: &mut CoreChannels) -> (LinkId, PeerId) {
        loop {
            match next_event(channels, WAIT) {
                Some(LinkEvent::PeerJoined { link, peer }) => return (link, peer),
                Some(_) => {}
                None => panic!("no peer joined"),
            }
        }
    }

    fn from_core(channels: &CoreChannels, dest: Destination, message: MavMessage) {
        channels
            .outbound
            .blocking_send(Outbound { dest, message })
            .expect("hub running");
    }

    /// Whether `socket` receives a STATUSTEXT saying `words` within `wait`.
    fn hears(socket: &StdUdpSocket, words: &str, wait: Duration) -> bool {
        hears_all(socket, &[words], wait)
    }

    /// Whether a STATUSTEXT starting with each of `words` arrives (frames
    /// queued together share a datagram).
    fn hears_all(socket: &StdUdpSocket, words: &[&str], wait: Duration) -> bool {
        let deadline = Instant::now() + wait;
        let mut buf = [0u8; 2048];
        let mut heard = vec![false; words.len()];
        while Instant::now() < deadline {
            let Ok(n) = socket.recv(&mut buf) else { continue };
            frame_datagram(&buf[..n], &mut FrameStats::default(), |f| {
                if let Ok(MavMessage::STATUSTEXT(t)) = &f.message {
                    for (w, h) in words.iter().zip(heard.iter_mut()) {
                        *h |= t.text.starts_with(w.as_bytes());
                    }
                }
            });
            if heard.iter().all(|h| *h) {
                return true;
            }
        }
        false
    }

    #[test]
    fn every_udp_peer_gets_what_the_core_sends_to_all() {
        let fixed = gcs_socket();
        let (hub, mut channels) = start_hub(&fixed, 0, None);
        let udp = hub.links.bound.udp_local.expect("udp bound");
        let (link, _) = joined(&mut channels);
        let (a, b) = (gcs_socket(), gcs_socket());
        a.send_to(&gcs_heartbeat(), udp).expect("send");
        joined(&mut channels);
        b.send_to(&gcs_heartbeat(), udp).expect("send");
        joined(&mut channels);
        from_core(&channels, Destination::AllLinks, text("to all"));
        from_core(&channels, Destination::Link(link), text("to the link"));
        for socket in [&fixed, &a, &b] {
            assert!(hears_all(socket, &["to all", "to the link"], WAIT));
        }
    }

    #[test]
    fn a_strangers_datagrams_never_divert_the_telemetry() {
        let fixed = gcs_socket();
        let (hub, mut channels) = start_hub(&fixed, 0, None);
        let udp = hub.links.bound.udp_local.expect("udp bound");
        joined(&mut channels);
        let gcs = gcs_socket();
        gcs.send_to(&gcs_heartbeat(), udp).expect("send");
        joined(&mut channels);
        let stranger = gcs_socket();
        let mut bad_crc = gcs_heartbeat();
        let last = bad_crc.len() - 1;
        bad_crc[last] ^= 0x55;
        let truncated = gcs_heartbeat()[..8].to_vec();
        let garbage: Vec<u8> = (0..200u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        for datagram in [
            vec![],
            vec![0x00],
            vec![0xFD],
            vec![0xFE, 0x09],
            truncated,
            bad_crc,
            garbage,
        ] {
            stranger.send_to(&datagram, udp).expect("send");
        }
        from_core(&channels, Destination::AllLinks, text("telemetry"));
        assert!(
            hears(&fixed, "telemetry", WAIT),
            "the configured GCS lost its telemetry"
        );
        assert!(hears(&gcs, "telemetry", WAIT), "the GCS that spoke lost its telemetry");
        assert!(!hears(&stranger, "telemetry", QUIET), "a stranger drew the telemetry");
        assert_eq!(next_event(&mut channels, QUIET), None, "a stranger became a peer");
    }

    #[test]
    fn a_new_peer_is_reported_once_and_a_message_for_it_goes_to_it_alone() {
        let fixed = gcs_socket();
        let (hub, mut channels) = start_hub(&fixed, 0, None);
        let udp = hub.links.bound.udp_local.expect("udp bound");
        let (link, fixed_peer) = joined(&mut channels);
        let (a, b) = (gcs_socket(), gcs_socket());
        a.send_to(&gcs_heartbeat(), udp).expect("send");
        let (_, peer_a) = joined(&mut channels);
        b.send_to(&gcs_heartbeat(), udp).expect("send");
        let (_, peer_b) = joined(&mut channels);
        a.send_to(&gcs_heartbeat(), udp).expect("send");
        assert_eq!(next_event(&mut channels, QUIET), None, "a peer heard again is not new");
        assert!(fixed_peer != peer_a && peer_a != peer_b);

        from_core(
            &channels,
            Destination::Peer { link, peer: peer_a },
            text("notice for a"),
        );
        assert!(hears(&a, "notice for a", WAIT));
        assert!(!hears(&b, "notice for a", QUIET));
        assert!(!hears(&fixed, "notice for a", QUIET));
        from_core(
            &channels,
            Destination::Peer { link, peer: fixed_peer },
            text("notice at boot"),
        );
        assert!(hears(&fixed, "notice at boot", WAIT));
        assert!(!hears(&a, "notice at boot", QUIET));
    }

    /// A signing key in a fresh directory, as SETUP_SIGNING would leave it.
    fn key_dir(key: [u8; 32]) -> tempfile::TempDir {
        let dir = tempfile::Builder::new()
            .prefix("furrow-hub-test-")
            .tempdir()
            .expect("temp dir");
        let stored = StoredSigning {
            key: SecretKey::new(key),
            timestamp: 0,
        };
        signing_key::save(dir.path(), &stored).expect("key saved");
        dir
    }

    #[test]
    fn where_signing_is_required_only_a_signed_frame_makes_a_peer() {
        const KEY: [u8; 32] = [7; 32];
        let dir = key_dir(KEY);
        let fixed = gcs_socket();
        // SIGN_REQUIRE bit 1: the UDP link's stream slot.
        let (hub, mut channels) = start_hub(&fixed, 0b10, Some(dir.path().to_path_buf()));
        let udp = hub.links.bound.udp_local.expect("udp bound");
        joined(&mut channels);
        let stranger = gcs_socket();
        let radio_status = frame_of(&MavMessage::RADIO_STATUS(RADIO_STATUS_DATA::DEFAULT), 1);
        stranger.send_to(&gcs_heartbeat(), udp).expect("send");
        stranger.send_to(&radio_status, udp).expect("send");
        assert_eq!(next_event(&mut channels, QUIET), None, "unsigned frames made a peer");
        from_core(&channels, Destination::AllLinks, text("signed telemetry"));
        assert!(!hears(&stranger, "signed telemetry", QUIET));

        let mut signer = SigningState::start(Some(SecretKey::new(KEY)), 0, wall_clock());
        let signed = signer.sign(&gcs_heartbeat(), 0, wall_clock()).expect("signed");
        let gcs = gcs_socket();
        gcs.send_to(&signed, udp).expect("send");
        joined(&mut channels);
        from_core(&channels, Destination::AllLinks, text("for the signer"));
        assert!(hears(&gcs, "for the signer", WAIT));
        assert!(!hears(&stranger, "for the signer", QUIET));
    }

    fn command_long_to(target_system: u8, target_component: u8) -> MavMessage {
        MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            target_system,
            target_component,
            command: MavCmd::MAV_CMD_REQUEST_MESSAGE,
            ..COMMAND_LONG_DATA::DEFAULT
        })
    }

    fn heartbeat_from(system_id: u8, component_id: u8) -> Vec<u8> {
        let header = MavHeader {
            system_id: u32::from(system_id),
            component_id,
            sequence: 0,
        };
        encode_v2(
            header,
            &MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
                ..HEARTBEAT_DATA::DEFAULT
            }),
        )
    }

    /// The message ids `stream` receives within `wait`.
    fn ids_heard(stream: &mut std::net::TcpStream, wait: Duration) -> Vec<u32> {
        use std::io::Read;
        stream
            .set_read_timeout(Some(Duration::from_millis(50)))
            .expect("timeout");
        let deadline = Instant::now() + wait;
        let mut framer = super::super::frame::StreamFramer::new();
        let mut ids = Vec::new();
        let mut buf = [0u8; 4096];
        while Instant::now() < deadline {
            if let Ok(n) = stream.read(&mut buf) {
                framer.push(&buf[..n], |f| ids.push(f.message_id()));
            }
        }
        ids
    }

    /// The core's messages of one id within `wait`.
    fn core_gets(channels: &mut CoreChannels, message_id: u32, wait: Duration) -> usize {
        let deadline = Instant::now() + wait;
        let mut count = 0;
        while Instant::now() < deadline {
            match channels.inbound.try_recv() {
                Ok(ToCore::Message(m)) if m.message.message_id() == message_id => count += 1,
                Ok(_) => {}
                Err(_) => std::thread::sleep(Duration::from_millis(5)),
            }
        }
        count
    }

    /// A UDP link to `fixed` and a TCP server on port 0, with one client.
    fn two_links(fixed: &StdUdpSocket) -> (Running, CoreChannels, std::net::TcpStream) {
        let runtime = crate::edge::runtime().expect("runtime");
        let mut sockets = LinkSockets::default();
        let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
        let tcp = listener.local_addr().expect("addr");
        sockets.tcp_server(listener).expect("tcp link");
        let udp = StdUdpSocket::bind("127.0.0.1:0").expect("bind");
        sockets
            .udp(udp, Some(fixed.local_addr().expect("addr")))
            .expect("udp link");
        let config = HubConfig {
            sysid: 1,
            ..HubConfig::default()
        };
        let (links, mut channels) = spawn(runtime.handle(), sockets, config).expect("links start");
        joined(&mut channels);
        let client = std::net::TcpStream::connect(tcp).expect("connect");
        joined(&mut channels);
        let running = Running {
            links,
            _runtime: runtime,
        };
        (running, channels, client)
    }

    #[test]
    fn a_command_for_another_system_goes_only_to_the_link_that_heard_it() {
        use std::io::Write;
        const COMMAND_LONG: u32 = 76;
        let gcs = gcs_socket();
        let (hub, mut channels, mut companion) = two_links(&gcs);
        let udp = hub.links.bound.udp_local.expect("udp bound");
        // System 42 speaks on the TCP link; the router learns where it is.
        companion.write_all(&heartbeat_from(42, 1)).expect("send");
        std::thread::sleep(Duration::from_millis(100));

        gcs.send_to(&frame_of(&command_long_to(42, 1), 1), udp).expect("send");
        let heard = ids_heard(&mut companion, Duration::from_millis(500));
        assert_eq!(
            heard.iter().filter(|&&id| id == COMMAND_LONG).count(),
            1,
            "heard {heard:?}"
        );
        assert_eq!(
            core_gets(&mut channels, COMMAND_LONG, QUIET),
            0,
            "not ours, not the core's"
        );

        gcs.send_to(&frame_of(&command_long_to(1, 1), 2), udp).expect("send");
        assert_eq!(core_gets(&mut channels, COMMAND_LONG, WAIT), 1, "ours goes to the core");
        let heard = ids_heard(&mut companion, QUIET);
        assert!(!heard.contains(&COMMAND_LONG), "ours is not forwarded: {heard:?}");
    }

    #[test]
    fn a_client_that_stops_reading_holds_up_neither_the_others_nor_the_core() {
        let gcs = gcs_socket();
        let (hub, mut channels, stalled) = two_links(&gcs);
        let udp = hub.links.bound.udp_local.expect("udp bound");
        socket2::SockRef::from(&stalled)
            .set_recv_buffer_size(4096)
            .expect("SO_RCVBUF");
        // Far more than the kernel buffers and the link's queue hold.
        for k in 0..3 * LINK_QUEUE {
            from_core(&channels, Destination::AllLinks, text(&format!("flood {k}")));
        }
        // What the kernel kept of the flood for the UDP GCS is read first.
        hears(&gcs, "nothing", QUIET);
        from_core(&channels, Destination::AllLinks, text("after the flood"));
        assert!(hears(&gcs, "after the flood", WAIT), "the UDP GCS lost its telemetry");
        gcs.send_to(&gcs_heartbeat(), udp).expect("send");
        assert_eq!(
            core_gets(&mut channels, 0, WAIT),
            1,
            "the core lost the GCS's heartbeat"
        );
        drop(stalled);
    }

    /// A hub with no sockets: link events and frames are handed to it as
    /// its link tasks would.
    struct BareHub {
        hub: Hub,
        core: mpsc::Receiver<ToCore>,
        link_queue: mpsc::Receiver<LinkFrame>,
        /// What the link's writer would report written.
        queued: QueuedBytes,
        /// The core's end of the published downloads.
        downloads: watch::Sender<PublishedDownloads>,
    }

    const LINK: LinkId = LinkId(0);

    impl BareHub {
        async fn open(core_queue: usize, signing: SigningState, sign_require_mask: u8) -> BareHub {
            Self::open_paced(core_queue, signing, sign_require_mask, LinkPace::Network).await
        }

        async fn open_paced(
            core_queue: usize,
            signing: SigningState,
            sign_require_mask: u8,
            pace: LinkPace,
        ) -> BareHub {
            let (core_tx, core) = mpsc::channel(core_queue);
            let sign_require = Arc::new(AtomicU8::new(sign_require_mask));
            let (downloads, downloads_rx) = watch::channel(None);
            let mut hub = Hub::new(1, core_tx, None, signing, None, sign_require, downloads_rx);
            let role = LinkRole { slot: 1, secure: false };
            let (opened, link_queue, queued) = open_link(LINK, role, PeerPolicy::FirstFrame, "test".to_string(), pace);
            hub.on_event(opened).await;
            let mut bare = BareHub {
                hub,
                core,
                link_queue,
                queued,
                downloads,
            };
            bare.core_items();
            bare
        }

        fn frame(&mut self, bytes: &[u8]) {
            let mut frames = Vec::new();
            frame_datagram(bytes, &mut FrameStats::default(), |f| frames.push(f));
            assert_eq!(frames.len(), 1, "one valid frame");
            for frame in frames {
                self.hub.on_frame(LINK, frame, None);
            }
        }

        /// Messages (not events) the core got.
        fn core_items(&mut self) -> usize {
            let mut n = 0;
            while let Ok(item) = self.core.try_recv() {
                n += usize::from(matches!(item, ToCore::Message(_)));
            }
            n
        }

        fn entry(&self) -> &LinkEntry {
            self.hub.links.get(&LINK).expect("link open")
        }
    }

    #[tokio::test]
    async fn a_full_link_queue_drops_and_counts_and_a_full_core_queue_too() {
        let mut bare = BareHub::open(8, SigningState::start(None, 0, wall_clock()), 0).await;
        for k in 0..LINK_QUEUE + 100 {
            bare.hub.on_outbound(Outbound {
                dest: Destination::AllLinks,
                message: text(&format!("m{k}")),
            });
        }
        assert_eq!(bare.link_queue.len(), LINK_QUEUE);
        assert_eq!(bare.entry().dropped_out, 100);

        for _ in 0..20 {
            bare.frame(&gcs_heartbeat());
        }
        assert_eq!(bare.core_items(), 8, "the core queue holds 8");
        assert_eq!(bare.hub.dropped_to_core, 12);
    }

    fn param_value(index: u16) -> MavMessage {
        MavMessage::PARAM_VALUE(mavlink::dialects::ardupilotmega::PARAM_VALUE_DATA {
            param_index: index,
            param_count: u16::MAX,
            ..Default::default()
        })
    }

    fn decoded(frame: &LinkFrame) -> MavMessage {
        let mut frames = Vec::new();
        frame_datagram(&frame.bytes, &mut FrameStats::default(), |f| frames.push(f));
        frames.remove(0).message.expect("decodes")
    }

    #[tokio::test]
    async fn bulk_replies_wait_for_room_and_arrive_all_in_order_with_room_kept_for_telemetry() {
        let mut bare = BareHub::open(8, SigningState::start(None, 0, wall_clock()), 0).await;
        let n = 3 * LINK_QUEUE;
        for k in 0..n {
            bare.hub.on_outbound(Outbound {
                dest: Destination::Link(LINK),
                message: param_value(k as u16),
            });
        }
        let admitted = LINK_QUEUE - super::super::pacing::RESERVED_SLOTS;
        assert_eq!(bare.link_queue.len(), admitted, "bulk stops short of the reserve");
        assert_eq!(bare.hub.backlog.waiting(), n - admitted);
        // Telemetry still finds room while the backlog waits.
        bare.hub.on_outbound(Outbound {
            dest: Destination::AllLinks,
            message: text("telemetry"),
        });
        assert_eq!(bare.link_queue.len(), admitted + 1);
        let mut indices = Vec::new();
        while indices.len() < n {
            while let Ok(frame) = bare.link_queue.try_recv() {
                match decoded(&frame) {
                    MavMessage::PARAM_VALUE(p) => indices.push(p.param_index),
                    MavMessage::STATUSTEXT(_) => {}
                    other => panic!("unexpected {other:?}"),
                }
            }
            bare.hub.pump_all();
            assert!(
                !bare.link_queue.is_empty() || indices.len() == n,
                "the pump refills the drained queue"
            );
        }
        assert_eq!(
            indices,
            (0..n as u16).collect::<Vec<_>>(),
            "every reply, once, in order"
        );
        assert_eq!(bare.hub.backlog.waiting(), 0);
        assert_eq!((bare.entry().dropped_out, bare.entry().bulk_dropped), (0, 0));
    }

    #[tokio::test]
    async fn a_new_parameter_list_request_restarts_the_list_instead_of_queueing_a_second() {
        let mut bare = BareHub::open(8, SigningState::start(None, 0, wall_clock()), 0).await;
        let n = 3 * LINK_QUEUE;
        for k in 0..n {
            bare.hub.on_outbound(Outbound {
                dest: Destination::Link(LINK),
                message: param_value(k as u16),
            });
        }
        // Something else bulk waits behind the list: it is kept.
        bare.hub.on_outbound(Outbound {
            dest: Destination::Link(LINK),
            message: MavMessage::MISSION_ACK(Default::default()),
        });
        // Admitted to the queue, or framed and waiting for room: these go out.
        let admitted = bare.link_queue.len() + usize::from(bare.entry().ready.is_some());
        assert_eq!(bare.hub.backlog.waiting(), n + 1 - bare.link_queue.len());
        let request = MavMessage::PARAM_REQUEST_LIST(mavlink::dialects::ardupilotmega::PARAM_REQUEST_LIST_DATA {
            target_system: 1,
            target_component: 1,
        });
        bare.frame(&frame_of(&request, 0));
        assert_eq!(bare.core_items(), 1, "the request reaches the core");
        assert_eq!(
            bare.hub.backlog.waiting(),
            1 + admitted - bare.link_queue.len(),
            "only the mission ACK (and the framed reply) still wait"
        );
        // The core's new list then queues once.
        for k in 0..n {
            bare.hub.on_outbound(Outbound {
                dest: Destination::Link(LINK),
                message: param_value(k as u16),
            });
        }
        let mut indices = Vec::new();
        for _ in 0..100 {
            while let Ok(frame) = bare.link_queue.try_recv() {
                if let MavMessage::PARAM_VALUE(p) = decoded(&frame) {
                    indices.push(p.param_index);
                }
            }
            bare.hub.pump_all();
        }
        assert_eq!(
            indices.len(),
            admitted + n,
            "the first list's queued part, then one whole list"
        );
        assert_eq!(indices[admitted..], (0..n as u16).collect::<Vec<_>>()[..]);
    }

    /// Drains the link queue as a writer would; returns the frames' bytes.
    fn write_out(bare: &mut BareHub) -> Vec<LinkFrame> {
        let mut frames = Vec::new();
        while let Ok(frame) = bare.link_queue.try_recv() {
            bare.queued.written(frame.bytes.len());
            frames.push(frame);
        }
        frames
    }

    #[tokio::test]
    async fn a_serial_link_queues_a_tenth_of_a_second_of_bulk_and_less_as_the_radio_fills() {
        let signing = SigningState::start(None, 0, wall_clock());
        let mut bare = BareHub::open_paced(8, signing, 0, LinkPace::Serial { baud: 57_600 }).await;
        for k in 0..300 {
            bare.hub.on_outbound(Outbound {
                dest: Destination::Link(LINK),
                message: param_value(k),
            });
        }
        // 57600 baud: 576 bytes in 100 ms.
        let first = write_out(&mut bare);
        let bytes: usize = first.iter().map(|f| f.bytes.len()).sum();
        assert!(
            !first.is_empty() && bytes <= 576,
            "{} frames, {bytes} bytes",
            first.len()
        );
        assert!(bytes + first[0].bytes.len() > 576, "as much as fits: {bytes} bytes");
        // Written: the next tenth of a second goes in.
        bare.hub.pump_all();
        assert_eq!(write_out(&mut bare).len(), first.len());
        // The radio's buffer at 60 % free: half the allowance.
        let radio = MavMessage::RADIO_STATUS(RADIO_STATUS_DATA {
            txbuf: 60,
            ..Default::default()
        });
        let mut raw = Vec::new();
        let header = MavHeader {
            system_id: 51,
            component_id: 68,
            sequence: 0,
        };
        mavlink::write_v2_msg(&mut raw, header, &radio).expect("encode");
        bare.frame(&raw);
        bare.hub.pump_all();
        let half = write_out(&mut bare);
        assert_eq!(half.len(), first.len() / 2, "half the allowance");
        let mut sent = first.len() * 2 + half.len();
        while sent < 300 {
            bare.hub.pump_all();
            let more = write_out(&mut bare).len();
            assert!(more > 0, "bulk keeps moving at {sent}");
            sent += more;
        }
        assert_eq!(sent, 300, "every parameter, none dropped");
        assert_eq!(bare.hub.backlog.waiting(), 0);
    }

    #[tokio::test]
    async fn frames_signing_rejects_are_counted_by_reason_and_never_reach_the_core() {
        const KEY: [u8; 32] = [7; 32];
        let signing = SigningState::start(Some(SecretKey::new(KEY)), 0, wall_clock());
        // SIGN_REQUIRE bit 1: the link's stream slot.
        let mut bare = BareHub::open(64, signing, 0b10).await;
        let mut ours = SigningState::start(Some(SecretKey::new(KEY)), 0, wall_clock());
        let mut strangers = SigningState::start(Some(SecretKey::new([9; 32])), 0, wall_clock());

        bare.frame(&gcs_heartbeat());
        let forged = strangers.sign(&gcs_heartbeat(), 0, wall_clock()).expect("signed");
        bare.frame(&forged);
        let signed = ours.sign(&gcs_heartbeat(), 0, wall_clock()).expect("signed");
        bare.frame(&signed);
        assert_eq!(bare.core_items(), 1, "only the signed frame");
        bare.frame(&signed);
        assert_eq!(bare.core_items(), 0, "a replay is dropped");
        let drops = bare.entry().signing_drops;
        assert_eq!(
            (drops.unsigned, drops.bad_signature, drops.replayed, drops.out_of_window),
            (1, 1, 1, 0)
        );
    }

    fn mission_request(seq: u16, target_system: u8) -> MavMessage {
        MavMessage::MISSION_REQUEST_INT(mavlink::dialects::ardupilotmega::MISSION_REQUEST_INT_DATA {
            seq,
            target_system,
            target_component: 1,
            mission_type: mavlink::dialects::ardupilotmega::MavMissionType::MAV_MISSION_TYPE_MISSION,
        })
    }

    /// A three-waypoint mission, published as the core would.
    fn publish_mission(bare: &BareHub) -> mission::Plan {
        let items = (0..3)
            .map(|seq| mission::MissionItem {
                seq,
                frame: mission::command::frame::GLOBAL_RELATIVE_ALT_INT,
                command: mission::command::cmd::NAV_WAYPOINT,
                current: false,
                autocontinue: true,
                params: [0.0; 4],
                x: 291_330_000 + i32::from(seq),
                y: 1_196_400_000,
                z: 0.0,
            })
            .collect();
        let plan = mission::validate_plan(mission::MissionType::Mission, items).expect("valid plan");
        let plans = mission::Plans {
            mission: plan.clone(),
            ..mission::Plans::default()
        };
        bare.downloads
            .send_replace(Some(Arc::new(mission::Downloads::new(plans, None))));
        plan
    }

    /// The replies the link got, decoded.
    fn replies(bare: &mut BareHub) -> Vec<MavMessage> {
        write_out(bare).iter().map(decoded).collect()
    }

    #[tokio::test]
    async fn download_requests_are_answered_from_the_published_plans_and_the_rest_goes_to_the_core() {
        let mut bare = BareHub::open(64, SigningState::start(None, 0, wall_clock()), 0).await;
        // Nothing published yet: the core answers.
        bare.frame(&frame_of(&mission_request(0, 1), 0));
        assert_eq!(bare.core_items(), 1);
        assert!(replies(&mut bare).is_empty());

        let plan = publish_mission(&bare);
        let list = MavMessage::MISSION_REQUEST_LIST(mavlink::dialects::ardupilotmega::MISSION_REQUEST_LIST_DATA {
            target_system: 1,
            target_component: 1,
            ..Default::default()
        });
        bare.frame(&frame_of(&list, 1));
        for seq in 0..4 {
            bare.frame(&frame_of(&mission_request(seq, 1), 2));
        }
        assert_eq!(bare.core_items(), 0, "the hub answered them all");
        let got = replies(&mut bare);
        assert_eq!(got.len(), 5);
        let MavMessage::MISSION_COUNT(count) = &got[0] else {
            panic!("not a count: {:?}", got[0]);
        };
        assert_eq!((count.count, count.opaque_id), (3, plan.opaque_id()));
        assert_eq!((count.target_system, count.target_component), (255, 190));
        for (seq, reply) in got[1..4].iter().enumerate() {
            let MavMessage::MISSION_ITEM_INT(item) = reply else {
                panic!("not an item: {reply:?}");
            };
            assert_eq!(mission::MissionItem::from_mavlink(item), plan.items()[seq]);
            assert_eq!((item.target_system, item.target_component), (255, 190));
        }
        assert!(matches!(
            &got[4],
            MavMessage::MISSION_ACK(a) if a.mavtype == MavMissionResult::MAV_MISSION_INVALID_SEQUENCE
        ));

        // Another vehicle's request, an upload and a withdrawn plan: not the hub's.
        bare.frame(&frame_of(&mission_request(0, 7), 3));
        let upload = MavMessage::MISSION_COUNT(mavlink::dialects::ardupilotmega::MISSION_COUNT_DATA {
            count: 1,
            target_system: 1,
            target_component: 1,
            ..Default::default()
        });
        bare.frame(&frame_of(&upload, 4));
        bare.downloads.send_replace(None);
        bare.frame(&frame_of(&mission_request(0, 1), 5));
        assert!(replies(&mut bare).is_empty());
        assert_eq!(bare.core_items(), 2, "the upload and the request after the withdrawal");
    }

    #[tokio::test]
    async fn a_download_request_the_signing_policy_drops_is_not_answered() {
        const KEY: [u8; 32] = [7; 32];
        let signing = SigningState::start(Some(SecretKey::new(KEY)), 0, wall_clock());
        let mut bare = BareHub::open(64, signing, 0b10).await;
        publish_mission(&bare);
        bare.frame(&frame_of(&mission_request(1, 1), 0));
        assert!(
            replies(&mut bare).is_empty(),
            "unsigned on a link that requires signing"
        );
        let mut ours = SigningState::start(Some(SecretKey::new(KEY)), 0, wall_clock());
        let signed = ours
            .sign(&frame_of(&mission_request(1, 1), 1), 0, wall_clock())
            .expect("signed");
        bare.frame(&signed);
        let got = replies(&mut bare);
        assert!(
            matches!(&got[..], [MavMessage::MISSION_ITEM_INT(i)] if i.seq == 1),
            "{got:?}"
        );
        assert_eq!(bare.core_items(), 0);
    }
}
