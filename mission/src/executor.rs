//! The mission executor: walks a validated mission plan, AP_Mission style,
//! as a pure state machine. The vehicle reports how its current leg is
//! going ([`VehicleReport`]); the executor answers with [`Action`]s.
//!
//! Sequencing (ArduPilot's): NAV items drive the vehicle one at a time. DO
//! and CONDITION items between two NAV items run one after another once the
//! NAV item before them completes (at mission start, those before the first
//! NAV item run at once); a CONDITION item holds back the DO items after it
//! until it is met. DO_JUMP is followed while looking for the next NAV item,
//! each jump item counting its own repeats.
//!
//! Where the vehicle stops: at a waypoint with a hold time, before a change
//! of direction (DO_SET_REVERSE between two NAV items), at the last NAV
//! item, and before a loiter, delay or RTL. Elsewhere it drives through the
//! waypoint (reached within `WP_RADIUS`) onto the next leg.

use std::collections::BTreeMap;
use std::time::Duration;

use crate::command::{MissionCommand, Position, interpret_mission};
use crate::item::Plan;
use crate::seconds::duration_from_secs;

/// A leg to drive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NavLeg {
    /// The NAV item's seq.
    pub seq: u16,
    /// The previous NAV item's position (the leg starts there), if any.
    pub from: Option<Position>,
    pub to: Position,
    /// The position after this one, when the vehicle drives through.
    pub next: Option<Position>,
    pub reverse: bool,
    /// Stop exactly at `to` (a precision stop) rather than drive through.
    pub stop: bool,
    /// A stop's heading (NAV_WAYPOINT param 4, true, degrees), if given.
    pub yaw_deg: Option<f32>,
}

/// What the vehicle should do.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    Navigate(NavLeg),
    /// Stop and stay (NAV_DELAY, the end of the mission).
    Hold,
    ReturnToLaunch,
    /// DO_CHANGE_SPEED: `None` returns to the default.
    SetSpeed(Option<f32>),
    SetServo {
        channel: u8,
        pwm_us: u16,
    },
    SetRelay {
        relay: u8,
        state: u8,
    },
    SetHome(Option<Position>),
    /// A NAV item was reached (MISSION_ITEM_REACHED, "Reached waypoint #n").
    Reached(u16),
    /// The current NAV item changed (MISSION_CURRENT).
    CurrentChanged(u16),
    /// The last item is done.
    Complete,
}

/// How the current leg is going.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VehicleReport {
    /// At the leg's end: stopped there when it stops, within the waypoint
    /// radius (or past it) when it drives through.
    pub arrived: bool,
    /// Distance left to the current NAV item's position.
    pub distance_to_destination_m: f64,
    /// UTC seconds since midnight, when known (NAV_DELAY until a time).
    pub utc_time_of_day_s: Option<u32>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExecState {
    NotStarted,
    Running,
    Complete,
}

/// The NAV item being executed.
#[derive(Clone, Copy, Debug)]
struct ActiveNav {
    seq: u16,
    command: MissionCommand,
    /// Where its leg starts (kept so a resumed leg is the same leg).
    from: Option<Position>,
    reached_at: Option<Duration>,
}

/// A DO_REPEAT_SERVO in progress.
#[derive(Clone, Copy, Debug)]
struct Repeat {
    channel: u8,
    pwm_us: u16,
    toggles_left: u32,
    period: Duration,
    next_at: Duration,
    high: bool,
}

/// An item's seconds as a `Duration`. Validation bounds them to a day;
/// saturating here too, so no value an executor is given can panic.
fn seconds(s: f32) -> Duration {
    duration_from_secs(f64::from(s))
}

