//! Pose goals for GUIDED and RTL: a point with an optional heading, reached
//! by today's straight leg when that leg can reach it (far ahead, or on the
//! line the vehicle faces) and otherwise by a manoeuvre planned in the core;
//! a far goal with a heading by the straight leg and then a manoeuvre onto
//! the heading (a manoeuvre all the way could be longer than `MNV_LEN_MAX`
//! allows, and RTL must not be refused for that); and the honest arrival: "Reached destination" only for a stop within
//! `WP_STOP_TOL_MM` / `WP_STOP_TOL_DEG`, one retry of a miss, a warning
//! for a miss after it.

use std::f64::consts::{FRAC_PI_2, PI};

use mavlink::dialects::ardupilotmega::MavSeverity;

use super::Core;
use crate::control::mixer::DriveTrain;
use crate::geo::{GeoPoint, Ned, wrap_pi};
use crate::guidance::manoeuvre::{ManoeuvreConfig, plan};
use crate::guidance::navigator::{NavTarget, StopReport};
use crate::guidance::reeds_shepp::Pose;
use crate::guidance::tracker::Direction;
use crate::modes::Mode;

/// A straight leg reaches a goal it starts this well aligned with…
const ALIGNED_RAD: f64 = 1.0 * PI / 180.0;
/// …this well when it is shorter than `MNV_APPR_LEN`…
const SHORT_ALIGNED_RAD: f64 = 0.2 * PI / 180.0;
/// …(and a leg shorter than this has no direction)…
const MIN_LEG_M: f64 = 0.01;
/// …or one this many planning radii (and the approach) away and not
/// behind: the capture turn and the settling after it fit in the leg.
const FAR_RADII: f64 = 4.0;
/// A stop report is of the pose goal when its point is this close to the
/// goal's.
const SAME_POINT_M: f64 = 0.001;

/// The estimate is 95 % sure of a stop's error when the error is beyond
/// its uncertainty: the radius that holds 95 % of a circular Gaussian
/// whose horizontal σ is `horiz_sigma_m` (per axis σ/√2, radius
/// √(−2·ln 0.05)·σ/√2 = 1.731 σ) and 1.96 σ of the heading. A miss after a
/// turn on the spot is retried only when this sure of it.
pub(super) const CONFIRM_POSITION_SIGMAS: f64 = 1.731;
pub(super) const CONFIRM_YAW_SIGMAS: f64 = 1.96;
/// "Reached" is claimed only when the stop error plus its uncertainty is
/// within tolerance at 99 %, for a claim is a promise: the radius
/// √(−2·ln 0.01)·σ/√2 = 2.146 σ of the position and 2.576 σ of the
/// heading. The bound is checked every tick until it holds, so the
/// estimate's wander at rest has many chances to cross it: at 95 % bench
/// seed 101 (differential, walk 1 mm, GUIDED) was claimed at 5.4 mm by the
/// estimate, σ 2.6 mm, with the truth 10.0 mm away.
const CLAIM_POSITION_SIGMAS: f64 = 2.146;
const CLAIM_YAW_SIGMAS: f64 = 2.576;
/// At rest the estimate keeps averaging fixes, so an unconfirmed stop
/// waits up to this long for its σ to shrink before it is reported
/// unconfirmed.
pub const CONFIRM_WAIT_S: f64 = 8.0;

/// Where GUIDED or RTL is driving to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct PoseGoal {
    pub point: Ned,
    /// Local frame, radians from north; `None`: any heading.
    pub yaw_rad: Option<f64>,
    pub speed_mps: Option<f64>,
    /// The one retry after a miss has been used.
    pub retried: bool,
    /// Driving a straight leg to a far goal: its heading comes after.
    pub turn_after_leg: bool,
    /// The mission item this is the stop of (AUTO), reported reached or
    /// not by the final stop.
    pub seq: Option<u16>,
}

