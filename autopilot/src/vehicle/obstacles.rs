//! The obstacle pipeline in the core (docs/architecture.md §Obstacles): every scan becomes
//! points, clusters and Kalman tracks; every tick the protective field (raw
//! points), the collision predictions (tracks) and the policy decide whether
//! the self-driving modes may drive on, slow, or must stop; the stops and
//! resumes are announced, and the scans are summarised for the GCS
//! proximity view (OBSTACLE_DISTANCE).

use std::time::Duration;

use drivers::scanner::Scan;
use mavlink::dialects::ardupilotmega::{MavDistanceSensor, MavFrame, MavSeverity, OBSTACLE_DISTANCE_DATA};

use super::{Core, ScanInput};
use crate::estimation::Estimate;
use crate::geo::{Ned, wrap_pi};
use crate::guidance::manoeuvre::Manoeuvre;
use crate::guidance::navigator::NavTarget;
use crate::guidance::path::LegPath;
use crate::guidance::reeds_shepp::Stroke;
use crate::guidance::rejoin::{RejoinSpeed, max_curvature};
use crate::guidance::tracker::{Direction, VehiclePose};
use crate::modes::Mode;
use crate::obstacles::cluster::{
    BeamAngles, Cluster, ClusterConfig, ScanPoint, cluster_points, mark_field_edges, scan_points,
};
use crate::obstacles::detour::{DetourConfig, DetourRefusal, plan_detour};
use crate::obstacles::field::{FieldConfig, FieldStatus, Fields, check_swept_fields, fields, warning_speed_limit};
use crate::obstacles::outline::{FitScratch, least_length_of};
use crate::obstacles::policy::{
    ObstaclePolicy, PolicyConfig, PolicyEvent, PolicyInputs, PolicyStatus, StopCause, Verdict,
};
use crate::obstacles::prediction::CollisionPrediction;
use crate::obstacles::swept::{Contact, Drive, PathAhead, Shape, SweepReach, SweptPath};
use crate::obstacles::tracking::{EXPECTED_TRACKS, ObstacleTracker, STILL_S, TrackingConfig};
use crate::obstacles::{Footprint, Pose, ScannerMount, Track, TrackStatus};

/// The fields checked this tick and the warning field's speed limit.
struct CheckedFields {
    field: FieldStatus,
    field_at_resume: FieldStatus,
    warning_limit_mps: Option<f64>,
}

/// How many scanners the core reads (SCAN1 front, SCAN2 rear).
pub const SCANNERS: usize = 2;
/// OBSTACLE_DISTANCE: 72 sectors of 5°.
const SECTORS: usize = 72;
const SECTOR_DEG: f64 = 5.0;
/// A scanner silent this long drops out of the proximity view.
const VIEW_TIMEOUT: Duration = Duration::from_secs(1);
/// How far ahead a detour looks for static obstacles in the lane, m.
const DETOUR_LOOKAHEAD_M: f64 = 15.0;
/// A track slower than this counts as a static obstacle (detour candidate,
/// and its fitted outline is its shape).
const STATIC_SPEED_MPS: f64 = 0.2;
/// How long (s) a track is followed before its filter's velocity counts
/// as settled (see `walking`).
const SETTLED_S: f64 = 1.0;
/// Scans since it last coasted a track with a velocity σ over
/// `OA_TRK_VEL_SD` must have been seen in before its velocity is used
/// (see `velocity_usable`): 0.2 s at 50 Hz.
const SETTLED_HITS: u32 = 10;
/// How far a standing object's tracked centroid can walk per radian its
/// view turns, in extents (see `ViewChange`).
const VIEW_WALK_PER_RAD: f64 = 2.0;
/// Further off its leg than this (or turned further from it), the vehicle
/// is manoeuvring onto it: the path it drives next is the tracker's way
/// back onto the leg (simulated), not the leg.
const ON_PATH_M: f64 = 1.0;
const ON_PATH_RAD: f64 = 0.35;
/// A wait is over once the vehicle drives faster than this (m/s).
const WAIT_OVER_MPS: f64 = 0.1;
/// Below this speed the yaw rate says nothing about the curvature driven.
const CURVATURE_MIN_SPEED_MPS: f64 = 0.2;
/// A track lost from view this near the outline (beyond `OA_MARGIN`) is
/// remembered: it may have walked into the scanners' blind zone beside the
/// body, or against it, where no return is taken for an object.
const HIDDEN_NEAR_M: f64 = 1.0;
/// A remembered track is forgotten this long after it was lost, or once it
/// would have walked (at its last velocity) this much beyond the margin.
const HIDDEN_MAX_S: f64 = 10.0;
const HIDDEN_CLEAR_M: f64 = 0.3;
/// A new track this near a remembered one's predicted place is that object
/// seen again.
const HIDDEN_SEEN_M: f64 = 0.7;
/// How fast a remembered track that had been moving, without a velocity to
/// trust, may have gone anywhere since it was lost (m/s). A slow walker's
/// velocity is spoilt as it enters the blind zone (the last returns are a
/// sliver of its side), and its last place says nothing about where it is
/// a second later: it may be walking on into the body.
const HIDDEN_SPREAD_MPS: f64 = 1.0;
/// A track that leaves view is kept at least as wide as a person of this
/// radius (m): its last returns beside the body are often a sliver of its
/// side (a radius of a few centimetres), and a sliver is passed closer than
/// the person it belongs to (see [`out_of_view_reach_m`]).
const OUT_OF_VIEW_MIN_RADIUS_M: f64 = 0.25;

/// One scanner's latest scan, reduced to what the tick needs.
#[derive(Clone, Debug)]
struct ScannerView {
    t: Option<Duration>,
    /// Returns in the body frame (x forward, y right, from the reference
    /// point): the protective field is checked on these.
    body_points: Vec<(f64, f64)>,
    /// The same returns in the local frame (detour planning).
    local_points: Vec<Ned>,
    /// Whether each return belongs to structure (walls, parked cars: too
    /// big or too straight to track), which only the fields see.
    structure: Vec<bool>,
    /// Which OBSTACLE_DISTANCE sectors the scan's beams cover.
    covered: [bool; SECTORS],
    beam_angles: BeamAngles,
}

impl Default for ScannerView {
    fn default() -> Self {
        ScannerView {
            t: None,
            body_points: Vec::new(),
            local_points: Vec::new(),
            structure: Vec::new(),
            covered: [false; SECTORS],
            beam_angles: BeamAngles::default(),
        }
    }
}

/// What the obstacle pipeline concluded this tick (telemetry, tests).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ObstacleStatus {
    pub enabled: bool,
    /// Every fitted scanner has sent a scan recently.
    pub scans_fresh: bool,
    pub stopped: bool,
    /// Why, while stopped or waiting.
    pub stop_cause: Option<StopCause>,
    /// At rest and not starting yet for a walker's far prediction
    /// (`stop_cause` names it): braked like a stop, but not a held stop.
    pub waiting: bool,
    /// The speed limit the warning field or a followed obstacle imposes.
    pub speed_limit_mps: Option<f64>,
    /// Pass first (OA_PASS): the speed to drive at until the obstacle is
    /// passed.
    pub speed_up_mps: Option<f64>,
    pub confirmed_tracks: usize,
    pub tentative_tracks: usize,
    /// Nearest return to the vehicle's outline, metres.
    pub nearest_m: Option<f64>,
    pub detouring: bool,
}

/// A track lost from view next to the vehicle: where it was, the velocity
/// it was going at (0 unless settled and moving) and when; and, for one
/// that had been moving without a velocity to trust, how fast the place it
/// may be in grows.
#[derive(Clone, Copy, Debug)]
struct HiddenTrack {
    id: u32,
    position: Ned,
    velocity: (f64, f64),
    radius_m: f64,
    lost_s: f64,
    spread_mps: f64,
    /// Its returns had stood still on one outline (`STILL_S`): it is
    /// where it was last seen, and a vehicle driving on is stopped by it
    /// as by a standing track in view.
    standing: bool,
    /// The largest id of the tracks acted on when it was lost: only a track
    /// with a larger one (born since, ids only grow) can be it seen again.
    /// Another object that was already tracked nearby, however near the
    /// place it may have reached, is not it.
    known_ids_to: u32,
}

impl HiddenTrack {
    /// How far from its predicted place it may be by `t_s`, its radius
    /// included.
    fn reach_at(&self, t_s: f64) -> f64 {
        self.radius_m + self.spread_mps * (t_s - self.lost_s).max(0.0)
    }

    fn position_at(&self, t_s: f64) -> Ned {
        let dt = (t_s - self.lost_s).max(0.0);
        Ned::new(
            self.position.north_m + self.velocity.0 * dt,
            self.position.east_m + self.velocity.1 * dt,
        )
    }
}

/// A detour in progress: the waypoints still to drive through, then the
/// leg it interrupted.
#[derive(Clone, Debug)]
struct ActiveDetour {
    waypoints: std::collections::VecDeque<Ned>,
    target: crate::guidance::navigator::NavTarget,
    /// The obstacle being passed (centre, radius of its returns).
    obstacle: (Ned, f64),
}

