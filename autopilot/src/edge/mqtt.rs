//! The VDA 5050 edge: one MQTT client (rumqttc on the edge's tokio runtime)
//! that carries `order` and `instantActions` from the broker to the core and
//! the core's `state`, `visualization` and `factsheet` to the broker, with
//! `connection` ONLINE on every connect, OFFLINE on a clean stop, and
//! CONNECTIONBROKEN as the last will (§6.14). It reconnects with
//! [`Backoff`] and subscribes again; the core's order carries on through an
//! outage and a fresh state and factsheet go out on reconnect.

use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use drivers::backoff::Backoff;
use rumqttc::{AsyncClient, Event, EventLoop, LastWill, MqttOptions, Packet, QoS, TlsConfiguration, Transport};
use tokio::runtime::Handle;
use tokio::sync::{mpsc, oneshot};
use vda5050::{ConnectionState, Qos, Topic, TopicPrefix};

use super::mqtt_tls::{TlsError, TlsFiles, client_config};
use crate::fleet::publish::{Publication, Publisher};
use crate::vehicle::{FleetMessage, Inputs};

/// Where the broker is and who this vehicle is on it.
#[derive(Clone, Debug)]
pub struct MqttConfig {
    pub host: String,
    pub port: u16,
    /// TLS for `mqtts://` (see [`super::mqtt_tls`]).
    pub tls: Option<Arc<rustls::ClientConfig>>,
    pub prefix: TopicPrefix,
    pub client_id: String,
    pub credentials: Option<(String, String)>,
}

/// A broker URL: `mqtt://HOST[:PORT]` or `mqtts://HOST[:PORT]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BrokerUrl {
    pub host: String,
    pub port: u16,
    pub tls: bool,
}

impl std::fmt::Display for BrokerUrl {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let scheme = if self.tls { "mqtts" } else { "mqtt" };
        write!(f, "{scheme}://{}:{}", self.host, self.port)
    }
}

/// `mqtt://HOST:PORT` (port 1883 when absent) or `mqtts://HOST:PORT` (8883).
pub fn parse_broker_url(url: &str) -> Result<BrokerUrl, String> {
    let (rest, tls) = if let Some(rest) = url.strip_prefix("mqtts://") {
        (rest, true)
    } else if let Some(rest) = url.strip_prefix("mqtt://") {
        (rest, false)
    } else {
        return Err(format!("{url}: expected mqtt://HOST:PORT or mqtts://HOST:PORT"));
    };
    let (host, port) = match rest.rsplit_once(':') {
        Some((host, port)) => {
            let port = port
                .parse::<u16>()
                .ok()
                .filter(|p| *p != 0)
                .ok_or_else(|| format!("{url}: bad port {port:?}"))?;
            (host, port)
        }
        None if tls => (rest, 8883),
        None => (rest, 1883),
    };
    if host.is_empty() || host.contains(['/', '@', '?', '#']) || host.contains(char::is_whitespace) {
        return Err(format!("{url}: expected mqtt://HOST:PORT or mqtts://HOST:PORT"));
    }
    Ok(BrokerUrl {
        host: host.to_owned(),
        port,
        tls,
    })
}

impl MqttConfig {
    /// The client's configuration; for `mqtts://` the TLS files are read
    /// and checked now, so a bad one fails at start-up.
    pub fn new(
        broker: &BrokerUrl,
        tls_files: &TlsFiles,
        prefix: TopicPrefix,
        client_id: String,
        credentials: Option<(String, String)>,
    ) -> Result<MqttConfig, TlsError> {
        let tls = broker.tls.then(|| client_config(tls_files)).transpose()?;
        Ok(MqttConfig {
            host: broker.host.clone(),
            port: broker.port,
            tls,
            prefix,
            client_id,
            credentials,
        })
    }
}

/// A broker still sending while the core is slow drops here, counted.
const QUEUE: usize = 256;
/// How long a clean stop waits for OFFLINE to reach the broker.
const STOP_WAIT: Duration = Duration::from_secs(2);

enum Outgoing {
    Message(FleetMessage),
    Stop(oneshot::Sender<()>),
}

