//! The fault table: the AGV course driven in AUTO in-process (simulated
//! time, wall time following it), one fault injected through its `SIM_*`
//! parameter 20 s in, and what must follow: the failsafe's action within
//! its deadline; every failsafe that started still on and reported
//! (HEARTBEAT CRITICAL, its SYS_STATUS health bit and EKF flags, sampled
//! every tick) until the fault ends; each cleared, said once, within 1 s of
//! the end; then the mission finished (resumed by `FS_RESUME`, or by the
//! operator selecting AUTO again, as the failsafe demands) with the mission
//! and parameters intact.

use mavlink::dialects::ardupilotmega::{MavCmd, MavMessage, MavState};
use mission::{ExecState, MissionType, Plan};

use super::Row;
use crate::tracking::load_courses;
use autopilot::modes::Mode;
use autopilot::sitl::gcs;
use autopilot::sitl::simulation::{ModelKind, Simulation, SimulationConfig, SimulationParams};
use autopilot::time::FrozenTimer;
use autopilot::vehicle::{Core, Failsafe};

/// A failsafe must be cleared this soon after its fault ends.
const CLEAR_WITHIN_S: f64 = 1.0;
/// "Speed" below which a vehicle is at rest (the runaway failsafe's).
const AT_REST_MPS: f64 = 0.3;
const HEARTBEAT_ID: u32 = 0;
const SYS_STATUS_ID: u32 = 1;
const EKF_STATUS_REPORT_ID: u32 = 193;