pub struct MissionExecutor {
    commands: Vec<Option<MissionCommand>>,
    state: ExecState,
    /// Where the next search for a NAV item starts.
    cursor: u16,
    nav: Option<ActiveNav>,
    /// Pending DO/CONDITION seqs for the current NAV item, in order.
    pending_do: Vec<u16>,
    /// When the item at the head of `pending_do` became the head (a
    /// CONDITION_DELAY counts from then).
    condition_since: Option<Duration>,
    jumps_left: BTreeMap<u16, i32>,
    reverse: bool,
    last_nav_position: Option<Position>,
    repeat: Option<Repeat>,
    /// The trim a repeated servo returns to (ArduPilot cycles pwm ↔ trim).
    servo_trim_us: u16,
    /// The NAV item started last: what MISSION_CURRENT keeps reporting once
    /// the mission is complete (as ArduPilot, whose nav index stays there).
    last_nav_seq: Option<u16>,
}

impl MissionExecutor {
    /// An executor for `plan` (item 0 is home and not executed). Items that
    /// do not interpret (a plan is validated before it gets here) are
    /// skipped.
    pub fn new(plan: &Plan) -> MissionExecutor {
        let count = u16::try_from(plan.len()).unwrap_or(u16::MAX);
        let commands = plan
            .items()
            .iter()
            .enumerate()
            .map(|(i, item)| {
                if i == 0 {
                    None
                } else {
                    interpret_mission(item, count).ok()
                }
            })
            .collect();
        MissionExecutor {
            commands,
            state: ExecState::NotStarted,
            cursor: 1,
            nav: None,
            pending_do: Vec::new(),
            condition_since: None,
            jumps_left: BTreeMap::new(),
            reverse: false,
            last_nav_position: None,
            repeat: None,
            servo_trim_us: 1500,
            last_nav_seq: None,
        }
    }

    pub fn state(&self) -> ExecState {
        self.state
    }

    /// Items after home (MISSION_CURRENT's `total`).
    pub fn total(&self) -> u16 {
        u16::try_from(self.commands.len().saturating_sub(1)).unwrap_or(u16::MAX)
    }

    /// Whether there is anything to drive.
    pub fn has_nav_items(&self) -> bool {
        self.commands.iter().flatten().any(MissionCommand::is_nav)
    }

    /// The current item: the NAV item in progress, else where the next
    /// search starts; once complete, the last NAV item driven (never past
    /// the last item: mavlink.io's "on last item, seq == total").
    pub fn current(&self) -> u16 {
        match (self.state, self.nav) {
            (_, Some(nav)) => nav.seq,
            (ExecState::Complete, None) => self.last_nav_seq.unwrap_or(self.cursor).min(self.total()),
            _ => self.cursor,
        }
    }

    /// Whether the vehicle is driving in reverse on this leg.
    pub fn reverse(&self) -> bool {
        self.reverse
    }

    /// Starts or resumes running (AUTO entered):
    /// - `restart`, or a finished mission: from item 1, jump counters and
    ///   direction reset;
    /// - not started: from the current item (item 1, or where
    ///   MISSION_SET_CURRENT put it);
    /// - paused (AUTO left mid-mission): the NAV item in progress again, on
    ///   the same leg (ArduPilot's `MIS_RESTART` 0).
    pub fn start(&mut self, now: Duration, restart: bool, actions: &mut Vec<Action>) {
        match self.state {
            _ if restart => self.reset_progress(1),
            ExecState::Complete => self.reset_progress(1),
            ExecState::NotStarted => self.reset_progress(self.cursor),
            ExecState::Running => {
                if let Some(nav) = self.nav.take() {
                    self.state = ExecState::Running;
                    self.cursor = nav.seq;
                    self.last_nav_position = nav.from;
                    self.start_nav(now, nav.seq, nav.command, actions);
                    return;
                }
            }
        }
        self.state = ExecState::Running;
        self.advance(now, actions);
    }

    fn reset_progress(&mut self, cursor: u16) {
        self.cursor = cursor;
        self.nav = None;
        self.pending_do.clear();
        self.condition_since = None;
        self.jumps_left.clear();
        self.reverse = false;
        self.last_nav_position = None;
        self.repeat = None;
        self.last_nav_seq = None;
        self.state = ExecState::NotStarted;
    }

