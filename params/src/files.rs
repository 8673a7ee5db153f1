//! Parameter files people already use:
//! - Mission Planner / MAVProxy `.param`: `NAME,VALUE` per line (a space or
//!   tab also separates, as MAVProxy writes), `#` comments;
//! - QGroundControl `.params`: tab-separated
//!   `Vehicle-Id Component-Id Name Value Type`, `#` comments.
//!
//! Parsing is pure (text in, entries out) and reports the line of the first
//! error, so a bad file changes nothing.

use std::fmt::Write as _;

use crate::def::{ParamDef, ParamType};
use crate::service::mav_param_type;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileFormat {
    MissionPlanner,
    QGroundControl,
}

impl FileFormat {
    /// From a file name: `.params` is QGroundControl's, anything else
    /// (`.param`, `.parm`) Mission Planner's.
    pub fn from_path(path: &std::path::Path) -> FileFormat {
        match path.extension().and_then(|e| e.to_str()) {
            Some(ext) if ext.eq_ignore_ascii_case("params") => FileFormat::QGroundControl,
            _ => FileFormat::MissionPlanner,
        }
    }
}

/// One `NAME = value` read from a file.
#[derive(Clone, Debug, PartialEq)]
pub struct FileEntry {
    pub name: String,
    pub value: f64,
    /// 1-based line number, for messages.
    pub line: usize,
}

/// Why a file could not be read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FileError {
    pub line: usize,
    pub message: String,
}

impl std::fmt::Display for FileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

impl std::error::Error for FileError {}

fn parse_value(text: &str, line: usize) -> Result<f64, FileError> {
    match text.trim().parse::<f64>() {
        // `-0` is 0: an integer parameter kept the sign bit, so a file with
        // `-0.000000` exported `0` and did not round-trip (found by fuzzing).
        Ok(v) if v.is_finite() => Ok(v + 0.0),
        _ => Err(FileError {
            line,
            message: format!("value {text:?} is not a finite number"),
        }),
    }
}

fn check_name(name: &str, line: usize) -> Result<(), FileError> {
    crate::def::ParamName::new(name.to_owned())
        .map(|_| ())
        .map_err(|e| FileError {
            line,
            message: format!("{name:?}: {e}"),
        })
}

/// Reads a file in `format`. Names are checked for syntax only; whether a
/// parameter exists is for the caller to decide.
pub fn parse(text: &str, format: FileFormat) -> Result<Vec<FileEntry>, FileError> {
    let mut entries = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let content = raw.trim();
        if content.is_empty() || content.starts_with('#') {
            continue;
        }
        let (name, value) = match format {
            FileFormat::MissionPlanner => {
                let mut parts = content.splitn(2, |c: char| c == ',' || c.is_whitespace());
                let name = parts.next().unwrap_or_default();
                let rest = parts
                    .next()
                    .map(|r| r.trim_start_matches([',', ' ', '\t']))
                    .unwrap_or("");
                // A trailing comment or MAVProxy's padding may follow the value.
                let value = rest.split(['#', ' ', '\t']).next().unwrap_or("");
                if value.is_empty() {
                    return Err(FileError {
                        line,
                        message: format!("expected NAME,VALUE, got {content:?}"),
                    });
                }
                (name, value)
            }
            FileFormat::QGroundControl => {
                let fields: Vec<&str> = content.split_whitespace().collect();
                if fields.len() != 5 || fields[0].parse::<u8>().is_err() || fields[1].parse::<u8>().is_err() {
                    return Err(FileError {
                        line,
                        message: format!("expected SYSID COMPID NAME VALUE TYPE, got {content:?}"),
                    });
                }
                (fields[2], fields[3])
            }
        };
        check_name(name, line)?;
        entries.push(FileEntry {
            name: name.to_owned(),
            value: parse_value(value, line)?,
            line,
        });
    }
    Ok(entries)
}

/// A value as text that reads back to the same stored value: integers
/// without a fraction, floats as the shortest decimal of their `f32`.
pub fn format_value(ty: ParamType, value: f64) -> String {
    match ty {
        ParamType::Real32 => format!("{}", value as f32),
        _ => format!("{}", value as i64),
    }
}

