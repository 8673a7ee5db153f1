//! Mission files people already use, as text in and text out (no I/O):
//! - [`wpl`]: QGC WPL 110 (`.waypoints`, `.txt`), which Mission Planner,
//!   MAVProxy and QGroundControl read and write; one plan per file, home at
//!   item 0;
//! - [`plan_json`]: QGroundControl's `.plan` (JSON), holding all three plans.
//!
//! Parsing reports the line of the first error, so a bad file changes
//! nothing. What a parsed plan means is checked separately, by
//! [`crate::validate::validate_plan`].

pub mod plan_json;
pub mod wpl;

use crate::validate::{is_local_frame, xy_from_float};

/// Why a file could not be read. `line` is 1-based; 0 when the error is
/// not tied to a line (the message then says where).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FileError {
    pub line: usize,
    pub message: String,
}

impl FileError {
    pub fn new(line: usize, message: impl Into<String>) -> FileError {
        FileError {
            line,
            message: message.into(),
        }
    }
}

impl std::fmt::Display for FileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line > 0 {
            write!(f, "line {}: {}", self.line, self.message)
        } else {
            f.write_str(&self.message)
        }
    }
}

impl std::error::Error for FileError {}

/// Which kind of mission file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// QGC WPL 110: one plan.
    Wpl,
    /// QGroundControl `.plan`: all three plans.
    PlanJson,
}

impl FileKind {
    /// From a file name: `.plan` is QGroundControl's, `.waypoints` and
    /// `.txt` WPL; otherwise `None`.
    pub fn from_path(path: &std::path::Path) -> Option<FileKind> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "plan" => Some(FileKind::PlanJson),
            "waypoints" | "txt" | "wpl" => Some(FileKind::Wpl),
            _ => None,
        }
    }

    /// From the content: `QGC WPL` or a JSON object. The words of the WPL
    /// header may be separated by any whitespace, as [`wpl::parse`] reads it
    /// (a tab-separated header was read but not recognised: found by fuzzing).
    pub fn sniff(text: &str) -> Option<FileKind> {
        let t = text.trim_start_matches('\u{feff}').trim_start();
        let mut words = t.split_whitespace();
        if words.next() == Some("QGC") && words.next().is_some_and(|w| w.starts_with("WPL")) {
            Some(FileKind::Wpl)
        } else if t.starts_with('{') {
            Some(FileKind::PlanJson)
        } else {
            None
        }
    }
}

/// `x`/`y` as text: degrees with exactly 7 decimals (global frames) or
/// metres with 4 (local frames), straight from the integer, so the text
/// reads back to the same integer.
pub fn format_xy(frame: u8, v: i32) -> String {
    let (unit, decimals) = if is_local_frame(frame) {
        (10_000u32, 4)
    } else {
        (10_000_000, 7)
    };
    let sign = if v < 0 { "-" } else { "" };
    let a = v.unsigned_abs();
    format!("{sign}{}.{:0decimals$}", a / unit, a % unit)
}

/// Reads `x`/`y` text back: plain decimals exactly (more decimals than the
/// unit are rounded half away from zero), other number forms (exponents,
/// `nan` where [`xy_from_float`] allows it) through `f64`.
pub fn parse_xy(frame: u8, text: &str) -> Option<i32> {
    let decimals = if is_local_frame(frame) { 4 } else { 7 };
    if let Some(v) = parse_fixed(text, decimals) {
        return i32::try_from(v).ok();
    }
    let v: f64 = text.parse().ok()?;
    xy_from_float(frame, v)
}

/// `[+-]digits[.digits]` as an integer in units of 10^-decimals.
fn parse_fixed(text: &str, decimals: usize) -> Option<i64> {
    let (neg, body) = match text.as_bytes().first()? {
        b'-' => (true, &text[1..]),
        b'+' => (false, &text[1..]),
        _ => (false, text),
    };
    let (int, frac) = body.split_once('.').unwrap_or((body, ""));
    if (int.is_empty() && frac.is_empty())
        || !int.bytes().all(|b| b.is_ascii_digit())
        || !frac.bytes().all(|b| b.is_ascii_digit())
    {
        return None;
    }
    let int = int.trim_start_matches('0');
    if int.len() > 10 {
        return None;
    }
    let mut v: i64 = if int.is_empty() { 0 } else { int.parse().ok()? };
    let digits = frac.as_bytes();
    for i in 0..decimals {
        v = v * 10 + i64::from(digits.get(i).map_or(0, |d| d - b'0'));
    }
    if digits.get(decimals).is_some_and(|d| *d >= b'5') {
        v += 1;
    }
    Some(if neg { -v } else { v })
}

