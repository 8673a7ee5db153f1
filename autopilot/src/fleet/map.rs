//! The VDA 5050 map frame and the vehicle's local frame.
//!
//! VDA 5050 positions are `x`, `y` in metres and `theta` in radians, right
//! handed: x east, y north, theta counter-clockwise from x (§6.6.6's
//! `nodePosition`, the project's map). Furrow's local frame is north/east
//! with headings clockwise from north; with `GEO_MAP_ENABLE` it already *is*
//! the site's plant grid (the four-parameter transform is applied when the
//! frame is built, `geo::PlaneTransform`), so the map frame is the local
//! frame with its axes named the VDA way. Without a plant grid, the map frame
//! is the local tangent plane about the first fix.

use std::f64::consts::FRAC_PI_2;

use crate::geo::{Ned, wrap_pi};

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
