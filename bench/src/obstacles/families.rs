//! The obstacle scenario families: people standing and walking near arcs
//! of 6–15 m radius (inside, outside, at the arc's entry and exit, under the
//! swing of the trailing overhang), S-bends, a person stepping out in the
//! middle of a turn, and boxes, posts and parked cars beside straight and
//! curved lanes at 0.3, 0.5, 0.7 and 1.0 m from the swept outline.
//!
//! Each family runs forwards and in reverse, turning left and right, at
//! each speed and seed. The course is a mission whose corners the navigator
//! rounds with arcs of `WP_ARC_MARGIN` × its tightest turn (seeds 1, 2, 3
//! give 6, 15, 10 m); objects are placed from the empty run's truth: a gap is
//! the true distance to the outline swept along that run (negative: that
//! far inside it).

use sim::{Shape, VehicleOutline};

use super::classic::{PERSON_RADIUS_M, person};
use super::drive::{Course, Setup, Waypoint};
use super::truth::{Pose, TruthLog, rectangle};
use autopilot::sitl::simulation::{ModelKind, SimulationParams};

/// Arc radii the seeds cycle through, m: the two ends first, so the
/// default two seeds drive both.
const ARC_RADII_M: [f64; 3] = [6.0, 15.0, 10.0];
/// A person in the way stands this long after the vehicle first comes near,
/// then walks away.
const STAND_S: f64 = 15.0;
/// How deep a person in the way stands inside the swept outline, m.
const IN_THE_WAY_M: f64 = 0.3;
/// The gap of a person standing beside the swept outline, m.
const BESIDE_M: f64 = 0.5;

/// The course a family drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Lane {
    /// A straight leg, a 90° corner, a straight leg.
    Turn,
    /// Out to one side by 45° and back.
    SBend,
}

/// How a family's course is driven.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Variant {
    pub reverse: bool,
    pub right: bool,
    pub speed_mps: f64,
    pub seed: u64,
}

impl Variant {
    pub fn label(&self) -> String {
        format!(
            "{} {} {:.1} m/s seed {}",
            if self.reverse { "reverse" } else { "forwards" },
            if self.right { "right" } else { "left" },
            self.speed_mps,
            self.seed
        )
    }

