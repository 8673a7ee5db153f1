//! The loop every running furrow shares (after mini-redis's
//! `server::run(listener, shutdown)`): given its sockets already bound, the
//! data directory and a shutdown future, it steps the core at the
//! platform's clock and, until the next tick is due, hands link traffic and
//! finished saves to the core as they come.

use std::future::Future;
use std::sync::Arc;
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::MavMessage;
use tokio::runtime::{Handle, Runtime};
use tokio::sync::{mpsc, oneshot};

use super::clock::InstantTimer;
use super::mqtt::{MqttConfig, MqttLink};
use super::persistence::Persistence;
use crate::ftp::service::{self as ftp_service, FtpService, FtpThread};
use crate::link::hub::{self, CoreChannels, HubConfig, LinkRuntime, PublishedDownloads, ToCore};
use crate::link::sockets::LinkSockets;
use crate::logging::edge::{self as log_edge, LogThread, Logger};
use crate::storage::signing_key::{self, KeyFileThread};
use crate::vehicle::{Core, FleetMessage, Inbound, Inputs, Outbound, Outputs, SaveRequest};

/// The core with the devices around it: a simulated world, or a real
/// vehicle's drivers and outputs. Times are wall time since the runner's
/// origin.
pub trait Platform {
    fn core(&self) -> &Core;

    /// The inputs of the next tick or link service.
    fn inputs_mut(&mut self) -> &mut Inputs;

    /// A message the edge answers itself rather than the core (replies go
    /// into `replies`): true when it was one.
    fn answer_at_edge(&mut self, _message: &Inbound, _wall: Duration, _replies: &mut Vec<Outbound>) -> bool {
        false
    }

    /// One tick: read the devices, step the core, drive the outputs.
    fn tick(&mut self, wall: Duration, timer: &mut InstantTimer) -> &mut Outputs;

    /// Between ticks: the core answers the link traffic in the inputs.
    fn service_links(&mut self, wall: Duration) -> &mut Outputs;

    /// After a tick: how long until the next one is due (`None`: now).
    fn until_next_tick(&mut self, wall: Duration) -> Option<Duration>;

    /// The shutdown future completed: outputs to rest, the summary logged.
    fn stop(&mut self, wall: Duration, dropped_to_links: u64);
}

/// The one tokio runtime of a running furrow, the wall clock's origin, and
/// the threads that do every vehicle's file work (FTP, onboard log, signing
/// key): one of each, however many vehicles.
pub struct EdgeRunner {
    pub(super) runtime: Runtime,
    origin: Instant,
    mqtt: Option<MqttConfig>,
    ftp: FtpThread,
    log: LogThread,
    key_files: KeyFileThread,
}

impl EdgeRunner {
    pub fn new() -> Result<EdgeRunner, String> {
        let runtime = super::runtime().map_err(|e| format!("tokio runtime: {e}"))?;
        Ok(EdgeRunner {
            runtime,
            origin: Instant::now(),
            mqtt: None,
            ftp: ftp_service::start_thread().map_err(|e| format!("FTP thread: {e}"))?,
            log: log_edge::start_thread().map_err(|e| format!("onboard log thread: {e}"))?,
            key_files: signing_key::start_thread().map_err(|e| format!("signing key thread: {e}"))?,
        })
    }

    /// Connects the core's VDA 5050 agent to a broker.
    pub fn with_vda5050(mut self, config: MqttConfig) -> Self {
        self.mqtt = Some(config);
        self
    }

    /// For devices whose drivers are tasks.
    pub fn handle(&self) -> &Handle {
        self.runtime.handle()
    }

    /// Wall time zero: what device samples and the core's `wall` count from.
    pub fn origin(&self) -> Instant {
        self.origin
    }

    /// Runs `platform` with the links on `sockets` until `shutdown`
    /// completes.
    pub fn run<P: Platform>(
        self,
        platform: &mut P,
        sockets: LinkSockets,
        persistence: Persistence,
        shutdown: impl Future<Output = ()> + Send + 'static,
    ) -> Result<(), String> {
        let mut edge = Edge::start(&self, Platform::core(platform), sockets, persistence, self.mqtt.clone())?;
        let stop = self.stop_on(shutdown);
        self.runtime.block_on(edge.drive(platform, stop));
        platform.stop(edge.wall(), edge.dropped_to_links);
        edge.finish(&self.runtime);
        Ok(())
    }

    /// A receiver that completes when `shutdown` does.
    pub(super) fn stop_on(&self, shutdown: impl Future<Output = ()> + Send + 'static) -> oneshot::Receiver<()> {
        let (stop_tx, stop) = oneshot::channel();
        self.runtime.spawn(async move {
            shutdown.await;
            let _ = stop_tx.send(());
        });
        stop
    }
}

