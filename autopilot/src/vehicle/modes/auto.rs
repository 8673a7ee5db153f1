//! AUTO: the mission executor's actions carried out by the vehicle, and the
//! mission telemetry (MISSION_CURRENT, MISSION_ITEM_REACHED).

use mavlink::dialects::ardupilotmega::{
    MISSION_CURRENT_DATA, MISSION_ITEM_REACHED_DATA, MavMessage, MavSeverity, MissionState as MavMissionState,
};
use mission::command::Position;
use mission::{Action, ExecState, MissionType, VehicleReport, interpret_rally};

use crate::geo::{GeoPoint, Ned};
use crate::guidance::navigator::NavTarget;
use crate::guidance::tracker::Direction;
use crate::modes::Mode;
use crate::vehicle::{Core, Destination};

impl Core {
    /// The local position a mission position stands for (`Current`: where
    /// the vehicle is).
    pub(in crate::vehicle) fn resolve(&self, p: &Position) -> Option<Ned> {
        let frame = self.frame()?;
        Some(match *p {
            Position::Global { lat_e7, lon_e7 } => frame.to_local(&GeoPoint::from_e7(lat_e7, lon_e7, 0.0)),
            Position::Local { north_m, east_m } => Ned::new(north_m, east_m),
            Position::Current => self.estimator.estimate().position,
        })
    }

    /// Where RTL goes: the nearest rally point, else home.
    pub(in crate::vehicle) fn rtl_target(&self) -> Option<GeoPoint> {
        let here = self.estimator.estimate().position;
        let frame = self.frame()?;
        let nearest_rally = self
            .missions
            .plan(MissionType::Rally)
            .items()
            .iter()
            .filter_map(|i| interpret_rally(i).ok())
            .filter_map(|r| self.resolve(&r.position))
            .min_by(|a, b| here.distance_to(a).total_cmp(&here.distance_to(b)));
        match nearest_rally {
            Some(p) => Some(frame.to_geodetic(&p)),
            None => self.home,
        }
    }

    /// The heading (local frame) a mission stop is to end facing: its
    /// NAV_WAYPOINT param 4 when `MNV_WP_YAW` is set.
    fn mission_stop_yaw(&self, leg: &mission::NavLeg, to: Ned) -> Option<f64> {
        let yaw_deg = leg
            .yaw_deg
            .filter(|_| leg.stop && self.p.manoeuvre.mission_yaw.get(&self.params))?;
        let at = self.frame()?.to_geodetic(&to);
        self.local_yaw(&at, f64::from(yaw_deg).to_radians())
    }

    /// AUTO entered: start the mission, or resume it (`MIS_RESTART` 0).
    pub(in crate::vehicle) fn start_mission(&mut self) {
        let restart = self.p.mission.restart.get(&self.params);
        if restart || self.missions.executor.state() != ExecState::Running {
            self.missions.speed_mps = None;
        }
        let mut actions = Vec::new();
        self.missions.executor.start(self.now.boot, restart, &mut actions);
        self.apply_mission_actions(actions);
    }

    /// One AUTO step of the executor.
    pub(in crate::vehicle) fn run_mission(&mut self) {
        // A stop with a heading: its straight leg ended, the manoeuvre onto
        // the heading starts, and the mission waits for it.
        self.turn_after_mission_leg();
        let status = self.navigator.status();
        let report = VehicleReport {
            // On a detour the leg's waypoint is not reached yet, nor a pose
            // stop still waiting for its verdict.
            arrived: self.navigator.arrived() && !self.obstacles.detouring() && !self.confirming_mission_stop(),
            distance_to_destination_m: status.wp_dist_m,
            utc_time_of_day_s: self
                .estimator
                .gnss()
                .utc_now_us(self.now.boot)
                .map(|us| ((us / 1_000_000).rem_euclid(86_400)) as u32),
        };
        let mut actions = Vec::new();
        self.missions.executor.update(self.now.boot, &report, &mut actions);
        self.apply_mission_actions(actions);
    }