    pub fn arc_radius_m(&self) -> f64 {
        ARC_RADII_M[((self.seed.max(1) - 1) % 3) as usize]
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Where {
    Straight,
    ArcInside,
    ArcOutside,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Object {
    Box,
    Post,
    ParkedCar,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Family {
    /// Stands inside the swept outline at mid-arc, inner side, then leaves.
    InsideArc,
    /// The same on the outer side (the front corner's swing).
    OutsideArc,
    /// Stands 0.5 m outside the swept outline at mid-arc, outer side.
    BesideArcOutside,
    /// Stands 0.5 m clear at the arc's entry, inner side.
    BesideEntry,
    /// Stands 0.5 m clear at the arc's exit, outer side.
    BesideExit,
    /// Stands where only the trailing overhang's swing reaches, then leaves.
    TailSwing,
    /// Walks across the arc on a collision course.
    CrossingArc,
    /// Waits 1 m outside the arc and steps across when the vehicle is 5 m
    /// away.
    StepOut,
    /// S-bend: stands inside the second bend, then leaves.
    SBendInside,
    /// S-bend: stands 0.5 m outside the first bend.
    SBendBeside,
    /// A static object beside the lane at a gap from the swept outline.
    Neighbour { object: Object, at: Where, gap_m: f64 },
}

impl Family {
    pub fn all() -> Vec<Family> {
        let mut list = vec![
            Family::InsideArc,
            Family::OutsideArc,
            Family::BesideArcOutside,
            Family::BesideEntry,
            Family::BesideExit,
            Family::TailSwing,
            Family::CrossingArc,
            Family::StepOut,
            Family::SBendInside,
            Family::SBendBeside,
        ];
        for object in [Object::Box, Object::Post, Object::ParkedCar] {
            for at in [Where::Straight, Where::ArcInside, Where::ArcOutside] {
                for gap_m in [0.3, 0.5, 0.7, 1.0] {
                    list.push(Family::Neighbour { object, at, gap_m });
                }
            }
        }
        list
    }

    pub fn name(&self) -> String {
        match self {
            Family::InsideArc => "turn: person standing inside the arc".into(),
            Family::OutsideArc => "turn: person standing outside the arc".into(),
            Family::BesideArcOutside => "turn: person 0.5 m outside the arc".into(),
            Family::BesideEntry => "turn: person 0.5 m inside the arc entry".into(),
            Family::BesideExit => "turn: person 0.5 m outside the arc exit".into(),
            Family::TailSwing => "turn: person under the overhang's swing".into(),
            Family::CrossingArc => "turn: person walking across the arc".into(),
            Family::StepOut => "turn: person stepping out mid-turn".into(),
            Family::SBendInside => "S-bend: person standing inside 2nd bend".into(),
            Family::SBendBeside => "S-bend: person 0.5 m outside 1st bend".into(),
            Family::Neighbour { object, at, gap_m } => {
                let object = match object {
                    Object::Box => "box 0.8 m",
                    Object::Post => "post",
                    Object::ParkedCar => "parked car",
                };
                let at = match at {
                    Where::Straight => "straight lane",
                    Where::ArcInside => "inside the arc",
                    Where::ArcOutside => "outside the arc",
                };
                format!("{object} {gap_m:.1} m beside, {at}")
            }
        }
    }

    pub fn lane(&self) -> Lane {
        match self {
            Family::SBendInside | Family::SBendBeside => Lane::SBend,
            _ => Lane::Turn,
        }
    }

    /// Whether the vehicle must stop (something stands in or within
    /// `OA_MARGIN` of the swept outline); the others must pass without one.
    pub fn must_stop(&self) -> bool {
        match self {
            Family::InsideArc | Family::OutsideArc | Family::TailSwing | Family::SBendInside => true,
            Family::Neighbour { gap_m, .. } => *gap_m < BESIDE_M,
            _ => false,
        }
    }

    /// Whether nothing at all should stop the vehicle (people beside the
    /// path, neighbours 0.5 m and more away).
    pub fn must_pass(&self) -> bool {
        match self {
            Family::BesideArcOutside | Family::BesideEntry | Family::BesideExit | Family::SBendBeside => true,
            Family::Neighbour { gap_m, .. } => *gap_m >= BESIDE_M,
            _ => false,
        }
    }

    /// A static neighbour inside the margin stays: the run cannot finish.
    fn blocked_by_design(&self) -> bool {
        matches!(self, Family::Neighbour { .. }) && self.must_stop()
    }

    // Stays whole: one flat arm per family (sharing the placing closures
    // above the match), each placing its obstacles.
    pub fn setup(&self, log: &TruthLog, outline: &VehicleOutline, variant: &Variant) -> Result<Setup, String> {
        let turn = Turn::find(log, 0).ok_or("the empty run has no turn")?;
        let mut setup = Setup {
            blocked_by_design: self.blocked_by_design(),
            ..Setup::default()
        };
        let placer = Placer { log, outline };
        let disc = |radius_m: f64| Shape::Circle {
            center: [0.0, 0.0],
            radius_m,
        };
        let person_disc = disc(PERSON_RADIUS_M);
        let mut stand = |at: [f64; 2], leave_dir: [f64; 2]| {
            let near_s = log.first_near(outline, at, 3.0, 0.0).unwrap_or(20.0);
            let away = [at[0] + leave_dir[0] * 6.0, at[1] + leave_dir[1] * 6.0];
            setup
                .world
                .movers
                .push(person("person", vec![at, away], 1.0, near_s + STAND_S));
        };
        match *self {
            Family::InsideArc | Family::OutsideArc => {
                let inner = *self == Family::InsideArc;
                let (anchor, u) = turn.mid(log, inner);
                let at = placer.place(&person_disc, anchor.point(), u, -IN_THE_WAY_M)?;
                stand(at, u);
            }
            Family::BesideArcOutside => {
                let (anchor, u) = turn.mid(log, false);
                let at = placer.place(&person_disc, anchor.point(), u, BESIDE_M)?;
                setup.world.movers.push(person("person", vec![at], 0.0, 0.0));
            }
            Family::BesideEntry | Family::BesideExit => {
                let entry = *self == Family::BesideEntry;
                let (anchor, u) = if entry {
                    turn.entry(log, true)
                } else {
                    turn.exit(log, false)
                };
                let at = placer.place(&person_disc, anchor.point(), u, BESIDE_M)?;
                setup.world.movers.push(person("person", vec![at], 0.0, 0.0));
            }
            Family::TailSwing => {
                let (corner, u) = turn.swing(log, outline).ok_or("no overhang swing")?;
                // Touching the swept outline from outside, then half the
                // swing's depth in: only the swinging corner reaches it.
                let at = placer.place(&person_disc, corner, u, 0.0)?;
                let swing_m = turn.swing_depth_m(log, outline);
                let at = [at[0] - u[0] * swing_m / 2.0, at[1] - u[1] * swing_m / 2.0];
                stand(at, u);
            }
            Family::CrossingArc => {
                let (anchor, u) = turn.mid(log, false);
                let p = anchor.point();
                let t_x = log.first_near(outline, p, 0.0, 0.0).unwrap_or(20.0);
                let walk_mps = 1.0;
                let lead_m = outline.half_width_m + 6.0;
                let from = [p[0] + u[0] * lead_m, p[1] + u[1] * lead_m];
                let to = [p[0] - u[0] * 10.0, p[1] - u[1] * 10.0];
                let start_s = t_x - lead_m / walk_mps;
                setup
                    .world
                    .movers
                    .push(person("person", vec![from, to], walk_mps, start_s));
            }
            Family::StepOut => {
                let (anchor, u) = turn.mid(log, false);
                let at = placer.place(&person_disc, anchor.point(), u, 1.0)?;
                let start_s = log.first_near(outline, at, 5.0, 0.0).unwrap_or(20.0);
                let to = [at[0] - u[0] * 8.0, at[1] - u[1] * 8.0];
                setup.world.movers.push(person("person", vec![at, to], 1.4, start_s));
            }
            Family::SBendInside => {
                let second = Turn::find(log, 1).ok_or("the S-bend has no second bend")?;
                let (anchor, u) = second.mid(log, true);
                let at = placer.place(&person_disc, anchor.point(), u, -IN_THE_WAY_M)?;
                stand(at, u);
            }
            Family::SBendBeside => {
                let (anchor, u) = turn.mid(log, false);
                let at = placer.place(&person_disc, anchor.point(), u, BESIDE_M)?;
                setup.world.movers.push(person("person", vec![at], 0.0, 0.0));
            }
            Family::Neighbour { object, at, gap_m } => {
                let (anchor, u) = match at {
                    Where::Straight => {
                        let side = if variant.right { 1.0 } else { -1.0 };
                        let p = turn.before(log, 8.0);
                        (p, side_of(&p, side))
                    }
                    Where::ArcInside => turn.mid(log, true),
                    Where::ArcOutside => turn.mid(log, false),
                };
                let shape = neighbour(object, anchor.yaw_rad);
                let center = placer.place(&shape, anchor.point(), u, gap_m)?;
                setup.world.statics.push(shape.translated(center));
            }
        }
        Ok(setup)
    }
}

/// An object about its centre, its length along `yaw_rad`.
fn neighbour(object: Object, yaw_rad: f64) -> Shape {
    let (length_m, width_m) = match object {
        Object::Box => (0.8, 0.8),
        Object::ParkedCar => (4.5, 1.8),
        Object::Post => {
            return Shape::Circle {
                center: [0.0, 0.0],
                radius_m: 0.15,
            };
        }
    };
    Shape::Box {
        center: [0.0, 0.0],
        length_m,
        width_m,
        yaw_rad,
    }
}

/// The mission of a lane.
pub fn course(lane: Lane, variant: &Variant) -> Course {
    // Forwards the path heads north, in reverse south; "right" is the
    // path's right.
    let d = if variant.reverse { -1.0 } else { 1.0 };
    let s = if variant.right { 1.0 } else { -1.0 };
    let wp = |north_m: f64, east_m: f64| Waypoint {
        north_m: d * north_m,
        east_m: d * s * east_m,
        reverse: variant.reverse,
    };
    let waypoints = match lane {
        Lane::Turn => vec![wp(35.0, 0.0), wp(35.0, 25.0)],
        Lane::SBend => vec![wp(15.0, 0.0), wp(30.0, 15.0), wp(45.0, 15.0)],
    };
    Course {
        waypoints,
        speed_mps: variant.speed_mps,
        params: vec![(
            "WP_ARC_MARGIN".to_string(),
            (variant.arc_radius_m() / tightest_turn_m()).clamp(1.0, 5.0),
        )],
    }
}

/// The navigator's tightest turn at default parameters (wheelbase over the
/// tangent of the largest steering angle).
pub fn tightest_turn_m() -> f64 {
    let p = SimulationParams::new(ModelKind::Ackermann);
    let wheelbase_m = f64::from(p.core.vehicle.wheelbase_m.get(&p.table));
    let steer_rad = f64::from(p.core.vehicle.steer_max_deg.get(&p.table)).to_radians();
    wheelbase_m / steer_rad.tan()
}

impl Pose {
    fn point(&self) -> [f64; 2] {
        [self.north_m, self.east_m]
    }
}

/// The unit vector to the right (`side` 1) or left (-1) of the path at
/// `pose` (the body's right is the path's right forwards, its left in
/// reverse; taking the body's side keeps it simple: a lane has two sides).
fn side_of(pose: &Pose, side: f64) -> [f64; 2] {
    let path_yaw = if pose.speed_mps < 0.0 {
        pose.yaw_rad + std::f64::consts::PI
    } else {
        pose.yaw_rad
    };
    // Right of a bearing: bearing + 90°.
    let right = [-path_yaw.sin(), path_yaw.cos()];
    [right[0] * side, right[1] * side]
}

/// A bend of the empty run: where the heading turned.
struct Turn {
    entry: usize,
    mid: usize,
    exit: usize,
    /// +1: the path turned right (clockwise), -1 left.
    sign: f64,
}

/// The heading has started turning once it is this far from the leg's.
const TURNING_RAD: f64 = 0.02;

impl Turn {
    /// The `index`-th bend of the log (0: the first).
    fn find(log: &TruthLog, index: usize) -> Option<Turn> {
        let poses = &log.poses;
        let moving: Vec<usize> = (0..poses.len()).filter(|&i| poses[i].speed_mps.abs() > 0.05).collect();
        let mut from = *moving.first()?;
        for k in 0..=index {
            let yaw0 = poses[from].yaw_rad;
            let entry = (from..poses.len()).find(|&i| wrap(poses[i].yaw_rad - yaw0).abs() > TURNING_RAD)?;
            // The bend ends where the heading stops changing.
            let exit = (entry + 1..poses.len())
                .find(|&i| {
                    let ahead = (i + 25).min(poses.len() - 1);
                    wrap(poses[ahead].yaw_rad - poses[i].yaw_rad).abs() < TURNING_RAD / 2.0
                        && poses[i].speed_mps.abs() > 0.05
                })
                .unwrap_or(poses.len() - 1);
            let turned = wrap(poses[exit].yaw_rad - poses[entry].yaw_rad);
            let mid = (entry..=exit)
                .find(|&i| wrap(poses[i].yaw_rad - poses[entry].yaw_rad).abs() >= turned.abs() / 2.0)
                .unwrap_or(entry);
            // Yaw grows clockwise; the path's heading (the body's, or its
            // opposite in reverse) turns with it.
            let sign = turned.signum();
            if k == index {
                return Some(Turn { entry, mid, exit, sign });
            }
            from = exit;
        }
        None
    }

    /// The unit vector towards the inside (or outside) of the bend at pose `i`.
    fn across(&self, log: &TruthLog, i: usize, inner: bool) -> [f64; 2] {
        let side = if inner { self.sign } else { -self.sign };
        side_of(&log.poses[i], side)
    }

    fn mid(&self, log: &TruthLog, inner: bool) -> (Pose, [f64; 2]) {
        (log.poses[self.mid], self.across(log, self.mid, inner))
    }

    fn entry(&self, log: &TruthLog, inner: bool) -> (Pose, [f64; 2]) {
        (log.poses[self.entry], self.across(log, self.entry, inner))
    }

    fn exit(&self, log: &TruthLog, inner: bool) -> (Pose, [f64; 2]) {
        (log.poses[self.exit], self.across(log, self.exit, inner))
    }

    /// The pose `back_m` of path before the bend.
    fn before(&self, log: &TruthLog, back_m: f64) -> Pose {
        let entry = log.poses[self.entry];
        log.poses[..self.entry]
            .iter()
            .rev()
            .find(|p| p.distance_to(entry.north_m, entry.east_m) >= back_m)
            .copied()
            .unwrap_or(log.poses[0])
    }

    /// How far the outline's corners reach outside the incoming lane's outer
    /// edge while the bend starts, and where: the trailing overhang swings
    /// out before the vehicle follows the arc.
    fn swing_points(&self, log: &TruthLog, outline: &VehicleOutline) -> Vec<(f64, [f64; 2])> {
        let entry = log.poses[self.entry];
        let out = self.across(log, self.entry, false);
        let edge =
            |p: [f64; 2]| (p[0] - entry.north_m) * out[0] + (p[1] - entry.east_m) * out[1] - outline.half_width_m;
        log.poses[self.entry..=self.mid]
            .iter()
            .flat_map(|pose| rectangle(outline, pose).corners())
            .map(|c| (edge(c), c))
            .collect()
    }

    fn swing(&self, log: &TruthLog, outline: &VehicleOutline) -> Option<([f64; 2], [f64; 2])> {
        let out = self.across(log, self.entry, false);
        self.swing_points(log, outline)
            .into_iter()
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, corner)| (corner, out))
    }

    fn swing_depth_m(&self, log: &TruthLog, outline: &VehicleOutline) -> f64 {
        self.swing_points(log, outline)
            .into_iter()
            .map(|(d, _)| d)
            .fold(0.0, f64::max)
    }
}

fn wrap(a: f64) -> f64 {
    autopilot::geo::wrap_pi(a)
}

/// Places shapes at a true gap from the empty run's swept outline.
struct Placer<'a> {
    log: &'a TruthLog,
    outline: &'a VehicleOutline,
}

impl Placer<'_> {
    /// Where along `from + x·u` to put `shape` (given about its centre) so
    /// its gap to the swept outline is `gap_m`; a negative gap is that deep
    /// inside it.
    fn place(&self, shape: &Shape, from: [f64; 2], u: [f64; 2], gap_m: f64) -> Result<[f64; 2], String> {
        let at = |x: f64| [from[0] + u[0] * x, from[1] + u[1] * x];
        let gap = |x: f64| self.log.clearance_m(self.outline, &shape.translated(at(x)));
        let target_m = gap_m.max(0.0);
        // Start well outside; the gap shrinks about one for one as the
        // shape moves in, so stepping by the error converges from outside.
        let mut x = self.outline.half_width_m + 6.0;
        for _ in 0..60 {
            let error_m = gap(x) - target_m;
            if error_m.abs() < 1e-9 {
                break;
            }
            x -= error_m;
        }
        let reached_m = gap(x);
        if (reached_m - target_m).abs() > 1e-6 {
            return Err(format!(
                "could not place an object at {gap_m} m (reached {reached_m:.4} m)"
            ));
        }
        Ok(at(x + gap_m.min(0.0)))
    }
}