#[derive(Default)]
pub(super) struct ObstacleState {
    tracker: ObstacleTracker,
    policy: ObstaclePolicy,
    views: [ScannerView; SCANNERS],
    points: Vec<ScanPoint>,
    clusters: Vec<Cluster>,
    fit_scratch: FitScratch,
    /// The outline swept along the path ahead, rebuilt every tick.
    swept: SweptPath,
    /// Last tick's acted-on tracks, to notice which were lost.
    last_tracks: Vec<Track>,
    /// Tracks lost from view next to the body: the vehicle may not start
    /// while one may still be there.
    hidden: Vec<HiddenTrack>,
    /// This tick's collision predictions (at the speed now, at the resume
    /// speed): buffers kept between ticks so a tick allocates nothing.
    predictions: Vec<CollisionPrediction>,
    predictions_at_resume: Vec<CollisionPrediction>,
    status: ObstacleStatus,
    /// Since when the vehicle has been held for a static obstacle (s).
    static_stop_since: Option<f64>,
    detour: Option<ActiveDetour>,
    detour_refusal_reported: bool,
    next_detour_attempt_s: f64,
    /// The simulated rejoin path's poses (a buffer kept between ticks).
    rejoin_poses: Vec<VehiclePose>,
    /// The wait announced (the track waited for, if any), until the vehicle
    /// moves, stops for an obstacle or changes mode.
    wait_announced: Option<Option<u32>>,
}

impl ObstacleState {
    pub fn status(&self) -> &ObstacleStatus {
        &self.status
    }

    pub fn tracks(&self) -> &[Track] {
        self.tracker.tracks()
    }

    pub fn detouring(&self) -> bool {
        self.detour.is_some()
    }
}

impl Core {
    pub(super) fn footprint(&self) -> Footprint {
        let f = &self.p.obstacles.footprint;
        Footprint {
            front_m: f64::from(f.front_m.get(&self.params)),
            rear_m: f64::from(f.rear_m.get(&self.params)),
            half_width_m: f64::from(f.width_m.get(&self.params)) / 2.0,
        }
    }

    fn scanner_mount(&self, index: usize) -> Option<ScannerMount> {
        let s = &self.p.obstacles.scanners;
        let t = &self.params;
        let (fitted, x, y, yaw) = match index {
            0 => (s.scan1_enable, s.scan1_x_m, s.scan1_y_m, s.scan1_yaw_deg),
            1 => (s.scan2_enable, s.scan2_x_m, s.scan2_y_m, s.scan2_yaw_deg),
            _ => return None,
        };
        fitted.get(t).then(|| ScannerMount {
            x_m: f64::from(x.get(t)),
            y_m: f64::from(y.get(t)),
            yaw_rad: f64::from(yaw.get(t)).to_radians(),
        })
    }

    fn tracking_config(&self) -> TrackingConfig {
        let a = &self.p.obstacles.avoidance;
        let t = &self.params;
        TrackingConfig {
            accel_density: f64::from(a.track_accel.get(t)),
            range_sigma_m: f64::from(a.range_sigma_m.get(t)),
            bearing_sigma_rad: f64::from(a.bearing_sigma_deg.get(t)).to_radians(),
            ..TrackingConfig::default()
        }
    }

    fn field_config(&self) -> FieldConfig {
        let a = &self.p.obstacles.avoidance;
        let t = &self.params;
        FieldConfig {
            reaction_s: f64::from(a.reaction_s.get(t)),
            decel_mps2: f64::from(a.decel_mps2.get(t)),
            margin_m: f64::from(a.field_margin_m.get(t)),
            lateral_margin_m: f64::from(a.field_side_m.get(t)),
            warning_time_s: f64::from(a.warning_s.get(t)),
            ..FieldConfig::default()
        }
    }

    fn policy_config(&self) -> PolicyConfig {
        let a = &self.p.obstacles.avoidance;
        let t = &self.params;
        PolicyConfig {
            resume_s: f64::from(a.resume_s.get(t)),
            auto_resume: a.auto_resume.get(t),
            pass_first: a.pass_first.get(t),
            max_speed_mps: f64::from(a.pass_speed_mps.get(t)),
            accel_mps2: f64::from(self.p.nav.accel_max_mps2.get(t)).max(0.1),
            safe_distance_m: f64::from(a.margin_m.get(t)),
            stop_horizon_s: f64::from(a.horizon_s.get(t)),
            scan_timeout_s: f64::from(a.scan_timeout_s.get(t)),
            stop_cycles: u32::try_from(a.stop_cycles.get(t)).unwrap_or(0),
            reaction_s: f64::from(a.reaction_s.get(t)),
            decel_mps2: f64::from(a.decel_mps2.get(t)),
        }
    }

