//! Each tick: the mode decides what to do (`modes/`), guidance turns it into a
//! steering angle and speed, control into normalised actuator commands.

use vehicle_types::ActuatorDemand;

use super::Core;
use crate::control::ackermann::{AckermannGeometry, curvature_from_steer, differential_wheel_speeds};
use crate::control::mixer::{self, DriveTrain, WheelOutputs};
use crate::control::pid::PidGains;
use crate::control::speed::{BrakeLimits, SpeedControlConfig};
use crate::guidance::navigator::{NavConfig, NavDemand, StopTolerance};
use crate::guidance::speed::{SpeedConfig, SpeedLimit, approach_loop_mps, braking_limit};
use crate::guidance::tracker::{Direction, TrackerConfig};
use crate::modes::Mode;
use crate::obstacles::policy::Verdict;

const GRAVITY_MPS2: f64 = 9.80665;
/// Braking for an obstacle ends at this speed, or after this long (from
/// 2 m/s the drive stops within about 1.5 s).
const BRAKE_LIMITS: BrakeLimits = BrakeLimits {
    rest_mps: 0.005,
    max_s: 3.0,
};

/// The normalised commands of the last tick and what went to the actuators.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveState {
    /// [-1, 1], positive right.
    pub steering: f64,
    /// [-1, 1], negative reverse.
    pub throttle: f64,
    pub actuators: ActuatorDemand,
    /// Per-wheel commands of an Ackermann vehicle (servos 5–8).
    pub wheels: Option<WheelOutputs>,
}

impl DriveState {
    pub fn neutral(drive: DriveTrain) -> Self {
        DriveState {
            steering: 0.0,
            throttle: 0.0,
            actuators: mixer::neutral(drive),
            wheels: match drive {
                DriveTrain::Ackermann => Some(WheelOutputs::default()),
                DriveTrain::Differential => None,
            },
        }
    }
}

/// What the mode asks of the drive train this tick.
pub(super) enum Demand {
    Stop,
    /// An obstacle stop: brake to rest on the path being driven.
    Brake,
    Manual {
        steering: f64,
        throttle: f64,
    },
    Navigate(NavDemand),
}

