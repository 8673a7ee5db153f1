//! The bench's judge: collisions, false stops and stalls decided from the
//! simulator's truth (true poses, true shapes, true velocities) and the
//! world, never from Furrow's tracks, fields or predictions.
//!
//! - The **outline** is the rectangle of `VEH_LEN_FRONT`, `VEH_LEN_REAR`
//!   and `VEH_WIDTH` about the true pose.
//! - The **course** is the truth pose log of the same run without
//!   obstacles (same mission, same seed): the path the vehicle was going to
//!   drive, arcs, tail swing and reverse legs included. It is followed by
//!   a cursor that only moves forwards, so a course that passes a point
//!   twice (out and back in reverse) is never confused.
//! - The **swept outline** at an instant is the union of the outline at the
//!   true pose and at every pose of the course from there onward (one per
//!   core tick, 2–4 cm apart, so nothing fits between them) until the
//!   reference point has driven the distance the plant truly needs to stop
//!   from `v` (its braking limit through the drive's lag, from a zero
//!   command at that tick: see [`super::plant`]) plus `v·OA_HORIZON`, with
//!   `v` the larger of the true speed and the fastest the course drives
//!   over the next `OA_HORIZON` from there (a vehicle at rest was going to
//!   drive on). Furrow's `OA_REACT_TIME` and `OA_DECEL` play no part: they
//!   are allowances the autopilot chose, not what the vehicle needs.
//! - **Way blocked**: some object's true shape, moved in a straight line at
//!   its true velocity for any time in `[0, OA_HORIZON]`, comes within
//!   `OA_MARGIN` of the swept outline (touching the margin counts, to the
//!   5 mm of [`ON_THE_MARGIN_M`]: the course's own heading noise moves a
//!   face placed exactly on the margin by a millimetre or two). A
//!   standing person is standing; a person about to turn away is, until the
//!   turn, on a straight line into the path.
//! - A **false stop** is an obstacle stop decided while the way is not
//!   blocked. There is no other allowance.
//! - A **collision** is an episode of the outline and an object's true shape
//!   overlapping or touching while the vehicle moves (|v| > 1 cm/s); a
//!   person walking into a vehicle at rest is not one.
//! - A **stall** is the vehicle at rest for more than 30 s, mission not
//!   complete, with the way not blocked for all that time.
//! - A collision is **unavoidable** when even braking as hard as the
//!   plant can, from the first instant the object could be known, would
//!   still have touched it (see [`super::unavoidable`]). Every other
//!   collision counts against the vehicle.

use sim::{MovingObstacle, ObstacleWorld, Rectangle, Shape, VehicleOutline};

use super::plant::PlantBraking;
use super::situation::ARC_RADIUS_M;
use super::unavoidable::ObjectId;

/// Below this speed the vehicle is at rest (a collision needs more).
pub const MOVING_MPS: f64 = 0.01;
/// At rest with the way clear for longer than this is a stall.
pub const STALL_S: f64 = 30.0;
/// An object this close to the margin is on it: the course's heading
/// wobbles by ~1e-4 rad, which moves a gap along a 1–5 m face by 1–2 mm,
/// and the neighbours placed at exactly `OA_MARGIN` must count as inside.
pub const ON_THE_MARGIN_M: f64 = 0.005;
/// Objects are moved along their velocity in steps of at most this far.
const OBJECT_STEP_M: f64 = 0.05;
/// How finely, and how far back, a mover's straight line is traced.
const LINE_STEP_S: f64 = 0.02;
const LINE_LOOKBACK_S: f64 = 60.0;

/// How long before `t_s` the mover had been on its present straight line:
/// the same velocity (standing counts), without vanishing.
pub fn on_its_line_s(mover: &MovingObstacle, t_s: f64) -> f64 {
    let Some((_, velocity)) = mover.state_at(t_s) else {
        return 0.0;
    };
    let mut back_s = 0.0;
    while back_s < LINE_LOOKBACK_S {
        let same = mover
            .state_at(t_s - back_s - LINE_STEP_S)
            .is_some_and(|(_, v)| (v[0] - velocity[0]).abs() < 1e-9 && (v[1] - velocity[1]).abs() < 1e-9);
        if !same {
            break;
        }
        back_s += LINE_STEP_S;
    }
    back_s
}

/// One true pose of the vehicle's reference point (rear axle centre).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pose {
    /// World (simulation) time, as the obstacles' `start_s`.
    pub t_s: f64,
    pub north_m: f64,
    pub east_m: f64,
    pub yaw_rad: f64,
    /// Signed: negative when reversing.
    pub speed_mps: f64,
}

