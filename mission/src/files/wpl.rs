//! QGC WPL 110, the text format Mission Planner, MAVProxy and
//! QGroundControl read and write (`.waypoints`):
//!
//! ```text
//! QGC WPL 110
//! seq  current  frame  command  p1  p2  p3  p4  x  y  z  autocontinue
//! ```
//!
//! one item per line, tab-separated, item 0 being home. Furrow writes it
//! losslessly: `x`/`y` as degrees with exactly 7 decimals in global frames
//! (metres with 4 in local frames) straight from the stored integers;
//! params and `z` as the shortest text that reads back to the same `f32`.
//! Reading accepts what other tools write: any whitespace between fields,
//! more decimals (rounded to the stored unit), `nan`.

use std::fmt::Write as _;

use super::{FileError, format_f32, format_xy, parse_f32, parse_xy};
use crate::item::{MissionItem, Plan};

pub const HEADER: &str = "QGC WPL 110";

/// The file for a plan.
pub fn render(plan: &Plan) -> String {
    render_items(plan.items())
}

/// The file for a list of items (written as they are).
pub fn render_items(items: &[MissionItem]) -> String {
    let mut text = String::with_capacity(32 + items.len() * 80);
    text.push_str(HEADER);
    text.push('\n');
    for it in items {
        let _ = writeln!(
            text,
            "{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}",
            it.seq,
            u8::from(it.current),
            it.frame,
            it.command,
            format_f32(it.params[0]),
            format_f32(it.params[1]),
            format_f32(it.params[2]),
            format_f32(it.params[3]),
            format_xy(it.frame, it.x),
            format_xy(it.frame, it.y),
            format_f32(it.z),
            u8::from(it.autocontinue),
        );
    }
    text
}

/// Reads a file's items (their meaning is checked by
/// [`crate::validate::validate_plan`]).
pub fn parse(text: &str) -> Result<Vec<MissionItem>, FileError> {
    Ok(parse_lines(text)?.into_iter().map(|(_, item)| item).collect())
}

/// Like [`parse`], with the 1-based line each item was on (for messages).
pub fn parse_lines(text: &str) -> Result<Vec<(usize, MissionItem)>, FileError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim()));
    let header = lines.by_ref().find(|(_, l)| !l.is_empty());
    match header {
        Some((_, h)) if h.split_whitespace().eq(HEADER.split_whitespace()) => {}
        Some((n, h)) if h.starts_with("QGC WPL") => {
            return Err(FileError::new(
                n,
                format!("{h:?}: only {HEADER} (home at item 0) is supported"),
            ));
        }
        Some((n, h)) => {
            let shown: String = h.chars().take(40).collect();
            return Err(FileError::new(
                n,
                format!("expected the header {HEADER:?}, found {shown:?}"),
            ));
        }
        None => return Err(FileError::new(1, format!("empty file: expected the header {HEADER:?}"))),
    }
    let mut items = Vec::new();
    for (n, line) in lines {
        if line.is_empty() {
            continue;
        }
        items.push((n, parse_item(n, line)?));
    }
    Ok(items)
}

const FIELDS: [&str; 12] = [
    "seq",
    "current",
    "frame",
    "command",
    "param 1",
    "param 2",
    "param 3",
    "param 4",
    "x (latitude)",
    "y (longitude)",
    "z (altitude)",
    "autocontinue",
];

