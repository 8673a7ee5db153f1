//! One bench run: a mission driven in AUTO in-process (world, simulated
//! scanners, the whole core) with or without obstacles, logging the true
//! poses and judging the run against the empty run's course (see
//! [`super::truth`]).

use std::time::Duration;

use mission::{ExecState, MissionType, Plan};
use sim::{ObstacleWorld, SimScannerConfig, VehicleOutline};

use super::plant::PlantBraking;
use super::situation::{Phase, PhaseWatch, Situation};
use super::truth::{Judge, Limits, MOVING_MPS, Pose, STALL_S, TruthLog, rectangle};
use super::unavoidable::{ObjectId, RunTruth, WorldHistory, nearest, touching};
use autopilot::edge::clock::InstantTimer;
use autopilot::obstacles::TrackStatus;
use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};

/// The simulator warms up (fix, filter) this long before arming.
const WARM_UP_S: f64 = 5.0;
/// A run is cut off this long after the empty run's completion.
const OVERTIME_S: f64 = 150.0;
/// A course that is blocked by design is watched this long at rest.
const BLOCKED_WATCH_S: f64 = 15.0;
/// The way is judged this often while the vehicle is at rest.
const REST_CHECK_S: f64 = 0.5;
/// The clearance at rest the issue asks for when the object was known in
/// time for it, m.
pub const ROOM_CLEARANCE_M: f64 = 0.3;

/// A waypoint of a course, metres about home.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Waypoint {
    pub north_m: f64,
    pub east_m: f64,
    pub reverse: bool,
}

/// A mission: waypoints after home, the cruise speed and parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Course {
    pub waypoints: Vec<Waypoint>,
    pub speed_mps: f64,
    pub params: Vec<(String, f64)>,
}

/// A mover that steps aside when the vehicle comes within `at_m` (a person
/// walking head-on does): it turns `side_m` to its right over `side_m` of
/// walk and carries on.
#[derive(Clone, Copy, Debug)]
pub struct Yield {
    pub mover: usize,
    pub at_m: f64,
    pub side_m: f64,
}

/// The obstacles of a run.
#[derive(Clone, Debug, Default)]
pub struct Setup {
    pub world: ObstacleWorld,
    pub yields: Vec<Yield>,
    /// Something stays on the course for good (no detour): the run ends
    /// after a while at rest instead of completing.
    pub blocked_by_design: bool,
    /// Print the true pose and clearance every 0.2 s (`--replay --verbose`).
    pub trace: bool,
}

/// One run's figures, all from the truth.
#[derive(Clone, Debug, Default)]
pub struct RunResult {
    pub completion_s: Option<f64>,
    pub collisions: u32,
    /// Of the collisions, those the vehicle could not have stopped for
    /// (see [`super::truth`]).
    pub unavoidable: u32,
    /// Smallest gap between the outline and an object while moving.
    pub min_clearance_m: f64,
    pub stops: u32,
    pub false_stops: u32,
    pub stalls: u32,
    /// Distance run from each stop decision to rest, m.
    pub braking_m: Vec<f64>,
    /// Clearance when at rest after a stop, m.
    pub rest_clearance_m: Vec<f64>,
    /// Of those, the stops a vehicle braking at once could have ended
    /// [`ROOM_CLEARANCE_M`] clear of (see [`judge_rests`]).
    pub rest_clearance_with_room_m: Vec<f64>,
    /// Each collision's situation, and whether it was unavoidable.
    pub collision_situations: Vec<(Situation, bool)>,
    pub false_stop_situations: Vec<Situation>,
    /// |v_track − v_true| once a track is 1 s old, m/s.
    pub kf_velocity_error_mps: Vec<f64>,
    pub time_lost_s: Option<f64>,
    pub malformed_scans: u64,
    /// What happened, for `--verbose` and `--replay`.
    pub events: Vec<String>,
}

/// The vehicle's outline and the judge's limits from the parameters.
pub fn outline_and_limits(sim: &Simulation) -> (VehicleOutline, Limits) {
    let h = sim.core().param_handles().obstacles;
    let p = sim.core().params();
    let outline = VehicleOutline {
        front_m: f64::from(h.footprint.front_m.get(p)),
        rear_m: f64::from(h.footprint.rear_m.get(p)),
        half_width_m: f64::from(h.footprint.width_m.get(p)) / 2.0,
    };
    let a = h.avoidance;
    let limits = Limits {
        margin_m: f64::from(a.margin_m.get(p)),
        horizon_s: f64::from(a.horizon_s.get(p)),
        plant: PlantBraking::of(&sim.world().config().vehicle),
    };
    (outline, limits)
}

