//! Local frames from latitude/longitude.
//!
//! Inside the core every position is metres north/east of an origin (NED,
//! the same axes MAVLink's local frames use), and every heading is radians
//! from north, clockwise. The conversion from WGS-84 is an ellipsoidal local
//! tangent plane (geodetic → ECEF → NED about the origin), which has none of
//! the ≈0.3 % scale error of a spherical-earth frame.

use map_3d::{Ellipsoid, geodetic2ned, ned2geodetic};

/// A WGS-84 position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeoPoint {
    pub lat_deg: f64,
    pub lon_deg: f64,
    /// Altitude above mean sea level.
    pub alt_m: f64,
}

impl GeoPoint {
    pub fn new(lat_deg: f64, lon_deg: f64, alt_m: f64) -> Self {
        GeoPoint {
            lat_deg,
            lon_deg,
            alt_m,
        }
    }

    /// Whether this is a position on the earth (finite, in range).
    pub fn is_valid(&self) -> bool {
        self.lat_deg.is_finite()
            && self.lon_deg.is_finite()
            && self.alt_m.is_finite()
            && self.lat_deg.abs() <= 90.0
            && self.lon_deg.abs() <= 180.0
    }

    /// MAVLink's integer degrees × 1e7.
    pub fn lat_e7(&self) -> i32 {
        (self.lat_deg * 1e7).round() as i32
    }

    pub fn lon_e7(&self) -> i32 {
        (self.lon_deg * 1e7).round() as i32
    }

    pub fn from_e7(lat_e7: i32, lon_e7: i32, alt_m: f64) -> Self {
        GeoPoint {
            lat_deg: f64::from(lat_e7) * 1e-7,
            lon_deg: f64::from(lon_e7) * 1e-7,
            alt_m,
        }
    }
}

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

/// The tangent plane at an origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalFrame {
    origin: GeoPoint,
}

impl LocalFrame {
    pub fn new(origin: GeoPoint) -> Self {
        LocalFrame { origin }
    }

    pub fn origin(&self) -> GeoPoint {
        self.origin
    }

    /// Horizontal position of `p` in this frame (its height is ignored: a
    /// ground vehicle's map is the tangent plane).
    pub fn to_local(&self, p: &GeoPoint) -> Ned {
        let (n, e, _d) = geodetic2ned(
            p.lat_deg.to_radians(),
            p.lon_deg.to_radians(),
            self.origin.alt_m,
            self.origin.lat_deg.to_radians(),
            self.origin.lon_deg.to_radians(),
            self.origin.alt_m,
            Ellipsoid::WGS84,
        );
        Ned::new(n, e)
    }

    /// The WGS-84 position of a local point, at the origin's altitude: the
    /// exact inverse of [`LocalFrame::to_local`].
    pub fn to_geodetic(&self, p: &Ned) -> GeoPoint {
        let (lat0, lon0) = (self.origin.lat_deg.to_radians(), self.origin.lon_deg.to_radians());
        let (lat, lon, _) = ned2geodetic(
            p.north_m,
            p.east_m,
            0.0,
            lat0,
            lon0,
            self.origin.alt_m,
            Ellipsoid::WGS84,
        );
        // ned2geodetic lands on the tangent plane (above the ellipsoid away
        // from the origin); to_local projects at the origin's altitude.
        // Two Newton steps on the local radii close that to nanometres.
        let mut guess = GeoPoint::new(lat.to_degrees(), lon.to_degrees(), self.origin.alt_m);
        for _ in 0..2 {
            let back = self.to_local(&guess);
            let (meridian_m, normal_m) = radii_of_curvature(guess.lat_deg.to_radians());
            guess.lat_deg += ((p.north_m - back.north_m) / meridian_m).to_degrees();
            guess.lon_deg += ((p.east_m - back.east_m) / (normal_m * guess.lat_deg.to_radians().cos())).to_degrees();
        }
        guess
    }
}

/// WGS-84 meridian and prime-vertical radii of curvature at a latitude.
fn radii_of_curvature(lat_rad: f64) -> (f64, f64) {
    const A: f64 = 6_378_137.0;
    const E2: f64 = 6.694_379_990_141_317e-3;
    let w = (1.0 - E2 * lat_rad.sin().powi(2)).sqrt();
    (A * (1.0 - E2) / (w * w * w), A / w)
}

/// Wraps an angle to [-π, π).
pub fn wrap_pi(angle_rad: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    let a = (angle_rad + std::f64::consts::PI).rem_euclid(two_pi);
    a - std::f64::consts::PI
}

/// Wraps an angle to [0, 2π).
pub fn wrap_2pi(angle_rad: f64) -> f64 {
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
