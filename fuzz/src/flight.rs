//! A mission flown in AUTO, cheaply: the mission executor and the
//! navigator as the core runs them, on a kinematic bicycle with a perfect
//! estimate, for simulated minutes per input. What a ground station could
//! put in a plan, and the vehicle's parameters within their declared
//! ranges, come from the fuzzer; only plans that `validate_plan` accepts
//! are flown (a refused one is still handed to the executor, which must
//! survive it).
//!
//! Properties, besides "no panic":
//! - every output is finite and within its limits (steering within
//!   `VEH_STEER_MAX`, speed within the fastest the plan or WP_SPEED asks,
//!   servo and relay numbers in range);
//! - the vehicle never leaves the fence: an inclusion circle round every
//!   waypoint and home, as wide as the vehicle needs to turn and stop;
//! - a stop always ends in HOLD or the next item: a finished mission holds
//!   (no leg, zero demand), a NAV_DELAY holds, a vehicle stopping at a
//!   waypoint demands nothing until the next item starts.

use std::time::Duration;

use autopilot::control::pid::PidGains;
use autopilot::estimation::Estimate;
use autopilot::fence::Fence;
use autopilot::geo::frame::LocalFrame;
use autopilot::geo::{GeoPoint, Ned, wrap_pi};
use autopilot::guidance::navigator::{NavConfig, NavDemand, NavTarget, Navigator, StopTolerance};
use autopilot::guidance::speed::SpeedConfig;
use autopilot::guidance::tracker::{Direction, TrackerConfig};
use libfuzzer_sys::arbitrary::{Result, Unstructured};
use mission::command::{cmd, frame, limits};
use mission::seconds::duration_from_secs;
use mission::{
    Action, ExecState, MissionExecutor, MissionItem, MissionType, Plan, Position, VehicleReport, validate_plan,
};

/// Simulated time flown per input.
pub const FLIGHT_S: f64 = 150.0;
/// Step while driving, and while holding at rest (long holds cost little).
const DRIVE_DT_S: f64 = 0.2;
const REST_DT_S: f64 = 2.0;
/// Waypoints lie within this of home (local metres).
const WAYPOINT_BOX_M: f64 = 100.0;
const GRAVITY_MPS2: f64 = 9.806_65;

/// Values a ground station might put in a param: the edges of every limit,
/// the specials, and ordinary ones.
const INTERESTING: [f32; 24] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    -2.0,
    0.5,
    2.0,
    3.0,
    5.0,
    16.0,
    1500.0,
    1e-30,
    0.01,
    0.009,
    100.0,
    100.1,
    32_767.0,
    65_535.0,
    limits::MAX_DURATION_S,
    86_401.0,
    1e20,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
];

const COMMANDS: [u16; 15] = [
    cmd::NAV_WAYPOINT,
    cmd::NAV_WAYPOINT,
    cmd::NAV_WAYPOINT,
    cmd::NAV_LOITER_UNLIM,
    cmd::NAV_LOITER_TIME,
    cmd::NAV_RETURN_TO_LAUNCH,
    cmd::NAV_DELAY,
    cmd::CONDITION_DELAY,
    cmd::CONDITION_DISTANCE,
    cmd::DO_JUMP,
    cmd::DO_CHANGE_SPEED,
    cmd::DO_SET_REVERSE,
    cmd::DO_SET_SERVO,
    cmd::DO_REPEAT_SERVO,
    cmd::DO_SET_RELAY,
];

fn param(u: &mut Unstructured) -> Result<f32> {
    Ok(match u.int_in_range(0u8..=3)? {
        0 => f32::from_bits(u.arbitrary()?),
        1 => f32::from(u.int_in_range(-2i16..=2000)?),
        _ => *u.choose(&INTERESTING)?,
    })
}

fn item(u: &mut Unstructured, seq: u16) -> Result<MissionItem> {
    let command = *u.choose(&COMMANDS)?;
    let box_e4 = (WAYPOINT_BOX_M * 1e4) as i32;
    Ok(MissionItem {
        seq,
        frame: frame::LOCAL_NED,
        command,
        current: false,
        autocontinue: true,
        params: [param(u)?, param(u)?, param(u)?, param(u)?],
        x: u.int_in_range(-box_e4..=box_e4)?,
        y: u.int_in_range(-box_e4..=box_e4)?,
        z: 0.0,
    })
}

