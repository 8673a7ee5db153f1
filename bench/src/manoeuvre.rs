//! The manoeuvre section of `furrow-bench tracking`: GUIDED pose goals 1–10 m
//! away in eight directions (ahead, beside, behind, inside the turning
//! circle), all to be reached facing north as the vehicle starts, then RTL
//! back home from there, then the same pose as an AUTO mission's stop with
//! a heading (NAV_WAYPOINT param 4, `MNV_WP_YAW` 1), on both vehicle models. Everything is measured
//! from the simulator's truth: the final pose against the goal
//! (`WP_STOP_TOL_MM` / `WP_STOP_TOL_DEG`, the defaults 10 mm and 0.05°),
//! the changes of direction the wheels really made, the turns on the spot
//! (a differential vehicle's pivots: turning while the centre stands), failsafes, and
//! "Reached" claims (`MISSION_ITEM_REACHED` in AUTO) made for a stop the
//! truth has out of tolerance.
//!
//! The goal is the one the vehicle was given: a GUIDED target as its
//! 1e-7° MAVLink coordinates carry it (up to 5.6 mm from the point the bench
//! chose), RTL's home as the vehicle recorded it with the heading it faced
//! then. Every miss and false claim is listed after the table with the
//! estimate's own error at the verdict.

use std::time::Duration;

use mavlink::dialects::ardupilotmega::MavMessage;
use mission::command::{cmd, frame};
use mission::{MissionItem, MissionType, Plan};
use vehicle_types::GeoPoint as SimGeoPoint;

use autopilot::edge::clock::InstantTimer;
use autopilot::geo::GeoPoint;
use autopilot::geo::wrap_pi;
use autopilot::sitl::gcs;
use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};
use autopilot::vehicle::CONFIRM_WAIT_S;

const DISTANCES_M: [f64; 4] = [1.0, 3.0, 6.0, 10.0];
const BEARINGS: usize = 8;
const TOL_M: f64 = 0.010;
const TOL_DEG: f64 = 0.05;
/// A turn on the spot: turning faster than this while the centre moves
/// slower than the direction-change threshold.
const PIVOT_RATE_RAD_S: f64 = 0.05;
/// A goal not decided within this long counts as not reached.
const TIMEOUT_S: f64 = 300.0;

/// One goal driven to: what the truth says and what the vehicle claimed.
#[derive(Clone, Debug, Default)]
struct Outcome {
    label: String,
    within: bool,
    claimed: bool,
    /// Said it stopped there by the estimate but could not confirm it.
    unconfirmed: bool,
    position_mm: f64,
    yaw_deg: f64,
    direction_changes: usize,
    pivots: usize,
    failsafes: usize,
    duration_s: f64,
    /// The truth's error at the verdict (before the bench's extra second).
    verdict_mm: f64,
    /// How far the truth moved and turned in the second after the verdict:
    /// a verdict is to be given on a vehicle at rest.
    moved_after_mm: f64,
    turned_after_deg: f64,
    /// The estimate's distance from the truth at the verdict.
    estimate_error_mm: f64,
    /// Where the estimate had the stop at the verdict: its position error
    /// from the goal and its yaw error. Within tolerance while the truth is
    /// not, the miss is the estimate's error, not the stop's.
    estimated_mm: f64,
    estimated_yaw_deg: f64,
    /// From the truth's pose coming within [`SETTLE_ZONE_M`] and
    /// [`SETTLE_ZONE_DEG`] of the goal for good
    /// to the vehicle's last stop report (NaN: never within it then).
    settle_s: f64,
    /// The same from the position alone coming within [`SETTLE_ZONE_M`]
    /// (the heading may still be far: a turn on the spot counts in it).
    settle_position_s: f64,
    /// Retries after a miss, and of them those called while the truth was
    /// within tolerance (the estimate's error made the miss).
    retries: usize,
    needless_retries: usize,
    /// The estimator's 1-σ horizontal position and heading at the verdict.
    sigma_mm: f64,
    /// The estimate's error from the truth at the verdict per axis (north,
    /// east) in its own σ of that axis: how well the σ the claims rest on
    /// describes the error.
    normalised_error: [f64; 2],
    sigma_deg: f64,
    /// The vehicle's last texts.
    texts: Vec<String>,
    /// What the vehicle said it planned and retried: the manoeuvres, the
    /// misses and the re-tries, in order.
    plans: Vec<String>,
}

impl Outcome {
    /// The truth moved or turned after the verdict: it was given before the
    /// vehicle came to rest (the simulated vehicle at rest stands exactly
    /// still).
    fn moved_after(&self) -> bool {
        self.moved_after_mm > MOVED_AFTER_MM || self.turned_after_deg > MOVED_AFTER_DEG
    }
}