impl Core {
    pub(super) fn nav_config(&self) -> NavConfig {
        let t = &self.params;
        let pv = &self.p.preview;
        let nav = &self.p.nav;
        let gains = |p: f32, i: f32, d: f32, imax: f32| PidGains {
            kp: f64::from(p),
            ki: f64::from(i),
            kd: f64::from(d),
            imax: f64::from(imax),
        };
        let cruise = match self.mode {
            Mode::Rtl if nav.rtl_speed_mps.get(t) > 0.0 => nav.rtl_speed_mps.get(t),
            _ => nav.wp_speed_mps.get(t),
        };
        let accel = f64::from(nav.accel_max_mps2.get(t));
        let wheelbase = f64::from(self.p.vehicle.wheelbase_m.get(t));
        let steer_max = f64::from(self.p.vehicle.steer_max_deg.get(t)).to_radians();
        let tightest_turn_m = wheelbase / steer_max.tan();
        let stop = self.stop_tolerance();
        NavConfig {
            tracker: TrackerConfig {
                lateral: gains(pv.lat_p.get(t), pv.lat_i.get(t), pv.lat_d.get(t), pv.lat_imax_m.get(t)),
                yaw: gains(
                    pv.yaw_p.get(t),
                    pv.yaw_i.get(t),
                    pv.yaw_d.get(t),
                    pv.yaw_imax_rad.get(t),
                ),
                preview_min_m: f64::from(pv.dist_m.get(t)),
                preview_s: f64::from(pv.dist_k_s.get(t)),
                feedforward_s: f64::from(pv.ff_time_s.get(t)),
                feedforward_exit_s: f64::from(pv.ff_exit_s.get(t)),
                steer_max_rad: steer_max,
                steer_rate_rad_s: f64::from(self.p.vehicle.steer_rate_deg_s.get(t)).to_radians(),
                wheelbase_m: wheelbase,
            },
            speed: SpeedConfig {
                cruise_mps: self.speed_override_mps.unwrap_or(f64::from(cruise)),
                // Plan stops at 80 % of the speed controller's limit so the
                // lagging vehicle still makes the stop.
                decel_mps2: 0.8 * self.decel_limit_mps2().min(accel.max(0.1) * 4.0),
                lateral_accel_mps2: f64::from(nav.turn_max_g.get(t)) * GRAVITY_MPS2,
                heading: gains(
                    pv.spd_p.get(t),
                    pv.spd_i.get(t),
                    pv.spd_d.get(t),
                    pv.spd_imax_mps.get(t),
                ),
                min_mps: 0.1,
                approach_gain_per_s: f64::from(nav.approach_gain.get(t)),
                // The loop is tuned to end within WP_STOP_TOL_MM.
                stop_slack_m: (stop.position_m - f64::from(nav.stop_tol_mm.get(t)) / 1000.0).max(0.0),
                wheelbase_m: wheelbase,
                steer_rate_rad_s: f64::from(self.p.vehicle.steer_rate_deg_s.get(t)).to_radians(),
            },
            speed_limit_mps: match (self.degraded_fix_speed_limit(), self.obstacles.status().speed_limit_mps) {
                (Some(a), Some(b)) => Some(a.min(b)),
                (a, b) => a.or(b),
            },
            speed_boost_mps: self.obstacles.status().speed_up_mps,
            wp_radius_m: f64::from(nav.wp_radius_m.get(t)),
            arc_radius_m: tightest_turn_m * f64::from(nav.arc_margin.get(t)),
            // Room for the tracker's corrections on top of the arc.
            min_arc_radius_m: tightest_turn_m * 1.05,
            stop_preview_m: f64::from(pv.stop_dist_m.get(t)),
            manoeuvre_speed_mps: f64::from(self.p.manoeuvre.speed_mps.get(t)),
            pivot_rate_rad_s: f64::from(self.p.manoeuvre.pivot_rate_deg_s.get(t)).to_radians(),
            // On the way to a pose goal: its changes of direction are limited.
            direction_changes_max: self
                .goals
                .goal
                .map(|_| self.p.manoeuvre.direction_changes_max.get(t).max(0) as usize),
            stop,
        }
    }

    /// How close the stop must end: a fleet node's allowed deviation on its
    /// leg, else `WP_STOP_TOL_*`.
    fn stop_tolerance(&self) -> StopTolerance {
        let nav = &self.p.nav;
        self.fleet_stop_tolerance().unwrap_or(StopTolerance {
            position_m: f64::from(nav.stop_tol_mm.get(&self.params)) / 1000.0,
            yaw_rad: f64::from(nav.stop_tol_deg.get(&self.params)).to_radians(),
        })
    }

    pub(super) fn decel_limit_mps2(&self) -> f64 {
        let nav = &self.p.nav;
        let decel = f64::from(nav.decel_max_mps2.get(&self.params));
        if decel > 0.0 {
            decel
        } else {
            f64::from(nav.accel_max_mps2.get(&self.params))
        }
    }

    fn speed_control_config(&self) -> SpeedControlConfig {
        let t = &self.params;
        let nav = &self.p.nav;
        SpeedControlConfig {
            gains: PidGains {
                kp: f64::from(nav.speed_p.get(t)),
                ki: f64::from(nav.speed_i.get(t)),
                kd: f64::from(nav.speed_d.get(t)),
                imax: f64::from(nav.speed_imax.get(t)),
            },
            cruise_speed_mps: f64::from(nav.cruise_speed_mps.get(t)),
            cruise_throttle: f64::from(nav.cruise_throttle_pct.get(t)) / 100.0,
            accel_max_mps2: f64::from(nav.accel_max_mps2.get(t)),
            decel_max_mps2: self.decel_limit_mps2(),
            drive_lag_s: f64::from(nav.drive_lag_s.get(t)),
        }
    }