/// A vehicle's guidance parameters, each within its declared range
/// (`autopilot/src/vehicle/params.rs`).
struct Vehicle {
    config: NavConfig,
    wheelbase_m: f64,
    accel_mps2: f64,
}

fn in_range(u: &mut Unstructured, lo: f64, hi: f64) -> Result<f64> {
    let t = f64::from(u.int_in_range(0u16..=1000)?) / 1000.0;
    Ok(lo + (hi - lo) * t)
}

fn vehicle(u: &mut Unstructured) -> Result<Vehicle> {
    let wheelbase_m = in_range(u, 0.5, 5.0)?;
    let steer_max_rad = in_range(u, 15.0, 45.0)?.to_radians();
    let accel_mps2 = in_range(u, 0.1, 10.0)?;
    let tightest_turn_m = wheelbase_m / steer_max_rad.tan();
    let arc_margin = in_range(u, 1.0, 5.0)?;
    let gains = |kp| PidGains {
        kp,
        ..PidGains::default()
    };
    let steer_rate_rad_s = in_range(u, 0.0, 90.0)?.to_radians();
    let config = NavConfig {
        tracker: TrackerConfig {
            lateral: gains(1.0),
            yaw: gains(0.5),
            preview_min_m: 2.0,
            preview_s: 0.5,
            feedforward_s: 0.3,
            feedforward_exit_s: 0.3,
            steer_max_rad,
            steer_rate_rad_s,
            wheelbase_m,
        },
        speed: SpeedConfig {
            cruise_mps: in_range(u, 0.0, 10.0)?,
            decel_mps2: 0.8 * accel_mps2,
            lateral_accel_mps2: in_range(u, 0.01, 1.0)? * GRAVITY_MPS2,
            heading: gains(2.0),
            min_mps: 0.1,
            approach_gain_per_s: in_range(u, 0.1, 2.0)?,
            stop_slack_m: 0.0,
            wheelbase_m,
            steer_rate_rad_s,
        },
        speed_limit_mps: None,
        speed_boost_mps: None,
        wp_radius_m: in_range(u, 0.0, 100.0)?,
        arc_radius_m: tightest_turn_m * arc_margin,
        min_arc_radius_m: tightest_turn_m * 1.1,
        stop: StopTolerance {
            position_m: in_range(u, 0.001, 0.5)?,
            yaw_rad: 1f64.to_radians(),
        },
        stop_preview_m: in_range(u, 0.0, 10.0)?,
        manoeuvre_speed_mps: in_range(u, 0.1, 2.0)?,
        pivot_rate_rad_s: in_range(u, 1.0, 180.0)?.to_radians(),
        direction_changes_max: None,
    };
    Ok(Vehicle {
        config,
        wheelbase_m,
        accel_mps2,
    })
}

/// The bicycle: speed follows the demand with a lag, within the
/// acceleration limit.
fn drive(est: &mut Estimate, demand: NavDemand, v: &Vehicle, dt_s: f64) {
    let dv =
        ((demand.speed_mps - est.speed_mps) * (dt_s / 0.3).min(1.0)).clamp(-v.accel_mps2 * dt_s, v.accel_mps2 * dt_s);
    est.speed_mps += dv;
    est.position.north_m += est.speed_mps * est.yaw_rad.cos() * dt_s;
    est.position.east_m += est.speed_mps * est.yaw_rad.sin() * dt_s;
    est.yaw_rad = wrap_pi(est.yaw_rad + est.speed_mps * demand.steer_rad.tan() / v.wheelbase_m * dt_s);
    est.vel_north_mps = est.speed_mps * est.yaw_rad.cos();
    est.vel_east_mps = est.speed_mps * est.yaw_rad.sin();
}

fn local(p: &Position, here: Ned) -> Ned {
    match *p {
        Position::Local { north_m, east_m } => Ned::new(north_m, east_m),
        Position::Global { .. } | Position::Current => here,
    }
}

