//! What the kill and flood benches need of a ground station and of the
//! process under test: `furrow sitl` started as a child (its ready line
//! parsed for the bound ports, stderr kept in a file), and a small blocking
//! MAVLink 2 client over TCP (system 255, component 190, as pymavlink)
//! with the mission and parameter microservices and a few commands.

use std::io::{BufRead, BufReader};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use mavlink::dialects::ardupilotmega::{
    HEARTBEAT_DATA, MISSION_ACK_DATA, MISSION_COUNT_DATA, MISSION_REQUEST_INT_DATA, MISSION_REQUEST_LIST_DATA, MavCmd,
    MavMessage, MavMissionResult, MavMissionType, MavParamType, MavResult, PARAM_REQUEST_READ_DATA, PARAM_SET_DATA,
};
use mavlink::error::MessageReadError;
use mavlink::{MavHeader, MavlinkReader, MavlinkVersion};
use mission::protocol::{Sender, item_message};
use mission::{MissionItem, MissionType};

/// The vehicle's ids (SITL defaults).
pub const VEHICLE: Sender = Sender {
    system_id: 1,
    component_id: 1,
};

/// ArduPilot Rover custom modes used here.
pub const MODE_HOLD: u32 = 4;
pub const MODE_AUTO: u32 = 10;

/// How long one request waits for its answer.
const ANSWER_TIMEOUT: Duration = Duration::from_secs(3);
/// Socket read timeout: short, so deadlines are kept; telemetry flows
/// continuously, so a timeout in the middle of a frame is rare.
const READ_POLL: Duration = Duration::from_millis(200);

/// A `furrow sitl` child process.
pub struct SitlProcess {
    child: Arc<Mutex<Child>>,
    pid: u32,
    pub tcp_port: u16,
    pub udp_local: SocketAddr,
    pub stderr_path: PathBuf,
    // Kept open: a closed stdout would make a later print fail in the child.
    _stdout: BufReader<ChildStdout>,
}

impl SitlProcess {
    /// Starts `exe sitl <args>` with stderr going to `stderr_path`, and waits
    /// for its ready line.
    pub fn start(exe: &Path, args: &[String], stderr_path: &Path) -> Result<SitlProcess, String> {
        let stderr = std::fs::File::create(stderr_path).map_err(|e| format!("{}: {e}", stderr_path.display()))?;
        let mut child = Command::new(exe)
            .arg("sitl")
            .args(args)
            .stdout(Stdio::piped())
            .stderr(stderr)
            .spawn()
            .map_err(|e| format!("starting {} sitl: {e}", exe.display()))?;
        let pid = child.id();
        let Some(stdout) = child.stdout.take() else {
            let _ = child.kill();
            return Err("furrow sitl: no stdout".into());
        };
        let mut stdout = BufReader::new(stdout);
        let mut line = String::new();
        let ready = stdout.read_line(&mut line).map_err(|e| e.to_string());
        let parsed = ready.and_then(|_| parse_ready_line(&line));
        match parsed {
            Ok((tcp_port, udp_local)) => Ok(SitlProcess {
                child: Arc::new(Mutex::new(child)),
                pid,
                tcp_port,
                udp_local,
                stderr_path: stderr_path.to_path_buf(),
                _stdout: stdout,
            }),
            Err(e) => {
                let _ = child.kill();
                let _ = child.wait();
                let log = std::fs::read_to_string(stderr_path).unwrap_or_default();
                Err(format!("furrow sitl did not start ({e}): {}", log.trim()))
            }
        }
    }

    /// The process id (for /proc).
    pub fn pid(&self) -> u32 {
        self.pid
    }

    /// Something another thread can SIGKILL the process with.
    pub fn killer(&self) -> Killer {
        Killer(self.child.clone())
    }

