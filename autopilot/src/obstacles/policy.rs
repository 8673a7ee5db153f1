//! What to do about obstacles (docs/architecture.md §Obstacles, seed 004 §III.D): stop, slow,
//! pass first, and when to resume.
//!
//! Rules, in order:
//! 1. Stale or missing scans while the vehicle wants to move: stop (it is
//!    blind).
//! 2. Any point in the protective field: stop, whatever the tracks say.
//! 3. A confirmed track with a collision predicted within `stop_horizon_s`:
//!    - ahead and walking away in the travel direction: slow to its speed
//!      along that direction (follow it rather than stop-and-go);
//!    - crossing the path, with `pass_first` and the corrected eq. 18
//!      holding: speed up to V_max and pass in front of it;
//!    - otherwise: stop.
//! 4. Points in the warning field: slow to the speed that keeps them out of
//!    the protective field.
//!
//! Without `pass_first` (which decides on the first prediction), a
//! collision predicted further off than the vehicle needs to stop
//! (`reaction_s` + v/`decel_mps2`) plus [`DECIDE_LEAD_S`] does not stop it
//! yet: it holds its speed (no acceleration) and decides again next tick,
//! with a track velocity that has had longer to settle. The stop, if it is
//! still needed, comes with at least that lead; the tracker's velocity
//! error over the last second of a 3 s horizon (a few tenths of a metre)
//! would otherwise stop it for people about to pass clear of it. At rest the
//! same holds for an object predicted walking: the vehicle does not start
//! ([`Verdict::Wait`]: braked at a standstill, no stop held or announced)
//! while the contact its start would make is further off than `reaction_s`
//! plus [`DECIDE_LEAD_S`], and decides again next tick; a standing object's
//! prediction owes nothing to a velocity estimate and stops it at once.
//!
//! A stop is held until the way has been clear *as if already moving at the
//! planned speed* (`field_at_resume`, `predictions_at_resume`) continuously
//! for `resume_s`: judging it at standstill would always find it clear and
//! the vehicle would start and stop again (chattering). With `auto_resume`
//! off the held stop then waits for the operator (ISO 3691-4 4.1.14: no
//! automatic restart), announced once.
//!
//! A stop for an object that follows, within `CYCLE_WINDOW_S`, a resume
//! from a stop for the same object (the field counts as one object) is a
//! stop/go cycle: hysteresis, not progress. After `stop_cycles` of them the
//! held stop becomes patient: it resumes only once nothing at all is
//! predicted for that object over the prediction horizon at the planned
//! speed and the warning field is empty too, for `resume_s` (the core may
//! plan a detour instead, with `OA_TYPE` 1). If that object stood still
//! when stopped for, the way is not clear either while it stands within
//! [`STOOD_MOVED_M`] of that place: the stop/go cycles show the path meets
//! it, whatever a check at rest finds (a path judged at rest, with no
//! turning rate to go by, can miss an object that the turn being driven
//! sweeps into, and each resume crept a few centimetres closer).
//!
//! A vehicle at rest with nothing to do (not wanting to move, not settling)
//! is not judged at all. One settling onto a precision stop wants no speed
//! but is not parked: it may still creep (the speed lag never quite reaches
//! 0) or re-approach the stop point, so the same checks apply to it as to a
//! start, and a stop holds its settling until the way is clear.
//!
//! At rest the current-velocity inputs describe a vehicle going nowhere, so
//! whether it may start is judged on the at-resume inputs there as well.
//! Starting (from rest, or resuming a held stop) is refused besides while
//! any object is within the margin of the outline now, closing or not,
//! confirmed, coasting or just lost from view (a prediction at time 0 for
//! a track that is not tentative): someone standing against the side, or
//! one who walked into the scanners' blind zone beside the body, is driven
//! into by the first metre of a turn, and a gap that "is not closing" at
//! rest says nothing about the motion about to begin.
//!
//! Sources: docs/references.md §Seed 004.

use std::cmp::Ordering;
use std::fmt;

use super::field::FieldStatus;
use super::prediction::{CollisionPrediction, to_body};
use super::tracking::STILL_S;
use super::{Footprint, Pose, Track, TrackStatus};
use crate::geo::Ned;