impl Pose {
    pub fn distance_to(&self, north_m: f64, east_m: f64) -> f64 {
        (self.north_m - north_m).hypot(self.east_m - east_m)
    }
}

/// The true poses of a run, one per core tick, from arming on.
#[derive(Clone, Debug, Default)]
pub struct TruthLog {
    pub poses: Vec<Pose>,
    /// Seconds from arming to the mission complete at rest.
    pub completion_s: Option<f64>,
}

impl TruthLog {
    /// First time at or after `after_s` the outline comes within `within_m`
    /// of `point`.
    pub fn first_near(&self, outline: &VehicleOutline, point: [f64; 2], within_m: f64, after_s: f64) -> Option<f64> {
        let dot = Shape::Circle {
            center: point,
            radius_m: 0.0,
        };
        self.poses
            .iter()
            .filter(|p| p.t_s >= after_s)
            .find(|p| dot.distance_to_rectangle_m(&rectangle(outline, p)) <= within_m)
            .map(|p| p.t_s)
    }

    /// Gap between `shape` and the outline anywhere along the whole log.
    pub fn clearance_m(&self, outline: &VehicleOutline, shape: &Shape) -> f64 {
        let rects: Vec<Rectangle> = self.poses.iter().map(|p| rectangle(outline, p)).collect();
        shape_clearance_m(shape, &rects)
    }
}

/// The outline at a pose.
pub fn rectangle(outline: &VehicleOutline, pose: &Pose) -> Rectangle {
    outline.rectangle(pose.north_m, pose.east_m, pose.yaw_rad)
}

/// Smallest gap between `shape` and any of `rects` (0 when touching).
pub fn shape_clearance_m(shape: &Shape, rects: &[Rectangle]) -> f64 {
    let (center, radius_m) = shape.bounding_circle();
    let mut best = f64::INFINITY;
    for rect in rects {
        // A circle round the rectangle rules most of them out cheaply.
        let reach_m = rect.half_length_m.hypot(rect.half_width_m);
        let apart_m = (center[0] - rect.center[0]).hypot(center[1] - rect.center[1]) - reach_m - radius_m;
        if apart_m >= best {
            continue;
        }
        best = best.min(shape.distance_to_rectangle_m(rect));
    }
    best
}

/// What the judge needs: the margin and horizon from the parameters, the
/// braking from the simulated plant.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    pub margin_m: f64,
    pub horizon_s: f64,
    pub plant: PlantBraking,
}

impl Limits {
    /// Whether a gap to the swept outline is within `OA_MARGIN`.
    pub fn within_margin(&self, gap_m: f64) -> bool {
        gap_m <= self.margin_m + ON_THE_MARGIN_M
    }

    /// Reference-point travel the swept outline covers from speed `v`: the
    /// plant's true stopping distance plus the horizon's travel.
    pub fn reach_m(&self, speed_mps: f64) -> f64 {
        let v = speed_mps.abs();
        self.plant.stopping_m(v) + v * self.horizon_s
    }
}

/// Follows a run along its course and judges it.
pub struct Judge<'a> {
    course: &'a TruthLog,
    outline: VehicleOutline,
    limits: Limits,
    cursor: usize,
}

/// How far ahead of the cursor (path length) the next match is searched.
const FOLLOW_WINDOW_M: f64 = 3.0;
/// The course's shape about the cursor is taken over this much path either
/// side, m.
const SHAPE_SPAN_M: f64 = 0.5;

impl<'a> Judge<'a> {
    pub fn new(course: &'a TruthLog, outline: VehicleOutline, limits: Limits) -> Self {
        Judge {
            course,
            outline,
            limits,
            cursor: 0,
        }
    }

    pub fn limits(&self) -> &Limits {
        &self.limits
    }

    /// Moves the cursor to the course pose nearest `pose`, searching only
    /// forwards and only a few metres of path ahead.
    pub fn follow(&mut self, pose: &Pose) {
        let poses = &self.course.poses;
        let mut best = (self.cursor, f64::INFINITY);
        let mut travelled_m = 0.0;
        for i in self.cursor..poses.len() {
            if i > self.cursor {
                travelled_m += poses[i].distance_to(poses[i - 1].north_m, poses[i - 1].east_m);
                if travelled_m > FOLLOW_WINDOW_M {
                    break;
                }
            }
            let d = poses[i].distance_to(pose.north_m, pose.east_m);
            if d < best.1 {
                best = (i, d);
            }
        }
        self.cursor = best.0;
    }