/// Movement after a verdict beyond these is listed.
const MOVED_AFTER_MM: f64 = 0.05;
const MOVED_AFTER_DEG: f64 = 0.001;

/// Where the vehicle is to stop, in the simulator's frame, and facing
/// (true, radians).
#[derive(Clone, Copy, Debug)]
struct Goal {
    north_m: f64,
    east_m: f64,
    yaw_rad: f64,
}

struct Run {
    sim: Simulation,
    timer: InstantTimer,
    /// The goal being driven to: at a miss, the truth's error from it is
    /// noted among the texts (what a retry has to correct).
    goal: Option<Goal>,
    /// Since when the truth's pose has been within [`SETTLE_ZONE_M`] and
    /// [`SETTLE_ZONE_DEG`] of the goal…
    within_since_s: Option<f64>,
    /// …and how long it had been at the last stop report.
    settled_s: f64,
    /// The same for the position alone.
    near_since_s: Option<f64>,
    settled_position_s: f64,
    /// Retries after a miss, and those with the truth within tolerance.
    retries: usize,
    needless_retries: usize,
    /// Print every tick ([`Run::trace_row`]).
    trace: bool,
}

/// A stop's settling time runs from the truth coming this close to the
/// goal for good (the navigator's and the tracking bench's zone).
const SETTLE_ZONE_M: f64 = autopilot::guidance::navigator::SETTLE_ZONE_M;
/// Every goal here has a heading, so the stop is of a pose: it settles
/// once the heading is near too. The zone is three heading tolerances, as
/// the position's 30 mm is three of its 10 mm; a differential vehicle's
/// turn on the spot onto the heading after it stopped on the point is
/// part of the manoeuvre until then, its last 0.15° part of the settling.
const SETTLE_ZONE_DEG: f64 = 3.0 * TOL_DEG;

impl Run {
    /// `MNV_WP_YAW` is 1: a mission stop's heading is driven to.
    /// `walk_m`: the GNSS's slow wander (simulated and as the estimator
    /// models it), or the default; `params` (NAME, value) set first.
    fn new(model: ModelKind, seed: u64, walk_m: Option<f64>, params: &[(String, f64)]) -> Run {
        let config = SimulationConfig {
            model,
            seed,
            ..SimulationConfig::default()
        };
        let mut sim_params = SimulationParams::new(model);
        sim_params.apply(params).expect("checked before the runs");
        let mut sim = Simulation::new(&config, sim_params);
        sim.core_mut()
            .params_mut()
            .set_by_name("MNV_WP_YAW", 1.0)
            .expect("a declared parameter in range");
        if let Some(walk_m) = walk_m {
            for name in ["SIM_GPS_WALK", "EKF_GPS_WALK"] {
                sim.core_mut()
                    .params_mut()
                    .set_by_name(name, walk_m)
                    .expect("a declared parameter in range");
            }
        }
        gcs::connect(&mut sim);
        let mut run = Run {
            sim,
            timer: InstantTimer::default(),
            goal: None,
            within_since_s: None,
            settled_s: f64::NAN,
            near_since_s: None,
            settled_position_s: f64::NAN,
            retries: 0,
            needless_retries: 0,
            trace: false,
        };
        run.drive_until(5.0, |_| false);
        gcs::send(&mut run.sim, gcs::set_mode(15));
        gcs::send(&mut run.sim, gcs::arm());
        run
    }