/// Slower than this the vehicle is at rest.
const AT_REST_MPS: f64 = 0.02;
/// A track walking away slower than this is treated as standing: following
/// it would be stop-and-go anyway.
const MIN_FOLLOW_SPEED_MPS: f64 = 0.1;
/// A stop this soon after a resume for the same object is a stop/go cycle.
pub const CYCLE_WINDOW_S: f64 = 5.0;
/// The protective field as the "object" of a stop/go cycle.
const FIELD_OBJECT: u32 = u32::MAX;
/// A standing object a patient stop was held for has left its place once
/// its track is this far from it (m): well beyond the tracker's noise on a
/// standing track's centre (a few centimetres).
pub const STOOD_MOVED_M: f64 = 0.3;
/// A moving vehicle stops for a predicted collision no later than this
/// long before it would need to (s).
pub const DECIDE_LEAD_S: f64 = 1.0;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PolicyConfig {
    /// OA_RESUME_S: how long the way must stay clear before resuming.
    pub resume_s: f64,
    /// Resume by itself; else wait for the GCS.
    pub auto_resume: bool,
    /// OA_PASS: seed 004's pass-first rule (eq. 18).
    pub pass_first: bool,
    /// V_Amax.
    pub max_speed_mps: f64,
    pub accel_mps2: f64,
    /// ΔL: clearance between the vehicle's trailing bumper and a crossing
    /// obstacle when it reaches the vehicle's lane after a pass.
    pub safe_distance_m: f64,
    /// A predicted collision sooner than this stops the vehicle.
    pub stop_horizon_s: f64,
    /// A scan older than this while wanting to move stops the vehicle.
    pub scan_timeout_s: f64,
    /// OA_STOP_CYCLES: stop/go cycles for one object before the stop turns
    /// patient; 0 never.
    pub stop_cycles: u32,
    /// OA_REACT_TIME and OA_DECEL: the time to stop from a speed.
    pub reaction_s: f64,
    pub decel_mps2: f64,
}

impl Default for PolicyConfig {
    fn default() -> Self {
        PolicyConfig {
            resume_s: 2.0,
            auto_resume: true,
            pass_first: false,
            max_speed_mps: 2.0,
            accel_mps2: 0.5,
            safe_distance_m: 0.5,
            stop_horizon_s: 3.0,
            scan_timeout_s: 0.2,
            stop_cycles: 3,
            reaction_s: 0.15,
            decel_mps2: 1.0,
        }
    }
}

/// One tick's view of the obstacles.
#[derive(Clone, Copy, Debug)]
pub struct PolicyInputs<'a> {
    pub t_s: f64,
    pub wants_to_move: bool,
    /// Wants no speed but is still settling onto a stop point, which it may
    /// creep towards or re-approach: not parked, so it is guarded.
    pub settling: bool,
    /// Signed: reversing is negative.
    pub speed_mps: f64,
    /// Age of the newest scan; `None` when there is none.
    pub scan_age_s: Option<f64>,
    /// Fields sized for the current speed.
    pub field: &'a FieldStatus,
    /// Fields sized for the speed it would resume at.
    pub field_at_resume: &'a FieldStatus,
    /// Predictions at the current velocity.
    pub predictions: &'a [CollisionPrediction],
    /// Predictions as if moving at the planned velocity: the hysteresis.
    pub predictions_at_resume: &'a [CollisionPrediction],
    pub tracks: &'a [Track],
    /// The vehicle's pose now: which tracks are ahead, crossing or walking
    /// away depends on it.
    pub pose: Pose,
    pub footprint: &'a Footprint,
    /// [`super::field::warning_speed_limit`] for the fields that apply (at
    /// rest, those sized for the resume speed); `None` without warning hits.
    pub warning_limit_mps: Option<f64>,
}

/// Why the vehicle stopped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StopCause {
    /// Distance ahead of the bumper of the nearest point in the field.
    ProtectiveField {
        distance_m: f64,
    },
    Collision {
        track_id: u32,
        time_s: f64,
        distance_m: f64,
    },
    StaleScan {
        age_s: Option<f64>,
    },
}

/// A short cause for a STATUSTEXT.
impl fmt::Display for StopCause {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StopCause::ProtectiveField { distance_m } => write!(f, "obstacle {distance_m:.1} m in path"),
            StopCause::Collision { track_id, time_s, .. } => {
                write!(f, "obstacle #{track_id} collision in {time_s:.1} s")
            }
            StopCause::StaleScan { age_s: Some(age_s) } => write!(f, "scanner stale {age_s:.2} s"),
            StopCause::StaleScan { age_s: None } => write!(f, "no scan from scanner"),
        }
    }
}

