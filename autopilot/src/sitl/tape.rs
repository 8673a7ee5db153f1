//! `furrow sitl --tape FILE`: a magnetic tape laid along a path, for
//! MAGNETIC mode. The path is a waypoint file (QGC WPL 110, as a mission):
//! straight runs between its positioned items with each corner rounded by
//! an arc of `--tape-radius`, the way a tape is laid on a shop floor.

use std::path::Path;

use mission::command::{Position, cmd, position};
use sim::{MagneticTape, TapeSegment, World};
use vehicle_types::GeoPoint;

use crate::geo::Ned;
use crate::guidance::path::fit_corner;

/// The tape through `points` (local metres), corners rounded with
/// `radius_m` (smaller where a leg is too short for it; a reversal or a
/// corner with no room stays a sharp corner).
pub fn tape_through(points: &[Ned], radius_m: f64, width_m: f64) -> Result<MagneticTape, String> {
    let points: Vec<Ned> = points.iter().copied().fold(Vec::new(), |mut acc: Vec<Ned>, p| {
        if acc.last().is_none_or(|q| q.distance_to(&p) > 1e-3) {
            acc.push(p);
        }
        acc
    });
    if points.len() < 2 {
        return Err("a tape needs at least two distinct points".into());
    }
    let mut segments = Vec::new();
    let mut from = points[0];
    for i in 1..points.len() {
        let corner = points.get(i + 1).and_then(|next| {
            fit_corner(
                points[i - 1],
                points[i],
                *next,
                radius_m,
                0.0,
                from.distance_to(&points[i]),
                0.5 * points[i].distance_to(next),
            )
        });
        let line_end = corner.map_or(points[i], |c| c.arc.point_at(0.0));
        if from.distance_to(&line_end) > 1e-6 {
            segments.push(TapeSegment::Line {
                start_m: (from.north_m, from.east_m),
                end_m: (line_end.north_m, line_end.east_m),
            });
        }
        from = match corner {
            Some(c) => {
                let start = c.arc.point_at(0.0);
                segments.push(TapeSegment::Arc {
                    centre_m: (c.arc.center.north_m, c.arc.center.east_m),
                    radius_m: c.arc.radius_m,
                    start_bearing_rad: (start.east_m - c.arc.center.east_m).atan2(start.north_m - c.arc.center.north_m),
                    sweep_rad: c.arc.turn * c.arc.sweep_rad,
                });
                c.arc.end()
            }
            None => points[i],
        };
    }
    Ok(MagneticTape::from_segments(segments, width_m))
}

/// Reads a waypoint file and lays its tape in `world`'s frame: from home
/// (item 0) through every waypoint (NAV_WAYPOINT, NAV_TAKEOFF).
pub fn load(path: &Path, world: &World, radius_m: f64) -> Result<MagneticTape, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let items = mission::files::wpl::parse(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let points: Vec<Ned> = items
        .iter()
        .filter(|item| matches!(item.command, cmd::NAV_WAYPOINT | cmd::NAV_TAKEOFF))
        .filter_map(|item| match position(item).ok()? {
            Position::Global { lat_e7, lon_e7 } => {
                let (north_m, east_m) = world.geodetic_to_local(&GeoPoint::from_e7(lat_e7, lon_e7, 0.0));
                Some(Ned::new(north_m, east_m))
            }
            Position::Local { north_m, east_m } => Some(Ned::new(north_m, east_m)),
            Position::Current => None,
        })
        .collect();
    tape_through(&points, radius_m, MagneticTape::DEFAULT_WIDTH_M).map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_gets_rounded_corners() {
        let square = [
            Ned::new(0.0, 0.0),
            Ned::new(40.0, 0.0),
            Ned::new(40.0, 40.0),
            Ned::new(0.0, 40.0),
        ];
        let tape = tape_through(&square, 10.0, 0.03).unwrap();
        // Two rounded corners: 40 − 10 + 2 × 10π/2 + 40 − 20 + 40 − 10.
        let expected = 30.0 + 2.0 * 10.0 * std::f64::consts::FRAC_PI_2 + 20.0 + 30.0;
        assert!((tape.length_m() - expected).abs() < 1e-6, "{}", tape.length_m());
        // The corner point is off the tape by R(√2 − 1); the arc's middle on it.
        let fix = tape.locate(40.0, 0.0).unwrap();
        assert!((fix.distance_m - 10.0 * (2f64.sqrt() - 1.0)).abs() < 1e-6);
        assert!(tape.locate(30.0, 0.0).unwrap().distance_m < 1e-9);
        assert!(tape.locate(40.0, 10.0).unwrap().distance_m < 1e-9);
        assert!(tape.locate(0.0, 40.0).unwrap().distance_m < 1e-9);
    }

    #[test]
    fn too_few_points_is_an_error() {
        assert!(tape_through(&[Ned::new(1.0, 1.0), Ned::new(1.0, 1.0)], 10.0, 0.03).is_err());
    }
}