    /// Steps until a text satisfies `done` or `seconds` pass; every text,
    /// the changes of direction and the turns on the spot.
    fn drive_until(&mut self, seconds: f64, mut done: impl FnMut(&str) -> bool) -> (Vec<String>, usize, usize) {
        let end = self.sim.time().as_secs_f64() + seconds;
        let mut texts = Vec::new();
        let mut changes = 0;
        let mut last_sign = 0.0;
        let (mut pivots, mut pivoting) = (0, false);
        while self.sim.time().as_secs_f64() < end {
            let out = self.sim.step(Duration::ZERO, &mut self.timer);
            // A long text goes out in 50-character chunks, several a step.
            let before = texts.len();
            for o in out.mavlink.drain(..) {
                match o.message {
                    MavMessage::STATUSTEXT(t) => texts.push(t.text.to_str().unwrap_or("").to_string()),
                    MavMessage::MISSION_ITEM_REACHED(r) => texts.push(format!("{ITEM_REACHED} {}", r.seq)),
                    _ => {}
                }
            }
            let speed = self.sim.world().truth().speed_mps;
            if speed.abs() > 0.02 {
                if last_sign != 0.0 && speed.signum() != last_sign {
                    changes += 1;
                    // Where among the texts the wheels changed direction.
                    let way = if speed > 0.0 { "forwards" } else { "in reverse" };
                    texts.push(format!("{CHANGE} {way}]"));
                }
                last_sign = speed.signum();
            }
            let turning = self.sim.world().truth().yaw_rate_rad_s.abs() > PIVOT_RATE_RAD_S;
            if turning && speed.abs() <= 0.02 && !pivoting {
                pivots += 1;
            }
            pivoting = turning && (pivoting || speed.abs() <= 0.02);
            self.watch_settling();
            if self.trace {
                self.trace_row(&texts[before..]);
            }
            if texts[before..]
                .iter()
                .any(|t| t.starts_with("Stop:") || t.starts_with("Stop #"))
            {
                let now_s = self.sim.time().as_secs_f64();
                self.settled_s = self.within_since_s.map_or(f64::NAN, |since| now_s - since);
                self.settled_position_s = self.near_since_s.map_or(f64::NAN, |since| now_s - since);
            }
            let missed = texts[before..].iter().any(|t| MISSES.iter().any(|m| t.contains(m)));
            if let Some(goal) = self.goal.filter(|_| missed) {
                let (mm, deg) = self.error(&goal);
                texts.push(format!("{TRUTH} {mm:.1} mm, yaw {deg:.3}°]"));
                self.retries += 1;
                if mm <= TOL_M * 1000.0 && deg.abs() <= TOL_DEG {
                    self.needless_retries += 1;
                }
            }
            if texts[before..].iter().any(|t| done(t)) {
                break;
            }
        }
        (texts, changes, pivots)
    }

    /// One tick of a traced goal: time, the truth's and the estimate's
    /// error from the goal (mm, °), the truth's speed (mm/s) and yaw rate
    /// (°/s), the actuator demand, the navigator's turn-on-the-spot target
    /// and the texts of the tick.
    fn trace_row(&self, texts: &[String]) {
        let Some(goal) = self.goal else {
            return;
        };
        let (mm, deg) = self.error(&goal);
        let (est_mm, est_deg) = self.estimated_error(&goal);
        let truth = self.sim.world().truth();
        let nav = self.sim.core().navigator();
        println!(
            "trace {:.2} truth {mm:.1} mm {deg:.4}° est {est_mm:.1} mm {est_deg:.4}° v {:.1} mm/s r {:.3}°/s demand {:?} pivot {:?} stopping {} {}",
            self.sim.time().as_secs_f64(),
            truth.speed_mps * 1000.0,
            truth.yaw_rate_rad_s.to_degrees(),
            self.sim.last_demand(),
            nav.pivot_target().map(|y| (y - goal.yaw_rad).to_degrees()),
            nav.stopping(),
            texts.join(" | "),
        );
    }

    /// Notes when the truth's pose came within [`SETTLE_ZONE_M`] and
    /// [`SETTLE_ZONE_DEG`] of the goal and
    /// stayed.
    fn watch_settling(&mut self) {
        let Some(goal) = self.goal else {
            return;
        };
        let (mm, deg) = self.error(&goal);
        let now_s = self.sim.time().as_secs_f64();
        let near = mm <= SETTLE_ZONE_M * 1000.0;
        if !near {
            self.near_since_s = None;
        } else if self.near_since_s.is_none() {
            self.near_since_s = Some(now_s);
        }
        if !(near && deg.abs() <= SETTLE_ZONE_DEG) {
            self.within_since_s = None;
        } else if self.within_since_s.is_none() {
            self.within_since_s = Some(now_s);
        }
    }

    /// The estimate's stop error from `goal` at rest: position (mm) and
    /// yaw (°).
    fn estimated_error(&self, goal: &Goal) -> (f64, f64) {
        let Some(estimate) = self.sim.core().estimate_geodetic() else {
            return (f64::NAN, f64::NAN);
        };
        let (north_m, east_m) = self.local(&estimate);
        let yaw_rad = self.sim.core().estimator().estimate().yaw_rad;
        (
            (north_m - goal.north_m).hypot(east_m - goal.east_m) * 1000.0,
            wrap_pi(yaw_rad - goal.yaw_rad).to_degrees(),
        )
    }

    /// A point the vehicle knows (geodetic) in the simulator's frame.
    fn local(&self, p: &GeoPoint) -> (f64, f64) {
        self.sim.world().geodetic_to_local(&SimGeoPoint {
            lat_deg: p.lat_deg,
            lon_deg: p.lon_deg,
            alt_m: 0.0,
        })
    }