/// Writes parameters as a Mission Planner `.param` file, sorted by name.
pub fn format_mission_planner<'a>(params: impl Iterator<Item = (&'a ParamDef, f64)>, header: &str) -> String {
    let mut sorted: Vec<_> = params.collect();
    sorted.sort_by(|a, b| a.0.name.cmp(&b.0.name));
    let mut out = String::new();
    for line in header.lines() {
        let _ = writeln!(out, "# {line}");
    }
    for (def, value) in sorted {
        let _ = writeln!(out, "{},{}", def.name, format_value(def.ty, value));
    }
    out
}

/// Writes parameters as a QGroundControl `.params` file, sorted by name.
pub fn format_qgroundcontrol<'a>(
    params: impl Iterator<Item = (&'a ParamDef, f64)>,
    system_id: u8,
    component_id: u8,
    header: &str,
) -> String {
    let mut sorted: Vec<_> = params.collect();
    sorted.sort_by(|a, b| a.0.name.cmp(&b.0.name));
    let mut out = String::new();
    for line in header.lines() {
        let _ = writeln!(out, "# {line}");
    }
    let _ = writeln!(out, "#\n# Vehicle-Id Component-Id Name Value Type");
    for (def, value) in sorted {
        let _ = writeln!(
            out,
            "{system_id}\t{component_id}\t{}\t{}\t{}",
            def.name,
            format_value(def.ty, value),
            mav_param_type(def.ty) as u8
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mission_planner_and_mavproxy_layouts() {
        let text = "# saved\nWP_SPEED,2.5\nWP_RADIUS 1.5\nCRUISE_SPEED\t3\n\nFS_ACTION,2 # hold\nSR0_POSITION        10.000000\n";
        let e = parse(text, FileFormat::MissionPlanner).unwrap();
        let got: Vec<(&str, f64)> = e.iter().map(|e| (e.name.as_str(), e.value)).collect();
        assert_eq!(
            got,
            vec![
                ("WP_SPEED", 2.5),
                ("WP_RADIUS", 1.5),
                ("CRUISE_SPEED", 3.0),
                ("FS_ACTION", 2.0),
                ("SR0_POSITION", 10.0)
            ]
        );
        assert_eq!(e[3].line, 6);
    }

    #[test]
    fn negative_zero_reads_as_zero() {
        for format in [FileFormat::MissionPlanner, FileFormat::QGroundControl] {
            let text = match format {
                FileFormat::MissionPlanner => "SR0_POSITION        -0.000000\n",
                FileFormat::QGroundControl => "1\t1\tSR0_POSITION\t-0\t4\n",
            };
            let e = parse(text, format).unwrap();
            assert_eq!(e[0].value.to_bits(), 0.0f64.to_bits(), "{format:?}");
        }
    }

    #[test]
    fn qgroundcontrol_layout() {
        let text = "# Onboard parameters\n#\n1\t1\tWP_SPEED\t2.500000000000000000\t9\n1\t1\tFS_ACTION\t2\t2\n";
        let e = parse(text, FileFormat::QGroundControl).unwrap();
        assert_eq!(e.len(), 2);
        assert_eq!((e[0].name.as_str(), e[0].value), ("WP_SPEED", 2.5));
    }

    #[test]
    fn errors_name_the_line() {
        assert_eq!(
            parse("WP_SPEED,2\nWP_RADIUS,abc\n", FileFormat::MissionPlanner)
                .unwrap_err()
                .line,
            2
        );
        assert_eq!(parse("WP_SPEED,nan\n", FileFormat::MissionPlanner).unwrap_err().line, 1);
        assert_eq!(parse("WP_SPEED\n", FileFormat::MissionPlanner).unwrap_err().line, 1);
        assert_eq!(parse("wp_speed,1\n", FileFormat::MissionPlanner).unwrap_err().line, 1);
        assert_eq!(
            parse("1\t1\tWP_SPEED\t2\n", FileFormat::QGroundControl)
                .unwrap_err()
                .line,
            1
        );
    }

    #[test]
    fn values_round_trip_through_text() {
        assert_eq!(format_value(ParamType::Real32, f64::from(2.9f32)), "2.9");
        assert_eq!(format_value(ParamType::Int16, 255.0), "255");
        let back: f64 = format_value(ParamType::Real32, f64::from(0.1f32)).parse().unwrap();
        assert_eq!(back as f32, 0.1f32);
    }
}