    /// Makes `seq` the current item (MISSION_SET_CURRENT). Returns false if
    /// there is no such item.
    pub fn set_current(
        &mut self,
        now: Duration,
        seq: u16,
        reset_jumps: bool,
        running: bool,
        actions: &mut Vec<Action>,
    ) -> bool {
        if seq == 0 || usize::from(seq) >= self.commands.len() {
            return false;
        }
        if reset_jumps {
            self.jumps_left.clear();
        }
        self.nav = None;
        self.pending_do.clear();
        self.condition_since = None;
        self.cursor = seq;
        if self.state == ExecState::Complete {
            self.state = ExecState::NotStarted;
        }
        if running {
            self.state = ExecState::Running;
            self.advance(now, actions);
        } else {
            actions.push(Action::CurrentChanged(seq));
        }
        true
    }

    /// One step while running.
    pub fn update(&mut self, now: Duration, report: &VehicleReport, actions: &mut Vec<Action>) {
        if self.state != ExecState::Running {
            return;
        }
        self.run_repeat(now, actions);
        if let Some(nav) = self.nav
            && self.nav_complete(now, report, actions)
        {
            // DO items after it start now; then the next leg. The report
            // describes the finished leg, so conditions wait for the next.
            self.nav = None;
            self.cursor = nav.seq.saturating_add(1);
            self.advance(now, actions);
            return;
        }
        self.run_do(now, report, actions);
    }

    /// Whether the active NAV item is done; reports the reach once.
    fn nav_complete(&mut self, now: Duration, report: &VehicleReport, actions: &mut Vec<Action>) -> bool {
        let Some(nav) = self.nav.as_mut() else { return false };
        let hold = match nav.command {
            MissionCommand::Waypoint { hold_s, .. } => Some(seconds(hold_s)),
            MissionCommand::LoiterTime { seconds: s, .. } => Some(seconds(s)),
            MissionCommand::ReturnToLaunch => Some(Duration::ZERO),
            MissionCommand::LoiterUnlimited { .. } => None,
            MissionCommand::Delay { seconds: Some(s), .. } => {
                let started = *nav.reached_at.get_or_insert(now);
                return now.saturating_sub(started) >= seconds(s);
            }
            MissionCommand::Delay {
                until_utc_s: Some(t), ..
            } => {
                return report.utc_time_of_day_s.is_some_and(|u| u >= t);
            }
            _ => Some(Duration::ZERO),
        };
        if nav.reached_at.is_none() && report.arrived {
            nav.reached_at = Some(now);
            actions.push(Action::Reached(nav.seq));
        }
        match (hold, nav.reached_at) {
            (Some(hold), Some(at)) => now.saturating_sub(at) >= hold,
            _ => false,
        }
    }

    /// Finds the next NAV item from the cursor, following jumps; DO items on
    /// the way are queued to run now.
    fn advance(&mut self, now: Duration, actions: &mut Vec<Action>) {
        let mut seq = self.cursor;
        let mut guard = 0usize;
        loop {
            guard += 1;
            if usize::from(seq) >= self.commands.len() || guard > 100_000 {
                self.finish(actions);
                return;
            }
            match self.commands[usize::from(seq)] {
                Some(MissionCommand::Jump { target, repeat }) => {
                    let left = self.jumps_left.entry(seq).or_insert(repeat);
                    if *left != 0 {
                        if *left > 0 {
                            *left -= 1;
                        }
                        seq = target;
                    } else {
                        seq = seq.saturating_add(1);
                    }
                }
                Some(command) if command.is_nav() => {
                    self.start_nav(now, seq, command, actions);
                    return;
                }
                Some(_) => {
                    self.pending_do.push(seq);
                    seq = seq.saturating_add(1);
                }
                None => seq = seq.saturating_add(1),
            }
        }
    }