/// One vehicle's core as its links see it: what the runner hands link
/// traffic to between ticks. Every [`Platform`] is one; so is each vehicle
/// of a fleet.
pub trait LinkServed {
    fn core(&self) -> &Core;
    fn inputs_mut(&mut self) -> &mut Inputs;
    fn answer_at_edge(&mut self, message: &Inbound, wall: Duration, replies: &mut Vec<Outbound>) -> bool;
    fn service_links(&mut self, wall: Duration) -> &mut Outputs;
}

impl<P: Platform> LinkServed for P {
    fn core(&self) -> &Core {
        Platform::core(self)
    }

    fn inputs_mut(&mut self) -> &mut Inputs {
        Platform::inputs_mut(self)
    }

    fn answer_at_edge(&mut self, message: &Inbound, wall: Duration, replies: &mut Vec<Outbound>) -> bool {
        Platform::answer_at_edge(self, message, wall, replies)
    }

    fn service_links(&mut self, wall: Duration) -> &mut Outputs {
        Platform::service_links(self, wall)
    }
}

/// One vehicle's side of its links, data directory, onboard log and VDA
/// 5050 client.
pub(super) struct Edge {
    origin: Instant,
    /// The VDA 5050 client, when configured.
    mqtt: Option<MqttLink>,
    /// Answers FILE_TRANSFER_PROTOCOL off the core's thread.
    ftp: FtpService,
    /// Writes the core's onboard log records off the core's thread.
    logger: Logger,
    links: LinkRuntime,
    channels: CoreChannels,
    persistence: Persistence,
    /// False once the hub has gone (its channel closed).
    links_open: bool,
    replies: Vec<Outbound>,
    /// A tick's messages for the links and the broker, held until
    /// [`Edge::release`].
    held_mavlink: Vec<Outbound>,
    held_vda5050: Vec<FleetMessage>,
    pub(super) dropped_to_links: u64,
}

impl Edge {
    /// Starts the links on `sockets`, FTP, the onboard log and the MQTT
    /// client (when configured) for `core`.
    pub(super) fn start(
        runner: &EdgeRunner,
        core: &Core,
        sockets: LinkSockets,
        persistence: Persistence,
        mqtt: Option<MqttConfig>,
    ) -> Result<Edge, String> {
        let config = HubConfig {
            sysid: core.sysid(),
            signing_dir: Some(persistence.dir().to_path_buf()),
            key_files: Some(runner.key_files.clone()),
            sign_require_mask: core.sign_require_mask(),
        };
        let handle = runner.runtime.handle();
        let (links, channels) = hub::spawn(handle, sockets, config).map_err(|e| format!("MAVLink links: {e}"))?;
        let ftp = FtpService::start(&runner.ftp, persistence.dir(), channels.outbound.clone());
        let logger = Logger::on(
            &runner.log,
            persistence.dir(),
            channels.outbound.clone(),
            channels.backlog.clone(),
        );
        Ok(Edge {
            mqtt: mqtt.map(|config| MqttLink::spawn(handle, config)),
            origin: runner.origin,
            logger,
            ftp,
            links,
            channels,
            persistence,
            links_open: true,
            replies: Vec::new(),
            held_mavlink: Vec::new(),
            held_vda5050: Vec::new(),
            dropped_to_links: 0,
        })
    }

    /// The clean stop: OFFLINE to the broker, pending saves written, the
    /// log's summary, the links closed.
    pub(super) fn finish(mut self, runtime: &Runtime) {
        if let Some(mqtt) = self.take_mqtt() {
            runtime.block_on(mqtt.stop());
        }
        self.persistence.finish();
        let Edge { links, logger, .. } = self;
        crate::logging::edge::report(logger);
        // The hub saves the signing timestamp as it stops.
        drop(links);
    }

    /// The MQTT client, to stop it (a fleet stops all of theirs at once).
    pub(super) fn take_mqtt(&mut self) -> Option<MqttLink> {
        let mqtt = self.mqtt.take()?;
        if mqtt.dropped() > 0 {
            tracing::warn!("VDA 5050: {} messages dropped (client queue full)", mqtt.dropped());
        }
        Some(mqtt)
    }

    pub(super) fn wall(&self) -> Duration {
        self.origin.elapsed()
    }

    /// Before a tick: link traffic, broker messages and finished saves into
    /// the inputs.
    pub(super) fn gather<P: LinkServed>(&mut self, platform: &mut P) {
        self.take_link_traffic(platform, None);
        if let Some(mqtt) = &mut self.mqtt {
            mqtt.drain_into(platform.inputs_mut());
        }
        self.persistence.collect(platform.inputs_mut());
    }

    /// Between ticks: `first` (and whatever else the links delivered)
    /// answered at once.
    pub(super) fn serve<P: LinkServed>(&mut self, platform: &mut P, first: Option<ToCore>) {
        self.take_link_traffic(platform, first);
        self.persistence.collect(platform.inputs_mut());
        let saves = self.send(platform.service_links(self.wall()));
        self.store(platform.core(), saves);
    }

