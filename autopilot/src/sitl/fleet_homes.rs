//! `--fleet-homes FILE`: where each vehicle of a simulated fleet starts.
//!
//! One vehicle a line, in fleet order: `NORTH_M EAST_M HEADING_DEG`
//! (metres from `--home` along north and east, heading clockwise from
//! north), separated by spaces or commas. `#` starts a comment; blank lines
//! are skipped. The file must give exactly one line per vehicle.

use std::path::Path;

/// Where one vehicle starts, about the fleet's home.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FleetHome {
    pub north_m: f64,
    pub east_m: f64,
    pub heading_deg: f64,
}

/// A site is far smaller than this; beyond it a typo is likelier.
const MAX_OFFSET_M: f64 = 100_000.0;
/// Side by side, `SPACING_M` apart, when no file places them.
const SPACING_M: f64 = 5.0;

/// Reads `path` for a fleet of `count` vehicles.
pub fn load(path: &Path, count: usize) -> Result<Vec<FleetHome>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    parse(&text, count).map_err(|e| format!("{}: {e}", path.display()))
}

/// Parses a homes file's text for a fleet of `count` vehicles.
pub fn parse(text: &str, count: usize) -> Result<Vec<FleetHome>, String> {
    let mut homes = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let home = parse_line(line).map_err(|e| format!("line {}: {e}", index + 1))?;
        homes.push(home);
    }
    if homes.len() != count {
        return Err(format!(
            "{} vehicle(s) placed, but the fleet has {count}: give one line `NORTH_M EAST_M HEADING_DEG` per vehicle",
            homes.len()
        ));
    }
    Ok(homes)
}

fn parse_line(line: &str) -> Result<FleetHome, String> {
    let fields: Vec<&str> = line
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|f| !f.is_empty())
        .collect();
    let [north, east, heading] = fields[..] else {
        return Err(format!(
            "{line:?}: expected NORTH_M EAST_M HEADING_DEG, found {} field(s)",
            fields.len()
        ));
    };
    let number = |name: &str, text: &str, limit: f64| {
        text.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && v.abs() <= limit)
            .ok_or_else(|| format!("{name} {text:?} is not a number within ±{limit}"))
    };
    Ok(FleetHome {
        north_m: number("NORTH_M", north, MAX_OFFSET_M)?,
        east_m: number("EAST_M", east, MAX_OFFSET_M)?,
        heading_deg: number("HEADING_DEG", heading, 360.0)?,
    })
}

/// Without a file: side by side, `SPACING_M` apart to the right of the
/// first, all heading `heading_deg`.
pub fn in_a_row(count: usize, heading_deg: f64) -> Vec<FleetHome> {
    let right_rad = (heading_deg + 90.0).to_radians();
    (0..count)
        .map(|i| {
            let offset_m = SPACING_M * i as f64;
            FleetHome {
                north_m: offset_m * right_rad.cos(),
                east_m: offset_m * right_rad.sin(),
                heading_deg,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_homes_file_places_each_vehicle() {
        let text = "# corridor\n0 0 90\n\n0, 30, 270  # facing the first\n";
        let homes = parse(text, 2).unwrap();
        assert_eq!(
            homes[1],
            FleetHome {
                north_m: 0.0,
                east_m: 30.0,
                heading_deg: 270.0
            }
        );
    }

    #[test]
    fn a_bad_homes_file_says_where_and_why() {
        let e = parse("0 0 0\n1 2\n", 2).unwrap_err();
        assert!(e.starts_with("line 2:") && e.contains("found 2 field(s)"), "{e}");
        let e = parse("0 0 0\n1 x 0\n", 2).unwrap_err();
        assert!(e.contains("line 2") && e.contains("EAST_M \"x\""), "{e}");
        let e = parse("0 0 400\n", 1).unwrap_err();
        assert!(e.contains("HEADING_DEG"), "{e}");
        let e = parse("0 0 0\n", 3).unwrap_err();
        assert!(e.contains("1 vehicle(s) placed, but the fleet has 3"), "{e}");
        assert!(parse("0 0 NaN\n", 1).is_err());
    }

    #[test]
    fn without_a_file_they_stand_side_by_side() {
        let homes = in_a_row(3, 0.0);
        assert!((homes[2].east_m - 10.0).abs() < 1e-12 && homes[2].north_m.abs() < 1e-12);
    }
}
