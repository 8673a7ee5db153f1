//! Speed → throttle, as ArduPilot Rover does it: feed-forward from the cruise
//! model (`CRUISE_SPEED` reached at `CRUISE_THROTTLE`) plus a PI correction
//! on the speed error, with acceleration limits on the demanded speed.
//! While the demand ramps at the acceleration limit, the feed-forward leads
//! the ramp by the drive's lag, so the wheels follow the ramp rather than
//! trail it.

use crate::control::pid::{PidGains, PidState, PidTerms};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedControlConfig {
    pub gains: PidGains,
    pub cruise_speed_mps: f64,
    /// Throttle fraction (0..1) that gives `cruise_speed_mps`.
    pub cruise_throttle: f64,
    pub accel_max_mps2: f64,
    pub decel_max_mps2: f64,
    /// The drive's first-order lag (s); 0: no lead.
    pub drive_lag_s: f64,
}

/// Braking with an accelerometer: the speed demand opposes the motion by
/// this many times the speed braked on, plus [`BRAKE_FLOOR_MPS`]. A drive
/// that follows its demand with a lag then brakes at its own limit until
/// close to rest and reaches zero in finite time, not along the lag's
/// exponential tail; a gain of 2 stays well damped with the measurement a
/// tick late (3.4 would ring at 50 Hz with a 0.3 s drive lag). Braking
/// ends at [`BRAKE_REST_MPS`] (measured in `tests/obstacle_brake.rs`: at
/// 0.03 rest came up to 0.2 s later, at 0 the roll back reached 3.5 cm/s).
const BRAKE_GAIN: f64 = 2.0;
const BRAKE_FLOOR_MPS: f64 = 0.1;
const BRAKE_REST_MPS: f64 = 0.02;

/// How long the accelerometer's forward bias is averaged over (s): long
/// against the speed estimate's lag (a tenth of a second behind the GNSS
/// velocity) and its centimetres per second of noise, so neither moves the
/// learnt bias by more than a few mm/s² (see [`AccelBias`]).
const ACCEL_BIAS_TAU_S: f64 = 5.0;

/// The forward accelerometer's bias, learnt all the time from what it
/// measures against how the speed estimate changes: the IMU's acceleration
/// integrated over seconds must add up to the speed's change, and what it
/// adds beyond is its bias (the simulator draws 0.03 m/s² per unit; a slope
/// counts as bias too, which is what dead reckoning on it needs). The
/// filter is `b' = (a − b − v̇)/τ`: with `a` = true acceleration + bias and
/// the estimate `v` lagging the truth by `e`, the error obeys
/// `(b − bias)' = (ė − (b − bias))/τ`, so the lag only moves it by `e/τ`
/// while the speed changes (0.04 m/s² at the height of a 2 m/s² stop), and
/// not at all once the estimate has caught up. The brake therefore uses the
/// bias learnt before it began.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AccelBias {
    bias_mps2: f64,
    last_speed_mps: Option<f64>,
}

impl AccelBias {
    /// One tick's IMU forward acceleration and speed estimate; `None`
    /// (no IMU, no estimate) starts the speed's differences afresh.
    pub fn observe(&mut self, accel_mps2: Option<f64>, speed_mps: Option<f64>, dt_s: f64) {
        let (Some(accel), Some(speed)) = (accel_mps2, speed_mps) else {
            self.last_speed_mps = None;
            return;
        };
        if !(accel.is_finite() && speed.is_finite() && dt_s > 0.0) {
            self.last_speed_mps = None;
            return;
        }
        if let Some(last) = self.last_speed_mps {
            let k = (dt_s / ACCEL_BIAS_TAU_S).min(1.0);
            self.bias_mps2 += k * (accel - self.bias_mps2) - (speed - last) / ACCEL_BIAS_TAU_S;
        }
        self.last_speed_mps = Some(speed);
    }

    /// The bias learnt so far, m/s².
    pub fn mps2(&self) -> f64 {
        self.bias_mps2
    }
}