    /// The swept outline from `pose` onward (see the module header).
    pub fn swept(&self, pose: &Pose) -> Vec<Rectangle> {
        let poses = &self.course.poses;
        // At rest (waiting, or before the start) the vehicle was going to
        // drive at the course's speed: the fastest it drove over the next
        // horizon from here.
        let from_s = poses.get(self.cursor).map_or(0.0, |p| p.t_s);
        let course_mps = poses[self.cursor.min(poses.len())..]
            .iter()
            .take_while(|p| p.t_s <= from_s + self.limits.horizon_s)
            .map(|p| p.speed_mps.abs())
            .fold(0.0, f64::max);
        let reach_m = self.limits.reach_m(pose.speed_mps.abs().max(course_mps));
        let mut rects = vec![rectangle(&self.outline, pose)];
        let mut travelled_m = 0.0;
        for i in self.cursor..poses.len() {
            if i > self.cursor {
                travelled_m += poses[i].distance_to(poses[i - 1].north_m, poses[i - 1].east_m);
            }
            if travelled_m > reach_m {
                break;
            }
            rects.push(rectangle(&self.outline, &poses[i]));
        }
        rects
    }

    /// Whether some object, on its true velocity, comes within `OA_MARGIN`
    /// of the swept outline within the horizon.
    pub fn way_blocked(&self, world: &ObstacleWorld, t_s: f64, pose: &Pose) -> bool {
        self.limits.within_margin(self.nearest_m(world, t_s, pose))
    }

    /// The smallest gap between the swept outline and any object moved
    /// along its true velocity for up to the horizon.
    pub fn nearest_m(&self, world: &ObstacleWorld, t_s: f64, pose: &Pose) -> f64 {
        self.nearest(world, t_s, pose).map_or(f64::INFINITY, |(gap_m, _)| gap_m)
    }

    /// [`Self::nearest_m`] and the object it is to.
    pub fn nearest(&self, world: &ObstacleWorld, t_s: f64, pose: &Pose) -> Option<(f64, ObjectId)> {
        let swept = self.swept(pose);
        let statics = (world.statics.iter().enumerate())
            .map(|(i, shape)| (shape_clearance_m(shape, &swept), ObjectId::Static(i)));
        let movers = world.movers.iter().enumerate().filter_map(|(i, mover)| {
            let (at, velocity) = mover.state_at(t_s)?;
            let speed_mps = velocity[0].hypot(velocity[1]);
            let steps = (speed_mps * self.limits.horizon_s / OBJECT_STEP_M).ceil() as usize;
            (0..=steps)
                .map(|k| {
                    let tau_s = self.limits.horizon_s * k as f64 / steps.max(1) as f64;
                    let placed = [at[0] + velocity[0] * tau_s, at[1] + velocity[1] * tau_s];
                    shape_clearance_m(&mover.shape.translated(placed), &swept)
                })
                .reduce(f64::min)
                .map(|gap_m| (gap_m, ObjectId::Mover(i)))
        });
        statics.chain(movers).min_by(|a, b| a.0.total_cmp(&b.0))
    }

    /// Whether the course turns tighter than [`ARC_RADIUS_M`] about the
    /// cursor (over [`SHAPE_SPAN_M`] of path either side), and whether it
    /// drives in reverse there (the nearest pose that moves, ahead first).
    pub fn course_here(&self) -> (bool, bool) {
        let poses = &self.course.poses;
        if poses.is_empty() {
            return (false, false);
        }
        let at = self.cursor.min(poses.len() - 1);
        let span = |indices: &mut dyn Iterator<Item = usize>| {
            let (mut last, mut length_m) = (at, 0.0);
            for i in indices {
                length_m += poses[i].distance_to(poses[last].north_m, poses[last].east_m);
                last = i;
                if length_m >= SHAPE_SPAN_M {
                    break;
                }
            }
            (last, length_m)
        };
        let (back, back_m) = span(&mut (0..at).rev());
        let (ahead, ahead_m) = span(&mut (at + 1..poses.len()));
        let turn_rad = autopilot::geo::wrap_pi(poses[ahead].yaw_rad - poses[back].yaw_rad).abs();
        let length_m = back_m + ahead_m;
        let arc = length_m > 0.1 && turn_rad / length_m > 1.0 / ARC_RADIUS_M;
        let moving = |p: &&Pose| p.speed_mps.abs() > 0.3;
        let reverse = (poses[at..].iter().find(moving))
            .or_else(|| poses[..at].iter().rev().find(moving))
            .is_some_and(|p| p.speed_mps < 0.0);
        (arc, reverse)
    }
}

#[cfg(test)]
pub(in crate::obstacles) mod tests {
    use super::*;

    /// North at `speed_mps` from the origin, one pose per 20 ms.
    pub(in crate::obstacles) fn straight(speed_mps: f64, seconds: f64) -> Vec<Pose> {
        (0..=(seconds / 0.02) as u32)
            .map(|k| {
                let t_s = f64::from(k) * 0.02;
                Pose {
                    t_s,
                    north_m: speed_mps * t_s,
                    east_m: 0.0,
                    yaw_rad: 0.0,
                    speed_mps,
                }
            })
            .collect()
    }