/// Speeds are magnitudes in the current driving direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Verdict {
    Go,
    Slow {
        limit_mps: f64,
    },
    /// Pass first (eq. 18): drive at this speed until the track is passed.
    SpeedUp {
        target_mps: f64,
    },
    Stop(StopCause),
    /// At rest: do not start yet. Braked at a standstill like a stop, but
    /// not held, announced or counted as a stop/go cycle: a walking
    /// object's far prediction, decided again next tick.
    Wait(StopCause),
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PolicyEvent {
    Stopped(StopCause),
    Resumed {
        stopped_s: f64,
    },
    WaitingForOperator(StopCause),
    PassingFirst {
        track_id: u32,
    },
    Slowing,
    /// `cycles` stop/go cycles for the object of `cause`: the held stop now
    /// waits for a clear way.
    StopGo {
        cycles: u32,
        cause: StopCause,
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct PolicyStatus {
    pub verdict: Verdict,
    /// Usually empty: each event is reported once, on the transition.
    pub events: Vec<PolicyEvent>,
    pub stopped: bool,
}

/// The distance gained by accelerating from `speed_now_mps` towards
/// `max_speed_mps` at `accel_mps2` for `t_s`, over carrying on at
/// `speed_now_mps`. The seed's eq. 18 takes this as (V_max − V_now)·t,
/// which needs an infinite acceleration: with τ = (V_max − V_now)/a it is
/// a·t²/2 up to τ and (V_max − V_now)·(t − τ/2) after.
pub fn distance_gained_m(speed_now_mps: f64, max_speed_mps: f64, accel_mps2: f64, t_s: f64) -> f64 {
    let dv = max_speed_mps - speed_now_mps.abs();
    if !(dv > 0.0 && accel_mps2 > 0.0 && t_s > 0.0) {
        return 0.0;
    }
    let tau_s = dv / accel_mps2;
    if t_s <= tau_s {
        0.5 * accel_mps2 * t_s * t_s
    } else {
        dv * (t_s - 0.5 * tau_s)
    }
}

/// The corrected eq. 18: speeding up passes first when the distance gained
/// by `t_c_s` exceeds `required_gain_m`. The seed asks for AC + ΔL (obstacle
/// size and safe distance) only, which clears the crossing point with the
/// front bumper but leaves the rest of the vehicle in the obstacle's way:
/// for an obstacle meeting the front bumper the requirement is L + AC + ΔL,
/// with L the vehicle's length (see [`pass_first_requirement`]).
pub fn pass_first_holds(speed_now_mps: f64, t_c_s: f64, required_gain_m: f64, config: &PolicyConfig) -> bool {
    distance_gained_m(speed_now_mps, config.max_speed_mps, config.accel_mps2, t_c_s) > required_gain_m
}

/// For a track crossing the vehicle's straight path: the time t_c at which
/// its edge reaches the vehicle's lane (|y| = half width), and the gain
/// needed by then for the trailing bumper to be ΔL past its far edge. In the
/// body frame at t_c of a vehicle carrying on at `speed_mps`, with x_c the
/// track's centre along the travel direction: x_c + radius + trailing
/// overhang + ΔL; an obstacle arriving at the front bumper (x_c = front +
/// radius) gives the seed's form with the length added, L + AC + ΔL.
/// `None` when the track is not crossing: inside the lane already, moving
/// away from it, moving more along the path than across it, or keeping up
/// with the vehicle once across.
pub fn pass_first_requirement(
    track: &Track,
    pose: &Pose,
    speed_mps: f64,
    footprint: &Footprint,
    safe_distance_m: f64,
) -> Option<(f64, f64)> {
    let direction = if speed_mps < 0.0 { -1.0 } else { 1.0 };
    let (x, y) = to_body(
        pose.yaw_rad,
        track.position.north_m - pose.position.north_m,
        track.position.east_m - pose.position.east_m,
    );
    let (vx, vy) = to_body(pose.yaw_rad, track.vel_north_mps, track.vel_east_mps);
    let radius_m = track.radius_m.max(0.0);
    let outside_m = y.abs() - footprint.half_width_m - radius_m;
    let approaching = y * vy < 0.0;
    let crossing = vy.abs() >= vx.abs() && vx * direction < speed_mps.abs();
    if !(outside_m > 0.0 && approaching && crossing) {
        return None;
    }
    let t_c_s = outside_m / vy.abs();
    let along_m = (x + vx * t_c_s) * direction - speed_mps.abs() * t_c_s;
    let trailing_m = if direction > 0.0 {
        footprint.rear_m
    } else {
        footprint.front_m
    };
    let required_m = along_m + radius_m + trailing_m + safe_distance_m.max(0.0);
    (t_c_s.is_finite() && required_m.is_finite()).then_some((t_c_s, required_m))
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct HeldStop {
    since_s: f64,
    cause: StopCause,
    /// When the way last became clear for resuming; `None` while blocked.
    clear_since_s: Option<f64>,
    /// Clear for `resume_s` and waiting for the GCS.
    ready_for_operator: bool,
    announced_waiting: bool,
    /// After too many stop/go cycles: resume only on a clear way.
    patient: bool,
    /// The track stopped for and where it stood, if it stood still.
    stood: Option<(u32, Ned)>,
}

/// What one collision prediction asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Response {
    Ignore,
    Follow {
        limit_mps: f64,
    },
    /// Too far off to stop for yet: hold the current speed (at rest: wait).
    Hold,
    PassFirst,
    Stop,
}

/// The stop/resume state machine. Feed it every tick.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObstaclePolicy {
    held: Option<HeldStop>,
    /// Events raised between ticks (an operator's resume).
    pending: Vec<PolicyEvent>,
    slowing: bool,
    passing_track: Option<u32>,
    /// The object of the last resumed stop, and when it resumed.
    last_resume: Option<(u32, f64)>,
    cycles: u32,
}

/// The object a stop was for: a track, or the field.
fn stop_object(cause: &StopCause) -> Option<u32> {
    match cause {
        StopCause::Collision { track_id, .. } => Some(*track_id),
        StopCause::ProtectiveField { .. } => Some(FIELD_OBJECT),
        StopCause::StaleScan { .. } => None,
    }
}

impl ObstaclePolicy {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn update(&mut self, inputs: &PolicyInputs, config: &PolicyConfig) -> PolicyStatus {
        let mut events = std::mem::take(&mut self.pending);
        if let Some(verdict) = self.check_held(inputs, config, &mut events) {
            return stopped(verdict, events);
        }

        let at_rest = inputs.speed_mps.abs() < AT_REST_MPS;
        if !inputs.wants_to_move && !inputs.settling && at_rest {
            self.slowing = false;
            self.passing_track = None;
            return PolicyStatus {
                verdict: Verdict::Go,
                events,
                stopped: false,
            };
        }

        let verdict = self.assess(inputs, config, at_rest, &mut events);
        match verdict {
            Verdict::Stop(cause) => {
                self.hold_stop(cause, inputs, config, &mut events);
                return stopped(verdict, events);
            }
            Verdict::Slow { .. } => {
                if !self.slowing {
                    events.push(PolicyEvent::Slowing);
                }
                self.slowing = true;
            }
            Verdict::SpeedUp { .. } | Verdict::Go | Verdict::Wait(_) => self.slowing = false,
        }
        PolicyStatus {
            verdict,
            events,
            stopped: false,
        }
    }

    /// A held stop: still blocked, not clear long enough, or waiting for the
    /// operator (Some, the verdict to hold), or resumed (None, announced).
    fn check_held(
        &mut self,
        inputs: &PolicyInputs,
        config: &PolicyConfig,
        events: &mut Vec<PolicyEvent>,
    ) -> Option<Verdict> {
        if let Some(held) = self.held.as_mut() {
            let blocker = if held.patient {
                patient_blocker(inputs, config, stop_object(&held.cause))
                    .or_else(|| still_standing(inputs, held.stood).map(|_| held.cause))
            } else {
                resume_blocker(inputs, config)
            };
            match blocker {
                Some(cause) => {
                    held.clear_since_s = None;
                    held.ready_for_operator = false;
                    return Some(Verdict::Stop(cause));
                }
                None => {
                    let clear_since_s = *held.clear_since_s.get_or_insert(inputs.t_s);
                    // Not waited long enough, or cannot tell (NaN): stay stopped.
                    let waited_s = inputs.t_s - clear_since_s;
                    if waited_s.partial_cmp(&config.resume_s).is_none_or(Ordering::is_lt) {
                        return Some(Verdict::Stop(held.cause));
                    }
                    if !config.auto_resume {
                        held.ready_for_operator = true;
                        if !held.announced_waiting {
                            held.announced_waiting = true;
                            events.push(PolicyEvent::WaitingForOperator(held.cause));
                        }
                        return Some(Verdict::Stop(held.cause));
                    }
                    events.push(PolicyEvent::Resumed {
                        stopped_s: inputs.t_s - held.since_s,
                    });
                    if held.patient {
                        self.cycles = 0;
                    }
                    self.last_resume = stop_object(&held.cause).map(|o| (o, inputs.t_s));
                    self.held = None;
                }
            }
        }
        None
    }

    /// Holds a new stop and announces it (and a stop-and-go cycle that has
    /// made the stop patient).
    fn hold_stop(
        &mut self,
        cause: StopCause,
        inputs: &PolicyInputs,
        config: &PolicyConfig,
        events: &mut Vec<PolicyEvent>,
    ) {
        let object = stop_object(&cause);
        let again = self
            .last_resume
            .is_some_and(|(o, t)| Some(o) == object && inputs.t_s - t <= CYCLE_WINDOW_S);
        self.cycles = if again { self.cycles + 1 } else { 0 };
        let patient = config.stop_cycles > 0 && self.cycles >= config.stop_cycles;
        let stood = match cause {
            StopCause::Collision { track_id, .. } => inputs
                .tracks
                .iter()
                .find(|t| t.id == track_id && t.still_s >= STILL_S)
                .map(|t| (t.id, t.position)),
            _ => None,
        };
        self.held = Some(HeldStop {
            since_s: inputs.t_s,
            cause,
            clear_since_s: None,
            ready_for_operator: false,
            announced_waiting: false,
            patient,
            stood,
        });
        events.push(PolicyEvent::Stopped(cause));
        if patient {
            events.push(PolicyEvent::StopGo {
                cycles: self.cycles,
                cause,
            });
        }
        self.slowing = false;
        self.passing_track = None;
    }

    /// The operator's resume from the GCS: releases a stop held for the
    /// operator once the way has been clear for `resume_s` (as of the last
    /// update). True when it released one; the Resumed event comes with the
    /// next update.
    pub fn operator_resume(&mut self, t_s: f64) -> bool {
        match self.held {
            Some(held) if held.ready_for_operator => {
                self.pending.push(PolicyEvent::Resumed {
                    stopped_s: t_s - held.since_s,
                });
                self.held = None;
                true
            }
            _ => false,
        }
    }

    /// Forgets any held stop (disarm, mode change).
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    pub fn is_stopped(&self) -> bool {
        self.held.is_some()
    }

    /// The verdict while not held, and the pass-first commitment's
    /// bookkeeping.
    fn assess(
        &mut self,
        inputs: &PolicyInputs,
        config: &PolicyConfig,
        at_rest: bool,
        events: &mut Vec<PolicyEvent>,
    ) -> Verdict {
        if inputs.wants_to_move && is_stale(inputs.scan_age_s, config) {
            return Verdict::Stop(StopCause::StaleScan {
                age_s: inputs.scan_age_s,
            });
        }
        let (field, predictions) = if at_rest {
            (inputs.field_at_resume, inputs.predictions_at_resume)
        } else {
            (inputs.field, inputs.predictions)
        };
        if let Some(cause) = field_stop(&[field]) {
            return Verdict::Stop(cause);
        }
        // Settling, the vehicle may still creep or re-approach its stop
        // point: someone within the margin of it stops it as at a start.
        if (at_rest || !inputs.wants_to_move)
            && let Some(prediction) = start_blocker(inputs)
        {
            return Verdict::Stop(collision_cause(prediction));
        }

        let Weighed {
            stop,
            wait,
            passes,
            slow_mps,
        } = weigh_predictions(predictions, inputs, config, at_rest);
        if let Some(prediction) = stop {
            self.passing_track = None;
            return Verdict::Stop(collision_cause(prediction));
        }
        if let Some(prediction) = wait {
            self.passing_track = None;
            return Verdict::Wait(collision_cause(prediction));
        }
        if let Some(limit_mps) = slow_mps {
            self.passing_track = None;
            return Verdict::Slow {
                limit_mps: limit_mps.min(config.max_speed_mps),
            };
        }
        self.pass_or_go(&passes, inputs, config, at_rest, events)
    }

    /// No stop and no slow-down: speed up to pass the first track a
    /// pass-first response chose (announced once per track), keep that
    /// speed while the track passed is still ahead, or go on.
    fn pass_or_go(
        &mut self,
        passes: &[&CollisionPrediction],
        inputs: &PolicyInputs,
        config: &PolicyConfig,
        at_rest: bool,
        events: &mut Vec<PolicyEvent>,
    ) -> Verdict {
        let speed_up = Verdict::SpeedUp {
            target_mps: config.max_speed_mps,
        };
        if let Some(first) = passes
            .iter()
            .copied()
            .reduce(|a, b| if b.time_s < a.time_s { b } else { a })
        {
            if self.passing_track != Some(first.track_id) {
                self.passing_track = Some(first.track_id);
                events.push(PolicyEvent::PassingFirst {
                    track_id: first.track_id,
                });
            }
            return speed_up;
        }
        // Once faster, the prediction for the track being passed clears
        // before the track is behind: keep the speed until it is, or the
        // vehicle would drop back to cruise and meet it again.
        if let Some(track_id) = self.passing_track {
            let still_ahead = inputs
                .tracks
                .iter()
                .find(|t| t.id == track_id)
                .is_some_and(|t| !is_behind(t, inputs));
            if still_ahead && !at_rest {
                return speed_up;
            }
            self.passing_track = None;
        }
        Verdict::Go
    }
}

/// Reaction and braking time from `speed_mps` (infinite without a usable
/// deceleration: then nothing is put off).
fn stopping_time_s(speed_mps: f64, config: &PolicyConfig) -> f64 {
    if config.decel_mps2 > 0.0 {
        config.reaction_s.max(0.0) + speed_mps.abs() / config.decel_mps2
    } else {
        f64::INFINITY
    }
}

fn stopped(verdict: Verdict, events: Vec<PolicyEvent>) -> PolicyStatus {
    PolicyStatus {
        verdict,
        events,
        stopped: true,
    }
}

fn is_stale(scan_age_s: Option<f64>, config: &PolicyConfig) -> bool {
    !matches!(scan_age_s, Some(age_s) if age_s <= config.scan_timeout_s)
}

fn field_stop(fields: &[&FieldStatus]) -> Option<StopCause> {
    let hit = fields.iter().filter(|f| f.protective_hits > 0);
    let nearest = hit.map(|f| f.nearest_protective_m.unwrap_or(0.0)).reduce(f64::min)?;
    Some(StopCause::ProtectiveField { distance_m: nearest })
}

/// What the predictions ask for together.
struct Weighed<'p> {
    /// The earliest stop.
    stop: Option<&'p CollisionPrediction>,
    /// At rest, the earliest prediction put off: do not start yet.
    wait: Option<&'p CollisionPrediction>,
    /// The pass-first candidates.
    passes: Vec<&'p CollisionPrediction>,
    /// The tightest speed limit (the warning field's, a follow's or a
    /// hold's).
    slow_mps: Option<f64>,
}

