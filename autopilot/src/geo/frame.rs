//! [`LocalFrame`]: a projection about an origin, optionally followed by a
//! plant-grid transform.
//!
//! Sources: docs/references.md §Seed 000, docs/references.md §Seed 001.

use map_3d::{Ellipsoid as Map3dEllipsoid, ecef2geodetic, geodetic2ecef};

use super::ellipsoid::Ellipsoid;
use super::gauss_kruger::TransverseMercator;
use super::plane::PlaneTransform;
use super::{GeoPoint, Ned, haversine, tangent, wrap_pi};

/// Which projection a [`LocalFrame`] uses (`GEO_FRAME`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FrameKind {
    /// WGS-84 → ECEF → NED about the origin, at the origin's height.
    #[default]
    TangentPlane,
    /// Seed 000's spherical frame (eq. 1 and 3, R = 6371 km).
    Haversine,
    /// Seed 001's Gauss–Krüger grid on an ellipsoid, minus the origin's grid
    /// position; central meridian through the origin unless given.
    GaussKruger(Ellipsoid),
}

impl FrameKind {
    /// From `GEO_FRAME` and `GEO_ELLIPSOID`; unknown numbers are the tangent
    /// plane and WGS-84.
    pub fn from_params(frame: i8, ellipsoid: i8) -> FrameKind {
        match frame {
            1 => FrameKind::Haversine,
            2 => FrameKind::GaussKruger(Ellipsoid::from_param(ellipsoid)),
            _ => FrameKind::TangentPlane,
        }
    }

    /// The kind a frame about `origin` can use: itself, except seed 000's
    /// haversine frame within [`HAVERSINE_MAX_ABS_LAT_DEG`] of a pole, which
    /// becomes the tangent plane. That frame measures east along each
    /// point's own parallel: around a pole the parallels are small circles,
    /// and a point passing behind the pole (Δλ through ±180°) jumps from
    /// one side of the frame to the other.
    pub fn usable_at(self, origin: &GeoPoint) -> FrameKind {
        match self {
            // A NaN latitude is no place for it either.
            FrameKind::Haversine if origin.lat_deg.abs() <= HAVERSINE_MAX_ABS_LAT_DEG => FrameKind::Haversine,
            FrameKind::Haversine => FrameKind::TangentPlane,
            kind => kind,
        }
    }
}

/// Beyond this latitude (111 km from a pole) the haversine frame is not
/// used (see [`FrameKind::usable_at`]).
pub const HAVERSINE_MAX_ABS_LAT_DEG: f64 = 89.0;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Projection {
    TangentPlane,
    Haversine,
    GaussKruger {
        tm: TransverseMercator,
        /// The origin's grid (north, east), subtracted so local is about it.
        origin_grid_m: (f64, f64),
    },
}

/// Local north/east metres about an origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalFrame {
    origin: GeoPoint,
    projection: Projection,
    /// Frame → plant grid, and its inverse (NaN if it has none).
    map: Option<(PlaneTransform, PlaneTransform)>,
}

/// What an uninvertible map inverts to: every point becomes NaN, so
/// `to_geodetic` reports the problem instead of a wrong position.
const NAN_TRANSFORM: PlaneTransform = PlaneTransform {
    shift_north_m: f64::NAN,
    shift_east_m: f64::NAN,
    rotation_rad: f64::NAN,
    scale: f64::NAN,
};

impl LocalFrame {
    /// The tangent plane at `origin`.
    pub fn new(origin: GeoPoint) -> Self {
        Self::with_kind(FrameKind::TangentPlane, origin, None)
    }