    /// Fitted scanners (0 = SCAN1) with no scan within the view timeout,
    /// when obstacle stopping is on.
    /// An iterator, not a Vec: the scanner failsafe asks every tick.
    pub(super) fn stale_scanners(&self) -> impl Iterator<Item = usize> + '_ {
        let enabled = self.obstacles_enabled();
        (0..SCANNERS)
            .filter(move |&i| enabled && self.scanner_mount(i).is_some())
            .filter(|&i| {
                self.obstacles.views[i]
                    .t
                    .is_none_or(|t| self.now.boot.saturating_sub(t) > VIEW_TIMEOUT)
            })
    }

    fn obstacles_enabled(&self) -> bool {
        self.p.obstacles.avoidance.enable.get(&self.params)
    }

    /// Each new scan: points in the body and local frames, clusters, tracks.
    pub(super) fn read_scans(&mut self, scans: &[ScanInput]) {
        if scans.is_empty() {
            return;
        }
        let estimate = *self.estimator.estimate();
        let located = estimate.position_valid && estimate.heading_valid;
        let max_range = f64::from(self.p.obstacles.scanners.max_range_m.get(&self.params));
        let tracking = self.tracking_config();
        let cluster_config = ClusterConfig::default();
        for input in scans {
            let Some(mount) = self.scanner_mount(input.scanner) else {
                continue;
            };
            // The pose when the scan was taken: the estimate moved back by
            // the scan's age (a tick at most).
            let age_s = self.now.boot.saturating_sub(input.scan.t).as_secs_f64();
            let back_m = estimate.speed_mps * age_s;
            let pose = Pose {
                position: Ned::new(
                    estimate.position.north_m - back_m * estimate.yaw_rad.cos(),
                    estimate.position.east_m - back_m * estimate.yaw_rad.sin(),
                ),
                yaw_rad: estimate.yaw_rad,
            };
            let obs = &mut self.obstacles;
            let view = &mut obs.views[input.scanner];
            let sensor = scan_points(
                &input.scan,
                &pose,
                &mount,
                max_range,
                &mut view.beam_angles,
                &mut obs.points,
            );
            view.t = Some(input.scan.t);
            view.body_points.clear();
            view.local_points.clear();
            view.structure.clear();
            view.structure.resize(obs.points.len(), false);
            // Room for every beam: the buffers never grow as more echo.
            view.body_points.reserve(input.scan.ranges_m.len());
            view.local_points.reserve(input.scan.ranges_m.len());
            for p in &obs.points {
                view.body_points.push((p.body_x_m, p.body_y_m));
                view.local_points.push(p.position);
            }
            view.covered = covered_sectors(&input.scan, mount.yaw_rad);
            if located {
                cluster_points(&obs.points, &cluster_config, &mut obs.fit_scratch, &mut obs.clusters);
                mark_field_edges(&mut obs.clusters, &obs.points, input.scan.ranges_m.len());
                mark_structure(&obs.clusters, &mut view.structure);
                obs.tracker.update(input.scan.t, sensor, &obs.clusters, &tracking);
            }
        }
    }

    /// Whether a self-driving mode may drive this tick: `Go`, `Slow` or
    /// `Stop`, with the stop/resume announcements. `wants_to_move`: the mode
    /// has somewhere to go; `settling`: it wants no speed but is still
    /// settling onto a stop point; `direction`: the way it would drive;
    /// `planned_mps`: the speed it would drive at; `stop_within_m`: how far
    /// it drives at most before it rests on a stop point.
    pub(super) fn obstacle_verdict(
        &mut self,
        active: bool,
        wants_to_move: bool,
        settling: bool,
        direction: Direction,
        (planned_mps, stop_within_m): (f64, Option<f64>),
    ) -> Verdict {
        let now_s = self.now.boot.as_secs_f64();
        let footprint = self.footprint();
        let estimate = *self.estimator.estimate();
        let (enabled, scan_age_s) = self.refresh_obstacle_status(&footprint);
        if !enabled || !active {
            self.reset_obstacle_policy();
            return Verdict::Go;
        }
        let speed = if estimate.position_valid && estimate.heading_valid {
            estimate.speed_mps
        } else {
            0.0
        };
        let pose = Pose {
            position: estimate.position,
            yaw_rad: estimate.yaw_rad,
        };
        let checked = self.sweep_and_check_fields(&pose, &footprint, direction, speed, (planned_mps, stop_within_m));
        let (predictions, predictions_at_resume) =
            self.predict_collisions(now_s, (&estimate, &pose), &footprint, (speed, planned_mps));
        let config = self.policy_config();
        let inputs = PolicyInputs {
            t_s: now_s,
            wants_to_move,
            settling,
            speed_mps: speed,
            scan_age_s,
            field: &checked.field,
            field_at_resume: &checked.field_at_resume,
            predictions: &predictions,
            predictions_at_resume: &predictions_at_resume,
            tracks: self.obstacles.tracker.tracks(),
            pose,
            footprint: &footprint,
            warning_limit_mps: checked.warning_limit_mps,
        };
        let status = self.obstacles.policy.update(&inputs, &config);
        self.obstacles.predictions = predictions;
        self.obstacles.predictions_at_resume = predictions_at_resume;
        let verdict = self.apply_policy_status(&status);
        self.announce_wait(&verdict, speed);
        self.note_static_block(&verdict, wants_to_move, now_s);
        verdict
    }
    /// Sweeps the path ahead and checks the protective and warning fields
    /// (at the speed now and at the resume speed) along it. The sweep ends
    /// at a stop point the vehicle will rest on first (`stop_within_m`):
    /// the leg's own sweep ends there, and one off the leg (the way back
    /// onto it, or the curvature driven at a stop leg's end) must not
    /// reach past it either.
    fn sweep_and_check_fields(
        &mut self,
        pose: &Pose,
        footprint: &Footprint,
        direction: Direction,
        speed: f64,
        (planned_mps, stop_within_m): (f64, Option<f64>),
    ) -> CheckedFields {
        let sign = direction.sign();
        let field_config = self.field_config();
        // Standing still, the field looks the way the vehicle would drive.
        let here_fields = fields(
            if speed.abs() > 0.05 { speed } else { 1e-3 * sign },
            footprint,
            &field_config,
        );
        let resume_fields = fields(planned_mps.abs() * sign, footprint, &field_config);
        let horizon = f64::from(self.p.obstacles.avoidance.horizon_s.get(&self.params));
        let sweep_m = here_fields
            .warning_length_m
            .max(resume_fields.warning_length_m)
            .max(speed.abs().max(planned_mps.abs()) * horizon)
            .min(stop_within_m.map_or(f64::INFINITY, f64::abs));
        self.sweep_path_ahead(pose, footprint, sign < 0.0, sweep_m, (speed, planned_mps));
        let [field, field_at_resume] = self.check_fields(&here_fields, &resume_fields, &field_config);
        // At rest the fields that matter are those it would start with.
        let warning_limit_mps = if speed.abs() <= 0.05 {
            warning_speed_limit(&resume_fields, &field_at_resume, &field_config, planned_mps.abs())
        } else {
            warning_speed_limit(&here_fields, &field, &field_config, planned_mps.abs())
        };
        CheckedFields {
            field,
            field_at_resume,
            warning_limit_mps,
        }
    }

    /// The tracks' collision predictions at the speed now and at the resume
    /// speed, the latter with the tracks remembered in the blind zone (the
    /// buffers are the state's, handed back after the policy has read them).
    fn predict_collisions(
        &mut self,
        now_s: f64,
        (estimate, pose): (&Estimate, &Pose),
        footprint: &Footprint,
        (speed, planned_mps): (f64, f64),
    ) -> (Vec<CollisionPrediction>, Vec<CollisionPrediction>) {
        let a = &self.p.obstacles.avoidance;
        let margin = f64::from(a.margin_m.get(&self.params));
        // The policy acts on nothing predicted beyond OA_HORIZON.
        let horizon = f64::from(a.horizon_s.get(&self.params));
        let velocity_gate_mps = f64::from(a.velocity_gate_mps.get(&self.params));
        let mut predictions = std::mem::take(&mut self.obstacles.predictions);
        let mut predictions_at_resume = std::mem::take(&mut self.obstacles.predictions_at_resume);
        self.track_predictions(
            (estimate, pose),
            (speed, planned_mps),
            (margin, horizon),
            (&mut predictions, &mut predictions_at_resume),
        );
        self.remember_hidden_tracks(now_s, pose, footprint, margin, velocity_gate_mps);
        self.push_hidden_predictions(now_s, pose, footprint, &mut predictions_at_resume);
        self.push_hidden_standing_contacts(speed, (margin, horizon), &mut predictions);
        (predictions, predictions_at_resume)
    }

    /// Avoidance off or not driving: forget any held stop, static block and
    /// remembered tracks.
    fn reset_obstacle_policy(&mut self) {
        self.obstacles.policy.reset();
        self.obstacles.static_stop_since = None;
        self.obstacles.hidden.clear();
        self.obstacles.wait_announced = None;
        self.obstacles.last_tracks.clear();
    }

    /// The protective and warning fields (at the speed now and at the
    /// resume speed) checked against the fresh scans' points.
    fn check_fields(
        &self,
        here_fields: &Fields,
        resume_fields: &Fields,
        field_config: &FieldConfig,
    ) -> [FieldStatus; 2] {
        let fresh_after = VIEW_TIMEOUT;
        let side_m = field_config.lateral_margin_m;
        // Structure is never tracked, so no prediction keeps OA_MARGIN from
        // it: the fields do, for its returns (a parked car at the margin
        // beside the lane is in the way).
        let structure_side_m = side_m.max(f64::from(self.p.obstacles.avoidance.margin_m.get(&self.params)));
        let fresh_points = self
            .obstacles
            .views
            .iter()
            .filter(|v| v.t.is_some_and(|t| self.now.boot.saturating_sub(t) <= fresh_after))
            .flat_map(|v| {
                v.local_points.iter().enumerate().map(move |(i, p)| {
                    let structure = v.structure.get(i).copied().unwrap_or(false);
                    (*p, if structure { structure_side_m } else { side_m })
                })
            });
        check_swept_fields([here_fields, resume_fields], &self.obstacles.swept, fresh_points)
    }

    /// Announces the policy's events and reports its state; its verdict.
    fn apply_policy_status(&mut self, status: &PolicyStatus) -> Verdict {
        for event in &status.events {
            self.report_obstacle_event(event);
        }
        let verdict = status.verdict;
        self.obstacles.status.stopped = status.stopped;
        self.obstacles.status.stop_cause = match verdict {
            Verdict::Stop(cause) | Verdict::Wait(cause) => Some(cause),
            _ => None,
        };
        self.obstacles.status.waiting = matches!(verdict, Verdict::Wait(_));
        self.obstacles.status.speed_limit_mps = match verdict {
            Verdict::Slow { limit_mps } => Some(limit_mps),
            _ => None,
        };
        self.obstacles.status.speed_up_mps = match verdict {
            Verdict::SpeedUp { target_mps } => Some(target_mps),
            _ => None,
        };
        verdict
    }

    /// Rebuilds the reported obstacle status for this tick (not yet the
    /// policy's part of it); returns whether avoidance is on (enabled and a
    /// scanner fitted) and the age of the stalest fitted scanner's scan, s.
    fn refresh_obstacle_status(&mut self, footprint: &Footprint) -> (bool, Option<f64>) {
        let fresh_after = VIEW_TIMEOUT;
        let mut scan_age_s: Option<f64> = None;
        let mut fitted = 0;
        for i in 0..SCANNERS {
            if self.scanner_mount(i).is_none() {
                continue;
            }
            fitted += 1;
            // The policy cares about the stalest fitted scanner.
            let age = self.obstacles.views[i]
                .t
                .map(|t| self.now.boot.saturating_sub(t).as_secs_f64());
            scan_age_s = match (fitted, scan_age_s, age) {
                (1, _, a) => a,
                (_, Some(worst), Some(a)) => Some(worst.max(a)),
                _ => None,
            };
        }
        let enabled = self.obstacles_enabled() && fitted > 0;
        let scans_fresh = scan_age_s.is_some_and(|a| a <= fresh_after.as_secs_f64());
        let confirmed = self
            .obstacles
            .tracker
            .tracks()
            .iter()
            .filter(|t| t.status != TrackStatus::Tentative)
            .count();
        let tentative = self.obstacles.tracker.tracks().len() - confirmed;
        let nearest_m = self.nearest_return_m(footprint);
        self.obstacles.status = ObstacleStatus {
            enabled,
            scans_fresh,
            stopped: false,
            stop_cause: None,
            waiting: false,
            speed_limit_mps: None,
            speed_up_mps: None,
            confirmed_tracks: confirmed,
            tentative_tracks: tentative,
            nearest_m,
            detouring: self.obstacles.detour.is_some(),
        };
        (enabled, scan_age_s)
    }

    /// The collision predictions of the tracked obstacles against the path
    /// ahead, into `predictions` (cleared first): at the vehicle's speed now
    /// (`speed`) and at the speed it would resume at (`planned_mps`). None
    /// without a valid position and heading.
    fn track_predictions(
        &self,
        (estimate, pose): (&Estimate, &Pose),
        (speed, planned_mps): (f64, f64),
        (margin, horizon): (f64, f64),
        (predictions, predictions_at_resume): (&mut Vec<CollisionPrediction>, &mut Vec<CollisionPrediction>),
    ) {
        predictions.clear();
        predictions_at_resume.clear();
        // Sized once for a full scene: a second object in view must not grow them mid-drive.
        predictions.reserve(EXPECTED_TRACKS);
        predictions_at_resume.reserve(EXPECTED_TRACKS);
        let passing = self.obstacles.detour.as_ref().map(|d| d.obstacle);
        let velocity_gate_mps = f64::from(self.p.obstacles.avoidance.velocity_gate_mps.get(&self.params));
        let accel_mps2 = self.policy_config().accel_mps2;
        if estimate.position_valid && estimate.heading_valid {
            let vehicle_velocity = (speed * estimate.yaw_rad.cos(), speed * estimate.yaw_rad.sin());
            let view = ViewChange::new(
                pose,
                vehicle_velocity,
                estimate.yaw_rate_rad_s,
                (0..SCANNERS).filter_map(|i| self.scanner_mount(i)),
            );
            for track in self.obstacles.tracker.tracks() {
                // Coasting tracks count only for starting (the policy
                // ignores their predictions otherwise).
                if track.status == TrackStatus::Tentative {
                    continue;
                }
                // On a detour the obstacle being passed is beside the path
                // by design; the field still guards against it.
                if let Some((centre, radius_m)) = passing
                    && track.position.distance_to(&centre) <= radius_m + 1.0
                {
                    continue;
                }
                // A velocity not yet settled (a track a few scans old, or one
                // that has just started moving) says little: until it does,
                // the obstacle is predicted as standing still.
                // A static object's velocity is the filter's noise: a few
                // cm/s towards the lane over the horizon would bring a box
                // beside it into the vehicle's way.
                // Nor is a speed the vehicle's own motion can give a
                // standing object's centroid, by changing the view of it.
                let walking = velocity_usable(track, velocity_gate_mps) && walking(track, &view);
                let velocity = if walking {
                    (track.vel_north_mps, track.vel_east_mps)
                } else {
                    (0.0, 0.0)
                };
                let shape = track_shape(track, walking);
                let swept = &self.obstacles.swept;
                let relative_speed_mps = (velocity.0 - vehicle_velocity.0).hypot(velocity.1 - vehicle_velocity.1);
                let to_prediction = |c: Contact| CollisionPrediction {
                    track_id: track.id,
                    time_s: c.time_s,
                    place: c.place,
                    distance_m: c.gap_now_m,
                    relative_speed_mps,
                    obstacle_speed_mps: velocity.0.hypot(velocity.1),
                    closing: c.closing,
                };
                if let Some(c) = swept.first_contact(&shape, velocity, speed, margin, horizon) {
                    predictions.push(to_prediction(c));
                }
                // Resuming, it gets up to the planned speed from the speed
                // it has, and is slower than that for the first seconds.
                let resume = Drive {
                    from_mps: speed.abs(),
                    speed_mps: planned_mps.abs(),
                    accel_mps2,
                };
                if let Some(c) = swept.first_contact_driving(&shape, velocity, &resume, margin, horizon) {
                    predictions_at_resume.push(to_prediction(c));
                }
            }
        }
    }

    /// The remembered hidden tracks as predictions for starting: each one
    /// closing, at its distance from the outline now.
    fn push_hidden_predictions(
        &self,
        now_s: f64,
        pose: &Pose,
        footprint: &Footprint,
        predictions_at_resume: &mut Vec<CollisionPrediction>,
    ) {
        for hidden in &self.obstacles.hidden {
            let at = hidden.position_at(now_s);
            let (x, y) = crate::obstacles::prediction::to_body(
                pose.yaw_rad,
                at.north_m - pose.position.north_m,
                at.east_m - pose.position.east_m,
            );
            let distance_m = outline_distance(footprint, x, y) - hidden.reach_at(now_s);
            predictions_at_resume.push(CollisionPrediction {
                track_id: hidden.id,
                time_s: 0.0,
                place: pose.position,
                distance_m: distance_m.max(0.0),
                relative_speed_mps: hidden.velocity.0.hypot(hidden.velocity.1),
                obstacle_speed_mps: hidden.velocity.0.hypot(hidden.velocity.1),
                closing: true,
            });
        }
    }

    /// The remembered tracks that stood still, as a moving vehicle's
    /// predictions: the inner side of an arc or the swing of the body
    /// sweeps into someone standing in the blind zone beside it (or behind
    /// another person), whose track the tracker has dropped; without this
    /// only the protective field, a few centimetres off, stopped it.
    fn push_hidden_standing_contacts(
        &self,
        speed: f64,
        (margin, horizon): (f64, f64),
        predictions: &mut Vec<CollisionPrediction>,
    ) {
        for hidden in self.obstacles.hidden.iter().filter(|h| h.standing) {
            let shape = Shape::Disc {
                centre: hidden.position,
                radius_m: hidden.radius_m,
            };
            if let Some(c) = self
                .obstacles
                .swept
                .first_contact(&shape, (0.0, 0.0), speed, margin, horizon)
            {
                predictions.push(CollisionPrediction {
                    track_id: hidden.id,
                    time_s: c.time_s,
                    place: c.place,
                    distance_m: c.gap_now_m,
                    relative_speed_mps: speed.abs(),
                    obstacle_speed_mps: 0.0,
                    closing: c.closing,
                });
            }
        }
    }

    /// A static obstacle that keeps the vehicle stopped: plan round it
    /// (notes since when it has blocked the way).
    fn note_static_block(&mut self, verdict: &Verdict, wants_to_move: bool, now_s: f64) {
        let static_block = match verdict {
            Verdict::Stop(StopCause::Collision { track_id, .. }) => self
                .obstacles
                .tracker
                .tracks()
                .iter()
                .find(|t| t.id == *track_id)
                .is_some_and(|t| t.speed_mps() < STATIC_SPEED_MPS),
            Verdict::Stop(StopCause::ProtectiveField { .. }) => true,
            _ => false,
        };
        self.obstacles.static_stop_since = if static_block && wants_to_move {
            self.obstacles.static_stop_since.or(Some(now_s))
        } else {
            None
        };
    }

    /// Remembers the tracks lost from view within `HIDDEN_NEAR_M` of the
    /// outline and forgets those that have walked clear, been seen again or
    /// been gone `HIDDEN_MAX_S`.
    fn remember_hidden_tracks(&mut self, now_s: f64, pose: &Pose, footprint: &Footprint, margin_m: f64, gate_mps: f64) {
        let obs = &mut self.obstacles;
        if obs.hidden.capacity() == 0 {
            // Sized once: the first person lost beside the body mid-drive must not allocate.
            obs.hidden.reserve(EXPECTED_TRACKS);
        }
        let tracks = obs.tracker.tracks();
        let gap_m = |at: Ned, radius_m: f64| {
            let (x, y) = crate::obstacles::prediction::to_body(
                pose.yaw_rad,
                at.north_m - pose.position.north_m,
                at.east_m - pose.position.east_m,
            );
            outline_distance(footprint, x, y) - radius_m
        };
        let known_ids_to = obs.last_tracks.iter().map(|t| t.id).max().unwrap_or(0);
        for lost in obs.last_tracks.iter().filter(|l| tracks.iter().all(|t| t.id != l.id)) {
            let radius_m = out_of_view_reach_m(lost.radius_m);
            if gap_m(lost.position, radius_m) <= margin_m + HIDDEN_NEAR_M {
                let walking = lost.velocity_sigma_mps <= gate_mps && moving(lost);
                // Its returns were leaving their outline: it was moving, at
                // a velocity not good enough to follow.
                let wandering = !walking && lost.still_s < STILL_S;
                let standing = !walking && !wandering;
                // A standing object is where it was last seen: the
                // filter's coasting moved the track by its velocity noise.
                let position = if standing {
                    Ned::new(
                        lost.position.north_m - lost.vel_north_mps * lost.unseen_s,
                        lost.position.east_m - lost.vel_east_mps * lost.unseen_s,
                    )
                } else {
                    lost.position
                };
                obs.hidden.push(HiddenTrack {
                    id: lost.id,
                    position,
                    velocity: if walking {
                        (lost.vel_north_mps, lost.vel_east_mps)
                    } else {
                        (0.0, 0.0)
                    },
                    radius_m,
                    lost_s: now_s,
                    spread_mps: if wandering { HIDDEN_SPREAD_MPS } else { 0.0 },
                    standing,
                    known_ids_to,
                });
            }
        }
        obs.hidden.retain(|h| {
            let at = h.position_at(now_s);
            let spread_m = h.reach_at(now_s) - h.radius_m;
            let seen_again = tracks.iter().any(|t| {
                t.status != TrackStatus::Tentative
                    && t.id > h.known_ids_to
                    && t.position.distance_to(&at) <= HIDDEN_SEEN_M + spread_m
            });
            // One that may be anywhere nearby has not walked clear until
            // seen (or the vehicle has left it behind).
            let clear_m = if h.spread_mps > 0.0 {
                HIDDEN_NEAR_M
            } else {
                HIDDEN_CLEAR_M
            };
            now_s - h.lost_s <= HIDDEN_MAX_S && !seen_again && gap_m(at, h.reach_at(now_s)) <= margin_m + clear_m
        });
        obs.last_tracks.clear();
        obs.last_tracks
            .extend(tracks.iter().filter(|t| t.status != TrackStatus::Tentative).copied());
    }

    /// Samples the path the vehicle is about to drive: its turn on the spot,
    /// the navigator's leg from where the vehicle is on it, the tracker's way
    /// back onto the leg when it is far from it (after a stop in a corner,
    /// turning onto a new leg), or, without a leg (MAGNETIC, MANUAL), the
    /// curvature it is turning at now. `speeds`: the speed now and the
    /// speed it would drive at, m/s.
    fn sweep_path_ahead(
        &mut self,
        pose: &Pose,
        footprint: &Footprint,
        reverse: bool,
        length_m: f64,
        speeds: (f64, f64),
    ) {
        let nav_config = self.nav_config();
        let pivot = self.navigator.pivot_target().filter(|_| self.mode != Mode::Magnetic);
        let target = self.navigator.target().copied();
        let leg = (self.mode != Mode::Magnetic)
            .then(|| self.navigator.path_ahead(pose.position, &nav_config).zip(target))
            .flatten();
        let off_leg = leg.is_some_and(|((path, along_m), target)| !on_leg(pose, path, along_m, &target));
        if pivot.is_none() && off_leg && self.sweep_rejoin(pose, footprint, length_m, speeds) {
            return;
        }
        let estimate = self.estimator.estimate();
        let frame = self.estimator.frame();
        let fleet = self.fleet.as_deref_mut();
        let leg = (self.mode != Mode::Magnetic)
            .then(|| self.navigator.path_ahead(pose.position, &nav_config).zip(target))
            .flatten()
            .filter(|((path, along_m), target)| on_leg(pose, path, *along_m, target))
            // Along a fleet order's trajectory: on over the chords after this one.
            .map(
                |((path, along_m), target)| match fleet.and_then(|f| f.trajectory_ahead(path, frame)) {
                    Some((whole, stop)) => (whole, along_m, stop, target),
                    None => (path, along_m, target.stop, target),
                },
            );
        let ahead = match (pivot, leg) {
            // Turning on the spot: the outline swept round to the heading.
            (Some(to_yaw_rad), _) => PathAhead::Pivot { to_yaw_rad },
            (None, Some((path, along_m, stop, target))) => PathAhead::Leg {
                path,
                along_m,
                stop_at_m: stop.then(|| path.end_m()),
                reverse: target.direction == Direction::Reverse,
            },
            (None, None) => {
                // Turning rate over speed; too slow to tell, straight on.
                let curvature = if estimate.speed_mps.abs() > CURVATURE_MIN_SPEED_MPS {
                    estimate.yaw_rate_rad_s / estimate.speed_mps.abs()
                } else {
                    0.0
                };
                PathAhead::Curvature { curvature, reverse }
            }
        };
        self.obstacles.swept.build(&ahead, pose, footprint, length_m);
    }

    /// Sweeps the path the tracker drives from `pose` back onto the leg
    /// (`guidance::rejoin`): from the speed now towards the speed it would
    /// drive at, at `ATC_ACCEL_MAX`. False (nothing swept) without a leg's
    /// path or a pose beyond the vehicle's own. With no return and no track
    /// within the path's reach the path is left empty instead of simulated
    /// (obstacles::swept §Skipping a sweep): every query finds nothing on
    /// it, as on the built one; a first step of the simulation still tells
    /// whether there would be a pose beyond the vehicle's own.
    fn sweep_rejoin(
        &mut self,
        pose: &Pose,
        footprint: &Footprint,
        length_m: f64,
        (speed, planned_mps): (f64, f64),
    ) -> bool {
        let nav_config = self.nav_config();
        let curvature_max = max_curvature(&nav_config.tracker);
        let ds_m = SweptPath::pose_spacing_m(footprint, curvature_max, length_m);
        let rejoin_speed = RejoinSpeed {
            from_mps: speed.abs(),
            to_mps: planned_mps.abs(),
            accel_mps2: self.policy_config().accel_mps2,
        };
        let start = VehiclePose {
            position: pose.position,
            yaw_rad: pose.yaw_rad,
        };
        let mut poses = std::mem::take(&mut self.obstacles.rejoin_poses);
        poses.clear();
        let reach = SweepReach::of_poses(pose.position, ds_m, curvature_max, footprint, length_m);
        // One step (none for a path of no length, as the whole would take).
        let first_step_m = if length_m > ds_m { ds_m } else { length_m };
        if !self.scene_within(&reach)
            && self
                .navigator
                .rejoin_path(start, rejoin_speed, &nav_config, (ds_m, first_step_m), &mut poses)
            && poses.len() > 1
        {
            self.obstacles.swept.clear();
            self.obstacles.rejoin_poses = poses;
            return true;
        }
        poses.clear();
        let built = self
            .navigator
            .rejoin_path(start, rejoin_speed, &nav_config, (ds_m, length_m), &mut poses)
            && poses.len() > 1;
        if built {
            let as_poses = poses.iter().map(|p| Pose {
                position: p.position,
                yaw_rad: p.yaw_rad,
            });
            self.obstacles
                .swept
                .build_from_poses(as_poses, ds_m, curvature_max, footprint);
        }
        self.obstacles.rejoin_poses = poses;
        built
    }

    /// Whether any scan return (fresh or not, at the larger of the fields'
    /// side margins) or any track (tentative or not, as a disc and as its
    /// outline, at its filter's speed) could be met on a path within
    /// `reach`, with the margins and horizon the fields and the collision
    /// predictions use, or any standing person remembered out of view (a
    /// moving vehicle still stops for them on the swept path).
    fn scene_within(&self, reach: &SweepReach) -> bool {
        let a = &self.p.obstacles.avoidance;
        let margin_m = f64::from(a.margin_m.get(&self.params));
        let horizon_s = f64::from(a.horizon_s.get(&self.params));
        let point_margin_m = self.field_config().lateral_margin_m.max(margin_m);
        let obs = &self.obstacles;
        let mut points = obs.views.iter().flat_map(|v| v.local_points.iter());
        if points.any(|p| reach.may_meet_point(*p, point_margin_m)) {
            return true;
        }
        let hidden_standing = obs.hidden.iter().filter(|h| h.standing).any(|h| {
            let shape = Shape::Disc {
                centre: h.position,
                radius_m: h.radius_m,
            };
            reach.may_meet_shape(&shape, 0.0, margin_m, horizon_s)
        });
        hidden_standing
            || obs.tracker.tracks().iter().any(|track| {
                [track_shape(track, true), track_shape(track, false)]
                    .iter()
                    .any(|shape| reach.may_meet_shape(shape, track.speed_mps(), margin_m, horizon_s))
            })
    }

    /// One STATUSTEXT per wait at rest (the verdict is decided again every
    /// tick, and may flicker while the walker passes): a new one only after
    /// the vehicle has moved or stopped for an obstacle since, or for
    /// another object.
    fn announce_wait(&mut self, verdict: &Verdict, speed_mps: f64) {
        match verdict {
            Verdict::Wait(cause) => {
                let object = match cause {
                    StopCause::Collision { track_id, .. } => Some(*track_id),
                    _ => None,
                };
                if self.obstacles.wait_announced != Some(object) {
                    self.obstacles.wait_announced = Some(object);
                    let text = match object {
                        Some(id) => format!("Obstacle #{id}: waiting for it to pass"),
                        None => format!("Obstacle: waiting ({cause})"),
                    };
                    self.send_text(MavSeverity::MAV_SEVERITY_INFO, &text);
                }
            }
            Verdict::Stop(_) => self.obstacles.wait_announced = None,
            _ if speed_mps.abs() > WAIT_OVER_MPS => self.obstacles.wait_announced = None,
            _ => {}
        }
    }

    fn report_obstacle_event(&mut self, event: &PolicyEvent) {
        match event {
            PolicyEvent::Stopped(cause) => {
                self.send_text(MavSeverity::MAV_SEVERITY_WARNING, &format!("Obstacle stop: {cause}"));
            }
            PolicyEvent::Resumed { stopped_s } => {
                self.send_text(
                    MavSeverity::MAV_SEVERITY_INFO,
                    &format!("Obstacle clear: resuming after {stopped_s:.1} s"),
                );
            }
            PolicyEvent::WaitingForOperator(cause) => {
                self.send_text(
                    MavSeverity::MAV_SEVERITY_NOTICE,
                    &format!("Obstacle clear ({cause}): waiting for GCS continue"),
                );
            }
            PolicyEvent::PassingFirst { track_id } => {
                self.send_text(
                    MavSeverity::MAV_SEVERITY_INFO,
                    &format!("Obstacle #{track_id}: passing first"),
                );
            }
            PolicyEvent::Slowing => {}
            PolicyEvent::StopGo { cycles, cause } => {
                let detour = self.p.obstacles.avoidance.kind.get(&self.params) == 1;
                let what = if detour {
                    // Plan round it now rather than after OA_DETOUR_WAIT.
                    self.obstacles.static_stop_since = Some(f64::NEG_INFINITY);
                    "planning a detour"
                } else {
                    "waiting for clear way"
                };
                let object = match cause {
                    StopCause::Collision { track_id, .. } => format!("#{track_id}"),
                    _ => "in path".to_string(),
                };
                self.send_text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    &format!("Obstacle {object} stop/go x{cycles}: {what}"),
                );
            }
        }
    }

    /// Whether the outline driven along `manoeuvre`'s strokes (planned
    /// with turning radius `radius_m`) keeps `OA_MARGIN` from all that
    /// stands: tracks that do not move, standing people remembered out of
    /// view, returns of structure. A retry from rest has two ways of one
    /// length (out forwards and back, or back and forwards), and the one
    /// the planner came to first could run into someone standing beside
    /// the goal, who held it there (bench seeds 563, 1943). True with
    /// avoidance off.
    pub(super) fn manoeuvre_clear(&self, manoeuvre: &Manoeuvre, radius_m: f64) -> bool {
        if !self.obstacles_enabled() {
            return true;
        }
        let footprint = self.footprint();
        let margin_m = f64::from(self.p.obstacles.avoidance.margin_m.get(&self.params));
        let curvature_max = if radius_m > 0.0 { 1.0 / radius_m } else { 0.0 };
        let mut swept = SweptPath::default();
        manoeuvre.strokes.iter().all(|stroke| {
            let ds_m = SweptPath::pose_spacing_m(&footprint, curvature_max, stroke.length_m());
            swept.build_from_poses(stroke_poses(stroke, ds_m), ds_m, curvature_max, &footprint);
            !self.standing_on(&swept, margin_m)
        })
    }

    /// Whether anything standing comes within `margin_m` of `swept`.
    fn standing_on(&self, swept: &SweptPath, margin_m: f64) -> bool {
        let obs = &self.obstacles;
        // Driven to its end: a standing shape is met, if at all, by then.
        let meets = |shape: &Shape| {
            swept
                .first_contact(shape, (0.0, 0.0), 1.0, margin_m, f64::INFINITY)
                .is_some()
        };
        let track = obs
            .tracker
            .tracks()
            .iter()
            .filter(|t| t.status != TrackStatus::Tentative && !moving(t))
            .any(|t| meets(&track_shape(t, false)));
        let hidden = obs.hidden.iter().filter(|h| h.standing).any(|h| {
            meets(&Shape::Disc {
                centre: h.position,
                radius_m: h.radius_m,
            })
        });
        let structure = obs.views.iter().any(|v| {
            (v.local_points.iter().zip(&v.structure))
                .any(|(p, is_structure)| *is_structure && swept.point_entry_m(*p, margin_m, f64::INFINITY).is_some())
        });
        track || hidden || structure
    }

    /// The deliberate resume after an obstacle stop held for the GCS
    /// (MAV_CMD_DO_PAUSE_CONTINUE with param1 = 1).
    pub(super) fn obstacle_continue(&mut self) -> bool {
        let released = self.obstacles.policy.operator_resume(self.now.boot.as_secs_f64());
        if released {
            self.send_text(MavSeverity::MAV_SEVERITY_INFO, "Obstacle stop released by GCS");
        }
        released
    }

    /// A mode change is a deliberate act: it clears any obstacle stop and
    /// abandons a detour.
    pub(super) fn obstacles_mode_changed(&mut self) {
        self.obstacles.policy.reset();
        self.obstacles.wait_announced = None;
        self.obstacles.detour = None;
        self.obstacles.static_stop_since = None;
    }

    /// Distance from the outline to the nearest fresh return (one square
    /// root for the nearest, not one per return: `least_length_of`).
    fn nearest_return_m(&self, footprint: &Footprint) -> Option<f64> {
        let gaps = self
            .obstacles
            .views
            .iter()
            .filter(|v| v.t.is_some_and(|t| self.now.boot.saturating_sub(t) <= VIEW_TIMEOUT))
            .flat_map(|v| v.body_points.iter())
            .map(|&(x, y)| outline_gap(footprint, x, y));
        gaps.clone().next()?;
        Some(least_length_of(gaps))
    }

    /// OBSTACLE_DISTANCE in the body frame: 72 sectors of 5° from the centre
    /// of the outline, clockwise from ahead; sectors no scanner sees are
    /// "unknown", seen but empty ones "beyond range".
    pub(super) fn obstacle_distance(&self) -> Option<OBSTACLE_DISTANCE_DATA> {
        // An iterator, not a Vec: OBSTACLE_DISTANCE goes out every few ticks.
        let views = || {
            self.obstacles
                .views
                .iter()
                .filter(|v| v.t.is_some_and(|t| self.now.boot.saturating_sub(t) <= VIEW_TIMEOUT))
        };
        views().next()?;
        let footprint = self.footprint();
        let max_range_m = f64::from(self.p.obstacles.scanners.max_range_m.get(&self.params));
        let max_cm = (max_range_m * 100.0).round().min(f64::from(u16::MAX - 2)) as u16;
        let centre_x = (footprint.front_m - footprint.rear_m) / 2.0;
        let mut distances = [u16::MAX; SECTORS];
        for view in views() {
            for (i, covered) in view.covered.iter().enumerate() {
                if *covered && distances[i] == u16::MAX {
                    distances[i] = max_cm + 1;
                }
            }
        }
        for view in views() {
            for &(x, y) in &view.body_points {
                let (dx, dy) = (x - centre_x, y);
                let sector = sector_of(dy.atan2(dx).to_degrees());
                let cm = (dx.hypot(dy) * 100.0).round().clamp(0.0, f64::from(max_cm)) as u16;
                if distances[sector] > max_cm || cm < distances[sector] {
                    distances[sector] = cm;
                }
            }
        }
        Some(OBSTACLE_DISTANCE_DATA {
            time_usec: self.now.boot.as_micros() as u64,
            distances,
            increment: SECTOR_DEG as u8,
            min_distance: 5,
            max_distance: max_cm,
            sensor_type: MavDistanceSensor::MAV_DISTANCE_SENSOR_LASER,
            increment_f: SECTOR_DEG as f32,
            angle_offset: 0.0,
            frame: MavFrame::MAV_FRAME_BODY_FRD,
        })
    }

    /// OA_TYPE 1: a stop for a static obstacle that has lasted
    /// OA_DETOUR_WAIT becomes a tangent-bug detour round it, if one fits in
    /// the corridor; the interrupted leg resumes from where the detour
    /// rejoins it.
    ///
    /// Driving (`stopped` false), it looks `DETOUR_LOOKAHEAD_M` ahead for
    /// static returns in the lane, so the detour starts while there is room
    /// to steer round (a stop a few metres short leaves none for an
    /// Ackermann vehicle).
    pub(super) fn maybe_plan_detour(&mut self, stopped: bool) {
        let a = &self.p.obstacles.avoidance;
        if a.kind.get(&self.params) != 1 || self.obstacles.detour.is_some() {
            return;
        }
        let now_s = self.now.boot.as_secs_f64();
        if stopped {
            let wait_s = f64::from(a.detour_wait_s.get(&self.params));
            let Some(since) = self.obstacles.static_stop_since else {
                return;
            };
            if now_s - since < wait_s {
                return;
            }
        }
        if now_s < self.obstacles.next_detour_attempt_s {
            return;
        }
        self.obstacles.next_detour_attempt_s = now_s + 0.5;
        let (Some(target), Some(from)) = (self.navigator.target().copied(), self.navigator.leg_start()) else {
            return;
        };
        let estimate = *self.estimator.estimate();
        let pose = Pose {
            position: estimate.position,
            yaw_rad: estimate.yaw_rad,
        };
        let footprint = self.footprint();
        let corridor_m = f64::from(a.corridor_m.get(&self.params));
        let sign = target.direction.sign();
        let Some((obstacle, others)) = self.detour_points(from, target.point, sign, &footprint, corridor_m) else {
            self.obstacles.detour_refusal_reported = false;
            return;
        };
        let config = DetourConfig {
            clearance_m: 0.5,
            corridor_m,
            min_turn_radius_m: self.nav_config().min_arc_radius_m,
        };
        match plan_detour(from, target.point, &pose, &footprint, &obstacle, &others, &config) {
            Ok(detour) => self.start_detour(detour, target, &obstacle, estimate.position),
            // Nothing in the way yet (or only beyond the leg): keep looking.
            Err(DetourRefusal::NotInTheWay) => {}
            Err(why) => {
                if !self.obstacles.detour_refusal_reported && (stopped || why != DetourRefusal::TooClose) {
                    self.obstacles.detour_refusal_reported = true;
                    self.send_text(MavSeverity::MAV_SEVERITY_WARNING, &format!("No detour: {why:?}"));
                }
            }
        }
    }

    /// The scan returns a detour must pass, or None with nothing in the
    /// lane: the obstacle (the returns ahead within the corridor, in the
    /// driving direction `sign`) and the others it must also clear.
    fn detour_points(
        &self,
        from: Ned,
        to: Ned,
        sign: f64,
        footprint: &Footprint,
        corridor_m: f64,
    ) -> Option<(Vec<Ned>, Vec<Ned>)> {
        // The obstacle: the returns ahead within the corridor, in the
        // driving direction (Some(true)); the others the detour must also
        // clear (Some(false)).
        let moving = || {
            self.obstacles
                .tracker
                .tracks()
                .iter()
                .filter(|t| t.speed_mps() >= STATIC_SPEED_MPS)
                .map(|t| t.position)
        };
        let class = |p: &Ned, x: f64| {
            let ahead = if sign > 0.0 {
                x - footprint.front_m
            } else {
                -footprint.rear_m - x
            };
            let lateral = cross_track(from, to, *p);
            let moving_near = moving().any(|m| m.distance_to(p) < 1.0);
            if (0.0..DETOUR_LOOKAHEAD_M).contains(&ahead)
                && lateral.abs() <= footprint.half_width_m + 0.5
                && !moving_near
            {
                Some(true)
            } else {
                (lateral.abs() <= corridor_m + footprint.half_width_m + 1.0).then_some(false)
            }
        };
        let points = || {
            self.obstacles
                .views
                .iter()
                .flat_map(|view| view.local_points.iter().zip(&view.body_points))
        };
        // Most ticks have nothing in the lane: look before collecting.
        if !points().any(|(p, &(x, _))| class(p, x) == Some(true)) {
            return None;
        }
        let (mut obstacle, mut others) = (Vec::new(), Vec::new());
        for (p, &(x, _)) in points() {
            match class(p, x) {
                Some(true) => obstacle.push(*p),
                Some(false) => others.push(*p),
                None => {}
            }
        }
        Some((obstacle, others))
    }

    /// Announces and takes up a planned detour round the `obstacle` returns.
    fn start_detour(
        &mut self,
        detour: crate::obstacles::detour::Detour,
        target: crate::guidance::navigator::NavTarget,
        obstacle: &[Ned],
        position: Ned,
    ) {
        self.send_text(
            MavSeverity::MAV_SEVERITY_INFO,
            &format!(
                "Obstacle detour {}, {:.1} m off the path",
                match detour.side {
                    crate::obstacles::detour::Side::Left => "left",
                    crate::obstacles::detour::Side::Right => "right",
                },
                detour.max_offset_m
            ),
        );
        self.obstacles.policy.reset();
        self.obstacles.static_stop_since = None;
        let n = obstacle.len() as f64;
        let centre = Ned::new(
            obstacle.iter().map(|p| p.north_m).sum::<f64>() / n,
            obstacle.iter().map(|p| p.east_m).sum::<f64>() / n,
        );
        let radius_m = obstacle.iter().map(|p| p.distance_to(&centre)).fold(0.0, f64::max);
        self.obstacles.detour = Some(ActiveDetour {
            waypoints: detour.waypoints.into_iter().collect(),
            target,
            obstacle: (centre, radius_m),
        });
        self.next_detour_leg(position);
    }

    /// Drives to the next detour waypoint, or back onto the interrupted leg.
    fn next_detour_leg(&mut self, from: Ned) {
        let Some(detour) = &mut self.obstacles.detour else {
            return;
        };
        use crate::guidance::navigator::NavTarget;
        match detour.waypoints.pop_front() {
            Some(point) => {
                let next = detour.waypoints.front().copied().or(Some(detour.target.point));
                let target = NavTarget {
                    point,
                    speed_mps: detour.target.speed_mps,
                    direction: detour.target.direction,
                    stop: false,
                    next,
                    seq: None,
                };
                self.navigator.set_target(from, target);
            }
            None => {
                let target = detour.target;
                self.obstacles.detour = None;
                self.navigator.set_target(from, target);
                self.send_text(MavSeverity::MAV_SEVERITY_INFO, "Obstacle detour done: back on the path");
            }
        }
    }

    /// On a detour, an arrived waypoint moves on to the next.
    pub(super) fn advance_detour(&mut self) {
        if self.obstacles.detour.is_some() && self.navigator.arrived() {
            let here = self
                .navigator
                .target()
                .map_or(self.estimator.estimate().position, |t| t.point);
            self.next_detour_leg(here);
        }
    }
}

