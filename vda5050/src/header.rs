//! The header every VDA 5050 message starts with (§6.5).

use serde::{Deserialize, Serialize};

/// The protocol version Furrow speaks, as sent in every header's `version`.
pub const PROTOCOL_VERSION: &str = "2.1.0";

/// Header fields shared by all messages. Flattened into each message.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct Header {
    /// Per topic and sender, incremented by one with each message.
    pub header_id: u32,
    /// ISO 8601 UTC, e.g. `2017-04-15T11:40:03.12Z`.
    pub timestamp: String,
    /// Protocol version `major.minor.patch`.
    pub version: String,
    pub manufacturer: String,
    pub serial_number: String,
}

impl Header {
    /// A header for a message Furrow sends, stamped with the injected time.
    pub fn new(header_id: u32, unix_ms: u64, manufacturer: &str, serial_number: &str) -> Self {
        Self {
            header_id,
            timestamp: timestamp_from_unix_ms(unix_ms),
            version: PROTOCOL_VERSION.to_owned(),
            manufacturer: manufacturer.to_owned(),
            serial_number: serial_number.to_owned(),
        }
    }
}

/// ISO 8601 UTC with milliseconds and a `Z`, the form §6.5 shows.
pub fn timestamp_from_unix_ms(unix_ms: u64) -> String {
    let ms = i64::try_from(unix_ms).unwrap_or(i64::MAX);
    let time = chrono::DateTime::from_timestamp_millis(ms).unwrap_or_default();
    time.to_rfc3339_opts(chrono::SecondsFormat::Millis, true)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timestamp_is_iso8601_utc_with_millis() {
        assert_eq!(timestamp_from_unix_ms(0), "1970-01-01T00:00:00.000Z");
        assert_eq!(timestamp_from_unix_ms(1_492_256_403_120), "2017-04-15T11:40:03.120Z");
    }
}