/// Each prediction's response.
fn weigh_predictions<'p>(
    predictions: &'p [CollisionPrediction],
    inputs: &PolicyInputs,
    config: &PolicyConfig,
    at_rest: bool,
) -> Weighed<'p> {
    let mut stop: Option<&CollisionPrediction> = None;
    let mut wait: Option<&CollisionPrediction> = None;
    let mut passes: Vec<&CollisionPrediction> = Vec::new();
    let mut slow_mps = inputs.warning_limit_mps.map(|l| l.max(0.0));
    let allow_pass = config.pass_first && !at_rest;
    // Pass-first (seed 004) decides on the first prediction. At rest only a
    // walking object's far prediction waits: its velocity is still settling.
    let defer = |p: &CollisionPrediction| !config.pass_first && (!at_rest || p.obstacle_speed_mps > 0.0);
    let held_mps = inputs.speed_mps.abs();
    for prediction in predictions {
        let response = match respond_moving(prediction, inputs, config, allow_pass, at_rest) {
            Response::Stop
                if defer(prediction)
                    && prediction.time_s > stopping_time_s(inputs.speed_mps, config) + DECIDE_LEAD_S =>
            {
                Response::Hold
            }
            response => response,
        };
        match response {
            Response::Ignore => {}
            Response::Stop => stop = earliest(stop, prediction),
            Response::Follow { limit_mps } => slow_mps = Some(slow_mps.map_or(limit_mps, |s| s.min(limit_mps))),
            Response::Hold if at_rest => wait = earliest(wait, prediction),
            Response::Hold => slow_mps = Some(slow_mps.map_or(held_mps, |s| s.min(held_mps))),
            Response::PassFirst => passes.push(prediction),
        }
    }
    // Following is judged at the planned velocity too: once slowed to
    // the walker's speed the current-velocity prediction clears, and
    // judging on it alone would speed up and slow down in turn.
    if !at_rest {
        for prediction in inputs.predictions_at_resume {
            if let Response::Follow { limit_mps } = respond(prediction, inputs, config, false) {
                slow_mps = Some(slow_mps.map_or(limit_mps, |s| s.min(limit_mps)));
            }
        }
    }
    // Passing first needs the speed a slow-down forbids.
    if slow_mps.is_some() {
        for prediction in passes.drain(..) {
            stop = earliest(stop, prediction);
        }
    }
    Weighed {
        stop,
        wait,
        passes,
        slow_mps,
    }
}