/// How far from the centroid of a lost track's returns the object may
/// reach. Returns spanning less than a person (radius r < R, R =
/// [`OUT_OF_VIEW_MIN_RADIUS_M`]) are part of its near face, and their
/// centroid lies on that face, not at its centre: the far side is up to
/// 2R − r away (2R for a sliver). Seed 3202: a person standing behind
/// another was last seen as returns of radius 0.13 m, 0.4 m short of
/// their centre; kept 0.25 m wide, the vehicle came to rest 0.26 m from
/// them.
fn out_of_view_reach_m(radius_m: f64) -> f64 {
    let radius_m = radius_m.max(0.0);
    radius_m.max(2.0 * OUT_OF_VIEW_MIN_RADIUS_M - radius_m)
}

/// Faster than a standing object's noise: above `STATIC_SPEED_MPS` and
/// twice its own velocity σ (the changing view of a box's corner as the
/// vehicle drives up to it walks its centroid at up to 0.4 m/s with σ
/// 0.35; someone walking is tracked at 1–1.6 m/s with σ well under 0.5).
/// Returns that have stayed on one outline for `STILL_S` are a standing
/// object whatever its centroid's velocity says.
fn moving(track: &Track) -> bool {
    shows_speed(track, 2.0)
}

/// Faster than a standing object's noise and than `sigmas` of its filter's
/// velocity σ, its returns not shown to be still.
fn shows_speed(track: &Track, sigmas: f64) -> bool {
    shows_speed_at(track, track.speed_mps(), sigmas)
}