    fn start_nav(&mut self, now: Duration, seq: u16, command: MissionCommand, actions: &mut Vec<Action>) {
        // DO items before this leg that change direction or speed must act
        // before it starts.
        self.run_leading_dos(now, actions);
        self.nav = Some(ActiveNav {
            seq,
            command,
            from: self.last_nav_position,
            reached_at: None,
        });
        self.cursor = seq;
        self.last_nav_seq = Some(seq);
        actions.push(Action::CurrentChanged(seq));
        match command {
            MissionCommand::Waypoint {
                position,
                hold_s,
                yaw_deg,
            } => {
                let stop = hold_s > 0.0 || self.stops_after(seq);
                let next = if stop { None } else { self.next_nav_position(seq) };
                actions.push(Action::Navigate(NavLeg {
                    seq,
                    from: self.last_nav_position,
                    to: position,
                    next,
                    reverse: self.reverse,
                    stop,
                    yaw_deg: yaw_deg.filter(|_| stop),
                }));
                self.last_nav_position = Some(position);
            }
            MissionCommand::LoiterUnlimited { position } | MissionCommand::LoiterTime { position, .. } => {
                actions.push(Action::Navigate(NavLeg {
                    seq,
                    from: self.last_nav_position,
                    to: position,
                    next: None,
                    reverse: self.reverse,
                    stop: true,
                    yaw_deg: None,
                }));
                self.last_nav_position = Some(position);
            }
            MissionCommand::ReturnToLaunch => {
                actions.push(Action::ReturnToLaunch);
                self.last_nav_position = None;
            }
            MissionCommand::Delay { .. } => {
                if let Some(nav) = self.nav.as_mut() {
                    nav.reached_at = Some(now);
                }
                actions.push(Action::Hold);
            }
            _ => {}
        }
    }

    /// Runs queued DO items that come before any condition, so a
    /// DO_SET_REVERSE or DO_CHANGE_SPEED just before a NAV item applies to it.
    fn run_leading_dos(&mut self, now: Duration, actions: &mut Vec<Action>) {
        while let Some(&seq) = self.pending_do.first() {
            match self.commands[usize::from(seq)] {
                Some(MissionCommand::ConditionDelay { .. } | MissionCommand::ConditionDistance { .. }) => {
                    self.condition_since = Some(now);
                    return;
                }
                Some(command) => {
                    self.pending_do.remove(0);
                    self.do_command(now, command, actions);
                }
                None => {
                    self.pending_do.remove(0);
                }
            }
        }
    }

    /// Runs pending DO items, respecting conditions.
    fn run_do(&mut self, now: Duration, report: &VehicleReport, actions: &mut Vec<Action>) {
        while let Some(&seq) = self.pending_do.first() {
            match self.commands[usize::from(seq)] {
                Some(MissionCommand::ConditionDelay { seconds: s }) => {
                    let since = *self.condition_since.get_or_insert(now);
                    if now.saturating_sub(since) < seconds(s) {
                        return;
                    }
                }
                Some(MissionCommand::ConditionDistance { metres })
                    if self.nav.is_some() && report.distance_to_destination_m > f64::from(metres) =>
                {
                    return;
                }
                Some(command) => self.do_command(now, command, actions),
                None => {}
            }
            self.pending_do.remove(0);
            self.condition_since = Some(now);
        }
    }

    fn do_command(&mut self, now: Duration, command: MissionCommand, actions: &mut Vec<Action>) {
        match command {
            MissionCommand::ChangeSpeed { speed_mps } => actions.push(Action::SetSpeed(speed_mps)),
            MissionCommand::SetReverse { reverse } => self.reverse = reverse,
            MissionCommand::SetHome { position } => actions.push(Action::SetHome(position)),
            MissionCommand::SetServo { channel, pwm_us } => actions.push(Action::SetServo { channel, pwm_us }),
            MissionCommand::SetRelay { relay, state } => actions.push(Action::SetRelay { relay, state }),
            MissionCommand::RepeatServo {
                channel,
                pwm_us,
                count,
                period_s,
            } => {
                actions.push(Action::SetServo { channel, pwm_us });
                let period = seconds(period_s / 2.0);
                self.repeat = Some(Repeat {
                    channel,
                    pwm_us,
                    toggles_left: u32::from(count).saturating_mul(2).saturating_sub(1),
                    period,
                    next_at: now.saturating_add(period),
                    high: true,
                });
            }
            _ => {}
        }
    }