fn earliest<'p>(a: Option<&'p CollisionPrediction>, b: &'p CollisionPrediction) -> Option<&'p CollisionPrediction> {
    match a {
        Some(a) if a.time_s <= b.time_s => Some(a),
        _ => Some(b),
    }
}

fn collision_cause(prediction: &CollisionPrediction) -> StopCause {
    StopCause::Collision {
        track_id: prediction.track_id,
        time_s: prediction.time_s,
        distance_m: prediction.distance_m,
    }
}

/// Why the held stop may not be released yet, judged as if moving at the
/// planned speed.
fn resume_blocker(inputs: &PolicyInputs, config: &PolicyConfig) -> Option<StopCause> {
    if is_stale(inputs.scan_age_s, config) {
        return Some(StopCause::StaleScan {
            age_s: inputs.scan_age_s,
        });
    }
    if let Some(cause) = field_stop(&[inputs.field, inputs.field_at_resume]) {
        return Some(cause);
    }
    if let Some(prediction) = start_blocker(inputs) {
        return Some(collision_cause(prediction));
    }
    inputs
        .predictions_at_resume
        .iter()
        .filter(|p| respond(p, inputs, config, false) == Response::Stop)
        .fold(None, earliest)
        .map(collision_cause)
}

/// An object within the margin of the outline now (a prediction at time 0
/// for a track that is not tentative, or no longer in the list): the
/// vehicle may not start.
fn start_blocker<'p>(inputs: &PolicyInputs<'p>) -> Option<&'p CollisionPrediction> {
    inputs
        .predictions_at_resume
        .iter()
        .filter(|p| p.time_s <= 0.0)
        .filter(|p| {
            inputs
                .tracks
                .iter()
                .find(|t| t.id == p.track_id)
                .is_none_or(|t| t.status != TrackStatus::Tentative)
        })
        .fold(None, earliest)
}

