//! Detour round a static obstacle on a mission leg: the tangent-bug choice
//! of side (seed 004 §III.D, Fig. 5) made into a path an Ackermann vehicle
//! with a body can drive, which leaves the planned line, passes the obstacle
//! and comes back onto the line before the leg ends.
//!
//! # The seed's method and what is corrected here
//! - **Heuristic.** §III.D says the algorithm "calculates the distance
//!   between the point O_i and q_goal" and goes to the shorter one. Only
//!   `d(O_i, q_goal)` leaves out the way to `O_i`: a tangent point far out to
//!   one side can be nearer the goal and still be the longer path. The
//!   tangent-bug heuristic (Kamon, Rivlin & Rimon) is
//!   `d(x, O_i) + d(O_i, q_goal)`, which is what [`plan_detour`] minimises
//!   (`x` the vehicle's reference point, `q_goal` the leg's end).
//! - **Point robot.** The tangent bug and Fig. 5 treat the AGV as a point and
//!   `O_i` as the obstacle's own tangent points, so aiming at `O_i` scrapes
//!   the obstacle with half the body. The tangent points here are those of
//!   the configuration-space obstacle: every obstacle point grown into a disc
//!   of radius `half_width + clearance`; the tangent from `x` to a disc of
//!   radius `r` at range `ρ` leaves at `±asin(r/ρ)` from the point's bearing
//!   and touches it `√(ρ² − r²)` from `x`. If `ρ ≤ r` for any point the
//!   vehicle is already inside the grown obstacle ([`DetourRefusal::TooClose`]).
//! - **Turning on the spot.** The seed's AGV is differential and the tangent
//!   bug turns towards `O_i` at once. A car cannot: a lateral offset `o`
//!   needs along-track run-in. Two tangent arcs of radius `R`, each turning
//!   by `θ`, give `o = 2R(1 − cos θ)` over a run of `2R·sin θ = √(4oR − o²)`
//!   (for `o ≤ 2R`; beyond, `2R`). [`s_bend_run_m`] takes
//!   `max(2√(oR), o)`: `2√(oR)` is never shorter than that exact run (so the
//!   path-follower, which does not drive the arcs at full lock, has slack)
//!   and the floor `o` keeps the chord at ≤ 45° so each arc turns ≤ 90°,
//!   which also gives a differential vehicle (`R = 0`) a drivable diagonal
//!   instead of a sideways step. Through those end points the S-bend of two
//!   equal arcs has radius `R' = (run² + o²)/(4o) ≥ R` and arcs of
//!   `θ' = 2·atan(o/run)`; that curve is the one checked against other
//!   points.
//! - **Body, not point.** The reference point is the rear axle centre: the
//!   front overhang reaches the obstacle before the reference point does and
//!   the rear overhang leaves it after. On an S-bend arc, `b` short of its
//!   straight end, a corner is `(R' − h)·sin b + overhang·(1 − cos b)` behind
//!   where it is at the end (`h` the half width), so it never passes that
//!   point by more than `(h − R')⁺·sin θ'` — nothing unless the bend is
//!   tighter than the half width. So the full offset is reached
//!   `clearance + max(front + (h − R')⁺·sin θ', h)` before the obstacle's
//!   near face and held until `clearance + max(rear + (h − R')⁺·sin θ', h)`
//!   past its far face: the body is then clear of the obstacle along the
//!   line while it turns, and beside it by the offset. (The `h` floor keeps
//!   the reference path itself at least `h + clearance` from every obstacle
//!   point.)
//! - **Leaving for the goal.** A tangent-bug robot heads straight for the
//!   goal once past the obstacle; a mission leg is a lane, so the detour
//!   turns back onto the planned line, and is refused if it cannot do that
//!   before the leg ends.
//!
//! A 2D scanner sees only the obstacle's near face, so its far face is where
//! the last seen point is; the caller should re-plan as more of it comes
//! into view. The detour is planned relative to the leg, from the vehicle's
//! position along it: the vehicle is assumed to be on (or near) the line.
//!
//! Sources: docs/references.md §Seed 004.

use std::fmt;

