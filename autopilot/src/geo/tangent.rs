//! The ellipsoidal local tangent plane: WGS-84 → ECEF → NED about the
//! origin, the point taken at the origin's height (a ground vehicle's map is
//! flat; its own height is not a horizontal position).

use map_3d::{Ellipsoid as Map3dEllipsoid, geodetic2ned, ned2geodetic};

use super::{GeoPoint, Ned};

/// Horizontal NED of `p` at the origin's height.
pub fn to_local(origin: &GeoPoint, p: &GeoPoint) -> Ned {
    let (n, e, _d) = geodetic2ned(
        p.lat_deg.to_radians(),
        p.lon_deg.to_radians(),
        origin.alt_m,
        origin.lat_deg.to_radians(),
        origin.lon_deg.to_radians(),
        origin.alt_m,
        Map3dEllipsoid::WGS84,
    );
    Ned::new(n, e)
}

/// The point at the origin's height whose [`to_local`] is `local`
/// (latitude, longitude in degrees).
///
/// That point lies on the vertical of the origin's NED frame through
/// (north, east): only its down coordinate is unknown. Each step moves down
/// by the height still above the origin's; the height changes by cos θ per
/// metre down (θ the angle between the two verticals, d/R), so the residual
/// shrinks by 1 − cos θ ≈ 3e-5 per step at 50 km: four steps reach
/// nanometres. Working in ECEF keeps this sound at the poles, where a
/// latitude/longitude Newton step would divide by cos φ.
pub fn to_geodetic(origin: &GeoPoint, local: &Ned) -> (f64, f64) {
    let (lat0, lon0) = (origin.lat_deg.to_radians(), origin.lon_deg.to_radians());
    let mut down_m = 0.0;
    let mut lat_lon = (f64::NAN, f64::NAN);
    for _ in 0..12 {
        let (lat, lon, h) = ned2geodetic(
            local.north_m,
            local.east_m,
            down_m,
            lat0,
            lon0,
            origin.alt_m,
            Map3dEllipsoid::WGS84,
        );
        lat_lon = (lat.to_degrees(), lon.to_degrees());
        let above_m = h - origin.alt_m;
        down_m += above_m;
        if above_m.is_nan() || above_m.abs() <= 1e-10 {
            break;
        }
    }
    lat_lon
}