/// The stricter resume test after too many stop/go cycles: besides the
/// usual blockers, any warning-field return, and any prediction at all at
/// the planned speed for the object stopped for (however far off within
/// the prediction horizon, closing or not).
fn patient_blocker(inputs: &PolicyInputs, config: &PolicyConfig, object: Option<u32>) -> Option<StopCause> {
    if let Some(cause) = resume_blocker(inputs, config) {
        return Some(cause);
    }
    if inputs.field_at_resume.warning_hits > 0 {
        return Some(StopCause::ProtectiveField {
            distance_m: inputs.field_at_resume.nearest_warning_m.unwrap_or(0.0),
        });
    }
    inputs
        .predictions_at_resume
        .iter()
        .filter(|p| Some(p.track_id) == object)
        .fold(None, earliest)
        .map(collision_cause)
}

/// The track of `stood` (a track and where it stood still) while it is
/// still tracked within [`STOOD_MOVED_M`] of that place.
fn still_standing<'t>(inputs: &PolicyInputs<'t>, stood: Option<(u32, Ned)>) -> Option<&'t Track> {
    let (id, at) = stood?;
    inputs
        .tracks
        .iter()
        .find(|t| t.id == id && t.status != TrackStatus::Tentative && t.position.distance_to(&at) <= STOOD_MOVED_M)
}