use super::{Footprint, Pose};
use crate::geo::{Ned, wrap_pi};

/// How far the detour may go and how tightly the vehicle turns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DetourConfig {
    /// Extra gap between the vehicle's body and the obstacle (and any other
    /// point), metres, e.g. 0.5.
    pub clearance_m: f64,
    /// `OA_CORRIDOR`: how far the reference path may leave the planned line,
    /// metres, e.g. 3.0 (the body reaches half its width further).
    pub corridor_m: f64,
    /// The vehicle's tightest turn radius at the reference point, metres
    /// (0 for a vehicle that turns on the spot).
    pub min_turn_radius_m: f64,
}

/// Which side of the planned line the detour passes the obstacle on, seen
/// in the direction of travel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    Left,
    Right,
}

/// A planned detour.
#[derive(Clone, Debug, PartialEq)]
pub struct Detour {
    /// The points to drive through in order: where to leave the line (on it,
    /// possibly where the vehicle already is), where the full offset is
    /// reached, where the turn back starts, and the rejoin point — back on
    /// the line, beyond the obstacle, not beyond the leg's end.
    pub waypoints: Vec<Ned>,
    pub side: Side,
    /// Along the leg from its start to the rejoin point, metres.
    pub rejoin_along_m: f64,
    /// The reference path's largest distance from the line, metres.
    pub max_offset_m: f64,
}

/// Why no detour was planned (the caller stops instead).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DetourRefusal {
    /// The detour would have to leave the line by more than `corridor_m` on
    /// every side that is otherwise possible.
    OutsideCorridor,
    /// Other points (walls, other obstacles) sit in the band the detour
    /// sweeps.
    Blocked,
    /// No room to steer round before the obstacle (or the vehicle is already
    /// alongside it).
    TooClose,
    /// The leg ends inside the obstacle, or so close behind it that the
    /// vehicle cannot get back onto the line before the leg's end.
    GoalInsideObstacle,
    /// The obstacle is not in the band the vehicle sweeps along the rest of
    /// the leg: no detour is needed.
    NotInTheWay,
    /// A NaN or infinite coordinate, a negative size or setting, a leg of no
    /// length, or an empty obstacle.
    InvalidInput,
}

impl fmt::Display for DetourRefusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let text = match self {
            DetourRefusal::OutsideCorridor => "detour: obstacle too wide for the corridor",
            DetourRefusal::Blocked => "detour: both sides blocked",
            DetourRefusal::TooClose => "detour: obstacle too close to steer round",
            DetourRefusal::GoalInsideObstacle => "detour: leg ends at the obstacle",
            DetourRefusal::NotInTheWay => "detour: obstacle not in the way",
            DetourRefusal::InvalidInput => "detour: invalid input",
        };
        f.write_str(text)
    }
}

impl std::error::Error for DetourRefusal {}

/// Along-track run-in the detour takes to move `offset_m` sideways:
/// `max(2√(offset·R), offset)` (see the module notes). 0 for a negative or
/// non-finite input.
pub fn s_bend_run_m(offset_m: f64, min_turn_radius_m: f64) -> f64 {
    if !(offset_m.is_finite() && min_turn_radius_m.is_finite()) || offset_m <= 0.0 {
        return 0.0;
    }
    (2.0 * (offset_m * min_turn_radius_m.max(0.0)).sqrt()).max(offset_m)
}

