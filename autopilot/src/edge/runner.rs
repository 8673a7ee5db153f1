//! The loop every running furrow shares (after mini-redis's
//! `server::run(listener, shutdown)`): given its sockets already bound, the
//! data directory and a shutdown future, it steps the core at the
//! platform's clock and, until the next tick is due, hands link traffic and
//! finished saves to the core as they come.

use std::future::Future;
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::MavMessage;
use tokio::runtime::{Handle, Runtime};
use tokio::sync::oneshot;

use super::clock::InstantTimer;
use super::mqtt::{MqttConfig, MqttLink};
use super::persistence::Persistence;
use crate::ftp::service::FtpService;
use crate::link::hub::{self, CoreChannels, HubConfig, LinkRuntime, ToCore};
use crate::link::sockets::LinkSockets;
use crate::logging::edge::Logger;
use crate::vehicle::{Core, Inbound, Inputs, Outbound, Outputs, SaveRequest};

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

/// The one tokio runtime of a running furrow and the wall clock's origin.
pub struct EdgeRunner {
    runtime: Runtime,
    origin: Instant,
    mqtt: Option<MqttConfig>,
}

impl EdgeRunner {
    pub fn new() -> Result<EdgeRunner, String> {
        let runtime = super::runtime().map_err(|e| format!("tokio runtime: {e}"))?;
        Ok(EdgeRunner {
            runtime,
            origin: Instant::now(),
            mqtt: None,
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
        let core = platform.core();
        let config = HubConfig {
            sysid: core.sysid(),
            signing_dir: Some(persistence.dir().to_path_buf()),
            sign_require_mask: core.sign_require_mask(),
        };
        let (links, channels) =
            hub::spawn(self.runtime.handle(), sockets, config).map_err(|e| format!("MAVLink links: {e}"))?;
        let (stop_tx, stop) = oneshot::channel();
        self.runtime.spawn(async move {
            shutdown.await;
            let _ = stop_tx.send(());
        });
        let ftp = FtpService::start(persistence.dir(), channels.outbound.clone());
        let logger = Logger::start(persistence.dir(), channels.outbound.clone(), channels.backlog.clone());
        let mqtt = self.mqtt.map(|config| MqttLink::spawn(self.runtime.handle(), config));
        let mut edge = Edge {
            mqtt,
            origin: self.origin,
            logger,
            ftp,
            links,
            channels,
            persistence,
            links_open: true,
            replies: Vec::new(),
            dropped_to_links: 0,
        };
        self.runtime.block_on(edge.drive(platform, stop));
        platform.stop(edge.wall(), edge.dropped_to_links);
        if let Some(mqtt) = edge.mqtt.take() {
            if mqtt.dropped() > 0 {
                tracing::warn!("VDA 5050: {} messages dropped (client queue full)", mqtt.dropped());
            }
            self.runtime.block_on(mqtt.stop());
        }
        edge.persistence.finish();
        let Edge { links, logger, .. } = edge;
        crate::logging::edge::report(logger);
        // The hub saves the signing timestamp as it stops.
        drop(links);
        Ok(())
    }
}

/// The loop's side of the links and the data directory.
struct Edge {
    origin: Instant,
    /// The VDA 5050 client, when configured.
    mqtt: Option<MqttLink>,
    /// Answers FILE_TRANSFER_PROTOCOL on a thread of its own.
    ftp: FtpService,
    /// Writes the core's onboard log records off the core's thread.
    logger: Logger,
    links: LinkRuntime,
    channels: CoreChannels,
    persistence: Persistence,
    /// False once the hub has gone (its channel closed).
    links_open: bool,
    replies: Vec<Outbound>,
    dropped_to_links: u64,
}

impl Edge {
    fn wall(&self) -> Duration {
        self.origin.elapsed()
    }

    async fn drive<P: Platform>(&mut self, platform: &mut P, mut stop: oneshot::Receiver<()>) {
        let mut timer = InstantTimer::default();
        loop {
            if !matches!(stop.try_recv(), Err(oneshot::error::TryRecvError::Empty)) {
                return;
            }
            self.take_link_traffic(platform, None);
            if let Some(mqtt) = &mut self.mqtt {
                mqtt.drain_into(platform.inputs_mut());
            }
            self.persistence.collect(platform.inputs_mut());
            let saves = self.send(platform.tick(self.wall(), &mut timer));
            self.store(platform.core(), saves);
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
                        platform.inputs_mut().saved.push(done);
                        None
                    }
                    () = tokio::time::sleep_until(deadline) => break,
                };
                self.take_link_traffic(platform, first);
                self.persistence.collect(platform.inputs_mut());
                let saves = self.send(platform.service_links(self.wall()));
                self.store(platform.core(), saves);
            }
        }
    }

    /// Moves what the links delivered into the inputs, except what the
    /// platform answers itself.
    fn take_link_traffic<P: Platform>(&mut self, platform: &mut P, first: Option<ToCore>) {
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
    fn send(&mut self, outputs: &mut Outputs) -> Vec<SaveRequest> {
        for out in outputs.mavlink.drain(..) {
            if let MavMessage::STATUSTEXT(t) = &out.message {
                tracing::info!("STATUSTEXT: {}", t.text.to_str().unwrap_or("?"));
            }
            self.send_to_links(out);
        }
        self.logger.send(&mut outputs.log);
        match &mut self.mqtt {
            Some(mqtt) => mqtt.publish(&mut outputs.vda5050),
            None => outputs.vda5050.clear(),
        }
        std::mem::take(&mut outputs.saves)
    }

    /// Never waits: a full queue drops and counts.
    fn send_to_links(&mut self, out: Outbound) {
        if self.channels.outbound.try_send(out).is_err() {
            self.dropped_to_links += 1;
        }
    }

    fn store(&mut self, core: &Core, saves: Vec<SaveRequest>) {
        self.persistence.save(saves, core);
        self.links.set_sign_require_mask(core.sign_require_mask());
    }
}