    fn run_repeat(&mut self, now: Duration, actions: &mut Vec<Action>) {
        let Some(r) = self.repeat.as_mut() else { return };
        while r.toggles_left > 0 && now >= r.next_at {
            r.high = !r.high;
            let pwm_us = if r.high { r.pwm_us } else { self.servo_trim_us };
            actions.push(Action::SetServo {
                channel: r.channel,
                pwm_us,
            });
            r.toggles_left -= 1;
            r.next_at = r.next_at.saturating_add(r.period);
        }
        if r.toggles_left == 0 {
            self.repeat = None;
        }
    }

    fn finish(&mut self, actions: &mut Vec<Action>) {
        self.nav = None;
        self.state = ExecState::Complete;
        actions.push(Action::Hold);
        actions.push(Action::Complete);
    }

    /// Follows the plan from `seq` to the next NAV item the way `advance`
    /// would, without changing anything: (its seq, whether the direction
    /// changes before it).
    fn peek_next_nav(&self, seq: u16) -> Option<(u16, bool)> {
        let mut reverse = self.reverse;
        let mut jumps = self.jumps_left.clone();
        let mut s = seq.saturating_add(1);
        for _ in 0..100_000 {
            match *self.commands.get(usize::from(s))? {
                Some(MissionCommand::Jump { target, repeat }) => {
                    let left = jumps.entry(s).or_insert(repeat);
                    if *left != 0 {
                        if *left > 0 {
                            *left -= 1;
                        }
                        s = target;
                    } else {
                        s = s.saturating_add(1);
                    }
                }
                Some(MissionCommand::SetReverse { reverse: r }) => {
                    reverse = r;
                    s = s.saturating_add(1);
                }
                Some(c) if c.is_nav() => return Some((s, reverse != self.reverse)),
                _ => s = s.saturating_add(1),
            }
        }
        None
    }

    /// Whether the vehicle must stop at the NAV item `seq`.
    fn stops_after(&self, seq: u16) -> bool {
        match self.peek_next_nav(seq) {
            None => true,
            Some((_, true)) => true,
            Some((next, false)) => !matches!(self.commands[usize::from(next)], Some(MissionCommand::Waypoint { .. })),
        }
    }