/// Plans a detour round `obstacle` (its points, a cluster or its hull, in the
/// local frame) for a vehicle at `vehicle` driving the leg `leg_from` →
/// `leg_to`, keeping `config.clearance_m` from the obstacle and from every
/// point in `others`, within `config.corridor_m` of the line.
///
/// The side is the one whose grown tangent point `O_i` minimises
/// `d(vehicle, O_i) + d(O_i, leg_to)`, left on a tie; if that side is
/// refused and the other is not, the other is taken. When both are refused
/// the preferred side's reason is returned.
pub fn plan_detour(
    leg_from: Ned,
    leg_to: Ned,
    vehicle: &Pose,
    footprint: &Footprint,
    obstacle: &[Ned],
    others: &[Ned],
    config: &DetourConfig,
) -> Result<Detour, DetourRefusal> {
    if !inputs_valid(leg_from, leg_to, vehicle, footprint, obstacle, others, config) {
        return Err(DetourRefusal::InvalidInput);
    }
    let leg = LegFrame::new(leg_from, leg_to).ok_or(DetourRefusal::InvalidInput)?;
    let extent = Extent::of(obstacle.iter().map(|p| leg.to_leg(p))).ok_or(DetourRefusal::InvalidInput)?;
    let vehicle_along_m = leg.to_leg(&vehicle.position).along_m;
    let clearance_m = config.clearance_m;
    let inflation_m = footprint.half_width_m + clearance_m;

    let offset_left_m = inflation_m - extent.cross_min_m;
    let offset_right_m = inflation_m + extent.cross_max_m;
    if offset_left_m <= 0.0 || offset_right_m <= 0.0 {
        return Err(DetourRefusal::NotInTheWay);
    }
    let (front_reach_m, rear_reach_m) = body_reach_along_m(footprint, wrap_pi(vehicle.yaw_rad - leg.heading_rad));
    if extent.along_max_m <= vehicle_along_m - rear_reach_m - clearance_m {
        return Err(DetourRefusal::NotInTheWay);
    }
    let goal_along_m = leg.length_m;
    if extent.along_min_m >= goal_along_m + footprint.front_m + clearance_m {
        return Err(DetourRefusal::NotInTheWay);
    }
    if extent.along_min_m < vehicle_along_m + front_reach_m + clearance_m {
        return Err(DetourRefusal::TooClose);
    }
    if extent.along_max_m > goal_along_m - footprint.rear_m - clearance_m {
        return Err(DetourRefusal::GoalInsideObstacle);
    }
    let costs = tangent_costs_m(vehicle.position, leg_to, obstacle, inflation_m).ok_or(DetourRefusal::TooClose)?;

    let plan = |side: Side, offset_m: f64| {
        plan_side(
            &leg,
            &extent,
            vehicle_along_m,
            footprint,
            others,
            config,
            side,
            offset_m,
        )
    };
    let left = plan(Side::Left, offset_left_m);
    let right = plan(Side::Right, offset_right_m);
    let (preferred, fallback) = if costs.left_m <= costs.right_m {
        (left, right)
    } else {
        (right, left)
    };
    let candidate = match (preferred, fallback) {
        (Ok(c), _) | (Err(_), Ok(c)) => c,
        (Err(reason), Err(_)) => return Err(reason),
    };
    Ok(candidate.into_detour(&leg))
}

/// Every coordinate finite, sizes and settings non-negative, an obstacle to
/// go round.
fn inputs_valid(
    leg_from: Ned,
    leg_to: Ned,
    vehicle: &Pose,
    footprint: &Footprint,
    obstacle: &[Ned],
    others: &[Ned],
    config: &DetourConfig,
) -> bool {
    let finite = |p: &Ned| p.north_m.is_finite() && p.east_m.is_finite();
    let non_negative = |x: f64| x.is_finite() && x >= 0.0;
    finite(&leg_from)
        && finite(&leg_to)
        && finite(&vehicle.position)
        && vehicle.yaw_rad.is_finite()
        && non_negative(footprint.front_m)
        && non_negative(footprint.rear_m)
        && non_negative(footprint.half_width_m)
        && non_negative(config.clearance_m)
        && non_negative(config.corridor_m)
        && non_negative(config.min_turn_radius_m)
        && !obstacle.is_empty()
        && obstacle.iter().all(finite)
        && others.iter().all(finite)
}

/// A point in the leg's frame: along the leg from its start, and across it,
/// positive to the right of the direction of travel.
#[derive(Clone, Copy, Debug, PartialEq)]
struct LegPoint {
    along_m: f64,
    cross_m: f64,
}

/// The leg's start, unit direction and length.
struct LegFrame {
    origin: Ned,
    unit_north: f64,
    unit_east: f64,
    length_m: f64,
    heading_rad: f64,
}

