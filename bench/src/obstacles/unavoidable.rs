//! Whether a collision was unavoidable, judged from the truth alone: no
//! reaction time, deceleration or other allowance of Furrow's parameters.
//!
//! The rule: an object can first be **known** at the later of
//! - the instant it began the straight line it hit the vehicle from (same
//!   true velocity, standing included; a static object has stood there
//!   forever): before that it was going somewhere else, and
//! - the first instant any beam of the vehicle's scanners reached it
//!   unoccluded (the simulator's own ray casting, without noise or
//!   dropouts, at the true pose): before that nothing could see it.
//!
//! From that instant the run is **replayed with the vehicle braking as hard
//! as the plant truly can** (a zero command to the simulated drive at once:
//! its braking limit through its lag, see [`super::plant`]), from its speed
//! then, along the path it actually drove, while
//! the object moves as it truly did. The collision is unavoidable only if
//! the outline still touches the object before that braking vehicle comes
//! to rest. A vehicle at rest at that instant could always have stayed at
//! rest: any collision after it counts against the vehicle. An object no
//! beam reached before the contact is unavoidable.

use std::time::Duration;

use sim::{ObstacleWorld, Shape, SimScannerConfig, VehicleOutline, VehicleTruth, render_scan};

use super::plant::PlantBraking;
use super::truth::{MOVING_MPS, Pose, on_its_line_s, rectangle};

/// Replay time step, s (the core tick).
const REPLAY_STEP_S: f64 = 0.02;
/// A beam reaches the object when nothing is nearer along it than this
/// less than the object (the scan's ranges are `f32`).
const BEAM_TOLERANCE_M: f64 = 1e-3;

/// The obstacle world as it was over time: scenarios change a mover's path
/// during the run (people stepping aside), so the past is read from the
/// version that was in force then.
#[derive(Clone, Debug, Default)]
pub struct WorldHistory {
    /// (in force from, world), in time order.
    versions: Vec<(f64, ObstacleWorld)>,
}

impl WorldHistory {
    pub fn new(world: ObstacleWorld) -> Self {
        WorldHistory {
            versions: vec![(f64::NEG_INFINITY, world)],
        }
    }

    /// The world changed at `t_s`.
    pub fn push(&mut self, t_s: f64, world: ObstacleWorld) {
        self.versions.push((t_s, world));
    }

    /// The world in force at `t_s`.
    pub fn at(&self, t_s: f64) -> &ObstacleWorld {
        let k = self.versions.partition_point(|(from_s, _)| *from_s <= t_s);
        &self.versions[k.saturating_sub(1)].1
    }
}

/// An object of the world, by index.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObjectId {
    Static(usize),
    Mover(usize),
}

impl ObjectId {
    /// Its true shape at `t_s` (none once a mover has vanished).
    pub fn shape_at(self, history: &WorldHistory, t_s: f64) -> Option<Shape> {
        let world = history.at(t_s);
        match self {
            ObjectId::Static(i) => world.statics.get(i).cloned(),
            ObjectId::Mover(i) => world.movers.get(i)?.shape_at(t_s),
        }
    }

    /// When it began the straight line it is on at `t_s`.
    fn line_since_s(self, history: &WorldHistory, t_s: f64) -> f64 {
        match self {
            ObjectId::Static(_) => f64::NEG_INFINITY,
            ObjectId::Mover(i) => history
                .at(t_s)
                .movers
                .get(i)
                .map_or(t_s, |m| t_s - on_its_line_s(m, t_s)),
        }
    }

    /// Whether it walks at `t_s` (its true velocity; a static never does).
    pub fn walking(self, world: &ObstacleWorld, t_s: f64) -> bool {
        match self {
            ObjectId::Static(_) => false,
            ObjectId::Mover(i) => world
                .mover_state(i, t_s)
                .is_some_and(|(_, v)| v[0].hypot(v[1]) > MOVING_MPS),
        }
    }

    pub fn label(self) -> String {
        match self {
            ObjectId::Static(i) => format!("static {i}"),
            ObjectId::Mover(i) => format!("mover {i}"),
        }
    }
}

