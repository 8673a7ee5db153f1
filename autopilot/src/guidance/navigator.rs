//! The navigator: drives the vehicle along a leg to a target, and either
//! stops there (a precision stop) or drives through it onto the next leg.
//! GUIDED, RTL and AUTO give it legs; it returns the steering angle and
//! signed speed for the controllers.

use crate::estimation::Estimate;
use crate::geo::{Ned, wrap_pi};
use crate::guidance::path::Segment;
use crate::guidance::speed::{SpeedLimits, scheduled_speed};
use crate::guidance::tracker::{Direction, TrackerConfig, TrackerState, TrackerStatus, VehiclePose, track_segment};

/// Remaining distance at which a stopping leg counts as arrived.
const ARRIVED_M: f64 = 0.03;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavConfig {
    pub tracker: TrackerConfig,
    pub speed: SpeedLimits,
    /// `WP_RADIUS`: within it the target counts as reached.
    pub wp_radius_m: f64,
}

/// A leg to drive: from `from` to `point`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavTarget {
    pub point: Ned,
    /// Overrides the cruise speed when set.
    pub speed_mps: Option<f64>,
    pub direction: Direction,
    /// Stop at `point` (else drive through it: reached within `WP_RADIUS`
    /// or once past it).
    pub stop: bool,
}

impl NavTarget {
    /// A forward leg that stops at `point` (GUIDED, RTL).
    pub fn stop_at(point: Ned) -> NavTarget {
        NavTarget {
            point,
            speed_mps: None,
            direction: Direction::Forward,
            stop: true,
        }
    }
}

/// What the controllers should do.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NavDemand {
    pub steer_rad: f64,
    /// Signed: negative in reverse.
    pub speed_mps: f64,
}

/// The navigator's report for NAV_CONTROLLER_OUTPUT.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NavStatus {
    pub active: bool,
    pub wp_dist_m: f64,
    pub target_bearing_rad: f64,
    pub nav_bearing_rad: f64,
    pub crosstrack_m: f64,
    pub reached: bool,
    pub tracker: TrackerStatus,
}

#[derive(Default)]
pub struct Navigator {
    leg: Option<(Segment, NavTarget)>,
    arrived: bool,
    tracker: TrackerState,
    status: NavStatus,
}

impl Navigator {
    /// Drives the leg from `from` to `target.point`.
    pub fn set_target(&mut self, from: Ned, target: NavTarget) {
        self.leg = Some((Segment::new(from, target.point), target));
        self.arrived = false;
        self.tracker.reset();
        self.status.reached = false;
    }

    /// Stops navigating (the vehicle holds).
    pub fn clear(&mut self) {
        self.leg = None;
        self.arrived = false;
        self.tracker.reset();
        self.status = NavStatus::default();
    }

    pub fn target(&self) -> Option<&NavTarget> {
        self.leg.as_ref().map(|(_, t)| t)
    }

    /// Where the current leg starts.
    pub fn leg_start(&self) -> Option<Ned> {
        self.leg.as_ref().map(|(s, _)| s.start)
    }

    pub fn status(&self) -> &NavStatus {
        &self.status
    }

    /// The leg is done: stopped at its end, or (driving through) within
    /// `WP_RADIUS` or past it.
    pub fn arrived(&self) -> bool {
        self.arrived
    }

    pub fn update(&mut self, est: &Estimate, config: &NavConfig, dt_s: f64) -> NavDemand {
        let Some((segment, target)) = self.leg else {
            self.status = NavStatus::default();
            return NavDemand::default();
        };
        let pose = VehiclePose {
            position: est.position,
            yaw_rad: est.yaw_rad,
        };
        let projection = segment.project(&est.position);
        let remaining = projection.length_m - projection.along_m;
        let wp_dist = est.position.distance_to(&target.point);

        let done = if target.stop {
            remaining <= ARRIVED_M
        } else {
            remaining <= 0.0 || wp_dist <= config.wp_radius_m
        };
        self.arrived |= done;
        let tracker = track_segment(
            &config.tracker,
            &mut self.tracker,
            &pose,
            est.speed_mps,
            &segment,
            target.direction,
            dt_s,
        );

        self.status = NavStatus {
            active: true,
            wp_dist_m: wp_dist,
            target_bearing_rad: est.position.bearing_to(&target.point),
            nav_bearing_rad: wrap_pi(pose.yaw_rad + tracker.steer_rad),
            crosstrack_m: tracker.crosstrack_m,
            reached: self.status.reached || wp_dist <= config.wp_radius_m || self.arrived,
            tracker,
        };
        if self.arrived && target.stop {
            return NavDemand::default();
        }
        let limits = SpeedLimits {
            cruise_mps: target.speed_mps.unwrap_or(config.speed.cruise_mps),
            ..config.speed
        };
        // Driving through, there is nothing to brake for at this leg's end.
        let to_stop = if target.stop { remaining } else { f64::INFINITY };
        let speed = scheduled_speed(&limits, to_stop, tracker.dyaw_rad);
        NavDemand {
            steer_rad: tracker.steer_rad,
            speed_mps: match target.direction {
                Direction::Forward => speed,
                Direction::Reverse => -speed,
            },
        }
    }
}