/// [`shows_speed`] with the track's speed already worked out.
fn shows_speed_at(track: &Track, speed: f64, sigmas: f64) -> bool {
    speed >= STATIC_SPEED_MPS && speed > sigmas * track.velocity_sigma_mps && track.still_s < STILL_S
}

/// Whether a track's velocity is good enough to predict it with: its σ
/// within `OA_TRK_VEL_SD`, or, once followed for `SETTLED_S`, seen in the
/// latest scan and in `SETTLED_HITS` since it last coasted, a speed over
/// twice that σ. A walker passing behind someone standing is seen in
/// pieces, and its σ rises past the gate while its speed stays well clear
/// of it: seed 490's walker
/// crossing at 1.66 m/s, tracked for 5 s, was at σ 0.57–0.75 m/s with a
/// speed of 1.6–1.9 m/s over the last two seconds before it reached the
/// vehicle, and was predicted standing until the stop came too late. A
/// track just picked up again after coasting has its velocity from one
/// jump, between where it coasted to and where it is found (a parked
/// car's corner, a sliver 2 m from where it coasted to: 2.7 m/s at σ
/// 0.76), which says nothing; and one not seen in this scan (two people
/// passing, seen as one cluster that updates neither) is carried on a
/// velocity nothing checks: seed 1755's walker, 13° off at σ 0.55–0.74,
/// was predicted into a turn its true line passes 1.2 m clear of.
fn velocity_usable(track: &Track, gate_mps: f64) -> bool {
    track.velocity_sigma_mps <= gate_mps
        || (track.age_s >= SETTLED_S
            && track.hits >= SETTLED_HITS
            && track.misses == 0
            && track.speed_mps() > 2.0 * track.velocity_sigma_mps)
}