/// An `f32` as the shortest text that reads back to the same value
/// (`NaN`, `inf` and `-inf` included).
pub fn format_f32(v: f32) -> String {
    format!("{v}")
}

/// Reads an `f32` (`nan`, `NaN`, `inf` accepted, any case).
pub fn parse_f32(text: &str) -> Option<f32> {
    text.parse::<f32>()
        .ok()
        .or_else(|| text.to_ascii_lowercase().parse::<f32>().ok())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::frame;

    #[test]
    fn sniffing_agrees_with_the_wpl_parser() {
        // Fuzzing found a header with tabs between its words: parsed, not sniffed.
        let text = "QGC\t\t WPL\t110\n0\t1\t0\t16\t0\t0\t0\t0\t29.1330000\t119.6400000\t40\t1\n";
        assert!(wpl::parse(text).is_ok());
        assert_eq!(FileKind::sniff(text), Some(FileKind::Wpl));
        assert_eq!(FileKind::sniff("QGC WPL 110\n"), Some(FileKind::Wpl));
        assert_eq!(FileKind::sniff("\u{feff}\n  QGC WPL 120\n"), Some(FileKind::Wpl));
        assert_eq!(FileKind::sniff("QGCWPL 110\n"), None);
        assert_eq!(FileKind::sniff(" {\"fileType\": \"Plan\"}"), Some(FileKind::PlanJson));
    }

    #[test]
    fn coordinates_are_exact() {
        assert_eq!(format_xy(frame::GLOBAL, 291_335_413), "29.1335413");
        assert_eq!(format_xy(frame::GLOBAL, -5), "-0.0000005");
        assert_eq!(format_xy(frame::GLOBAL, i32::MIN), "-214.7483648");
        assert_eq!(format_xy(frame::LOCAL_NED, -12_345), "-1.2345");
        assert_eq!(parse_xy(frame::GLOBAL, "29.1335413"), Some(291_335_413));
        assert_eq!(
            parse_xy(frame::GLOBAL, "29.13354135"),
            Some(291_335_414),
            "half away from zero"
        );
        assert_eq!(parse_xy(frame::GLOBAL, "-29.13354135"), Some(-291_335_414));
        assert_eq!(parse_xy(frame::GLOBAL, "29.133541107177734375"), Some(291_335_411));
        assert_eq!(parse_xy(frame::GLOBAL, "119.64"), Some(1_196_400_000));
        assert_eq!(parse_xy(frame::GLOBAL, ".5"), Some(5_000_000));
        assert_eq!(parse_xy(frame::GLOBAL, "1.5e1"), Some(150_000_000));
        assert_eq!(parse_xy(frame::GLOBAL, "-214.7483648"), Some(i32::MIN));
        assert_eq!(parse_xy(frame::GLOBAL, "214.7483648"), None);
        assert_eq!(parse_xy(frame::GLOBAL, "nan"), None);
        assert_eq!(parse_xy(frame::MISSION, "nan"), Some(0));
        assert_eq!(parse_xy(frame::GLOBAL, "."), None);
        assert_eq!(parse_xy(frame::GLOBAL, "-"), None);
        assert_eq!(parse_xy(frame::GLOBAL, ""), None);
        assert_eq!(parse_xy(frame::GLOBAL, "99999999999999999999"), None);
    }

    #[test]
    fn floats_are_shortest_and_read_back() {
        assert_eq!(format_f32(2.0), "2");
        assert_eq!(format_f32(0.1), "0.1");
        assert_eq!(format_f32(f32::NAN), "NaN");
        for text in ["nan", "NaN", "NAN"] {
            assert!(parse_f32(text).unwrap().is_nan(), "{text}");
        }
        assert_eq!(parse_f32("inf"), Some(f32::INFINITY));
        assert_eq!(parse_f32("-0"), Some(-0.0));
        assert_eq!(parse_f32("x"), None);
    }
}
