//! Collision prediction (seed 004 §III.C, eq. 13–17), corrected.
//!
//! The obstacle is a disc of `track.radius_m + margin_m`; the vehicle is its
//! [`Footprint`] rectangle. In the vehicle's body frame, with the relative
//! velocity held constant, the disc's centre moves along a ray; the disc
//! touches the rectangle exactly when the centre enters the rectangle grown
//! by the disc's radius with rounded corners (their Minkowski sum: two
//! rectangles, one grown along x and one along y, and a disc at each corner).
//! The first entry time along that ray is the collision time.
//!
//! Corrections to the seed, each applied here:
//! - Eq. 13, V_OA = V_O − V_A, is right in the local (non-rotating) frame; it
//!   is formed there and then rotated into the body frame once, at the
//!   current heading. The vehicle's turning is ignored: both move in straight
//!   lines over the horizon, so the prediction is for the current velocity
//!   only and is redone every scan.
//! - Eq. 14–15 cast three lines (the two edge points and the nearest point of
//!   the obstacle) along V_OA and test them against the footprint's four
//!   edges. The edge points are the cluster's ends as the scanner sees them,
//!   not the extremes across the direction of relative motion, and the
//!   nearest point changes as the obstacle moves, so an obstacle whose body
//!   sweeps over a footprint corner while all three lines pass beside it (a
//!   grazing contact) is missed. The exact test above has no such gap.
//! - Eq. 16, t_c = l_min / |V_OAx|, divides the shortest distance (not the
//!   distance along the motion) by the x component only: it is wrong for any
//!   oblique approach and divides by zero for a pure crossing in the seed's
//!   frame. The time is the distance along the ray over |V_OA|, which is the
//!   ray parameter itself.
//! - Eq. 17, P_c = V_A · t_c, is the vehicle's displacement, not a place; the
//!   vehicle's current position is added to give the place in the local frame.
//!
//! Sources: docs/references.md §Seed 004.

use super::{Footprint, Pose, Track};
use crate::geo::Ned;

/// Below this relative speed the obstacle and the vehicle are taken to be at
/// rest relative to each other: no crossing time exists.
const MIN_RELATIVE_SPEED_MPS: f64 = 1e-9;

/// The vehicle's pose and velocity in the local frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VehicleMotion {
    pub pose: Pose,
    pub vel_north_mps: f64,
    pub vel_east_mps: f64,
}

impl VehicleMotion {
    /// Motion along the heading at a signed speed (reversing is negative).
    pub fn along_heading(pose: Pose, speed_mps: f64) -> Self {
        let (sin_yaw, cos_yaw) = pose.yaw_rad.sin_cos();
        VehicleMotion {
            pose,
            vel_north_mps: speed_mps * cos_yaw,
            vel_east_mps: speed_mps * sin_yaw,
        }
    }
}

/// Where and when a track would first touch the vehicle's outline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CollisionPrediction {
    pub track_id: u32,
    /// t_c, seconds from now; 0 when already overlapping.
    pub time_s: f64,
    /// P_c: where the vehicle's reference point will be at t_c.
    pub place: Ned,
    /// l_min: current clearance between the outline and the obstacle's edge
    /// (its radius, without the margin); 0 when touching.
    pub distance_m: f64,
    /// |V_OA|.
    pub relative_speed_mps: f64,
    /// The speed the obstacle itself was predicted at: 0 for one predicted
    /// standing, whose prediction owes nothing to a velocity estimate.
    pub obstacle_speed_mps: f64,
    /// The relative motion is bringing the obstacle nearer the outline.
    pub closing: bool,
}

/// Local-frame vector into the body frame (x forward, y right) at `yaw_rad`.
pub fn to_body(yaw_rad: f64, north: f64, east: f64) -> (f64, f64) {
    let (sin_yaw, cos_yaw) = yaw_rad.sin_cos();
    (north * cos_yaw + east * sin_yaw, -north * sin_yaw + east * cos_yaw)
}