/// The core's side of the MQTT client.
pub struct MqttLink {
    inbound: mpsc::Receiver<(Topic, Vec<u8>)>,
    outbound: mpsc::Sender<Outgoing>,
    dropped: u64,
}

fn unix_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

fn qos(q: Qos) -> QoS {
    match q {
        Qos::AtMostOnce => QoS::AtMostOnce,
        Qos::AtLeastOnce => QoS::AtLeastOnce,
    }
}

impl MqttLink {
    /// Starts the client on `handle`; it connects in the background.
    pub fn spawn(handle: &Handle, config: MqttConfig) -> MqttLink {
        let mut publisher = Publisher::new(config.prefix.clone());
        let will = publisher.connection(ConnectionState::ConnectionBroken, unix_ms());
        let mut options = MqttOptions::new(config.client_id.clone(), config.host.clone(), config.port);
        options
            .set_keep_alive(Duration::from_secs(5))
            .set_clean_session(true)
            .set_max_packet_size(1 << 20, 1 << 20)
            .set_last_will(LastWill::new(will.topic, will.payload, qos(will.qos), will.retain));
        if let Some((user, password)) = &config.credentials {
            options.set_credentials(user.clone(), password.clone());
        }
        if let Some(tls) = &config.tls {
            options.set_transport(Transport::tls_with_config(TlsConfiguration::Rustls(tls.clone())));
        }
        let (client, eventloop) = AsyncClient::new(options, QUEUE);
        let (to_core, inbound) = mpsc::channel(QUEUE);
        let (outbound, from_core) = mpsc::channel(QUEUE);
        let task = Session {
            config,
            client,
            publisher,
            to_core,
            connected: false,
            held: Vec::new(),
        };
        handle.spawn(task.run(eventloop, from_core));
        MqttLink {
            inbound,
            outbound,
            dropped: 0,
        }
    }

    /// What arrived from the broker, for the next tick.
    pub fn drain_into(&mut self, inputs: &mut Inputs) {
        while let Ok(item) = self.inbound.try_recv() {
            inputs.vda5050.push(item);
        }
    }

    /// The core's messages, to the broker (never waits: a full queue drops).
    pub fn publish(&mut self, messages: &mut Vec<FleetMessage>) {
        for message in messages.drain(..) {
            if self.outbound.try_send(Outgoing::Message(message)).is_err() {
                self.dropped += 1;
            }
        }
    }

    /// Messages dropped because the client's queue was full.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// A clean stop: OFFLINE, then disconnect (waits at most a few seconds).
    pub async fn stop(self) {
        let (done, wait) = oneshot::channel();
        if self.outbound.send(Outgoing::Stop(done)).await.is_ok() {
            let _ = tokio::time::timeout(STOP_WAIT + Duration::from_millis(500), wait).await;
        }
    }
}

/// The client task's state.
struct Session {
    config: MqttConfig,
    client: AsyncClient,
    publisher: Publisher,
    to_core: mpsc::Sender<(Topic, Vec<u8>)>,
    connected: bool,
    /// What the core published while not connected, oldest first.
    held: Vec<Publication>,
}

impl Session {
    async fn run(mut self, mut eventloop: EventLoop, mut from_core: mpsc::Receiver<Outgoing>) {
        let mut backoff = Backoff::new(Duration::from_millis(200), Duration::from_secs(5));
        loop {
            tokio::select! {
                event = eventloop.poll() => match event {
                    Ok(event) => {
                        if self.event(event) {
                            backoff.reset();
                        }
                    }
                    Err(e) => {
                        if std::mem::take(&mut self.connected) {
                            tracing::warn!("VDA 5050: broker {}:{} lost: {e}", self.config.host, self.config.port);
                        }
                        tokio::time::sleep(backoff.next_delay()).await;
                    }
                },
                out = from_core.recv() => match out {
                    Some(Outgoing::Message(message)) => {
                        let publication = self.publisher.message(message, unix_ms());
                        self.send_or_hold(publication);
                    }
                    Some(Outgoing::Stop(done)) => {
                        self.stop(&mut eventloop).await;
                        let _ = done.send(());
                        return;
                    }
                    None => return,
                },
            }
        }
    }