impl PoseGoal {
    fn new(point: Ned, yaw_rad: Option<f64>, speed_mps: Option<f64>, seq: Option<u16>) -> PoseGoal {
        PoseGoal {
            point,
            yaw_rad,
            speed_mps,
            retried: false,
            turn_after_leg: false,
            seq,
        }
    }
}

#[derive(Clone, Copy, Debug, Default)]
pub(super) struct PoseGoalState {
    pub goal: Option<PoseGoal>,
    /// The vehicle's heading when home was set to where it stood (local
    /// frame): RTL returns facing that way.
    pub home_yaw_rad: Option<f64>,
    /// A mission stop that ended out of tolerance: it is not reported
    /// reached.
    pub missed_seq: Option<u16>,
    /// A mission stop with a heading that ended in tolerance by the
    /// estimate, which is not sure of it: not claimed reached either (a
    /// pose stop is a precision claim, as GUIDED's "Reached destination").
    pub unconfirmed_seq: Option<u16>,
    /// A stop in tolerance by the estimate, waiting for the estimate to be
    /// sure of it: GUIDED's or RTL's, or an AUTO pose stop's (the mission
    /// waits for the verdict).
    pub confirming: Option<Confirming>,
}

/// A stop waiting for its verdict: where it should be, facing which way,
/// in which mode, for how long it has waited, and the mission item it is
/// the stop of (AUTO).
#[derive(Clone, Copy, Debug)]
pub(super) struct Confirming {
    point: Ned,
    yaw_rad: f64,
    mode: Mode,
    waited_s: f64,
    seq: Option<u16>,
}

impl Core {
    pub(super) fn manoeuvre_config(&self) -> ManoeuvreConfig {
        let t = &self.params;
        let m = &self.p.manoeuvre;
        ManoeuvreConfig {
            radius_m: self.nav_config().arc_radius_m,
            approach_m: f64::from(m.approach_m.get(t)),
            max_length_m: f64::from(m.length_max_m.get(t)),
            max_direction_changes: m.direction_changes_max.get(t).max(0) as usize,
            pivots: m.pivot.get(t) && self.drive_train == DriveTrain::Differential,
            arriving: None,
        }
    }

    /// The limits for driving on towards the goal: the changes of direction
    /// already driven on the way to it (a stop's creep back included) come
    /// off `MNV_DIR_MAX`, and a first stroke against the way it last drove
    /// is one more.
    pub(super) fn manoeuvre_config_on_the_way(&self) -> ManoeuvreConfig {
        let config = self.manoeuvre_config();
        let driven = self.navigator.driven();
        ManoeuvreConfig {
            max_direction_changes: config.max_direction_changes.saturating_sub(driven.changes),
            arriving: driven.last,
            ..config
        }
    }

    /// Drives to `target`, facing `yaw_rad` (local frame) if given, and
    /// stops there. False (with a STATUSTEXT) when no manoeuvre fits.
    pub(super) fn navigate_to(&mut self, target: GeoPoint, yaw_rad: Option<f64>, speed_mps: Option<f64>) -> bool {
        let Some(frame) = self.frame() else {
            return false;
        };
        let goal = PoseGoal::new(frame.to_local(&target), yaw_rad, speed_mps, None);
        self.goals.goal = Some(goal);
        self.goals.confirming = None;
        self.navigator.count_directions_afresh();
        self.drive_to_goal(goal, false)
    }

    /// AUTO: a mission stop (item `seq`) with a heading, driven as a pose
    /// goal. False (with a STATUSTEXT) when no manoeuvre fits.
    pub(super) fn navigate_to_mission_pose(
        &mut self,
        point: Ned,
        yaw_rad: f64,
        speed_mps: Option<f64>,
        seq: u16,
    ) -> bool {
        let goal = PoseGoal {
            retried: true,
            ..PoseGoal::new(point, Some(yaw_rad), speed_mps, Some(seq))
        };
        self.goals.goal = Some(goal);
        self.goals.confirming = None;
        self.navigator.count_directions_afresh();
        self.drive_to_goal(goal, false)
    }

