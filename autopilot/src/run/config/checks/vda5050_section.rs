//! The `[vda5050]` section: the broker and how to reach it (TLS files,
//! credentials), who this vehicle is on it (topic levels, client id), its
//! map, message rates, and the actions mapped to outputs.

use std::ops::RangeInclusive;

use serde::Deserialize;
use toml::Spanned;

use super::Checker;
use crate::control::servo::RELAYS;
use crate::edge::mqtt::{BrokerUrl, parse_broker_url};
use crate::edge::mqtt_tls::{TlsFile, TlsFiles, client_config};
use crate::fleet::AgentConfig;
use crate::fleet::actions::{ActionMapping, ActionOutput, default_mappings};
use crate::fleet::agent::INSTANT_ACTIONS;
use crate::geo::GeoPoint;
use crate::run::config::error::ConfigError;
use crate::run::config::types::{SERVO_CHANNELS, Vda5050Settings};

/// The standard's limit for a state while nothing happens (§6.10).
const STATE_INTERVAL_S_RANGE: RangeInclusive<f64> = 0.05..=30.0;
/// 0 sends no visualization.
const VISUALIZATION_INTERVAL_S_RANGE: RangeInclusive<f64> = 0.0..=60.0;
const PWM_US_RANGE: RangeInclusive<i64> = 500..=2500;
const ACTION_DURATION_S_RANGE: RangeInclusive<f64> = 0.0..=600.0;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawVda5050 {
    broker: Spanned<String>,
    ca_file: Option<Spanned<String>>,
    client_cert: Option<Spanned<String>>,
    client_key: Option<Spanned<String>>,
    username: Option<Spanned<String>>,
    password: Option<Spanned<String>>,
    client_id: Option<Spanned<String>>,
    interface_name: Option<Spanned<String>>,
    manufacturer: Option<Spanned<String>>,
    serial_number: Spanned<String>,
    map_id: Option<Spanned<String>>,
    map_version: Option<Spanned<String>>,
    map_origin: Option<Spanned<Vec<f64>>>,
    state_interval_s: Option<Spanned<f64>>,
    state_idle_interval_s: Option<Spanned<f64>>,
    visualization_interval_s: Option<Spanned<f64>>,
    #[serde(default)]
    action: Vec<RawAction>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAction {
    #[serde(rename = "type")]
    action_type: Spanned<String>,
    servo: Option<Spanned<i64>>,
    pwm_us: Option<Spanned<i64>>,
    relay: Option<Spanned<i64>>,
    on: Option<Spanned<bool>>,
    duration_s: Spanned<f64>,
}

impl Checker<'_> {
    pub(super) fn vda5050(&self, raw: RawVda5050) -> Result<Vda5050Settings, ConfigError> {
        let broker =
            parse_broker_url(raw.broker.get_ref()).map_err(|e| self.error("vda5050.broker", raw.broker.span(), e))?;
        let tls = self.tls_files(&raw, &broker)?;
        let credentials = self.credentials(&raw)?;
        let text = |key: &str, value: &Option<Spanned<String>>, default: &str| match value {
            Some(v) if v.get_ref().is_empty() => Err(self.error(key, v.span(), "cannot be empty")),
            Some(v) => Ok(v.get_ref().clone()),
            None => Ok(default.to_owned()),
        };
        let interface = text("vda5050.interface_name", &raw.interface_name, "uagv")?;
        let manufacturer = text("vda5050.manufacturer", &raw.manufacturer, "Furrow")?;
        let serial = raw.serial_number.get_ref();
        let prefix = vda5050::TopicPrefix::new(&interface, "v2", &manufacturer, serial).map_err(|e| {
            let (key, span) = match e.level {
                "interfaceName" => ("vda5050.interface_name", raw.interface_name.as_ref().map(Spanned::span)),
                "manufacturer" => ("vda5050.manufacturer", raw.manufacturer.as_ref().map(Spanned::span)),
                _ => ("vda5050.serial_number", Some(raw.serial_number.span())),
            };
            self.error(key, span.unwrap_or(raw.broker.span()), e.to_string())
        })?;
        let client_id = text("vda5050.client_id", &raw.client_id, &format!("{manufacturer}-{serial}"))?;
        let defaults = AgentConfig::default();
        let interval = |key, value: &Option<Spanned<f64>>, range, default| match value {
            Some(v) => self.float_in(key, v, range),
            None => Ok(default),
        };
        let agent = AgentConfig {
            map_id: text("vda5050.map_id", &raw.map_id, &defaults.map_id)?,
            map_version: text("vda5050.map_version", &raw.map_version, &defaults.map_version)?,
            map_origin: self.map_origin(&raw.map_origin)?,
            mappings: self.action_mappings(&raw.action)?,
            state_interval_driving_s: interval(
                "vda5050.state_interval_s",
                &raw.state_interval_s,
                STATE_INTERVAL_S_RANGE,
                defaults.state_interval_driving_s,
            )?,
            state_interval_idle_s: interval(
                "vda5050.state_idle_interval_s",
                &raw.state_idle_interval_s,
                STATE_INTERVAL_S_RANGE,
                defaults.state_interval_idle_s,
            )?,
            visualization_interval_s: interval(
                "vda5050.visualization_interval_s",
                &raw.visualization_interval_s,
                VISUALIZATION_INTERVAL_S_RANGE,
                defaults.visualization_interval_s,
            )?,
        };
        Ok(Vda5050Settings {
            broker,
            tls,
            credentials,
            client_id,
            prefix,
            agent,
        })
    }

    /// `map_origin = [LAT, LON]`: the map frame's fixed origin (degrees).
    fn map_origin(&self, value: &Option<Spanned<Vec<f64>>>) -> Result<Option<GeoPoint>, ConfigError> {
        let Some(value) = value else {
            return Ok(None);
        };
        let key = "vda5050.map_origin";
        match value.get_ref()[..] {
            [lat_deg, lon_deg] if lat_deg.abs() <= 90.0 && lon_deg.abs() <= 180.0 => Ok(Some(GeoPoint {
                lat_deg,
                lon_deg,
                alt_m: 0.0,
            })),
            _ => Err(self.error(
                key,
                value.span(),
                "expected [LAT, LON] in degrees, latitude within ±90 and longitude within ±180",
            )),
        }
    }

    /// The TLS files (relative to the config file), read and checked now.
    fn tls_files(&self, raw: &RawVda5050, broker: &BrokerUrl) -> Result<TlsFiles, ConfigError> {
        let keys = [
            ("vda5050.ca_file", &raw.ca_file),
            ("vda5050.client_cert", &raw.client_cert),
            ("vda5050.client_key", &raw.client_key),
        ];
        if !broker.tls
            && let Some((key, value)) = keys.iter().find_map(|(k, v)| v.as_ref().map(|v| (k, v)))
        {
            return Err(self.error(key, value.span(), "TLS files are for an mqtts:// broker"));
        }
        match (&raw.client_cert, &raw.client_key) {
            (Some(cert), None) => {
                return Err(self.error("vda5050.client_key", cert.span(), "client_cert needs client_key"));
            }
            (None, Some(key)) => {
                return Err(self.error("vda5050.client_cert", key.span(), "client_key needs client_cert"));
            }
            _ => {}
        }
        let path =
            |key, value: &Option<Spanned<String>>| value.as_ref().map(|v| self.relative_path(key, v)).transpose();
        let files = TlsFiles {
            ca_file: path("vda5050.ca_file", &raw.ca_file)?,
            client_auth: path("vda5050.client_cert", &raw.client_cert)?
                .zip(path("vda5050.client_key", &raw.client_key)?),
        };
        if broker.tls
            && let Err(e) = client_config(&files)
        {
            let (key, value) = match e.file {
                TlsFile::Ca => ("vda5050.ca_file", &raw.ca_file),
                TlsFile::ClientCert => ("vda5050.client_cert", &raw.client_cert),
                TlsFile::ClientKey => ("vda5050.client_key", &raw.client_key),
            };
            let (key, span) = match value {
                Some(v) => (key, v.span()),
                None => ("vda5050.broker", raw.broker.span()),
            };
            return Err(self.error(key, span, e.message));
        }
        Ok(files)
    }

    fn credentials(&self, raw: &RawVda5050) -> Result<Option<(String, String)>, ConfigError> {
        match (&raw.username, &raw.password) {
            (None, Some(password)) => Err(self.error(
                "vda5050.password",
                password.span(),
                "a password without a user; add username = \"…\"",
            )),
            (Some(user), _) if user.get_ref().is_empty() => {
                Err(self.error("vda5050.username", user.span(), "cannot be empty"))
            }
            (Some(user), password) => Ok(Some((
                user.get_ref().clone(),
                password.as_ref().map(|p| p.get_ref().clone()).unwrap_or_default(),
            ))),
            (None, None) => Ok(None),
        }
    }

    /// `[[vda5050.action]]`: each replaces the default mapping of its type.
    fn action_mappings(&self, raw: &[RawAction]) -> Result<Vec<ActionMapping>, ConfigError> {
        let mut mappings: Vec<ActionMapping> = Vec::new();
        for (i, action) in raw.iter().enumerate() {
            let key = |name: &str| format!("vda5050.action[{i}].{name}");
            let kind = action.action_type.get_ref();
            let type_error = |message: String| self.error(&key("type"), action.action_type.span(), message);
            if kind.is_empty() {
                return Err(type_error("cannot be empty".into()));
            }
            if INSTANT_ACTIONS.contains(&kind.as_str()) {
                return Err(type_error(format!("{kind} is carried out by the vehicle itself")));
            }
            if let Some(first) = mappings.iter().position(|m| m.action_type == *kind) {
                return Err(type_error(format!("{kind} is already vda5050.action[{first}]")));
            }
            mappings.push(ActionMapping {
                action_type: kind.clone(),
                output: self.action_output(action, &key)?,
                duration_s: self.float_in(&key("duration_s"), &action.duration_s, ACTION_DURATION_S_RANGE)?,
            });
        }
        for default in default_mappings() {
            if !mappings.iter().any(|m| m.action_type == default.action_type) {
                mappings.push(default);
            }
        }
        Ok(mappings)
    }

    fn action_output(&self, action: &RawAction, key: &dyn Fn(&str) -> String) -> Result<ActionOutput, ConfigError> {
        let span = action.action_type.span();
        match (&action.servo, &action.pwm_us, &action.relay, &action.on) {
            (Some(servo), Some(pwm), None, None) => Ok(ActionOutput::Servo {
                channel: self.int_in(&key("servo"), servo, 1..=i64::from(SERVO_CHANNELS))?,
                pwm_us: self.int_in(&key("pwm_us"), pwm, PWM_US_RANGE)?,
            }),
            (None, None, Some(relay), Some(on)) => Ok(ActionOutput::Relay {
                relay: self.int_in(&key("relay"), relay, 0..=(RELAYS as i64 - 1))?,
                on: *on.get_ref(),
            }),
            (_, _, Some(relay), _) if action.servo.is_some() || action.pwm_us.is_some() => Err(self.error(
                &key("relay"),
                relay.span(),
                "give either servo and pwm_us or relay and on, not both",
            )),
            (Some(servo), None, _, _) => Err(self.error(&key("pwm_us"), servo.span(), "servo needs pwm_us")),
            (None, Some(pwm), _, _) => Err(self.error(&key("servo"), pwm.span(), "pwm_us needs servo")),
            (_, _, Some(relay), None) => Err(self.error(&key("on"), relay.span(), "relay needs on = true or false")),
            (_, _, None, Some(on)) => Err(self.error(&key("relay"), on.span(), "on needs relay")),
            _ => Err(self.error(
                &key("type"),
                span,
                "give servo and pwm_us (DO_SET_SERVO) or relay and on (DO_SET_RELAY)",
            )),
        }
    }

    fn float_in(&self, key: &str, value: &Spanned<f64>, range: RangeInclusive<f64>) -> Result<f64, ConfigError> {
        let v = *value.get_ref();
        if v.is_finite() && range.contains(&v) {
            Ok(v)
        } else {
            Err(self.error(
                key,
                value.span(),
                format!("{v} is out of range {}..={}", range.start(), range.end()),
            ))
        }
    }
}