/// The fence: a circle about home round every waypoint, with room for a
/// turn (two tightest circles either way) and a stop from the fastest
/// speed the plan may ask for.
fn fence_for(v: &Vehicle, fastest_mps: f64) -> (Fence, f64) {
    let turn_m = 4.0 * v.config.arc_radius_m.max(v.config.min_arc_radius_m);
    let stop_m = fastest_mps * fastest_mps / (2.0 * v.config.speed.decel_mps2) + fastest_mps * 0.3;
    let radius_m = WAYPOINT_BOX_M * std::f64::consts::SQRT_2 + turn_m + stop_m + 5.0;
    let circle = MissionItem {
        seq: 0,
        frame: frame::LOCAL_NED,
        command: cmd::NAV_FENCE_CIRCLE_INCLUSION,
        current: false,
        autocontinue: true,
        params: [radius_m as f32, 0.0, 0.0, 0.0],
        x: 0,
        y: 0,
        z: 0.0,
    };
    let plan = validate_plan(MissionType::Fence, vec![circle]).expect("the fuzz fence is a valid plan");
    let frame = LocalFrame::new(GeoPoint::new(45.0, 7.0, 0.0));
    (Fence::from_items(plan.items(), &frame), radius_m)
}

/// What the flight loop keeps between steps.
struct Flight {
    navigator: Navigator,
    est: Estimate,
    speed_mps: Option<f64>,
    holding: bool,
    fastest_mps: f64,
}

impl Flight {
    /// Carries out the executor's actions as `Core::apply_mission_actions`
    /// does, checking each output.
    fn apply(&mut self, actions: Vec<Action>) {
        let here = self.est.position;
        for action in actions {
            match action {
                Action::Navigate(leg) => {
                    let target = NavTarget {
                        point: local(&leg.to, here),
                        speed_mps: self.speed_mps,
                        direction: if leg.reverse {
                            Direction::Reverse
                        } else {
                            Direction::Forward
                        },
                        stop: leg.stop,
                        next: leg.next.map(|p| local(&p, here)),
                        seq: Some(leg.seq),
                    };
                    let from = leg.from.map_or(here, |p| local(&p, here));
                    self.navigator.set_target(from, target);
                    self.holding = false;
                }
                Action::Hold => {
                    self.navigator.clear();
                    self.holding = true;
                }
                Action::ReturnToLaunch => {
                    self.navigator.set_target(
                        here,
                        NavTarget {
                            speed_mps: self.speed_mps,
                            ..NavTarget::stop_at(Ned::default())
                        },
                    );
                    self.holding = false;
                }
                Action::SetSpeed(speed) => {
                    if let Some(s) = speed {
                        assert!(
                            s.is_finite() && s > 0.0 && s <= limits::MAX_SPEED_MPS,
                            "DO_CHANGE_SPEED {s} out of limits"
                        );
                        self.fastest_mps = self.fastest_mps.max(f64::from(s));
                    }
                    self.speed_mps = speed.map(f64::from);
                    self.navigator.set_speed(self.speed_mps);
                }
                Action::SetServo { channel, pwm_us } => {
                    assert!((1..=16).contains(&channel), "servo channel {channel}");
                    assert!((500..=2500).contains(&pwm_us), "servo pwm {pwm_us}");
                }
                Action::SetRelay { relay, state } => {
                    assert!(relay <= 15 && state <= 2, "relay {relay} state {state}");
                }
                Action::SetHome(_) | Action::Reached(_) | Action::CurrentChanged(_) | Action::Complete => {}
            }
        }
    }
}

/// Builds a plan and a vehicle from `data` and flies it.
pub fn fly(data: &[u8]) -> Result<()> {
    let mut u = Unstructured::new(data);
    let v = vehicle(&mut u)?;
    let count = u.int_in_range(1u16..=24)?;
    let home = MissionItem {
        command: cmd::NAV_WAYPOINT,
        params: [0.0; 4],
        x: 0,
        y: 0,
        ..item(&mut u, 0)?
    };
    let mut items = vec![home];
    for seq in 1..=count {
        items.push(item(&mut u, seq)?);
    }
    let plan = match validate_plan(MissionType::Mission, items.clone()) {
        Ok(plan) => plan,
        Err(_) => {
            // Refused at upload; a damaged stored plan could still reach an
            // executor, which must survive it.
            survive_unvalidated(&Plan::new(MissionType::Mission, items));
            return Ok(());
        }
    };
    if std::env::var_os("FURROW_FLIGHT_DEBUG").is_some() {
        eprintln!("config {:?}\nplan {:#?}", v.config, plan.items());
    }
    fly_plan(&plan, &v);
    Ok(())
}