/// When braking to rest ends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BrakeLimits {
    /// At or below this measured speed the vehicle is at rest (m/s).
    pub rest_mps: f64,
    /// Braking ends after this long whatever the measurement says (s).
    pub max_s: f64,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SpeedController {
    pid: PidState,
    /// The demand after the acceleration limit.
    limited_mps: f64,
    /// The last update's PID terms and feed-forward throttle (for the log).
    last_terms: PidTerms,
    last_feed_forward: f64,
    /// Braking has brought the vehicle to rest: it stays without throttle
    /// (speed noise at rest must not drive it) until driven again.
    braked: bool,
    /// How long the present braking has lasted (s).
    braking_s: f64,
    /// While braking with an accelerometer: the speed measured when the
    /// braking began, carried on with the measured acceleration less the
    /// bias learnt before (m/s, m/s²).
    braked_on: Option<(f64, f64)>,
    /// The accelerometer's forward bias, learnt whatever the demand.
    accel_bias: AccelBias,
}

impl SpeedController {
    pub fn reset(&mut self, current_speed_mps: f64) {
        self.braked = false;
        self.braking_s = 0.0;
        self.braked_on = None;
        self.pid.reset();
        self.limited_mps = current_speed_mps;
    }

    /// One tick's IMU forward acceleration and speed estimate, to learn
    /// the accelerometer's bias from (see [`AccelBias`]).
    pub fn observe_accel(&mut self, accel_mps2: Option<f64>, speed_mps: Option<f64>, dt_s: f64) {
        self.accel_bias.observe(accel_mps2, speed_mps, dt_s);
    }

    /// The acceleration-limited speed demand of the last update.
    pub fn limited_demand_mps(&self) -> f64 {
        self.limited_mps
    }

    /// The last update's PID terms and feed-forward throttle.
    pub fn last_terms(&self) -> (PidTerms, f64) {
        (self.last_terms, self.last_feed_forward)
    }

    /// Throttle in [-1, 1] for `desired_mps` given the measured speed; with
    /// no measurement (no estimate), the feed-forward alone.
    pub fn update(
        &mut self,
        config: &SpeedControlConfig,
        desired_mps: f64,
        measured_mps: Option<f64>,
        dt_s: f64,
    ) -> f64 {
        self.braked = false;
        self.braking_s = 0.0;
        self.braked_on = None;
        let step = desired_mps - self.limited_mps;
        let slowing = desired_mps.abs() < self.limited_mps.abs() || desired_mps * self.limited_mps < 0.0;
        let limit = if slowing {
            config.decel_max_mps2
        } else {
            config.accel_max_mps2
        } * dt_s;
        let change = step.clamp(-limit, limit);
        self.limited_mps += change;

        let full_throttle_speed = if config.cruise_throttle > 0.0 {
            config.cruise_speed_mps / config.cruise_throttle
        } else {
            1.0
        };
        let lead_mps = ramp_lead_mps(config, change, change != step && !slowing, dt_s);
        let feed_forward = (self.limited_mps + lead_mps) / full_throttle_speed.max(1e-3);
        self.last_terms = match measured_mps {
            Some(measured) => self.pid.update(&config.gains, self.limited_mps - measured, dt_s),
            None => {
                self.pid.reset();
                PidTerms::default()
            }
        };
        self.last_feed_forward = feed_forward;
        let correction = self.last_terms.output();
        (feed_forward + correction).clamp(-1.0, 1.0)
    }

