//! `furrow bench obstacles`: the obstacle scenarios of DESIGN §5.5, each
//! driven in AUTO in-process at full speed (world with its obstacles,
//! simulated scanners speaking CoLa-A to the real parser, the whole core),
//! at 1 and 2 m/s and several seeds. Everything is measured from the
//! simulator's truth: contacts between the vehicle's outline and an
//! obstacle, the smallest clearance, how far the vehicle ran after deciding
//! to stop, the time lost against the same run without obstacles, stops
//! that nothing justified, and the tracker's velocity error once a track is
//! 1 s old.
//!
//! A stop is justified when, at that instant, something truly is in the
//! protective field, or an obstacle comes within `OA_MARGIN` + 0.25 m of
//! the outline within the horizon — either on its true future path or on
//! its true present velocity extended in a straight line (what a perfect
//! tracker would predict: a person walking towards the path who turns away
//! later was on a collision course when the vehicle stopped). Any other
//! stop — a ghost, a noisy velocity, a static object seen as moving — is
//! false.
//!
//! Movers are placed on a collision course: each reaches the crossing point
//! on the path at the instant the vehicle's leading edge would have (taken
//! from the empty run with the same seed), so doing nothing would hit.

use std::time::{Duration, Instant};

use drivers::sim::{MovingObstacle, ObstacleWorld, Rectangle, Shape};
use mavlink::dialects::ardupilotmega::MavMessage;
use mission::{ExecState, MissionType, Plan};

use crate::geo::{GeoPoint, LocalFrame, Ned};
use crate::obstacles::TrackStatus;
use crate::sitl::gcs;
use crate::sitl::runner::InstantTimer;
use crate::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};

#[derive(clap::Args, Debug)]
pub struct ObstacleBenchArgs {
    /// Seeds 1..=N for every scenario and speed.
    #[arg(long, default_value_t = 3)]
    pub seeds: u64,
    /// Only the scenarios whose name contains this.
    #[arg(long)]
    pub only: Option<String>,
    /// Vehicle speeds to run each scenario at, m/s.
    #[arg(long = "speed", default_values_t = vec![1.0, 2.0])]
    pub speeds: Vec<f64>,
    /// Run with a parameter changed, NAME=VALUE (repeatable).
    #[arg(long = "param", value_parser = super::tracking::parse_param)]
    pub params: Vec<(String, f64)>,
    /// Print every run, not only the per-scenario summary.
    #[arg(long)]
    pub verbose: bool,
}

/// A person: a disc of this radius (two legs and a body seen at knee
/// height).
const PERSON_RADIUS_M: f64 = 0.25;
/// The leg every forward scenario drives along: north from home.
const LEG_M: f64 = 50.0;
/// Where movers cross the path (north of home, m).
const CROSSING_N: f64 = 25.0;
/// How long a crossing person is seen walking before reaching the path.
const LEAD_S: f64 = 12.0;
/// A run that has not finished after this long is cut off.
const TIMEOUT_S: f64 = 240.0;
/// A blocked vehicle (static box, no detour) is watched this long at rest.
const BLOCKED_WATCH_S: f64 = 15.0;

#[derive(Clone, Debug)]
enum Kind {
    Crossing { person_mps: f64, angle_deg: f64 },
    HeadOn,
    WalkingAway,
    ParkedCar,
    StaticBox { detour: bool },
    ReverseSlot,
    Corridor,
}

#[derive(Clone, Debug)]
struct Scenario {
    name: String,
    kind: Kind,
}

impl Scenario {
    fn all() -> Vec<Scenario> {
        let mut list = Vec::new();
        for person_mps in [0.5, 1.0, 1.5, 2.0] {
            for angle_deg in [45.0, 90.0, 135.0] {
                list.push(Scenario {
                    name: format!("crossing {person_mps:.1} m/s at {angle_deg:.0}°"),
                    kind: Kind::Crossing { person_mps, angle_deg },
                });
            }
        }
        let named = [
            ("head-on (person yields at 5 m)", Kind::HeadOn),
            ("walking away ahead", Kind::WalkingAway),
            ("person from behind parked car", Kind::ParkedCar),
            ("static box on path (stop)", Kind::StaticBox { detour: false }),
            ("static box on path (detour)", Kind::StaticBox { detour: true }),
            ("person behind, reversing into slot", Kind::ReverseSlot),
            ("corridor, walls 0.6 m beside", Kind::Corridor),
        ];
        list.extend(named.into_iter().map(|(name, kind)| Scenario {
            name: name.to_string(),
            kind,
        }));
        list
    }