/// The simulation with the course loaded as the mission.
pub fn build_sim(course: &Course, seed: u64, params: &[(String, f64)]) -> Result<Simulation, String> {
    let config = SimulationConfig {
        model: ModelKind::Ackermann,
        seed,
        ..SimulationConfig::default()
    };
    let mut table = SimulationParams::new(config.model);
    table.apply(&course.params)?;
    table.apply(params)?;
    let mut sim = Simulation::new(&config, table);
    let world = sim.world();
    let home = world.local_to_geodetic(0.0, 0.0);
    let mut wpl = format!(
        "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t{:.9}\t{:.9}\t0\t1\n",
        home.lat_deg, home.lon_deg
    );
    let mut seq = 1;
    wpl += &format!("{seq}\t0\t2\t178\t1\t{:.3}\t-1\t0\t0\t0\t0\t1\n", course.speed_mps);
    seq += 1;
    let mut reversing = false;
    for wp in &course.waypoints {
        if wp.reverse != reversing {
            reversing = wp.reverse;
            wpl += &format!("{seq}\t0\t2\t194\t{}\t0\t0\t0\t0\t0\t0\t1\n", u8::from(wp.reverse));
            seq += 1;
        }
        let p = world.local_to_geodetic(wp.north_m, wp.east_m);
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

/// The true pose now (world time).
fn true_pose(sim: &Simulation) -> Pose {
    let truth = sim.world().truth();
    Pose {
        t_s: sim.time().as_secs_f64(),
        north_m: truth.north_m,
        east_m: truth.east_m,
        yaw_rad: truth.yaw_rad,
        speed_mps: truth.speed_mps,
    }
}

/// The empty run: no obstacles; its log is the course of the runs with.
pub fn drive_empty(course: &Course, seed: u64, params: &[(String, f64)]) -> Result<TruthLog, String> {
    let mut sim = build_sim(course, seed, params)?;
    let start_s = arm(&mut sim);
    let mut log = TruthLog::default();
    let timeout_s = 40.0 + 4.0 * course_length_m(course) / course.speed_mps.max(0.1);
    while sim.time().as_secs_f64() - start_s < timeout_s {
        sim.step(Duration::ZERO, &mut InstantTimer::default()).mavlink.clear();
        let pose = true_pose(&sim);
        log.poses.push(pose);
        if sim.core().mission_state() == ExecState::Complete && pose.speed_mps.abs() < 0.02 {
            log.completion_s = Some(pose.t_s - start_s);
            break;
        }
    }
    Ok(log)
}

fn course_length_m(course: &Course) -> f64 {
    let mut at = (0.0, 0.0);
    let mut length_m = 0.0;
    for wp in &course.waypoints {
        length_m += (wp.north_m - at.0).hypot(wp.east_m - at.1);
        at = (wp.north_m, wp.east_m);
    }
    length_m
}

/// Warms up, switches to AUTO and arms; returns the simulation time then.
pub(super) fn arm(sim: &mut Simulation) -> f64 {
    crate::warm_up_and_arm(sim, &mut InstantTimer::default(), WARM_UP_S, 10);
    sim.time().as_secs_f64()
}

/// A run with the obstacles of `setup`, judged against `course_log` (the
/// empty run of the same course and seed).
pub fn drive_with(
    course: &Course,
    seed: u64,
    params: &[(String, f64)],
    setup: &Setup,
    course_log: &TruthLog,
) -> Result<RunResult, String> {
    let mut sim = build_sim(course, seed, params)?;
    let (outline, limits) = outline_and_limits(&sim);
    let mut world = setup.world.clone();
    sim.world_mut().set_obstacles(Some(world.clone()));
    let mut history = WorldHistory::new(world.clone());
    let start_s = arm(&mut sim);
    let mut judge = Judge::new(course_log, outline, limits);
    let mut timer = InstantTimer::default();
    let mut result = RunResult {
        min_clearance_m: f64::INFINITY,
        ..RunResult::default()
    };
    let mut yielded = vec![false; setup.yields.len()];
    let mut watch = Watch::default();
    let mut rest = RestWatch::default();
    let mut kf_recorded: Vec<u32> = Vec::new();
    // The true pose at every tick, for the judging after the run.
    let mut poses: Vec<Pose> = Vec::new();
    let timeout_s = course_log.completion_s.unwrap_or(120.0) + OVERTIME_S;
    loop {
        let texts = crate::status_texts(sim.step(Duration::ZERO, &mut timer));
        let pose = true_pose(&sim);
        let t_world = pose.t_s;
        poses.push(pose);
        if t_world - start_s > timeout_s {
            result.events.push(format!("t {t_world:.1} cut off"));
            break;
        }
        judge.follow(&pose);
        let rect = rectangle(&outline, &pose);
        let (moving, clearance_m) = observe(&sim, setup.trace, &world, &rect, &pose, &mut result);
        let tick = TickTruth {
            pose,
            index: poses.len() - 1,
            rect,
            moving,
            clearance_m,
        };
        watch.judge_tick(&texts, &tick, &judge, &world, &mut result);
        if apply_yields(setup, &mut yielded, &mut world, &rect, t_world) {
            sim.world_mut().set_obstacles(Some(world.clone()));
            history.push(t_world, world.clone());
        }
        record_kf_errors(&sim, &world, t_world, &mut kf_recorded, &mut result);

        let complete = sim.core().mission_state() == ExecState::Complete;
        if complete && !moving {
            result.completion_s = Some(t_world - start_s);
            break;
        }
        let verdict = rest.update(&pose, moving || complete, || judge.way_blocked(&world, t_world, &pose));
        if rest_ends_run(verdict, setup, &pose, &mut result) {
            break;
        }
    }
    let scanners: Vec<SimScannerConfig> = sim.world().scanner_configs().cloned().collect();
    let run = RunTruth {
        poses: &poses,
        history: &history,
        scanners: &scanners,
        outline,
        plant: limits.plant,
    };
    conclude(&run, &watch, course_log, sim.malformed_scans(), &mut result);
    Ok(result)
}

/// One tick's truth.
struct TickTruth {
    pose: Pose,
    /// Of the pose in the run's log.
    index: usize,
    /// The outline there.
    rect: sim::Rectangle,
    moving: bool,
    /// The gap to the nearest object's true shape.
    clearance_m: f64,
}

/// The judging carried from tick to tick: stops, contacts and rests, and
/// what is judged once the run is over.
#[derive(Default)]
struct Watch {
    in_contact: bool,
    /// Where the last obstacle stop began, and whether it reached rest.
    braking: Option<(Pose, bool)>,
    phases: PhaseWatch,
    collisions: Vec<Collision>,
    rests: Vec<Rest>,
}

impl Watch {
    fn judge_tick(
        &mut self,
        texts: &[String],
        tick: &TickTruth,
        judge: &Judge,
        world: &ObstacleWorld,
        result: &mut RunResult,
    ) {
        let t_s = tick.pose.t_s;
        self.phases.update(&tick.pose);
        let phase = self.phases.phase(&tick.pose);
        if let Some(stopped_at) = record_obstacle_texts(texts, &tick.pose, judge, world, phase, result) {
            self.braking = Some(stopped_at);
        }
        self.phases.texts(texts);
        let contact = tick.moving && tick.clearance_m <= 0.0;
        if contact && !self.in_contact {
            let objects = touching(world, &tick.rect, t_s);
            let walking = objects.iter().any(|o| o.walking(world, t_s));
            let situation = situation_here(judge, phase, walking);
            self.collisions
                .push(record_collision(objects, situation, &tick.pose, result));
        }
        self.in_contact = contact;
        if !tick.moving
            && finish_braking(&mut self.braking, &tick.pose, tick.clearance_m, result)
            && let Some((object, _)) = nearest(world, &tick.rect, t_s)
        {
            self.rests.push(Rest {
                index: tick.index,
                object,
                clearance_m: tick.clearance_m,
            });
        }
    }
}

/// The situation at the judge's place on the course.
fn situation_here(judge: &Judge, phase: Phase, walking: bool) -> Situation {
    let (arc, reverse) = judge.course_here();
    Situation {
        phase,
        walking,
        arc,
        reverse,
    }
}

/// The vehicle at rest after an obstacle stop: the pose and the object
/// nearest it.
struct Rest {
    index: usize,
    object: ObjectId,
    clearance_m: f64,
}

/// The true clearance at this tick, and whether the vehicle moves (only
/// then does the clearance count towards the run's minimum).
fn observe(
    sim: &Simulation,
    trace: bool,
    world: &ObstacleWorld,
    rect: &sim::Rectangle,
    pose: &Pose,
    result: &mut RunResult,
) -> (bool, f64) {
    let clearance_m = world.clearance_m(rect, pose.t_s);
    if trace && (pose.t_s * 50.0).round() as i64 % 10 == 0 {
        print_trace(pose, clearance_m, sim.core().obstacle_status().stopped);
        print_trace_objects(world, pose.t_s, sim.core().obstacle_tracks());
    }
    let moving = pose.speed_mps.abs() > MOVING_MPS;
    if moving {
        result.min_clearance_m = result.min_clearance_m.min(clearance_m);
    }
    (moving, clearance_m)
}

/// Once the run is over: which collisions braking could have avoided, and
/// the time the obstacles cost.
fn conclude(run: &RunTruth, watch: &Watch, course_log: &TruthLog, malformed_scans: u64, result: &mut RunResult) {
    judge_collisions(run, &watch.collisions, result);
    judge_rests(run, &watch.rests, result);
    result.time_lost_s = result
        .completion_s
        .zip(course_log.completion_s)
        .map(|(with, without)| with - without);
    result.malformed_scans = malformed_scans;
}

/// The vehicle has come to rest: the braking an obstacle stop began, if
/// not yet measured, ends here (then true).
fn finish_braking(braking: &mut Option<(Pose, bool)>, pose: &Pose, clearance_m: f64, result: &mut RunResult) -> bool {
    let Some((from, done)) = braking else {
        return false;
    };
    if *done {
        return false;
    }
    *done = true;
    result.braking_m.push(from.distance_to(pose.north_m, pose.east_m));
    result.rest_clearance_m.push(clearance_m);
    true
}

/// The rests after a stop whose object stood still and was known while
/// the outline was at least the plant's stopping distance plus
/// [`ROOM_CLEARANCE_M`] from it: a vehicle braking at once could have
/// rested that far clear, so the clearance at rest is held to it.
fn judge_rests(run: &RunTruth, rests: &[Rest], result: &mut RunResult) {
    for rest in rests {
        let at = run.poses[rest.index];
        if rest.object.walking(run.history.at(at.t_s), at.t_s) {
            continue;
        }
        let Some(known_s) = run.known_s(rest.object, at.t_s) else {
            continue;
        };
        let from = run.poses[run.poses.partition_point(|p| p.t_s < known_s).min(rest.index)];
        let Some(shape) = rest.object.shape_at(run.history, from.t_s) else {
            continue;
        };
        let gap_m = shape.distance_to_rectangle_m(&rectangle(&run.outline, &from));
        let stopping_m = run.plant.stopping_m(from.speed_mps);
        if gap_m >= stopping_m + ROOM_CLEARANCE_M {
            result.rest_clearance_with_room_m.push(rest.clearance_m);
            result.events.push(format!(
                "t {:.2} at rest {:.3} m from {} (standing), known at t {:.2} at {:.2} m/s {gap_m:.2} m away (stopping {stopping_m:.2} m): room for {ROOM_CLEARANCE_M} m",
                at.t_s,
                rest.clearance_m,
                rest.object.label(),
                from.t_s,
                from.speed_mps.abs()
            ));
        }
    }
}

/// Whether being at rest ends the run: a stall (at rest with the way
/// clear), or a blockage the scenario intends, watched long enough.
fn rest_ends_run(verdict: RestVerdict, setup: &Setup, pose: &Pose, result: &mut RunResult) -> bool {
    match verdict {
        RestVerdict::Stall => {
            result.stalls += 1;
            result
                .events
                .push(format!("t {:.1} STALL: at rest 30 s with the way clear", pose.t_s));
            true
        }
        RestVerdict::Blocked(at_rest_s) => setup.blocked_by_design && at_rest_s > BLOCKED_WATCH_S,
        _ => false,
    }
}

/// Files the obstacle STATUSTEXTs of one tick as events, judging each
/// obstacle stop against the truth; returns where braking began when one
/// was announced.
fn record_obstacle_texts(
    texts: &[String],
    pose: &Pose,
    judge: &Judge,
    world: &ObstacleWorld,
    phase: Phase,
    result: &mut RunResult,
) -> Option<(Pose, bool)> {
    let t_world = pose.t_s;
    let mut stopped_at = None;
    for text in texts
        .iter()
        .filter(|t| t.starts_with("Obstacle") && !t.starts_with("Obstacle stop:"))
    {
        result.events.push(format!(
            "t {:.2} {text} at {:.2},{:.2} v {:.2}",
            pose.t_s, pose.north_m, pose.east_m, pose.speed_mps
        ));
    }
    for text in texts.iter().filter(|t| t.starts_with("Obstacle stop:")) {
        result.stops += 1;
        let nearest = judge.nearest(world, t_world, pose);
        let nearest_m = nearest.map_or(f64::INFINITY, |(gap_m, _)| gap_m);
        let blocked = judge.limits().within_margin(nearest_m);
        let mut verdict = "way blocked".to_string();
        if !blocked {
            result.false_stops += 1;
            let walking = nearest.is_some_and(|(_, object)| object.walking(world, t_world));
            let situation = situation_here(judge, phase, walking);
            result.false_stop_situations.push(situation);
            verdict = format!("FALSE STOP ({})", situation.label());
        }
        result.events.push(format!(
            "t {:.2} {text} at {:.2},{:.2} v {:.2}: {verdict} (nearest {nearest_m:.4} m from the swept outline)",
            pose.t_s, pose.north_m, pose.east_m, pose.speed_mps,
        ));
        stopped_at = Some((*pose, false));
    }
    stopped_at
}

/// One line of the `--trace` output.
fn print_trace(pose: &Pose, clearance_m: f64, obstacle_stop: bool) {
    println!(
        "  t {:.2} at {:.3},{:.3} yaw {:.1}° v {:.4} clearance {:.3} m{}",
        pose.t_s,
        pose.north_m,
        pose.east_m,
        pose.yaw_rad.to_degrees(),
        pose.speed_mps,
        clearance_m,
        if obstacle_stop { " (obstacle stop)" } else { "" }
    );
}

/// The people's true places and velocities, then the core's acted-on
/// tracks, under a `--trace` line.
fn print_trace_objects(world: &ObstacleWorld, t_s: f64, tracks: &[autopilot::obstacles::Track]) {
    let mut line = String::from("    truth:");
    for (i, mover) in world.movers.iter().enumerate() {
        if let Some((at, v)) = mover.state_at(t_s) {
            line += &format!(" [{i}] {:.2},{:.2} v {:.2},{:.2}", at[0], at[1], v[0], v[1]);
        }
    }
    line += "; tracks:";
    for t in tracks
        .iter()
        .filter(|t| t.status != autopilot::obstacles::TrackStatus::Tentative)
    {
        line += &format!(
            " #{} {:?} {:.2},{:.2} v {:.2},{:.2} σv {:.2} r {:.2} still {:.1}",
            t.id,
            t.status,
            t.position.north_m,
            t.position.east_m,
            t.vel_north_mps,
            t.vel_east_mps,
            t.velocity_sigma_mps,
            t.radius_m,
            t.still_s
        );
    }
    println!("{line}");
}

/// A collision that began at `t_s` with `objects`; its event is
/// `result.events[event]`.
struct Collision {
    t_s: f64,
    objects: Vec<ObjectId>,
    situation: Situation,
    event: usize,
}

/// A collision starts: counted and filed; whether it was unavoidable is
/// judged at the end of the run ([`judge_collisions`]).
fn record_collision(objects: Vec<ObjectId>, situation: Situation, pose: &Pose, result: &mut RunResult) -> Collision {
    result.collisions += 1;
    result.events.push(format!(
        "t {:.2} COLLISION at {:.2},{:.2} yaw {:.1}° v {:.2} ({})",
        pose.t_s,
        pose.north_m,
        pose.east_m,
        pose.yaw_rad.to_degrees(),
        pose.speed_mps,
        situation.label(),
    ));
    Collision {
        t_s: pose.t_s,
        objects,
        situation,
        event: result.events.len() - 1,
    }
}

/// Counts the unavoidable collisions (see [`super::unavoidable`]): each
/// object touched must have been one the vehicle could not stop for.
fn judge_collisions(run: &RunTruth, collisions: &[Collision], result: &mut RunResult) {
    for collision in collisions {
        let whys: Option<Vec<String>> = collision
            .objects
            .iter()
            .map(|&object| run.unavoidable(object, collision.t_s))
            .collect();
        let unavoidable = whys.as_ref().is_some_and(|w| !w.is_empty());
        if let Some(whys) = whys.filter(|_| unavoidable) {
            result.unavoidable += 1;
            result.events[collision.event] += &whys.concat();
        }
        result.collision_situations.push((collision.situation, unavoidable));
    }
}

/// Watches the vehicle at rest: how long, and how long with the way clear.
#[derive(Default)]
struct RestWatch {
    since_s: Option<f64>,
    clear_since_s: Option<f64>,
    next_check_s: f64,
}

enum RestVerdict {
    Moving,
    /// At rest this long, the way blocked or not yet judged clear for long.
    Blocked(f64),
    Stall,
}

impl RestWatch {
    fn update(&mut self, pose: &Pose, moving: bool, way_blocked: impl FnOnce() -> bool) -> RestVerdict {
        if moving {
            *self = RestWatch::default();
            return RestVerdict::Moving;
        }
        let since_s = *self.since_s.get_or_insert(pose.t_s);
        if pose.t_s >= self.next_check_s {
            self.next_check_s = pose.t_s + REST_CHECK_S;
            if way_blocked() {
                self.clear_since_s = None;
            } else {
                self.clear_since_s.get_or_insert(pose.t_s);
            }
        }
        match self.clear_since_s {
            Some(clear_s) if pose.t_s - clear_s > STALL_S => RestVerdict::Stall,
            _ => RestVerdict::Blocked(pose.t_s - since_s),
        }
    }
}

/// Yielding movers step aside when the vehicle comes close; true when the
/// world changed.
fn apply_yields(
    setup: &Setup,
    yielded: &mut [bool],
    world: &mut ObstacleWorld,
    rect: &sim::Rectangle,
    t_s: f64,
) -> bool {
    let mut changed = false;
    for (k, y) in setup.yields.iter().enumerate() {
        if yielded[k] {
            continue;
        }
        let Some((pos, vel)) = world.mover_state(y.mover, t_s) else {
            continue;
        };
        let mover = &mut world.movers[y.mover];
        let d = mover.shape.translated(pos).distance_to_rectangle_m(rect);
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
            mover.path = vec![pos, side, end];
            mover.start_s = t_s;
            changed = true;
        }
    }
    changed
}

/// The tracker's velocity error once a track has followed a walking person
/// for 1 s (a track born while its person stood is measured 1 s into the
/// walk).
fn record_kf_errors(sim: &Simulation, world: &ObstacleWorld, t: f64, recorded: &mut Vec<u32>, result: &mut RunResult) {
    let Some(frame) = sim.core().estimator().frame().copied() else {
        return;
    };
    let offset = crate::tracking::true_local(sim, &frame, 0.0, 0.0);
    for track in sim.core().obstacle_tracks() {
        if track.status != TrackStatus::Confirmed || track.age_s < 1.0 || recorded.contains(&track.id) {
            continue;
        }
        let at = [
            track.position.north_m - offset.north_m,
            track.position.east_m - offset.east_m,
        ];
        let nearest = (0..world.movers.len())
            .filter_map(|i| world.mover_state(i, t).map(|(p, v)| (i, p, v)))
            .map(|(i, p, v)| (i, (p[0] - at[0]).hypot(p[1] - at[1]), v))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let Some((mover, _, v)) = nearest.filter(|n| n.1 < 1.0) else {
            // Not a mover's track (structure, a ghost): never measured.
            recorded.push(track.id);
            continue;
        };
        let walking = |at_s: f64| {
            world
                .mover_state(mover, at_s)
                .is_some_and(|(_, v)| v[0].hypot(v[1]) > 0.1)
        };
        if walking(t) && walking(t - 1.0) {
            recorded.push(track.id);
            result
                .kf_velocity_error_mps
                .push((track.vel_north_mps - v[0]).hypot(track.vel_east_mps - v[1]));
        }
    }
}
