//! The vehicle configuration file of `furrow run --config FILE`: which
//! devices the real vehicle has and where they are plugged in. Tuning lives
//! in the parameters (SERVOn_*, SYSID_THISMAV, …), never here: this file only
//! says what hardware exists, so one parameter set can move between vehicles
//! wired differently.
//!
//! Rules the checks enforce (the examples in `autopilot/examples/*.toml`
//! explain every key):
//! - Unknown keys are errors, so a typo never silently falls back to a default.
//! - Every error names the key (`pwm.output[2].servo`, 0-based indices for
//!   arrays of tables) and the line, as `FILE:LINE:COLUMN: KEY: message`.
//! - Baud rates must be one of [`BAUD_RATES`]: the rates Linux sets through
//!   plain termios (no custom divisors). A list rather than a range catches
//!   the usual typos (11520, 15200) before the port opens and stays silent.
//! - Device paths (`serial = …`) must be absolute: a relative device path
//!   would depend on the directory `furrow` happens to be started from.
//! - `data_dir` and `pwm.root` are relative to the config file's directory, so
//!   a vehicle's config and its data can move together.
//! - One device path serves one purpose: the same port given twice is an error.
//! - `[gnss]` is the only required section.

use std::fmt;
use std::ops::{Range, RangeInclusive};
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde::Deserialize;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

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

const STALE_MS_RANGE: RangeInclusive<i64> = 100..=60_000;
const GGA_INTERVAL_S_RANGE: RangeInclusive<i64> = 0..=3600;
// Above the longest servo pulse (2200 µs) and up to 10 Hz frames.
const PWM_PERIOD_US_RANGE: RangeInclusive<i64> = 2500..=100_000;
const PWM_INDEX_RANGE: RangeInclusive<i64> = 0..=65_535;

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
    pub pwm: PwmSettings,
    /// MAVLink endpoints, in file order.
    pub mavlink: Vec<Endpoint>,
    /// Endpoints marked `secure = true`, in file order: they accept
    /// SETUP_SIGNING and unsigned packets (see `link::sign_policy`).
    pub secure_mavlink: Vec<Endpoint>,
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

    fn name(self) -> &'static str {
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
    pub ntrip: Option<NtripSettings>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NtripVersion {
    V1,
    V2,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NtripSettings {
    pub host: String,
    pub port: u16,
    pub mountpoint: String,
    pub user: Option<String>,
    pub password: Option<String>,
    pub version: NtripVersion,
    /// 0: never send GGA (casters with a fixed base need none).
    pub gga_interval_s: u32,
}

impl NtripSettings {
    pub fn gga_interval(&self) -> Duration {
        Duration::from_secs(u64::from(self.gga_interval_s))
    }
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

/// What is wrong and where.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConfigError {
    /// Set by [`load`]; [`parse`] has no file name.
    pub file: Option<PathBuf>,
    /// 1-based; `None` when the error is about the file as a whole (a missing
    /// section, an unreadable file).
    pub line: Option<usize>,
    pub column: Option<usize>,
    /// Dotted key path (`gnss.baud`, `scanner[1].address`); empty for syntax
    /// errors that are not about one key.
    pub key: String,
    pub message: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.file {
            Some(file) => write!(f, "{}", file.display())?,
            None => write!(f, "config")?,
        }
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
            if let Some(column) = self.column {
                write!(f, ":{column}")?;
            }
        }
        if !self.key.is_empty() {
            write!(f, ": {}", self.key)?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for ConfigError {}

/// Reads and checks a config file.
pub fn load(path: &Path) -> Result<VehicleConfig, ConfigError> {
    let with_file = |mut e: ConfigError| {
        e.file = Some(path.to_path_buf());
        e
    };
    let text = std::fs::read_to_string(path).map_err(|e| {
        with_file(ConfigError {
            file: None,
            line: None,
            column: None,
            key: String::new(),
            message: format!("cannot read: {e}"),
        })
    })?;
    let base_dir = path.parent().unwrap_or(Path::new(""));
    parse(&text, base_dir).map_err(with_file)
}

/// Checks config text; relative paths are resolved against `base_dir`.
pub fn parse(text: &str, base_dir: &Path) -> Result<VehicleConfig, ConfigError> {
    let raw: RawConfig = toml::from_str(text).map_err(|e| from_toml_error(text, &e))?;
    Checker { text, base_dir }.check(raw)
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
            let version = match ntrip.version {
                NtripVersion::V1 => 1,
                NtripVersion::V2 => 2,
            };
            let user = match (&ntrip.user, &ntrip.password) {
                (Some(user), Some(_)) => format!("as {user} (password set)"),
                (Some(user), None) => format!("as {user} (no password)"),
                _ => "anonymous".to_string(),
            };
            let gga = match ntrip.gga_interval_s {
                0 => "no GGA".to_string(),
                s => format!("GGA every {s} s"),
            };
            let host = HostPort {
                host: ntrip.host.clone(),
                port: ntrip.port,
            };
            lines.push(format!(
                "ntrip        v{version} {host}/{} {user}, {gga}",
                ntrip.mountpoint
            ));
        }
        for (index, address) in self.scanners.iter().enumerate() {
            let role = if index == 0 { " (front)" } else { "" };
            lines.push(format!("scanner      SCAN{}{role} CoLa-A tcp {address}", index + 1));
        }
        if let Some(line) = &self.magnetic {
            lines.push(format!("magnetic     {line}"));
        }
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
        lines.join("\n")
    }
}

