//! The VDA 5050 map frame and the vehicle's local frame.
//!
//! VDA 5050 positions are `x`, `y` in metres and `theta` in radians, right
//! handed: x east, y north, theta counter-clockwise from x (§6.6.6's
//! `nodePosition`, the project's map). Furrow's local frame is north/east
//! with headings clockwise from north, about the vehicle's first fix.
//!
//! A fleet shares one map, so the map frame cannot be about each vehicle's
//! own first fix: with a map origin configured ([`MapFrame::new`]), the map
//! frame is the plant grid about that fixed geodetic point — the frame the
//! vehicle would build (`GEO_FRAME`, and `GEO_MAP_*` when enabled) had its
//! first fix been there — and positions pass through WGS-84 between the
//! two. Every vehicle with the same map configuration then gives the same
//! map coordinates for the same place. Without one, the map frame is the
//! local frame with its axes named the VDA way (one vehicle on its own).

use std::f64::consts::FRAC_PI_2;

use crate::geo::{FrameKind, GeoPoint, LocalFrame, Ned, PlaneTransform, wrap_pi};

/// A pose in the map frame (m, rad counter-clockwise from east).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapPose {
    pub x_m: f64,
    pub y_m: f64,
    pub theta_rad: f64,
}

/// The local position of a map point.
pub fn local_from_map(x_m: f64, y_m: f64) -> Ned {
    Ned::new(y_m, x_m)
}

/// A local yaw (clockwise from north) from a map theta.
pub fn yaw_from_theta(theta_rad: f64) -> f64 {
    wrap_pi(FRAC_PI_2 - theta_rad)
}

/// The map pose of a local position and yaw.
pub fn map_from_local(position: &Ned, yaw_rad: f64) -> MapPose {
    MapPose {
        x_m: position.east_m,
        y_m: position.north_m,
        theta_rad: wrap_pi(FRAC_PI_2 - yaw_rad),
    }
}

/// The map frame: a plant grid about a fixed geodetic origin, or the
/// vehicle's local frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapFrame {
    grid: Option<LocalFrame>,
}

impl MapFrame {
    /// The map frame about `origin` (projection `kind`, then `transform`),
    /// or, without an origin, the vehicle's local frame.
    pub fn new(origin: Option<GeoPoint>, kind: FrameKind, transform: Option<PlaneTransform>) -> Self {
        MapFrame {
            grid: origin.map(|o| LocalFrame::with_kind(kind, o, transform)),
        }
    }

    /// Whether the map frame is fixed, not about the vehicle's first fix.
    pub fn is_fixed(&self) -> bool {
        self.grid.is_some()
    }

    /// The local position of a map point; `None` before the vehicle has a
    /// local frame to put it in.
    pub fn to_local(&self, local: Option<&LocalFrame>, x_m: f64, y_m: f64) -> Option<Ned> {
        let in_map = local_from_map(x_m, y_m);
        match (&self.grid, local) {
            (None, _) => Some(in_map),
            (Some(grid), Some(local)) => Some(local.to_local(&grid.to_geodetic(&in_map))),
            (Some(_), None) => None,
        }
    }