    /// Hands the links' inbound queue over (the fleet's loop merges every
    /// vehicle's into one); this edge then reads an empty, closed queue.
    pub(super) fn take_inbound(&mut self) -> mpsc::Receiver<ToCore> {
        let (_, closed) = mpsc::channel(1);
        self.links_open = false;
        std::mem::replace(&mut self.channels.inbound, closed)
    }

    async fn drive<P: Platform>(&mut self, platform: &mut P, mut stop: oneshot::Receiver<()>) {
        let mut timer = InstantTimer::default();
        loop {
            if !matches!(stop.try_recv(), Err(oneshot::error::TryRecvError::Empty)) {
                return;
            }
            self.gather(platform);
            let saves = self.send(platform.tick(self.wall(), &mut timer));
            self.store(Platform::core(platform), saves);
            let Some(delay) = platform.until_next_tick(self.wall()) else {
                continue;
            };
            // Until the next tick: answer link traffic as it comes.
            let deadline = tokio::time::Instant::now() + delay;
            loop {
                let first = tokio::select! {
                    _ = &mut stop => return,
                    item = self.channels.inbound.recv(), if self.links_open => {
                        self.links_open = item.is_some();
                        item
                    }
                    done = self.persistence.next_done() => {
                        Platform::inputs_mut(platform).saved.push(done);
                        None
                    }
                    () = tokio::time::sleep_until(deadline) => break,
                };
                self.serve(platform, first);
            }
        }
    }

    /// Moves what the links delivered into the inputs, except what the
    /// platform answers itself.
    pub(super) fn take_link_traffic<P: LinkServed>(&mut self, platform: &mut P, first: Option<ToCore>) {
        let wall = self.wall();
        let inbound = &mut self.channels.inbound;
        for item in first.into_iter().chain(std::iter::from_fn(|| inbound.try_recv().ok())) {
            match item {
                ToCore::Event(e) => platform.inputs_mut().link_events.push(e),
                ToCore::Message(m) => {
                    self.ftp.offer(std::slice::from_ref(&m), platform.core());
                    if !platform.answer_at_edge(&m, wall, &mut self.replies) {
                        platform.inputs_mut().messages.push(m);
                    }
                }
                ToCore::UndecodableItem(i) => platform.inputs_mut().undecodable_items.push(i),
            }
        }
        for reply in std::mem::take(&mut self.replies) {
            self.send_to_links(reply);
        }
    }

    /// Hands the core's messages to the links; returns the saves it asked
    /// for.
    pub(super) fn send(&mut self, outputs: &mut Outputs) -> Vec<SaveRequest> {
        let saves = self.hold(outputs);
        self.release();
        saves
    }

    /// Takes the core's messages for the links and the broker, to hand
    /// over at [`Edge::release`]; returns the saves it asked for.
    pub(super) fn hold(&mut self, outputs: &mut Outputs) -> Vec<SaveRequest> {
        // Before the messages: once a ground station hears of a new plan
        // (its MISSION_ACK), its download reads that plan.
        self.publish_downloads(&outputs.mission_downloads);
        for out in &outputs.mavlink {
            if let MavMessage::STATUSTEXT(t) = &out.message {
                tracing::info!("STATUSTEXT: {}", t.text.to_str().unwrap_or("?"));
            }
        }
        self.held_mavlink.append(&mut outputs.mavlink);
        self.logger.send(&mut outputs.log);
        if self.mqtt.is_some() {
            self.held_vda5050.append(&mut outputs.vda5050);
        } else {
            outputs.vda5050.clear();
        }
        std::mem::take(&mut outputs.saves)
    }

    /// What [`Edge::hold`] took, to the links and the broker (never waits).
    pub(super) fn release(&mut self) {
        let mut held = std::mem::take(&mut self.held_mavlink);
        for out in held.drain(..) {
            self.send_to_links(out);
        }
        self.held_mavlink = held;
        if let Some(mqtt) = &mut self.mqtt {
            mqtt.publish(&mut self.held_vda5050);
        }
    }

    /// What the links answer mission downloads from, when it changed.
    fn publish_downloads(&self, downloads: &PublishedDownloads) {
        self.channels.downloads.send_if_modified(|published| {
            let same = match (published.as_ref(), downloads) {
                (Some(old), Some(new)) => Arc::ptr_eq(old, new),
                (old, new) => old.is_none() && new.is_none(),
            };
            if !same {
                published.clone_from(downloads);
            }
            !same
        });
    }

    /// Never waits: a full queue drops and counts.
    fn send_to_links(&mut self, out: Outbound) {
        if self.channels.outbound.try_send(out).is_err() {
            self.dropped_to_links += 1;
        }
    }

    pub(super) fn store(&mut self, core: &Core, saves: Vec<SaveRequest>) {
        self.persistence.save(saves, core);
        self.links.set_sign_require_mask(core.sign_require_mask());
    }
}