    /// A frame of `kind` about `origin`. With `map`, local positions are in
    /// the plant grid: `to_local` returns `map.apply(projected)`. A map that
    /// cannot be inverted (see [`PlaneTransform::is_valid`]) makes
    /// `to_geodetic` return NaN.
    /// The haversine kind is replaced near a pole ([`FrameKind::usable_at`]);
    /// [`LocalFrame::kind`] tells which kind was built.
    pub fn with_kind(kind: FrameKind, origin: GeoPoint, map: Option<PlaneTransform>) -> Self {
        match kind.usable_at(&origin) {
            FrameKind::TangentPlane => Self::build(origin, Projection::TangentPlane, map),
            FrameKind::Haversine => Self::build(origin, Projection::Haversine, map),
            FrameKind::GaussKruger(ellipsoid) => Self::gauss_kruger(ellipsoid, origin.lon_deg, origin, map),
        }
    }

    /// A Gauss–Krüger frame with an explicit central meridian (a national
    /// grid's 3° or 6° zone meridian, see [`super::zone_meridian_deg`]).
    /// Local axes are then grid north/east, turned from true north by the
    /// meridian convergence at the origin (≈ Δλ·sin φ: 0.18° at the bench
    /// for the 120° E meridian), and scaled by the grid scale there.
    pub fn gauss_kruger(
        ellipsoid: Ellipsoid,
        central_meridian_deg: f64,
        origin: GeoPoint,
        map: Option<PlaneTransform>,
    ) -> Self {
        let tm = TransverseMercator::new(ellipsoid, central_meridian_deg);
        let origin_grid_m = tm.forward(origin.lat_deg, origin.lon_deg);
        Self::build(origin, Projection::GaussKruger { tm, origin_grid_m }, map)
    }

    fn build(origin: GeoPoint, projection: Projection, map: Option<PlaneTransform>) -> Self {
        let map = map.map(|m| (m, m.invert().unwrap_or(NAN_TRANSFORM)));
        LocalFrame {
            origin,
            projection,
            map,
        }
    }

    pub fn origin(&self) -> GeoPoint {
        self.origin
    }

    pub fn kind(&self) -> FrameKind {
        match self.projection {
            Projection::TangentPlane => FrameKind::TangentPlane,
            Projection::Haversine => FrameKind::Haversine,
            Projection::GaussKruger { tm, .. } => FrameKind::GaussKruger(tm.ellipsoid()),
        }
    }

    /// The Gauss–Krüger central meridian, for that kind only.
    pub fn central_meridian_deg(&self) -> Option<f64> {
        match self.projection {
            Projection::GaussKruger { tm, .. } => Some(tm.central_meridian_deg()),
            _ => None,
        }
    }

    /// The plant-grid transform, if any.
    pub fn map(&self) -> Option<PlaneTransform> {
        self.map.map(|(forward, _)| forward)
    }

    /// Horizontal position of `p` in this frame (its height is ignored: a
    /// ground vehicle's map is the plane).
    pub fn to_local(&self, p: &GeoPoint) -> Ned {
        let projected = match &self.projection {
            Projection::TangentPlane => tangent::to_local(&self.origin, p),
            Projection::Haversine => haversine::to_local(&self.origin, p),
            Projection::GaussKruger { tm, origin_grid_m } => {
                let (north_m, east_m) = tm.forward(p.lat_deg, p.lon_deg);
                Ned::new(north_m - origin_grid_m.0, east_m - origin_grid_m.1)
            }
        };
        match &self.map {
            Some((forward, _)) => forward.apply(&projected),
            None => projected,
        }
    }

    /// The WGS-84 position of a local point, at the origin's altitude: the
    /// inverse of [`LocalFrame::to_local`] (round trip within a micrometre
    /// out to 50 km; tests in `geo_frames.rs`).
    pub fn to_geodetic(&self, p: &Ned) -> GeoPoint {
        let projected = match &self.map {
            Some((_, inverse)) => inverse.apply(p),
            None => *p,
        };
        let (lat_deg, lon_deg) = match &self.projection {
            Projection::TangentPlane => tangent::to_geodetic(&self.origin, &projected),
            Projection::Haversine => haversine::to_geodetic(&self.origin, &projected),
            Projection::GaussKruger { tm, origin_grid_m } => {
                tm.inverse(projected.north_m + origin_grid_m.0, projected.east_m + origin_grid_m.1)
            }
        };
        GeoPoint::new(lat_deg, lon_deg, self.origin.alt_m)
    }