    /// The estimate's error from the truth (north, east), m.
    fn estimate_error_m(&self) -> [f64; 2] {
        let Some(estimate) = self.sim.core().estimate_geodetic() else {
            return [f64::NAN; 2];
        };
        let t = self.sim.world().truth();
        let (north_m, east_m) = self.local(&estimate);
        [north_m - t.north_m, east_m - t.east_m]
    }

    /// The estimate's error per axis in the estimator's σ of that axis.
    fn normalised_error(&self) -> [f64; 2] {
        let [north_m, east_m] = self.estimate_error_m();
        self.sim.core().estimator().ekf_status().map_or([f64::NAN; 2], |s| {
            [north_m / s.position_sigma_north_m, east_m / s.position_sigma_east_m]
        })
    }

    fn error(&self, goal: &Goal) -> (f64, f64) {
        let t = self.sim.world().truth();
        let position_mm = (t.north_m - goal.north_m).hypot(t.east_m - goal.east_m) * 1000.0;
        (position_mm, wrap_pi(t.yaw_rad - goal.yaw_rad).to_degrees())
    }

    fn goal(&mut self, label: String, message: MavMessage, goal: Goal) -> Outcome {
        let start_s = self.sim.time().as_secs_f64();
        self.goal = Some(goal);
        (self.within_since_s, self.settled_s) = (None, f64::NAN);
        (self.near_since_s, self.settled_position_s) = (None, f64::NAN);
        (self.retries, self.needless_retries) = (0, 0);
        gcs::send(&mut self.sim, message);
        let verdict = |t: &str| VERDICTS.iter().any(|v| t.starts_with(v));
        let (texts, direction_changes, pivots) = self.drive_until(TIMEOUT_S, verdict);
        let (settle_s, settle_position_s) = (self.settled_s, self.settled_position_s);
        let (estimated_mm, estimated_yaw_deg) = self.estimated_error(&goal);
        let (verdict_mm, _) = self.error(&goal);
        let at_verdict = *self.sim.world().truth();
        let [north_m, east_m] = self.estimate_error_m();
        let estimate_error_mm = north_m.hypot(east_m) * 1000.0;
        let normalised_error = self.normalised_error();
        let sigma_mm = self.sim.core().estimator().estimate().horiz_sigma_m * 1000.0;
        let sigma_deg = self
            .sim
            .core()
            .estimator()
            .ekf_status()
            .map_or(f64::NAN, |s| s.heading_sigma_rad.to_degrees());
        // Let the claim's stop be measured at rest.
        self.drive_until(1.0, |_| false);
        let (position_mm, yaw_deg) = self.error(&goal);
        let after = self.sim.world().truth();
        let moved_after_mm = (after.north_m - at_verdict.north_m).hypot(after.east_m - at_verdict.east_m) * 1000.0;
        let turned_after_deg = wrap_pi(after.yaw_rad - at_verdict.yaw_rad).to_degrees().abs();
        Outcome {
            label,
            within: position_mm <= TOL_M * 1000.0 && yaw_deg.abs() <= TOL_DEG,
            claimed: texts
                .iter()
                .any(|t| t.starts_with("Reached destination") || t.starts_with(ITEM_REACHED)),
            unconfirmed: texts
                .iter()
                .any(|t| t.starts_with("Stopped at") || t.starts_with(UNCLAIMED_ITEM)),
            position_mm,
            yaw_deg,
            direction_changes,
            pivots,
            failsafes: texts.iter().filter(|t| t.contains("ailsafe")).count(),
            duration_s: self.sim.time().as_secs_f64() - start_s,
            verdict_mm,
            moved_after_mm,
            turned_after_deg,
            estimate_error_mm,
            estimated_mm,
            estimated_yaw_deg,
            settle_s,
            settle_position_s,
            retries: self.retries,
            needless_retries: self.needless_retries,
            sigma_mm,
            normalised_error,
            sigma_deg,
            texts: last_said(&texts, 4),
            plans: texts
                .iter()
                .filter(|t| PLAN_TEXTS.iter().any(|p| t.contains(p)))
                .cloned()
                .collect(),
        }
    }

    /// GUIDED to `north_m`, `east_m` facing north: the goal as the target's
    /// coordinates carry it.
    fn guided(&mut self, label: String, north_m: f64, east_m: f64) -> Outcome {
        let target = gcs::local_pose_target(&self.sim, north_m, east_m, 0.0);
        let MavMessage::SET_POSITION_TARGET_GLOBAL_INT(t) = &target else {
            unreachable!("local_pose_target builds a SET_POSITION_TARGET_GLOBAL_INT")
        };
        let sent = GeoPoint::new(f64::from(t.lat_int) * 1e-7, f64::from(t.lon_int) * 1e-7, 0.0);
        let (north_m, east_m) = self.local(&sent);
        self.goal(
            label,
            target,
            Goal {
                north_m,
                east_m,
                yaw_rad: 0.0,
            },
        )
    }

