//! The ellipsoidal local tangent plane: WGS-84 → ECEF → NED about the
//! origin, the point taken at the origin's height (a ground vehicle's map is
//! flat; its own height is not a horizontal position).

use std::cell::Cell;

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
///
/// A step asks for the same point several times (the fleet's map pose
/// twice, the onboard log's pose and heading, telemetry), each a few dozen
/// libm calls: the last few answers on this thread are kept, keyed by the
/// exact bits of the origin and the point, so a repeat returns the same
/// value without converting again.
pub fn to_geodetic(origin: &GeoPoint, local: &Ned) -> (f64, f64) {
    let key = [
        origin.lat_deg.to_bits(),
        origin.lon_deg.to_bits(),
        origin.alt_m.to_bits(),
        local.north_m.to_bits(),
        local.east_m.to_bits(),
    ];
    RECENT_TO_GEODETIC.with(|recent| {
        let mut answers = recent.get();
        if let Some(answer) = answers.iter().flatten().find(|a| a.key == key) {
            return answer.lat_lon_deg;
        }
        let lat_lon_deg = convert_to_geodetic(origin, local);
        answers.rotate_right(1);
        answers[0] = Some(Answer { key, lat_lon_deg });
        recent.set(answers);
        lat_lon_deg
    })
}

/// How many of [`to_geodetic`]'s last answers are kept (per thread): a
/// step's own point and one other asked for in between.
const RECENT_ANSWERS: usize = 2;

/// One answer of [`to_geodetic`]: the bits of its origin (latitude,
/// longitude, height) and point (north, east), and the latitude and
/// longitude.
#[derive(Clone, Copy)]
struct Answer {
    key: [u64; 5],
    lat_lon_deg: (f64, f64),
}

thread_local! {
    static RECENT_TO_GEODETIC: Cell<[Option<Answer>; RECENT_ANSWERS]> = const { Cell::new([None; RECENT_ANSWERS]) };
}

/// [`to_geodetic`] worked out.
fn convert_to_geodetic(origin: &GeoPoint, local: &Ned) -> (f64, f64) {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_repeated_point_gets_the_answer_of_a_fresh_conversion() {
        let bits = |(lat, lon): (f64, f64)| (lat.to_bits(), lon.to_bits());
        let origins = [GeoPoint::new(31.2, 121.5, 12.0), GeoPoint::new(-33.9, 151.2, 0.0)];
        // -0.0 and 0.0 are different keys; 4 km out takes several steps.
        let points = [
            Ned::new(120.0, -35.5),
            Ned::new(-0.0, 0.0),
            Ned::new(0.0, 0.0),
            Ned::new(4000.0, 2500.0),
        ];
        for round in 0..3 {
            for origin in &origins {
                for point in points.iter().cycle().skip(round).take(points.len() + 2) {
                    let fresh = convert_to_geodetic(origin, point);
                    assert_eq!(bits(to_geodetic(origin, point)), bits(fresh));
                    assert_eq!(bits(to_geodetic(origin, point)), bits(fresh));
                }
            }
        }
        // The answer is the point's: a kept one is not given for another.
        let (near, far) = (Ned::new(10.0, 0.0), Ned::new(11.0, 0.0));
        assert_ne!(to_geodetic(&origins[0], &near), to_geodetic(&origins[0], &far));
        assert_ne!(to_geodetic(&origins[0], &near), to_geodetic(&origins[1], &near));
    }
}