/// The objects touching `rect` at `t_s`.
pub fn touching(world: &ObstacleWorld, rect: &sim::Rectangle, t_s: f64) -> Vec<ObjectId> {
    let statics = (world.statics.iter().enumerate())
        .filter(|(_, s)| s.distance_to_rectangle_m(rect) <= 0.0)
        .map(|(i, _)| ObjectId::Static(i));
    let movers = (world.movers.iter().enumerate())
        .filter(|(_, m)| m.shape_at(t_s).is_some_and(|s| s.distance_to_rectangle_m(rect) <= 0.0))
        .map(|(i, _)| ObjectId::Mover(i));
    statics.chain(movers).collect()
}

/// The object nearest `rect` at `t_s`, and its gap.
pub fn nearest(world: &ObstacleWorld, rect: &sim::Rectangle, t_s: f64) -> Option<(ObjectId, f64)> {
    let statics =
        (world.statics.iter().enumerate()).map(|(i, s)| (ObjectId::Static(i), s.distance_to_rectangle_m(rect)));
    let movers = (world.movers.iter().enumerate())
        .filter_map(|(i, m)| Some((ObjectId::Mover(i), m.shape_at(t_s)?.distance_to_rectangle_m(rect))));
    statics.chain(movers).min_by(|a, b| a.1.total_cmp(&b.1))
}

/// What the judge of unavoidability needs of a run.
pub struct RunTruth<'a> {
    /// The run's true poses, one per core tick, from arming to its end.
    pub poses: &'a [Pose],
    pub history: &'a WorldHistory,
    pub scanners: &'a [SimScannerConfig],
    pub outline: VehicleOutline,
    /// How the plant brakes.
    pub plant: PlantBraking,
}

impl RunTruth<'_> {
    /// Why the collision with `object` beginning at `t_s` was unavoidable,
    /// or `None` when braking from the instant it could be known avoids it.
    pub fn unavoidable(&self, object: ObjectId, t_s: f64) -> Option<String> {
        let Some(known_s) = self.known_s(object, t_s) else {
            return Some(format!(
                " (unavoidable: {} never reached by a beam before)",
                object.label()
            ));
        };
        let start = self.poses.partition_point(|p| p.t_s < known_s);
        let from = self.poses.get(start.min(self.poses.len().saturating_sub(1)))?;
        if from.speed_mps.abs() <= MOVING_MPS {
            return None;
        }
        let touch_s = self.braking_touches(object, start)?;
        Some(format!(
            " (unavoidable: {} known at t {:.2} at {:.2} m/s, still touched braking as the plant can from then, at t {touch_s:.2})",
            object.label(),
            from.t_s,
            from.speed_mps.abs(),
        ))
    }

    /// The first instant the object, as it is at `t_s`, could be known: the
    /// later of when it began its present straight line and when a beam
    /// first reached it (none if no beam did by `t_s`).
    pub fn known_s(&self, object: ObjectId, t_s: f64) -> Option<f64> {
        let line_s = object.line_since_s(self.history, t_s);
        Some(line_s.max(self.first_seen_s(object, t_s)?))
    }

    /// The first pose time, up to `until_s`, at which a scanner's beam
    /// reached the object.
    fn first_seen_s(&self, object: ObjectId, until_s: f64) -> Option<f64> {
        self.poses
            .iter()
            .take_while(|p| p.t_s <= until_s)
            .find(|p| self.visible(object, p))
            .map(|p| p.t_s)
    }

    /// Whether some beam reaches the object, unoccluded, from `pose`.
    fn visible(&self, object: ObjectId, pose: &Pose) -> bool {
        let Some(shape) = object.shape_at(self.history, pose.t_s) else {
            return false;
        };
        let world = self.history.at(pose.t_s);
        let truth = VehicleTruth {
            north_m: pose.north_m,
            east_m: pose.east_m,
            yaw_rad: pose.yaw_rad,
            ..VehicleTruth::default()
        };
        self.scanners.iter().filter(|c| c.enabled).any(|config| {
            let exact = SimScannerConfig {
                range_sigma_m: 0.0,
                dropout_probability: 0.0,
                ..*config
            };
            let t = Duration::from_secs_f64(pose.t_s.max(0.0));
            let scan = render_scan(&exact, world, &truth, t, 0, 0);
            let (origin, forward_rad) = exact.scanner_pose(&truth);
            let first_rad = forward_rad - exact.fov_rad / 2.0;
            scan.ranges_m.iter().enumerate().any(|(i, &range_m)| {
                let bearing_rad = first_rad + i as f64 * exact.step_rad;
                shape
                    .raycast(origin, bearing_rad, exact.max_range_m)
                    .is_some_and(|object_m| f64::from(range_m) >= object_m - BEAM_TOLERANCE_M)
            })
        })
    }

    /// Replays the plant's braking from pose `start` along the poses
    /// driven; the time of the first contact with `object` while the
    /// braking vehicle still moves.
    fn braking_touches(&self, object: ObjectId, start: usize) -> Option<f64> {
        let poses = &self.poses[start..];
        let v0_mps = poses[0].speed_mps.abs();
        let mut along = PathCursor::new(poses);
        let mut k = 0u32;
        loop {
            let tau_s = f64::from(k) * REPLAY_STEP_S;
            if self.plant.speed_mps(v0_mps, tau_s) <= MOVING_MPS {
                return None;
            }
            let t_s = poses[0].t_s + tau_s;
            let pose = along.at(self.plant.distance_m(v0_mps, tau_s));
            let rect = rectangle(&self.outline, &pose);
            if object
                .shape_at(self.history, t_s)
                .is_some_and(|s| s.distance_to_rectangle_m(&rect) <= 0.0)
            {
                return Some(t_s);
            }
            k += 1;
        }
    }
}