    /// AUTO: the straight leg of a mission pose has ended; the manoeuvre
    /// onto its heading follows (the mission sees no arrival until then).
    /// True when one was started.
    pub(super) fn turn_after_mission_leg(&mut self) -> bool {
        let Some(mut goal) = self.goals.goal.filter(|g| g.turn_after_leg && g.seq.is_some()) else {
            return false;
        };
        if !self.navigator.arrived() {
            return false;
        }
        goal.turn_after_leg = false;
        self.goals.goal = Some(goal);
        self.drive_to_goal(goal, true)
    }

    fn drive_to_goal(&mut self, mut goal: PoseGoal, manoeuvre_only: bool) -> bool {
        let estimate = *self.estimator.estimate();
        let start = Pose {
            position: estimate.position,
            yaw_rad: estimate.yaw_rad,
        };
        let leg = if manoeuvre_only {
            None
        } else {
            self.straight_leg(&start, &goal)
        };
        if let Some((direction, turn_after_leg)) = leg {
            goal.turn_after_leg = turn_after_leg;
            self.goals.goal = Some(goal);
            self.navigator.set_target(
                start.position,
                NavTarget {
                    speed_mps: goal.speed_mps,
                    direction,
                    // A heading still to come: this stop is not the item's.
                    seq: goal.seq.filter(|_| !turn_after_leg),
                    ..NavTarget::stop_at(goal.point)
                },
            );
            return true;
        }
        match plan(&start, goal.point, goal.yaw_rad, &self.manoeuvre_config_on_the_way()) {
            Ok(manoeuvre) => {
                let pivots = manoeuvre.pivot_headings(start.yaw_rad).len();
                if manoeuvre.direction_changes() > 0 || manoeuvre_only || pivots > 0 {
                    self.send_text(
                        MavSeverity::MAV_SEVERITY_INFO,
                        &format!(
                            "Manoeuvre: {:.1} m, {} reversals, {pivots} pivots",
                            manoeuvre.length_m(),
                            manoeuvre.direction_changes()
                        ),
                    );
                }
                self.navigator.set_manoeuvre(manoeuvre, goal.speed_mps, goal.seq);
                true
            }
            Err(why) => {
                self.send_text(MavSeverity::MAV_SEVERITY_WARNING, &format!("Manoeuvre refused: {why}"));
                self.navigator.clear();
                self.goals.goal = None;
                false
            }
        }
    }

    /// Today's straight leg from here reaches the goal's point: the
    /// vehicle already faces along the leg (or away from it: a reverse
    /// leg) and the goal's heading is the leg's, or the goal is far ahead.
    /// The leg's direction, and whether the heading needs a manoeuvre after
    /// it (a far goal's).
    fn straight_leg(&self, start: &Pose, goal: &PoseGoal) -> Option<(Direction, bool)> {
        let distance = start.position.distance_to(&goal.point);
        let bearing = start.position.bearing_to(&goal.point);
        let config = self.manoeuvre_config();
        let tolerance = self.nav_config().stop.yaw_rad;
        // A short leg has little room to turn onto it.
        let aligned_limit = if distance >= config.approach_m {
            ALIGNED_RAD
        } else {
            SHORT_ALIGNED_RAD
        };
        for direction in [Direction::Forward, Direction::Reverse] {
            let flip = if direction == Direction::Reverse { PI } else { 0.0 };
            let off = wrap_pi(bearing - flip - start.yaw_rad).abs();
            let end_yaw = wrap_pi(bearing - flip);
            let heading_fits = goal.yaw_rad.is_none_or(|yaw| wrap_pi(yaw - end_yaw).abs() <= tolerance);
            if off <= aligned_limit && heading_fits && distance >= MIN_LEG_M {
                return Some((direction, false));
            }
        }
        let off = wrap_pi(bearing - start.yaw_rad).abs();
        // A goal with a heading needs room for the final manoeuvre's
        // approach as well; one without is reached by the leg alone.
        let approach_m = if goal.yaw_rad.is_some() { config.approach_m } else { 0.0 };
        let far = distance >= FAR_RADII * config.radius_m + approach_m && off <= FRAC_PI_2;
        let heading_fits = goal.yaw_rad.is_none_or(|yaw| wrap_pi(yaw - bearing).abs() <= tolerance);
        far.then_some((Direction::Forward, !heading_fits))
    }

