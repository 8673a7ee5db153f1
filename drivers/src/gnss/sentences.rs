//! One complete line → samples. Framing and checksum are checked here (so a
//! bad checksum is told apart from an unknown type), then the consumed types
//! go to `nmea::parse_str` one sentence at a time, and THS, HDM and HDG,
//! which the `nmea` crate does not know, are parsed by hand, as are an
//! IMU's VectorNav lines (`crate::imu`).

use std::time::Duration;

use chrono::{NaiveDateTime, NaiveTime, Timelike};
use nmea::ParseResult;
use nmea::sentences::rmc::RmcStatusOfFix;
use nmea::sentences::{FixType, GgaData, GstData, HdtData, RmcData, VtgData};

use super::{
    FixQuality, GnssAccuracy, GnssFix, GnssHeading, GnssSample, GnssTime, GnssVelocity, HeadingReference, nmea_checksum,
};

const MPS_PER_KNOT: f64 = 1852.0 / 3600.0;

/// What became of one line; the reader turns it into a counter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum LineOutcome {
    Parsed,
    ChecksumError,
    Malformed,
    Unsupported,
}

/// A sentence parsed, but a value in it is impossible (NaN, latitude 95°…).
struct BadValue;

pub(super) fn parse_line(line: &[u8], t: Duration, out: &mut Vec<GnssSample>) -> LineOutcome {
    let Ok(text) = std::str::from_utf8(line) else {
        return LineOutcome::Malformed;
    };
    if !text.is_ascii() {
        return LineOutcome::Malformed;
    }
    let Some((body, expected)) = frame(text) else {
        return LineOutcome::Malformed;
    };
    if nmea_checksum(body.as_bytes()) != expected {
        return LineOutcome::ChecksumError;
    }
    let address = body.split(',').next().unwrap_or_default();
    if address.is_empty() || !address.bytes().all(|b| b.is_ascii_alphanumeric()) {
        return LineOutcome::Malformed;
    }
    // Standard sentences are a 2-character talker plus a 3-character type;
    // anything else (proprietary `$P…`, `!AIVDM`) is not ours to read.
    if address.len() != 5 || !text.starts_with('$') {
        return LineOutcome::Unsupported;
    }
    if crate::imu::is_imu_address(address) {
        return match crate::imu::parse_vectornav_body(body, t) {
            Ok(sample) => {
                out.push(GnssSample::Imu(sample));
                LineOutcome::Parsed
            }
            Err(_) => LineOutcome::Malformed,
        };
    }
    let before = out.len();
    let result = match &address[2..] {
        "THS" => parse_ths(body, t, out),
        "HDM" => parse_hdm(body, t, out),
        "HDG" => parse_hdg(body, t, out),
        "GGA" | "RMC" | "VTG" | "GST" | "HDT" => match nmea::parse_str(text) {
            Ok(parsed) => samples_from(&parsed, t, out),
            Err(_) => Err(BadValue),
        },
        _ => return LineOutcome::Unsupported,
    };
    match result {
        Ok(()) => LineOutcome::Parsed,
        Err(BadValue) => {
            out.truncate(before);
            LineOutcome::Malformed
        }
    }
}

/// The text between the start character and `*`, and the checksum after it,
/// if the line is framed as `$body*hh` (or `!body*hh`) with exactly one `*`.
fn frame(text: &str) -> Option<(&str, u8)> {
    let rest = text.strip_prefix('$').or_else(|| text.strip_prefix('!'))?;
    let (body, hex) = rest.split_once('*')?;
    // `from_str_radix` alone would accept a sign ("+F").
    if hex.len() != 2 || !hex.bytes().all(|b| b.is_ascii_hexdigit()) || body.contains('!') {
        return None;
    }
    Some((body, u8::from_str_radix(hex, 16).ok()?))
}

fn samples_from(parsed: &ParseResult, t: Duration, out: &mut Vec<GnssSample>) -> Result<(), BadValue> {
    match parsed {
        ParseResult::GGA(gga) => out.push(GnssSample::Fix(fix_from_gga(gga, t)?)),
        ParseResult::RMC(rmc) => samples_from_rmc(rmc, t, out)?,
        ParseResult::VTG(vtg) => samples_from_vtg(vtg, t, out)?,
        ParseResult::GST(gst) => samples_from_gst(gst, t, out)?,
        ParseResult::HDT(hdt) => samples_from_hdt(hdt, t, out)?,
        // parse_line only hands over the five types above.
        _ => return Err(BadValue),
    }
    Ok(())
}