fn parse_item(n: usize, line: &str) -> Result<MissionItem, FileError> {
    let f: Vec<&str> = line.split_whitespace().collect();
    if f.len() != FIELDS.len() {
        return Err(FileError::new(
            n,
            format!("expected {} tab-separated fields, found {}", FIELDS.len(), f.len()),
        ));
    }
    let bad = |i: usize, why: &str| FileError::new(n, format!("{} {:?} {why}", FIELDS[i], f[i]));
    let int = |i: usize, max: u64| -> Result<u64, FileError> {
        f[i].parse::<u64>()
            .ok()
            .filter(|v| *v <= max)
            .ok_or_else(|| bad(i, &format!("is not a whole number from 0 to {max}")))
    };
    let flag = |i: usize| -> Result<bool, FileError> {
        match f[i] {
            "0" => Ok(false),
            "1" => Ok(true),
            _ => Err(bad(i, "must be 0 or 1")),
        }
    };
    let float = |i: usize| parse_f32(f[i]).ok_or_else(|| bad(i, "is not a number"));
    let frame = int(2, u64::from(u8::MAX))? as u8;
    Ok(MissionItem {
        seq: int(0, u64::from(u16::MAX))? as u16,
        current: flag(1)?,
        frame,
        command: int(3, u64::from(u16::MAX))? as u16,
        params: [float(4)?, float(5)?, float(6)?, float(7)?],
        x: parse_xy(frame, f[8]).ok_or_else(|| bad(8, "is not a coordinate in this frame"))?,
        y: parse_xy(frame, f[9]).ok_or_else(|| bad(9, "is not a coordinate in this frame"))?,
        z: float(10)?,
        autocontinue: flag(11)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_like_mission_planner_and_reads_back() {
        let items = vec![
            MissionItem {
                seq: 0,
                frame: 0,
                command: 16,
                current: true,
                autocontinue: true,
                params: [0.0; 4],
                x: 291_330_000,
                y: 1_196_400_000,
                z: 40.0,
            },
            MissionItem {
                seq: 1,
                frame: 3,
                command: 16,
                current: false,
                autocontinue: true,
                params: [5.0, 0.0, 0.0, f32::NAN],
                x: 291_335_413,
                y: -1_196_400_001,
                z: 0.25,
            },
        ];
        let text = render_items(&items);
        assert_eq!(
            text,
            "QGC WPL 110\n\
             0\t1\t0\t16\t0\t0\t0\t0\t29.1330000\t119.6400000\t40\t1\n\
             1\t0\t3\t16\t5\t0\t0\tNaN\t29.1335413\t-119.6400001\t0.25\t1\n"
        );
        let back = parse(&text).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(back[0], items[0]);
        assert!(back[1].params[3].is_nan());
        assert_eq!(back[1].x, items[1].x);
        assert_eq!(back[1].y, items[1].y);
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t1\t2\t3\t1\n\n1\t0\t3\t16\t0\t0\t0\t0\tabc\t2\t3\t1\n")
            .unwrap_err();
        assert_eq!(e.line, 4, "{e}");
        assert!(e.message.contains("x (latitude)"), "{e}");
        let e = parse("QGC WPL 120\n").unwrap_err();
        assert!(e.to_string().contains("only QGC WPL 110"), "{e}");
        let e = parse("").unwrap_err();
        assert_eq!(e.line, 1);
        let e = parse("QGC WPL 110\n0 1 0 16 0 0 0 0 1 2 3\n").unwrap_err();
        assert!(e.to_string().contains("found 11"), "{e}");
        let e = parse("QGC WPL 110\n0 2 0 16 0 0 0 0 1 2 3 1\n").unwrap_err();
        assert!(e.to_string().contains("current"), "{e}");
        let e = parse("QGC WPL 110\n70000 0 0 16 0 0 0 0 1 2 3 1\n").unwrap_err();
        assert!(e.to_string().contains("seq"), "{e}");
    }

    #[test]
    fn accepts_crlf_bom_spaces_and_long_decimals() {
        let text = "\u{feff}QGC WPL 110\r\n0 1 0 16 0.000000000000000000 0 0 0 29.133000000000000000 119.640000000000000000 40.000000 1\r\n";
        let items = parse(text).unwrap();
        assert_eq!(items[0].x, 291_330_000);
        assert_eq!(items[0].y, 1_196_400_000);
        assert_eq!(items[0].z, 40.0);
    }
}
