//! The fault table: the AGV course driven in AUTO in-process (simulated
//! time, wall time following it), one fault injected through its `SIM_*`
//! parameter 20 s in, and what must follow: the failsafe's action within
//! its deadline, then the mission finished (resumed by `FS_RESUME`, or by
//! the operator selecting AUTO again, as the failsafe demands) with the
//! mission and parameters intact.

use mavlink::dialects::ardupilotmega::MavMessage;
use mission::{ExecState, MissionType, Plan};

use super::Row;
use crate::bench::tracking::load_courses;
use crate::modes::Mode;
use crate::sitl::gcs;
use crate::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};
use crate::time::FrozenTimer;

/// What must be seen after the fault.
#[derive(Clone, Copy, Debug)]
enum Expect {
    /// The mode becomes this.
    Mode(Mode),
    /// The vehicle is disarmed.
    Disarmed,
    /// The true speed drops below this while the mission goes on.
    SlowerThan(f64),
    /// Nothing visible: the vehicle keeps within this of its path.
    StaysOnPath(f64),
    /// HOLD within the deadline of the path error passing this.
    HoldOffPath(f64),
}

struct Scenario {
    name: &'static str,
    /// Settings before the run (the operator's configuration).
    setup: &'static [(&'static str, f64)],
    inject: &'static [(&'static str, f64)],
    /// Undone this long after the injection (timed faults clear themselves).
    clear_after_s: f64,
    clear: &'static [(&'static str, f64)],
    expect: Expect,
    deadline_s: f64,
    /// The failsafe's STATUSTEXT (a prefix), if the link is up to carry it.
    text: Option<&'static str>,
}