fn fix_from_gga(gga: &GgaData, t: Duration) -> Result<GnssFix, BadValue> {
    let quality = match gga.fix_type {
        None | Some(FixType::Invalid) => FixQuality::NoFix,
        // PPS (3) is a single-receiver fix with the military code.
        Some(FixType::Gps) | Some(FixType::Pps) => FixQuality::Single,
        Some(FixType::DGps) => FixQuality::Dgps,
        Some(FixType::Rtk) => FixQuality::RtkFixed,
        Some(FixType::FloatRtk) => FixQuality::RtkFloat,
        Some(FixType::Estimated) => FixQuality::DeadReckoning,
        Some(FixType::Manual) => FixQuality::Manual,
        Some(FixType::Simulation) => FixQuality::Simulation,
    };
    let position = match (gga.latitude, gga.longitude) {
        (Some(lat), Some(lon)) if quality != FixQuality::NoFix => {
            if !(lat.is_finite() && lat.abs() <= 90.0 && lon.is_finite() && lon.abs() <= 180.0) {
                return Err(BadValue);
            }
            Some((lat, lon))
        }
        _ => None,
    };
    let (quality, lat_deg, lon_deg) = match position {
        Some((lat, lon)) => (quality, lat, lon),
        None => (FixQuality::NoFix, f64::NAN, f64::NAN),
    };
    let alt_msl_m = optional_finite(gga.altitude)?.map_or(f64::NAN, f64::from);
    let hdop = optional_finite(gga.hdop)?.unwrap_or(f32::NAN);
    if hdop < 0.0 {
        return Err(BadValue);
    }
    Ok(GnssFix {
        t,
        utc_time_of_day_s: gga.fix_time.map(seconds_of_day),
        lat_deg,
        lon_deg,
        alt_msl_m,
        quality,
        satellites: gga.fix_satellites.map_or(0, |n| u8::try_from(n).unwrap_or(u8::MAX)),
        hdop,
    })
}

fn samples_from_rmc(rmc: &RmcData, t: Duration, out: &mut Vec<GnssSample>) -> Result<(), BadValue> {
    // A receiver without a fix may still send its free-running clock and a
    // stale speed: only a valid status makes either usable.
    if rmc.status_of_fix == RmcStatusOfFix::Invalid {
        return Ok(());
    }
    if let Some(velocity) = velocity(rmc.speed_over_ground, rmc.true_course, t)? {
        out.push(GnssSample::Velocity(velocity));
    }
    if let (Some(date), Some(time)) = (rmc.fix_date, rmc.fix_time) {
        let utc_unix_us = NaiveDateTime::new(date, time).and_utc().timestamp_micros();
        out.push(GnssSample::Time(GnssTime { t, utc_unix_us }));
    }
    Ok(())
}

fn samples_from_vtg(vtg: &VtgData, t: Duration, out: &mut Vec<GnssSample>) -> Result<(), BadValue> {
    if let Some(velocity) = velocity(vtg.speed_over_ground, vtg.true_course, t)? {
        out.push(GnssSample::Velocity(velocity));
    }
    Ok(())
}

fn velocity(speed_knots: Option<f32>, course_deg: Option<f32>, t: Duration) -> Result<Option<GnssVelocity>, BadValue> {
    let course_deg = optional_finite(course_deg)?.map(|c| f64::from(c).rem_euclid(360.0));
    let Some(speed_knots) = optional_finite(speed_knots)? else {
        return Ok(None);
    };
    if speed_knots < 0.0 {
        return Err(BadValue);
    }
    Ok(Some(GnssVelocity {
        t,
        speed_mps: f64::from(speed_knots) * MPS_PER_KNOT,
        course_deg,
    }))
}

fn samples_from_gst(gst: &GstData, t: Duration, out: &mut Vec<GnssSample>) -> Result<(), BadValue> {
    let sigma = |v: Option<f32>| -> Result<Option<f64>, BadValue> {
        match optional_finite(v)? {
            Some(s) if s < 0.0 => Err(BadValue),
            s => Ok(s.map(f64::from)),
        }
    };
    let (north, east, up) = (sigma(gst.lat_sd)?, sigma(gst.long_sd)?, sigma(gst.alt_sd)?);
    if let (Some(sigma_north_m), Some(sigma_east_m)) = (north, east) {
        out.push(GnssSample::Accuracy(GnssAccuracy {
            t,
            sigma_north_m,
            sigma_east_m,
            sigma_up_m: up,
        }));
    }
    Ok(())
}