    /// RTL: the goal is home as the vehicle recorded it, facing as it did.
    fn rtl(&mut self, label: String) -> Outcome {
        let (home, yaw) = self.sim.core().home_pose().expect("home is set before arming");
        let (north_m, east_m) = self.local(&home);
        let goal = Goal {
            north_m,
            east_m,
            yaw_rad: yaw.unwrap_or(0.0),
        };
        self.goal(label, gcs::set_mode(11), goal)
    }

    /// AUTO: a mission whose one stop is `north_m`, `east_m` facing north
    /// (NAV_WAYPOINT param 4), started where the vehicle stands; the goal as
    /// the item's coordinates carry it.
    fn mission(&mut self, label: String, north_m: f64, east_m: f64) -> Outcome {
        let p = self.sim.world().local_to_geodetic(north_m, east_m);
        let stop = GeoPoint::new(p.lat_deg, p.lon_deg, 0.0);
        let home = self.sim.core().home().expect("home is set before arming");
        let item = |seq: u16, at: &GeoPoint, yaw_deg: f32| MissionItem {
            seq,
            frame: frame::GLOBAL_RELATIVE_ALT_INT,
            command: cmd::NAV_WAYPOINT,
            current: false,
            autocontinue: true,
            params: [0.0, 0.0, 0.0, yaw_deg],
            x: at.lat_e7(),
            y: at.lon_e7(),
            z: 0.0,
        };
        let items = vec![item(0, &home, 0.0), item(1, &stop, 0.0)];
        self.sim
            .core_mut()
            .load_plan(MissionType::Mission, Plan::new(MissionType::Mission, items));
        let sent = GeoPoint::from_e7(stop.lat_e7(), stop.lon_e7(), 0.0);
        let (north_m, east_m) = self.local(&sent);
        let goal = Goal {
            north_m,
            east_m,
            yaw_rad: 0.0,
        };
        self.goal(label, gcs::set_mode(10), goal)
    }
}

/// The vehicle's last `n` texts (and `MISSION_ITEM_REACHED`s), without
/// the bench's own notes.
fn last_said(texts: &[String], n: usize) -> Vec<String> {
    let said: Vec<&String> = texts
        .iter()
        .filter(|t| !t.starts_with(CHANGE) && !t.starts_with(TRUTH))
        .collect();
    said[said.len().saturating_sub(n)..]
        .iter()
        .map(|t| t.to_string())
        .collect()
}

/// How the bench's text list carries a `MISSION_ITEM_REACHED`.
const ITEM_REACHED: &str = "[MISSION_ITEM_REACHED]";
/// The texts (and AUTO's `MISSION_ITEM_REACHED`) that end a goal.
const VERDICTS: [&str; 7] = [
    "Reached destination",
    "Destination NOT reached",
    "Stopped at",
    ITEM_REACHED,
    "Waypoint #1 NOT reached",
    UNCLAIMED_ITEM,
    "Manoeuvre refused",
];
/// AUTO's verdict on a stop in tolerance it cannot confirm (GUIDED's and
/// RTL's start "Stopped at").
const UNCLAIMED_ITEM: &str = "Waypoint #1 not claimed";
/// How the bench's text list marks a change of direction of the truth.
const CHANGE: &str = "[changed direction:";
/// The texts that say a stop missed and is tried again…
const MISSES: [&str; 2] = ["Missed (", "missed: retry"];
/// …and how the bench's text list notes the truth's error then.
const TRUTH: &str = "[truth then:";
/// The texts that say what was planned, missed and tried again, and the
/// changes of direction among them.
const PLAN_TEXTS: [&str; 7] = ["Manoeuvre", "Missed", "missed", "trying again", "Stop", CHANGE, TRUTH];

/// GNSS receivers the goals are driven with: the simulator's default (a
/// wander of 5 mm per axis, which alone keeps a perfect stop within 10 mm
/// only 86.5 % of the time), and an RTK-grade one that can confirm 10 mm.
const RECEIVERS: [(&str, Option<f64>); 2] = [("walk 5 mm", None), ("walk 1 mm", Some(0.001))];

/// What the manoeuvre section runs.
pub struct Options<'a> {
    /// Seeds 1..=seeds of every goal.
    pub seeds: u64,
    /// (NAME, value) set on every vehicle.
    pub params: &'a [(String, f64)],
    /// The models (none: both).
    pub models: &'a [ModelKind],
    /// Only these run seeds (none: all).
    pub run_seeds: &'a [u64],
    /// Print the goals tick by tick.
    pub trace: bool,
}