    /// (north, east, reverse) of each waypoint after home.
    fn waypoints(&self) -> Vec<(f64, f64, bool)> {
        match self.kind {
            Kind::ReverseSlot => vec![(30.0, 0.0, false), (10.0, 0.0, true)],
            Kind::WalkingAway => vec![(70.0, 0.0, false)],
            _ => vec![(LEG_M, 0.0, false)],
        }
    }

    fn params(&self) -> Vec<(String, f64)> {
        match self.kind {
            Kind::StaticBox { detour: true } => vec![("OA_TYPE".into(), 1.0)],
            _ => Vec::new(),
        }
    }

    /// Whether the mission can finish (a box with no detour blocks it).
    fn completes(&self) -> bool {
        !matches!(self.kind, Kind::StaticBox { detour: false })
    }
}

/// The vehicle's outline and where its leading edges were, from the empty
/// run: when the front (forwards) or the rear (reversing) reached a
/// northing.
#[derive(Clone, Debug, Default)]
struct Timeline {
    /// (t, front northing, rear northing, reversing)
    samples: Vec<(f64, f64, f64, bool)>,
    completion_s: Option<f64>,
}

impl Timeline {
    /// First time the leading edge reached `north_m` driving forwards
    /// (or reversing).
    fn reach(&self, north_m: f64, reversing: bool) -> Option<f64> {
        self.samples.iter().find_map(|&(t, front, rear, rev)| {
            let hit = if reversing {
                rev && rear <= north_m
            } else {
                !rev && front >= north_m
            };
            hit.then_some(t)
        })
    }
}

/// A mover that steps aside when the vehicle comes within `at_m` (a person
/// walking head-on does): it turns `side_m` to its right over `side_m` of
/// walk and carries on.
#[derive(Clone, Copy, Debug)]
struct Yield {
    mover: usize,
    at_m: f64,
    side_m: f64,
}

struct Setup {
    world: ObstacleWorld,
    yields: Vec<Yield>,
}

