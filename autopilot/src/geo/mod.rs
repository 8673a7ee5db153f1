//! Local frames from latitude/longitude (docs/architecture.md §Frames).
//!
//! Inside the core every position is metres north/east of an origin (NED,
//! the same axes MAVLink's local frames use), and every heading is radians
//! from north, clockwise. [`LocalFrame`] converts from WGS-84 with one of
//! three projections ([`FrameKind`], parameter `GEO_FRAME`):
//!
//! - the ellipsoidal local tangent plane (geodetic → ECEF → NED about the
//!   origin, at the origin's height): the default, with none of the ≈0.3 %
//!   scale error of a spherical-earth frame ([`tangent`]);
//! - seed 000's spherical haversine frame, R = 6371 km ([`haversine`]);
//! - seed 001's Gauss–Krüger grid on a chosen ellipsoid, relative to the
//!   origin's grid position ([`gauss_kruger`]);
//!
//! optionally followed by seed 001's 4-parameter plane transform into a
//! site's plant grid ([`PlaneTransform`], `GEO_MAP_*`).
//!
//! # Measured error at the bench (29.133° N, 119.64° E, 40 m)
//!
//! Worst case over eight bearings, from `cargo test -p autopilot --test
//! geo_frames error_table -- --nocapture` against PROJ's exact values
//! (`tests/data/geo`). *Position* is the distance from the exact local
//! tangent-plane position (PROJ's geodetic → ECEF → topocentric), *distance*
//! the error of the frame's distance from the origin against the geodesic
//! distance at the origin's height (what a wheel on the ground measures).
//!
//! | frame | 100 m: position | 100 m: distance | 1 km: position | 1 km: distance | 10 km: position | 10 km: distance |
//! |---|---:|---:|---:|---:|---:|---:|
//! | tangent plane (`GEO_FRAME=0`) | < 0.001 mm | < 0.001 mm (< 0.001 ppm) | < 0.001 mm | -0.00417 mm (-0.00417 ppm) | < 0.001 mm | -4.13 mm (-0.413 ppm) |
//! | haversine, eq. 3 (`GEO_FRAME=1`) | 321 mm | +321 mm (+3214 ppm) | 3215 mm | +3215 mm (+3215 ppm) | 32214 mm | +32209 mm (+3221 ppm) |
//! | Gauss–Krüger WGS-84 (`=2`) | 0.630 mm | -0.630 mm (-6.30 ppm) | 6.29 mm | -6.30 mm (-6.30 ppm) | 58.9 mm | -63.0 mm (-6.30 ppm) |
//! | Gauss–Krüger IAG-75 | 0.583 mm | -0.583 mm (-5.83 ppm) | 5.83 mm | -5.83 mm (-5.83 ppm) | 54.2 mm | -58.3 mm (-5.83 ppm) |
//! | Gauss–Krüger Krassovsky | 1.13 mm | +1.13 mm (+11.3 ppm) | 11.3 mm | +11.3 mm (+11.3 ppm) | 117 mm | +113 mm (+11.3 ppm) |
//! | Gauss–Krüger WGS-84, 120° E zone meridian | 306 mm | +0.892 mm (+8.92 ppm) | 3059 mm | +9.31 mm (+9.31 ppm) | 30633 mm | +136 mm (+13.6 ppm) |
//!
//! The implementations themselves agree with PROJ to 7e-8 m (the fixtures'
//! rounding) for every origin out to 50 km, and the Gauss–Krüger grid to
//! 7e-8 m from 80° S to 80° N within ±3.5° of the central meridian; every
//! kind's `to_geodetic` undoes `to_local` to 1e-8 m out to 50 km.
//!
//! Why: the tangent plane *is* the exact reference for position; its distance
//! error is the plane's foreshortening, s³/(6R²). The haversine frame's error
//! is its sphere: north scale R/M − 1 = +0.323 %, east R/N − 1 = −0.190 %
//! (M, N the WGS-84 radii of curvature), plus the missing parallel curvature
//! (≈ east²·tan φ/(2R)); that is the worst bearing (north) above, east is
//! −0.19 %. Gauss–Krüger is conformal with scale 1 on the central meridian:
//! it projects the ellipsoid, not the ground 40 m above it (−h/R = −6.3 ppm,
//! which a plant-grid transform's fitted scale absorbs), plus the grid scale
//! (1 + east²/(2R²)); on IAG-75 and Krassovsky the WGS-84 latitude/longitude
//! are used as they are, so their different radii add +0.5 and +17.6 ppm.
//! With a zone meridian 0.36° away the grid axes are turned by the meridian
//! convergence (0.175°, hence metres of "position" error) and scaled by
//! +15 ppm: such a frame is only useful behind a fitted plane transform.
//!
//! Headings: true north at a point away from the origin is not the frame's
//! north axis in any of these frames (meridian convergence, ≈ east·tan φ/N:
//! 0.005° at 1 km, 0.05° at 10 km east of the bench origin, against the
//! ±0.1° bar of seed 000); [`LocalFrame::heading_to_local`] converts.
//! For the tangent plane that conversion is exact and has no cos φ in it
//! (true north and east at the point, in ECEF, projected onto the origin's
//! plane), so it holds beside and at a pole, where true north is the limit
//! along the given longitude's meridian; the other kinds take central
//! differences along true north and east stepped in ECEF.
//!
//! # Any latitude
//!
//! `tests/data/geo/polar.csv` (PROJ, GeographicLib) has origins at both
//! poles, 5 m, 111 m, 1 km and 1.1 km from them, on and beside ±180° and at
//! 0°, 0°, with points out to 1 km (across the pole from the origins beside
//! it). Worst errors over it: tangent plane 5.7e-8 m (`to_local`), 5.8e-8 m
//! (`to_geodetic`), headings 1.2e-7°; Gauss–Krüger (WGS-84, central meridian
//! at the origin) 5.4e-8 m, headings 1.6e-7° — the fixtures' own rounding.
//! The haversine frame is not used within [`HAVERSINE_MAX_ABS_LAT_DEG`] of a
//! pole ([`FrameKind::usable_at`]).
//!
//! Sources: docs/references.md §Seed 000, docs/references.md §Seed 001.

