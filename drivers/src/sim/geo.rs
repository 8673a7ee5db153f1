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
}