fn person(name: &str, path: Vec<[f64; 2]>, speed_mps: f64, start_s: f64) -> MovingObstacle {
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

fn setup(scenario: &Scenario, timeline: &Timeline, half_width_m: f64) -> Setup {
    let mut statics = Vec::new();
    let mut movers = Vec::new();
    let mut yields = Vec::new();
    match scenario.kind {
        Kind::Crossing { person_mps, angle_deg } => {
            // Direction of walk: angle_deg from the vehicle's heading
            // (north), coming from its left.
            let a = angle_deg.to_radians();
            let dir = [a.cos(), a.sin()];
            let t_x = timeline.reach(CROSSING_N, false).unwrap_or(20.0);
            let lead_m = person_mps * LEAD_S;
            let start = [CROSSING_N - dir[0] * lead_m, -dir[1] * lead_m];
            let end = [CROSSING_N + dir[0] * 15.0, dir[1] * 15.0];
            movers.push(person("person", vec![start, end], person_mps, t_x - LEAD_S));
        }
        Kind::HeadOn => {
            movers.push(person("person", vec![[60.0, 0.0], [-20.0, 0.0]], 1.0, 0.0));
            yields.push(Yield {
                mover: 0,
                at_m: 5.0,
                side_m: half_width_m + 1.5,
            });
        }
        Kind::WalkingAway => {
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
        Kind::ParkedCar => {
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
            let start_s = timeline.reach(CROSSING_N - 7.0, false).unwrap_or(15.0);
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
        Kind::StaticBox { .. } => statics.push(Shape::Box {
            center: [CROSSING_N, 0.2],
            length_m: 1.0,
            width_m: 1.0,
            yaw_rad: 0.0,
        }),
        Kind::ReverseSlot => {
            // Crosses behind the reversing vehicle at 1 m/s, right to left.
            let x = 18.0;
            let t_x = timeline.reach(x, true).unwrap_or(40.0);
            let lead_m = 1.0 * LEAD_S;
            movers.push(person("person", vec![[x, lead_m], [x, -15.0]], 1.0, t_x - LEAD_S));
        }
        Kind::Corridor => {
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
    Setup {
        world: ObstacleWorld { statics, movers },
        yields,
    }
}

/// One run's figures.
#[derive(Clone, Debug, Default)]
struct RunResult {
    completion_s: Option<f64>,
    /// Contact episodes (the outline touched an obstacle).
    collisions: u32,
    min_clearance_m: f64,
    stops: u32,
    false_stops: u32,
    /// Distance run from each stop decision to rest, m.
    braking_m: Vec<f64>,
    /// Clearance when at rest after a stop, m.
    stop_clearance_m: Vec<f64>,
    /// |v_track − v_true| once a track is 1 s old, m/s.
    kf_velocity_error_mps: Vec<f64>,
    time_lost_s: Option<f64>,
    malformed_scans: u64,
}

struct RunSpec<'a> {
    scenario: &'a Scenario,
    speed_mps: f64,
    seed: u64,
    params: &'a [(String, f64)],
}

fn build_sim(spec: &RunSpec<'_>) -> Result<Simulation, String> {
    let config = SimulationConfig {
        model: ModelKind::Ackermann,
        seed: spec.seed,
        ..SimulationConfig::default()
    };
    let mut params = SimulationParams::new(config.model);
    params.apply(&spec.scenario.params())?;
    params.apply(spec.params)?;
    let mut sim = Simulation::new(&config, params);
    let world = sim.world();
    let home = world.local_to_geodetic(0.0, 0.0);
    let mut wpl = format!(
        "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t{:.9}\t{:.9}\t0\t1\n",
        home.lat_deg, home.lon_deg
    );
    let mut seq = 1;
    wpl += &format!("{seq}\t0\t2\t178\t1\t{:.3}\t-1\t0\t0\t0\t0\t1\n", spec.speed_mps);
    seq += 1;
    let mut reversing = false;
    for (n, e, reverse) in spec.scenario.waypoints() {
        if reverse != reversing {
            reversing = reverse;
            wpl += &format!("{seq}\t0\t2\t194\t{}\t0\t0\t0\t0\t0\t0\t1\n", u8::from(reverse));
            seq += 1;
        }
        let p = world.local_to_geodetic(n, e);
        wpl += &format!(
            "{seq}\t0\t3\t16\t0\t0\t0\t0\t{:.9}\t{:.9}\t0\t1\n",
            p.lat_deg, p.lon_deg
        );
        seq += 1;
    }
    let items = mission::files::wpl::parse(&wpl).map_err(|e| format!("bench mission: {e}"))?;
    sim.core_mut()
        .load_plan(MissionType::Mission, Plan::new(MissionType::Mission, items));
    Ok(sim)
}

/// The vehicle's outline from the truth.
fn outline(sim: &Simulation, front_m: f64, rear_m: f64, half_width_m: f64) -> Rectangle {
    let truth = sim.world().truth();
    let mid = (front_m - rear_m) / 2.0;
    Rectangle {
        center: [
            truth.north_m + mid * truth.yaw_rad.cos(),
            truth.east_m + mid * truth.yaw_rad.sin(),
        ],
        yaw_rad: truth.yaw_rad,
        half_length_m: (front_m + rear_m) / 2.0,
        half_width_m,
    }
}

struct Footprint {
    front_m: f64,
    rear_m: f64,
    half_width_m: f64,
}

fn footprint(sim: &Simulation) -> Footprint {
    let f = sim.core().param_handles().obstacles.footprint;
    let t = sim.core().params();
    Footprint {
        front_m: f64::from(f.front_m.get(t)),
        rear_m: f64::from(f.rear_m.get(t)),
        half_width_m: f64::from(f.width_m.get(t)) / 2.0,
    }
}

/// Whether a stop decided now had a cause in the truth: an obstacle inside
/// the protective field (sized from the true speed, 0.2 m of slack), or the
/// vehicle, carried on straight at `speed` (its planned speed when at
/// rest), coming within OA_MARGIN + 0.25 m of an obstacle within
/// `horizon_s`.
fn stop_justified(sim: &Simulation, world: &ObstacleWorld, fp: &Footprint, speed_mps: f64, horizon_s: f64) -> bool {
    let a = sim.core().param_handles().obstacles.avoidance;
    let p = sim.core().params();
    let truth = sim.world().truth();
    let v = truth.speed_mps.abs();
    let field_m = v * f64::from(a.reaction_s.get(p))
        + v * v / (2.0 * f64::from(a.decel_mps2.get(p)))
        + f64::from(a.field_margin_m.get(p));
    let side_m = f64::from(a.field_side_m.get(p));
    // The field's rectangle: ahead of the front bumper, or behind the rear
    // one when reversing.
    let (near, far) = if speed_mps >= 0.0 {
        (fp.front_m, fp.front_m + field_m)
    } else {
        (-fp.rear_m - field_m, -fp.rear_m)
    };
    let mid = (near + far) / 2.0;
    let field = Rectangle {
        center: [
            truth.north_m + mid * truth.yaw_rad.cos(),
            truth.east_m + mid * truth.yaw_rad.sin(),
        ],
        yaw_rad: truth.yaw_rad,
        half_length_m: (far - near) / 2.0,
        half_width_m: fp.half_width_m + side_m,
    };
    if world.clearance_m(&field, sim.time().as_secs_f64()) < 0.2 {
        return true;
    }
    let margin = f64::from(
        sim.core()
            .param_handles()
            .obstacles
            .avoidance
            .margin_m
            .get(sim.core().params()),
    ) + 0.25;
    let t0 = sim.time().as_secs_f64();
    let base = outline(sim, fp.front_m, fp.rear_m, fp.half_width_m);
    let yaw = sim.world().truth().yaw_rad;
    let steps = (horizon_s / 0.1).ceil() as usize;
    let comes_near = |w: &ObstacleWorld| {
        (0..=steps).any(|k| {
            let tau = k as f64 * 0.1;
            let rect = Rectangle {
                center: [
                    base.center[0] + speed_mps * tau * yaw.cos(),
                    base.center[1] + speed_mps * tau * yaw.sin(),
                ],
                ..base
            };
            w.clearance_m(&rect, t0 + tau) < margin
        })
    };
    comes_near(world) || comes_near(&constant_velocity_world(world, t0))
}

/// The world as a perfect tracker predicts it at `t0_s`: every mover goes
/// on straight at its present velocity (a person about to turn away from
/// the path is, until the turn, on a collision course: a stop for it is
/// not a perception error).
fn constant_velocity_world(world: &ObstacleWorld, t0_s: f64) -> ObstacleWorld {
    let mut predicted = world.clone();
    for (i, mover) in predicted.movers.iter_mut().enumerate() {
        let Some((position, velocity)) = world.mover_state(i, t0_s) else {
            continue;
        };
        let speed_mps = velocity[0].hypot(velocity[1]);
        let far_s = 1000.0;
        mover.path = vec![
            position,
            [position[0] + velocity[0] * far_s, position[1] + velocity[1] * far_s],
        ];
        mover.speed_mps = speed_mps;
        mover.start_s = t0_s;
        mover.looped = false;
        mover.vanish_at_end = false;
    }
    predicted
}

fn run_one(spec: &RunSpec<'_>, setup: Option<&Setup>) -> Result<(RunResult, Timeline), String> {
    let mut sim = build_sim(spec)?;
    let fp = footprint(&sim);
    let mut world = setup.map(|s| s.world.clone());
    sim.world_mut().set_obstacles(world.clone());
    let mut yielded: Vec<bool> = setup.map_or(Vec::new(), |s| vec![false; s.yields.len()]);
    gcs::connect(&mut sim);
    let mut timer = InstantTimer::default();
    while sim.time().as_secs_f64() < 5.0 {
        sim.step(Duration::ZERO, &mut timer).mavlink.clear();
    }
    gcs::send(&mut sim, gcs::set_mode(10));
    gcs::send(&mut sim, gcs::arm());
    let start_s = sim.time().as_secs_f64();
    let horizon_s = f64::from(
        sim.core()
            .param_handles()
            .obstacles
            .avoidance
            .horizon_s
            .get(sim.core().params()),
    ) + 1.0;

    let mut result = RunResult {
        min_clearance_m: f64::INFINITY,
        ..RunResult::default()
    };
    let mut timeline = Timeline::default();
    let mut in_contact = false;
    let mut braking: Option<(Ned, bool)> = None;
    let mut blocked_since: Option<f64> = None;
    let mut kf_recorded: Vec<u32> = Vec::new();
    let mut reversing = false;
    while sim.time().as_secs_f64() - start_s < TIMEOUT_S {
        let outputs = sim.step(Duration::ZERO, &mut timer);
        let texts: Vec<String> = outputs
            .mavlink
            .drain(..)
            .filter_map(|o| match o.message {
                MavMessage::STATUSTEXT(t) => t.text.to_str().ok().map(str::to_string),
                _ => None,
            })
            .collect();
        let t = sim.time().as_secs_f64();
        let truth = *sim.world().truth();
        if let Some(target) = sim.core().navigator().target() {
            reversing = target.direction == crate::guidance::tracker::Direction::Reverse;
        }
        let front_n = truth.north_m + fp.front_m * truth.yaw_rad.cos();
        let rear_n = truth.north_m - fp.rear_m * truth.yaw_rad.cos();
        timeline.samples.push((t, front_n, rear_n, reversing));
        let here = Ned::new(truth.north_m, truth.east_m);
        for text in &texts {
            if std::env::var("FURROW_DEBUG_TEXTS").is_ok() {
                eprintln!("t {:.2} TEXT {text}", sim.time().as_secs_f64());
            }
            if text.starts_with("Obstacle stop") {
                result.stops += 1;
                let speed = if truth.speed_mps.abs() > 0.1 {
                    truth.speed_mps
                } else if reversing {
                    -spec.speed_mps
                } else {
                    spec.speed_mps
                };
                let justified = world
                    .as_ref()
                    .is_some_and(|w| stop_justified(&sim, w, &fp, speed, horizon_s));
                if !justified {
                    result.false_stops += 1;
                }
                if std::env::var("FURROW_DEBUG_STOPS").is_ok() {
                    let movers: Vec<_> = world.as_ref().map_or(Vec::new(), |w| {
                        (0..w.movers.len()).filter_map(|i| w.mover_state(i, t)).collect()
                    });
                    eprintln!(
                        "t {t:.2} {text} justified {justified} veh {:.2},{:.2} v {:.2} movers {movers:?}",
                        truth.north_m, truth.east_m, truth.speed_mps
                    );
                }
                braking = Some((here, false));
            }
        }

        if let Some(w) = world.as_mut() {
            let rect = outline(&sim, fp.front_m, fp.rear_m, fp.half_width_m);
            let clearance = w.clearance_m(&rect, t);
            result.min_clearance_m = result.min_clearance_m.min(clearance);
            if clearance <= 0.0 && !in_contact {
                result.collisions += 1;
                if std::env::var("FURROW_DEBUG_STOPS").is_ok() {
                    let movers: Vec<_> = (0..w.movers.len()).filter_map(|i| w.mover_state(i, t)).collect();
                    eprintln!(
                        "t {t:.2} CONTACT veh {:.2},{:.2} yaw {:.1} v {:.2} movers {movers:?}",
                        truth.north_m,
                        truth.east_m,
                        truth.yaw_rad.to_degrees(),
                        truth.speed_mps
                    );
                }
            }
            in_contact = clearance <= 0.0;
            if let Some((from, done)) = &mut braking
                && !*done
                && truth.speed_mps.abs() < 0.02
            {
                *done = true;
                result.braking_m.push(from.distance_to(&here));
                result.stop_clearance_m.push(clearance);
            }
            // Yielding movers step aside when the vehicle comes close.
            if let Some(s) = setup {
                for (k, y) in s.yields.iter().enumerate() {
                    if yielded[k] {
                        continue;
                    }
                    let Some((pos, vel)) = w.mover_state(y.mover, t) else {
                        continue;
                    };
                    let d = rectangle_distance(&rect, pos) - PERSON_RADIUS_M;
                    if d < y.at_m {
                        yielded[k] = true;
                        let speed = vel[0].hypot(vel[1]).max(0.5);
                        let dir = [vel[0] / speed, vel[1] / speed];
                        // Its right: the walking direction turned 90° clockwise.
                        let right = [-dir[1], dir[0]];
                        let side = [
                            pos[0] + (dir[0] + right[0]) * y.side_m,
                            pos[1] + (dir[1] + right[1]) * y.side_m,
                        ];
                        let end = [side[0] + dir[0] * 40.0, side[1] + dir[1] * 40.0];
                        let mover = &mut w.movers[y.mover];
                        mover.path = vec![pos, side, end];
                        mover.start_s = t;
                        sim.world_mut().set_obstacles(Some(w.clone()));
                    }
                }
            }
            // The tracker's velocity once a track has been followed for 1 s.
            if let Some(frame) = sim.core().estimator().frame().copied() {
                let offset = sim_to_core(&sim, &frame, 0.0, 0.0);
                for track in sim.core().obstacle_tracks() {
                    if track.status != TrackStatus::Confirmed || track.age_s < 1.0 || kf_recorded.contains(&track.id) {
                        continue;
                    }
                    let at = [
                        track.position.north_m - offset.north_m,
                        track.position.east_m - offset.east_m,
                    ];
                    let nearest = (0..w.movers.len())
                        .filter_map(|i| w.mover_state(i, t).map(|(p, v)| (i, p, v)))
                        .map(|(i, p, v)| (i, (p[0] - at[0]).hypot(p[1] - at[1]), v))
                        .min_by(|a, b| a.1.total_cmp(&b.1));
                    let Some((mover, _, v)) = nearest.filter(|n| n.1 < 1.0) else {
                        // Not a mover's track (structure, a ghost): never measured.
                        kf_recorded.push(track.id);
                        continue;
                    };
                    // Measured once the person has walked for 1 s and the
                    // track is 1 s old: a track born while the person stood
                    // waiting is measured 1 s into the walk.
                    let walking = |at_s: f64| w.mover_state(mover, at_s).is_some_and(|(_, v)| v[0].hypot(v[1]) > 0.1);
                    if walking(t) && walking(t - 1.0) {
                        kf_recorded.push(track.id);
                        result
                            .kf_velocity_error_mps
                            .push((track.vel_north_mps - v[0]).hypot(track.vel_east_mps - v[1]));
                    }
                }
            }
        }

        if sim.core().mission_state() == ExecState::Complete && truth.speed_mps.abs() < 0.02 {
            result.completion_s = Some(t - start_s);
            break;
        }
        if !spec.scenario.completes() && setup.is_some() {
            if truth.speed_mps.abs() < 0.01 && result.stops > 0 {
                let since = *blocked_since.get_or_insert(t);
                if t - since > BLOCKED_WATCH_S {
                    break;
                }
            } else {
                blocked_since = None;
            }
        }
    }
    timeline.completion_s = result.completion_s;
    result.malformed_scans = sim.malformed_scans();
    Ok((result, timeline))
}

/// Distance from a point to a rectangle (0 inside).
fn rectangle_distance(rect: &Rectangle, p: [f64; 2]) -> f64 {
    let (dn, de) = (p[0] - rect.center[0], p[1] - rect.center[1]);
    let (c, s) = (rect.yaw_rad.cos(), rect.yaw_rad.sin());
    let along = dn * c + de * s;
    let across = -dn * s + de * c;
    let dx = (along.abs() - rect.half_length_m).max(0.0);
    let dy = (across.abs() - rect.half_width_m).max(0.0);
    dx.hypot(dy)
}

/// The simulator's point in the autopilot's frame, through WGS-84.
fn sim_to_core(sim: &Simulation, frame: &LocalFrame, north_m: f64, east_m: f64) -> Ned {
    let g = sim.world().local_to_geodetic(north_m, east_m);
    frame.to_local(&GeoPoint::new(g.lat_deg, g.lon_deg, g.alt_m))
}

pub fn run(args: &ObstacleBenchArgs) -> Result<(), String> {
    if args.seeds == 0 {
        return Err("--seeds must be at least 1".into());
    }
    if args.speeds.iter().any(|s| !(s.is_finite() && *s > 0.0 && *s <= 5.0)) {
        return Err("--speed must be in (0, 5] m/s".into());
    }
    // Parameters are checked once before hours of runs.
    SimulationParams::new(ModelKind::Ackermann).apply(&args.params)?;
    let scenarios: Vec<Scenario> = Scenario::all()
        .into_iter()
        .filter(|s| args.only.as_ref().is_none_or(|o| s.name.contains(o.as_str())))
        .collect();
    if scenarios.is_empty() {
        return Err("--only matches no scenario".into());
    }
    println!("# furrow bench obstacles");
    println!();
    println!(
        "{} scenarios × speeds {:?} m/s × {} seeds; Ackermann AGV 4.4 × 2.0 m, scanners front and rear (LMS1xx-like, 50 Hz, 0.5°, 270°).",
        scenarios.len(),
        args.speeds,
        args.seeds
    );
    println!();
    println!(
        "| scenario | m/s | runs | completed | collisions | min clearance m | stop distance m (max) | clearance at rest m (min) | time lost s (median / max) | stops | false stops | KF |v| err after 1 s m/s (mean / max) |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let wall = Instant::now();
    let mut totals = (0u32, 0u32, 0usize);
    for scenario in &scenarios {
        for &speed_mps in &args.speeds {
            let mut runs = Vec::new();
            for seed in 1..=args.seeds {
                let spec = RunSpec {
                    scenario,
                    speed_mps,
                    seed,
                    params: &args.params,
                };
                let (empty, timeline) = run_one(&spec, None)?;
                let sim = build_sim(&spec)?;
                let half_width = footprint(&sim).half_width_m;
                let s = setup(scenario, &timeline, half_width);
                let (mut r, _) = run_one(&spec, Some(&s))?;
                r.time_lost_s = r.completion_s.zip(empty.completion_s).map(|(a, b)| a - b);
                if args.verbose {
                    println!("<!-- {} {speed_mps} m/s seed {seed}: {r:?} -->", scenario.name);
                }
                runs.push(r);
            }
            let row = summarise(scenario, speed_mps, &runs);
            totals.0 += row.0;
            totals.1 += row.1;
            totals.2 += runs.len();
        }
    }
    println!();
    println!(
        "Total: {} runs, {} collisions, {} false stops ({:.1} s wall).",
        totals.2,
        totals.0,
        totals.1,
        wall.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Prints a scenario's row; returns (collisions, false stops).
fn summarise(scenario: &Scenario, speed_mps: f64, runs: &[RunResult]) -> (u32, u32) {
    let fmt = |v: Option<f64>| v.map_or("–".to_string(), |v| format!("{v:.2}"));
    let collisions: u32 = runs.iter().map(|r| r.collisions).sum();
    let false_stops: u32 = runs.iter().map(|r| r.false_stops).sum();
    let stops: u32 = runs.iter().map(|r| r.stops).sum();
    let completed = runs.iter().filter(|r| r.completion_s.is_some()).count();
    let min_clearance = runs
        .iter()
        .map(|r| r.min_clearance_m)
        .filter(|c| c.is_finite())
        .min_by(f64::total_cmp);
    let max_braking = runs
        .iter()
        .flat_map(|r| r.braking_m.iter().copied())
        .max_by(f64::total_cmp);
    let min_rest = runs
        .iter()
        .flat_map(|r| r.stop_clearance_m.iter().copied())
        .min_by(f64::total_cmp);
    let mut lost: Vec<f64> = runs.iter().filter_map(|r| r.time_lost_s).collect();
    lost.sort_by(f64::total_cmp);
    let lost_text = if lost.is_empty() {
        if scenario.completes() {
            "–".to_string()
        } else {
            "blocked (expected)".to_string()
        }
    } else {
        format!("{:.1} / {:.1}", lost[lost.len() / 2], lost[lost.len() - 1])
    };
    let kf: Vec<f64> = runs
        .iter()
        .flat_map(|r| r.kf_velocity_error_mps.iter().copied())
        .collect();
    let kf_text = if kf.is_empty() {
        "–".to_string()
    } else {
        format!(
            "{:.3} / {:.3} (n={})",
            kf.iter().sum::<f64>() / kf.len() as f64,
            kf.iter().copied().fold(0.0, f64::max),
            kf.len()
        )
    };
    let malformed: u64 = runs.iter().map(|r| r.malformed_scans).sum();
    let completed_text = if scenario.completes() {
        format!("{completed}/{}", runs.len())
    } else {
        format!("{completed}/{} (blocked by design)", runs.len())
    };
    println!(
        "| {} | {speed_mps:.1} | {} | {completed_text} | {collisions} | {} | {} | {} | {lost_text} | {stops} | {false_stops} | {kf_text} |{}",
        scenario.name,
        runs.len(),
        fmt(min_clearance),
        fmt(max_braking),
        fmt(min_rest),
        if malformed > 0 {
            format!(" {malformed} malformed scans!")
        } else {
            String::new()
        }
    );
    (collisions, false_stops)
}