/// Poses along a driven path by distance from its first, interpolated.
struct PathCursor<'a> {
    poses: &'a [Pose],
    /// Index of the segment's end and the path length to its start.
    next: usize,
    start_m: f64,
}

impl<'a> PathCursor<'a> {
    fn new(poses: &'a [Pose]) -> Self {
        PathCursor {
            poses,
            next: 1,
            start_m: 0.0,
        }
    }

    /// The pose `distance_m` along the path (distances asked for only grow);
    /// the path's last pose beyond its end.
    fn at(&mut self, distance_m: f64) -> Pose {
        while let Some(b) = self.poses.get(self.next) {
            let a = &self.poses[self.next - 1];
            let length_m = a.distance_to(b.north_m, b.east_m);
            if self.start_m + length_m >= distance_m {
                let f = if length_m > 0.0 {
                    (distance_m - self.start_m) / length_m
                } else {
                    0.0
                };
                return Pose {
                    north_m: a.north_m + f * (b.north_m - a.north_m),
                    east_m: a.east_m + f * (b.east_m - a.east_m),
                    yaw_rad: a.yaw_rad + f * autopilot::geo::wrap_pi(b.yaw_rad - a.yaw_rad),
                    ..*a
                };
            }
            self.start_m += length_m;
            self.next += 1;
        }
        *self.poses.last().expect("a replay starts at a pose")
    }
}

#[cfg(test)]
pub(in crate::obstacles) mod tests {
    use super::*;
    use crate::obstacles::truth::tests::straight;
    use sim::MovingObstacle;

    /// A person walking west at 1.5 m/s from `east_m` at `north_m`, from
    /// `start_s`.
    pub(in crate::obstacles) fn walker(start_s: f64, north_m: f64, east_m: f64) -> ObstacleWorld {
        ObstacleWorld::new(
            Vec::new(),
            vec![MovingObstacle {
                name: "p".into(),
                shape: Shape::Circle {
                    center: [0.0, 0.0],
                    radius_m: 0.25,
                },
                path: vec![[north_m, east_m], [north_m, -10.0]],
                speed_mps: 1.5,
                start_s,
                looped: false,
                vanish_at_end: false,
            }],
        )
    }