    /// SIGINT (the process prints its exit report), then waits up to
    /// `timeout` before killing it.
    pub fn interrupt(&self, timeout: Duration) -> Result<(), String> {
        Command::new("kill")
            .args(["-INT", &self.pid.to_string()])
            .status()
            .map_err(|e| format!("kill -INT: {e}"))?;
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            if let Ok(mut child) = self.child.lock()
                && child.try_wait().map_err(|e| e.to_string())?.is_some()
            {
                return Ok(());
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        self.killer().kill();
        Err(format!("furrow sitl did not stop within {timeout:?} of SIGINT"))
    }

    /// What the process wrote to stderr so far.
    pub fn stderr(&self) -> String {
        std::fs::read_to_string(&self.stderr_path).unwrap_or_default()
    }
}

impl Drop for SitlProcess {
    fn drop(&mut self) {
        self.killer().kill();
    }
}

/// Sends SIGKILL to a [`SitlProcess`] and reaps it.
#[derive(Clone)]
pub struct Killer(Arc<Mutex<Child>>);

impl Killer {
    pub fn kill(&self) {
        if let Ok(mut child) = self.0.lock() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// `furrow sitl ready: tcp 0.0.0.0:P, udp 127.0.0.1:Q to …` → (P, udp address).
pub fn parse_ready_line(line: &str) -> Result<(u16, SocketAddr), String> {
    let field = |key: &str| {
        line.split(key)
            .nth(1)
            .and_then(|rest| rest.split([',', ' ']).next())
            .and_then(|a| a.parse::<SocketAddr>().ok())
    };
    match (field("tcp "), field("udp ")) {
        (Some(tcp), Some(udp)) => Ok((tcp.port(), udp)),
        _ => Err(format!("unexpected ready line {line:?}")),
    }
}

/// A MAVLink 2 ground station on one TCP connection.
pub struct GcsClient {
    stream: TcpStream,
    reader: MavlinkReader<TcpStream>,
    sequence: u8,
    system_id: u8,
}

impl GcsClient {
    pub fn connect(port: u16) -> Result<GcsClient, String> {
        Self::connect_as(port, 255)
    }

    /// Connects as `system_id` (component 190).
    pub fn connect_as(port: u16, system_id: u8) -> Result<GcsClient, String> {
        let stream = TcpStream::connect(("127.0.0.1", port)).map_err(|e| format!("connect to port {port}: {e}"))?;
        stream.set_read_timeout(Some(READ_POLL)).map_err(|e| e.to_string())?;
        let _ = stream.set_nodelay(true);
        let reader = MavlinkReader::new(stream.try_clone().map_err(|e| e.to_string())?);
        Ok(GcsClient {
            stream,
            reader,
            sequence: 0,
            system_id,
        })
    }

    pub fn send(&mut self, message: &MavMessage) -> Result<(), String> {
        let header = MavHeader {
            system_id: u32::from(self.system_id),
            component_id: 190,
            sequence: self.sequence,
        };
        self.sequence = self.sequence.wrapping_add(1);
        mavlink::write_versioned_msg(&mut self.stream, MavlinkVersion::V2, header, message)
            .map(|_| ())
            .map_err(|e| format!("send: {e}"))
    }

    /// The next message, `None` when `deadline` passes first; an error when
    /// the connection is gone.
    pub fn recv(&mut self, deadline: Instant) -> Result<Option<MavMessage>, String> {
        while Instant::now() < deadline {
            match self.reader.read_message::<MavMessage>(MavlinkVersion::V2) {
                Ok((_, m)) => return Ok(Some(m)),
                Err(MessageReadError::Io(e))
                    if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {}
                Err(MessageReadError::Io(e)) => return Err(format!("connection: {e}")),
                // A frame this dialect cannot decode: skip it.
                Err(_) => {}
            }
        }
        Ok(None)
    }

    /// Reads until `pick` returns something, or `timeout` passes.
    pub fn wait_for<T>(
        &mut self,
        timeout: Duration,
        mut pick: impl FnMut(&MavMessage) -> Option<T>,
    ) -> Result<Option<T>, String> {
        let deadline = Instant::now() + timeout;
        while let Some(m) = self.recv(deadline)? {
            if let Some(t) = pick(&m) {
                return Ok(Some(t));
            }
        }
        Ok(None)
    }

    /// Like [`GcsClient::wait_for`], with a timeout being an error.
    fn expect<T>(&mut self, what: &str, pick: impl FnMut(&MavMessage) -> Option<T>) -> Result<T, String> {
        self.wait_for(ANSWER_TIMEOUT, pick)?
            .ok_or_else(|| format!("no {what} within {ANSWER_TIMEOUT:?}"))
    }

    /// A GCS heartbeat, as ground stations send once a second.
    pub fn heartbeat(&mut self) -> Result<(), String> {
        self.send(&gcs_heartbeat())
    }

    /// Sends a heartbeat and waits for the vehicle's.
    pub fn wait_heartbeat(&mut self, timeout: Duration) -> Result<HEARTBEAT_DATA, String> {
        self.heartbeat()?;
        self.wait_for(timeout, |m| match m {
            MavMessage::HEARTBEAT(h) => Some(h.clone()),
            _ => None,
        })?
        .ok_or_else(|| format!("no HEARTBEAT within {timeout:?}"))
    }

    /// PARAM_SET; returns the echoed PARAM_VALUE's value.
    pub fn param_set(&mut self, name: &str, value: f32) -> Result<f32, String> {
        self.send(&param_set_message(name, value))?;
        self.expect(&format!("PARAM_VALUE echo of {name}"), |m| param_value_of(m, name))
    }

    /// PARAM_REQUEST_READ by name; returns the value.
    pub fn param_read(&mut self, name: &str) -> Result<f32, String> {
        self.send(&MavMessage::PARAM_REQUEST_READ(PARAM_REQUEST_READ_DATA {
            param_index: -1,
            target_system: VEHICLE.system_id,
            target_component: VEHICLE.component_id,
            param_id: param_id(name).into(),
        }))?;
        self.expect(&format!("PARAM_VALUE of {name}"), |m| param_value_of(m, name))
    }

    /// COMMAND_LONG and its COMMAND_ACK's result.
    pub fn command(&mut self, command: MavCmd, params: [f32; 7]) -> Result<MavResult, String> {
        // The vehicle is 1/1 (VEHICLE), as the in-process GCS addresses it.
        self.send(&autopilot::sitl::gcs::command_long(command, params))?;
        self.expect(&format!("COMMAND_ACK for {command:?}"), |m| match m {
            MavMessage::COMMAND_ACK(a) if a.command == command => Some(a.result),
            _ => None,
        })
    }

    /// DO_SET_MODE with a Rover custom mode number.
    pub fn set_mode(&mut self, custom_mode: u32) -> Result<MavResult, String> {
        self.command(
            MavCmd::MAV_CMD_DO_SET_MODE,
            [1.0, custom_mode as f32, 0.0, 0.0, 0.0, 0.0, 0.0],
        )
    }

    pub fn arm(&mut self) -> Result<MavResult, String> {
        self.command(
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        )
    }

    /// Makes mission item `seq` current (what MISSION_SET_CURRENT asked for
    /// before it was deprecated).
    pub fn set_mission_current(&mut self, seq: u16) -> Result<MavResult, String> {
        self.command(
            MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT,
            [f32::from(seq), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        )
    }

    /// Uploads a mission (item 0 is home) the way QGroundControl does,
    /// answering the vehicle's requests. Returns the final MISSION_ACK's
    /// opaque id and when it arrived. `sent_last` is told when the last
    /// item has been written to the socket.
    pub fn upload_mission(
        &mut self,
        items: &[MissionItem],
        mut sent_last: impl FnMut(Instant),
    ) -> Result<(u32, Instant), String> {
        let count = u16::try_from(items.len()).map_err(|_| format!("{} items: too many", items.len()))?;
        self.send(&MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count,
            target_system: VEHICLE.system_id,
            target_component: VEHICLE.component_id,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id: 0,
        }))?;
        let me = Sender {
            system_id: VEHICLE.system_id,
            component_id: VEHICLE.component_id,
        };
        loop {
            #[allow(deprecated)]
            let next = self.expect("MISSION_REQUEST_INT or MISSION_ACK", |m| match m {
                MavMessage::MISSION_REQUEST_INT(r) if r.mission_type == MavMissionType::MAV_MISSION_TYPE_MISSION => {
                    Some(Ok(r.seq))
                }
                MavMessage::MISSION_REQUEST(r) if r.mission_type == MavMissionType::MAV_MISSION_TYPE_MISSION => {
                    Some(Ok(r.seq))
                }
                MavMessage::MISSION_ACK(a) if a.mission_type == MavMissionType::MAV_MISSION_TYPE_MISSION => {
                    Some(Err((a.mavtype, a.opaque_id)))
                }
                _ => None,
            })?;
            match next {
                Ok(seq) => {
                    let item = items
                        .get(usize::from(seq))
                        .ok_or_else(|| format!("vehicle asked for item {seq} of {count}"))?;
                    let message = item_message(item, MissionType::Mission, me)
                        .ok_or_else(|| format!("item {seq}: not expressible as MISSION_ITEM_INT"))?;
                    self.send(&message)?;
                    if usize::from(seq) + 1 == items.len() {
                        sent_last(Instant::now());
                    }
                }
                Err((MavMissionResult::MAV_MISSION_ACCEPTED, opaque_id)) => return Ok((opaque_id, Instant::now())),
                Err((result, _)) => return Err(format!("mission upload refused: {result:?}")),
            }
        }
    }

    /// Downloads the mission in force: its items and opaque id.
    pub fn download_mission(&mut self) -> Result<(Vec<MissionItem>, u32), String> {
        self.send(&MavMessage::MISSION_REQUEST_LIST(MISSION_REQUEST_LIST_DATA {
            target_system: VEHICLE.system_id,
            target_component: VEHICLE.component_id,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        }))?;
        let (count, opaque_id) = self.expect("MISSION_COUNT", |m| match m {
            MavMessage::MISSION_COUNT(c) if c.mission_type == MavMissionType::MAV_MISSION_TYPE_MISSION => {
                Some((c.count, c.opaque_id))
            }
            _ => None,
        })?;
        let mut items = Vec::with_capacity(usize::from(count));
        for seq in 0..count {
            self.send(&MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
                seq,
                target_system: VEHICLE.system_id,
                target_component: VEHICLE.component_id,
                mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            }))?;
            let item = self.expect(&format!("MISSION_ITEM_INT {seq}"), |m| match m {
                MavMessage::MISSION_ITEM_INT(i)
                    if i.seq == seq && i.mission_type == MavMissionType::MAV_MISSION_TYPE_MISSION =>
                {
                    Some(MissionItem::from_mavlink(i))
                }
                _ => None,
            })?;
            items.push(item);
        }
        self.send(&MavMessage::MISSION_ACK(MISSION_ACK_DATA {
            target_system: VEHICLE.system_id,
            target_component: VEHICLE.component_id,
            mavtype: MavMissionResult::MAV_MISSION_ACCEPTED,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id,
        }))?;
        Ok((items, opaque_id))
    }
}