/// When the fault is over.
#[derive(Clone, Copy, Debug, PartialEq)]
enum FaultEnd {
    /// When `clear` is applied, or a timed fault runs out (`clear_after_s`).
    Cleared,
    /// When the vehicle truly comes to rest after the failsafe: a stuck
    /// throttle is harmless once the power is cut, "does not stop" is over.
    AtRest,
}

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
    /// A latching failsafe also needs the operator's disarm (`DISARM`).
    clear_after_s: f64,
    clear: &'static [(&'static str, f64)],
    end: FaultEnd,
    /// The failsafes the fault itself causes: each must be on, and
    /// reported, from its start to the fault's end. Any other that starts
    /// (an EKF upset by a jump) only has to clear in time.
    causes: &'static [Failsafe],
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
        end: FaultEnd::Cleared,
        causes: &[Failsafe::GnssLost, Failsafe::HeadingLost, Failsafe::Ekf],
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
        end: FaultEnd::Cleared,
        causes: &[],
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
        end: FaultEnd::Cleared,
        causes: &[],
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
        end: FaultEnd::Cleared,
        causes: &[],
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
        end: FaultEnd::Cleared,
        causes: &[Failsafe::HeadingLost],
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
        end: FaultEnd::Cleared,
        causes: &[Failsafe::HeadingLost],
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
        end: FaultEnd::Cleared,
        causes: &[Failsafe::Scanner],
        expect: Expect::Mode(Mode::Hold),
        deadline_s: 1.5,
        text: Some("Failsafe: scanner stale: HOLD"),
    },
    Scenario {
        name: "steering stuck (SIM_ACT_STUCK 1), FS_XTRACK_M 2",
        setup: &[("FS_XTRACK_M", 2.0)],
        inject: &[("SIM_ACT_STUCK", 1.0)],
        clear_after_s: 20.0,
        clear: &[("SIM_ACT_STUCK", 0.0), ("DISARM", 0.0)],
        end: FaultEnd::Cleared,
        causes: &[Failsafe::Control],
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
        end: FaultEnd::AtRest,
        causes: &[Failsafe::Runaway],
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
        end: FaultEnd::Cleared,
        causes: &[Failsafe::Gcs],
        expect: Expect::Mode(Mode::Hold),
        deadline_s: 5.6,
        text: None,
    },
    Scenario {
        name: "core stall 400 ms (SIM_CPU_STALL)",
        setup: &[],
        inject: &[("SIM_CPU_STALL", 400.0)],
        clear_after_s: 1.0,
        clear: &[("DISARM", 0.0)],
        end: FaultEnd::Cleared,
        causes: &[Failsafe::CoreStall],
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
        clear: &[("SIM_BATT_VOLT", 0.0), ("DISARM", 0.0)],
        end: FaultEnd::Cleared,
        causes: &[Failsafe::BatteryLow],
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
        end: FaultEnd::Cleared,
        causes: &[Failsafe::BatteryLow, Failsafe::BatteryCritical],
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

    /// A parameter, or the operator's `MODE` change or `DISARM`.
    fn set(&mut self, name: &str, value: f64) -> Result<(), String> {
        if name == "MODE" {
            gcs::send(&mut self.sim, gcs::set_mode(value as u32));
            return Ok(());
        }
        if name == "DISARM" {
            let disarm = gcs::command_long(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [0.0; 7]);
            gcs::send(&mut self.sim, disarm);
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

fn run_scenario(s: &Scenario, course: &crate::tracking::Course, seed: u64) -> Result<Row, String> {
    let (mut d, plan, params_before) = drive_auto_until_fault(s, course, seed)?;
    let seq_at_fault = d.sim.core().mission_current_seq();
    let inject_t = d.t();
    for (name, value) in s.inject {
        d.set(name, *value)?;
    }
    let texts_before = d.texts.len();
    let phase = watch_fault(&mut d, s, inject_t)?;
    // The failsafe texts of this fault (a later failsafe, while the mission
    // is finished, is another story).
    let texts_of_fault = d.texts.len();
    let said = match s.text {
        Some(prefix) => d.texts[texts_before..].iter().any(|t| t.starts_with(prefix)),
        None => true,
    };
    let action_ok = match s.expect {
        Expect::StaysOnPath(limit) => phase.worst_xtrack_m <= limit,
        Expect::HoldOffPath(_) => match (phase.off_path_at, phase.acted_after) {
            (Some(off), Some(acted)) => inject_t + acted - off <= s.deadline_s,
            _ => false,
        },
        _ => phase.acted_after.is_some_and(|t| t <= s.deadline_s),
    };
    // Then finish the mission: resumed by itself, or by the operator.
    let (completed, operator_actions) = finish_mission(&mut d)?;

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
    let action = action_text(s, &phase, inject_t);
    let expected = format!(
        "{}; failsafe on while the fault lasts, cleared <= {CLEAR_WITHIN_S} s after",
        expected_action(s)
    );
    let failsafe_texts = &d.texts[texts_before..texts_of_fault];
    let (held, held_ok) = phase.watch.held(s.causes, phase.fault_end);
    let (clearing, clearing_ok) = phase.watch.clearing(phase.fault_end, failsafe_texts);
    let ok = action_ok && said && completed && plan_intact && params_intact && held_ok && clearing_ok;
    Ok(Row {
        part: "fault",
        case: s.name.to_string(),
        expected,
        measured: format!(
            "{action}; text {}; {held}; {clearing}; {outcome}; mission {}, params {}",
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

/// Every parameter by name, as `snapshot` takes them.
type ParamValues = Vec<(String, f64)>;

/// The course loaded, the scenario's setup applied, armed in AUTO and
/// driven until the fault is due; the plan and the parameters before it.
fn drive_auto_until_fault(
    s: &Scenario,
    course: &crate::tracking::Course,
    seed: u64,
) -> Result<(Drive, Plan, ParamValues), String> {
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
    let params_before: ParamValues = snapshot(&d.sim);
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
    Ok((d, plan, params_before))
}

/// What happened from the fault's injection until its failsafes are over.
struct FaultPhase {
    /// Seconds from the injection to the expected action.
    acted_after: Option<f64>,
    /// When the vehicle left the path (`HoldOffPath`).
    off_path_at: Option<f64>,
    /// Largest |crosstrack| while the fault lasted (`StaysOnPath`).
    worst_xtrack_m: f64,
    watch: Watch,
    fault_end: Option<f64>,
}

/// Steps through the fault: clears it after `clear_after_s`, and looks for
/// the action within the deadline (a little past it, to say how late a late
/// one was).
fn watch_fault(d: &mut Drive, s: &Scenario, inject_t: f64) -> Result<FaultPhase, String> {
    let mut acted_after: Option<f64> = None;
    let mut off_path_at: Option<f64> = None;
    let mut worst_xtrack_m: f64 = 0.0;
    let mut cleared = false;
    let mut watch = Watch::default();
    let mut fault_end: Option<f64> = None;
    let look_until = inject_t + s.deadline_s.max(s.clear_after_s) + 5.0;
    while d.t() < look_until {
        d.step();
        if !cleared && d.t() >= inject_t + s.clear_after_s {
            for (name, value) in s.clear {
                d.set(name, *value)?;
            }
            cleared = true;
        }
        if fault_end.is_none() {
            fault_end = match s.end {
                FaultEnd::Cleared => cleared.then(|| d.t()),
                FaultEnd::AtRest => {
                    (watch.any_started() && d.sim.world().truth().speed_mps.abs() <= AT_REST_MPS).then(|| d.t())
                }
            };
        }
        watch.sample(d.sim.core(), d.t(), fault_end);
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
        let failsafes_over = fault_end.is_some_and(|end| watch.all_cleared() || d.t() > end + CLEAR_WITHIN_S + 1.0);
        if cleared
            && failsafes_over
            && (acted_after.is_some() || matches!(s.expect, Expect::StaysOnPath(_)))
            && d.t() > inject_t + s.deadline_s
        {
            break;
        }
    }
    Ok(FaultPhase {
        acted_after,
        off_path_at,
        worst_xtrack_m,
        watch,
        fault_end,
    })
}

/// Drives on until the mission completes, acting as the operator would when
/// the vehicle stands still for 5 s: re-arm, disarm a latched failsafe, or
/// AUTO again. Whether it completed, and what the operator did.
fn finish_mission(d: &mut Drive) -> Result<(bool, Vec<&'static str>), String> {
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
            } else if Failsafe::ALL.into_iter().any(|f| core.failsafe_is_active(f)) {
                // A failsafe that is on refuses AUTO: a latched one ends
                // only with a disarm.
                d.set("DISARM", 0.0)?;
                operator_actions.push("disarm");
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
    Ok((d.sim.core().mission_state() == ExecState::Complete, operator_actions))
}

fn action_text(s: &Scenario, phase: &FaultPhase, inject_t: f64) -> String {
    match (s.expect, phase.acted_after) {
        (Expect::StaysOnPath(_), _) => format!("max |xtrack| {:.3} m during the jump", phase.worst_xtrack_m),
        (Expect::HoldOffPath(limit_m), Some(t)) => match phase.off_path_at {
            Some(off) => format!(
                "off the path by {limit_m} m {:.2} s after the fault, HOLD {:.2} s later",
                off - inject_t,
                inject_t + t - off
            ),
            None => format!("HOLD after {t:.2} s without leaving the path"),
        },
        (_, Some(t)) => format!("acted after {t:.2} s"),
        (_, None) => "no action".to_string(),
    }
}

fn expected_action(s: &Scenario) -> String {
    match s.expect {
        Expect::Mode(m) => format!("{m} within {:.1} s", s.deadline_s),
        Expect::Disarmed => format!("disarm within {:.1} s", s.deadline_s),
        Expect::SlowerThan(v) => format!("AUTO slowed < {v} m/s within {:.1} s", s.deadline_s),
        Expect::StaysOnPath(m) => format!("jump rejected, |xtrack| <= {m} m"),
        Expect::HoldOffPath(m) => format!("HOLD within {:.1} s of |xtrack| > {m} m", s.deadline_s),
    }
}

/// Every failsafe that starts while the fault lasts, sampled every tick.
#[derive(Default)]
struct Watch {
    /// When each started, and when each was first seen off (index:
    /// `Failsafe as usize`).
    started: [Option<f64>; Failsafe::ALL.len()],
    off: [Option<f64>; Failsafe::ALL.len()],
    /// The first tick, before the fault's end, where each was not on or
    /// not reported, and what was wrong.
    lapse: [Option<(f64, &'static str)>; Failsafe::ALL.len()],
    /// Ticks from the first start to the fault's end.
    ticks: u32,
    first_start: Option<f64>,
}

impl Watch {
    fn any_started(&self) -> bool {
        self.first_start.is_some()
    }

    fn started_kinds(&self) -> impl Iterator<Item = Failsafe> + '_ {
        Failsafe::ALL
            .into_iter()
            .filter(|&f| self.started[f as usize].is_some())
    }

    fn all_cleared(&self) -> bool {
        self.started_kinds().all(|f| self.off[f as usize].is_some())
    }

    fn sample(&mut self, core: &Core, t: f64, fault_end: Option<f64>) {
        let ended = fault_end.is_some_and(|end| t >= end);
        for kind in Failsafe::ALL {
            let i = kind as usize;
            let on = core.failsafe_is_active(kind);
            if on && !ended && self.started[i].is_none() {
                self.started[i] = Some(t);
                self.first_start = self.first_start.or(Some(t));
            }
            if self.started[i].is_none() {
                continue;
            }
            if !on && self.off[i].is_none() {
                self.off[i] = Some(t);
            }
            if !ended
                && self.lapse[i].is_none()
                && let Some(what) = unreported(core, kind)
            {
                self.lapse[i] = Some((t, what));
            }
        }
        if !ended && self.any_started() {
            self.ticks += 1;
        }
    }

    /// "Still reported while the fault lasts", for the failsafes it causes.
    fn held(&self, causes: &[Failsafe], fault_end: Option<f64>) -> (String, bool) {
        if causes.is_empty() {
            return ("causes no failsafe".to_string(), true);
        }
        let Some(end) = fault_end else {
            return ("fault never ended".to_string(), false);
        };
        let mut wrong = Vec::new();
        for &kind in causes {
            match (self.started[kind as usize], self.lapse[kind as usize]) {
                (None, _) => wrong.push(format!("{} never on", kind.name())),
                (Some(_), Some((t, what))) => wrong.push(format!(
                    "{} {what} {:.2} s before the fault's end",
                    kind.name(),
                    end - t
                )),
                (Some(_), None) => {}
            }
        }
        if !wrong.is_empty() {
            return (wrong.join(", "), false);
        }
        let start = self.first_start.unwrap_or(end);
        let summary = format!(
            "on and reported every tick ({}, {:.2} s) to the fault's end",
            self.ticks,
            end - start
        );
        (summary, true)
    }

    /// "Cleared within 1 s of the fault's end", each said exactly once
    /// (one that was not the fault's may clear before).
    fn clearing(&self, fault_end: Option<f64>, texts: &[String]) -> (String, bool) {
        let Some(end) = fault_end.filter(|_| self.any_started()) else {
            return (
                "nothing to clear".to_string(),
                fault_end.is_some() || !self.any_started(),
            );
        };
        let mut parts = Vec::new();
        let mut ok = true;
        for kind in self.started_kinds() {
            let said = texts
                .iter()
                .filter(|t| **t == format!("Failsafe cleared: {}", kind.name()))
                .count();
            let part = match self.off[kind as usize] {
                Some(t) => {
                    ok &= t - end <= CLEAR_WITHIN_S && said == 1;
                    if t < end {
                        format!("{} cleared {:.2} s before it, said {said}x", kind.name(), end - t)
                    } else {
                        format!("{} cleared {:.2} s after, said {said}x", kind.name(), t - end)
                    }
                }
                None => {
                    ok = false;
                    format!("{} NOT cleared", kind.name())
                }
            };
            parts.push(part);
        }
        (parts.join(", "), ok)
    }
}

/// What does not say `kind` is on (as the vehicle would report it now).
fn unreported(core: &Core, kind: Failsafe) -> Option<&'static str> {
    if !core.failsafe_is_active(kind) {
        return Some("off");
    }
    let critical = matches!(core.build_requested(HEARTBEAT_ID),
        Some(MavMessage::HEARTBEAT(hb)) if hb.system_status == MavState::MAV_STATE_CRITICAL);
    if !critical {
        return Some("HEARTBEAT not CRITICAL");
    }
    if let Some(sensor) = kind.health_sensor() {
        let healthy = matches!(core.build_requested(SYS_STATUS_ID),
            Some(MavMessage::SYS_STATUS(s)) if s.onboard_control_sensors_health.contains(sensor));
        if healthy {
            return Some("SYS_STATUS healthy");
        }
    }
    let flagged = matches!(core.build_requested(EKF_STATUS_REPORT_ID),
        Some(MavMessage::EKF_STATUS_REPORT(e)) if e.flags.intersects(kind.ekf_flags_withheld()));
    if flagged {
        return Some("EKF flags set");
    }
    None
}

fn snapshot(sim: &Simulation) -> Vec<(String, f64)> {
    let table = sim.core().params();
    (0..table.len() as u16)
        .map(|i| (table.def(i).name.to_string(), table.value(i)))
        .collect()
}
