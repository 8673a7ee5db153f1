//! The configuration file as written, spans kept, and the checks that turn
//! it into [`VehicleConfig`]: every error names its key and place.

mod vda5050_section;

use std::ops::{Range, RangeInclusive};
use std::path::{Path, PathBuf};
use std::time::Duration;

use drivers::ntrip::{NtripConfig, NtripVersion};
use serde::Deserialize;
use toml::Spanned;

use super::error::ConfigError;
use super::types::*;
use crate::link::endpoint::Endpoint;

const STALE_MS_RANGE: RangeInclusive<i64> = 100..=60_000;
const GGA_INTERVAL_S_RANGE: RangeInclusive<i64> = 0..=3600;
// Above the longest servo pulse (2200 µs) and up to 10 Hz frames.
const PWM_PERIOD_US_RANGE: RangeInclusive<i64> = 2500..=100_000;
const PWM_INDEX_RANGE: RangeInclusive<i64> = 0..=65_535;

/// Parses and checks config text; relative paths are resolved against `base_dir`.
pub(super) fn check(text: &str, base_dir: &Path) -> Result<VehicleConfig, ConfigError> {
    let raw: RawConfig = toml::from_str(text).map_err(|e| ConfigError::from_toml(text, &e))?;
    Checker { text, base_dir }.check(raw)
}

// Numbers are read as i64 so that range errors use this module's wording
// ("baud 11520 is not …") rather than serde's type names.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawConfig {
    vehicle: Option<RawVehicle>,
    gnss: Option<Spanned<RawGnss>>,
    heading: Option<RawHeading>,
    corrections: Option<RawCorrections>,
    #[serde(default)]
    scanner: Vec<RawScanner>,
    magnetic: Option<RawSerial>,
    imu: Option<RawSerial>,
    pwm: Option<RawPwm>,
    #[serde(default)]
    mavlink: Vec<RawMavlink>,
    vda5050: Option<vda5050_section::RawVda5050>,
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
        ConfigError::at(self.text, key, span, message)
    }

    fn check(&self, raw: RawConfig) -> Result<VehicleConfig, ConfigError> {
        let mut claims = Vec::new();
        // Sections are optional to serde so that a missing one is reported
        // here, by name, rather than read out of serde's message.
        let Some(vehicle) = raw.vehicle else {
            return Err(ConfigError::whole_file("vehicle", "missing section [vehicle]"));
        };
        let data_dir = match &vehicle.data_dir {
            Some(dir) => self.relative_path("vehicle.data_dir", dir)?,
            None => self.base_dir.join(DEFAULT_DATA_DIR),
        };
        let Some(gnss) = raw.gnss else {
            return Err(ConfigError::whole_file(
                "gnss",
                "missing section [gnss]: the vehicle needs a GNSS receiver (serial = … or tcp = …)",
            ));
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
        let imu = raw
            .imu
            .map(|m| self.serial_line("imu", &m.serial, Some(&m.baud), None, &mut claims))
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
        let vda5050 = raw.vda5050.map(|v| self.vda5050(v)).transpose()?;
        Ok(VehicleConfig {
            frame: vehicle.frame,
            data_dir,
            gnss,
            heading,
            corrections,
            scanners,
            magnetic,
            imu,
            pwm,
            mavlink,
            secure_mavlink,
            vda5050,
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

    fn ntrip(&self, ntrip: RawNtrip) -> Result<NtripConfig, ConfigError> {
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
        Ok(NtripConfig {
            host: host.clone(),
            port,
            mountpoint: mountpoint.clone(),
            user: ntrip.user.map(Spanned::into_inner),
            password: ntrip.password.map(Spanned::into_inner),
            version,
            gga_interval: Duration::from_secs(u64::from(gga_interval_s)),
            ..NtripConfig::default()
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
            let first_line = toml_report::place(self.text, first_span.start).line;
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
