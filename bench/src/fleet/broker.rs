//! The real broker the benchmark runs against (Mosquitto behind a port from
//! the OS) and the master control's side: one MQTT client subscribed to
//! every vehicle's topics, stamping what arrives with the wall clock, and
//! every message checked against the official VDA 5050 schema of its topic.

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use rumqttc::{Client, Event, MqttOptions, Packet, QoS};
use serde_json::Value;

pub struct Mosquitto {
    child: Child,
    /// The broker's TCP port: the benchmark's own listener, carried to
    /// Mosquitto's Unix socket.
    pub port: u16,
    _port: BrokerPort,
}

impl Mosquitto {
    /// Mosquitto from the distribution (`mosquitto` on PATH or in
    /// /usr/sbin), anonymous, no persistence, listening on a Unix socket in
    /// `dir`, behind a loopback TCP port the benchmark binds on port 0 and
    /// holds (Mosquitto 2.0 cannot bind port 0 and say which port it got;
    /// the tests use the same scheme). No port is probed or guessed.
    pub fn start(dir: &Path) -> Result<Mosquitto, String> {
        let exe = mosquitto_exe()?;
        let socket = dir.join("broker.sock");
        let child = start_on(exe, dir, &socket)?;
        let port = BrokerPort::open(socket)?;
        Ok(Mosquitto {
            child,
            port: port.port,
            _port: port,
        })
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }
}

/// A TCP port from the OS on loopback whose every connection is carried to
/// the broker's Unix socket, both ways, on one thread (tokio). It closes
/// when dropped; a connection ends when either side closes.
struct BrokerPort {
    port: u16,
    _stop: tokio::sync::oneshot::Sender<()>,
}

impl BrokerPort {
    fn open(socket: PathBuf) -> Result<BrokerPort, String> {
        let listener = std::net::TcpListener::bind("127.0.0.1:0").map_err(|e| format!("a port from the OS: {e}"))?;
        let port = listener.local_addr().map_err(|e| e.to_string())?.port();
        listener.set_nonblocking(true).map_err(|e| e.to_string())?;
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_io()
            .build()
            .map_err(|e| format!("broker port runtime: {e}"))?;
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        std::thread::Builder::new()
            .name("broker port".into())
            .spawn(move || runtime.block_on(carry_connections(listener, socket, stopped)))
            .map_err(|e| format!("broker port thread: {e}"))?;
        Ok(BrokerPort { port, _stop: stop })
    }
}

async fn carry_connections(
    listener: std::net::TcpListener,
    socket: PathBuf,
    mut stopped: tokio::sync::oneshot::Receiver<()>,
) {
    let Ok(listener) = tokio::net::TcpListener::from_std(listener) else {
        return;
    };
    loop {
        let accepted = tokio::select! {
            accepted = listener.accept() => accepted,
            _ = &mut stopped => return,
        };
        let Ok((mut client, _)) = accepted else {
            continue;
        };
        let socket = socket.clone();
        tokio::spawn(async move {
            // Small MQTT packets go out at once, as on a direct link.
            let _ = client.set_nodelay(true);
            if let Ok(mut broker) = tokio::net::UnixStream::connect(&socket).await {
                let _ = tokio::io::copy_bidirectional(&mut client, &mut broker).await;
            }
        });
    }
}

fn mosquitto_exe() -> Result<&'static str, String> {
    ["mosquitto", "/usr/sbin/mosquitto"]
        .into_iter()
        .find(|exe| {
            Command::new(exe)
                .arg("-h")
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .status()
                .is_ok()
        })
        .ok_or_else(|| "mosquitto is not installed (apt-get install mosquitto; tests/run installs it)".to_string())
}

/// This process's user: Mosquitto started as root drops to its own user,
/// who could not create the socket in the benchmark's directory.
fn user_name() -> String {
    Command::new("id")
        .arg("-un")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|name| name.trim().to_owned())
        .filter(|name| !name.is_empty())
        .or_else(|| std::env::var("USER").ok())
        .unwrap_or_else(|| "root".to_owned())
}