    /// Throttle that brakes to rest. Nothing once at rest or after
    /// `limits.max_s` (a speed measurement biased off zero must not keep
    /// it creeping), until driven again; nothing without a measurement;
    /// never a push the way it is moving.
    ///
    /// With the longitudinal acceleration (`accel_mps2`, the IMU's, each
    /// tick), the speed braked on is the one measured when the braking
    /// began, carried on with that acceleration: the speed estimate moves
    /// only with each GNSS velocity, a tenth of a second apart and behind,
    /// with centimetres per second of noise, and a brake closed on it
    /// either stops short of zero (the drive's lag then leaves the vehicle
    /// creeping for a second) or, harder, overshoots into reverse. The
    /// demand opposes the motion ([`BRAKE_GAIN`], [`BRAKE_FLOOR_MPS`]) until
    /// that speed reaches zero, which is rest. An accelerometer bias of
    /// 0.03 m/s² moves that moment by under 3 cm/s over a one-second stop.
    ///
    /// Without it: the P correction on the speed measured, rest at or below
    /// `limits.rest_mps`, no integrator (one wound up while braking would
    /// drive the vehicle the other way once stopped).
    pub fn brake(
        &mut self,
        config: &SpeedControlConfig,
        measured_mps: Option<f64>,
        accel_mps2: Option<f64>,
        limits: &BrakeLimits,
        dt_s: f64,
    ) -> f64 {
        self.braking_s += dt_s.max(0.0);
        if self.braking_s > limits.max_s {
            self.braked = true;
        }
        self.pid.reset();
        self.limited_mps = 0.0;
        self.last_terms = PidTerms::default();
        self.last_feed_forward = 0.0;
        let Some(measured) = measured_mps else {
            return 0.0;
        };
        if self.braked {
            return 0.0;
        }
        match accel_mps2.filter(|a| a.is_finite()) {
            Some(accel) => self.brake_dead_reckoned(config, measured, accel, dt_s),
            None if measured.abs() > limits.rest_mps => {
                let throttle = (-config.gains.kp * measured).clamp(-1.0, 1.0);
                // Braking opposes the motion; a NaN gain gives nothing.
                if throttle * measured < 0.0 { throttle } else { 0.0 }
            }
            None => {
                self.braked = true;
                0.0
            }
        }
    }

    /// [`Self::brake`] on the speed carried on with the acceleration.
    fn brake_dead_reckoned(&mut self, config: &SpeedControlConfig, measured: f64, accel: f64, dt_s: f64) -> f64 {
        let (speed, bias) = match self.braked_on {
            None => (measured, self.accel_bias.mps2()),
            Some((v, bias)) => (v + (accel - bias) * dt_s.max(0.0), bias),
        };
        // The direction braked against: the last tick's.
        let started = self.braked_on.map_or(measured, |(v, _)| v);
        self.braked_on = Some((speed, bias));
        // Down to the last centimetres per second, or crossed zero (or
        // nothing to brake from, or NaN): at rest. Stopping the brake a
        // little short of zero leaves the drive's lag a short tail, where
        // braking on to the dead-reckoned zero would roll it back by the
        // reckoning's error (a GNSS speed up to 0.1 s old at the start,
        // the accelerometer's bias).
        let ahead_mps = speed * started.signum();
        if ahead_mps.is_nan() || ahead_mps <= BRAKE_REST_MPS {
            self.braked = true;
            return 0.0;
        }
        let demand_mps = -(BRAKE_GAIN * speed + BRAKE_FLOOR_MPS * speed.signum());
        let full_throttle_speed = if config.cruise_throttle > 0.0 {
            config.cruise_speed_mps / config.cruise_throttle
        } else {
            1.0
        };
        let throttle = (demand_mps / full_throttle_speed.max(1e-3)).clamp(-1.0, 1.0);
        if throttle * speed < 0.0 { throttle } else { 0.0 }
    }
}