    fn next_nav_position(&self, seq: u16) -> Option<Position> {
        let (next, _) = self.peek_next_nav(seq)?;
        match self.commands[usize::from(next)]? {
            MissionCommand::Waypoint { position, .. } => Some(position),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::{cmd, frame};
    use crate::item::{MissionItem, MissionType};

    fn item(seq: u16, command: u16, params: [f32; 4], x: i32) -> MissionItem {
        MissionItem {
            seq,
            frame: frame::LOCAL_NED,
            command,
            current: false,
            autocontinue: true,
            params,
            x,
            y: 0,
            z: 0.0,
        }
    }

    fn wp(seq: u16, north_m: i32, hold_s: f32) -> MissionItem {
        item(seq, cmd::NAV_WAYPOINT, [hold_s, 0.0, 0.0, 0.0], north_m * 10_000)
    }

    fn plan(items: Vec<MissionItem>) -> Plan {
        Plan::new(MissionType::Mission, items)
    }

    fn home() -> MissionItem {
        wp(0, 0, 0.0)
    }

    fn ms(v: u64) -> Duration {
        Duration::from_millis(v)
    }

    fn arrived() -> VehicleReport {
        VehicleReport {
            arrived: true,
            ..VehicleReport::default()
        }
    }

    fn driving(distance: f64) -> VehicleReport {
        VehicleReport {
            arrived: false,
            distance_to_destination_m: distance,
            utc_time_of_day_s: None,
        }
    }

    fn legs(actions: &[Action]) -> Vec<NavLeg> {
        actions
            .iter()
            .filter_map(|a| if let Action::Navigate(l) = a { Some(*l) } else { None })
            .collect()
    }

    fn reached(actions: &[Action]) -> Vec<u16> {
        actions
            .iter()
            .filter_map(|a| if let Action::Reached(s) = a { Some(*s) } else { None })
            .collect()
    }

    /// Steps, arriving at every leg at once, until complete.
    fn run_to_end(ex: &mut MissionExecutor) -> Vec<Action> {
        let mut all = Vec::new();
        ex.start(ms(0), false, &mut all);
        for t in 1..10_000 {
            ex.update(ms(t * 100), &arrived(), &mut all);
            if ex.state() == ExecState::Complete {
                break;
            }
        }
        all
    }

    #[test]
    fn waypoints_in_order_drive_through_and_stop_at_the_last() {
        let mut ex = MissionExecutor::new(&plan(vec![home(), wp(1, 10, 0.0), wp(2, 20, 0.0), wp(3, 30, 0.0)]));
        let actions = run_to_end(&mut ex);
        let l = legs(&actions);
        assert_eq!(l.iter().map(|l| l.seq).collect::<Vec<_>>(), vec![1, 2, 3]);
        assert_eq!(l.iter().map(|l| l.stop).collect::<Vec<_>>(), vec![false, false, true]);
        assert_eq!(
            l[1].from,
            Some(Position::Local {
                north_m: 10.0,
                east_m: 0.0
            })
        );
        assert_eq!(
            l[0].next,
            Some(Position::Local {
                north_m: 20.0,
                east_m: 0.0
            })
        );
        assert_eq!(reached(&actions), vec![1, 2, 3]);
        assert_eq!(actions.last(), Some(&Action::Complete));
    }

    #[test]
    fn a_complete_mission_reports_its_last_nav_item_never_one_past_the_end() {
        let servo = item(3, cmd::DO_SET_SERVO, [9.0, 1900.0, 0.0, 0.0], 0);
        let mut ex = MissionExecutor::new(&plan(vec![home(), wp(1, 10, 0.0), wp(2, 20, 0.0), servo]));
        run_to_end(&mut ex);
        assert_eq!(ex.state(), ExecState::Complete);
        assert_eq!(
            (ex.current(), ex.total()),
            (2, 3),
            "the last NAV item, not the DO after it"
        );
        let mut ex = MissionExecutor::new(&plan(vec![home(), wp(1, 10, 0.0), wp(2, 20, 0.0)]));
        run_to_end(&mut ex);
        assert_eq!(ex.current(), ex.total(), "on the last item seq == total");
        let mut a = Vec::new();
        ex.start(ms(0), false, &mut a);
        assert_eq!(ex.current(), 1, "a restart starts from item 1 again");
    }

    #[test]
    fn do_items_after_a_waypoint_run_when_it_completes_after_its_hold() {
        let servo = item(2, cmd::DO_SET_SERVO, [9.0, 1900.0, 0.0, 0.0], 0);
        let mut ex = MissionExecutor::new(&plan(vec![home(), wp(1, 10, 5.0), servo, wp(3, 20, 0.0)]));
        let mut a = Vec::new();
        ex.start(ms(0), false, &mut a);
        assert!(legs(&a)[0].stop, "a hold stops the vehicle");
        ex.update(ms(1000), &arrived(), &mut a);
        assert_eq!(reached(&a), vec![1]);
        ex.update(ms(5900), &arrived(), &mut a);
        assert!(
            !a.contains(&Action::SetServo {
                channel: 9,
                pwm_us: 1900
            }),
            "not during the hold"
        );
        ex.update(ms(6100), &driving(10.0), &mut a);
        let servo_at = a
            .iter()
            .position(|x| {
                *x == Action::SetServo {
                    channel: 9,
                    pwm_us: 1900,
                }
            })
            .expect("servo fired");
        let next_leg_at = a
            .iter()
            .rposition(|x| matches!(x, Action::Navigate(l) if l.seq == 3))
            .unwrap();
        assert!(servo_at < next_leg_at);
    }

    #[test]
    fn do_jump_repeats_the_right_number_of_times() {
        // 1 wp, 2 wp, 3 jump to 1 twice more, 4 wp
        let jump = item(3, cmd::DO_JUMP, [1.0, 2.0, 0.0, 0.0], 0);
        let mut ex = MissionExecutor::new(&plan(vec![
            home(),
            wp(1, 10, 0.0),
            wp(2, 20, 0.0),
            jump,
            wp(4, 30, 0.0),
        ]));
        let actions = run_to_end(&mut ex);
        assert_eq!(reached(&actions), vec![1, 2, 1, 2, 1, 2, 4]);
    }

    #[test]
    fn reverse_legs_stop_at_the_direction_change() {
        let rev = item(2, cmd::DO_SET_REVERSE, [1.0, 0.0, 0.0, 0.0], 0);
        let fwd = item(4, cmd::DO_SET_REVERSE, [0.0, 0.0, 0.0, 0.0], 0);
        let mut ex = MissionExecutor::new(&plan(vec![
            home(),
            wp(1, 20, 0.0),
            rev,
            wp(3, 10, 0.0),
            fwd,
            wp(5, 30, 0.0),
        ]));
        let l = legs(&run_to_end(&mut ex));
        assert_eq!(
            l.iter().map(|l| (l.seq, l.reverse, l.stop)).collect::<Vec<_>>(),
            vec![(1, false, true), (3, true, true), (5, false, true)]
        );
    }

    #[test]
    fn condition_delay_holds_back_the_do_items_after_it() {
        let delay = item(2, cmd::CONDITION_DELAY, [3.0, 0.0, 0.0, 0.0], 0);
        let relay = item(3, cmd::DO_SET_RELAY, [0.0, 1.0, 0.0, 0.0], 0);
        let mut ex = MissionExecutor::new(&plan(vec![home(), wp(1, 10, 0.0), delay, relay, wp(4, 40, 0.0)]));
        let mut a = Vec::new();
        ex.start(ms(0), false, &mut a);
        ex.update(ms(1000), &arrived(), &mut a);
        ex.update(ms(3000), &driving(20.0), &mut a);
        assert!(!a.contains(&Action::SetRelay { relay: 0, state: 1 }));
        ex.update(ms(4100), &driving(15.0), &mut a);
        assert!(a.contains(&Action::SetRelay { relay: 0, state: 1 }));
    }

    #[test]
    fn condition_distance_waits_until_close() {
        let dist = item(2, cmd::CONDITION_DISTANCE, [5.0, 0.0, 0.0, 0.0], 0);
        let speed = item(3, cmd::DO_CHANGE_SPEED, [1.0, 0.5, 0.0, 0.0], 0);
        let mut ex = MissionExecutor::new(&plan(vec![home(), wp(1, 10, 0.0), dist, speed, wp(4, 40, 0.0)]));
        let mut a = Vec::new();
        ex.start(ms(0), false, &mut a);
        ex.update(ms(100), &arrived(), &mut a);
        ex.update(ms(200), &driving(12.0), &mut a);
        assert!(!a.contains(&Action::SetSpeed(Some(0.5))));
        ex.update(ms(300), &driving(4.0), &mut a);
        assert!(a.contains(&Action::SetSpeed(Some(0.5))));
    }

    #[test]
    fn resume_continues_the_current_leg_and_restart_goes_back() {
        let mut ex = MissionExecutor::new(&plan(vec![home(), wp(1, 10, 0.0), wp(2, 20, 0.0), wp(3, 30, 0.0)]));
        let mut a = Vec::new();
        ex.start(ms(0), false, &mut a);
        ex.update(ms(100), &arrived(), &mut a);
        assert_eq!(ex.current(), 2);
        a.clear();
        ex.start(ms(200), false, &mut a);
        assert_eq!(legs(&a)[0].seq, 2);
        assert_eq!(
            legs(&a)[0].from,
            Some(Position::Local {
                north_m: 10.0,
                east_m: 0.0
            })
        );
        a.clear();
        ex.start(ms(300), true, &mut a);
        assert_eq!(legs(&a)[0].seq, 1);
    }

    #[test]
    fn set_current_moves_the_start() {
        let mut ex = MissionExecutor::new(&plan(vec![home(), wp(1, 10, 0.0), wp(2, 20, 0.0), wp(3, 30, 0.0)]));
        let mut a = Vec::new();
        assert!(ex.set_current(ms(0), 3, false, false, &mut a));
        assert!(!ex.set_current(ms(0), 9, false, false, &mut a));
        ex.start(ms(0), false, &mut a);
        assert_eq!(legs(&a)[0].seq, 3);
    }

    #[test]
    fn repeat_servo_cycles_between_pwm_and_trim() {
        let rep = item(1, cmd::DO_REPEAT_SERVO, [10.0, 1800.0, 3.0, 2.0], 0);
        let mut ex = MissionExecutor::new(&plan(vec![home(), rep, wp(2, 10, 0.0)]));
        let mut a = Vec::new();
        ex.start(ms(0), false, &mut a);
        for t in 1..100 {
            ex.update(ms(t * 100), &driving(5.0), &mut a);
        }
        let pwms: Vec<u16> = a
            .iter()
            .filter_map(|x| {
                if let Action::SetServo { pwm_us, .. } = x {
                    Some(*pwm_us)
                } else {
                    None
                }
            })
            .collect();
        assert_eq!(pwms, vec![1800, 1500, 1800, 1500, 1800, 1500]);
    }

    #[test]
    fn loiter_unlimited_never_completes() {
        let loiter = item(1, cmd::NAV_LOITER_UNLIM, [0.0; 4], 100_000);
        let mut ex = MissionExecutor::new(&plan(vec![home(), loiter, wp(2, 20, 0.0)]));
        let actions = run_to_end(&mut ex);
        assert_eq!(ex.state(), ExecState::Running);
        assert_eq!(reached(&actions), vec![1]);
    }

    #[test]
    fn no_value_in_an_unvalidated_plan_panics() {
        // Plan::new does not validate: the executor must survive what a
        // damaged plan may hold (it skips the items that do not interpret).
        let mut a = Vec::new();
        for bad in [1e20, f32::MAX, f32::INFINITY, f32::NAN, -1.0, -0.0, 1e-30] {
            let items = vec![
                home(),
                wp(1, 10, bad),
                item(2, cmd::NAV_LOITER_TIME, [bad, 0.0, 0.0, 0.0], 10_000),
                item(3, cmd::NAV_DELAY, [bad, 0.0, 0.0, 0.0], 0),
                item(4, cmd::CONDITION_DELAY, [bad, 0.0, 0.0, 0.0], 0),
                item(5, cmd::DO_REPEAT_SERVO, [9.0, 1800.0, 65_535.0, bad], 0),
                item(6, cmd::DO_JUMP, [1.0, bad, 0.0, 0.0], 0),
                wp(7, 20, 0.0),
            ];
            let mut ex = MissionExecutor::new(&plan(items));
            ex.start(ms(0), false, &mut a);
            for t in [1, 2, 3, u64::MAX / 4, u64::MAX / 2] {
                ex.update(Duration::from_millis(t), &arrived(), &mut a);
            }
            ex.update(Duration::MAX, &arrived(), &mut a);
        }
        assert_eq!(seconds(1e20), Duration::MAX);
    }

    #[test]
    fn nav_delay_waits_then_continues() {
        let delay = item(2, cmd::NAV_DELAY, [2.0, 0.0, 0.0, 0.0], 0);
        let mut ex = MissionExecutor::new(&plan(vec![home(), wp(1, 10, 0.0), delay, wp(3, 30, 0.0)]));
        let mut a = Vec::new();
        ex.start(ms(0), false, &mut a);
        ex.update(ms(100), &arrived(), &mut a);
        assert!(a.contains(&Action::Hold));
        ex.update(ms(1500), &arrived(), &mut a);
        assert_eq!(ex.current(), 2);
        ex.update(ms(2200), &arrived(), &mut a);
        assert_eq!(ex.current(), 3);
    }
}