// ---- The file as written: spans kept for the checks after parsing. ----
// Numbers are read as i64 so that range errors use this module's wording
// ("baud 11520 is not …") rather than serde's type names.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawConfig {
    vehicle: RawVehicle,
    gnss: Option<Spanned<RawGnss>>,
    heading: Option<RawHeading>,
    corrections: Option<RawCorrections>,
    #[serde(default)]
    scanner: Vec<RawScanner>,
    magnetic: Option<RawSerial>,
    pwm: Option<RawPwm>,
    #[serde(default)]
    mavlink: Vec<RawMavlink>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawVehicle {
    frame: Frame,
    data_dir: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGnss {
    serial: Option<Spanned<String>>,
    baud: Option<Spanned<i64>>,
    tcp: Option<Spanned<String>>,
    stale_ms: Option<Spanned<i64>>,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "lowercase")]
enum RawHeadingSource {
    Gnss,
    Compass,
    None,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawHeading {
    source: Spanned<RawHeadingSource>,
    serial: Option<Spanned<String>>,
    baud: Option<Spanned<i64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCorrections {
    mavlink: Option<bool>,
    ntrip: Option<RawNtrip>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawNtrip {
    host: Spanned<String>,
    port: Option<Spanned<i64>>,
    mountpoint: Spanned<String>,
    user: Option<Spanned<String>>,
    password: Option<Spanned<String>>,
    version: Option<Spanned<i64>>,
    gga_interval_s: Option<Spanned<i64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScanner {
    address: Spanned<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSerial {
    serial: Spanned<String>,
    baud: Spanned<i64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPwm {
    root: Option<Spanned<String>>,
    period_us: Option<Spanned<i64>>,
    #[serde(default)]
    output: Vec<RawPwmOutput>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPwmOutput {
    servo: Spanned<i64>,
    chip: Spanned<i64>,
    channel: Spanned<i64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMavlink {
    endpoint: Spanned<String>,
    secure: Option<bool>,
}

/// A device path already claimed, to report the first user on a clash.
struct Claim {
    path: String,
    key: String,
    span: Range<usize>,
}

struct Checker<'a> {
    text: &'a str,
    base_dir: &'a Path,
}

impl Checker<'_> {
    fn error(&self, key: &str, span: Range<usize>, message: impl Into<String>) -> ConfigError {
        let (line, column) = line_column(self.text, span.start);
        ConfigError {
            file: None,
            line: Some(line),
            column: Some(column),
            key: key.to_string(),
            message: message.into(),
        }
    }

    fn check(&self, raw: RawConfig) -> Result<VehicleConfig, ConfigError> {
        let mut claims = Vec::new();
        let data_dir = match &raw.vehicle.data_dir {
            Some(dir) => self.relative_path("vehicle.data_dir", dir)?,
            None => self.base_dir.join(DEFAULT_DATA_DIR),
        };
        let Some(gnss) = raw.gnss else {
            return Err(ConfigError {
                file: None,
                line: None,
                column: None,
                key: "gnss".to_string(),
                message: "missing section [gnss]: the vehicle needs a GNSS receiver (serial = … or tcp = …)"
                    .to_string(),
            });
        };
        let gnss = self.gnss(gnss, &mut claims)?;
        let heading = self.heading(raw.heading, &mut claims)?;
        let corrections = match raw.corrections {
            Some(c) => Corrections {
                mavlink: c.mavlink.unwrap_or(true),
                ntrip: c.ntrip.map(|n| self.ntrip(n)).transpose()?,
            },
            None => Corrections {
                mavlink: true,
                ntrip: None,
            },
        };
        let scanners = self.scanners(&raw.scanner)?;
        let magnetic = raw
            .magnetic
            .map(|m| self.serial_line("magnetic", &m.serial, Some(&m.baud), None, &mut claims))
            .transpose()?;
        let pwm = self.pwm(raw.pwm)?;
        let mut mavlink = Vec::new();
        let mut secure_mavlink = Vec::new();
        for (i, m) in raw.mavlink.iter().enumerate() {
            let endpoint = self.endpoint(&format!("mavlink[{i}].endpoint"), &m.endpoint, &mut claims)?;
            if m.secure == Some(true) {
                secure_mavlink.push(endpoint);
            } else {
                mavlink.push(endpoint);
            }
        }
        Ok(VehicleConfig {
            frame: raw.vehicle.frame,
            data_dir,
            gnss,
            heading,
            corrections,
            scanners,
            magnetic,
            pwm,
            mavlink,
            secure_mavlink,
        })
    }

    fn gnss(&self, gnss: Spanned<RawGnss>, claims: &mut Vec<Claim>) -> Result<GnssSettings, ConfigError> {
        let span = gnss.span();
        let gnss = gnss.into_inner();
        let link = match (&gnss.serial, &gnss.tcp) {
            (Some(serial), Some(tcp)) => {
                // Name whichever of the two comes second: that is the line to delete.
                let (key, later) = if tcp.span().start > serial.span().start {
                    ("gnss.tcp", tcp.span())
                } else {
                    ("gnss.serial", serial.span())
                };
                return Err(self.error(key, later, "give either serial or tcp, not both"));
            }
            (Some(serial), None) => GnssLink::Serial(self.serial_line(
                "gnss",
                serial,
                gnss.baud.as_ref(),
                Some(DEFAULT_GNSS_BAUD),
                claims,
            )?),
            (None, Some(tcp)) => {
                if let Some(baud) = &gnss.baud {
                    return Err(self.error("gnss.baud", baud.span(), "baud is for serial; a tcp source has none"));
                }
                GnssLink::Tcp(self.host_port("gnss.tcp", tcp)?)
            }
            (None, None) => {
                return Err(self.error(
                    "gnss",
                    span,
                    "no receiver: give serial = \"/dev/…\" (with baud) or tcp = \"HOST:PORT\"",
                ));
            }
        };
        let stale_ms = match &gnss.stale_ms {
            Some(ms) => self.int_in("gnss.stale_ms", ms, STALE_MS_RANGE)?,
            None => DEFAULT_GNSS_STALE_MS,
        };
        Ok(GnssSettings { link, stale_ms })
    }

    fn heading(&self, heading: Option<RawHeading>, claims: &mut Vec<Claim>) -> Result<HeadingSource, ConfigError> {
        let Some(heading) = heading else {
            return Ok(HeadingSource::Gnss);
        };
        match *heading.source.get_ref() {
            RawHeadingSource::Compass => {
                let Some(serial) = &heading.serial else {
                    return Err(self.error(
                        "heading.serial",
                        heading.source.span(),
                        "source = \"compass\" needs serial = \"/dev/…\" and baud",
                    ));
                };
                if heading.baud.is_none() {
                    return Err(self.error(
                        "heading.baud",
                        heading.source.span(),
                        "source = \"compass\" needs the compass's baud rate (often 4800 or 9600)",
                    ));
                }
                Ok(HeadingSource::Compass(self.serial_line(
                    "heading",
                    serial,
                    heading.baud.as_ref(),
                    None,
                    claims,
                )?))
            }
            source => {
                if let Some(serial) = &heading.serial {
                    return Err(self.error("heading.serial", serial.span(), "only with source = \"compass\""));
                }
                if let Some(baud) = &heading.baud {
                    return Err(self.error("heading.baud", baud.span(), "only with source = \"compass\""));
                }
                Ok(match source {
                    RawHeadingSource::Gnss => HeadingSource::Gnss,
                    _ => HeadingSource::None,
                })
            }
        }
    }

    fn ntrip(&self, ntrip: RawNtrip) -> Result<NtripSettings, ConfigError> {
        let host = ntrip.host.get_ref();
        if host.contains("://") {
            return Err(self.error(
                "corrections.ntrip.host",
                ntrip.host.span(),
                "a host name without scheme (caster.example.com, not http://…)",
            ));
        }
        check_host(host).map_err(|e| self.error("corrections.ntrip.host", ntrip.host.span(), e))?;
        let port = match &ntrip.port {
            Some(port) => self.int_in("corrections.ntrip.port", port, 1..=65_535)?,
            None => DEFAULT_NTRIP_PORT,
        };
        let mountpoint = ntrip.mountpoint.get_ref();
        let bad_mountpoint = if mountpoint.is_empty() {
            Some("empty mountpoint")
        } else if mountpoint.starts_with('/') {
            Some("write the mountpoint without the leading '/'")
        } else if mountpoint
            .chars()
            .any(|c| c.is_whitespace() || c.is_control() || c == '/')
        {
            Some("a mountpoint has no spaces or '/'")
        } else {
            None
        };
        if let Some(why) = bad_mountpoint {
            return Err(self.error("corrections.ntrip.mountpoint", ntrip.mountpoint.span(), why));
        }
        if let Some(user) = &ntrip.user
            && (user.get_ref().is_empty() || user.get_ref().contains(':'))
        {
            return Err(self.error(
                "corrections.ntrip.user",
                user.span(),
                "a user name is non-empty and has no ':' (HTTP Basic auth)",
            ));
        }
        if let (Some(password), None) = (&ntrip.password, &ntrip.user) {
            return Err(self.error(
                "corrections.ntrip.password",
                password.span(),
                "a password without a user; add user = \"…\"",
            ));
        }
        let version = match &ntrip.version {
            None => NtripVersion::V2,
            Some(v) => match *v.get_ref() {
                1 => NtripVersion::V1,
                2 => NtripVersion::V2,
                other => {
                    return Err(self.error(
                        "corrections.ntrip.version",
                        v.span(),
                        format!("{other} is not an NTRIP version: 1 or 2"),
                    ));
                }
            },
        };
        let gga_interval_s = match &ntrip.gga_interval_s {
            Some(s) => self.int_in("corrections.ntrip.gga_interval_s", s, GGA_INTERVAL_S_RANGE)?,
            None => DEFAULT_GGA_INTERVAL_S,
        };
        Ok(NtripSettings {
            host: host.clone(),
            port,
            mountpoint: mountpoint.clone(),
            user: ntrip.user.map(Spanned::into_inner),
            password: ntrip.password.map(Spanned::into_inner),
            version,
            gga_interval_s,
        })
    }

    fn scanners(&self, scanners: &[RawScanner]) -> Result<Vec<HostPort>, ConfigError> {
        let mut out: Vec<HostPort> = Vec::new();
        for (i, scanner) in scanners.iter().enumerate() {
            let key = format!("scanner[{i}].address");
            if i >= MAX_SCANNERS {
                return Err(self.error(
                    &key,
                    scanner.address.span(),
                    format!("at most {MAX_SCANNERS} scanners (SCAN1 front, SCAN2)"),
                ));
            }
            let address = self.host_port(&key, &scanner.address)?;
            if let Some(first) = out.iter().position(|a| *a == address) {
                return Err(self.error(
                    &key,
                    scanner.address.span(),
                    format!("{address} is already scanner[{first}]"),
                ));
            }
            out.push(address);
        }
        Ok(out)
    }

    fn pwm(&self, pwm: Option<RawPwm>) -> Result<PwmSettings, ConfigError> {
        let Some(pwm) = pwm else {
            return Ok(PwmSettings {
                root: PathBuf::from(DEFAULT_PWM_ROOT),
                period_us: DEFAULT_PWM_PERIOD_US,
                outputs: Vec::new(),
            });
        };
        let root = match &pwm.root {
            Some(root) => self.relative_path("pwm.root", root)?,
            None => PathBuf::from(DEFAULT_PWM_ROOT),
        };
        let period_us = match &pwm.period_us {
            Some(p) => self.int_in("pwm.period_us", p, PWM_PERIOD_US_RANGE)?,
            None => DEFAULT_PWM_PERIOD_US,
        };
        let mut outputs: Vec<PwmOutputSetting> = Vec::new();
        for (i, raw) in pwm.output.iter().enumerate() {
            let servo_key = format!("pwm.output[{i}].servo");
            let channel_key = format!("pwm.output[{i}].channel");
            let output = PwmOutputSetting {
                servo: self.int_in(&servo_key, &raw.servo, 1..=i64::from(SERVO_CHANNELS))?,
                chip: self.int_in(&format!("pwm.output[{i}].chip"), &raw.chip, PWM_INDEX_RANGE)?,
                channel: self.int_in(&channel_key, &raw.channel, PWM_INDEX_RANGE)?,
            };
            if let Some(first) = outputs.iter().position(|o| o.servo == output.servo) {
                return Err(self.error(
                    &servo_key,
                    raw.servo.span(),
                    format!("SERVO{} already goes out on pwm.output[{first}]", output.servo),
                ));
            }
            if let Some(first) = outputs
                .iter()
                .position(|o| (o.chip, o.channel) == (output.chip, output.channel))
            {
                return Err(self.error(
                    &channel_key,
                    raw.channel.span(),
                    format!(
                        "pwmchip{}/pwm{} is already used by pwm.output[{first}]",
                        output.chip, output.channel
                    ),
                ));
            }
            outputs.push(output);
        }
        Ok(PwmSettings {
            root,
            period_us,
            outputs,
        })
    }

    fn endpoint(&self, key: &str, spec: &Spanned<String>, claims: &mut Vec<Claim>) -> Result<Endpoint, ConfigError> {
        let endpoint: Endpoint = spec
            .get_ref()
            .parse()
            .map_err(|e: String| self.error(key, spec.span(), e))?;
        if let Endpoint::Serial { device, baud } = &endpoint {
            self.device_path(key, spec.span(), device, claims)?;
            check_baud(*baud).map_err(|e| self.error(key, spec.span(), e))?;
        }
        Ok(endpoint)
    }

    /// `section.serial` + `section.baud`.
    fn serial_line(
        &self,
        section: &str,
        serial: &Spanned<String>,
        baud: Option<&Spanned<i64>>,
        default_baud: Option<u32>,
        claims: &mut Vec<Claim>,
    ) -> Result<SerialLine, ConfigError> {
        let serial_key = format!("{section}.serial");
        self.device_path(&serial_key, serial.span(), serial.get_ref(), claims)?;
        let baud_key = format!("{section}.baud");
        let baud = match (baud, default_baud) {
            (Some(b), _) => {
                let value = u32::try_from(*b.get_ref()).unwrap_or(0);
                check_baud(value).map_err(|_| {
                    self.error(
                        &baud_key,
                        b.span(),
                        format!("{} is not a standard baud rate ({})", b.get_ref(), baud_list()),
                    )
                })?;
                value
            }
            (None, Some(default)) => default,
            (None, None) => return Err(self.error(&baud_key, serial.span(), "missing baud for this serial port")),
        };
        Ok(SerialLine {
            path: PathBuf::from(serial.get_ref()),
            baud,
        })
    }

    fn device_path(
        &self,
        key: &str,
        span: Range<usize>,
        path: &str,
        claims: &mut Vec<Claim>,
    ) -> Result<(), ConfigError> {
        if path.is_empty() {
            return Err(self.error(key, span, "empty device path"));
        }
        if path.contains('\0') {
            return Err(self.error(key, span, "a path cannot hold a NUL character"));
        }
        if !path.starts_with('/') {
            return Err(self.error(
                key,
                span,
                format!("device path {path:?} is not absolute (/dev/ttyUSB0, /dev/serial/by-id/…)"),
            ));
        }
        if let Some(other) = claims.iter().find(|c| c.path == path) {
            // Sections are checked in a fixed order, not file order: blame
            // whichever of the two comes later in the file.
            let (blamed_key, blamed_span, first_key, first_span) = if other.span.start < span.start {
                (key, span, other.key.as_str(), other.span.clone())
            } else {
                (other.key.as_str(), other.span.clone(), key, span)
            };
            let first_line = line_column(self.text, first_span.start).0;
            return Err(self.error(
                blamed_key,
                blamed_span,
                format!("{path} is already used by {first_key} (line {first_line})"),
            ));
        }
        claims.push(Claim {
            path: path.to_string(),
            key: key.to_string(),
            span,
        });
        Ok(())
    }

    fn host_port(&self, key: &str, text: &Spanned<String>) -> Result<HostPort, ConfigError> {
        HostPort::parse(text.get_ref()).map_err(|e| self.error(key, text.span(), e))
    }

    fn relative_path(&self, key: &str, text: &Spanned<String>) -> Result<PathBuf, ConfigError> {
        if text.get_ref().is_empty() {
            return Err(self.error(key, text.span(), "empty path"));
        }
        // The OS takes a path as a C string: a NUL would cut it short or fail
        // at the first file operation, long after the check said yes.
        if text.get_ref().contains('\0') {
            return Err(self.error(key, text.span(), "a path cannot hold a NUL character"));
        }
        Ok(self.base_dir.join(text.get_ref()))
    }

    fn int_in<T: TryFrom<i64>>(
        &self,
        key: &str,
        value: &Spanned<i64>,
        range: RangeInclusive<i64>,
    ) -> Result<T, ConfigError> {
        let v = *value.get_ref();
        let out_of_range = || {
            self.error(
                key,
                value.span(),
                format!("{v} is out of range {}..={}", range.start(), range.end()),
            )
        };
        if !range.contains(&v) {
            return Err(out_of_range());
        }
        T::try_from(v).map_err(|_| out_of_range())
    }
}

fn check_baud(baud: u32) -> Result<(), String> {
    if BAUD_RATES.contains(&baud) {
        Ok(())
    } else {
        Err(format!("baud {baud} is not a standard rate ({})", baud_list()))
    }
}

fn baud_list() -> String {
    BAUD_RATES.map(|b| b.to_string()).join(", ")
}

fn check_host(host: &str) -> Result<(), String> {
    if host.is_empty() {
        Err("empty host".to_string())
    } else if host.chars().any(|c| c.is_whitespace() || c.is_control() || c == '/') {
        Err(format!("{host:?} is not a host name or address"))
    } else {
        Ok(())
    }
}

/// 1-based line and column (in characters) of a byte offset.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = text.get(..offset).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before.get(line_start..).map_or(0, |s| s.chars().count()) + 1;
    (line, column)
}

/// Turns a toml/serde error into one that names the key: the error's span is
/// looked up in the document's syntax tree.
fn from_toml_error(text: &str, error: &toml::de::Error) -> ConfigError {
    let message = error.message().trim().to_string();
    let Some(span) = error.span() else {
        return ConfigError {
            file: None,
            line: None,
            column: None,
            key: String::new(),
            message,
        };
    };
    let missing = message
        .strip_prefix("missing field `")
        .and_then(|rest| rest.strip_suffix('`'))
        .map(str::to_string);
    let mut key = match DeTable::parse(text) {
        // A missing key's span is its table's header (or 0..0 for the root),
        // which only an exact match finds.
        Ok(root) => key_path(root.get_ref(), &span, missing.is_none()).unwrap_or_default(),
        // Syntax errors (and duplicate keys) leave no tree to look in.
        Err(_) => key_from_lines(text, span.start),
    };
    if let Some(field) = &missing {
        key = if key.is_empty() {
            field.clone()
        } else {
            format!("{key}.{field}")
        };
    }
    // Every root key is a section; a missing one has no line of its own.
    if let Some(field) = missing.filter(|_| !key.contains('.')) {
        return ConfigError {
            file: None,
            line: None,
            column: None,
            key,
            message: format!("missing section [{field}]"),
        };
    }
    let (line, column) = line_column(text, span.start);
    ConfigError {
        file: None,
        line: Some(line),
        column: Some(column),
        key,
        message: plain_types(&message),
    }
}

/// A best guess at the key of a line that does not parse: the text before
/// `=` on the error's line, under the nearest `[table]` header above it.
fn key_from_lines(text: &str, offset: usize) -> String {
    let before = text.get(..offset.min(text.len())).unwrap_or(text);
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let line = text
        .get(line_start..)
        .unwrap_or_default()
        .lines()
        .next()
        .unwrap_or_default();
    let header = |l: &str| {
        let l = l.trim();
        l.starts_with('[').then(|| {
            let name = l.split(']').next().unwrap_or_default();
            name.trim_start_matches('[').trim().to_string()
        })
    };
    if let Some(name) = header(line) {
        return name;
    }
    let table = text
        .get(..line_start)
        .unwrap_or_default()
        .lines()
        .rev()
        .find_map(header)
        .unwrap_or_default();
    let key = line
        .split_once('=')
        .map(|(k, _)| k.trim())
        .filter(|k| !k.is_empty() && k.chars().all(|c| c.is_ascii_alphanumeric() || "_-.\"' ".contains(c)))
        .unwrap_or_default();
    match (table.is_empty(), key.is_empty()) {
        (_, true) => table,
        (true, false) => key.to_string(),
        (false, false) => format!("{table}.{key}"),
    }
}

/// serde names Rust types; a config user thinks in TOML's.
fn plain_types(message: &str) -> String {
    message
        .replace("missing field", "missing key")
        .replace("unknown field", "unknown key")
        .replace("expected i64", "expected an integer")
        .replace("expected a boolean", "expected true or false")
}

#[derive(Clone)]
enum Segment {
    Key(String),
    Index(usize),
}

fn render(path: &[Segment]) -> String {
    let mut out = String::new();
    for segment in path {
        match segment {
            Segment::Key(k) => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(k);
            }
            Segment::Index(i) => out.push_str(&format!("[{i}]")),
        }
    }
    out
}

/// The dotted path of the key or value whose span is `span`; failing an
/// exact match, of the innermost value containing it.
fn key_path(root: &DeTable<'_>, span: &Range<usize>, or_containing: bool) -> Option<String> {
    let mut path = Vec::new();
    if find_in_table(root, span, true, &mut path) || (or_containing && find_in_table(root, span, false, &mut path)) {
        Some(render(&path))
    } else {
        None
    }
}

fn matches(candidate: &Range<usize>, span: &Range<usize>, exact: bool) -> bool {
    if exact {
        candidate == span
    } else {
        candidate.start <= span.start && span.end <= candidate.end && candidate.start < candidate.end
    }
}

fn find_in_table(table: &DeTable<'_>, span: &Range<usize>, exact: bool, path: &mut Vec<Segment>) -> bool {
    for (key, value) in table.iter() {
        path.push(Segment::Key(key.get_ref().to_string()));
        if exact && key.span() == *span {
            return true;
        }
        // Children first: a table made implicitly by `[a.b]` shares its
        // header's span with `a.b`, and the deeper name is the useful one.
        if find_in_value(value.get_ref(), span, exact, path) || matches(&value.span(), span, exact) {
            return true;
        }
        path.pop();
    }
    false
}

fn find_in_value(value: &DeValue<'_>, span: &Range<usize>, exact: bool, path: &mut Vec<Segment>) -> bool {
    match value {
        DeValue::Table(table) => find_in_table(table, span, exact, path),
        DeValue::Array(items) => {
            for (i, item) in items.iter().enumerate() {
                path.push(Segment::Index(i));
                if find_in_value(item.get_ref(), span, exact, path) || matches(&item.span(), span, exact) {
                    return true;
                }
                path.pop();
            }
            false
        }
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_nul_in_any_path_is_refused() {
        let base = "[vehicle]\nframe = \"ackermann\"\n[gnss]\nserial = \"/dev/ttyUSB0\"\n";
        let with_dir = base.replace(
            "frame = \"ackermann\"\n",
            "frame = \"ackermann\"\ndata_dir = \"data\\u0000x\"\n",
        );
        let e = parse(&with_dir, Path::new("/")).unwrap_err().to_string();
        assert!(e.contains("NUL") && e.contains("data_dir"), "{e}");
        let device = base.replace("/dev/ttyUSB0", "/dev/tty\\u0000USB0");
        let e = parse(&device, Path::new("/")).unwrap_err().to_string();
        assert!(e.contains("NUL"), "{e}");
        assert!(parse(base, Path::new("/")).is_ok());
    }

    #[test]
    fn secure_endpoints_are_kept_apart() {
        let text = "[vehicle]\nframe = \"ackermann\"\n[gnss]\nserial = \"/dev/ttyUSB0\"\n\
                    [[mavlink]]\nendpoint = \"tcpin:0.0.0.0:5760\"\n\
                    [[mavlink]]\nendpoint = \"serial:/dev/ttyACM0:115200\"\nsecure = true\n\
                    [[mavlink]]\nendpoint = \"udp:10.0.0.1:14550\"\nsecure = false\n";
        let config = parse(text, Path::new("/")).expect("parses");
        assert_eq!(config.mavlink.len(), 2);
        assert_eq!(
            config.secure_mavlink,
            vec![Endpoint::Serial {
                device: "/dev/ttyACM0".into(),
                baud: 115_200
            }]
        );
        assert!(config.summary().contains("serial:/dev/ttyACM0:115200 (secure"));
        let typo = text.replace("secure = true", "secure = \"yes\"");
        assert!(parse(&typo, Path::new("/")).is_err());
    }

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

    #[test]
    fn line_column_counts_characters() {
        let text = "a = 1\nbé = \"x\"\n";
        assert_eq!(line_column(text, 0), (1, 1));
        let x = text.find('"').unwrap_or_default();
        assert_eq!(line_column(text, x), (2, 6));
        assert_eq!(line_column(text, text.len() + 10), (3, 1));
    }
}