    fn judge<'a>(poses: &'a [Pose], history: &'a WorldHistory, scanners: &'a [SimScannerConfig]) -> RunTruth<'a> {
        RunTruth {
            poses,
            history,
            scanners,
            outline: VehicleOutline::default(),
            plant: PlantBraking {
                tau_s: 0.3,
                brake_max_mps2: 2.0,
            },
        }
    }

    // The vehicle drives north at 2 m/s, its front 3.6 m ahead of the
    // reference point; both walkers reach the lane's edge (east 1.25 m with
    // their radius) at 5.1 s, beside the front.
    const CONTACT_S: f64 = 5.1;

    #[test]
    fn a_person_stepping_out_just_ahead_is_unavoidable() {
        let poses = straight(2.0, 20.0);
        let scanners = [SimScannerConfig::default()];
        // Standing 0.75 m from the lane until 4.6 s: braking from then
        // (2 m/s, 1 s, 1 m) still reaches them.
        let close = WorldHistory::new(walker(4.6, 13.6, 2.0));
        let why = judge(&poses, &close, &scanners).unavoidable(ObjectId::Mover(0), CONTACT_S);
        assert!(why.is_some_and(|w| w.contains("known at t 4.60")));
    }

    #[test]
    fn a_person_walking_in_from_afar_is_avoidable() {
        let poses = straight(2.0, 20.0);
        let scanners = [SimScannerConfig::default()];
        // 6.75 m to walk: on that line, and in view, from 0.6 s.
        let far = WorldHistory::new(walker(0.6, 13.6, 8.0));
        assert!(
            judge(&poses, &far, &scanners)
                .unavoidable(ObjectId::Mover(0), CONTACT_S)
                .is_none()
        );
    }

    #[test]
    fn an_object_no_beam_reaches_is_unavoidable() {
        let poses = straight(2.0, 20.0);
        // A scanner looking backwards only sees neither the walker nor a
        // post ahead before the contact.
        let backwards = [SimScannerConfig {
            mount_x_m: -0.8,
            mount_yaw_rad: std::f64::consts::PI,
            fov_rad: 90f64.to_radians(),
            ..SimScannerConfig::default()
        }];
        let far = WorldHistory::new(walker(0.6, 13.6, 8.0));
        assert!(
            judge(&poses, &far, &backwards)
                .unavoidable(ObjectId::Mover(0), CONTACT_S)
                .is_some()
        );
        let post = WorldHistory::new(ObstacleWorld::new(
            vec![Shape::Circle {
                center: [13.0, 0.0],
                radius_m: 0.2,
            }],
            Vec::new(),
        ));
        assert!(
            judge(&poses, &post, &backwards)
                .unavoidable(ObjectId::Static(0), 4.6)
                .is_some()
        );
        // Seen from the start by the front scanner: 1.1 m of braking was enough.
        let front = [SimScannerConfig::default()];
        assert!(
            judge(&poses, &post, &front)
                .unavoidable(ObjectId::Static(0), 4.6)
                .is_none()
        );
    }

    #[test]
    fn a_vehicle_at_rest_when_the_object_is_known_could_stay_there() {
        let mut poses = straight(2.0, 20.0);
        for p in poses.iter_mut().take_while(|p| p.t_s < 4.7) {
            p.speed_mps = 0.0;
            p.north_m = 0.0;
        }
        let scanners = [SimScannerConfig::default()];
        let close = WorldHistory::new(walker(4.6, 13.6, 2.0));
        assert!(
            judge(&poses, &close, &scanners)
                .unavoidable(ObjectId::Mover(0), CONTACT_S)
                .is_none()
        );
    }

    #[test]
    fn the_path_cursor_interpolates_along_the_poses() {
        let poses = straight(1.0, 2.0);
        let mut cursor = PathCursor::new(&poses);
        assert!((cursor.at(0.5).north_m - 0.5).abs() < 1e-9);
        assert!((cursor.at(1.234).north_m - 1.234).abs() < 1e-9);
        assert_eq!(cursor.at(9.0).north_m, poses.last().unwrap().north_m);
    }

    #[test]
    fn the_history_gives_the_world_in_force() {
        let mut history = WorldHistory::new(ObstacleWorld::default());
        history.push(3.0, walker(0.0, 1.0, 2.0));
        assert!(history.at(2.9).movers.is_empty());
        assert_eq!(history.at(3.0).movers.len(), 1);
        assert_eq!(history.at(10.0).movers.len(), 1);
    }
}