    /// The obstacle policy for this tick; true when it stops the vehicle.
    pub(super) fn obstacle_tick(&mut self) -> bool {
        let active = self.armed && self.mode.self_driving();
        let (wants_to_move, direction, planned_mps, stop_within_m) = match self.navigator.target().copied() {
            _ if self.mode == Mode::Magnetic => (
                active,
                Direction::Forward,
                f64::from(self.p.nav.wp_speed_mps.get(&self.params)),
                None,
            ),
            Some(target) => {
                // A manoeuvre's strokes are driven at its capped speed, not
                // the mission's: a start or resume is predicted at that.
                let nav_config = self.nav_config();
                let cruise = self
                    .navigator
                    .leg_cruise_mps(&nav_config)
                    .unwrap_or(nav_config.speed.cruise_mps);
                // Towards a stop, no faster than the schedule allows from
                // here (the path is built here if no update has yet).
                let position = self.estimator.estimate().position;
                let remaining_m = target
                    .stop
                    .then(|| self.navigator.path_ahead(position, &nav_config))
                    .flatten()
                    .map(|(path, along_m)| path.end_m() - along_m);
                let planned_mps = remaining_m.map_or(cruise, |r| cruise.min(stop_approach_mps(r, &nav_config.speed)));
                (
                    active && !self.navigator.stopping(),
                    target.direction,
                    planned_mps,
                    remaining_m,
                )
            }
            None => (false, Direction::Forward, 0.0, None),
        };
        // Settling onto a precision stop: not driving, not parked either.
        let settling = active && self.mode != Mode::Magnetic && self.navigator.stopping();
        let verdict = self.obstacle_verdict(active, wants_to_move, settling, direction, (planned_mps, stop_within_m));
        // A wait at rest brakes like a stop: the drive is held at 0, not
        // left to creep on a speed demand of 0.
        matches!(verdict, Verdict::Stop(_) | Verdict::Wait(_))
    }

    pub(super) fn apply_demand(&mut self, demand: Demand, dt_s: f64) {
        let estimate = self.estimator.estimate();
        // A speed measurement only while the estimate is good.
        let measured = (estimate.position_valid && estimate.heading_valid).then_some(estimate.speed_mps);
        // The accelerometer's bias is learnt whatever is driven, for the
        // obstacle brake's dead reckoning.
        let accel = self.longitudinal_accel_mps2();
        self.speed_control.observe_accel(accel, measured, dt_s);
        let (steering, throttle) = match demand {
            Demand::Stop => {
                self.speed_control.reset(0.0);
                (0.0, 0.0)
            }
            Demand::Brake => {
                let config = self.speed_control_config();
                let throttle = self.speed_control.brake(&config, measured, accel, &BRAKE_LIMITS, dt_s);
                (self.braking_steering(), throttle)
            }
            Demand::Manual { steering, throttle } => {
                self.speed_control.reset(measured.unwrap_or(0.0));
                (steering, throttle)
            }
            Demand::Navigate(nav) if nav.pivot_rate_rad_s != 0.0 => {
                // Turning on the spot: no speed to hold, so no throttle
                // for the estimate's speed noise to drive the centre off.
                self.speed_control.reset(0.0);
                (self.steering_for(nav, 0.0), 0.0)
            }
            Demand::Navigate(nav) if nav.speed_mps == 0.0 && self.holding_at_stop() => {
                // Rolling onto a wide stop: the drive let go (neutral, so
                // the estimator may find it at rest), and the vehicle comes
                // to rest where its lag takes it, centimetres on. A speed
                // of 0 chased on the lagging speed estimate pushed on after
                // the wheels had stopped and backed the vehicle up.
                self.speed_control.reset(0.0);
                (0.0, 0.0)
            }
            Demand::Navigate(nav) => {
                let config = self.speed_control_config();
                let throttle = self.speed_control.update(&config, nav.speed_mps, measured, dt_s);
                (self.steering_for(nav, measured.unwrap_or(nav.speed_mps)), throttle)
            }
        };
        let wheels = match self.drive_train {
            DriveTrain::Ackermann => {
                let t = &self.params;
                let geometry = AckermannGeometry::new(
                    f64::from(self.p.vehicle.wheelbase_m.get(t)),
                    f64::from(self.p.vehicle.track_m.get(t)),
                );
                let steer_max = f64::from(self.p.vehicle.steer_max_deg.get(t)).to_radians();
                Some(WheelOutputs::from_demand(&geometry, steer_max, steering, throttle))
            }
            DriveTrain::Differential => None,
        };
        self.drive = DriveState {
            steering,
            throttle,
            actuators: mixer::mix(self.drive_train, steering, throttle),
            wheels,
        };
    }

