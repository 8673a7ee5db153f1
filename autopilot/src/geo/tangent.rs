//! The ellipsoidal local tangent plane: WGS-84 → ECEF → NED about the
//! origin, the point taken at the origin's height (a ground vehicle's map is
//! flat; its own height is not a horizontal position).

use map_3d::{Ellipsoid as Map3dEllipsoid, enu2uvw, geodetic2ned, ned2geodetic, uvw2enu};

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

/// The local (north, east) of a unit step toward true north and toward true
/// east at `at`: rows local (north, east), columns true (north, east).
///
/// The frame is a linear projection of ECEF onto the origin's tangent plane,
/// so this is its exact Jacobian: the ECEF directions of true north and east
/// at `at`, projected. Nothing divides by cos φ, so it holds at a pole,
/// where "true north" is taken as the limit along the meridian of `at`'s
/// longitude (at 90° N north points along the meridian λ + 180°), as a
/// receiver computing a heading at that reported position does.
pub fn true_axes(origin: &GeoPoint, at: &GeoPoint) -> [[f64; 2]; 2] {
    let (lat0, lon0) = (origin.lat_deg.to_radians(), origin.lon_deg.to_radians());
    let (lat, lon) = (at.lat_deg.to_radians(), at.lon_deg.to_radians());
    let column = |east: f64, north: f64| {
        let (x, y, z) = enu2uvw(east, north, 0.0, lat, lon);
        let (e, n, _up) = uvw2enu(x, y, z, lat0, lon0);
        (n, e)
    };
    let (nn, en) = column(0.0, 1.0);
    let (ne, ee) = column(1.0, 0.0);
    [[nn, ne], [en, ee]]
}

/// ECEF unit vectors of true north and true east at a latitude/longitude
/// (the pole's limit convention of [`true_axes`]).
pub fn north_east_ecef(lat_deg: f64, lon_deg: f64) -> ([f64; 3], [f64; 3]) {
    let (lat, lon) = (lat_deg.to_radians(), lon_deg.to_radians());
    let (nx, ny, nz) = enu2uvw(0.0, 1.0, 0.0, lat, lon);
    let (ex, ey, ez) = enu2uvw(1.0, 0.0, 0.0, lat, lon);
    ([nx, ny, nz], [ex, ey, ez])
}
