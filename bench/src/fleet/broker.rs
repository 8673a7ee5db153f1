//! The real broker the benchmark runs against (Mosquitto on a port from the OS)
//! and the master control's side: one MQTT client subscribed to every
//! vehicle's topics, stamping what arrives with the wall clock, and every
//! message checked against the official VDA 5050 schema of its topic.

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use rumqttc::{Client, Event, MqttOptions, Packet, QoS};
use serde_json::Value;

pub struct Mosquitto {
    child: Child,
    pub port: u16,
}

impl Mosquitto {
    /// Mosquitto from the distribution (`mosquitto` on PATH or in
    /// /usr/sbin), anonymous, no persistence, on a loopback port the OS
    /// handed out. Mosquitto cannot bind port 0 and say which port it got,
    /// so it is given a port the OS chose a moment ago, and the broker's own
    /// log says whether it bound it: a port taken in between makes it exit,
    /// and another is tried. Nothing else listening there is ever talked to.
    pub fn start(dir: &Path) -> Result<Mosquitto, String> {
        let exe = mosquitto_exe()?;
        let mut failures = Vec::new();
        for _ in 0..5 {
            let port = std::net::TcpListener::bind("127.0.0.1:0")
                .and_then(|l| l.local_addr())
                .map_err(|e| format!("a port from the OS: {e}"))?
                .port();
            match start_on(exe, dir, port) {
                Ok(child) => return Ok(Mosquitto { child, port }),
                Err(e) => failures.push(e),
            }
        }
        Err(failures.join("; "))
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
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

/// Mosquitto listening on `port`, once its log says it runs (every
/// listener bound); its log is drained to the end on a thread of its own.
fn start_on(exe: &str, dir: &Path, port: u16) -> Result<Child, String> {
    let conf = dir.join("mosquitto.conf");
    let text = format!(
        "listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\nmax_queued_messages 10000\nlog_dest stderr\n"
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
                Ok(Err(log)) => format!("mosquitto on port {port} exited: {log}"),
                _ => format!("mosquitto on port {port} did not start within 10 s"),
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

    #[test]
    fn a_port_taken_before_the_broker_binds_it_is_refused_not_used() {
        let dir = tempfile::tempdir().expect("scratch");
        let taken = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
        let port = taken.local_addr().expect("addr").port();
        let error = start_on(mosquitto_exe().unwrap(), dir.path(), port).expect_err("the port is taken");
        assert!(error.contains("exited"), "{error}");
        let broker = Mosquitto::start(dir.path()).expect("a broker");
        assert_ne!(broker.port, port);
        std::net::TcpStream::connect(("127.0.0.1", broker.port)).expect("it listens");
    }
}