impl LegFrame {
    /// Shorter than this a leg has no direction to detour along.
    const MIN_LENGTH_M: f64 = 1e-3;

    fn new(from: Ned, to: Ned) -> Option<Self> {
        let length_m = from.distance_to(&to);
        if length_m.is_nan() || length_m < Self::MIN_LENGTH_M {
            return None;
        }
        Some(LegFrame {
            origin: from,
            unit_north: (to.north_m - from.north_m) / length_m,
            unit_east: (to.east_m - from.east_m) / length_m,
            length_m,
            heading_rad: from.bearing_to(&to),
        })
    }

    fn to_leg(&self, p: &Ned) -> LegPoint {
        let dn = p.north_m - self.origin.north_m;
        let de = p.east_m - self.origin.east_m;
        // Right of a heading (n, e) is (−e, n) in NED.
        LegPoint {
            along_m: dn * self.unit_north + de * self.unit_east,
            cross_m: -dn * self.unit_east + de * self.unit_north,
        }
    }

    fn to_ned(&self, p: LegPoint) -> Ned {
        Ned::new(
            self.origin.north_m + p.along_m * self.unit_north - p.cross_m * self.unit_east,
            self.origin.east_m + p.along_m * self.unit_east + p.cross_m * self.unit_north,
        )
    }
}

/// The obstacle's bounding box in the leg frame.
struct Extent {
    along_min_m: f64,
    along_max_m: f64,
    cross_min_m: f64,
    cross_max_m: f64,
}

impl Extent {
    fn of(points: impl Iterator<Item = LegPoint>) -> Option<Extent> {
        points.fold(None, |acc: Option<Extent>, p| {
            Some(match acc {
                None => Extent {
                    along_min_m: p.along_m,
                    along_max_m: p.along_m,
                    cross_min_m: p.cross_m,
                    cross_max_m: p.cross_m,
                },
                Some(e) => Extent {
                    along_min_m: e.along_min_m.min(p.along_m),
                    along_max_m: e.along_max_m.max(p.along_m),
                    cross_min_m: e.cross_min_m.min(p.cross_m),
                    cross_max_m: e.cross_max_m.max(p.cross_m),
                },
            })
        })
    }
}

/// How far the body reaches ahead of and behind the reference point along
/// the leg, with the vehicle yawed `relative_yaw_rad` from the leg.
fn body_reach_along_m(footprint: &Footprint, relative_yaw_rad: f64) -> (f64, f64) {
    let (sin, cos) = relative_yaw_rad.sin_cos();
    let corners = [
        (footprint.front_m, footprint.half_width_m),
        (footprint.front_m, -footprint.half_width_m),
        (-footprint.rear_m, footprint.half_width_m),
        (-footprint.rear_m, -footprint.half_width_m),
    ];
    corners
        .iter()
        .fold((f64::NEG_INFINITY, f64::NEG_INFINITY), |(ahead, behind), &(x, y)| {
            let along = x * cos - y * sin;
            (ahead.max(along), behind.max(-along))
        })
}

/// `d(vehicle, O_i) + d(O_i, goal)` for the left and right tangent points of
/// the obstacle grown by `inflation_m`.
struct TangentCosts {
    left_m: f64,
    right_m: f64,
}

