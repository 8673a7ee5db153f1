//! The validated vehicle configuration: what the runner opens.

use std::fmt;
use std::path::PathBuf;
use std::time::Duration;

use drivers::ntrip::{NtripConfig, NtripVersion};
use serde::Deserialize;

use vda5050::TopicPrefix;

use crate::edge::mqtt::{BrokerUrl, MqttConfig};
use crate::edge::mqtt_tls::TlsFiles;
use crate::fleet::AgentConfig;
use crate::fleet::actions::ActionOutput;
use crate::link::endpoint::Endpoint;
use crate::sitl::simulation::ModelKind;

pub const DEFAULT_DATA_DIR: &str = "furrow-data";
pub const DEFAULT_GNSS_BAUD: u32 = 115_200;
pub const DEFAULT_GNSS_STALE_MS: u32 = 1000;
pub const DEFAULT_NTRIP_PORT: u16 = 2101;
pub const DEFAULT_GGA_INTERVAL_S: u32 = 10;
pub const DEFAULT_PWM_ROOT: &str = "/sys/class/pwm";
pub const DEFAULT_PWM_PERIOD_US: u32 = 20_000;
/// SCAN1 (front) and SCAN2: the obstacle pipeline has two scanner slots.
pub const MAX_SCANNERS: usize = 2;
/// SERVO1..SERVO16, as in ArduPilot.
pub const SERVO_CHANNELS: u8 = 16;

/// Accepted baud rates: the Linux termios `Bnnn` constants from 1200 up.
pub const BAUD_RATES: [u32; 21] = [
    1200, 2400, 4800, 9600, 19_200, 38_400, 57_600, 115_200, 230_400, 460_800, 500_000, 576_000, 921_600, 1_000_000,
    1_152_000, 1_500_000, 2_000_000, 2_500_000, 3_000_000, 3_500_000, 4_000_000,
];

/// A validated vehicle configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct VehicleConfig {
    pub frame: Frame,
    /// Parameters, missions and logs; resolved against the config file's directory.
    pub data_dir: PathBuf,
    pub gnss: GnssSettings,
    pub heading: HeadingSource,
    pub corrections: Corrections,
    /// Index 0 is SCAN1 (front), index 1 SCAN2.
    pub scanners: Vec<HostPort>,
    /// The magnetic guide sensor's frame reader.
    pub magnetic: Option<SerialLine>,
    /// An inertial unit sending VectorNav `$VNIMU`/`$VNYMR` lines.
    pub imu: Option<SerialLine>,
    pub pwm: PwmSettings,
    /// MAVLink endpoints, in file order.
    pub mavlink: Vec<Endpoint>,
    /// Endpoints marked `secure = true`, in file order: they accept
    /// SETUP_SIGNING and unsigned packets (see `link::sign_policy`).
    pub secure_mavlink: Vec<Endpoint>,
    /// The VDA 5050 broker and agent, when this vehicle is an AGV of a fleet.
    pub vda5050: Option<Vda5050Settings>,
}

/// `[vda5050]`: the broker, who this vehicle is on it, and its agent.
#[derive(Clone, Debug, PartialEq)]
pub struct Vda5050Settings {
    pub broker: BrokerUrl,
    /// Read for an `mqtts://` broker only.
    pub tls: TlsFiles,
    /// User name and password (empty when only a user name is given).
    pub credentials: Option<(String, String)>,
    pub client_id: String,
    pub prefix: TopicPrefix,
    /// Map, message rates and the actions' outputs.
    pub agent: AgentConfig,
}

impl Vda5050Settings {
    /// The MQTT client's configuration (the TLS files read again).
    pub fn mqtt(&self) -> Result<MqttConfig, String> {
        MqttConfig::new(
            &self.broker,
            &self.tls,
            self.prefix.clone(),
            self.client_id.clone(),
            self.credentials.clone(),
        )
        .map_err(|e| format!("[vda5050]: {e}"))
    }

