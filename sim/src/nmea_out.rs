//! NMEA 0183 output of the simulated receiver: GGA, RMC, GST, HDT per epoch,
//! formatted like a high-precision RTK receiver (7 decimals of arc minutes,
//! ≈ 0.2 mm) and kept within 82 characters per sentence.

use std::fmt;
use std::io::{self, Write as _};

use chrono::{DateTime, Datelike};

use super::GeoPoint;
use drivers::fixed_decimal::FixedDecimal;
use drivers::gnss::{FixQuality, nmea_checksum};

const KNOTS_PER_MPS: f64 = 3600.0 / 1852.0;
const US_PER_DAY: i64 = 86_400_000_000;
/// Units of 1e-7 arc minute per degree.
const TICKS_PER_DEG: u64 = 600_000_000;
const TICKS_PER_MIN: u64 = 10_000_000;

/// Everything one receiver epoch reports.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct EpochReport {
    pub utc_unix_us: i64,
    pub quality: FixQuality,
    /// Antenna position as measured (with noise).
    pub position: GeoPoint,
    pub satellites: u8,
    pub hdop: f32,
    pub speed_mps: f64,
    /// Direction of motion; `None` when nearly stationary.
    pub course_deg: Option<f64>,
    pub sigma_horizontal_m: f64,
    pub sigma_alt_m: f64,
    pub heading_deg: Option<f64>,
}

/// Appends the epoch's sentences to `out`, each ending in CR LF. Formats
/// straight into `out`: nothing is allocated once it has grown.
pub(crate) fn write_epoch(talker: &str, report: &EpochReport, out: &mut Vec<u8>) {
    let talker = if talker.len() == 2 && talker.bytes().all(|b| b.is_ascii_alphanumeric()) {
        talker
    } else {
        "GN"
    };
    let (time, date) = utc_fields(report.utc_unix_us);
    let has_fix = report.quality != FixQuality::NoFix;
    let (lat, lon) = (
        Shown(has_fix.then(|| coordinate(report.position.lat_deg, 2, ['N', 'S']))),
        Shown(has_fix.then(|| coordinate(report.position.lon_deg, 3, ['E', 'W']))),
    );
    // Without a fix each coordinate is two empty fields.
    let no_fix = if has_fix { "" } else { "," };
    let hdop = Shown(
        report
            .hdop
            .is_finite()
            .then_some(FixedDecimal::new(f64::from(report.hdop), 1)),
    );
    let alt = Shown(has_fix.then_some(FixedDecimal::new(report.position.alt_m, 3)));
    sentence(talker, "GGA", out, |w| {
        write!(
            w,
            "{time},{lat}{no_fix},{lon}{no_fix},{},{:02},{hdop},{alt},M,0.0,M,,",
            report.quality.gga_digit(),
            report.satellites,
        )
    });

    if has_fix {
        let course = Shown(report.course_deg.map(milli_degrees));
        sentence(talker, "RMC", out, |w| {
            write!(
                w,
                "{time},A,{lat},{lon},{},{course},{date},,,{}",
                FixedDecimal::new(report.speed_mps * KNOTS_PER_MPS, 3),
                report.quality.faa_mode(),
            )
        });
    } else {
        sentence(talker, "RMC", out, |w| write!(w, "{time},V,,,,,,,{date},,,N"));
        return;
    }

    let sigma = FixedDecimal::new(report.sigma_horizontal_m, 4);
    sentence(talker, "GST", out, |w| {
        write!(
            w,
            "{time},{sigma},{sigma},{sigma},0.0,{sigma},{sigma},{}",
            FixedDecimal::new(report.sigma_alt_m, 4)
        )
    });

    if let Some(heading_deg) = report.heading_deg {
        sentence(talker, "HDT", out, |w| write!(w, "{},T", milli_degrees(heading_deg)));
    }
}

/// `$<talker><kind>,<fields>*<checksum>\r\n`, the fields written by `fields`.
fn sentence(talker: &str, kind: &str, out: &mut Vec<u8>, fields: impl FnOnce(&mut Vec<u8>) -> io::Result<()>) {
    out.push(b'$');
    let body_start = out.len();
    out.extend_from_slice(talker.as_bytes());
    out.extend_from_slice(kind.as_bytes());
    out.push(b',');
    // Writing to a Vec cannot fail.
    let _ = fields(out);
    let checksum = nmea_checksum(&out[body_start..]);
    let _ = write!(out, "*{checksum:02X}\r\n");
}

/// An optional field: its value, or nothing (an empty field).
struct Shown<T>(Option<T>);

impl<T: fmt::Display> fmt::Display for Shown<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.0 {
            Some(value) => value.fmt(f),
            None => Ok(()),
        }
    }
}

/// `ddmm.mmmmmmm,N` (latitude, 2 degree digits) or `dddmm.mmmmmmm,E`.
/// Rounded once, in integer ticks, so 59.99999999′ carries into the degrees.
struct Coordinate {
    ticks: u64,
    degree_digits: usize,
    hemisphere: char,
}

fn coordinate(value_deg: f64, degree_digits: usize, hemispheres: [char; 2]) -> Coordinate {
    let hemisphere = if value_deg < 0.0 {
        hemispheres[1]
    } else {
        hemispheres[0]
    };
    Coordinate {
        ticks: (value_deg.abs() * TICKS_PER_DEG as f64).round() as u64,
        degree_digits,
        hemisphere,
    }
}