    /// GUIDED or RTL came to rest at its goal: say whether it is there, and
    /// try once more if not.
    pub(super) fn announce_arrival(&mut self, report: Option<&StopReport>) {
        if let Some(mut goal) = self.goals.goal.filter(|g| g.turn_after_leg) {
            goal.turn_after_leg = false;
            self.goals.goal = Some(goal);
            self.drive_to_goal(goal, true);
            return;
        }
        if let Some(report) = report.filter(|r| r.within_tolerance) {
            let (Some(target), estimate) = (self.navigator.target(), self.estimator.estimate()) else {
                return;
            };
            self.goals.confirming = Some(Confirming {
                point: target.point,
                yaw_rad: wrap_pi(estimate.yaw_rad - report.yaw_error_rad),
                mode: self.mode,
                waited_s: 0.0,
                seq: None,
            });
            self.confirm_arrival(0.0);
            return;
        }
        let miss = report.map_or(String::from("no stop report"), |r| {
            format!(
                "{:.1} mm, yaw {:.3} deg",
                r.position_error_m() * 1000.0,
                r.yaw_error_rad.to_degrees()
            )
        });
        let doubt = report.and_then(|r| self.miss_in_doubt(r));
        match self.goals.goal {
            Some(goal) if !goal.retried && doubt.is_some() => {
                let why = doubt.unwrap_or_default();
                self.send_text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    &format!("Destination NOT reached: {miss}; no retry: the miss is within {why}"),
                );
            }
            Some(mut goal) if !goal.retried => {
                self.send_text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    &format!("Missed ({miss}): trying again"),
                );
                goal.retried = true;
                self.goals.goal = Some(goal);
                if !self.drive_to_goal(goal, true) {
                    self.send_text(
                        MavSeverity::MAV_SEVERITY_WARNING,
                        &format!("Destination NOT reached: {miss}"),
                    );
                }
            }
            _ => self.send_text(
                MavSeverity::MAV_SEVERITY_WARNING,
                &format!("Destination NOT reached: {miss}"),
            ),
        }
    }

    /// AUTO: a mission pose stop (item `seq`) in tolerance by the estimate,
    /// which is not yet sure of it, waits for the verdict as GUIDED's does:
    /// the mission sees no arrival until then.
    pub(super) fn confirm_mission_stop(&mut self, report: &StopReport, seq: u16) {
        self.goals.confirming = Some(Confirming {
            point: report.goal.position,
            yaw_rad: report.goal.yaw_rad,
            mode: self.mode,
            waited_s: 0.0,
            seq: Some(seq),
        });
        self.confirm_arrival(0.0);
    }

    /// A mission pose stop is waiting for its verdict.
    pub(super) fn confirming_mission_stop(&self) -> bool {
        self.goals
            .confirming
            .is_some_and(|c| c.seq.is_some() && c.mode == self.mode)
    }

    /// A stop in tolerance by the estimate, resting: "Reached destination"
    /// once the vehicle is at rest (held still, the GNSS agreeing) and the
    /// estimate is sure of it (its error plus its uncertainty within
    /// tolerance); after `CONFIRM_WAIT_S` without, "Stopped at destination
    /// … unconfirmed" with what kept it from a claim (the σ, or no rest;
    /// another approach would end as uncertain, so there is no retry). A
    /// mission stop's verdict is the mission's to report: reached, or not
    /// claimed.
    pub(super) fn confirm_arrival(&mut self, dt_s: f64) {
        let Some(mut confirming) = self.goals.confirming.filter(|c| c.mode == self.mode) else {
            self.goals.confirming = None;
            return;
        };
        confirming.waited_s += dt_s;
        let estimate = *self.estimator.estimate();
        let error_m = estimate.position.distance_to(&confirming.point);
        let yaw_error_rad = wrap_pi(estimate.yaw_rad - confirming.yaw_rad);
        let error_mm = error_m * 1000.0;
        // A verdict on a vehicle still moving could be undone by the motion.
        let why = if self.estimator.at_rest() {
            self.unconfirmed_because(error_m, yaw_error_rad)
        } else {
            Some(String::from("not at rest"))
        };
        if why.is_some() && confirming.waited_s < CONFIRM_WAIT_S {
            self.goals.confirming = Some(confirming);
            return;
        }
        self.goals.confirming = None;
        if let Some(seq) = confirming.seq {
            self.goals.unconfirmed_seq = why.is_some().then_some(seq);
            return;
        }
        let text = match (why, self.mode) {
            (None, Mode::Rtl) => "Reached destination: home".to_string(),
            (None, _) => format!("Reached destination: {error_mm:.1} mm"),
            (Some(why), Mode::Rtl) => format!("Stopped at home: {error_mm:.1} mm, unconfirmed ({why})"),
            (Some(why), _) => format!("Stopped at destination: {error_mm:.1} mm, unconfirmed ({why})"),
        };
        self.send_text(MavSeverity::MAV_SEVERITY_INFO, &text);
    }

    /// A stop on a straight leg to a pose goal, judged against the goal's
    /// heading rather than the leg's: the leg is taken when its heading is
    /// within `WP_STOP_TOL_DEG` of the goal's, so a stop in tolerance of
    /// the leg could be out of it of the goal by up to twice that (bench
    /// seed 112, differential, AUTO: -0.019° from the leg, -0.057° from the
    /// goal, and claimed reached). Other stops are returned as they are.
    pub(super) fn against_pose_goal(&self, report: StopReport) -> StopReport {
        let Some(goal) = self.goals.goal.filter(|g| !g.turn_after_leg) else {
            return report;
        };
        let Some(yaw_rad) = goal.yaw_rad else {
            return report;
        };
        if goal.point.distance_to(&report.goal.position) > SAME_POINT_M {
            return report;
        }
        let estimate_yaw_rad = wrap_pi(report.goal.yaw_rad + report.yaw_error_rad);
        let yaw_error_rad = wrap_pi(estimate_yaw_rad - yaw_rad);
        let tolerance = self.nav_config().stop;
        StopReport {
            yaw_error_rad,
            goal: Pose {
                position: report.goal.position,
                yaw_rad,
            },
            within_tolerance: report.position_error_m() <= tolerance.position_m
                && yaw_error_rad.abs() <= tolerance.yaw_rad,
            ..report
        }
    }

    /// A stop that ended with a turn on the spot (a differential
    /// vehicle's, onto the goal's heading) out of tolerance by the estimate
    /// is retried only when the estimate is sure of the miss (at 95 %; a
    /// claim of a hit, [`Core::unconfirmed_because`], needs 99 %): the
    /// error less its uncertainty still past the tolerance. The turn
    /// stirs the position estimate up by 5–10 mm while the centre stands
    /// still, so such a miss is as likely the estimate's as the stop's, and
    /// retrying it turns the vehicle to face a point 15 mm away, creeps
    /// there and turns back, for nothing: on the manoeuvre bench 23 of 25
    /// such retries were called with the truth within tolerance. A stop
    /// driven onto its heading (Ackermann) is retried as before: 3 of 72 of
    /// those were needless, and without them 1–4 more goals per 64 missed.
    /// Some(the uncertainty that holds the miss).
    pub(super) fn miss_in_doubt(&self, report: &StopReport) -> Option<String> {
        if report.turn_s <= 0.0 {
            return None;
        }
        let tolerance = self.nav_config().stop;
        let (sigma_m, yaw_sigma_rad) = self.stop_sigmas();
        let position_sure = report.position_error_m() - CONFIRM_POSITION_SIGMAS * sigma_m > tolerance.position_m;
        let yaw_sure = report.yaw_error_rad.abs() - CONFIRM_YAW_SIGMAS * yaw_sigma_rad > tolerance.yaw_rad;
        // NaN compares false: an estimate that cannot say is not sure.
        (!position_sure && !yaw_sure).then(|| {
            format!(
                "position sigma {:.1} mm, heading sigma {:.3} deg",
                sigma_m * 1000.0,
                yaw_sigma_rad.to_degrees()
            )
        })
    }

    /// The estimate's position σ (m) and heading σ (rad; infinite without an
    /// EKF status) a stop is judged with.
    fn stop_sigmas(&self) -> (f64, f64) {
        let yaw_sigma_rad = self
            .estimator
            .ekf_status()
            .map_or(f64::INFINITY, |s| s.heading_sigma_rad);
        (self.estimator.estimate().horiz_sigma_m, yaw_sigma_rad)
    }

    /// Why a stop `error_m`, `yaw_error_rad` from its pose by the estimate
    /// cannot be claimed within tolerance: the error is past it, or the
    /// estimate's uncertainty reaches past it (a GNSS whose wander is a good
    /// part of `WP_STOP_TOL_MM`). None: confirmed.
    pub(super) fn unconfirmed_because(&self, error_m: f64, yaw_error_rad: f64) -> Option<String> {
        let tolerance = self.nav_config().stop;
        let (sigma_m, yaw_sigma_rad) = self.stop_sigmas();
        let position_bound_m = error_m + CLAIM_POSITION_SIGMAS * sigma_m;
        let yaw_bound_rad = yaw_error_rad.abs() + CLAIM_YAW_SIGMAS * yaw_sigma_rad;
        // False for a NaN bound: an estimate that cannot say is not sure.
        let confirms = |bound: f64, limit: f64| bound <= limit;
        if !confirms(position_bound_m, tolerance.position_m) {
            Some(format!("position sigma {:.1} mm", sigma_m * 1000.0))
        } else if !confirms(yaw_bound_rad, tolerance.yaw_rad) {
            Some(format!("heading sigma {:.3} deg", yaw_sigma_rad.to_degrees()))
        } else {
            None
        }
    }

    /// A true heading (MAVLink's) at `at` as a heading in the local frame;
    /// `None` for no heading (NaN, infinite).
    pub(super) fn local_yaw(&self, at: &GeoPoint, true_yaw_rad: f64) -> Option<f64> {
        let frame = self.frame()?;
        true_yaw_rad
            .is_finite()
            .then(|| frame.heading_to_local(at, true_yaw_rad))
    }

    /// Home and the true heading RTL returns facing (when home was set
    /// where the vehicle stood): what RTL drives to, for a ground station
    /// or bench to measure the arrival against.
    pub fn home_pose(&self) -> Option<(GeoPoint, Option<f64>)> {
        let home = self.home?;
        let frame = self.frame()?;
        let yaw = self.goals.home_yaw_rad.map(|yaw| frame.heading_to_true(&home, yaw));
        Some((home, yaw))
    }

    /// Where the estimate has the vehicle, in WGS-84.
    pub fn estimate_geodetic(&self) -> Option<GeoPoint> {
        let frame = self.frame()?;
        Some(frame.to_geodetic(&self.estimator.estimate().position))
    }

    /// Where RTL faces at home: the way the vehicle faced when home was set
    /// where it stood (unknown for a home sent as coordinates or a rally
    /// point).
    pub(super) fn rtl_yaw(&self, rtl_target: &GeoPoint) -> Option<f64> {
        let home = self.home?;
        (home.lat_e7() == rtl_target.lat_e7() && home.lon_e7() == rtl_target.lon_e7())
            .then_some(self.goals.home_yaw_rad)
            .flatten()
    }
}