    fn summary(&self) -> Vec<String> {
        let mut lines = vec![format!(
            "vda5050      {} as {}, client id {}, map {:?} v{:?}",
            self.broker,
            self.prefix.topic(vda5050::Topic::State).trim_end_matches("/state"),
            self.client_id,
            self.agent.map_id,
            self.agent.map_version
        )];
        match self.agent.map_origin {
            Some(o) => lines.push(format!(
                "vda5050      map frame: the plant grid about {:.7},{:.7} (shared by every vehicle configured so)",
                o.lat_deg, o.lon_deg
            )),
            None => lines.push(
                "vda5050      map frame: about this vehicle's first fix (no map_origin: a fleet's vehicles do not share coordinates)"
                    .to_owned(),
            ),
        }
        if self.broker.tls {
            let ca = self
                .tls
                .ca_file
                .as_ref()
                .map_or("the system's trust store".to_string(), |f| f.display().to_string());
            let client = self
                .tls
                .client_auth
                .as_ref()
                .map_or("no client certificate".to_string(), |(c, _)| {
                    format!("client certificate {}", c.display())
                });
            lines.push(format!("vda5050      TLS: broker checked against {ca}, {client}"));
        }
        if let Some((user, _)) = &self.credentials {
            lines.push(format!("vda5050      user {user} (password not shown)"));
        }
        for m in &self.agent.mappings {
            let output = match m.output {
                ActionOutput::Servo { channel, pwm_us } => format!("SERVO{channel} to {pwm_us} us"),
                ActionOutput::Relay { relay, on } => format!("relay {relay} {}", if on { "on" } else { "off" }),
            };
            lines.push(format!(
                "vda5050      action {} sets {output} for {} s",
                m.action_type, m.duration_s
            ));
        }
        lines
    }
}

/// The drive train; it picks the parameter defaults profile the way
/// `furrow sitl --model` does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Frame {
    Ackermann,
    Differential,
}

impl Frame {
    pub fn model_kind(self) -> ModelKind {
        match self {
            Frame::Ackermann => ModelKind::Ackermann,
            Frame::Differential => ModelKind::Differential,
        }
    }

    pub(super) fn name(self) -> &'static str {
        match self {
            Frame::Ackermann => "ackermann",
            Frame::Differential => "differential",
        }
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SerialLine {
    pub path: PathBuf,
    pub baud: u32,
}

impl fmt::Display for SerialLine {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "serial {} at {} baud", self.path.display(), self.baud)
    }
}

/// A TCP peer; the host is kept unresolved (name or address) so a config
/// check needs no network.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HostPort {
    pub host: String,
    pub port: u16,
}

impl HostPort {
    /// `HOST:PORT` or `[IPV6]:PORT`, port 1..=65535.
    pub fn parse(text: &str) -> Result<HostPort, String> {
        let (head, tail) = text
            .rsplit_once(':')
            .ok_or_else(|| format!("{text:?} is not HOST:PORT"))?;
        let host = match head.strip_prefix('[') {
            Some(inner) => inner
                .strip_suffix(']')
                .ok_or_else(|| format!("{text:?}: unclosed '[' in the host"))?,
            None if head.contains(':') => {
                return Err(format!("{text:?}: write an IPv6 host in brackets, [::1]:PORT"));
            }
            None => head,
        };
        check_host(host).map_err(|e| format!("{text:?}: {e}"))?;
        let port = tail
            .parse::<u16>()
            .ok()
            .filter(|p| *p != 0)
            .ok_or_else(|| format!("{text:?}: port {tail:?} is not a number 1-65535"))?;
        Ok(HostPort {
            host: host.to_string(),
            port,
        })
    }
}