/// `None` when the vehicle is inside the grown obstacle.
fn tangent_costs_m(vehicle: Ned, goal: Ned, obstacle: &[Ned], inflation_m: f64) -> Option<TangentCosts> {
    let count = obstacle.len() as f64;
    let centroid = Ned::new(
        obstacle.iter().map(|p| p.north_m).sum::<f64>() / count,
        obstacle.iter().map(|p| p.east_m).sum::<f64>() / count,
    );
    // Bearings relative to the centroid's, so an obstacle straight behind
    // does not straddle the ±π cut.
    let centre_bearing_rad = vehicle.bearing_to(&centroid);
    let mut left = (f64::INFINITY, 0.0);
    let mut right = (f64::NEG_INFINITY, 0.0);
    for p in obstacle {
        let range_m = vehicle.distance_to(p);
        if range_m <= inflation_m {
            return None;
        }
        let relative_rad = wrap_pi(vehicle.bearing_to(p) - centre_bearing_rad);
        let spread_rad = (inflation_m / range_m).asin();
        let tangent_m = (range_m * range_m - inflation_m * inflation_m).sqrt();
        // Clockwise positive: the left tangent is the most negative angle.
        if relative_rad - spread_rad < left.0 {
            left = (relative_rad - spread_rad, tangent_m);
        }
        if relative_rad + spread_rad > right.0 {
            right = (relative_rad + spread_rad, tangent_m);
        }
    }
    let cost = |(angle_rad, tangent_m): (f64, f64)| {
        let bearing_rad = centre_bearing_rad + angle_rad;
        let tangent_point = Ned::new(
            vehicle.north_m + tangent_m * bearing_rad.cos(),
            vehicle.east_m + tangent_m * bearing_rad.sin(),
        );
        tangent_m + tangent_point.distance_to(&goal)
    };
    Some(TangentCosts {
        left_m: cost(left),
        right_m: cost(right),
    })
}

/// One side's detour in the leg frame.
struct Candidate {
    side: Side,
    offset_m: f64,
    leave_along_m: f64,
    offset_start_along_m: f64,
    offset_end_along_m: f64,
    rejoin_along_m: f64,
}

impl Candidate {
    fn signed_offset_m(&self) -> f64 {
        match self.side {
            Side::Left => -self.offset_m,
            Side::Right => self.offset_m,
        }
    }

    fn into_detour(self, leg: &LegFrame) -> Detour {
        let cross_m = self.signed_offset_m();
        let waypoints = vec![
            leg.to_ned(LegPoint {
                along_m: self.leave_along_m,
                cross_m: 0.0,
            }),
            leg.to_ned(LegPoint {
                along_m: self.offset_start_along_m,
                cross_m,
            }),
            leg.to_ned(LegPoint {
                along_m: self.offset_end_along_m,
                cross_m,
            }),
            leg.to_ned(LegPoint {
                along_m: self.rejoin_along_m,
                cross_m: 0.0,
            }),
        ];
        Detour {
            waypoints,
            side: self.side,
            rejoin_along_m: self.rejoin_along_m,
            max_offset_m: self.offset_m,
        }
    }
}

/// Lays out the detour on one side and checks it: corridor, room before the
/// obstacle, room before the leg's end, and the band it sweeps.
#[allow(clippy::too_many_arguments)]
fn plan_side(
    leg: &LegFrame,
    extent: &Extent,
    vehicle_along_m: f64,
    footprint: &Footprint,
    others: &[Ned],
    config: &DetourConfig,
    side: Side,
    offset_m: f64,
) -> Result<Candidate, DetourRefusal> {
    if offset_m > config.corridor_m {
        return Err(DetourRefusal::OutsideCorridor);
    }
    let run_m = s_bend_run_m(offset_m, config.min_turn_radius_m);
    let overshoot_m = SBend::corner_overshoot_m(footprint, offset_m, run_m);
    let half_width_m = footprint.half_width_m;
    let offset_start_along_m =
        extent.along_min_m - config.clearance_m - (footprint.front_m + overshoot_m).max(half_width_m);
    let offset_end_along_m =
        extent.along_max_m + config.clearance_m + (footprint.rear_m + overshoot_m).max(half_width_m);
    let candidate = Candidate {
        side,
        offset_m,
        leave_along_m: offset_start_along_m - run_m,
        offset_start_along_m,
        offset_end_along_m,
        rejoin_along_m: offset_end_along_m + run_m,
    };
    if candidate.leave_along_m < vehicle_along_m {
        return Err(DetourRefusal::TooClose);
    }
    if candidate.rejoin_along_m > leg.length_m {
        return Err(DetourRefusal::GoalInsideObstacle);
    }
    if !band_clear(leg, &candidate, run_m, footprint, others, config.clearance_m) {
        return Err(DetourRefusal::Blocked);
    }
    Ok(candidate)
}

