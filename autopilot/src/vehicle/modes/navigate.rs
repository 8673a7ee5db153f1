//! GUIDED, RTL and AUTO: drive to the navigator's target. GUIDED's target
//! comes from the ground station, RTL's is home, AUTO's the mission's
//! current item (`auto.rs`); the driving is one and the same.

use mavlink::dialects::ardupilotmega::MavSeverity;

use crate::guidance::manoeuvre::plan_preferring;
use crate::guidance::navigator::StopReport;
use crate::guidance::reeds_shepp::Pose;
use crate::modes::Mode;
use crate::vehicle::Core;
use crate::vehicle::drive::Demand;

/// A stop should settle within this long of first coming within
/// `SETTLE_ZONE_M` of its point; one that takes longer says why.
const SETTLE_TARGET_S: f64 = 8.0;

impl Core {
    /// This tick's demand while no obstacle stops the vehicle.
    pub(super) fn navigate_demand(&mut self, dt_s: f64) -> Demand {
        self.maybe_plan_detour(false);
        let was_arrived = self.navigator.arrived();
        let config = self.nav_config();
        let estimate = *self.estimator.estimate();
        let nav = self.navigator.update(&estimate, &config, dt_s);
        let report = self.navigator.take_stop_report().map(|r| self.against_pose_goal(r));
        if let Some(report) = &report {
            self.report_stop(report);
            if let Some(seq) = report.seq.filter(|_| !self.retry_mission_stop(report)) {
                self.goals.missed_seq = report.seq.filter(|_| !report.within_tolerance);
                self.goals.unconfirmed_seq = None;
                if self.unconfirmed_pose_stop(report) {
                    self.confirm_mission_stop(report, seq);
                }
            }
        }
        self.advance_detour();
        // AUTO reports its own arrivals (MISSION_ITEM_REACHED).
        if self.mode != Mode::Auto && self.navigator.arrived() && !was_arrived && self.navigator.target().is_some() {
            self.announce_arrival(report.as_ref());
        } else if self.goals.confirming.is_some() {
            self.confirm_arrival(dt_s);
        }
        // Arrived (or nothing to do): stop outright, so no integrator
        // keeps the wheels creeping.
        let stopped = self.navigator.stopping() || self.navigator.pivot_resting();
        if self.navigator.target().is_some() && !stopped {
            Demand::Navigate(nav)
        } else {
            Demand::Stop
        }
    }

    /// A mission stop that ended out of tolerance gets one more try, as a
    /// GUIDED or RTL goal does: a manoeuvre from where the vehicle rests
    /// onto the stop's pose (a leg that could not converge, say after a
    /// corner too sharp to round, leaves no room to correct otherwise).
    /// True when the retry is under way: the stop is not reported yet.
    fn retry_mission_stop(&mut self, report: &StopReport) -> bool {
        let Some(seq) = report.seq else {
            return false;
        };
        if self.mode != Mode::Auto || report.within_tolerance || self.missions.stop_retried == Some(seq) {
            return false;
        }
        self.missions.stop_retried = Some(seq);
        if let Some(why) = self.miss_in_doubt(report) {
            self.send_text(
                MavSeverity::MAV_SEVERITY_WARNING,
                &format!("Waypoint #{seq} missed, no retry: the miss is within {why}"),
            );
            return false;
        }
        let estimate = self.estimator.estimate();
        let start = Pose {
            position: estimate.position,
            yaw_rad: estimate.yaw_rad,
        };
        let goal = report.goal;
        let config = self.manoeuvre_config_on_the_way();
        // Of the ways onto the stop, one that meets nothing standing.
        match plan_preferring(&start, goal.position, Some(goal.yaw_rad), &config, |m| {
            self.manoeuvre_clear(m, config.radius_m)
        }) {
            Ok(manoeuvre) => {
                self.send_text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    // Under STATUSTEXT's 50 characters.
                    &format!(
                        "Waypoint #{seq} missed: retry {:.1} m, {} reversals",
                        manoeuvre.length_m(),
                        manoeuvre.direction_changes()
                    ),
                );
                self.navigator
                    .set_manoeuvre(manoeuvre, self.missions.speed_mps, Some(seq));
                true
            }
            Err(why) => {
                self.send_text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    &format!("Waypoint #{seq} missed, no retry: {why}"),
                );
                false
            }
        }
    }

    /// A mission stop with a heading (a pose goal) in tolerance by the
    /// estimate, which cannot confirm it yet (its σ reaches past the
    /// tolerance): it waits for the verdict as GUIDED's stop does. A stop
    /// without a heading is reported reached by the estimate's verdict
    /// alone: the mission's progress, as ArduPilot's.
    fn unconfirmed_pose_stop(&self, report: &StopReport) -> bool {
        let pose_stop = self.goals.goal.is_some_and(|g| g.seq.is_some() && g.seq == report.seq);
        pose_stop
            && report.within_tolerance
            && self
                .unconfirmed_because(report.position_error_m(), report.yaw_error_rad)
                .is_some()
    }

    /// The achieved stop error, as the estimate has it once the vehicle
    /// rests: what an integrator checks a docking against. A stop in
    /// tolerance the estimate is not sure of says so, with the σ that keeps
    /// it from being confirmed (AUTO still reports a stop without a heading
    /// reached: the estimate's verdict is its progress signal, as
    /// ArduPilot's; a pose stop is not claimed); a stop
    /// that took longer than [`SETTLE_TARGET_S`] to settle says what it
    /// spent the time on.
    fn report_stop(&mut self, report: &StopReport) {
        self.log_stop_report(report);
        let which = report.seq.map_or(String::new(), |seq| format!(" #{seq}"));
        let mut verdict = String::from(if report.within_tolerance {
            "in tolerance"
        } else {
            "OUT of tolerance"
        });
        if report.within_tolerance
            && let Some(why) = self.unconfirmed_because(report.position_error_m(), report.yaw_error_rad)
        {
            verdict.push_str(&format!(", unconfirmed ({why})"));
        }
        if report.settle_s > SETTLE_TARGET_S {
            let why = settle_reason(report);
            verdict.push_str(&format!(", settled in {:.1} s: {why}", report.settle_s));
        }
        let text = format!(
            "Stop{which}: {:.1} mm, yaw {:.3} deg, {verdict}",
            report.position_error_m() * 1000.0,
            report.yaw_error_rad.to_degrees()
        );
        let severity = if report.within_tolerance {
            MavSeverity::MAV_SEVERITY_INFO
        } else {
            MavSeverity::MAV_SEVERITY_WARNING
        };
        self.send_text(severity, &text);
        if let Some(truth) = self.true_stop_text(report) {
            self.send_text(MavSeverity::MAV_SEVERITY_INFO, &truth);
        }
    }
}

/// What a stop that settled slowly spent its time on: the turn on the spot
/// onto the heading (from the point, however far it had to turn), the
/// re-approaches, or else the final creep.
fn settle_reason(report: &StopReport) -> String {
    let creeps = match report.reapproaches {
        0 => None,
        1 => Some(String::from("1 re-approach")),
        n => Some(format!("{n} re-approaches")),
    };
    match (report.turn_s > 0.0, creeps) {
        (true, Some(creeps)) => format!("{creeps}, turn on the spot {:.1} s", report.turn_s),
        (true, None) => format!("turn on the spot {:.1} s", report.turn_s),
        (false, Some(creeps)) => creeps,
        (false, None) => String::from("slow final creep"),
    }
}