/// Runs every goal (and RTL from it) on the models with the seeds and
/// prints the table.
pub fn report(options: &Options<'_>) {
    let (seeds, params) = (options.seeds, options.params);
    println!();
    println!(
        "## manoeuvres: GUIDED to a pose {DISTANCES_M:?} m away in {BEARINGS} directions, facing north as at the start, then RTL, then AUTO to the same pose (a mission stop with a heading) (seeds 1..={seeds}; truth)"
    );
    println!();
    println!(
        "| model | GNSS | leg | goals | reached within 10 mm & 0.05° | \"Reached\" claimed | false \"Reached\" | stopped, unconfirmed | most direction changes | most turns on the spot | failsafes | p95 mm | worst mm | worst yaw ° | median s | stop settled s median / max | position settled s median / max | retries (truth already within) | estimate error > 2σ / > 3σ (axes) | most moved after the verdict mm / ° |"
    );
    println!("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let (mut misses, mut many_changes, mut caps) = (Vec::new(), Vec::new(), Vec::new());
    let mut slow = Vec::new();
    let models = if options.models.is_empty() {
        &[ModelKind::Ackermann, ModelKind::Differential][..]
    } else {
        options.models
    };
    for &model in models {
        for (receiver, walk_m) in RECEIVERS {
            let rows = drive_goals(model, (receiver, walk_m), options, &mut misses, &mut many_changes);
            slow.extend(
                rows.iter()
                    .flat_map(|(_, outcomes)| outcomes)
                    .filter(|o| o.settle_s > SETTLE_MAX_S)
                    .cloned(),
            );
            let walk_m = walk_m.unwrap_or_else(|| default_walk_m(model, params));
            caps.extend(
                rows.iter()
                    .map(|(leg, outcomes)| cap_row(model, receiver, walk_m, leg, outcomes)),
            );
        }
    }
    println!();
    println!(
        "Settling runs from the truth's pose coming within {:.0} mm and {SETTLE_ZONE_DEG:.2}° of the goal for good to the vehicle's last stop report (`Stop: …`); \"position settled\" from the position alone within {0:.0} mm (on a differential vehicle it includes the turn on the spot onto the heading after stopping on the point). A retry is counted needless when the truth was within tolerance as it was called. The verdict after it waits up to {CONFIRM_WAIT_S:.0} s more at rest for the estimate to be sure (GUIDED, RTL and AUTO pose stops alike), which the median s column includes. The last column is the estimate's error from the truth at the verdict on each axis (north, east) in the estimator's own σ of that axis: a true σ has 4.6 % beyond 2σ and 0.27 % beyond 3σ.",
        SETTLE_ZONE_M * 1000.0
    );
    print_caps(&caps);
    print_misses(&misses);
    print_many_changes(&many_changes);
    print_slow_stops(&slow);
}

/// The target's longest settling of a stop: slower stops are listed with
/// what the vehicle said.
const SETTLE_MAX_S: f64 = 8.0;

fn print_slow_stops(outcomes: &[Outcome]) {
    println!();
    println!("Stops that took more than {SETTLE_MAX_S:.0} s to settle, with what the vehicle planned and said:");
    println!();
    if outcomes.is_empty() {
        println!("- none");
    }
    for o in outcomes {
        println!(
            "- {}: {:.1} s, {:.1} mm, yaw {:.3}°: {}",
            o.label,
            o.settle_s,
            o.position_mm,
            o.yaw_deg,
            o.plans.join(" | ")
        );
    }
}

/// Every goal and RTL on one model and receiver: three rows (returned with
/// their leg), and the misses.
fn drive_goals(
    model: ModelKind,
    (receiver, walk_m): (&str, Option<f64>),
    options: &Options<'_>,
    misses: &mut Vec<Outcome>,
    many_changes: &mut Vec<Outcome>,
) -> Vec<(&'static str, Vec<Outcome>)> {
    let (mut guided, mut rtl, mut auto) = (Vec::new(), Vec::new(), Vec::new());
    for seed in 1..=options.seeds {
        for (i, &distance) in DISTANCES_M.iter().enumerate() {
            for b in 0..BEARINGS {
                let bearing = (b as f64 * 360.0 / BEARINGS as f64).to_radians();
                let (north, east) = (distance * bearing.cos(), distance * bearing.sin());
                let run_seed = seed * 100 + (i * BEARINGS + b) as u64;
                if !(options.run_seeds.is_empty() || options.run_seeds.contains(&run_seed)) {
                    continue;
                }
                let mut run = Run::new(model, run_seed, walk_m, options.params);
                run.trace = options.trace;
                let label = format!(
                    "{model:?} {receiver} seed {run_seed}: {distance} m at {:.0}°",
                    bearing.to_degrees()
                );
                guided.push(run.guided(format!("{label} GUIDED"), north, east));
                rtl.push(run.rtl(format!("{label} RTL")));
                auto.push(run.mission(format!("{label} AUTO"), north, east));
            }
        }
    }
    if guided.is_empty() {
        return Vec::new();
    }
    let rows = vec![("GUIDED", guided), ("RTL", rtl), ("AUTO", auto)];
    for (leg, outcomes) in &rows {
        print_row(model, receiver, leg, outcomes);
    }
    let all = rows.iter().flat_map(|(_, outcomes)| outcomes);
    many_changes.extend(all.clone().filter(|o| o.direction_changes > MOST_CHANGES).cloned());
    misses.extend(all.filter(|o| !o.within || o.failsafes > 0 || o.moved_after()).cloned());
    rows
}

/// The target's most changes of direction per goal: goals that took more
/// are listed with what the vehicle planned.
const MOST_CHANGES: usize = 3;

fn print_many_changes(outcomes: &[Outcome]) {
    println!();
    println!(
        "Goals that took more than {MOST_CHANGES} changes of direction, with what the vehicle planned and retried:"
    );
    println!();
    if outcomes.is_empty() {
        println!("- none");
    }
    for o in outcomes {
        println!(
            "- {}: {} changes, {:.1} mm, yaw {:.3}°: {}",
            o.label,
            o.direction_changes,
            o.position_mm,
            o.yaw_deg,
            o.plans.join(" | ")
        );
    }
}

fn print_misses(misses: &[Outcome]) {
    println!();
    println!(
        "Misses (truth out of tolerance 1 s after the verdict), failsafes, and verdicts on a vehicle still moving (the truth moved after it):"
    );
    println!();
    for o in misses {
        println!(
            "- {}: {:.1} mm, yaw {:.3}° ({:.1} mm at the verdict, then moved {:.1} mm and {:.3}°; estimate {:.1} mm from the truth, σ {:.1} mm, error {:+.1}σ north {:+.1}σ east, {:.3}°){}{}: {} (planned: {})",
            o.label,
            o.position_mm,
            o.yaw_deg,
            o.verdict_mm,
            o.moved_after_mm,
            o.turned_after_deg,
            o.estimate_error_mm,
            o.sigma_mm,
            o.normalised_error[0],
            o.normalised_error[1],
            o.sigma_deg,
            if o.claimed {
                ", CLAIMED"
            } else if o.unconfirmed {
                ", unconfirmed"
            } else {
                ""
            },
            if o.failsafes > 0 { ", FAILSAFE" } else { "" },
            o.texts.join(" | "),
            o.plans.join(" | ")
        );
    }
}

fn print_row(model: ModelKind, receiver: &str, leg: &str, outcomes: &[Outcome]) {
    let n = outcomes.len();
    let within = outcomes.iter().filter(|o| o.within).count();
    let claims = outcomes.iter().filter(|o| o.claimed).count();
    let unconfirmed = outcomes.iter().filter(|o| o.unconfirmed).count();
    let false_claims = outcomes.iter().filter(|o| o.claimed && !o.within).count();
    let changes = outcomes.iter().map(|o| o.direction_changes).max().unwrap_or(0);
    let pivots = outcomes.iter().map(|o| o.pivots).max().unwrap_or(0);
    let failsafes: usize = outcomes.iter().map(|o| o.failsafes).sum();
    let mut mm: Vec<f64> = outcomes.iter().map(|o| o.position_mm).collect();
    mm.sort_by(f64::total_cmp);
    let mut secs: Vec<f64> = outcomes.iter().map(|o| o.duration_s).collect();
    secs.sort_by(f64::total_cmp);
    let worst_yaw = outcomes.iter().map(|o| o.yaw_deg.abs()).fold(0.0, f64::max);
    // NaN: the truth never came within the zone (sorted last, shown as such).
    let sorted = |f: fn(&Outcome) -> f64| {
        let mut v: Vec<f64> = outcomes.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v
    };
    let settle = sorted(|o| o.settle_s);
    let settle_position = sorted(|o| o.settle_position_s);
    let retries: usize = outcomes.iter().map(|o| o.retries).sum();
    let needless: usize = outcomes.iter().map(|o| o.needless_retries).sum();
    let at = |v: &[f64], q: f64| v[((q * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)];
    let beyond = |k: f64| {
        let axes = outcomes.iter().flat_map(|o| o.normalised_error);
        // NaN (no estimate) counts as beyond: an estimate that cannot say.
        100.0 * axes.filter(|z| z.is_nan() || z.abs() > k).count() as f64 / (2 * n) as f64
    };
    println!(
        "| {model:?} | {receiver} | {leg} | {n} | {within} ({:.0} %) | {claims} | {false_claims} | {unconfirmed} | {changes} | {pivots} | {failsafes} | {:.1} | {:.1} | {worst_yaw:.3} | {:.0} | {:.1} / {:.1} | {:.1} / {:.1} | {retries} ({needless}) | {:.1} % / {:.1} % | {:.1} / {:.3} |",
        100.0 * within as f64 / n as f64,
        at(&mm, 0.95),
        mm[n - 1],
        at(&secs, 0.5),
        at(&settle, 0.5),
        settle[n - 1],
        at(&settle_position, 0.5),
        settle_position[n - 1],
        beyond(2.0),
        beyond(3.0),
        outcomes.iter().map(|o| o.moved_after_mm).fold(0.0, f64::max),
        outcomes.iter().map(|o| o.turned_after_deg).fold(0.0, f64::max),
    );
}

/// The simulator's GNSS walk (σ per axis, m) for `model` with `params` set:
/// the default receiver's.
fn default_walk_m(model: ModelKind, params: &[(String, f64)]) -> f64 {
    let mut sim_params = SimulationParams::new(model);
    sim_params.apply(params).expect("checked before the runs");
    sim_params.table.value_of("SIM_GPS_WALK").unwrap_or(f64::NAN)
}

/// What keeps one row from 100 %, from the truth: each goal not reached is
/// either a stop the estimate had within tolerance (the estimate's error
/// took the truth out: the GNSS's share) or one out by the estimate too
/// (the stop's own). Beside it, the floor the walk sets: its bias is slow
/// (τ 60 s), so a perfect stop on a perfect estimate of the fixes lands
/// within `TOL_M` only with the Rayleigh probability 1 − exp(−tol²/2σ²).
fn cap_row(model: ModelKind, receiver: &str, walk_m: f64, leg: &str, outcomes: &[Outcome]) -> String {
    let n = outcomes.len();
    let reached = outcomes.iter().filter(|o| o.within).count();
    let estimate_in = |o: &&Outcome| o.estimated_mm <= TOL_M * 1000.0 && o.estimated_yaw_deg.abs() <= TOL_DEG;
    let by_estimate = outcomes.iter().filter(|o| !o.within).filter(estimate_in).count();
    let by_stop = n - reached - by_estimate;
    // The estimate's error from the truth at the verdict, RMS per axis.
    let rms_mm = (outcomes.iter().map(|o| o.estimate_error_mm.powi(2)).sum::<f64>() / (2 * n) as f64).sqrt();
    let (tol_mm, walk_mm) = (TOL_M * 1000.0, walk_m * 1000.0);
    let floor = 1.0 - (-(tol_mm * tol_mm) / (2.0 * walk_mm * walk_mm)).exp();
    let expected = n as f64 * floor;
    let spread = 2.0 * (n as f64 * floor * (1.0 - floor)).sqrt();
    let cap = if reached == n {
        String::from("none")
    } else if by_stop == 0 && reached as f64 >= expected - spread {
        String::from("the estimate's error, at the walk's floor")
    } else if by_stop == 0 {
        String::from("the estimate's error, below the walk's floor")
    } else {
        format!("{by_stop} stops out by the estimate too")
    };
    format!(
        "| {model:?} | {receiver} | {leg} | {reached} of {n} | {by_estimate} | {by_stop} | {rms_mm:.1} | {walk_mm:.1} | 1 − exp(−{tol_mm:.0}²/(2·{walk_mm:.1}²)) = {:.1} % | {expected:.1} ± {spread:.1} | {cap} |",
        100.0 * floor
    )
}

fn print_caps(rows: &[String]) {
    println!();
    println!(
        "What keeps each row from 100 % (truth at rest 1 s after the verdict against the estimate's stop at the verdict):"
    );
    println!();
    println!(
        "| model | GNSS | leg | reached | not reached: in tolerance by the estimate (its error) | not reached: out by the estimate too (the stop) | estimate error RMS per axis mm | GNSS walk σ per axis mm | a perfect stop within tolerance | expected reached at that floor (± 2 s.d.) | what caps it |"
    );
    println!("|---|---|---|---:|---:|---:|---:|---:|---|---:|---|");
    for row in rows {
        println!("{row}");
    }
}
