//! Actions of orders and instant actions (§6.8, §6.11, §6.12): each one's
//! state WAITING → INITIALIZING → RUNNING → FINISHED/FAILED, the blocking
//! rules (NONE drives on, SOFT stops the vehicle, HARD also runs alone), and
//! the outputs a configured action drives (a servo pulse or a relay, as
//! DO_SET_SERVO / DO_SET_RELAY do) for its configured duration.
//!
//! A node counts as traversed while the vehicle may still be rolling onto
//! it, and its actions are triggered then (§6.10.2). A SOFT or HARD action
//! is one the vehicle must not drive during (§6.12): it stays INITIALIZING
//! (triggered, preparing) until the vehicle is at rest, and only then sets
//! its output and RUNS.
//!
//! A pause (startPause) stops the clock of every RUNNING timed action,
//! which reports PAUSED until stopPause resumes it as RUNNING for the time
//! it had left (§6.11, §6.12: "All actions will be paused", a paused pick
//! "continues" after). The standard pauses the process, so an action's
//! output stops what it drives where stopping is possible without moving
//! anything: a relay it switched on goes off (what it powers stops) and is
//! switched on again at the resume; a servo pulse is a position, and any
//! other pulse would move the mechanism while the vehicle stands still, so
//! it holds.
//!
//! Pure and stepped with time in seconds.

use vda5050::common::{Action, BlockingType};
use vda5050::state::{ActionState, ActionStatus};

/// What a configured action sets when it starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ActionOutput {
    /// Servo channel (1-based) to a pulse width.
    Servo { channel: u8, pwm_us: u16 },
    /// Relay (0-based) on or off.
    Relay { relay: u8, on: bool },
}

/// An action type this vehicle carries out with an output.
#[derive(Clone, Debug, PartialEq)]
pub struct ActionMapping {
    pub action_type: String,
    pub output: ActionOutput,
    /// How long the action runs once its output is set.
    pub duration_s: f64,
}

/// The defaults: `pick` raises a lift on servo 9, `drop` lowers it, each
/// taking 3 s (ArduPilot's first free output after the drive channels).
pub fn default_mappings() -> Vec<ActionMapping> {
    vec![
        ActionMapping {
            action_type: "pick".into(),
            output: ActionOutput::Servo {
                channel: 9,
                pwm_us: 1900,
            },
            duration_s: 3.0,
        },
        ActionMapping {
            action_type: "drop".into(),
            output: ActionOutput::Servo {
                channel: 9,
                pwm_us: 1100,
            },
            duration_s: 3.0,
        },
    ]
}

/// Where an action belongs: sent alone, or on a node or edge (sequenceId).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scope {
    Instant,
    Node(u32),
    Edge(u32),
}

#[derive(Clone, Debug)]
struct Tracked {
    action: Action,
    scope: Scope,
    status: ActionStatus,
    /// Its node was reached or its edge entered.
    triggered: bool,
    started_s: Option<f64>,
    /// When a pause stopped its clock.
    paused_s: Option<f64>,
    result: Option<String>,
}

impl Tracked {
    fn done(&self) -> bool {
        matches!(self.status, ActionStatus::Finished | ActionStatus::Failed)
    }

    fn active(&self) -> bool {
        matches!(
            self.status,
            ActionStatus::Initializing | ActionStatus::Running | ActionStatus::Paused
        )
    }
}

/// Every action the vehicle knows of, in the order received.
#[derive(Clone, Debug, Default)]
pub struct ActionRunner {
    actions: Vec<Tracked>,
    /// Bumped on every status change (the state message is sent on change).
    pub generation: u64,
    /// Actions that ran their duration since the last [`Self::take_finished`].
    finished: Vec<Action>,
}

impl ActionRunner {
    /// Actions of an accepted order: WAITING until their node or edge.
    pub fn add_waiting(&mut self, action: &Action, scope: Scope) {
        self.actions.push(Tracked {
            action: action.clone(),
            scope,
            status: ActionStatus::Waiting,
            triggered: false,
            started_s: None,
            paused_s: None,
            result: None,
        });
        self.generation += 1;
    }