/// Whether a track is predicted at its velocity: faster than a standing
/// object's noise (`STATIC_SPEED_MPS`), faster than the vehicle's own
/// motion can walk a standing object's centroid (`ViewChange`), its returns
/// not shown to be still (`STILL_S`), and its speed shown by the filter:
/// twice its velocity σ, as in [`moving`], or, once the track has been
/// followed for `SETTLED_S`, one σ. That σ settles at 0.35–0.43 m/s for
/// someone walking steadily, about twice the real error, so two of them
/// called a walker below 0.7–0.9 m/s standing, and the vehicle drove into
/// them. A new track's velocity is not settled (a sliver seen at the
/// field's edge for 0.2 s: 0.5 m/s at σ 0.6), so it still needs two.
fn walking(track: &Track, view: &ViewChange) -> bool {
    let sigmas = if track.age_s >= SETTLED_S { 1.0 } else { 2.0 };
    let speed = track.speed_mps();
    shows_speed_at(track, speed, sigmas) && view.outpaced_by(track, speed)
}

/// How fast the vehicle's own motion can walk a standing object's centroid:
/// the centroid is the middle of the faces a scanner sees, and as the line
/// of sight to the object turns (at its speed across that line over the
/// range) it slides over the object, and the filter turns the jumps of a
/// cluster whose faces come and go into velocity. Measured on 0.8 m boxes
/// passed at 1–2 m/s: up to 1.5 extents per radian of view turned (0.8 m/s
/// at 0.66 rad/s); the bound is [`VIEW_WALK_PER_RAD`] extents per radian.
/// It is small for what is far or ahead, where the view hardly changes.
struct ViewChange {
    /// Each fitted scanner's motion.
    scanners: [Option<ScannerMotion>; SCANNERS],
}