    /// Handles one event; true on a new connection.
    fn event(&mut self, event: Event) -> bool {
        match event {
            Event::Incoming(Packet::ConnAck(_)) => {
                self.connected = true;
                tracing::info!("VDA 5050: connected to {}:{}", self.config.host, self.config.port);
                let prefix = self.publisher.prefix().clone();
                for topic in [Topic::Order, Topic::InstantActions] {
                    if let Err(e) = self.client.try_subscribe(prefix.topic(topic), qos(topic.qos())) {
                        tracing::warn!("VDA 5050: subscribe {}: {e}", topic.name());
                    }
                }
                let online = self.publisher.connection(ConnectionState::Online, unix_ms());
                self.send(online);
                for held in std::mem::take(&mut self.held) {
                    self.send(held);
                }
                // Tells the core: a fresh state and the factsheet are due.
                let _ = self.to_core.try_send((Topic::Connection, Vec::new()));
                true
            }
            Event::Incoming(Packet::Publish(publish)) => {
                let topic = self.publisher.prefix().parse_topic(&publish.topic);
                if let Some(topic) = topic.filter(|t| t.subscribed_by_vehicle())
                    && self.to_core.try_send((topic, publish.payload.to_vec())).is_err()
                {
                    tracing::warn!("VDA 5050: core busy, {} dropped", topic.name());
                }
                false
            }
            _ => false,
        }
    }

    /// Sends at once when connected; else holds it until the subscriptions
    /// and ONLINE have gone out: a state the master reads before the
    /// vehicle has subscribed invites an order the broker would drop.
    fn send_or_hold(&mut self, publication: Publication) {
        if self.connected {
            self.send(publication);
            return;
        }
        if self.held.len() >= QUEUE {
            self.held.remove(0);
        }
        self.held.push(publication);
    }

    fn send(&self, publication: Publication) {
        let Publication {
            topic,
            qos: q,
            retain,
            payload,
        } = publication;
        // Queued in the client while disconnected, dropped when its queue
        // is full (a state is sent again soon).
        let _ = self.client.try_publish(topic, qos(q), retain, payload);
    }

    /// OFFLINE (retained), then disconnect, polling until it is out.
    async fn stop(&mut self, eventloop: &mut EventLoop) {
        let offline = self.publisher.connection(ConnectionState::Offline, unix_ms());
        self.send(offline);
        let _ = self.client.try_disconnect();
        let _ = tokio::time::timeout(STOP_WAIT, async {
            loop {
                match eventloop.poll().await {
                    Ok(Event::Outgoing(rumqttc::Outgoing::Disconnect)) | Err(_) => return,
                    Ok(_) => {}
                }
            }
        })
        .await;
    }
}

#[cfg(test)]
mod tests {
    use super::{BrokerUrl, parse_broker_url};

    #[test]
    fn broker_urls_are_mqtt_or_mqtts_host_port() {
        let url = |host: &str, port, tls| {
            Ok(BrokerUrl {
                host: host.into(),
                port,
                tls,
            })
        };
        assert_eq!(parse_broker_url("mqtt://127.0.0.1:1884"), url("127.0.0.1", 1884, false));
        assert_eq!(parse_broker_url("mqtt://broker"), url("broker", 1883, false));
        assert_eq!(parse_broker_url("mqtts://broker:8884"), url("broker", 8884, true));
        assert_eq!(parse_broker_url("mqtts://broker"), url("broker", 8883, true));
        assert_eq!(
            parse_broker_url("mqtts://broker").map(|u| u.to_string()),
            Ok("mqtts://broker:8883".into())
        );
        for bad in [
            "http://broker",
            "mqtt://:1883",
            "mqtt://b:99999",
            "mqtt://b:0",
            "mqtts://user@b:1",
            "mqtt://b/x",
            "broker:1883",
        ] {
            assert!(parse_broker_url(bad).is_err(), "{bad}");
        }
    }
}