    /// An instant action carried out at once, with its final status.
    pub fn add_done(&mut self, action: &Action, status: ActionStatus, result: String) {
        self.actions.push(Tracked {
            action: action.clone(),
            scope: Scope::Instant,
            status,
            triggered: true,
            started_s: None,
            paused_s: None,
            result: Some(result),
        });
        self.generation += 1;
    }

    /// A configured instant action: runs as soon as the blocking rules allow.
    pub fn add_instant(&mut self, action: &Action) {
        self.add_waiting(action, Scope::Instant);
        if let Some(last) = self.actions.last_mut() {
            last.triggered = true;
        }
    }

    /// A new order replaces the old one's finished and failed actions.
    pub fn forget_done(&mut self) {
        self.actions.retain(|a| !a.done());
        self.generation += 1;
    }

    /// The node was reached or the edge entered: its actions may start.
    pub fn trigger(&mut self, scope: Scope) {
        for tracked in self.actions.iter_mut().filter(|a| a.scope == scope) {
            tracked.triggered = true;
        }
    }

    /// The edge was left: what still runs on it is finished (§6.10.2).
    pub fn leave_edge(&mut self, sequence_id: u32) {
        for tracked in &mut self.actions {
            if tracked.scope == Scope::Edge(sequence_id) && tracked.active() {
                tracked.status = ActionStatus::Finished;
                tracked.result = Some("edge left".into());
                self.generation += 1;
            }
        }
    }

    /// cancelOrder: every action not done fails. Returns how many.
    pub fn cancel_all(&mut self) -> usize {
        let mut cancelled = 0;
        for tracked in self
            .actions
            .iter_mut()
            .filter(|a| !a.done() && a.scope != Scope::Instant)
        {
            tracked.status = ActionStatus::Failed;
            tracked.result = Some("order cancelled".into());
            cancelled += 1;
        }
        self.generation += 1;
        cancelled
    }

    /// Whether actions of the order are still to run or running.
    pub fn busy(&self) -> bool {
        self.actions.iter().any(|a| !a.done() && a.scope != Scope::Instant)
    }

    /// Whether a triggered SOFT or HARD action keeps the vehicle still.
    pub fn blocks_driving(&self) -> bool {
        self.actions
            .iter()
            .any(|a| a.triggered && !a.done() && a.action.blocking_type != BlockingType::None)
    }

    /// Whether a SOFT or HARD action RUNS (the vehicle must stand).
    pub fn runs_blocking(&self) -> bool {
        self.actions
            .iter()
            .any(|a| a.status == ActionStatus::Running && a.action.blocking_type != BlockingType::None)
    }

    /// Advances the actions to `now_s`: starts what the blocking rules let
    /// start and moves INITIALIZING to RUNNING (a blocking one only once
    /// the vehicle is `at_rest`), neither while `paused`, and sets its
    /// output, finishes what has run its duration. Returns the outputs to
    /// set.
    pub fn step(&mut self, now_s: f64, paused: bool, at_rest: bool, mappings: &[ActionMapping]) -> Vec<ActionOutput> {
        let mut outputs = Vec::new();
        for i in 0..self.actions.len() {
            let configured = mapping(mappings, &self.actions[i].action.action_type);
            let tracked = &mut self.actions[i];
            let blocking = tracked.action.blocking_type != BlockingType::None;
            match tracked.status {
                ActionStatus::Initializing if !paused && (at_rest || !blocking) => {
                    outputs.extend(configured.map(|m| m.output));
                    tracked.status = ActionStatus::Running;
                    tracked.started_s = Some(now_s);
                    self.generation += 1;
                }
                // Running without a duration (cancelOrder) is finished by
                // whoever started it.
                ActionStatus::Running if tracked.started_s.is_some() => {
                    let started = tracked.started_s.unwrap_or(now_s);
                    if now_s - started >= configured.map_or(0.0, |m| m.duration_s) {
                        tracked.status = ActionStatus::Finished;
                        tracked.result = Some("done".into());
                        self.finished.push(tracked.action.clone());
                        self.generation += 1;
                    }
                }
                _ => {}
            }
        }
        if !paused {
            self.start_ready(mappings);
        }
        outputs
    }