const SCENARIOS: &[Scenario] = &[
    Scenario {
        name: "GNSS drop (SIM_GPS_DISABLE)",
        setup: &[("FS_RESUME", 1.0)],
        inject: &[("SIM_GPS_DISABLE", 1.0)],
        clear_after_s: 10.0,
        clear: &[("SIM_GPS_DISABLE", 0.0)],
        expect: Expect::Mode(Mode::Hold),
        deadline_s: 1.5,
        // The EKF, left without fixes, may give up first: either stops.
        text: Some("Failsafe: "),
    },
    Scenario {
        name: "fix downgrade to RTK float",
        setup: &[],
        inject: &[("SIM_GPS_QUALITY", 5.0)],
        clear_after_s: 15.0,
        clear: &[("SIM_GPS_QUALITY", 4.0)],
        expect: Expect::SlowerThan(0.6),
        deadline_s: 3.0,
        text: Some("GPS fix degraded: speed limited"),
    },
    Scenario {
        name: "fix downgrade to single",
        setup: &[],
        inject: &[("SIM_GPS_QUALITY", 1.0)],
        clear_after_s: 10.0,
        clear: &[("SIM_GPS_QUALITY", 4.0)],
        expect: Expect::Mode(Mode::Hold),
        deadline_s: 0.5,
        text: Some("GPS fix degraded: HOLD"),
    },
    Scenario {
        name: "position jump 3 m (SIM_GPS_GLITCH_E)",
        setup: &[],
        inject: &[("SIM_GPS_GLITCH_E", 3.0)],
        clear_after_s: 2.0,
        clear: &[("SIM_GPS_GLITCH_E", 0.0)],
        expect: Expect::StaysOnPath(0.15),
        deadline_s: 0.5,
        text: Some("EKF: GPS jump"),
    },
    Scenario {
        name: "heading lost (SIM_HDG_ENABLE 0)",
        setup: &[("FS_RESUME", 1.0)],
        inject: &[("SIM_HDG_ENABLE", 0.0)],
        clear_after_s: 10.0,
        clear: &[("SIM_HDG_ENABLE", 1.0)],
        expect: Expect::Mode(Mode::Hold),
        deadline_s: 1.5,
        text: Some("Failsafe: heading lost: HOLD"),
    },
    Scenario {
        name: "heading freeze (SIM_HDG_FREEZE)",
        setup: &[],
        inject: &[("SIM_HDG_FREEZE", 1.0)],
        clear_after_s: 10.0,
        clear: &[("SIM_HDG_FREEZE", 0.0)],
        expect: Expect::Mode(Mode::Hold),
        deadline_s: 1.5,
        text: Some("Failsafe: heading lost: HOLD"),
    },
    Scenario {
        name: "scanner stall (SIM_SCAN_DISABLE 1)",
        setup: &[("FS_RESUME", 1.0)],
        inject: &[("SIM_SCAN_DISABLE", 1.0)],
        clear_after_s: 8.0,
        clear: &[("SIM_SCAN_DISABLE", 0.0)],
        expect: Expect::Mode(Mode::Hold),
        deadline_s: 1.5,
        text: Some("Failsafe: scanner stale: HOLD"),
    },
    Scenario {
        name: "steering stuck (SIM_ACT_STUCK 1), FS_XTRACK_M 2",
        setup: &[("FS_XTRACK_M", 2.0)],
        inject: &[("SIM_ACT_STUCK", 1.0)],
        clear_after_s: 15.0,
        clear: &[("SIM_ACT_STUCK", 0.0)],
        expect: Expect::HoldOffPath(2.0),
        deadline_s: 1.2,
        text: Some("Failsafe: off the path: HOLD"),
    },
    Scenario {
        name: "throttle stuck (SIM_ACT_STUCK 2)",
        setup: &[],
        inject: &[("SIM_ACT_STUCK", 2.0), ("MODE", 4.0)],
        clear_after_s: 10.0,
        clear: &[("SIM_ACT_STUCK", 0.0)],
        expect: Expect::Disarmed,
        deadline_s: 3.5,
        text: Some("Failsafe: vehicle does not stop: disarm"),
    },
    Scenario {
        name: "link loss 8 s (SIM_LINK_DROP), FS_GCS_ENABLE 1",
        setup: &[("FS_GCS_ENABLE", 1.0)],
        inject: &[("SIM_LINK_DROP", 8.0)],
        clear_after_s: 8.0,
        clear: &[],
        expect: Expect::Mode(Mode::Hold),
        deadline_s: 5.6,
        text: None,
    },
    Scenario {
        name: "core stall 400 ms (SIM_CPU_STALL)",
        setup: &[],
        inject: &[("SIM_CPU_STALL", 400.0)],
        clear_after_s: 1.0,
        clear: &[],
        expect: Expect::Mode(Mode::Hold),
        deadline_s: 0.5,
        text: Some("Failsafe: core stalled"),
    },
    Scenario {
        name: "battery low (SIM_BATT_VOLT 45 < 46 V)",
        setup: &[
            ("BATT_LOW_VOLT", 46.0),
            ("BATT_CRT_VOLT", 44.0),
            ("BATT_FS_LOW_ACT", 2.0),
        ],
        inject: &[("SIM_BATT_VOLT", 45.0)],
        clear_after_s: 15.0,
        clear: &[("SIM_BATT_VOLT", 0.0)],
        expect: Expect::Mode(Mode::Hold),
        deadline_s: 10.5,
        text: Some("Failsafe: battery low: HOLD"),
    },
    Scenario {
        name: "battery critical (SIM_BATT_VOLT 43 < 44 V)",
        setup: &[
            ("BATT_LOW_VOLT", 46.0),
            ("BATT_CRT_VOLT", 44.0),
            ("BATT_FS_CRT_ACT", 5.0),
        ],
        inject: &[("SIM_BATT_VOLT", 43.0)],
        clear_after_s: 15.0,
        clear: &[("SIM_BATT_VOLT", 0.0)],
        expect: Expect::Disarmed,
        deadline_s: 10.5,
        text: Some("Failsafe: battery critical: disarm"),
    },
];

const INJECT_AT_S: f64 = 20.0;
const MISSION_LIMIT_S: f64 = 600.0;

pub fn run(seed: u64) -> Result<Vec<Row>, String> {
    let course = load_courses(&[])?
        .into_iter()
        .find(|c| c.name == "agv_course")
        .ok_or("the built-in AGV course is missing")?;
    let mut rows = Vec::new();
    for scenario in SCENARIOS {
        rows.push(run_scenario(scenario, &course, seed)?);
    }
    Ok(rows)
}

struct Drive {
    sim: Simulation,
    timer: FrozenTimer,
    texts: Vec<String>,
    next_heartbeat_s: f64,
}

impl Drive {
    fn t(&self) -> f64 {
        self.sim.time().as_secs_f64()
    }