impl fmt::Display for HostPort {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.host.contains(':') {
            write!(f, "[{}]:{}", self.host, self.port)
        } else {
            write!(f, "{}:{}", self.host, self.port)
        }
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GnssLink {
    Serial(SerialLine),
    /// A receiver's or an NMEA server's TCP port.
    Tcp(HostPort),
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GnssSettings {
    pub link: GnssLink,
    /// No good sentence for this long: the GNSS counts as lost.
    pub stale_ms: u32,
}

impl GnssSettings {
    pub fn stale_after(&self) -> Duration {
        Duration::from_millis(u64::from(self.stale_ms))
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub enum HeadingSource {
    /// HDT/THS from a dual-antenna receiver, on the GNSS link.
    Gnss,
    /// A separate NMEA compass (HDG/HDM) on its own port.
    Compass(SerialLine),
    /// No heading sensor: heading from motion only.
    None,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Corrections {
    /// Pass GPS_RTCM_DATA from a ground station to the receiver.
    pub mavlink: bool,
    /// The caster, with the client's default timeouts and backoff.
    pub ntrip: Option<NtripConfig>,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PwmSettings {
    /// The sysfs PWM class directory, normally /sys/class/pwm.
    pub root: PathBuf,
    pub period_us: u32,
    pub outputs: Vec<PwmOutputSetting>,
}

/// SERVOn's pulse goes out on `ROOT/pwmchipCHIP/pwmCHANNEL`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PwmOutputSetting {
    pub servo: u8,
    pub chip: u32,
    pub channel: u32,
}

impl VehicleConfig {
    /// One line per device, for `furrow config check`. Passwords are not shown.
    pub fn summary(&self) -> String {
        let mut lines = vec![format!(
            "vehicle      {} frame, data in {}",
            self.frame.name(),
            self.data_dir.display()
        )];
        let gnss = match &self.gnss.link {
            GnssLink::Serial(line) => line.to_string(),
            GnssLink::Tcp(address) => format!("tcp {address}"),
        };
        lines.push(format!("gnss         {gnss}, stale after {} ms", self.gnss.stale_ms));
        lines.push(match &self.heading {
            HeadingSource::Gnss => "heading      HDT/THS from the GNSS receiver".to_string(),
            HeadingSource::Compass(line) => format!("heading      NMEA compass on {line}"),
            HeadingSource::None => "heading      none (from motion only)".to_string(),
        });
        lines.push(format!(
            "corrections  MAVLink GPS_RTCM_DATA {}",
            if self.corrections.mavlink {
                "accepted"
            } else {
                "ignored"
            }
        ));
        if let Some(ntrip) = &self.corrections.ntrip {
            lines.push(ntrip_summary(ntrip));
        }
        for (index, address) in self.scanners.iter().enumerate() {
            let role = if index == 0 { " (front)" } else { "" };
            lines.push(format!("scanner      SCAN{}{role} CoLa-A tcp {address}", index + 1));
        }
        if let Some(line) = &self.magnetic {
            lines.push(format!("magnetic     {line}"));
        }
        if let Some(line) = &self.imu {
            lines.push(format!("imu          VectorNav ASCII on {line}"));
        }
        lines.extend(self.output_summary());
        if let Some(vda5050) = &self.vda5050 {
            lines.extend(vda5050.summary());
        }
        lines.join("\n")
    }

    /// The summary's PWM outputs and MAVLink endpoints.
    fn output_summary(&self) -> Vec<String> {
        let mut lines = Vec::new();
        for output in &self.pwm.outputs {
            lines.push(format!(
                "pwm          SERVO{} -> {}, period {} us",
                output.servo,
                self.pwm
                    .root
                    .join(format!("pwmchip{}/pwm{}", output.chip, output.channel))
                    .display(),
                self.pwm.period_us
            ));
        }
        for endpoint in &self.mavlink {
            lines.push(format!("mavlink      {endpoint}"));
        }
        for endpoint in &self.secure_mavlink {
            lines.push(format!(
                "mavlink      {endpoint} (secure: SETUP_SIGNING and unsigned accepted)"
            ));
        }
        if self.mavlink.is_empty() && self.secure_mavlink.is_empty() {
            lines.push("mavlink      none: no ground station can connect".to_string());
        }
        lines
    }
}

/// The summary's NTRIP line. The password is not shown.
fn ntrip_summary(ntrip: &NtripConfig) -> String {
    let version = match ntrip.version {
        NtripVersion::V1 => 1,
        NtripVersion::V2 => 2,
    };
    let user = match (&ntrip.user, &ntrip.password) {
        (Some(user), Some(_)) => format!("as {user} (password set)"),
        (Some(user), None) => format!("as {user} (no password)"),
        _ => "anonymous".to_string(),
    };
    let gga = match ntrip.gga_interval.as_secs() {
        0 => "no GGA".to_string(),
        s => format!("GGA every {s} s"),
    };
    let host = HostPort {
        host: ntrip.host.clone(),
        port: ntrip.port,
    };
    format!("ntrip        v{version} {host}/{} {user}, {gga}", ntrip.mountpoint)
}

pub(super) fn check_host(host: &str) -> Result<(), String> {
    if host.is_empty() {
        Err("empty host".to_string())
    } else if host.chars().any(|c| c.is_whitespace() || c.is_control() || c == '/') {
        Err(format!("{host:?} is not a host name or address"))
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn host_port_forms() {
        assert_eq!(
            HostPort::parse("192.168.0.1:2111"),
            Ok(HostPort {
                host: "192.168.0.1".into(),
                port: 2111
            })
        );
        assert_eq!(HostPort::parse("[::1]:2111").map(|h| h.host), Ok("::1".to_string()));
        assert_eq!(
            HostPort::parse("[::1]:2111").map(|h| h.to_string()),
            Ok("[::1]:2111".into())
        );
        for bad in [
            "",
            "host",
            "host:",
            ":80",
            "host:0",
            "host:65536",
            "::1:80",
            "[::1:80",
            "a b:1",
        ] {
            assert!(HostPort::parse(bad).is_err(), "{bad}");
        }
    }
}