    /// The vehicle's side of each executor action: one arm per `Action`
    /// variant, so the list of what a mission can do reads in one place.
    fn apply_mission_actions(&mut self, actions: Vec<Action>) {
        for action in actions {
            match action {
                Action::Navigate(leg) => self.apply_navigate(leg),
                Action::Hold => self.navigator.clear(),
                Action::ReturnToLaunch => {
                    if let Some(target) = self.rtl_target() {
                        self.navigate_to(target, self.rtl_yaw(&target), self.missions.speed_mps);
                    }
                }
                Action::SetSpeed(speed) => {
                    self.missions.speed_mps = speed.map(f64::from);
                    self.navigator.set_speed(self.missions.speed_mps);
                }
                Action::SetServo { channel, pwm_us } => self.apply_set_servo(channel, pwm_us),
                Action::SetRelay { relay, state } => {
                    let bit = 1u16 << relay.min(15);
                    self.missions.relays_used |= bit;
                    match state {
                        0 => self.missions.relays_on &= !bit,
                        1 => self.missions.relays_on |= bit,
                        _ => self.missions.relays_on ^= bit,
                    }
                }
                Action::SetHome(position) => self.apply_set_home(position),
                Action::Reached(seq) if self.goals.missed_seq == Some(seq) => {
                    self.goals.missed_seq = None;
                    self.send_text(
                        MavSeverity::MAV_SEVERITY_WARNING,
                        &format!("Waypoint #{seq} NOT reached: stop out of tolerance"),
                    );
                }
                Action::Reached(seq) if self.goals.unconfirmed_seq == Some(seq) => {
                    self.goals.unconfirmed_seq = None;
                    self.send_text(
                        MavSeverity::MAV_SEVERITY_INFO,
                        &format!("Waypoint #{seq} not claimed: stop unconfirmed"),
                    );
                }
                Action::Reached(seq) => {
                    self.send(
                        Destination::AllLinks,
                        MavMessage::MISSION_ITEM_REACHED(MISSION_ITEM_REACHED_DATA { seq }),
                    );
                    self.send_text(MavSeverity::MAV_SEVERITY_INFO, &format!("Reached waypoint #{seq}"));
                }
                Action::CurrentChanged(_) => self.send_mission_current_if_changed(),
                Action::Complete => {
                    self.send_text(MavSeverity::MAV_SEVERITY_INFO, "Mission Complete");
                    self.send_mission_current_if_changed();
                    // MIS_DONE_BEHAVE 3: MANUAL; 0 (and LOITER/ACRO, which
                    // Furrow does not have) hold position in AUTO.
                    if self.mode == Mode::Auto && self.p.mission.done_behave.get(&self.params) == 3 {
                        self.enter_mode(Mode::Manual);
                    }
                }
            }
        }
    }

    /// A NAV leg: to a mission pose when the stop has a heading, else a
    /// navigator target from the leg's start (or here).
    fn apply_navigate(&mut self, leg: mission::NavLeg) {
        // A new leg (a DO_JUMP may come back to the same item): its stop
        // has its one retry again, whichever way it is driven.
        self.missions.stop_retried = None;
        // Its changes of direction (and a retry's limit) count from here,
        // and a verdict still pending on the last stop is moot.
        self.navigator.count_directions_afresh();
        self.goals.confirming = None;
        let here = self.estimator.estimate().position;
        let (Some(to), from) = (self.resolve(&leg.to), leg.from.and_then(|p| self.resolve(&p))) else {
            return;
        };
        let next = leg.next.and_then(|p| self.resolve(&p));
        let speed_mps = self.missions.speed_mps;
        if let Some(yaw_rad) = self.mission_stop_yaw(&leg, to)
            && self.navigate_to_mission_pose(to, yaw_rad, speed_mps, leg.seq)
        {
            return;
        }
        self.goals.goal = None;
        let target = NavTarget {
            point: to,
            speed_mps: self.missions.speed_mps,
            direction: if leg.reverse {
                Direction::Reverse
            } else {
                Direction::Forward
            },
            stop: leg.stop,
            next,
            seq: Some(leg.seq),
        };
        self.navigator.set_target(from.unwrap_or(here), target);
    }

    /// DO_SET_SERVO: the pulse is kept for the output either way; the GCS
    /// is told only for a channel no function owns.
    fn apply_set_servo(&mut self, channel: u8, pwm_us: u16) {
        let owned = self
            .p
            .servos
            .config(&self.params)
            .channels
            .get(usize::from(channel).wrapping_sub(1))
            .is_some_and(|ch| !ch.function.accepts_direct_pulse());
        if let Some(slot) = self.missions.servo_us.get_mut(usize::from(channel) - 1) {
            *slot = pwm_us;
        }
        // A channel a function owns is refused (and said so) when
        // the outputs are set.
        if !owned {
            self.send_text(
                MavSeverity::MAV_SEVERITY_INFO,
                &format!("Servo {channel} set to {pwm_us}"),
            );
        }
    }