/// Mosquitto listening on the Unix socket `socket`, once its log says it
/// runs (every listener bound); its log is drained to the end on a thread
/// of its own.
fn start_on(exe: &str, dir: &Path, socket: &Path) -> Result<Child, String> {
    let conf = dir.join("mosquitto.conf");
    let text = format!(
        "listener 0 {}\nuser {}\nallow_anonymous true\npersistence false\nmax_queued_messages 10000\nlog_dest stderr\n",
        socket.display(),
        user_name()
    );
    std::fs::write(&conf, text).map_err(|e| format!("{}: {e}", conf.display()))?;
    let mut child = Command::new(exe)
        .arg("-c")
        .arg(&conf)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("starting mosquitto: {e}"))?;
    let log = child.stderr.take().expect("piped");
    let (running_tx, running_rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut lines = Vec::new();
        for line in BufReader::new(log).lines().map_while(Result::ok) {
            if line.contains(" running") {
                let _ = running_tx.send(Ok(()));
            }
            if lines.len() < 20 {
                lines.push(line);
            }
        }
        // The log ended before the broker ran: what it said is the reason.
        let _ = running_tx.send(Err(lines.join(" / ")));
    });
    match running_rx.recv_timeout(Duration::from_secs(10)) {
        Ok(Ok(())) => Ok(child),
        outcome => {
            let _ = child.kill();
            let _ = child.wait();
            Err(match outcome {
                Ok(Err(log)) => format!("mosquitto on {} exited: {log}", socket.display()),
                _ => format!("mosquitto on {} did not start within 10 s", socket.display()),
            })
        }
    }
}

impl Drop for Mosquitto {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// One message as the master control received it.
pub struct Received {
    pub at: Instant,
    pub unix_ms: u64,
    /// The serial number (topic level 4).
    pub serial: String,
    /// The topic's last level: state, visualization, connection, factsheet.
    pub kind: String,
    pub body: Value,
}

pub fn unix_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

/// The master control: subscribed to `uagv/v2/Furrow/+/+`.
pub struct Master {
    client: Client,
    inbox: mpsc::Receiver<(Instant, u64, String, Vec<u8>)>,
    schemas: Schemas,
}

impl Master {
    pub fn connect(port: u16, client_id: &str) -> Result<Master, String> {
        let mut options = MqttOptions::new(client_id, "127.0.0.1", port);
        options.set_keep_alive(Duration::from_secs(30));
        options.set_max_packet_size(1 << 20, 1 << 20);
        let (client, mut connection) = Client::new(options, 4096);
        client
            .subscribe("uagv/v2/Furrow/+/+", QoS::AtMostOnce)
            .map_err(|e| format!("subscribe: {e}"))?;
        let (tx, inbox) = mpsc::channel();
        std::thread::spawn(move || {
            for event in connection.iter() {
                match event {
                    Ok(Event::Incoming(Packet::Publish(p))) => {
                        let item = (Instant::now(), unix_ms(), p.topic, p.payload.to_vec());
                        if tx.send(item).is_err() {
                            return;
                        }
                    }
                    Ok(_) => {}
                    Err(_) => std::thread::sleep(Duration::from_millis(100)),
                }
            }
        });
        Ok(Master {
            client,
            inbox,
            schemas: Schemas::load()?,
        })
    }