/// How far ahead of the demand the drive is commanded while the demand
/// speeds up at the acceleration limit (`ramping`): a first-order drive of
/// lag τ trails a ramp of slope a by τ·a, and one commanded τ·a ahead
/// follows it. Only at the limit: there the slope is the controller's own
/// and known, not the derivative of a demand that may be noisy. Slowing
/// down gets none: stops are planned with room for the lag.
fn ramp_lead_mps(config: &SpeedControlConfig, change_mps: f64, ramping: bool, dt_s: f64) -> f64 {
    if ramping && dt_s > 0.0 && config.drive_lag_s > 0.0 {
        config.drive_lag_s * change_mps / dt_s
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config() -> SpeedControlConfig {
        SpeedControlConfig {
            gains: PidGains {
                kp: 0.2,
                ki: 0.2,
                kd: 0.0,
                imax: 0.5,
            },
            cruise_speed_mps: 2.0,
            cruise_throttle: 0.5,
            accel_max_mps2: 1.0,
            decel_max_mps2: 2.0,
            drive_lag_s: 0.0,
        }
    }

    #[test]
    fn feed_forward_gives_cruise_throttle_at_cruise_speed() {
        let mut c = SpeedController::default();
        c.reset(2.0);
        assert!((c.update(&config(), 2.0, Some(2.0), 0.02) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn demand_ramps_at_the_acceleration_limit() {
        let mut c = SpeedController::default();
        c.reset(0.0);
        for _ in 0..50 {
            c.update(&config(), 2.0, Some(0.0), 0.02);
        }
        assert!((c.limited_demand_mps() - 1.0).abs() < 1e-9, "1 m/s² for 1 s");
    }

    /// The true speed of a first-order drive of lag `tau_s` (throttle 1 =
    /// 4 m/s, the cruise model of `config`) after each tick of a start from
    /// rest towards 2 m/s, feed-forward alone.
    fn start_through_lag(drive_lag_s: f64, tau_s: f64) -> Vec<(f64, f64)> {
        let config = SpeedControlConfig {
            drive_lag_s,
            ..config()
        };
        let mut c = SpeedController::default();
        c.reset(0.0);
        let (dt, mut v) = (0.02, 0.0);
        (0..100)
            .map(|_| {
                let command_mps = 4.0 * c.update(&config, 2.0, None, dt);
                v += (command_mps - v) * (1.0 - (-dt / tau_s).exp());
                (c.limited_demand_mps(), v)
            })
            .collect()
    }

    #[test]
    fn the_lead_makes_a_lagging_drive_follow_the_ramp() {
        let tau = 0.3;
        // Without the lead the wheels trail the 1 m/s² ramp by τ·a = 0.3 m/s.
        let trailing = start_through_lag(0.0, tau);
        let (demand, v) = trailing[49];
        assert!((demand - v - 0.3).abs() < 0.03, "{demand} {v}");
        // With it they follow the ramp, within half a tick's worth of it
        // (the command holds over a tick the ramp climbs through), and do
        // not overshoot its end.
        let leading = start_through_lag(tau, tau);
        for &(demand, v) in &leading {
            assert!((demand - v).abs() <= 0.011, "{demand} {v}");
        }
        assert!(leading.iter().all(|&(_, v)| v <= 2.0));
    }

    #[test]
    fn no_lead_when_slowing_or_below_the_limit() {
        let config = SpeedControlConfig {
            drive_lag_s: 0.3,
            ..config()
        };
        let mut c = SpeedController::default();
        c.reset(1.0);
        // A demand change within the limit, and braking: feed-forward alone.
        assert!((c.update(&config, 1.01, None, 0.02) - 1.01 / 4.0).abs() < 1e-12);
        assert!((c.update(&config, 0.0, None, 0.02) - 0.97 / 4.0).abs() < 1e-12);
        // Speeding up in reverse leads the other way.
        c.reset(0.0);
        assert!((c.update(&config, -1.0, None, 0.02) - (-0.02 - 0.3) / 4.0).abs() < 1e-12);
    }

    #[test]
    fn braking_opposes_the_motion_until_at_rest() {
        let mut c = SpeedController::default();
        c.reset(1.0);
        c.update(&config(), 1.0, Some(1.0), 0.02);
        // P 0.2 throttle per m/s against the speed measured.
        let limits = BrakeLimits {
            rest_mps: 0.02,
            max_s: 3.0,
        };
        assert!((c.brake(&config(), Some(1.0), None, &limits, 0.02) + 0.2).abs() < 1e-12);
        assert!((c.brake(&config(), Some(-0.5), None, &limits, 0.02) - 0.1).abs() < 1e-12);
        assert_eq!(c.brake(&config(), None, None, &limits, 0.02), 0.0);
        assert_eq!(c.brake(&config(), Some(0.015), None, &limits, 0.02), 0.0);
        // At rest once, speed noise does not start it braking again.
        assert_eq!(c.brake(&config(), Some(0.04), None, &limits, 0.02), 0.0);
        // Nothing is left to drive on with afterwards.
        assert_eq!(c.limited_demand_mps(), 0.0);
        assert!(c.update(&config(), 0.0, Some(0.0), 0.02).abs() < 1e-12);
    }

    #[test]
    fn braking_ends_after_its_time_whatever_the_measurement() {
        let limits = BrakeLimits {
            rest_mps: 0.005,
            max_s: 1.0,
        };
        let mut c = SpeedController::default();
        c.reset(0.0);
        // A measurement stuck at 1 cm/s: braked against for 1 s, then not.
        let throttles: Vec<f64> = (0..60)
            .map(|_| c.brake(&config(), Some(0.01), None, &limits, 0.02))
            .collect();
        assert!(throttles[..45].iter().all(|&t| t < 0.0), "{throttles:?}");
        assert!(throttles[55..].iter().all(|&t| t == 0.0), "{throttles:?}");
    }

    /// A drive cycle at 50 Hz (rest, 1 m/s² up to 1.5 m/s, cruise, a
    /// 2 m/s² stop, rest) seen by an accelerometer biased by `bias_mps2`
    /// and a speed estimate 0.1 s behind the truth, updated at 10 Hz.
    fn learn_bias(bias_mps2: f64, seconds: f64) -> AccelBias {
        let dt = 0.02;
        let mut learnt = AccelBias::default();
        let speed_at = |t: f64| -> f64 {
            let t = t % 12.0;
            match t {
                t if t < 2.0 => 0.0,
                t if t < 3.5 => t - 2.0,
                t if t < 9.0 => 1.5,
                t if t < 9.75 => 1.5 - 2.0 * (t - 9.0),
                _ => 0.0,
            }
        };
        for k in 0..(seconds / dt) as u64 {
            let t = k as f64 * dt;
            let accel = (speed_at(t + dt) - speed_at(t)) / dt + bias_mps2;
            let estimate = speed_at(((t - 0.1) * 10.0).floor() / 10.0);
            learnt.observe(Some(accel), Some(estimate), dt);
        }
        learnt
    }

    #[test]
    fn the_accelerometer_bias_is_learnt_while_driving() {
        for bias in [-0.05, 0.0, 0.03] {
            // Three cycles: 36 s, seven time constants.
            let learnt = learn_bias(bias, 36.0).mps2();
            assert!((learnt - bias).abs() < 0.005, "bias {bias}: learnt {learnt}");
        }
    }

    #[test]
    fn braking_carries_the_speed_on_without_the_learnt_bias() {
        let mut c = SpeedController::default();
        let bias = 0.05;
        let dt = 0.02;
        // At rest for 30 s: the accelerometer reads its bias alone.
        for _ in 0..1500 {
            c.observe_accel(Some(bias), Some(0.0), dt);
        }
        let limits = BrakeLimits {
            rest_mps: 0.02,
            max_s: 3.0,
        };
        // Braking from 1 m/s while truly decelerating at 1 m/s²: the brake
        // lets go when the truth is down to its rest speed, not the 5 cm/s
        // more that the bias would have added over a second.
        let mut true_mps = 1.0;
        let mut released_at_mps = None;
        for _ in 0..100 {
            let throttle = c.brake(&config(), Some(1.0), Some(-1.0 + bias), &limits, dt);
            if throttle == 0.0 {
                released_at_mps = Some(true_mps);
                break;
            }
            true_mps -= 1.0 * dt;
        }
        // Within a tick (2 cm/s of this braking) of the truth reaching it:
        // the bias left in would have let go at -3 cm/s, in reverse.
        let released = released_at_mps.expect("the brake lets go");
        assert!(
            (-1e-9..=BRAKE_REST_MPS + 1e-9).contains(&released),
            "released at {released} m/s"
        );
    }

    #[test]
    fn reverse_gives_negative_throttle() {
        let mut c = SpeedController::default();
        c.reset(-1.0);
        assert!(c.update(&config(), -1.0, Some(-1.0), 0.02) < 0.0);
    }
}