fn survive_unvalidated(plan: &Plan) {
    let mut executor = MissionExecutor::new(plan);
    let mut actions = Vec::new();
    executor.start(Duration::ZERO, false, &mut actions);
    let report = VehicleReport {
        arrived: true,
        ..VehicleReport::default()
    };
    for t_s in [1, 10, 100, 100_000, u64::MAX / 2] {
        executor.update(Duration::from_secs(t_s), &report, &mut actions);
    }
}

/// Flies an accepted plan for [`FLIGHT_S`], checking the properties.
fn fly_plan(plan: &Plan, v: &Vehicle) {
    let mut executor = MissionExecutor::new(plan);
    let mut flight = Flight {
        navigator: Navigator::default(),
        est: Estimate {
            position_valid: true,
            heading_valid: true,
            ..Estimate::default()
        },
        speed_mps: None,
        holding: false,
        fastest_mps: v.config.speed.cruise_mps,
    };
    let fastest_plan_mps = plan
        .items()
        .iter()
        .filter(|i| i.command == cmd::DO_CHANGE_SPEED && i.params[1] > 0.0)
        .map(|i| f64::from(i.params[1]))
        .fold(v.config.speed.cruise_mps, f64::max);
    let (fence, fence_radius_m) = fence_for(v, fastest_plan_mps);
    let mut now_s = 0.0;
    let mut actions = Vec::new();
    executor.start(Duration::ZERO, false, &mut actions);
    flight.apply(std::mem::take(&mut actions));
    while now_s < FLIGHT_S {
        let at_rest = flight.navigator.target().is_none() && flight.est.speed_mps.abs() < 1e-3;
        let dt_s = if at_rest { REST_DT_S } else { DRIVE_DT_S };
        now_s += dt_s;
        let now = duration_from_secs(now_s);
        let demand = flight.navigator.update(&flight.est, &v.config, dt_s);
        check_demand(&demand, &flight, v);
        drive(&mut flight.est, demand, v, dt_s);
        let p = flight.est.position;
        if std::env::var_os("FURROW_FLIGHT_DEBUG").is_some() {
            eprintln!(
                "{now_s:.1} {p:?} v {:.2} demand {demand:?} target {:?}",
                flight.est.speed_mps,
                flight.navigator.target().map(|t| (t.point, t.stop, t.seq))
            );
        }
        assert!(p.north_m.is_finite() && p.east_m.is_finite(), "position {p:?}");
        assert!(
            fence.breach(&p).is_none(),
            "left the fence ({fence_radius_m:.1} m) at {p:?}, {now_s:.1} s"
        );
        let status = flight.navigator.status();
        let report = VehicleReport {
            arrived: flight.navigator.arrived(),
            distance_to_destination_m: status.wp_dist_m,
            utc_time_of_day_s: Some((now_s as u32) % 86_400),
        };
        executor.update(now, &report, &mut actions);
        flight.apply(std::mem::take(&mut actions));
        check_stop(&executor, &flight);
    }
}

fn check_demand(demand: &NavDemand, flight: &Flight, v: &Vehicle) {
    assert!(
        demand.steer_rad.is_finite() && demand.speed_mps.is_finite(),
        "{demand:?}"
    );
    assert!(
        demand.steer_rad.abs() <= v.config.tracker.steer_max_rad + 1e-9,
        "steering {} beyond VEH_STEER_MAX",
        demand.steer_rad
    );
    assert!(
        demand.speed_mps.abs() <= flight.fastest_mps.max(v.config.speed.min_mps) + 1e-6,
        "speed {} beyond what was asked ({} m/s)",
        demand.speed_mps,
        flight.fastest_mps
    );
    if flight.navigator.stopping() || flight.holding {
        assert_eq!(*demand, NavDemand::default(), "a stop demands nothing");
    }
}

fn check_stop(executor: &MissionExecutor, flight: &Flight) {
    match executor.state() {
        ExecState::Complete => {
            assert!(
                flight.holding && flight.navigator.target().is_none(),
                "a finished mission holds"
            );
        }
        ExecState::Running => {
            assert!(
                flight.holding || flight.navigator.target().is_some(),
                "a running mission drives or holds"
            );
        }
        ExecState::NotStarted => panic!("started missions never go back to not started"),
    }
}