    /// The local heading (radians from the frame's north axis, clockwise) of
    /// a direction at `at` with true heading `true_heading_rad` (GNSS
    /// heading, compass). The two differ away from the origin by the
    /// meridians' convergence, and by the map's rotation.
    pub fn heading_to_local(&self, at: &GeoPoint, true_heading_rad: f64) -> f64 {
        let [[nn, ne], [en, ee]] = self.jacobian(at);
        let (sin, cos) = true_heading_rad.sin_cos();
        wrap_pi((en * cos + ee * sin).atan2(nn * cos + ne * sin))
    }

    /// The true heading of a direction with local heading `local_heading_rad`
    /// at `at`: the inverse of [`LocalFrame::heading_to_local`].
    pub fn heading_to_true(&self, at: &GeoPoint, local_heading_rad: f64) -> f64 {
        let [[nn, ne], [en, ee]] = self.jacobian(at);
        let (sin, cos) = local_heading_rad.sin_cos();
        // Solve J·d = (cos, sin) by the adjugate; the determinant's sign is
        // positive (every kind keeps orientation) and its size cancels.
        let north = ee * cos - ne * sin;
        let east = -en * cos + nn * sin;
        wrap_pi(east.atan2(north))
    }

    /// Local metres per true metre north and east at `at`: rows local
    /// (north, east), columns true (north, east), the map's rotation and
    /// scale included.
    fn jacobian(&self, at: &GeoPoint) -> [[f64; 2]; 2] {
        let projected = match self.projection {
            Projection::TangentPlane => tangent::true_axes(&self.origin, at),
            _ => self.projection_jacobian(at),
        };
        match &self.map {
            Some((forward, _)) => {
                // The map's linear part, s·R(r), applied to each column.
                let (sin, cos) = forward.rotation_rad.sin_cos();
                let s = forward.scale;
                let [[nn, ne], [en, ee]] = projected;
                [
                    [s * (nn * cos - en * sin), s * (ne * cos - ee * sin)],
                    [s * (nn * sin + en * cos), s * (ne * sin + ee * cos)],
                ]
            }
            None => projected,
        }
    }