    /// The map pose of a local position and yaw (the heading turned by the
    /// meridians' convergence and the grid's rotation between the frames).
    pub fn pose(&self, local: Option<&LocalFrame>, position: &Ned, yaw_rad: f64) -> Option<MapPose> {
        match (&self.grid, local) {
            (None, _) => Some(map_from_local(position, yaw_rad)),
            (Some(grid), Some(local)) => {
                let at = local.to_geodetic(position);
                let true_heading_rad = local.heading_to_true(&at, yaw_rad);
                Some(map_from_local(
                    &grid.to_local(&at),
                    grid.heading_to_local(&at, true_heading_rad),
                ))
            }
            (Some(_), None) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;

    #[test]
    fn map_x_is_east_and_theta_turns_counter_clockwise_from_east() {
        let p = local_from_map(3.0, 4.0);
        assert_eq!((p.north_m, p.east_m), (4.0, 3.0));
        // theta 0 faces east: yaw 90° clockwise from north.
        assert!((yaw_from_theta(0.0) - FRAC_PI_2).abs() < 1e-12);
        // theta 90° faces north: yaw 0.
        assert!(yaw_from_theta(FRAC_PI_2).abs() < 1e-12);
        // theta 180° faces west: yaw -90°.
        assert!((yaw_from_theta(PI) + FRAC_PI_2).abs() < 1e-12);
    }

    /// Two vehicles whose first fixes are 40 m apart, on one plant grid
    /// (shifted, turned 30°) about a fixed origin: the same place has the
    /// same map coordinates on both, and map points land on the same place.
    #[test]
    fn vehicles_with_different_first_fixes_share_the_map_frame() {
        let origin = GeoPoint::new(29.133, 119.64, 40.0);
        let transform = PlaneTransform {
            shift_north_m: 1500.0,
            shift_east_m: -250.0,
            rotation_rad: 30f64.to_radians(),
            scale: 1.0,
        };
        let map = MapFrame::new(Some(origin), FrameKind::TangentPlane, Some(transform));
        let grid = LocalFrame::with_kind(FrameKind::TangentPlane, origin, Some(transform));
        let first_fixes = [
            GeoPoint::new(29.1331, 119.6401, 40.0),
            GeoPoint::new(29.1334, 119.6399, 41.0),
        ];
        let frames = first_fixes.map(|fix| LocalFrame::with_kind(FrameKind::TangentPlane, fix, Some(transform)));
        let place = GeoPoint::new(29.1332, 119.6402, 40.0);
        // Facing true north-east at `place`.
        let true_heading = 45f64.to_radians();
        let expected = map_from_local(&grid.to_local(&place), grid.heading_to_local(&place, true_heading));
        for frame in &frames {
            let local = frame.to_local(&place);
            let yaw = frame.heading_to_local(&place, true_heading);
            let pose = map.pose(Some(frame), &local, yaw).expect("a pose");
            assert!(
                (pose.x_m - expected.x_m).abs() < 1e-6 && (pose.y_m - expected.y_m).abs() < 1e-6,
                "{pose:?}"
            );
            assert!(wrap_pi(pose.theta_rad - expected.theta_rad).abs() < 1e-9, "{pose:?}");
            let back = map
                .to_local(Some(frame), expected.x_m, expected.y_m)
                .expect("a local point");
            assert!(back.distance_to(&local) < 1e-6, "{back:?} vs {local:?}");
        }
        // The map's own numbers: the grid's, not a first fix's.
        assert!((expected.y_m - grid.to_local(&place).north_m).abs() < 1e-12);
        assert!(map.to_local(None, 0.0, 0.0).is_none(), "no local frame yet");
    }

    #[test]
    fn without_an_origin_the_map_frame_is_the_local_frame() {
        let map = MapFrame::new(None, FrameKind::TangentPlane, None);
        assert!(!map.is_fixed());
        let p = map.to_local(None, 3.0, 4.0).expect("always");
        assert_eq!((p.north_m, p.east_m), (4.0, 3.0));
        let pose = map.pose(None, &p, 0.0).expect("always");
        assert_eq!((pose.x_m, pose.y_m), (3.0, 4.0));
    }

    #[test]
    fn map_and_local_round_trip() {
        for (x, y, theta) in [(1.5, -2.0, 0.3), (-7.0, 12.0, -2.9), (0.0, 0.0, 3.1)] {
            let yaw = yaw_from_theta(theta);
            let pose = map_from_local(&local_from_map(x, y), yaw);
            assert!((pose.x_m - x).abs() < 1e-12 && (pose.y_m - y).abs() < 1e-12);
            assert!(wrap_pi(pose.theta_rad - theta).abs() < 1e-12);
        }
    }
}
