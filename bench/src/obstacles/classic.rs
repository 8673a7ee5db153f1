//! The scenarios of docs/architecture.md §Obstacles on a straight leg north: people crossing at
//! several speeds and angles, head-on, walking away, stepping out from
//! behind a parked car, a static box on the path (stop, detour), a person
//! crossing behind a vehicle reversing into a slot, a corridor.
//!
//! Movers are placed on a collision course: each reaches the crossing point
//! when the empty run's outline did, so doing nothing would hit.

use sim::{MovingObstacle, Shape, VehicleOutline};

use super::drive::{Course, Setup, Waypoint, Yield};
use super::truth::TruthLog;

/// A person: a disc of this radius (two legs and a body seen at knee
/// height).
pub const PERSON_RADIUS_M: f64 = 0.25;
/// The leg every forward scenario drives along: north from home.
const LEG_M: f64 = 50.0;
/// Where movers cross the path (north of home, m).
const CROSSING_N: f64 = 25.0;
/// How long a crossing person is seen walking before reaching the path.
const LEAD_S: f64 = 12.0;

#[derive(Clone, Debug)]
pub enum Classic {
    Crossing { person_mps: f64, angle_deg: f64 },
    HeadOn,
    WalkingAway,
    ParkedCar,
    StaticBox { detour: bool },
    ReverseSlot,
    Corridor,
}

impl Classic {
    pub fn all() -> Vec<(String, Classic)> {
        let mut list = Vec::new();
        for person_mps in [0.5, 1.0, 1.5, 2.0] {
            for angle_deg in [45.0, 90.0, 135.0] {
                list.push((
                    format!("crossing {person_mps:.1} m/s at {angle_deg:.0}°"),
                    Classic::Crossing { person_mps, angle_deg },
                ));
            }
        }
        list.extend([
            ("head-on (person yields at 5 m)".to_string(), Classic::HeadOn),
            ("walking away ahead".to_string(), Classic::WalkingAway),
            ("person from behind parked car".to_string(), Classic::ParkedCar),
            (
                "static box on path (stop)".to_string(),
                Classic::StaticBox { detour: false },
            ),
            (
                "static box on path (detour)".to_string(),
                Classic::StaticBox { detour: true },
            ),
            ("person behind, reversing into slot".to_string(), Classic::ReverseSlot),
            ("corridor, walls 0.6 m beside".to_string(), Classic::Corridor),
        ]);
        list
    }

    pub fn course(&self, speed_mps: f64) -> Course {
        let wp = |north_m: f64, reverse: bool| Waypoint {
            north_m,
            east_m: 0.0,
            reverse,
        };
        let waypoints = match self {
            Classic::ReverseSlot => vec![wp(30.0, false), wp(10.0, true)],
            Classic::WalkingAway => vec![wp(70.0, false)],
            _ => vec![wp(LEG_M, false)],
        };
        let params = match self {
            Classic::StaticBox { detour: true } => vec![("OA_TYPE".to_string(), 1.0)],
            _ => Vec::new(),
        };
        Course {
            waypoints,
            speed_mps,
            params,
        }
    }

    // Stays whole: one flat arm per scenario, each placing its obstacles.
    pub fn setup(&self, log: &TruthLog, outline: &VehicleOutline) -> Setup {
        let half_width_m = outline.half_width_m;
        let reach = |point: [f64; 2], within_m: f64, after_s: f64, otherwise_s: f64| {
            log.first_near(outline, point, within_m, after_s).unwrap_or(otherwise_s)
        };
        let mut setup = Setup::default();
        let (statics, movers) = (&mut setup.world.statics, &mut setup.world.movers);
        match *self {
            Classic::Crossing { person_mps, angle_deg } => {
                // Direction of walk: angle_deg from the vehicle's heading
                // (north), coming from its left.
                let a = f64::to_radians(angle_deg);
                let dir = [a.cos(), a.sin()];
                let t_x = reach([CROSSING_N, 0.0], 0.0, 0.0, 25.0);
                let lead_m = person_mps * LEAD_S;
                let start = [CROSSING_N - dir[0] * lead_m, -dir[1] * lead_m];
                let end = [CROSSING_N + dir[0] * 15.0, dir[1] * 15.0];
                movers.push(person("person", vec![start, end], person_mps, t_x - LEAD_S));
            }
            Classic::HeadOn => {
                movers.push(person("person", vec![[60.0, 0.0], [-20.0, 0.0]], 1.0, 0.0));
                setup.yields.push(Yield {
                    mover: 0,
                    at_m: 5.0,
                    side_m: half_width_m + 1.5,
                });
            }
            Classic::WalkingAway => {
                // Starts 12 m ahead, walks away slower than the vehicle, then
                // leaves the path to the right after 30 m.
                let n0 = 3.6 + 12.0;
                movers.push(person(
                    "person",
                    vec![[n0, 0.0], [n0 + 30.0, 0.0], [n0 + 32.0, 4.0], [n0 + 40.0, 8.0]],
                    0.6,
                    0.0,
                ));
            }
            Classic::ParkedCar => {
                // A car parked left of the path, its near side 1.5 m from the
                // vehicle's; a person waits on its far side and walks out past
                // its front and across the path when the vehicle's front is
                // 7 m from the crossing line.
                let car_e = -(half_width_m + 1.5 + 0.9);
                statics.push(Shape::Box {
                    center: [CROSSING_N - 2.6, car_e],
                    length_m: 4.5,
                    width_m: 1.8,
                    yaw_rad: 0.0,
                });
                let start_s = reach([CROSSING_N, 0.0], 7.0, 0.0, 20.0);
                movers.push(person(
                    "person",
                    vec![
                        [CROSSING_N - 1.2, car_e - 1.4],
                        [CROSSING_N, car_e + 0.2],
                        [CROSSING_N, 6.0],
                    ],
                    1.4,
                    start_s,
                ));
            }
            Classic::StaticBox { detour } => {
                statics.push(Shape::Box {
                    center: [CROSSING_N, 0.2],
                    length_m: 1.0,
                    width_m: 1.0,
                    yaw_rad: 0.0,
                });
                setup.blocked_by_design = !detour;
            }
            Classic::ReverseSlot => {
                // Crosses behind the reversing vehicle at 1 m/s, right to
                // left, once it has turned round at the far end.
                let x = 18.0;
                let turned_s = log
                    .poses
                    .iter()
                    .max_by(|a, b| a.north_m.total_cmp(&b.north_m))
                    .map_or(0.0, |p| p.t_s);
                let t_x = reach([x, 0.0], 0.0, turned_s, 45.0);
                let lead_m = 1.0 * LEAD_S;
                movers.push(person("person", vec![[x, lead_m], [x, -15.0]], 1.0, t_x - LEAD_S));
            }
            Classic::Corridor => {
                let e = half_width_m + 0.6 + 0.1;
                for side in [-1.0, 1.0] {
                    statics.push(Shape::Wall {
                        from: [-5.0, side * e],
                        to: [LEG_M + 10.0, side * e],
                        thickness_m: 0.2,
                    });
                }
            }
        }
        setup
    }
}

/// A person walking `path` at `speed_mps` from `start_s` (world time).
pub fn person(name: &str, path: Vec<[f64; 2]>, speed_mps: f64, start_s: f64) -> MovingObstacle {
    MovingObstacle {
        name: name.to_string(),
        shape: Shape::Circle {
            center: [0.0, 0.0],
            radius_m: PERSON_RADIUS_M,
        },
        path,
        speed_mps,
        start_s,
        looped: false,
        vanish_at_end: false,
    }
}
