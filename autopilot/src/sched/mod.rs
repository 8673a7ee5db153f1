//! The scheduler: a table of tasks with their rate and time budget, as
//! ArduPilot Rover's `SCHED_TASK(fn, hz, max_us)` table, plus statistics.
//!
//! The core runs the table once per step. A task is due when its period has
//! elapsed on its clock: vehicle time for control work, wall time for what a
//! ground station paces against. Durations come from an injected
//! [`TaskTimer`](crate::time::TaskTimer); a task that runs longer than its
//! budget counts an overrun.

mod stats;

use std::time::Duration;

pub use stats::{DurationHistogram, TaskStats};

/// Which clock a task's period is measured on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TaskClock {
    Boot,
    Wall,
}

/// How often a task runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TaskRate {
    /// Every core step (`SCHED_LOOP_RATE`).
    EveryTick,
    Hz(f64),
}

/// What the core does in a task.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TaskId {
    LinkEvents,
    GcsReceive,
    ReadSensors,
    UpdateMode,
    SetServos,
    GcsStreams,
    Heartbeat,
    OneSecond,
}

#[derive(Clone, Copy, Debug)]
pub struct TaskSpec {
    pub id: TaskId,
    pub name: &'static str,
    pub rate: TaskRate,
    pub budget_us: u32,
    pub clock: TaskClock,
}

const fn task(id: TaskId, name: &'static str, rate: TaskRate, budget_us: u32, clock: TaskClock) -> TaskSpec {
    TaskSpec {
        id,
        name,
        rate,
        budget_us,
        clock,
    }
}

/// The core's task table, run in this order each step.
pub const TASKS: &[TaskSpec] = &[
    task(
        TaskId::LinkEvents,
        "link_events",
        TaskRate::EveryTick,
        50,
        TaskClock::Boot,
    ),
    task(
        TaskId::GcsReceive,
        "gcs_receive",
        TaskRate::EveryTick,
        500,
        TaskClock::Boot,
    ),
    task(
        TaskId::ReadSensors,
        "read_sensors",
        TaskRate::EveryTick,
        300,
        TaskClock::Boot,
    ),
    task(
        TaskId::UpdateMode,
        "update_mode",
        TaskRate::EveryTick,
        300,
        TaskClock::Boot,
    ),
    task(
        TaskId::SetServos,
        "set_servos",
        TaskRate::EveryTick,
        100,
        TaskClock::Boot,
    ),
    task(
        TaskId::GcsStreams,
        "gcs_streams",
        TaskRate::Hz(50.0),
        1000,
        TaskClock::Wall,
    ),
    task(TaskId::Heartbeat, "heartbeat", TaskRate::Hz(1.0), 200, TaskClock::Wall),
    task(TaskId::OneSecond, "one_second", TaskRate::Hz(1.0), 500, TaskClock::Boot),
];

/// Decides which tasks are due and keeps per-task statistics.
pub struct Scheduler {
    next_due: Vec<Option<Duration>>,
    stats: Vec<TaskStats>,
    tick: TaskStats,
}

impl Default for Scheduler {
    fn default() -> Self {
        Self::new()
    }
}

impl Scheduler {
    pub fn new() -> Self {
        Scheduler {
            next_due: vec![None; TASKS.len()],
            stats: TASKS.iter().map(|t| TaskStats::new(t.budget_us)).collect(),
            tick: TaskStats::new(0),
        }
    }

    /// Whether task `i` of [`TASKS`] runs in this step; if so its next due
    /// time is advanced by whole periods (no drift, no bursts after a stall).
    pub fn is_due(&mut self, i: usize, boot: Duration, wall: Duration) -> bool {
        let spec = &TASKS[i];
        let period = match spec.rate {
            TaskRate::EveryTick => return true,
            TaskRate::Hz(hz) => crate::time::duration_from_secs(1.0 / hz),
        };
        let now = match spec.clock {
            TaskClock::Boot => boot,
            TaskClock::Wall => wall,
        };
        match self.next_due[i] {
            Some(due) if now < due => false,
            Some(due) => {
                let mut next = due + period;
                if next <= now {
                    next = now + period;
                }
                self.next_due[i] = Some(next);
                true
            }
            None => {
                self.next_due[i] = Some(now + period);
                true
            }
        }
    }

    /// Records how long task `i` took.
    pub fn record(&mut self, i: usize, elapsed_ns: u64) {
        self.stats[i].record(elapsed_ns);
    }

    /// Records how long a whole step took (the figure the benchmark prints).
    pub fn record_tick(&mut self, elapsed_ns: u64) {
        self.tick.record(elapsed_ns);
    }

    pub fn task_stats(&self) -> impl Iterator<Item = (&'static TaskSpec, &TaskStats)> {
        TASKS.iter().zip(self.stats.iter())
    }

    pub fn tick_stats(&self) -> &TaskStats {
        &self.tick
    }

    /// Overruns summed over all tasks.
    pub fn total_overruns(&self) -> u64 {
        self.stats.iter().map(|s| s.overruns).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn index_of(id: TaskId) -> usize {
        TASKS.iter().position(|t| t.id == id).unwrap()
    }

    #[test]
    fn every_tick_tasks_always_run() {
        let mut s = Scheduler::new();
        let i = index_of(TaskId::UpdateMode);
        for k in 0..10 {
            assert!(s.is_due(i, Duration::from_millis(20 * k), Duration::ZERO));
        }
    }

    #[test]
    fn one_hz_boot_task_runs_once_per_boot_second() {
        let mut s = Scheduler::new();
        let i = index_of(TaskId::OneSecond);
        let runs = (0..250)
            .filter(|k| s.is_due(i, Duration::from_millis(20 * k), Duration::ZERO))
            .count();
        assert_eq!(runs, 5, "t = 0, 1, 2, 3, 4 s");
    }

    #[test]
    fn wall_task_ignores_boot_time() {
        let mut s = Scheduler::new();
        let i = index_of(TaskId::Heartbeat);
        assert!(s.is_due(i, Duration::ZERO, Duration::ZERO));
        // 1000 simulated seconds pass in 10 ms of wall time: no extra heartbeats.
        let runs = (1..=1000)
            .filter(|k| s.is_due(i, Duration::from_secs(*k), Duration::from_micros(10 * k)))
            .count();
        assert_eq!(runs, 0);
        assert!(s.is_due(i, Duration::from_secs(1001), Duration::from_secs(1)));
    }

    #[test]
    fn a_stall_does_not_cause_a_burst() {
        let mut s = Scheduler::new();
        let i = index_of(TaskId::Heartbeat);
        assert!(s.is_due(i, Duration::ZERO, Duration::ZERO));
        assert!(s.is_due(i, Duration::ZERO, Duration::from_secs(10)));
        assert!(!s.is_due(i, Duration::ZERO, Duration::from_millis(10_500)));
    }

    #[test]
    fn overruns_are_counted_against_the_budget() {
        let mut s = Scheduler::new();
        let i = index_of(TaskId::SetServos);
        s.record(i, 50_000);
        s.record(i, 150_000);
        assert_eq!(s.total_overruns(), 1);
    }
}