    fn straight_course(speed_mps: f64) -> TruthLog {
        TruthLog {
            poses: straight(speed_mps, 40.0),
            completion_s: Some(40.0),
        }
    }

    const LIMITS: Limits = Limits {
        margin_m: 0.3,
        horizon_s: 3.0,
        plant: PlantBraking {
            tau_s: 0.3,
            brake_max_mps2: 2.0,
        },
    };

    fn post(north_m: f64, east_m: f64) -> ObstacleWorld {
        ObstacleWorld::new(
            vec![Shape::Circle {
                center: [north_m, east_m],
                radius_m: 0.1,
            }],
            Vec::new(),
        )
    }

    #[test]
    fn a_post_beside_the_lane_blocks_only_within_the_margin() {
        let course = straight_course(1.0);
        let judge = Judge::new(&course, VehicleOutline::default(), LIMITS);
        let at = course.poses[0];
        // Reach at 1 m/s: the plant stops in 0.16 + 0.177 m, plus 3 m of
        // horizon: 3.337 m, the front 3.6 m ahead of the reference point.
        assert!((LIMITS.reach_m(1.0) - 3.337).abs() < 1e-9);
        assert!(judge.way_blocked(&post(5.0, 1.0 + 0.1 + 0.30), 0.0, &at));
        assert!(!judge.way_blocked(&post(5.0, 1.0 + 0.1 + 0.31), 0.0, &at));
        // Within the margin of the swept front (poses 2 cm apart), and
        // beyond it.
        assert!(judge.way_blocked(&post(3.6 + 3.337 + 0.1 + 0.28, 0.0), 0.0, &at));
        assert!(!judge.way_blocked(&post(3.6 + 3.337 + 0.1 + 0.35, 0.0), 0.0, &at));
    }

    #[test]
    fn a_walker_is_extended_along_its_velocity_for_the_horizon() {
        let course = straight_course(1.0);
        let judge = Judge::new(&course, VehicleOutline::default(), LIMITS);
        let walker = |speed_mps: f64| {
            ObstacleWorld::new(
                Vec::new(),
                vec![MovingObstacle {
                    name: "p".into(),
                    shape: Shape::Circle {
                        center: [0.0, 0.0],
                        radius_m: 0.25,
                    },
                    path: vec![[4.0, 5.0], [4.0, -20.0]],
                    speed_mps,
                    start_s: 0.0,
                    looped: false,
                    vanish_at_end: false,
                }],
            )
        };
        let at = course.poses[0];
        // 5 m out, 3.45 m to the margin: 1.2 m/s gets there in the horizon.
        assert!(judge.way_blocked(&walker(1.2), 0.0, &at));
        assert!(!judge.way_blocked(&walker(1.1), 0.0, &at));
    }

    #[test]
    fn the_cursor_only_moves_forwards() {
        // Out north 10 m and back in reverse.
        let mut poses = straight_course(1.0).poses;
        poses.truncate(501);
        let back: Vec<Pose> = poses
            .iter()
            .rev()
            .map(|p| Pose {
                t_s: 20.0 - p.t_s,
                speed_mps: -1.0,
                ..*p
            })
            .collect();
        poses.extend(back);
        let course = TruthLog {
            poses,
            completion_s: None,
        };
        let mut judge = Judge::new(&course, VehicleOutline::default(), LIMITS);
        for p in course.poses.iter().step_by(10) {
            judge.follow(p);
        }
        assert!(judge.cursor > 900, "cursor {}", judge.cursor);
    }

    #[test]
    fn a_walker_is_on_its_line_since_it_last_turned_or_started() {
        let walker = MovingObstacle {
            name: "p".into(),
            shape: Shape::Circle {
                center: [0.0, 0.0],
                radius_m: 0.25,
            },
            path: vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]],
            speed_mps: 1.0,
            start_s: 5.0,
            looped: false,
            vanish_at_end: true,
        };
        // Standing at its first point before 5 s, since the world began:
        // as far back as the trace looks.
        assert!(on_its_line_s(&walker, 4.0) >= LINE_LOOKBACK_S);
        // Walking: the first leg from 5 s (10 m to 15 s), the second from 15 s.
        assert!((on_its_line_s(&walker, 8.0) - 3.0).abs() < 0.03);
        assert!((on_its_line_s(&walker, 16.5) - 1.5).abs() < 0.03);
        // Gone at 25 s.
        assert_eq!(on_its_line_s(&walker, 26.0), 0.0);
    }
}