    /// startPause: every RUNNING timed action stops its clock and reports
    /// PAUSED. Returns the outputs to set (a relay it switched on goes off).
    pub fn pause(&mut self, now_s: f64, mappings: &[ActionMapping]) -> Vec<ActionOutput> {
        let mut outputs = Vec::new();
        for tracked in &mut self.actions {
            if tracked.status != ActionStatus::Running || tracked.started_s.is_none() {
                continue;
            }
            tracked.status = ActionStatus::Paused;
            tracked.paused_s = Some(now_s);
            self.generation += 1;
            if let Some(ActionOutput::Relay { relay, on: true }) =
                mapping(mappings, &tracked.action.action_type).map(|m| m.output)
            {
                outputs.push(ActionOutput::Relay { relay, on: false });
            }
        }
        outputs
    }

    /// stopPause: every PAUSED action RUNS again for the time it had left.
    /// Returns the outputs to set again.
    pub fn resume(&mut self, now_s: f64, mappings: &[ActionMapping]) -> Vec<ActionOutput> {
        let mut outputs = Vec::new();
        for tracked in &mut self.actions {
            if tracked.status != ActionStatus::Paused {
                continue;
            }
            let paused_for_s = now_s - tracked.paused_s.take().unwrap_or(now_s);
            tracked.started_s = tracked.started_s.map(|s| s + paused_for_s);
            tracked.status = ActionStatus::Running;
            self.generation += 1;
            outputs.extend(mapping(mappings, &tracked.action.action_type).map(|m| m.output));
        }
        outputs
    }

    /// Starts (INITIALIZING) triggered WAITING actions in sequence: a HARD
    /// one only when nothing runs, and nothing after a HARD one until it is
    /// done.
    fn start_ready(&mut self, mappings: &[ActionMapping]) {
        let mut hard_running = self
            .actions
            .iter()
            .any(|a| a.active() && a.action.blocking_type == BlockingType::Hard);
        let mut any_running = self.actions.iter().any(Tracked::active);
        for tracked in &mut self.actions {
            if hard_running {
                return;
            }
            if !tracked.triggered || tracked.status != ActionStatus::Waiting {
                continue;
            }
            let hard = tracked.action.blocking_type == BlockingType::Hard;
            if hard && any_running {
                return;
            }
            match mapping(mappings, &tracked.action.action_type) {
                Some(_) => tracked.status = ActionStatus::Initializing,
                None => {
                    tracked.status = ActionStatus::Failed;
                    tracked.result = Some("no output configured for this action type".into());
                }
            }
            self.generation += 1;
            any_running = true;
            hard_running = hard;
        }
    }

    /// The actions that finished by running their duration (a pick or a
    /// drop done), since the last call.
    pub fn take_finished(&mut self) -> Vec<Action> {
        std::mem::take(&mut self.finished)
    }

    /// `actionStates` for the state message.
    pub fn states(&self) -> Vec<ActionState> {
        self.actions
            .iter()
            .map(|a| ActionState {
                action_id: a.action.action_id.clone(),
                action_type: Some(a.action.action_type.clone()),
                action_description: a.action.action_description.clone(),
                action_status: a.status,
                result_description: a.result.clone(),
            })
            .collect()
    }

    /// The status of one action (tests, and cancelOrder's own report).
    pub fn status(&self, action_id: &str) -> Option<ActionStatus> {
        self.actions
            .iter()
            .rev()
            .find(|a| a.action.action_id == action_id)
            .map(|a| a.status)
    }

    /// Sets an instant action's final status (cancelOrder once all stopped).
    pub fn finish(&mut self, action_id: &str, status: ActionStatus, result: &str) {
        if let Some(a) = self.actions.iter_mut().rev().find(|a| a.action.action_id == action_id) {
            a.status = status;
            a.result = Some(result.to_owned());
            self.generation += 1;
        }
    }
}