    /// DO_SET_HOME: here, or the item's position.
    fn apply_set_home(&mut self, position: Option<Position>) {
        let home = match position {
            None => {
                self.set_home_to_current(true);
                return;
            }
            Some(p) => self
                .resolve(&p)
                .zip(self.frame())
                .map(|(local, f)| f.to_geodetic(&local)),
        };
        if let Some(mut home) = home {
            home.alt_m = self.estimator.gnss().alt_msl_m;
            self.set_home(home, true);
        }
    }

    /// MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT.
    pub(in crate::vehicle) fn set_mission_current(&mut self, seq: u16, reset_jumps: bool) -> bool {
        let running = self.mode == Mode::Auto;
        let mut actions = Vec::new();
        let ok = self
            .missions
            .executor
            .set_current(self.now.boot, seq, reset_jumps, running, &mut actions);
        self.apply_mission_actions(actions);
        if ok {
            self.missions.last_current_sent = None;
            self.send_mission_current_if_changed();
        }
        ok
    }

    /// The MISSION_SET_CURRENT message: no ACK in the protocol, so success
    /// shows as MISSION_CURRENT and failure as a STATUSTEXT.
    pub(in crate::vehicle) fn mission_set_current_message(&mut self, seq: u16) {
        if !self.set_mission_current(seq, false) {
            self.send_text(
                MavSeverity::MAV_SEVERITY_WARNING,
                &format!("Mission item #{seq} does not exist"),
            );
        }
    }

    /// A plan was replaced (upload, clear, import); the derived state is
    /// already rebuilt.
    pub(in crate::vehicle) fn plan_changed(&mut self, mission_type: mission::MissionType) {
        let running = self.mode == Mode::Auto && mission_type == MissionType::Mission;
        if running {
            // The mission being driven is gone: stop rather than guess
            // where the new one starts.
            self.send_text(MavSeverity::MAV_SEVERITY_WARNING, "Mission changed while in AUTO: HOLD");
            self.enter_mode(Mode::Hold);
        }
        if mission_type == MissionType::Mission {
            self.send_mission_current_if_changed();
        }
    }

    fn send_mission_current_if_changed(&mut self) {
        let current = (self.missions.executor.current(), self.missions.executor.state());
        if self.missions.last_current_sent != Some(current) {
            self.missions.last_current_sent = Some(current);
            self.send(
                Destination::AllLinks,
                MavMessage::MISSION_CURRENT(self.mission_current()),
            );
        }
    }

    /// MISSION_CURRENT with the mavlink.io extension fields (total excludes
    /// home, mission state and mode, the three plans' opaque ids).
    pub(in crate::vehicle) fn mission_current(&self) -> MISSION_CURRENT_DATA {
        let ex = &self.missions.executor;
        let has_mission = self.missions.plan(MissionType::Mission).len() > 1;
        let mission_state = match (has_mission, ex.state()) {
            (false, _) => MavMissionState::MISSION_STATE_NO_MISSION,
            (true, ExecState::NotStarted) => MavMissionState::MISSION_STATE_NOT_STARTED,
            (true, ExecState::Complete) => MavMissionState::MISSION_STATE_COMPLETE,
            (true, ExecState::Running) if self.mode == Mode::Auto => MavMissionState::MISSION_STATE_ACTIVE,
            (true, ExecState::Running) => MavMissionState::MISSION_STATE_PAUSED,
        };
        MISSION_CURRENT_DATA {
            seq: if has_mission { ex.current() } else { 0 },
            total: if has_mission { ex.total() } else { u16::MAX },
            mission_state,
            mission_mode: if self.mode == Mode::Auto { 1 } else { 2 },
            mission_id: self.missions.plan(MissionType::Mission).opaque_id(),
            fence_id: self.missions.plan(MissionType::Fence).opaque_id(),
            rally_points_id: self.missions.plan(MissionType::Rally).opaque_id(),
        }
    }
}