/// A scanner's position, velocity (north, east) and speed in the local
/// frame.
#[derive(Clone, Copy)]
struct ScannerMotion {
    at: Ned,
    velocity: (f64, f64),
    speed_mps: f64,
}

impl ViewChange {
    fn new(
        pose: &Pose,
        vehicle_velocity: (f64, f64),
        yaw_rate_rad_s: f64,
        mounts: impl Iterator<Item = ScannerMount>,
    ) -> Self {
        let (sin_yaw, cos_yaw) = pose.yaw_rad.sin_cos();
        let mut scanners = [None; SCANNERS];
        for (slot, mount) in scanners.iter_mut().zip(mounts) {
            let (x, y) = (mount.x_m, mount.y_m);
            let at = Ned::new(
                pose.position.north_m + x * cos_yaw - y * sin_yaw,
                pose.position.east_m + x * sin_yaw + y * cos_yaw,
            );
            // The mount swings round the reference point as the body turns.
            let swing = (-x * sin_yaw - y * cos_yaw, x * cos_yaw - y * sin_yaw);
            let velocity = (
                vehicle_velocity.0 + yaw_rate_rad_s * swing.0,
                vehicle_velocity.1 + yaw_rate_rad_s * swing.1,
            );
            *slot = Some(ScannerMotion {
                at,
                velocity,
                speed_mps: velocity.0.hypot(velocity.1),
            });
        }
        ViewChange { scanners }
    }

    /// Whether `speed_mps` is above [`Self::centroid_speed_mps`]. The view
    /// walks the centroid at most `VIEW_WALK_PER_RAD`·extent·|v|/range for
    /// a scanner at speed |v| (what crosses the line of sight is no more
    /// than |v|), and the range is at least the larger of the offsets north
    /// and east: a speed above that bound (a part in a billion more, for
    /// rounding) is above the exact figure too, found without a square
    /// root per scanner and track.
    fn outpaced_by(&self, track: &Track, speed_mps: f64) -> bool {
        let extent_m = 2.0 * track.radius_m.max(0.0);
        let bound = self
            .scanners
            .iter()
            .flatten()
            .map(|scanner| {
                let at = scanner.at;
                let (dn, de) = (track.position.north_m - at.north_m, track.position.east_m - at.east_m);
                let range_at_least_m = dn.abs().max(de.abs()).max(track.radius_m).max(0.1);
                VIEW_WALK_PER_RAD * extent_m * scanner.speed_mps / range_at_least_m
            })
            .fold(0.0, f64::max);
        if speed_mps > bound * (1.0 + 1e-9) && bound.is_finite() {
            return true;
        }
        speed_mps > self.centroid_speed_mps(track)
    }

