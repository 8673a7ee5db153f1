//! Helpers for end-to-end tests that start the `furrow` binary and talk to
//! it over real sockets, as a ground station would.

use std::io::{BufRead, BufReader};
use std::net::{SocketAddr, TcpStream};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::{MavHeader, MavlinkReader, MavlinkVersion};

/// The binary under test: `FURROW_BIN`, else the one Cargo built next to
/// this test (target/<profile>/furrow).
pub fn furrow_bin() -> PathBuf {
    if let Some(path) = std::env::var_os("FURROW_BIN") {
        return PathBuf::from(path);
    }
    let exe = std::env::current_exe().expect("test executable path");
    // target/<profile>/deps/<test> → target/<profile>/furrow
    let profile_dir = exe.parent().and_then(|d| d.parent()).expect("target/<profile>");
    profile_dir.join("furrow")
}

/// What follows `key` in a ready line, up to the next `,` or whitespace.
fn field_after<'a>(line: &'a str, key: &str) -> &'a str {
    line.split(key)
        .nth(1)
        .and_then(|rest| rest.split([',', ' ', '\n']).next())
        .unwrap_or_else(|| panic!("no {key:?} in ready line {line:?}"))
}

/// A `furrow sitl` process with its bound addresses.
pub struct Sitl {
    child: Child,
    pub tcp: SocketAddr,
    pub udp_local: SocketAddr,
    /// The line it printed when ready.
    pub ready: String,
    _data: tempfile::TempDir,
}

impl Sitl {
    /// Starts SITL with a fresh data directory, TCP on a free port and the
    /// UDP link sending to `udp_peer_port`.
    pub fn start(udp_peer_port: u16, extra: &[&str]) -> Sitl {
        let data = tempfile::Builder::new()
            .prefix("furrow-e2e-")
            .tempdir()
            .expect("temp dir");
        let mut child = Command::new(furrow_bin())
            .args(["sitl", "--tcp-port", "0", "--speedup", "10", "--udp-port"])
            .arg(udp_peer_port.to_string())
            .arg("--data-dir")
            .arg(data.path())
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("starting {}: {e} (build it first)", furrow_bin().display()));
        let mut line = String::new();
        BufReader::new(child.stdout.take().expect("stdout"))
            .read_line(&mut line)
            .expect("ready line");
        let field = |key: &str| -> SocketAddr {
            let text = field_after(&line, key);
            text.parse()
                .unwrap_or_else(|_| panic!("{text:?} after {key:?} is not an address"))
        };
        let tcp = field("tcp ");
        let udp_local = field("udp ");
        Sitl {
            child,
            tcp: SocketAddr::from(([127, 0, 0, 1], tcp.port())),
            udp_local,
            ready: line,
            _data: data,
        }
    }

    /// What follows `key` in the ready line, up to the next `,` or space.
    pub fn ready_field(&self, key: &str) -> &str {
        field_after(&self.ready, key)
    }

    pub fn is_running(&mut self) -> bool {
        self.child.try_wait().expect("try_wait").is_none()
    }

    /// A TCP connection with a MAVLink reader (5 s read timeout).
    pub fn connect(&self) -> (TcpStream, MavlinkReader<TcpStream>) {
        let stream = TcpStream::connect(self.tcp).expect("connect");
        stream.set_read_timeout(Some(Duration::from_secs(5))).expect("timeout");
        let reader = MavlinkReader::new(stream.try_clone().expect("clone"));
        (stream, reader)
    }
}

impl Drop for Sitl {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Reads MAVLink 2 frames (all Furrow sends) until a message matches or
/// `timeout` passes; a MAVLink 1 frame would never match.
pub fn wait_for<R: std::io::Read>(
    reader: &mut MavlinkReader<R>,
    timeout: Duration,
    mut pred: impl FnMut(&MavHeader, &MavMessage) -> bool,
) -> Option<MavMessage> {
    let deadline = Instant::now() + timeout;
    while Instant::now() < deadline {
        match reader.read_message::<MavMessage>(MavlinkVersion::V2) {
            Ok((h, m)) if pred(&h, &m) => return Some(m),
            Ok(_) => {}
            Err(mavlink::error::MessageReadError::Io(e))
                if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {}
            Err(mavlink::error::MessageReadError::Io(_)) => return None,
            Err(_) => {}
        }
    }
    None
}

/// Encodes a message as a ground station (255/190) would.
pub fn encode(version: MavlinkVersion, message: &MavMessage) -> Vec<u8> {
    let header = MavHeader {
        system_id: 255,
        component_id: 190,
        sequence: 0,
    };
    let mut buf = Vec::new();
    mavlink::write_versioned_msg(&mut buf, version, header, message).expect("encode");
    buf
}