pub fn mapping<'a>(mappings: &'a [ActionMapping], action_type: &str) -> Option<&'a ActionMapping> {
    mappings.iter().find(|m| m.action_type == action_type)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn action(id: &str, kind: &str, blocking: BlockingType) -> Action {
        Action {
            action_type: kind.into(),
            action_id: id.into(),
            action_description: None,
            blocking_type: blocking,
            action_parameters: None,
        }
    }

    #[test]
    fn an_action_runs_waiting_initializing_running_finished_with_its_output() {
        let mut runner = ActionRunner::default();
        let maps = default_mappings();
        runner.add_waiting(&action("p1", "pick", BlockingType::Hard), Scope::Node(2));
        assert!(runner.step(0.0, false, true, &maps).is_empty(), "not triggered yet");
        assert_eq!(runner.status("p1"), Some(ActionStatus::Waiting));
        assert!(!runner.blocks_driving());
        runner.trigger(Scope::Node(2));
        assert!(runner.blocks_driving());
        assert!(runner.step(1.0, false, false, &maps).is_empty(), "no output yet");
        assert_eq!(runner.status("p1"), Some(ActionStatus::Initializing));
        assert!(runner.step(1.1, false, false, &maps).is_empty(), "still rolling");
        assert_eq!(runner.status("p1"), Some(ActionStatus::Initializing));
        assert!(!runner.runs_blocking());
        let out = runner.step(1.2, false, true, &maps);
        assert_eq!(
            out,
            vec![ActionOutput::Servo {
                channel: 9,
                pwm_us: 1900
            }]
        );
        assert_eq!(runner.status("p1"), Some(ActionStatus::Running), "at rest");
        assert!(runner.runs_blocking());
        runner.step(4.1, false, true, &maps);
        assert_eq!(runner.status("p1"), Some(ActionStatus::Running), "3 s from 1.2");
        runner.step(4.2, false, true, &maps);
        assert_eq!(runner.status("p1"), Some(ActionStatus::Finished));
        assert!(!runner.blocks_driving());
        assert!(!runner.busy());
    }

    #[test]
    fn a_hard_action_runs_alone_and_soft_ones_run_together() {
        let mut runner = ActionRunner::default();
        let maps = default_mappings();
        runner.add_waiting(&action("s1", "pick", BlockingType::Soft), Scope::Node(4));
        runner.add_waiting(&action("s2", "drop", BlockingType::Soft), Scope::Node(4));
        runner.add_waiting(&action("h1", "pick", BlockingType::Hard), Scope::Node(4));
        runner.add_waiting(&action("n1", "drop", BlockingType::None), Scope::Node(4));
        runner.trigger(Scope::Node(4));
        runner.step(0.0, false, true, &maps);
        assert_eq!(runner.status("s1"), Some(ActionStatus::Initializing));
        assert_eq!(runner.status("s2"), Some(ActionStatus::Initializing));
        assert_eq!(
            runner.status("h1"),
            Some(ActionStatus::Waiting),
            "waits for the soft ones"
        );
        assert_eq!(
            runner.status("n1"),
            Some(ActionStatus::Waiting),
            "comes after the hard one"
        );
        runner.step(0.1, false, true, &maps);
        assert_eq!(runner.status("s1"), Some(ActionStatus::Running));
        runner.step(3.1, false, true, &maps);
        assert_eq!(runner.status("s1"), Some(ActionStatus::Finished));
        assert_eq!(runner.status("h1"), Some(ActionStatus::Initializing));
        assert_eq!(runner.status("n1"), Some(ActionStatus::Waiting));
        runner.step(3.2, false, true, &maps);
        runner.step(6.2, false, true, &maps);
        assert_eq!(runner.status("h1"), Some(ActionStatus::Finished));
        assert_eq!(runner.status("n1"), Some(ActionStatus::Initializing));
    }

    /// A pause stops the clocks of what runs (PAUSED) and starts nothing,
    /// not even what was INITIALIZING; the resume runs each for what it
    /// had left. A relay switched on is off while paused, a servo holds.
    #[test]
    fn a_pause_stops_the_clocks_of_what_runs_and_the_resume_runs_what_was_left() {
        let mut runner = ActionRunner::default();
        let mut maps = default_mappings();
        let pump_on = ActionOutput::Relay { relay: 2, on: true };
        maps.push(ActionMapping {
            action_type: "pump".into(),
            output: pump_on,
            duration_s: 2.0,
        });
        runner.add_waiting(&action("p1", "pick", BlockingType::Soft), Scope::Node(2));
        runner.add_waiting(&action("w1", "pump", BlockingType::Soft), Scope::Node(2));
        runner.trigger(Scope::Node(2));
        runner.step(0.0, false, true, &maps);
        assert_eq!(runner.step(1.0, false, true, &maps).len(), 2, "both run from 1 s");
        runner.add_waiting(&action("d1", "drop", BlockingType::Soft), Scope::Node(4));
        runner.trigger(Scope::Node(4));
        runner.step(1.5, false, true, &maps);
        assert_eq!(runner.status("d1"), Some(ActionStatus::Initializing));
        let generation = runner.generation;
        assert_eq!(
            runner.pause(2.0, &maps),
            vec![ActionOutput::Relay { relay: 2, on: false }]
        );
        assert!(runner.generation > generation, "the state is sent");
        assert!(runner.step(10.0, true, true, &maps).is_empty());
        for id in ["p1", "w1"] {
            assert_eq!(runner.status(id), Some(ActionStatus::Paused), "{id}");
        }
        assert_eq!(runner.status("d1"), Some(ActionStatus::Initializing), "not started");
        let resumed = runner.resume(10.0, &maps);
        assert!(resumed.contains(&pump_on), "{resumed:?}");
        assert_eq!(runner.status("p1"), Some(ActionStatus::Running));
        runner.step(10.9, false, true, &maps);
        assert_eq!(runner.status("w1"), Some(ActionStatus::Running), "1 s run of 2");
        assert_eq!(runner.status("d1"), Some(ActionStatus::Running));
        runner.step(11.0, false, true, &maps);
        assert_eq!(runner.status("w1"), Some(ActionStatus::Finished));
        runner.step(11.9, false, true, &maps);
        assert_eq!(runner.status("p1"), Some(ActionStatus::Running), "1 s run of 3");
        runner.step(12.0, false, true, &maps);
        assert_eq!(runner.status("p1"), Some(ActionStatus::Finished));
    }

    #[test]
    fn paused_starts_nothing_and_cancel_fails_what_is_left() {
        let mut runner = ActionRunner::default();
        let maps = default_mappings();
        runner.add_waiting(&action("p1", "pick", BlockingType::Hard), Scope::Node(0));
        runner.add_waiting(&action("d1", "drop", BlockingType::Hard), Scope::Node(2));
        runner.trigger(Scope::Node(0));
        assert!(runner.step(0.0, true, true, &maps).is_empty());
        assert_eq!(runner.status("p1"), Some(ActionStatus::Waiting));
        runner.step(0.5, false, true, &maps);
        assert_eq!(runner.cancel_all(), 2);
        assert_eq!(runner.status("p1"), Some(ActionStatus::Failed));
        assert_eq!(runner.status("d1"), Some(ActionStatus::Failed));
        assert!(!runner.busy());
    }

    #[test]
    fn an_action_without_output_fails_and_edge_actions_finish_when_the_edge_is_left() {
        let mut runner = ActionRunner::default();
        let maps = default_mappings();
        runner.add_waiting(&action("x", "beep", BlockingType::None), Scope::Edge(1));
        runner.add_waiting(&action("e", "pick", BlockingType::None), Scope::Edge(3));
        runner.trigger(Scope::Edge(1));
        runner.trigger(Scope::Edge(3));
        runner.step(0.0, false, true, &maps);
        assert_eq!(runner.status("x"), Some(ActionStatus::Failed));
        runner.leave_edge(3);
        assert_eq!(runner.status("e"), Some(ActionStatus::Finished));
    }
}