impl fmt::Display for Coordinate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (deg, rem) = (self.ticks / TICKS_PER_DEG, self.ticks % TICKS_PER_DEG);
        write!(
            f,
            "{deg:0digits$}{:02}.{:07},{}",
            rem / TICKS_PER_MIN,
            rem % TICKS_PER_MIN,
            self.hemisphere,
            digits = self.degree_digits
        )
    }
}

/// An angle in [0, 360) with 3 decimals; rounding never yields "360.000".
struct MilliDegrees(i64);

fn milli_degrees(angle_deg: f64) -> MilliDegrees {
    MilliDegrees(((angle_deg * 1000.0).round() as i64).rem_euclid(360_000))
}

impl fmt::Display for MilliDegrees {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{:03}", self.0 / 1000, self.0 % 1000)
    }
}

/// `hhmmss.ss`, truncated to the centisecond as receivers stamp.
struct UtcTime {
    centis_of_day: i64,
}

impl fmt::Display for UtcTime {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let centis = self.centis_of_day;
        write!(
            f,
            "{:02}{:02}{:02}.{:02}",
            centis / 360_000,
            centis / 6_000 % 60,
            centis / 100 % 60,
            centis % 100
        )
    }
}

/// `ddmmyy`; empty if the instant is beyond what a calendar date holds.
struct UtcDate(Option<(u32, u32, i32)>);

impl fmt::Display for UtcDate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some((day, month, year)) => write!(f, "{day:02}{month:02}{:02}", year.rem_euclid(100)),
            None => Ok(()),
        }
    }
}

fn utc_fields(utc_unix_us: i64) -> (UtcTime, UtcDate) {
    let time = UtcTime {
        centis_of_day: utc_unix_us.rem_euclid(US_PER_DAY) / 10_000,
    };
    let date = DateTime::from_timestamp_micros(utc_unix_us).map(|utc| (utc.day(), utc.month(), utc.year()));
    (time, UtcDate(date))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coordinates_round_in_ticks_and_carry() {
        assert_eq!(coordinate(29.133, 2, ['N', 'S']).to_string(), "2907.9800000,N");
        assert_eq!(coordinate(-33.5, 2, ['N', 'S']).to_string(), "3330.0000000,S");
        assert_eq!(coordinate(119.64, 3, ['E', 'W']).to_string(), "11938.4000000,E");
        assert_eq!(coordinate(-0.5, 3, ['E', 'W']).to_string(), "00030.0000000,W");
        // 59.999999999′ rounds up to the next whole degree.
        assert_eq!(coordinate(10.0 - 1e-12, 2, ['N', 'S']).to_string(), "1000.0000000,N");
    }

    #[test]
    fn poles_and_the_antimeridian_format_and_read_back() {
        assert_eq!(coordinate(90.0, 2, ['N', 'S']).to_string(), "9000.0000000,N");
        assert_eq!(coordinate(-90.0, 2, ['N', 'S']).to_string(), "9000.0000000,S");
        assert_eq!(coordinate(180.0, 3, ['E', 'W']).to_string(), "18000.0000000,E");
        assert_eq!(coordinate(-180.0, 3, ['E', 'W']).to_string(), "18000.0000000,W");
        // Rounds into 180°, never to "17960.0000000".
        assert_eq!(
            coordinate(-179.999_999_999_9, 3, ['E', 'W']).to_string(),
            "18000.0000000,W"
        );
        assert_eq!(coordinate(179.999_999_99, 3, ['E', 'W']).to_string(), "17959.9999994,E");
        for (lat_deg, lon_deg) in [
            (-90.0, 0.0),
            (89.999_999_9, -180.0),
            (-89.999, 179.999_999_9),
            (0.0, 0.0),
        ] {
            let report = EpochReport {
                utc_unix_us: 0,
                quality: FixQuality::RtkFixed,
                position: GeoPoint {
                    lat_deg,
                    lon_deg,
                    alt_m: 2835.0,
                },
                satellites: 20,
                hdop: 0.6,
                speed_mps: 0.0,
                course_deg: None,
                sigma_horizontal_m: 0.01,
                sigma_alt_m: 0.02,
                heading_deg: Some(359.9996),
            };
            let mut bytes = Vec::new();
            write_epoch("GN", &report, &mut bytes);
            let mut samples = Vec::new();
            drivers::gnss::NmeaReader::new().push(std::time::Duration::ZERO, &bytes, &mut samples);
            let fix = samples
                .iter()
                .find_map(|s| match s {
                    drivers::gnss::GnssSample::Fix(f) => Some(*f),
                    _ => None,
                })
                .unwrap_or_else(|| panic!("{lat_deg} {lon_deg}: {samples:?}"));
            // 1e-7 arc minute is 1.7e-9°.
            assert!((fix.lat_deg - lat_deg).abs() < 2e-9, "{} vs {lat_deg}", fix.lat_deg);
            assert!((fix.lon_deg - lon_deg).abs() < 2e-9, "{} vs {lon_deg}", fix.lon_deg);
        }
    }

    #[test]
    fn angles_wrap_after_rounding() {
        assert_eq!(milli_degrees(359.9996).to_string(), "0.000");
        assert_eq!(milli_degrees(-0.25).to_string(), "359.750");
        assert_eq!(milli_degrees(12.3456).to_string(), "12.346");
    }

    #[test]
    fn utc_time_and_date() {
        // 2025-01-01T00:00:00Z + 1 h 2 min 3.456789 s.
        let us = 1_735_689_600_000_000 + 3_723_456_789;
        let (time, date) = utc_fields(us);
        assert_eq!(
            (time.to_string(), date.to_string()),
            ("010203.45".to_owned(), "010125".to_owned())
        );
    }
}