/// [`respond`] for a vehicle that moves: a coasting track that stood
/// still when last seen counts as a confirmed one. A standing thing drops
/// out of view beside the body (the blind zone between the scanners'
/// fields) and is still there; ignored, the inner side of an arc or the
/// swing of the body sweeps into it while the track coasts.
fn respond_moving(
    prediction: &CollisionPrediction,
    inputs: &PolicyInputs,
    config: &PolicyConfig,
    allow_pass: bool,
    at_rest: bool,
) -> Response {
    let standing_out_of_view = !at_rest
        && inputs
            .tracks
            .iter()
            .find(|t| t.id == prediction.track_id)
            .is_some_and(|t| t.status == TrackStatus::Coasting && t.still_s >= STILL_S);
    if standing_out_of_view {
        return respond_confirmed(prediction, None, inputs, config, false);
    }
    respond(prediction, inputs, config, allow_pass)
}

fn respond(
    prediction: &CollisionPrediction,
    inputs: &PolicyInputs,
    config: &PolicyConfig,
    allow_pass: bool,
) -> Response {
    let track = inputs.tracks.iter().find(|t| t.id == prediction.track_id);
    // A prediction for a track not in the list cannot be judged: act on it.
    if track.is_some_and(|t| t.status != TrackStatus::Confirmed) {
        return Response::Ignore;
    }
    respond_confirmed(prediction, track, inputs, config, allow_pass)
}

