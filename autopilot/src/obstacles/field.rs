//! The speed-dependent protective and warning fields (docs/architecture.md §Obstacles; the SICK
//! stopping-distance sizing of reference B.4), checked against raw scan
//! points every scan.
//!
//! Tracks need several scans to confirm (reference B.5: 60–80 ms at best), so
//! this per-scan check of the raw points sits beneath the track-based
//! prediction, not beside it: whatever is inside the braking distance stops
//! the vehicle whether or not it has become a track.
//!
//! The protective field is the vehicle's outline, grown by a lateral margin,
//! swept along the path it is about to drive ([`super::swept`]) over the
//! stopping distance v·t_react + v²/(2a) + Z_G; the warning field continues
//! the sweep by `warning_time_s` of travel. A return is in a field when the
//! swept outline comes within the margin of it, nearer than the outline is
//! now: what stays beside the body (a wall along a straight lane) is not in
//! the way, what the inner side or the tail will swing into in a turn is.
//! Distances are path travelled before the outline reaches the return.
//! [`check_field`] is the straight rectangle of the same length (the sweep
//! of a straight path), kept for callers without a path. This is an availability function in
//! software, not the ISO 3691-4 personnel-detection safety function, which
//! needs a safety-rated scanner wired to the brakes (reference B.4).

use super::Footprint;
use super::swept::SweptPath;
use crate::geo::Ned;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldConfig {
    /// Scan period + core tick + actuator delay.
    pub reaction_s: f64,
    /// The deceleration the vehicle can be relied on to achieve.
    pub decel_mps2: f64,
    /// Z_G, the general supplement added to the stopping distance.
    pub margin_m: f64,
    /// Added to each side of the vehicle's width.
    pub lateral_margin_m: f64,
    /// How much further the warning field reaches, in seconds of travel.
    pub warning_time_s: f64,
    /// The protective field is never shorter than this, even at rest.
    pub min_length_m: f64,
}

impl Default for FieldConfig {
    /// Reference B.4's worked example: 20 ms scan + 20 ms tick + 50 ms
    /// actuator delay, 1 m/s², Z_G 100 mm.
    fn default() -> Self {
        FieldConfig {
            reaction_s: 0.09,
            decel_mps2: 1.0,
            margin_m: 0.1,
            lateral_margin_m: 0.15,
            warning_time_s: 2.0,
            min_length_m: 0.1,
        }
    }
}

/// The fields for one speed, lengths measured from the bumper in the
/// driving direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fields {
    /// +1 forward, −1 reverse.
    pub direction: i8,
    pub protective_length_m: f64,
    /// Measured from the bumper too, so never shorter than the protective
    /// length.
    pub warning_length_m: f64,
    pub half_width_m: f64,
}

/// What the points in one scan did to the fields. A point is counted in one
/// field only: the warning counts cover the band beyond the protective field.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FieldStatus {
    pub protective_hits: usize,
    pub warning_hits: usize,
    /// Distance ahead of the bumper (in the driving direction) of the nearest
    /// point in each field.
    pub nearest_protective_m: Option<f64>,
    pub nearest_warning_m: Option<f64>,
}

/// Stopping distance v·t_react + v²/(2a) + Z_G, at least `min_length_m`.
pub fn protective_length_m(speed_mps: f64, config: &FieldConfig) -> f64 {
    let v = if speed_mps.is_finite() { speed_mps.abs() } else { 0.0 };
    let braking_m = if v == 0.0 {
        0.0
    } else if config.decel_mps2 > 0.0 {
        v * v / (2.0 * config.decel_mps2)
    } else {
        // No usable deceleration: nothing short of the scanner's reach is safe.
        f64::INFINITY
    };
    (v * config.reaction_s.max(0.0) + braking_m + config.margin_m.max(0.0)).max(config.min_length_m)
}

/// The fields for a signed speed (at rest they face forward).
pub fn fields(speed_mps: f64, footprint: &Footprint, config: &FieldConfig) -> Fields {
    let protective = protective_length_m(speed_mps, config);
    let v = if speed_mps.is_finite() { speed_mps.abs() } else { 0.0 };
    Fields {
        direction: if speed_mps < 0.0 { -1 } else { 1 },
        protective_length_m: protective,
        warning_length_m: protective + v * config.warning_time_s.max(0.0),
        half_width_m: footprint.half_width_m + config.lateral_margin_m.max(0.0),
    }
}