/// Whether every point in `others` stays `clearance_m` from the body along
/// the whole detour: both S-bends (sampled) and the straight between them
/// (exact). The obstacle itself is cleared by construction in [`plan_side`].
fn band_clear(
    leg: &LegFrame,
    candidate: &Candidate,
    run_m: f64,
    footprint: &Footprint,
    others: &[Ned],
    clearance_m: f64,
) -> bool {
    if others.is_empty() {
        return true;
    }
    let others: Vec<LegPoint> = others.iter().map(|p| leg.to_leg(p)).collect();
    let cross_m = candidate.signed_offset_m();
    let straight = Footprint {
        front_m: candidate.offset_end_along_m - candidate.offset_start_along_m + footprint.front_m,
        ..*footprint
    };
    let straight_start = LegPoint {
        along_m: candidate.offset_start_along_m,
        cross_m,
    };
    if others
        .iter()
        .any(|p| body_distance_m(straight_start, 0.0, &straight, *p) < clearance_m)
    {
        return false;
    }
    let away = SBend::new(candidate.leave_along_m, 0.0, cross_m, run_m);
    let back = SBend::new(candidate.offset_end_along_m, cross_m, 0.0, run_m);
    away.clear_of(&others, footprint, clearance_m) && back.clear_of(&others, footprint, clearance_m)
}

/// Distance from `p` to the body with its reference point at `reference`
/// heading `heading_rad` from the leg (clockwise); 0 inside.
fn body_distance_m(reference: LegPoint, heading_rad: f64, footprint: &Footprint, p: LegPoint) -> f64 {
    let (sin, cos) = heading_rad.sin_cos();
    let d_along = p.along_m - reference.along_m;
    let d_cross = p.cross_m - reference.cross_m;
    let x = d_along * cos + d_cross * sin;
    let y = -d_along * sin + d_cross * cos;
    let dx = (-footprint.rear_m - x).max(x - footprint.front_m).max(0.0);
    let dy = (y.abs() - footprint.half_width_m).max(0.0);
    dx.hypot(dy)
}

/// Two equal arcs turning opposite ways, from `from_cross_m` at
/// `start_along_m` to `to_cross_m` `run_m` further on, heading along the leg
/// at both ends.
struct SBend {
    start_along_m: f64,
    from_cross_m: f64,
    to_cross_m: f64,
    run_m: f64,
    /// +1 towards the right, −1 towards the left.
    sign: f64,
    radius_m: f64,
    arc_rad: f64,
}

impl SBend {
    /// Body points move at most this far between samples.
    const SAMPLE_MOVE_M: f64 = 0.01;
    const MAX_SAMPLES: usize = 4000;

    /// Each arc's turn for an S-bend of `offset_m` over `run_m`.
    fn arc_for(offset_m: f64, run_m: f64) -> f64 {
        2.0 * offset_m.atan2(run_m)
    }

    /// The two arcs' radius for an S-bend of `offset_m` over `run_m`.
    fn radius_for(offset_m: f64, run_m: f64) -> f64 {
        if offset_m > 0.0 {
            (run_m * run_m + offset_m * offset_m) / (4.0 * offset_m)
        } else {
            0.0
        }
    }

    /// How far a body corner can get past, along the line, where it is when
    /// the bend ends (or before where it is when the bend starts):
    /// `(half_width − R')⁺·sin θ'` (see the module notes).
    fn corner_overshoot_m(footprint: &Footprint, offset_m: f64, run_m: f64) -> f64 {
        let excess_m = (footprint.half_width_m - Self::radius_for(offset_m, run_m)).max(0.0);
        excess_m * Self::arc_for(offset_m, run_m).sin()
    }

    fn new(start_along_m: f64, from_cross_m: f64, to_cross_m: f64, run_m: f64) -> SBend {
        let offset_m = (to_cross_m - from_cross_m).abs();
        let radius_m = Self::radius_for(offset_m, run_m);
        SBend {
            start_along_m,
            from_cross_m,
            to_cross_m,
            run_m,
            sign: if to_cross_m >= from_cross_m { 1.0 } else { -1.0 },
            radius_m,
            arc_rad: Self::arc_for(offset_m, run_m),
        }
    }