pub mod ellipsoid;
pub mod frame;
pub mod gauss_kruger;
pub mod haversine;
pub mod params;
pub mod plane;
pub mod tangent;

pub use ellipsoid::Ellipsoid;
pub use frame::{FrameKind, HAVERSINE_MAX_ABS_LAT_DEG, LocalFrame};
pub use gauss_kruger::{TransverseMercator, ZoneWidth, zone_meridian_deg};
pub use params::{GeoParams, frame_from_params};
pub use plane::PlaneTransform;
pub use vehicle_types::GeoPoint;

/// A point in the local frame, metres.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Ned {
    pub north_m: f64,
    pub east_m: f64,
}

impl Ned {
    pub const fn new(north_m: f64, east_m: f64) -> Self {
        Ned { north_m, east_m }
    }

    pub fn distance_to(&self, other: &Ned) -> f64 {
        (other.north_m - self.north_m).hypot(other.east_m - self.east_m)
    }

    /// Bearing from `self` to `other`, radians from north, clockwise.
    pub fn bearing_to(&self, other: &Ned) -> f64 {
        (other.east_m - self.east_m).atan2(other.north_m - self.north_m)
    }
}

/// Wraps an angle to [-π, π).
pub fn wrap_pi(angle_rad: f64) -> f64 {
    wrap_2pi(angle_rad + std::f64::consts::PI) - std::f64::consts::PI
}

/// Wraps an angle to [0, 2π).
pub fn wrap_2pi(angle_rad: f64) -> f64 {
    // `rem_euclid` returns an angle already in range unchanged, but costs a
    // libm `fmod` call; the core wraps several angles per scan return.
    if (0.0..std::f64::consts::TAU).contains(&angle_rad) {
        return angle_rad;
    }
    angle_rad.rem_euclid(std::f64::consts::TAU)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_is_sub_millimetre_over_a_site() {
        let frame = LocalFrame::new(GeoPoint::new(29.133, 119.64, 40.0));
        for &(n, e) in &[(0.0, 0.0), (60.0, 40.0), (-500.0, 1200.0), (3000.0, -2500.0)] {
            let g = frame.to_geodetic(&Ned::new(n, e));
            let back = frame.to_local(&g);
            assert!((back.north_m - n).abs() < 1e-6, "{n} → {}", back.north_m);
            assert!((back.east_m - e).abs() < 1e-6, "{e} → {}", back.east_m);
        }
    }

    #[test]
    fn a_degree_of_latitude_is_about_110_9_km_at_29_degrees() {
        let frame = LocalFrame::new(GeoPoint::new(29.0, 119.0, 0.0));
        let n = frame.to_local(&GeoPoint::new(29.001, 119.0, 0.0)).north_m;
        // Meridian arc per 0.001° at 29° N on WGS-84 ≈ 110.87 m.
        assert!((n - 110.87).abs() < 0.05, "{n}");
    }

    #[test]
    fn wrapping() {
        use std::f64::consts::PI;
        assert!((wrap_pi(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
        assert!((wrap_pi(-PI) + PI).abs() < 1e-12);
        assert!((wrap_2pi(-PI / 2.0) - 3.0 * PI / 2.0).abs() < 1e-12);
    }
}
