//! Exact WGS-84 local frame: NED about the home point, through ECEF.

use map_3d::Ellipsoid;

use super::GeoPoint;

#[derive(Clone, Copy, Debug)]
pub(crate) struct LocalFrame {
    home: GeoPoint,
}

impl LocalFrame {
    pub(crate) fn new(home: GeoPoint) -> Self {
        Self { home }
    }

    pub(crate) fn to_geodetic(self, north_m: f64, east_m: f64, down_m: f64) -> GeoPoint {
        let (lat, lon, alt) = map_3d::ned2geodetic(
            north_m,
            east_m,
            down_m,
            self.home.lat_deg.to_radians(),
            self.home.lon_deg.to_radians(),
            self.home.alt_m,
            Ellipsoid::WGS84,
        );
        GeoPoint {
            lat_deg: lat.to_degrees(),
            lon_deg: lon.to_degrees(),
            alt_m: alt,
        }
    }

    /// (north, east, down) of `p`.
    pub(crate) fn to_local(self, p: &GeoPoint) -> (f64, f64, f64) {
        map_3d::geodetic2ned(
            p.lat_deg.to_radians(),
            p.lon_deg.to_radians(),
            p.alt_m,
            self.home.lat_deg.to_radians(),
            self.home.lon_deg.to_radians(),
            self.home.alt_m,
            Ellipsoid::WGS84,
        )
    }

    /// The true heading (radians from true north at `at`, clockwise) of the
    /// home-frame heading `local_heading_rad`: what a receiver at `at`
    /// reports as its course or dual-antenna heading. The direction goes
    /// through ECEF, so this holds at a pole, where true north is the limit
    /// along the meridian of `at`'s longitude (at 90° N it points along the
    /// meridian λ + 180°), as for a receiver computing its heading in the
    /// local frame of the position it reports.
    pub(crate) fn heading_to_true(self, at: &GeoPoint, local_heading_rad: f64) -> f64 {
        let (sin, cos) = local_heading_rad.sin_cos();
        let (x, y, z) = map_3d::enu2uvw(
            sin,
            cos,
            0.0,
            self.home.lat_deg.to_radians(),
            self.home.lon_deg.to_radians(),
        );
        let (east, north, _up) = map_3d::uvw2enu(x, y, z, at.lat_deg.to_radians(), at.lon_deg.to_radians());
        east.atan2(north)
    }
}