fn samples_from_hdt(hdt: &HdtData, t: Duration, out: &mut Vec<GnssSample>) -> Result<(), BadValue> {
    if let Some(heading) = optional_finite(hdt.heading)? {
        out.push(GnssSample::Heading(GnssHeading {
            t,
            heading_deg: f64::from(heading),
            reference: HeadingReference::True,
        }));
    }
    Ok(())
}

/// `$xxTHS,heading,mode`: mode A autonomous, E estimated, M manual,
/// S simulator, V invalid. Only an autonomous heading is a measurement.
fn parse_ths(body: &str, t: Duration, out: &mut Vec<GnssSample>) -> Result<(), BadValue> {
    let mut fields = body.split(',').skip(1);
    let (Some(heading), Some(mode), None) = (fields.next(), fields.next(), fields.next()) else {
        return Err(BadValue);
    };
    if !matches!(mode, "A" | "E" | "M" | "S" | "V") {
        return Err(BadValue);
    }
    let heading_deg = if heading.is_empty() {
        None
    } else {
        match heading.parse::<f64>() {
            Ok(h) if h.is_finite() => Some(h),
            _ => return Err(BadValue),
        }
    };
    if let (Some(heading_deg), "A") = (heading_deg, mode) {
        out.push(GnssSample::Heading(GnssHeading {
            t,
            heading_deg,
            reference: HeadingReference::True,
        }));
    }
    Ok(())
}

/// An empty field is `None`; anything else must be a finite number.
fn optional_number(field: &str) -> Result<Option<f64>, BadValue> {
    if field.is_empty() {
        return Ok(None);
    }
    match field.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(Some(v)),
        _ => Err(BadValue),
    }
}

/// `$xxHDM,heading,M`: magnetic heading.
fn parse_hdm(body: &str, t: Duration, out: &mut Vec<GnssSample>) -> Result<(), BadValue> {
    let mut fields = body.split(',').skip(1);
    let (Some(heading), Some(unit), None) = (fields.next(), fields.next(), fields.next()) else {
        return Err(BadValue);
    };
    if unit != "M" {
        return Err(BadValue);
    }
    if let Some(heading_deg) = optional_number(heading)? {
        out.push(GnssSample::Heading(GnssHeading {
            t,
            heading_deg,
            reference: HeadingReference::Magnetic,
        }));
    }
    Ok(())
}

/// `$xxHDG,sensor heading,deviation,E|W,variation,E|W`: the magnetic
/// heading is the sensor's plus its deviation (east positive). The
/// variation is left to `COMPASS_DEC`, as the autopilot's own setting.
fn parse_hdg(body: &str, t: Duration, out: &mut Vec<GnssSample>) -> Result<(), BadValue> {
    let fields: Vec<&str> = body.split(',').skip(1).collect();
    let [heading, deviation, deviation_dir, variation, variation_dir] = fields[..] else {
        return Err(BadValue);
    };
    let signed = |value: Option<f64>, dir: &str| -> Result<f64, BadValue> {
        match (value, dir) {
            (None, "") => Ok(0.0),
            (Some(v), "E") => Ok(v),
            (Some(v), "W") => Ok(-v),
            _ => Err(BadValue),
        }
    };
    let deviation_deg = signed(optional_number(deviation)?, deviation_dir)?;
    signed(optional_number(variation)?, variation_dir)?;
    if let Some(sensor_deg) = optional_number(heading)? {
        out.push(GnssSample::Heading(GnssHeading {
            t,
            heading_deg: sensor_deg + deviation_deg,
            reference: HeadingReference::Magnetic,
        }));
    }
    Ok(())
}

fn optional_finite(value: Option<f32>) -> Result<Option<f32>, BadValue> {
    match value {
        Some(v) if !v.is_finite() => Err(BadValue),
        v => Ok(v),
    }
}

fn seconds_of_day(time: NaiveTime) -> f64 {
    f64::from(time.num_seconds_from_midnight()) + f64::from(time.nanosecond()) * 1e-9
}