    /// The largest speed the view change alone gives `track`'s centroid.
    fn centroid_speed_mps(&self, track: &Track) -> f64 {
        let extent_m = 2.0 * track.radius_m.max(0.0);
        self.scanners
            .iter()
            .flatten()
            .map(|scanner| {
                let (at, (vn, ve)) = (scanner.at, scanner.velocity);
                let (dn, de) = (track.position.north_m - at.north_m, track.position.east_m - at.east_m);
                let range_m = dn.hypot(de).max(track.radius_m).max(0.1);
                let across_mps = (dn * ve - de * vn).abs() / range_m;
                VIEW_WALK_PER_RAD * extent_m * across_mps / range_m
            })
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
    }
}

/// Poses every `ds_m` along a stroke's pieces, its end included: the
/// reference point on the path, the body along the travel (turned round
/// in reverse).
fn stroke_poses(stroke: &Stroke, ds_m: f64) -> impl Iterator<Item = Pose> + '_ {
    let length_m = stroke.length_m();
    let flip = if stroke.direction == Direction::Reverse {
        std::f64::consts::PI
    } else {
        0.0
    };
    let count = if ds_m > 0.0 && length_m.is_finite() {
        (length_m / ds_m).ceil() as usize
    } else {
        0
    };
    (0..=count).filter_map(move |i| {
        let mut along_m = (i as f64 * ds_m).min(length_m);
        let last = stroke.pieces.len().checked_sub(1)?;
        for (k, piece) in stroke.pieces.iter().enumerate() {
            if along_m <= piece.length_m() || k == last {
                return Some(Pose {
                    position: piece.point_at(along_m),
                    yaw_rad: wrap_pi(piece.heading_at(along_m) + flip),
                });
            }
            along_m -= piece.length_m();
        }
        None
    })
}

/// Marks the returns of structure clusters (cleared by the caller, one
/// flag per return the clusters were grouped from).
fn mark_structure(clusters: &[Cluster], structure: &mut [bool]) {
    for cluster in clusters.iter().filter(|c| c.is_structure) {
        let end = (cluster.first_point + cluster.points).min(structure.len());
        for flag in structure.iter_mut().take(end).skip(cluster.first_point) {
            *flag = true;
        }
    }
}

/// A track's shape for collision prediction: a walking object is a disc of
/// its radius (half the width the scanner sees, which for someone walking
/// is the width across their motion or their depth, the larger for a
/// person); anything else keeps the outline fitted to its returns (faces,
/// not a disc of half its extent).
fn track_shape(track: &Track, walking: bool) -> Shape<'_> {
    match &track.outline {
        Some(outline) if !walking => Shape::Polygon {
            centre: track.position,
            outline,
        },
        _ => Shape::Disc {
            centre: track.position,
            radius_m: track.radius_m,
        },
    }
}

/// The body sectors the scan's beams fall in.
fn covered_sectors(scan: &Scan, mount_yaw_rad: f64) -> [bool; SECTORS] {
    let mut covered = [false; SECTORS];
    let beams = scan.ranges_m.len();
    let body_deg = |beam: usize| (scan.angle_rad(beam) + mount_yaw_rad).to_degrees();
    let step_deg = scan.step_rad.to_degrees().abs();
    let span_deg = step_deg * beams.saturating_sub(1) as f64;
    if beams > 0 && step_deg < SECTOR_DEG && span_deg < 360.0 - SECTOR_DEG {
        // Beams closer than a sector skip none between the first beam's
        // sector and the last's: walk from one to the other, the way the
        // beams go, instead of placing every beam.
        let (first, last) = (sector_of(body_deg(0)), sector_of(body_deg(beams - 1)));
        let next = if scan.step_rad >= 0.0 { 1 } else { SECTORS - 1 };
        let mut sector = first;
        covered[sector] = true;
        while sector != last {
            sector = (sector + next) % SECTORS;
            covered[sector] = true;
        }
    } else {
        for beam in 0..beams {
            covered[sector_of(body_deg(beam))] = true;
        }
    }
    covered
}

fn sector_of(body_deg: f64) -> usize {
    let wrapped = wrap_pi((body_deg + SECTOR_DEG / 2.0).to_radians()).to_degrees();
    let from_zero = if wrapped < 0.0 { wrapped + 360.0 } else { wrapped };
    ((from_zero / SECTOR_DEG).floor() as usize).min(SECTORS - 1)
}

/// Distance from a body-frame point to the outline (0 inside).
fn outline_distance(f: &Footprint, x: f64, y: f64) -> f64 {
    let (dx, dy) = outline_gap(f, x, y);
    dx.hypot(dy)
}

/// The vector from the outline's nearest point to a body-frame point
/// outside it ((0, 0) inside).
fn outline_gap(f: &Footprint, x: f64, y: f64) -> (f64, f64) {
    let dx = if x > f.front_m {
        x - f.front_m
    } else if x < -f.rear_m {
        -f.rear_m - x
    } else {
        0.0
    };
    let dy = (y.abs() - f.half_width_m).max(0.0);
    (dx, dy)
}

/// Signed distance of `p` right of the line from `a` to `b`.
fn cross_track(a: Ned, b: Ned, p: Ned) -> f64 {
    let (dn, de) = (b.north_m - a.north_m, b.east_m - a.east_m);
    let len = dn.hypot(de);
    if len < 1e-9 {
        return a.distance_to(&p);
    }
    ((p.east_m - a.east_m) * dn - (p.north_m - a.north_m) * de) / len
}

impl Mode {
    /// The modes the obstacle policy governs: those that drive by themselves.
    pub fn self_driving(self) -> bool {
        matches!(self, Mode::Auto | Mode::Guided | Mode::Rtl | Mode::Magnetic)
    }
}

/// Whether the vehicle at `pose` is on its leg: near the path at its
/// projection `along_m`, and pointing along it (within `ON_PATH_M`,
/// `ON_PATH_RAD`).
fn on_leg(pose: &Pose, path: &LegPath, along_m: f64, target: &NavTarget) -> bool {
    let flip = if target.direction == Direction::Reverse {
        std::f64::consts::PI
    } else {
        0.0
    };
    let heading_off = wrap_pi(pose.yaw_rad - path.heading_at(along_m) - flip).abs();
    path.point_at(along_m).distance_to(&pose.position) <= ON_PATH_M && heading_off <= ON_PATH_RAD
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use proptest::prelude::*;

    use super::*;

    proptest! {
        /// Walking the sectors from the first beam's to the last's marks
        /// the same sectors as placing every beam.
        #[test]
        fn covered_sectors_match_placing_every_beam(
            start_deg in -400.0f64..400.0,
            step_deg in prop_oneof![-6.0f64..6.0, Just(0.5), Just(-0.5), Just(0.0)],
            beams in 0usize..1100,
            mount_yaw_deg in -360.0f64..360.0,
        ) {
            let scan = Scan {
                t: Duration::ZERO,
                scan_counter: 0,
                start_angle_rad: start_deg.to_radians(),
                step_rad: step_deg.to_radians(),
                ranges_m: vec![1.0; beams],
            };
            let mount_yaw_rad = mount_yaw_deg.to_radians();
            let mut expected = [false; SECTORS];
            for beam in 0..beams {
                expected[sector_of((scan.angle_rad(beam) + mount_yaw_rad).to_degrees())] = true;
            }
            prop_assert_eq!(covered_sectors(&scan, mount_yaw_rad), expected);
        }
    }

    /// Off its leg with no scan return and no track near, the vehicle
    /// still sweeps its way back onto the leg when a standing person
    /// remembered out of view is on it (`scene_within`), so the person
    /// gets a collision prediction (`push_hidden_standing_contacts`);
    /// skipped, the empty sweep would find nothing.
    #[test]
    fn off_the_leg_a_remembered_standing_person_on_the_rejoin_path_is_predicted() {
        use crate::sitl::simulation::{Simulation, SimulationConfig, SimulationParams};

        let config = SimulationConfig::default();
        let mut sim = Simulation::new(&config, SimulationParams::new(config.model));
        let core = sim.core_mut();
        let footprint = core.footprint();
        // A leg due north along east 0; the vehicle 1.5 m east of it, heading north.
        core.navigator
            .set_target(Ned::new(0.0, 0.0), NavTarget::stop_at(Ned::new(30.0, 0.0)));
        let pose = Pose {
            position: Ned::new(5.0, 1.5),
            yaw_rad: 0.0,
        };
        // Someone who stood 1.5 m past the front bumper, lost from view.
        let person = Ned::new(5.0 + footprint.front_m + 1.5, 1.2);
        core.obstacles.hidden.push(HiddenTrack {
            id: 7,
            position: person,
            velocity: (0.0, 0.0),
            radius_m: 0.25,
            lost_s: 0.0,
            spread_mps: 0.0,
            standing: true,
            known_ids_to: 7,
        });
        assert!(core.obstacles.tracker.tracks().is_empty());
        assert!(core.obstacles.views.iter().all(|v| v.local_points.is_empty()));
        let (speed, planned_mps) = (1.0, 1.0);
        core.sweep_path_ahead(&pose, &footprint, false, 5.0, (speed, planned_mps));
        assert!(
            !core.obstacles.rejoin_poses.is_empty(),
            "off the leg: the rejoin branch"
        );
        let a = &core.p.obstacles.avoidance;
        let margin = f64::from(a.margin_m.get(&core.params));
        let horizon = f64::from(a.horizon_s.get(&core.params));
        let mut predictions = Vec::new();
        core.push_hidden_standing_contacts(speed, (margin, horizon), &mut predictions);
        assert!(
            predictions.iter().any(|p| p.track_id == 7),
            "no collision prediction for the person on the rejoin path: {predictions:?}"
        );
    }
}