    /// The next message from a vehicle (orders and instant actions, ours,
    /// are skipped), each checked against its schema.
    pub fn next(&mut self, timeout: Duration) -> Option<Received> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.checked_duration_since(Instant::now())?;
            let (at, unix_ms, topic, payload) = self.inbox.recv_timeout(left).ok()?;
            let mut levels = topic.split('/').skip(3);
            let (Some(serial), Some(kind)) = (levels.next(), levels.next()) else {
                continue;
            };
            if kind == "order" || kind == "instantActions" {
                continue;
            }
            let body = self.schemas.check(kind, &payload);
            return Some(Received {
                at,
                unix_ms,
                serial: serial.to_owned(),
                kind: kind.to_owned(),
                body,
            });
        }
    }

    /// Publishes `body` to vehicle `serial`'s `topic`.
    pub fn publish(&self, serial: &str, topic: &str, body: &Value) -> Result<(), String> {
        self.client
            .publish(
                format!("uagv/v2/Furrow/{serial}/{topic}"),
                QoS::AtMostOnce,
                false,
                body.to_string(),
            )
            .map_err(|e| format!("publish: {e}"))
    }

    pub fn schemas(&self) -> &Schemas {
        &self.schemas
    }
}

/// The official VDA 5050 2.1 schemas (vendored in tests/data/vda5050) and
/// what they found.
pub struct Schemas {
    validators: Vec<(String, jsonschema::Validator)>,
    pub checked: BTreeMap<String, u64>,
    pub violations: u64,
    /// The first few violations, for the report.
    pub examples: Vec<String>,
}

impl Schemas {
    fn load() -> Result<Schemas, String> {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/vda5050");
        let mut validators = Vec::new();
        for name in ["state", "visualization", "factsheet", "connection"] {
            let path = dir.join(format!("{name}.schema"));
            let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
            let schema: Value = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
            let validator = jsonschema::options()
                .should_validate_formats(true)
                .build(&schema)
                .map_err(|e| format!("{}: {e}", path.display()))?;
            validators.push((name.to_owned(), validator));
        }
        Ok(Schemas {
            validators,
            checked: BTreeMap::new(),
            violations: 0,
            examples: Vec::new(),
        })
    }

    /// Parses and validates one message of topic `kind` (Null if it is not
    /// JSON, counted as a violation).
    fn check(&mut self, kind: &str, payload: &[u8]) -> Value {
        *self.checked.entry(kind.to_owned()).or_default() += 1;
        let body: Value = match serde_json::from_slice(payload) {
            Ok(body) => body,
            Err(e) => {
                self.violation(format!("{kind}: not JSON: {e}"));
                return Value::Null;
            }
        };
        let Some((_, validator)) = self.validators.iter().find(|(name, _)| name == kind) else {
            self.violation(format!("{kind}: no schema for this topic"));
            return body;
        };
        let errors: Vec<String> = validator
            .iter_errors(&body)
            .map(|e| format!("{e} at {}", e.instance_path()))
            .collect();
        if let Some(first) = errors.first() {
            self.violation(format!("{kind}: {first}"));
        }
        body
    }

    fn violation(&mut self, text: String) {
        self.violations += 1;
        if self.examples.len() < 5 {
            self.examples.push(text);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A message published through the benchmark's port reaches a
    /// subscriber through it: the broker is there, behind a port nobody
    /// guessed.
    #[test]
    fn the_broker_carries_messages_behind_a_port_from_the_os() {
        let dir = tempfile::tempdir().expect("scratch");
        let broker = Mosquitto::start(dir.path()).expect("a broker");
        let mut master = Master::connect(broker.port, "bench-test").expect("connected");
        let connection = serde_json::json!({
            "headerId": 1, "timestamp": "2026-11-27T08:00:00.00Z", "version": "2.1.0",
            "manufacturer": "Furrow", "serialNumber": "X1", "connectionState": "ONLINE",
        });
        // The subscription may still be on its way: publish until it arrives.
        let deadline = Instant::now() + Duration::from_secs(10);
        let received = loop {
            master.publish("X1", "connection", &connection).expect("published");
            if let Some(m) = master.next(Duration::from_millis(200)) {
                break m;
            }
            assert!(Instant::now() < deadline, "nothing came back through the broker");
        };
        assert_eq!((received.serial.as_str(), received.kind.as_str()), ("X1", "connection"));
        assert_eq!(master.schemas().violations, 0, "{:?}", master.schemas().examples);
    }
}