    /// The speed schedule holds the vehicle at a stop it may end past (see
    /// [`SpeedLimit::Hold`]).
    fn holding_at_stop(&self) -> bool {
        self.navigator.target().is_some_and(|t| t.stop) && self.navigator.status().speed.limit == SpeedLimit::Hold
    }

    /// The IMU's forward specific force, while it reports: on level ground
    /// the vehicle's acceleration along its heading (a slope adds g·sin of
    /// its pitch, a few hundredths of g over one short stop).
    fn longitudinal_accel_mps2(&self) -> Option<f64> {
        let imu = self.estimator.imu();
        imu.fresh(self.now.boot)
            .then(|| imu.last().map(|s| s.accel_mps2[0]))
            .flatten()
    }

    /// Steering while braking for an obstacle: an Ackermann vehicle keeps
    /// its wheels where they are, so it stops on the arc it was driving (the
    /// path the obstacle checks swept), not on a straightening one. A
    /// differential vehicle's steering is a wheel-speed difference, which
    /// would turn it ever tighter as it slows: it brakes straight.
    fn braking_steering(&self) -> f64 {
        match self.drive_train {
            DriveTrain::Ackermann => self.drive.steering,
            DriveTrain::Differential => 0.0,
        }
    }

    /// Normalised steering for a steering-angle demand. Skid steering turns
    /// the same curvature (tan δ / wheelbase) into a wheel-speed difference.
    fn steering_for(&self, nav: NavDemand, measured_mps: f64) -> f64 {
        let steer_max = f64::from(self.p.vehicle.steer_max_deg.get(&self.params)).to_radians();
        match self.drive_train {
            DriveTrain::Ackermann => nav.steer_rad / steer_max,
            DriveTrain::Differential => {
                let wheelbase = f64::from(self.p.vehicle.wheelbase_m.get(&self.params));
                let track = f64::from(self.p.vehicle.track_m.get(&self.params));
                let speed = if measured_mps.abs() > 0.05 {
                    measured_mps
                } else {
                    nav.speed_mps
                };
                let nav_config = self.speed_control_config();
                let full_speed = nav_config.cruise_speed_mps / nav_config.cruise_throttle.max(1e-3);
                if nav.pivot_rate_rad_s != 0.0 {
                    // Turning on the spot: the wheels in opposite senses,
                    // each at the rate times half the track.
                    return nav.pivot_rate_rad_s * track / (2.0 * full_speed);
                }
                // The same curvature a bicycle of VEH_WHEELBASE would drive,
                // as wheel speeds; the mixer adds ±steering to the throttle.
                let wheels = differential_wheel_speeds(speed, curvature_from_steer(wheelbase, nav.steer_rad), track);
                (wheels.left_mps - wheels.right_mps) / (2.0 * full_speed)
            }
        }
    }
}

/// The fastest the speed schedule drives with `remaining_m` left to a stop
/// point (either way): braking to it, and the final approach's position
/// loop. A vehicle settling onto its stop, or short of it, starts and
/// resumes no faster. Judged at cruise instead, someone standing a metre
/// or two ahead of a vehicle resting on the mission's last stop was in the
/// protective field at resume (sized for cruise) or in the path of a
/// cruise-speed resume, and the stop was never released (bench seeds 448,
/// 604, 1156, 1323, 1440: stalls).
fn stop_approach_mps(remaining_m: f64, speed: &SpeedConfig) -> f64 {
    let remaining_m = remaining_m.abs();
    braking_limit(0.0, remaining_m, speed.decel_mps2.max(0.01)).min(approach_loop_mps(speed, remaining_m).max(0.0))
}