pub use autopilot::sitl::gcs::heartbeat as gcs_heartbeat;

pub fn param_set_message(name: &str, value: f32) -> MavMessage {
    MavMessage::PARAM_SET(PARAM_SET_DATA {
        param_value: value,
        target_system: VEHICLE.system_id,
        target_component: VEHICLE.component_id,
        param_id: param_id(name).into(),
        param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
    })
}

/// A parameter name as the 16-byte, NUL-padded `param_id`.
pub fn param_id(name: &str) -> [u8; 16] {
    let mut id = [0u8; 16];
    for (slot, byte) in id.iter_mut().zip(name.bytes()) {
        *slot = byte;
    }
    id
}

/// The value of a PARAM_VALUE for `name`.
pub fn param_value_of(message: &MavMessage, name: &str) -> Option<f32> {
    match message {
        MavMessage::PARAM_VALUE(v) => {
            let id: [u8; 16] = v.param_id.into();
            (id == param_id(name)).then_some(v.param_value)
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ready_line_gives_the_ports() {
        let (tcp, udp) =
            parse_ready_line("furrow sitl ready: tcp 0.0.0.0:40123, udp 127.0.0.1:41017 to 127.0.0.1:14550, sysid 1\n")
                .unwrap();
        assert_eq!(tcp, 40123);
        assert_eq!(udp, "127.0.0.1:41017".parse().unwrap());
        assert!(parse_ready_line("error: port in use").is_err());
    }

    #[test]
    fn param_ids_are_nul_padded() {
        assert_eq!(&param_id("WP_SPEED")[..9], b"WP_SPEED\0");
        assert_eq!(param_id("ABCDEFGHIJKLMNOPQ"), *b"ABCDEFGHIJKLMNOP");
    }
}