    /// The projection's Jacobian by central differences, stepping ±10 m
    /// along true north and east in ECEF (so no step divides by cos φ and a
    /// step across a pole stays 10 m long). Central differences cancel the
    /// second-order terms, and the 8 µm each step rises above the ground
    /// is the same either way. The steps start on the ellipsoid: these
    /// projections are functions of latitude and longitude alone, and at a
    /// height h a step's latitude/longitude direction would turn by
    /// h·(1/M − 1/N)·sin 2α / 2 (1e-6° at 250 m).
    fn projection_jacobian(&self, at: &GeoPoint) -> [[f64; 2]; 2] {
        const STEP_M: f64 = 10.0;
        let (north_axis, east_axis) = tangent::north_east_ecef(at.lat_deg, at.lon_deg);
        let (x, y, z) = geodetic2ecef(
            at.lat_deg.to_radians(),
            at.lon_deg.to_radians(),
            0.0,
            Map3dEllipsoid::WGS84,
        );
        let projected_at = |sign: f64, axis: [f64; 3]| {
            let (lat, lon, alt) = ecef2geodetic(
                x + sign * STEP_M * axis[0],
                y + sign * STEP_M * axis[1],
                z + sign * STEP_M * axis[2],
                Map3dEllipsoid::WGS84,
            );
            let p = GeoPoint::new(lat.to_degrees(), lon.to_degrees(), alt);
            match &self.projection {
                Projection::TangentPlane => tangent::to_local(&self.origin, &p),
                Projection::Haversine => haversine::to_local(&self.origin, &p),
                Projection::GaussKruger { tm, .. } => {
                    let (north_m, east_m) = tm.forward(p.lat_deg, p.lon_deg);
                    Ned::new(north_m, east_m)
                }
            }
        };
        let column = |axis: [f64; 3]| {
            let (plus, minus) = (projected_at(1.0, axis), projected_at(-1.0, axis));
            let scale = 1.0 / (2.0 * STEP_M);
            (
                (plus.north_m - minus.north_m) * scale,
                (plus.east_m - minus.east_m) * scale,
            )
        };
        let (nn, en) = column(north_axis);
        let (ne, ee) = column(east_axis);
        [[nn, ne], [en, ee]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BENCH: GeoPoint = GeoPoint {
        lat_deg: 29.133,
        lon_deg: 119.64,
        alt_m: 40.0,
    };

    #[test]
    fn every_kind_reports_itself_and_puts_the_origin_at_zero() {
        for kind in [
            FrameKind::TangentPlane,
            FrameKind::Haversine,
            FrameKind::GaussKruger(Ellipsoid::Wgs84),
            FrameKind::GaussKruger(Ellipsoid::Krassovsky),
        ] {
            let frame = LocalFrame::with_kind(kind, BENCH, None);
            assert_eq!(frame.kind(), kind);
            assert!(frame.to_local(&BENCH).distance_to(&Ned::default()) < 1e-9, "{kind:?}");
            assert_eq!(frame.to_geodetic(&Ned::default()).alt_m, BENCH.alt_m);
        }
        assert_eq!(LocalFrame::new(BENCH).kind(), FrameKind::TangentPlane);
        assert_eq!(LocalFrame::new(BENCH).central_meridian_deg(), None);
        let zone = LocalFrame::gauss_kruger(Ellipsoid::Iag75, 120.0, BENCH, None);
        assert_eq!(zone.central_meridian_deg(), Some(120.0));
        assert_eq!(zone.kind(), FrameKind::GaussKruger(Ellipsoid::Iag75));
    }

    #[test]
    fn the_map_applies_after_the_projection() {
        let map = PlaneTransform {
            shift_north_m: 100.0,
            shift_east_m: 200.0,
            rotation_rad: 1.0,
            scale: 1.01,
        };
        let plain = LocalFrame::new(BENCH);
        let mapped = LocalFrame::with_kind(FrameKind::TangentPlane, BENCH, Some(map));
        let p = GeoPoint::new(29.14, 119.65, 0.0);
        assert!(mapped.to_local(&p).distance_to(&map.apply(&plain.to_local(&p))) < 1e-9);
        let back = mapped.to_geodetic(&mapped.to_local(&p));
        assert!((back.lat_deg - p.lat_deg).abs() < 1e-12 && (back.lon_deg - p.lon_deg).abs() < 1e-12);
        assert_eq!(mapped.map(), Some(map));
        assert_eq!(plain.map(), None);
    }

    #[test]
    fn the_haversine_frame_gives_way_to_the_tangent_plane_near_a_pole() {
        for lat in [-90.0, -89.5, 89.01, 90.0, f64::NAN] {
            let frame = LocalFrame::with_kind(FrameKind::Haversine, GeoPoint::new(lat, 10.0, 0.0), None);
            assert_eq!(frame.kind(), FrameKind::TangentPlane, "{lat}");
        }
        for lat in [-89.0, 0.0, 88.99] {
            let frame = LocalFrame::with_kind(FrameKind::Haversine, GeoPoint::new(lat, 10.0, 0.0), None);
            assert_eq!(frame.kind(), FrameKind::Haversine, "{lat}");
        }
        let gk = FrameKind::GaussKruger(Ellipsoid::Wgs84);
        assert_eq!(gk.usable_at(&GeoPoint::new(90.0, 0.0, 0.0)), gk);
    }

    #[test]
    fn frame_kinds_from_params() {
        assert_eq!(FrameKind::from_params(0, 2), FrameKind::TangentPlane);
        assert_eq!(FrameKind::from_params(1, 0), FrameKind::Haversine);
        assert_eq!(
            FrameKind::from_params(2, 2),
            FrameKind::GaussKruger(Ellipsoid::Krassovsky)
        );
        assert_eq!(FrameKind::from_params(9, 0), FrameKind::TangentPlane);
    }
}