/// The first time within `horizon_s` at which the track's disc (radius +
/// `margin_m`) touches the footprint, moving at constant velocities. `None`
/// when it does not within the horizon, or there is no relative motion and
/// they do not already overlap, or an input is not finite.
pub fn predict_collision(
    track: &Track,
    vehicle: &VehicleMotion,
    footprint: &Footprint,
    margin_m: f64,
    horizon_s: f64,
) -> Option<CollisionPrediction> {
    let inputs = [
        track.position.north_m,
        track.position.east_m,
        track.vel_north_mps,
        track.vel_east_mps,
        track.radius_m,
        vehicle.pose.position.north_m,
        vehicle.pose.position.east_m,
        vehicle.pose.yaw_rad,
        vehicle.vel_north_mps,
        vehicle.vel_east_mps,
        footprint.front_m,
        footprint.rear_m,
        footprint.half_width_m,
        margin_m,
    ];
    if inputs.iter().any(|v| !v.is_finite()) || horizon_s.is_nan() {
        return None;
    }
    let yaw = vehicle.pose.yaw_rad;
    let position = to_body(
        yaw,
        track.position.north_m - vehicle.pose.position.north_m,
        track.position.east_m - vehicle.pose.position.east_m,
    );
    // Eq. 13 in the local frame, then into the body frame.
    let velocity = to_body(
        yaw,
        track.vel_north_mps - vehicle.vel_north_mps,
        track.vel_east_mps - vehicle.vel_east_mps,
    );
    let rect = Rect::of(footprint);
    let radius_m = track.radius_m.max(0.0);
    let reach_m = radius_m + margin_m.max(0.0);
    let relative_speed_mps = velocity.0.hypot(velocity.1);
    let (gap_m, closing) = rect.gap_and_closing(position, velocity);

    let time_s = if gap_m <= reach_m {
        0.0
    } else if relative_speed_mps < MIN_RELATIVE_SPEED_MPS {
        return None;
    } else {
        rect.first_contact(position, velocity, reach_m)?
    };
    if time_s > horizon_s {
        return None;
    }
    Some(CollisionPrediction {
        track_id: track.id,
        time_s,
        place: Ned::new(
            vehicle.pose.position.north_m + vehicle.vel_north_mps * time_s,
            vehicle.pose.position.east_m + vehicle.vel_east_mps * time_s,
        ),
        distance_m: (gap_m - radius_m).max(0.0),
        relative_speed_mps,
        obstacle_speed_mps: track.vel_north_mps.hypot(track.vel_east_mps),
        closing,
    })
}

/// The footprint in the body frame.
#[derive(Clone, Copy, Debug)]
struct Rect {
    x_min: f64,
    x_max: f64,
    half_width: f64,
}

impl Rect {
    fn of(footprint: &Footprint) -> Self {
        Rect {
            x_min: -footprint.rear_m,
            x_max: footprint.front_m,
            half_width: footprint.half_width_m.max(0.0),
        }
    }

    fn nearest(&self, (x, y): (f64, f64)) -> (f64, f64) {
        (
            x.clamp(self.x_min, self.x_max.max(self.x_min)),
            y.clamp(-self.half_width, self.half_width),
        )
    }

    /// Distance from `position` to the rectangle, and whether `velocity`
    /// reduces it (from inside the rectangle: whether it heads for the
    /// centre, i.e. deeper in).
    fn gap_and_closing(&self, position: (f64, f64), velocity: (f64, f64)) -> (f64, bool) {
        let nearest = self.nearest(position);
        let (dx, dy) = (position.0 - nearest.0, position.1 - nearest.1);
        let gap = dx.hypot(dy);
        let outward = if gap > 0.0 {
            (dx, dy)
        } else {
            (position.0 - 0.5 * (self.x_min + self.x_max), position.1)
        };
        (gap, outward.0 * velocity.0 + outward.1 * velocity.1 < 0.0)
    }

    /// First t ≥ 0 at which `position + velocity·t` comes within `reach` of
    /// the rectangle, for a start outside that distance.
    fn first_contact(&self, position: (f64, f64), velocity: (f64, f64), reach: f64) -> Option<f64> {
        let hw = self.half_width;
        let boxes = [
            (self.x_min - reach, self.x_max + reach, -hw, hw),
            (self.x_min, self.x_max, -hw - reach, hw + reach),
        ];
        let corners = [(self.x_min, -hw), (self.x_min, hw), (self.x_max, -hw), (self.x_max, hw)];
        let box_hits = boxes.iter().filter_map(|b| ray_box(position, velocity, *b));
        let corner_hits = corners.iter().filter_map(|c| ray_disc(position, velocity, *c, reach));
        box_hits.chain(corner_hits).filter(|t| *t >= 0.0).min_by(f64::total_cmp)
    }
}

/// Entry time of a ray into an axis-aligned box (slab method).
fn ray_box(p: (f64, f64), v: (f64, f64), (x_min, x_max, y_min, y_max): (f64, f64, f64, f64)) -> Option<f64> {
    let (tx0, tx1) = slab(p.0, v.0, x_min, x_max)?;
    let (ty0, ty1) = slab(p.1, v.1, y_min, y_max)?;
    let (enter, leave) = (tx0.max(ty0), tx1.min(ty1));
    (enter <= leave && leave >= 0.0).then_some(enter.max(0.0))
}