    /// One tick, a GCS heartbeat every second (as any ground station).
    fn step(&mut self) {
        if self.t() >= self.next_heartbeat_s {
            gcs::send(&mut self.sim, gcs::heartbeat());
            self.next_heartbeat_s = self.t() + 1.0;
        }
        let wall = self.sim.time();
        let out = self.sim.step(wall, &mut self.timer);
        for o in out.mavlink.drain(..) {
            if let MavMessage::STATUSTEXT(t) = o.message {
                self.texts.push(t.text.to_str().unwrap_or("").to_string());
            }
        }
    }

    fn set(&mut self, name: &str, value: f64) -> Result<(), String> {
        if name == "MODE" {
            gcs::send(&mut self.sim, gcs::set_mode(value as u32));
            return Ok(());
        }
        self.sim
            .core_mut()
            .params_mut()
            .set_by_name(name, value)
            .map(|_| ())
            .map_err(|e| format!("{name} = {value}: {e:?}"))
    }

    fn crosstrack_m(&self) -> f64 {
        self.sim.core().navigator().status().crosstrack_m.abs()
    }
}

fn run_scenario(s: &Scenario, course: &crate::bench::tracking::Course, seed: u64) -> Result<Row, String> {
    let config = SimulationConfig {
        home: course.home,
        model: ModelKind::Ackermann,
        seed,
        ..SimulationConfig::default()
    };
    let mut sim = Simulation::new(&config, SimulationParams::new(config.model));
    let plan = Plan::new(MissionType::Mission, course.items.clone());
    sim.core_mut().load_plan(MissionType::Mission, plan.clone());
    gcs::connect(&mut sim);
    let mut d = Drive {
        sim,
        timer: FrozenTimer,
        texts: Vec::new(),
        next_heartbeat_s: 0.0,
    };
    for (name, value) in s.setup {
        d.set(name, *value)?;
    }
    let params_before: Vec<(String, f64)> = snapshot(&d.sim);
    while d.t() < 5.0 {
        d.step();
    }
    gcs::send(&mut d.sim, gcs::set_mode(10));
    gcs::send(&mut d.sim, gcs::arm());
    let start = d.t();
    while d.t() < start + INJECT_AT_S {
        d.step();
    }
    if !(d.sim.core().is_armed() && d.sim.core().mode() == Mode::Auto) {
        return Err(format!("{}: not driving AUTO before the fault: {:?}", s.name, d.texts));
    }
    let seq_at_fault = d.sim.core().mission_current_seq();
    let inject_t = d.t();
    for (name, value) in s.inject {
        d.set(name, *value)?;
    }
    let texts_before = d.texts.len();
    // The action, within the deadline (looked for a little past it, to say
    // how late a late one was).
    let mut acted_after: Option<f64> = None;
    let mut off_path_at: Option<f64> = None;
    let mut worst_xtrack_m: f64 = 0.0;
    let mut cleared = false;
    let look_until = inject_t + s.deadline_s.max(s.clear_after_s) + 5.0;
    while d.t() < look_until {
        d.step();
        if !cleared && d.t() >= inject_t + s.clear_after_s {
            for (name, value) in s.clear {
                d.set(name, *value)?;
            }
            cleared = true;
        }
        let core = d.sim.core();
        let seen = match s.expect {
            Expect::Mode(mode) => core.mode() == mode,
            Expect::Disarmed => !core.is_armed(),
            Expect::SlowerThan(mps) => core.mode() == Mode::Auto && d.sim.world().truth().speed_mps < mps,
            Expect::HoldOffPath(limit_m) => {
                if off_path_at.is_none() && core.mode() == Mode::Auto && d.crosstrack_m() > limit_m {
                    off_path_at = Some(d.t());
                }
                core.mode() == Mode::Hold
            }
            Expect::StaysOnPath(_) => {
                if d.t() <= inject_t + s.clear_after_s {
                    worst_xtrack_m = worst_xtrack_m.max(d.crosstrack_m());
                }
                false
            }
        };
        if seen && acted_after.is_none() {
            acted_after = Some(d.t() - inject_t);
        }
        if cleared
            && (acted_after.is_some() || matches!(s.expect, Expect::StaysOnPath(_)))
            && d.t() > inject_t + s.deadline_s
        {
            break;
        }
    }
    let said = match s.text {
        Some(prefix) => d.texts[texts_before..].iter().any(|t| t.starts_with(prefix)),
        None => true,
    };
    let action_ok = match s.expect {
        Expect::StaysOnPath(limit) => worst_xtrack_m <= limit,
        Expect::HoldOffPath(_) => match (off_path_at, acted_after) {
            (Some(off), Some(acted)) => inject_t + acted - off <= s.deadline_s,
            _ => false,
        },
        _ => acted_after.is_some_and(|t| t <= s.deadline_s),
    };
    // Then finish the mission: resumed by itself, or by the operator.
    let mut operator_actions = Vec::new();
    let mission_end = d.t() + MISSION_LIMIT_S;
    let mut quiet_since = d.t();
    while d.t() < mission_end && d.sim.core().mission_state() != ExecState::Complete {
        d.step();
        let core = d.sim.core();
        let stopped = !core.is_armed() || core.mode() != Mode::Auto;
        if !stopped {
            quiet_since = d.t();
        } else if d.t() - quiet_since > 5.0 {
            if !core.is_armed() {
                gcs::send(&mut d.sim, gcs::set_mode(10));
                gcs::send(&mut d.sim, gcs::arm());
                operator_actions.push("re-arm");
            } else {
                gcs::send(&mut d.sim, gcs::set_mode(10));
                operator_actions.push("AUTO");
            }
            quiet_since = d.t();
            if operator_actions.len() > 5 {
                break;
            }
        }
    }
    let completed = d.sim.core().mission_state() == ExecState::Complete;
    let plan_intact = *d.sim.core().plan(MissionType::Mission) == plan;
    let mut params_after = snapshot(&d.sim);
    // The fault parameters themselves are what the test changed.
    params_after.retain(|(n, _)| !n.starts_with("SIM_"));
    let mut params_before = params_before;
    params_before.retain(|(n, _)| !n.starts_with("SIM_"));
    let params_intact = params_after == params_before;
    let resumed_from = d.sim.core().mission_current_seq();
    let outcome = if completed {
        let how = if operator_actions.is_empty() {
            "went on by itself".to_string()
        } else {
            format!("operator: {}", operator_actions.join(", "))
        };
        format!("completed ({how}; stopped at item {seq_at_fault})")
    } else {
        format!("NOT completed (item {resumed_from}, {:?})", d.sim.core().mode())
    };
    let action = match (s.expect, acted_after) {
        (Expect::StaysOnPath(_), _) => format!("max |xtrack| {:.3} m during the jump", worst_xtrack_m),
        (Expect::HoldOffPath(limit_m), Some(t)) => match off_path_at {
            Some(off) => format!(
                "off the path by {limit_m} m {:.2} s after the fault, HOLD {:.2} s later",
                off - inject_t,
                inject_t + t - off
            ),
            None => format!("HOLD after {t:.2} s without leaving the path"),
        },
        (_, Some(t)) => format!("acted after {t:.2} s"),
        (_, None) => "no action".to_string(),
    };
    let expected = match s.expect {
        Expect::Mode(m) => format!("{m} within {:.1} s", s.deadline_s),
        Expect::Disarmed => format!("disarm within {:.1} s", s.deadline_s),
        Expect::SlowerThan(v) => format!("AUTO slowed < {v} m/s within {:.1} s", s.deadline_s),
        Expect::StaysOnPath(m) => format!("jump rejected, |xtrack| <= {m} m"),
        Expect::HoldOffPath(m) => format!("HOLD within {:.1} s of |xtrack| > {m} m", s.deadline_s),
    };
    let ok = action_ok && said && completed && plan_intact && params_intact;
    Ok(Row {
        part: "fault",
        case: s.name.to_string(),
        expected,
        measured: format!(
            "{action}; text {}; {outcome}; mission {}, params {}",
            match (s.text, said) {
                (None, _) => "none (link down)",
                (Some(_), true) => "sent",
                (Some(_), false) => "MISSING",
            },
            if plan_intact { "intact" } else { "CHANGED" },
            if params_intact { "intact" } else { "CHANGED" }
        ),
        ok,
    })
}

fn snapshot(sim: &Simulation) -> Vec<(String, f64)> {
    let table = sim.core().params();
    (0..table.len() as u16)
        .map(|i| (table.def(i).name.to_string(), table.value(i)))
        .collect()
}