/// Counts the body-frame points (x forward, y right, from the reference
/// point) inside each field. Points within the footprint itself (returns
/// from the vehicle's own body) and non-finite points are ignored.
pub fn check_field(
    fields: &Fields,
    footprint: &Footprint,
    body_points: impl IntoIterator<Item = (f64, f64)>,
) -> FieldStatus {
    let mut status = FieldStatus::default();
    for (x, y) in body_points {
        if !x.is_finite() || !y.is_finite() || y.abs() > fields.half_width_m {
            continue;
        }
        let ahead_m = if fields.direction < 0 {
            -footprint.rear_m - x
        } else {
            x - footprint.front_m
        };
        // At or behind the bumper: inside the body, or beside it.
        if ahead_m <= 0.0 {
            continue;
        }
        if ahead_m <= fields.protective_length_m {
            status.protective_hits += 1;
            status.nearest_protective_m = Some(status.nearest_protective_m.map_or(ahead_m, |d| d.min(ahead_m)));
        } else if ahead_m <= fields.warning_length_m {
            status.warning_hits += 1;
            status.nearest_warning_m = Some(status.nearest_warning_m.map_or(ahead_m, |d| d.min(ahead_m)));
        }
    }
    status
}

/// Both field sets (sized for two speeds along the same path, e.g. now
/// and at the resume speed) for local-frame returns, each with the lateral
/// margin the fields keep from it, in one pass.
pub fn check_swept_fields(
    sets: [&Fields; 2],
    swept: &SweptPath,
    points: impl IntoIterator<Item = (Ned, f64)>,
) -> [FieldStatus; 2] {
    let mut status = [FieldStatus::default(); 2];
    let reach_m = sets[0].warning_length_m.max(sets[1].warning_length_m);
    for (p, lateral_margin_m) in points {
        let Some(along_m) = swept.point_entry_m(p, lateral_margin_m, reach_m) else {
            continue;
        };
        for (fields, status) in sets.iter().zip(status.iter_mut()) {
            if along_m <= fields.protective_length_m {
                status.protective_hits += 1;
                status.nearest_protective_m = Some(status.nearest_protective_m.map_or(along_m, |d| d.min(along_m)));
            } else if along_m <= fields.warning_length_m {
                status.warning_hits += 1;
                status.nearest_warning_m = Some(status.nearest_warning_m.map_or(along_m, |d| d.min(along_m)));
            }
        }
    }
    status
}

/// The speed at which the nearest warning-field point would sit exactly on
/// the protective boundary, capped at `cruise_mps`: driving no faster keeps
/// it out of the protective field as the vehicle closes in, so the vehicle
/// slows progressively instead of stopping. `None` without warning hits.
///
/// Solves v·t + v²/(2a) + Z_G = d for v ≥ 0; a point no further than the
/// minimum field length (or already within the given protective field)
/// gives 0.
pub fn warning_speed_limit(
    fields: &Fields,
    status: &FieldStatus,
    config: &FieldConfig,
    cruise_mps: f64,
) -> Option<f64> {
    let distance_m = status.nearest_warning_m?;
    let cruise_mps = cruise_mps.abs();
    if !(distance_m > fields.protective_length_m && distance_m > config.min_length_m) {
        return Some(0.0);
    }
    let room_m = distance_m - config.margin_m.max(0.0);
    if room_m <= 0.0 || config.decel_mps2 <= 0.0 {
        return Some(0.0);
    }
    let a = config.decel_mps2;
    let t = config.reaction_s.max(0.0);
    let speed_mps = a * (-t + (t * t + 2.0 * room_m / a).sqrt());
    Some(speed_mps.min(cruise_mps))
}

#[cfg(test)]
mod tests {
    use super::*;

    const FOOTPRINT: Footprint = Footprint {
        front_m: 1.0,
        rear_m: 0.2,
        half_width_m: 0.35,
    };

    #[test]
    fn limit_inverts_the_length() {
        let config = FieldConfig::default();
        for d in [0.3, 0.69, 1.5, 2.28, 4.0] {
            let fields = fields(0.0, &FOOTPRINT, &config);
            let status = FieldStatus {
                warning_hits: 1,
                nearest_warning_m: Some(d),
                ..FieldStatus::default()
            };
            let v = warning_speed_limit(&fields, &status, &config, 10.0).unwrap_or(-1.0);
            assert!((protective_length_m(v, &config) - d).abs() < 1e-9, "d {d}: v {v}");
        }
    }

    #[test]
    fn limit_is_capped_at_cruise_and_absent_without_hits() {
        let config = FieldConfig::default();
        let fields = fields(0.5, &FOOTPRINT, &config);
        let far = FieldStatus {
            warning_hits: 1,
            nearest_warning_m: Some(50.0),
            ..FieldStatus::default()
        };
        assert_eq!(warning_speed_limit(&fields, &far, &config, 1.2), Some(1.2));
        assert_eq!(
            warning_speed_limit(&fields, &FieldStatus::default(), &config, 1.2),
            None
        );
    }

    #[test]
    fn no_deceleration_means_an_unbounded_field() {
        let config = FieldConfig {
            decel_mps2: 0.0,
            ..FieldConfig::default()
        };
        assert!(protective_length_m(0.5, &config).is_infinite());
        assert_eq!(protective_length_m(0.0, &config), 0.1);
    }
}