/// The response to a prediction for `track` (none: a track not in the
/// list, which is stopped for).
fn respond_confirmed(
    prediction: &CollisionPrediction,
    track: Option<&Track>,
    inputs: &PolicyInputs,
    config: &PolicyConfig,
    allow_pass: bool,
) -> Response {
    let beyond_horizon = prediction
        .time_s
        .partial_cmp(&config.stop_horizon_s)
        .is_none_or(Ordering::is_gt);
    if !prediction.closing || beyond_horizon {
        return Response::Ignore;
    }
    let Some(track) = track else {
        return Response::Stop;
    };
    if prediction.time_s > 0.0 {
        if let Some(limit_mps) = follow_speed(track, inputs) {
            return Response::Follow {
                limit_mps: limit_mps.min(config.max_speed_mps),
            };
        }
        if allow_pass {
            let requirement = pass_first_requirement(
                track,
                &inputs.pose,
                inputs.speed_mps,
                inputs.footprint,
                config.safe_distance_m,
            );
            if requirement.is_some_and(|(t_c_s, gain_m)| pass_first_holds(inputs.speed_mps, t_c_s, gain_m, config)) {
                return Response::PassFirst;
            }
        }
    }
    Response::Stop
}

/// +1 forward, −1 reverse; at rest, forward.
fn travel_direction(speed_mps: f64) -> f64 {
    if speed_mps < 0.0 { -1.0 } else { 1.0 }
}

/// A track in the lane ahead of the leading bumper walking away in the
/// travel direction: its speed along it. Only such a walker can be followed;
/// one beside the vehicle that outruns it while closing in from the side
/// (overtaking at an angle) is a collision to stop for, however fast it
/// walks forward.
fn follow_speed(track: &Track, inputs: &PolicyInputs) -> Option<f64> {
    let direction = travel_direction(inputs.speed_mps);
    let (x, y) = to_body(
        inputs.pose.yaw_rad,
        track.position.north_m - inputs.pose.position.north_m,
        track.position.east_m - inputs.pose.position.east_m,
    );
    let (vx, _) = to_body(inputs.pose.yaw_rad, track.vel_north_mps, track.vel_east_mps);
    let along_mps = vx * direction;
    let leading_m = if direction > 0.0 {
        inputs.footprint.front_m
    } else {
        inputs.footprint.rear_m
    };
    let radius_m = track.radius_m.max(0.0);
    let ahead = x * direction > leading_m + radius_m;
    let in_lane = y.abs() < inputs.footprint.half_width_m + radius_m;
    (ahead && in_lane && along_mps >= MIN_FOLLOW_SPEED_MPS).then_some(along_mps)
}

/// Behind the trailing bumper, in the travel direction.
fn is_behind(track: &Track, inputs: &PolicyInputs) -> bool {
    let direction = travel_direction(inputs.speed_mps);
    let (x, _) = to_body(
        inputs.pose.yaw_rad,
        track.position.north_m - inputs.pose.position.north_m,
        track.position.east_m - inputs.pose.position.east_m,
    );
    let trailing_m = if direction > 0.0 {
        inputs.footprint.rear_m
    } else {
        inputs.footprint.front_m
    };
    x * direction < -(trailing_m + track.radius_m.max(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gain_matches_integrated_motion() {
        // Integrate the accelerate-then-cruise profile numerically.
        for (v0, vmax, a, t) in [
            (0.5, 2.0, 0.5, 1.0),
            (0.5, 2.0, 0.5, 6.0),
            (1.0, 1.5, 2.0, 3.0),
            (0.0, 1.0, 0.3, 2.0),
        ] {
            let steps = 200_000;
            let dt = t / steps as f64;
            let (mut v, mut s) = (v0, 0.0);
            for _ in 0..steps {
                let next = (v + a * dt).min(vmax);
                s += 0.5 * (v + next) * dt;
                v = next;
            }
            let expected = s - v0 * t;
            let got = distance_gained_m(v0, vmax, a, t);
            assert!(
                (got - expected).abs() < 1e-6,
                "{v0} {vmax} {a} {t}: {got} vs {expected}"
            );
        }
    }

    #[test]
    fn no_gain_at_or_above_max_speed() {
        assert_eq!(distance_gained_m(2.0, 2.0, 1.0, 5.0), 0.0);
        assert_eq!(distance_gained_m(-2.5, 2.0, 1.0, 5.0), 0.0);
        assert_eq!(distance_gained_m(1.0, 2.0, 0.0, 5.0), 0.0);
    }

    #[test]
    fn causes_read_short() {
        let causes = [
            StopCause::ProtectiveField { distance_m: 1.23 },
            StopCause::Collision {
                track_id: 4,
                time_s: 2.08,
                distance_m: 3.0,
            },
            StopCause::StaleScan { age_s: Some(0.35) },
            StopCause::StaleScan { age_s: None },
        ];
        let text: Vec<String> = causes.iter().map(ToString::to_string).collect();
        assert_eq!(text[0], "obstacle 1.2 m in path");
        assert_eq!(text[1], "obstacle #4 collision in 2.1 s");
        assert_eq!(text[2], "scanner stale 0.35 s");
        assert!(text.iter().all(|t| t.len() <= 40));
    }
}