/// The interval of t over which `p + v·t` lies in [lo, hi]; unbounded when
/// still inside, `None` when never.
fn slab(p: f64, v: f64, lo: f64, hi: f64) -> Option<(f64, f64)> {
    if lo > hi {
        return None;
    }
    if v == 0.0 {
        return (lo..=hi).contains(&p).then_some((f64::NEG_INFINITY, f64::INFINITY));
    }
    let (a, b) = ((lo - p) / v, (hi - p) / v);
    Some((a.min(b), a.max(b)))
}

/// First time a ray comes within `r` of `centre`.
fn ray_disc(p: (f64, f64), v: (f64, f64), centre: (f64, f64), r: f64) -> Option<f64> {
    let (dx, dy) = (p.0 - centre.0, p.1 - centre.1);
    let a = v.0 * v.0 + v.1 * v.1;
    if a == 0.0 {
        return None;
    }
    let b = dx * v.0 + dy * v.1;
    let c = dx * dx + dy * dy - r * r;
    let discriminant = b * b - a * c;
    if discriminant < 0.0 {
        return None;
    }
    let root = discriminant.sqrt();
    let (enter, leave) = ((-b - root) / a, (-b + root) / a);
    (leave >= 0.0).then_some(enter.max(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::obstacles::TrackStatus;

    const FOOTPRINT: Footprint = Footprint {
        front_m: 1.0,
        rear_m: 0.2,
        half_width_m: 0.35,
    };

    fn track(north_m: f64, east_m: f64, vel_north_mps: f64, vel_east_mps: f64, radius_m: f64) -> Track {
        Track {
            id: 7,
            status: TrackStatus::Confirmed,
            position: Ned::new(north_m, east_m),
            vel_north_mps,
            vel_east_mps,
            position_sigma_m: 0.05,
            velocity_sigma_mps: 0.05,
            radius_m,
            outline: None,
            age_s: 1.0,
            unseen_s: 0.0,
            hits: 10,
            misses: 0,
            still_s: 0.0,
        }
    }

    fn at_origin(yaw_rad: f64, speed_mps: f64) -> VehicleMotion {
        VehicleMotion::along_heading(
            Pose {
                position: Ned::default(),
                yaw_rad,
            },
            speed_mps,
        )
    }

    #[test]
    fn body_frame_matches_the_convention() {
        // Heading east: a point to the east is ahead, one to the south is on the right.
        let (x, y) = to_body(std::f64::consts::FRAC_PI_2, 0.0, 1.0);
        assert!((x - 1.0).abs() < 1e-12 && y.abs() < 1e-12);
        let (x, y) = to_body(std::f64::consts::FRAC_PI_2, -1.0, 0.0);
        assert!(x.abs() < 1e-12 && (y - 1.0).abs() < 1e-12);
    }

    #[test]
    fn rotated_scene_gives_the_same_time() {
        let north = predict_collision(
            &track(6.0, 0.1, 0.0, 0.0, 0.2),
            &at_origin(0.0, 1.0),
            &FOOTPRINT,
            0.1,
            20.0,
        );
        let yaw = 2.2_f64;
        let (s, c) = yaw.sin_cos();
        let east = predict_collision(
            &track(6.0 * c - 0.1 * s, 6.0 * s + 0.1 * c, 0.0, 0.0, 0.2),
            &at_origin(yaw, 1.0),
            &FOOTPRINT,
            0.1,
            20.0,
        );
        let (a, b) = (north.map(|p| p.time_s), east.map(|p| p.time_s));
        assert!(a.is_some());
        assert!((a.unwrap_or(0.0) - b.unwrap_or(-1.0)).abs() < 1e-9, "{a:?} vs {b:?}");
    }

    #[test]
    fn beyond_the_horizon_is_none() {
        let far = track(30.0, 0.0, 0.0, 0.0, 0.2);
        assert!(predict_collision(&far, &at_origin(0.0, 1.0), &FOOTPRINT, 0.1, 10.0).is_none());
        assert!(predict_collision(&far, &at_origin(0.0, 1.0), &FOOTPRINT, 0.1, 40.0).is_some());
    }

    #[test]
    fn non_finite_input_is_none_not_a_panic() {
        let bad = track(f64::NAN, 0.0, 0.0, 0.0, 0.2);
        assert!(predict_collision(&bad, &at_origin(0.0, 1.0), &FOOTPRINT, 0.1, 10.0).is_none());
    }

    #[test]
    fn no_relative_motion_and_apart_is_none() {
        let beside = track(0.0, 3.0, 1.0, 0.0, 0.2);
        assert!(predict_collision(&beside, &at_origin(0.0, 1.0), &FOOTPRINT, 0.1, 10.0).is_none());
    }
}