    /// Reference point and heading a fraction `u` ∈ [0, 1] of the way along.
    fn pose(&self, u: f64) -> (LegPoint, f64) {
        let r = self.radius_m;
        if u <= 0.5 {
            let turned_rad = self.arc_rad * 2.0 * u;
            let p = LegPoint {
                along_m: self.start_along_m + r * turned_rad.sin(),
                cross_m: self.from_cross_m + self.sign * r * (1.0 - turned_rad.cos()),
            };
            (p, self.sign * turned_rad)
        } else {
            let remaining_rad = self.arc_rad * 2.0 * (1.0 - u);
            let p = LegPoint {
                along_m: self.start_along_m + self.run_m - r * remaining_rad.sin(),
                cross_m: self.to_cross_m - self.sign * r * (1.0 - remaining_rad.cos()),
            };
            (p, self.sign * remaining_rad)
        }
    }

    /// Samples finely enough that no body point moves more than
    /// [`Self::SAMPLE_MOVE_M`] between samples, and widens the clearance by
    /// half the actual spacing so a point cannot slip between two samples.
    fn clear_of(&self, points: &[LegPoint], footprint: &Footprint, clearance_m: f64) -> bool {
        let corner_m = footprint.front_m.max(footprint.rear_m).hypot(footprint.half_width_m);
        let reach_m = corner_m + clearance_m + Self::SAMPLE_MOVE_M;
        let low_cross_m = self.from_cross_m.min(self.to_cross_m) - reach_m;
        let high_cross_m = self.from_cross_m.max(self.to_cross_m) + reach_m;
        let near: Vec<LegPoint> = points
            .iter()
            .copied()
            .filter(|p| {
                p.along_m >= self.start_along_m - reach_m
                    && p.along_m <= self.start_along_m + self.run_m + reach_m
                    && p.cross_m >= low_cross_m
                    && p.cross_m <= high_cross_m
            })
            .collect();
        if near.is_empty() {
            return true;
        }
        let length_m = if self.radius_m > 0.0 {
            2.0 * self.radius_m * self.arc_rad
        } else {
            self.run_m
        };
        // Per metre of reference path a body point moves up to 1 + corner/R.
        let move_per_m = 1.0
            + if self.radius_m > 0.0 {
                corner_m / self.radius_m
            } else {
                0.0
            };
        let wanted = (length_m * move_per_m / Self::SAMPLE_MOVE_M).ceil();
        let samples = if wanted.is_finite() {
            (wanted as usize).clamp(1, Self::MAX_SAMPLES)
        } else {
            Self::MAX_SAMPLES
        };
        let slack_m = 0.5 * length_m * move_per_m / samples as f64;
        (0..=samples).all(|k| {
            let (reference, heading_rad) = self.pose(k as f64 / samples as f64);
            near.iter()
                .all(|p| body_distance_m(reference, heading_rad, footprint, *p) >= clearance_m + slack_m)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn s_bend_ends_where_the_waypoints_are() {
        let bend = SBend::new(3.0, 0.0, -1.2, s_bend_run_m(1.2, 2.0));
        let (start, start_heading) = bend.pose(0.0);
        let (middle, _) = bend.pose(0.5);
        let (end, end_heading) = bend.pose(1.0);
        assert!((start.along_m - 3.0).abs() < 1e-12 && start.cross_m.abs() < 1e-12 && start_heading == 0.0);
        assert!((end.along_m - (3.0 + bend.run_m)).abs() < 1e-9, "{end:?}");
        assert!((end.cross_m + 1.2).abs() < 1e-9 && end_heading.abs() < 1e-12);
        assert!((middle.along_m - (3.0 + bend.run_m / 2.0)).abs() < 1e-9 && (middle.cross_m + 0.6).abs() < 1e-9);
        assert!(
            bend.radius_m >= 2.0,
            "the S-bend never turns tighter than the vehicle can: {}",
            bend.radius_m
        );
    }

    #[test]
    fn run_in_is_at_least_the_exact_two_arc_run() {
        for &(offset_m, radius_m) in &[(0.1_f64, 2.0_f64), (1.0, 2.0), (3.9, 2.0), (5.0, 1.0), (1.0, 0.0)] {
            let exact_m: f64 = if offset_m <= 2.0 * radius_m {
                (4.0 * offset_m * radius_m - offset_m * offset_m).sqrt()
            } else {
                2.0 * radius_m
            };
            let run_m = s_bend_run_m(offset_m, radius_m);
            assert!(run_m >= exact_m - 1e-12, "{offset_m} {radius_m}: {run_m} < {exact_m}");
            assert!(SBend::arc_for(offset_m, run_m) <= std::f64::consts::FRAC_PI_2 + 1e-12);
        }
    }

    /// The body corners' along-track positions over a bend, sampled.
    fn corner_alongs(bend: &SBend, footprint: &Footprint) -> impl Iterator<Item = f64> {
        let corners = [
            (footprint.front_m, footprint.half_width_m),
            (footprint.front_m, -footprint.half_width_m),
            (-footprint.rear_m, footprint.half_width_m),
            (-footprint.rear_m, -footprint.half_width_m),
        ];
        let samples = 2000;
        (0..=samples).flat_map(move |k| {
            let (reference, heading_rad) = bend.pose(k as f64 / samples as f64);
            let (sin, cos) = heading_rad.sin_cos();
            corners.map(|(x, y)| reference.along_m + x * cos - y * sin)
        })
    }

    #[test]
    fn while_turning_the_body_stays_clear_of_the_obstacle_along_the_line() {
        let extent = Extent {
            along_min_m: 10.0,
            along_max_m: 11.0,
            cross_min_m: -0.5,
            cross_max_m: 0.5,
        };
        let leg = LegFrame::new(Ned::new(0.0, 0.0), Ned::new(40.0, 0.0)).expect("leg");
        // Offsets small and large against the half width, bends tight and wide.
        for &(offset_m, radius_m) in &[(0.05, 0.0), (0.3, 0.0), (1.0, 0.0), (0.2, 0.1), (1.0, 2.0), (3.0, 0.5)] {
            for footprint in [
                Footprint {
                    front_m: 1.2,
                    rear_m: 0.3,
                    half_width_m: 0.4,
                },
                Footprint {
                    front_m: 0.2,
                    rear_m: 0.0,
                    half_width_m: 0.6,
                },
            ] {
                let config = DetourConfig {
                    clearance_m: 0.3,
                    corridor_m: 5.0,
                    min_turn_radius_m: radius_m,
                };
                let c =
                    plan_side(&leg, &extent, 0.0, &footprint, &[], &config, Side::Right, offset_m).expect("candidate");
                let run_m = s_bend_run_m(offset_m, radius_m);
                let away = SBend::new(c.leave_along_m, 0.0, offset_m, run_m);
                let back = SBend::new(c.offset_end_along_m, offset_m, 0.0, run_m);
                let furthest_m = corner_alongs(&away, &footprint).fold(f64::NEG_INFINITY, f64::max);
                let hindmost_m = corner_alongs(&back, &footprint).fold(f64::INFINITY, f64::min);
                let case = format!("offset {offset_m} R {radius_m} {footprint:?}");
                assert!(
                    furthest_m <= extent.along_min_m - config.clearance_m + 1e-9,
                    "{case}: {furthest_m}"
                );
                assert!(
                    hindmost_m >= extent.along_max_m + config.clearance_m - 1e-9,
                    "{case}: {hindmost_m}"
                );
            }
        }
    }

    #[test]
    fn leg_frame_round_trips_and_right_is_positive() {
        let leg = LegFrame::new(Ned::new(1.0, 2.0), Ned::new(1.0, 12.0)).expect("leg");
        // Driving east, south is on the right.
        let p = leg.to_leg(&Ned::new(0.0, 5.0));
        assert!(
            (p.along_m - 3.0).abs() < 1e-12 && (p.cross_m - 1.0).abs() < 1e-12,
            "{p:?}"
        );
        let back = leg.to_ned(p);
        assert!((back.north_m - 0.0).abs() < 1e-12 && (back.east_m - 5.0).abs() < 1e-12);
    }
}
