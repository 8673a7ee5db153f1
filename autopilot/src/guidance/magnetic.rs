//! Double magnetic guide tracking ("Path tracking of a wheeled AGV with
//! double magnetic guide", Yin et al., called "the seed" below: its §2 and
//! §4; docs/architecture.md §Kinematics and the magnetic guide): two 16-probe sensors, front and rear, read the tape;
//! their deviations give the vehicle's lateral and angle deviation; a PD on
//! the lateral deviation sets the steering angle and a PID on the angle
//! deviation the speed, both in incremental form (eq. 15).
//!
//! Signs (the seed's eq. 1–2 use magnitudes and lose them; fixed here):
//! - probe i is bit i−1 of the mask, probe 1 the rightmost (the seed's §4.2
//!   numbering: deviated left ⇒ right probes ⇒ num < 17), so
//!   `error = 17 − num` counts half pitches of tape offset to the right, and
//!   a sensor's deviation e = error·pitch/2 is positive when the tape is to
//!   the right of the sensor's centre;
//! - with the front and rear deviations e1, e2 at spacing d, the tape runs
//!   through body points (x_f, e1) and (x_r, e2): its direction relative to
//!   the body is α = atan2(e1 − e2, d) (positive = the tape heads to the
//!   right: turn right), and the midpoint between the sensors is
//!   (e1 + e2)/2·cos α from it, perpendicular (positive = tape to the right:
//!   steer right). Seed eq. 2 uses |e1| + |e2|, which is |e1 − e2| only when
//!   the sensors are on opposite sides of the tape; seed eq. 1's sum e1 + e2
//!   is twice the midpoint's offset (a gain of 2 in its PD).
//!
//! Both deviations therefore want positive (right) steering when positive,
//! which makes the steering law δ = δ_I + PD(lateral), δ_I the integral
//! (with the seed's K_I = 0: whatever steering the guide took over, see
//! [`MagneticGuide::engaged_at`]).
//!
//! Beyond the seed, each for a reason found in SITL (`sitl::magnetic_scenario`):
//! - the D term's rate is by default the kinematic one, v·tan α − ω·x_mid
//!   ([`LateralRate::Kinematic`]): the reading moves in 2.5 mm steps, and
//!   differenced at 50 Hz (eq. 15 as written) that is 0.125 m/s of noise per
//!   step; filtered enough to use, it lags so much that the vehicle loses the
//!   tape in every start of the scenario. The two sensors measure the tape's
//!   angle directly, which is what the seed's second sensor is for;
//! - the PD part is limited to ±`steer_correction_max_rad` about the
//!   integral: the seed's "correction angle within ±10°";
//! - one sensor off the tape: its deviation is placed just beyond its
//!   outermost probe (±8 pitches), or further out if the other sensor's rate
//!   says so (that rate is v·tan α − ω·x, so it gives α), on the side the
//!   tape left it or, never having seen the tape, the side that rate puts it,
//!   decided once the rate has settled and the seen sensor has read inside
//!   its trusted range since the tape came in (edge readings stick, so their
//!   rate says nothing) or a line through the seen sensor's first readings
//!   ([`super::magnetic_slope::ReadingSlope`], four readings) puts it
//!   clearly on one side, and
//!   kept open until then; the side is the rate's own, not the blended
//!   placement's (which starts beyond the edge); the tape cannot
//!   change sides of a sensor unseen. A sensor the tape has just come into
//!   reads where the tape is: its edge reading is not pushed out (below);
//! - the approach angle is limited to what keeps both sensors on the tape:
//!   with the midpoint at lateral y and the body at angle α to the tape the
//!   sensors are at y ± (d/2)·sin α, so both read it while |y| + (d/2)·|sin α|
//!   is within the outermost probe ([`MagneticGuideConfig::approach_limit_rad`]).
//!   The PD law settles on the approach tan α = kp·y/(kd·v), so limiting the
//!   P term to kd·v·sin α_max limits the angle it steers to (found in SITL: 0.1 m
//!   off, full P swung the bench vehicle 10° across the tape and both sensors
//!   lost it);
//! - the correction's turn rate is limited to what the sensors can follow:
//!   a correction δ yaws the body at v·tan δ/L, sweeping a sensor at x across
//!   the tape at that times |x|; kept within the approach limit's v·sin α_max
//!   that is tan δ ≤ L·sin α_max/|x|max ([`MagneticGuideConfig::correction_limit_rad`]);
//! - dead reckoning ([`TapeEstimate`], `dead_reckon_s`): the lateral and
//!   angle deviation are carried forward between readings with the speed
//!   and yaw rate. A reading at a sensor's edge (its outer 1.75 pitches) only
//!   says "this far or further" and is pushed out to the estimate's value
//!   when that is further (a sensor the tape has just come into excepted,
//!   until it reads inside that range); a sensor off the tape is placed from
//!   the other one's rate once that has settled away from its edge, blended
//!   into the estimate (`placement_blend_s`), else from the estimate; with
//!   both off, the guide steers on the estimate at the speed PID's speed,
//!   each sensor kept beyond its edge on the side it last saw the tape.
//!   Found in SITL: from 5° away from the tape the rear sensor
//!   (behind the rear axle) swings off it whatever the vehicle does, the
//!   edge readings on the way out collapsed the measured angle, and the
//!   search at 0.5 m/s took 5–9 s. With dead reckoning on, the approach is
//!   `approach_max_rad` (or the reach's, if larger) and the correction only
//!   `steer_correction_max_rad`: the sensors leaving the tape for a moment
//!   no longer blinds the guide;
//! - with the steering's slew rate known (`steer_rate_rad_s`), the PD acts
//!   on the deviation the vehicle will have once its steering has unwound
//!   to the curve's (`after_unwinding`): found in SITL, a PD on the present
//!   deviation keeps turning while the steering unwinds at 30°/s and
//!   overshoots into a limit cycle on any larger error;
//! - both off the tape past dead reckoning: for `lost_hold_s` keep the last demands (the tape
//!   passing between the sensors' ranges, an edge probe flickering), then
//!   search: steer towards the side the sensors last saw the tape on (the
//!   front sensor's, else the rear's; a sensor cannot cross the tape unseen,
//!   so that side stays true) at the correction limit, until the body has
//!   turned the last angle deviation plus the approach limit, then on at
//!   the search speed with the steering the integral learnt (straight on a
//!   straight, as the seed's §4.3 and Fig. 4c; along an arc it keeps the
//!   approach instead of leaving the arc for good). Never having seen the
//!   tape (a start off it), straight at once, as the seed ("straight"
//!   along the curve the guide took over: on along an arc it was knocked
//!   off, which a truly straight drive off its outside never meets), at the speed
//!   from which the steering can still turn along the tape before the
//!   sensor that finds it has crossed it
//!   ([`MagneticGuideConfig::off_tape_speed_mps`]; `lost_speed_mps` was
//!   slow enough that 2° towards the tape took seconds to reach it). `lost` is
//!   reported throughout;
//! - the steering a curve needs is learnt by the integral from the lateral
//!   error, and also measured: along the tape α changes at v·k − ω, so
//!   k = (α̇ + ω)/v, filtered, is the tape's curvature, and the integral is
//!   pulled towards atan(L·k) while both sensors read the tape away from
//!   their edges ([`MagneticGuideConfig::curvature_pull_s`]). Found in SITL:
//!   an arc beginning under the bench vehicle driving straight needs 16° on
//!   10 m, beyond the 12.3° correction limit, and the integral alone lost
//!   the tape at every speed. Not on the seed's robot (its PD, as the seed);
//! - the speed PID acts on |α| minus a dead band and only lowers the speed
//!   from the cruise speed; with the dead band its integral winds back down
//!   once the vehicle is aligned;
//! - the incremental form keeps its accumulator unclamped for the P and D
//!   increments and integrates only while that does not push further past a
//!   limit: the literal form, clamped, "remembers" saturation (a 1 rad
//!   demand clamped to 0.5 rad comes back as −0.5 rad when the error goes).
//!
//! Sources: docs/references.md §Seed 002.

use super::magnetic_estimate::TapeEstimate;
use super::magnetic_slope::ReadingSlope;
use super::magnetic_turn::{TurnBackModel, search_speed_mps};

/// Probes per sensor.
pub const PROBES: u32 = 16;
/// `num` with the tape centred under the sensor (seed 002 §4.2).
pub const NUM_CENTRED: f64 = (PROBES + 1) as f64;
/// A lost sensor's deviation, in pitches: just beyond the outermost probe
/// (probe 1 is 7.5 pitches right of the centre).
const LOST_EDGE_PITCHES: f64 = PROBES as f64 / 2.0;

/// Seed 002 §4.2's `num`: twice the mean 1-based index of the triggered
/// probes, 2..=32, 17 = centred; `None` when no probe triggers.
pub fn probe_num(mask: u16) -> Option<f64> {
    if mask == 0 {
        return None;
    }
    let (sum, count) = (0..PROBES)
        .filter(|bit| mask & (1 << bit) != 0)
        .fold((0u32, 0u32), |(s, c), bit| (s + bit + 1, c + 1));
    Some(2.0 * f64::from(sum) / f64::from(count))
}

/// The tape's offset from a sensor's centre, positive = tape to the right:
/// (17 − num)·pitch/2. `None` off the tape.
pub fn sensor_deviation_m(mask: u16, probe_pitch_m: f64) -> Option<f64> {
    probe_num(mask).map(|num| (NUM_CENTRED - num) * probe_pitch_m / 2.0)
}

/// Seed eq. 1–2 with signs: (lateral deviation of the midpoint between the
/// sensors, angle deviation) from the front and rear deviations and the
/// sensor spacing. Both positive when the vehicle should steer right.
pub fn lateral_and_angle(front_m: f64, rear_m: f64, spacing_m: f64) -> (f64, f64) {
    let angle_rad = (front_m - rear_m).atan2(spacing_m);
    (0.5 * (front_m + rear_m) * angle_rad.cos(), angle_rad)
}

/// Gains of an incremental PID, in time units so they do not depend on the
/// loop rate: per sample K_I = ki·T and K_D = kd/T (seed eq. 15: K_I =
/// Kp·T/Ti, K_D = Kp·Td/T).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct IncrementalPidGains {
    pub kp: f64,
    /// Per second.
    pub ki: f64,
    /// Seconds.
    pub kd: f64,
    /// Cut-off of a first-order low-pass on the derivative; 0 = none.
    pub d_filter_hz: f64,
}

/// The seed's eq. 15, Δu(k) = K_P(e_k − e_{k−1}) + K_I·e_k +
/// K_D(e_k − 2e_{k−1} + e_{k−2}), accumulated into u(k). The D increment is
/// kept as the change of a (filterable) derivative, which is eq. 15 exactly
/// for a fixed T without the filter.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct IncrementalPid {
    last_error: Option<f64>,
    last_derivative: f64,
    /// u(k−1) before the output limits.
    accumulated: f64,
    /// The integral the first update starts from.
    initial_integral: f64,
    /// The integral after the last update (u − P − D).
    integral: f64,
}

/// One update, with the positional-equivalent terms for telemetry.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct IncrementalTerms {
    /// kp·e_k.
    pub p: f64,
    /// The integral so far (u − p − d).
    pub i: f64,
    /// kd·(de/dt)_k.
    pub d: f64,
    /// Δu(k), as applied.
    pub delta: f64,
    /// u(k), within the output limits.
    pub output: f64,
}

impl IncrementalPid {
    /// A controller whose integral starts at `integral` (bumpless transfer
    /// from whatever set the output before); non-finite means 0.
    pub fn starting_at(integral: f64) -> Self {
        let integral = if integral.is_finite() { integral } else { 0.0 };
        IncrementalPid {
            initial_integral: integral,
            integral,
            ..IncrementalPid::default()
        }
    }

    /// The integral term as of the last update (the starting one before any).
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// Moves the integral (and so the output) by `by`: what it holds learnt
    /// from elsewhere. Non-finite changes nothing.
    pub fn shift_integral(&mut self, by: f64) {
        if by.is_finite() {
            self.accumulated += by;
            self.integral += by;
            self.initial_integral += by;
        }
    }

    /// Advances by `dt_s` with `error`, differencing it for the D term (seed
    /// eq. 15); the output is kept within `min..=max`. The first sample
    /// starts from u = kp·e plus the starting integral, without a derivative
    /// kick, as the positional form does. A non-finite error or step changes
    /// nothing.
    pub fn update(
        &mut self,
        gains: &IncrementalPidGains,
        error: f64,
        dt_s: f64,
        min: f64,
        max: f64,
    ) -> IncrementalTerms {
        if !(error.is_finite() && dt_s.is_finite() && dt_s > 0.0) {
            return self.held(min, max);
        }
        let rate = self.last_error.map_or(0.0, |e| (error - e) / dt_s);
        self.advance(gains, error, rate, dt_s, min, max)
    }

    /// As [`Self::update`], with the error's rate measured rather than
    /// differenced (the D increment is then kd·(ė_k − ė_{k−1})).
    pub fn update_with_rate(
        &mut self,
        gains: &IncrementalPidGains,
        error: f64,
        rate: f64,
        dt_s: f64,
        min: f64,
        max: f64,
    ) -> IncrementalTerms {
        if !(error.is_finite() && rate.is_finite() && dt_s.is_finite() && dt_s > 0.0) {
            return self.held(min, max);
        }
        self.advance(gains, error, rate, dt_s, min, max)
    }

    fn held(&self, min: f64, max: f64) -> IncrementalTerms {
        IncrementalTerms {
            i: self.integral,
            output: self.accumulated.clamp(min, max),
            ..IncrementalTerms::default()
        }
    }

    fn advance(
        &mut self,
        gains: &IncrementalPidGains,
        error: f64,
        raw_rate: f64,
        dt_s: f64,
        min: f64,
        max: f64,
    ) -> IncrementalTerms {
        let first = self.last_error.is_none();
        let (last_error, last_derivative) = match self.last_error {
            Some(e) => (e, self.last_derivative),
            None => {
                // Start where the positional form would: u = kp·e + I, the
                // D term following from a zero last rate.
                self.accumulated = gains.kp * error + self.initial_integral;
                (error, 0.0)
            }
        };
        let derivative = if gains.d_filter_hz > 0.0 && !first {
            low_pass(last_derivative, raw_rate, gains.d_filter_hz, dt_s)
        } else {
            raw_rate
        };
        let delta_pd = gains.kp * (error - last_error) + gains.kd * (derivative - last_derivative);
        let delta_i = gains.ki * error * dt_s;
        let unwound = self.accumulated + delta_pd;
        // Integrate only while it does not push further past a limit.
        let delta_i = if (unwound + delta_i > max && delta_i > 0.0) || (unwound + delta_i < min && delta_i < 0.0) {
            0.0
        } else {
            delta_i
        };
        self.accumulated = unwound + delta_i;
        self.last_error = Some(error);
        self.last_derivative = derivative;
        let p = gains.kp * error;
        let d = gains.kd * derivative;
        self.integral = self.accumulated - p - d;
        IncrementalTerms {
            p,
            i: self.integral,
            d,
            delta: delta_pd + delta_i,
            output: self.accumulated.clamp(min, max),
        }
    }

    pub fn reset(&mut self) {
        *self = IncrementalPid::default();
    }
}

/// One step of a first-order low-pass with cut-off `cutoff_hz`.
fn low_pass(last: f64, input: f64, cutoff_hz: f64, dt_s: f64) -> f64 {
    let rc_s = 1.0 / (std::f64::consts::TAU * cutoff_hz);
    last + dt_s / (dt_s + rc_s) * (input - last)
}

/// Where the lateral deviation's rate for the steering D term comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LateralRate {
    /// Differenced from sample to sample, as seed eq. 15 writes it. The
    /// reading moves in 2.5 mm steps (the mean of two 5 mm ones): at 50 Hz
    /// each step is a 0.125 m/s spike, so it wants `d_filter_hz`.
    Difference,
    /// From the geometry the two sensors measure: the midpoint's offset
    /// changes at v·tan α − ω·x_mid (x_mid from the rear axle). Its
    /// resolution is v·pitch/(2d): 3.75 mm/s at 1.5 m/s over 2 m.
    Kinematic,
}

/// Everything the guide needs; the `MAG_*` parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MagneticGuideConfig {
    /// Probe pitch of both sensors.
    pub probe_pitch_m: f64,
    /// Body x of the sensors' centres from the point that does not slip
    /// sideways (the rear axle centre; the wheel axle of a differential
    /// vehicle). The spacing d is their difference.
    pub front_x_m: f64,
    pub rear_x_m: f64,
    /// Lateral deviation (m) → centre steering angle (rad): kp rad/m,
    /// ki rad/(m·s) (0 in the seed), kd rad·s/m.
    pub steer: IncrementalPidGains,
    pub steer_max_rad: f64,
    /// Limit of the PD terms: the correction about the integral (the
    /// geometric [`Self::correction_limit_rad`] applies as well).
    pub steer_correction_max_rad: f64,
    /// Front axle to rear axle (the no-slip point): turns steering into yaw
    /// rate for the correction limit.
    pub wheelbase_m: f64,
    pub lateral_rate: LateralRate,
    /// |angle deviation| − dead band (rad) → speed reduction (m/s).
    pub speed: IncrementalPidGains,
    pub angle_deadband_rad: f64,
    /// Speed on the tape when aligned.
    pub cruise_speed_mps: f64,
    /// The speed PID never asks for less.
    pub min_speed_mps: f64,
    /// Speed while both sensors are off the tape after losing it, and the
    /// least a start off the tape searches at
    /// ([`Self::off_tape_speed_mps`]).
    pub lost_speed_mps: f64,
    /// For this long after both sensors lose the tape, keep the last demands
    /// (and what the sensors last saw) before going straight; 0 = straight at
    /// once, as the seed.
    pub lost_hold_s: f64,
    /// Low-pass on each sensor's own rate, which places a sensor that is off
    /// the tape when the other one is on it.
    pub sensor_rate_filter_hz: f64,
    /// The tape's curvature, measured while both sensors read it (the angle
    /// deviation's change along the way plus the yaw rate), pulls the
    /// steering integral towards the steering that curvature needs with
    /// this time constant; 0 = off (the integral learns it from the lateral
    /// error alone).
    pub curvature_pull_s: f64,
    /// Low-pass on the measured curvature.
    pub curvature_filter_hz: f64,
    /// Both sensors off the tape: steer on the deviation carried forward
    /// from the last readings ([`TapeEstimate`]) this long, at the speed
    /// the speed PID sets, before the hold and the search; 0 = never.
    pub dead_reckon_s: f64,
    /// The steering's slew rate; 0 = unknown. The control law then acts on
    /// the deviation the vehicle will have once its steering has unwound
    /// (see `after_unwinding`).
    pub steer_rate_rad_s: f64,
    /// With dead reckoning, the largest approach angle the P term steers to
    /// (the sensors' reach, [`Self::approach_limit_rad`], when larger);
    /// the correction is then limited only by `steer_correction_max_rad`.
    pub approach_max_rad: f64,
    /// One sensor on the tape, the estimate running: the other sensor's
    /// placement from the seen one's rate is blended into the estimate's
    /// with this time constant; 0 = taken as placed.
    pub placement_blend_s: f64,
}

impl Default for MagneticGuideConfig {
    /// For general driving on the bench vehicle (2.9 m wheelbase, 30°/s
    /// steering) with the sensors 1 m either side of the rear axle, at
    /// 50 Hz: the seed's P and D, and an integral (learnt while tracking) so
    /// that curves entered from a straight are held without a standing
    /// offset; dead reckoning for 1.5 s, so no correction limit below full
    /// lock (the geometric one, 12.3° here, applies only without it) and
    /// approaches up to 8°. `furrow-bench magnetic` measures it: back
    /// within 1.4 s from 0.1 m and 5° towards the tape (3.0 s away from
    /// it) at 1.5 m/s on a straight and on 25, 15 and 10 m arcs, never off a tape running into
    /// arcs of 10 m and more.
    fn default() -> Self {
        Self {
            probe_pitch_m: 0.010,
            front_x_m: 1.0,
            rear_x_m: -1.0,
            steer: IncrementalPidGains {
                kp: 9.0,
                ki: 2.0,
                kd: 6.0,
                d_filter_hz: 0.0,
            },
            steer_max_rad: 30f64.to_radians(),
            steer_correction_max_rad: 30f64.to_radians(),
            wheelbase_m: 2.9,
            lateral_rate: LateralRate::Kinematic,
            // Slowing down costs time to re-acquire (the steering, not the
            // speed, limits it): only past 5° and gently.
            speed: IncrementalPidGains {
                kp: 3.0,
                ki: 1.0,
                kd: 0.0,
                d_filter_hz: 0.0,
            },
            angle_deadband_rad: 5f64.to_radians(),
            cruise_speed_mps: 1.5,
            min_speed_mps: 0.5,
            lost_speed_mps: 0.5,
            lost_hold_s: 0.3,
            sensor_rate_filter_hz: 3.0,
            // Measured on the bench AGV driving onto a 10 m arc at 1.5 m/s
            // (tried 0.5–5 Hz, 0.05–0.5 s): slower loses the tape; a faster
            // filter passes the readings' 5 mm steps (straight p99 4–6 mm
            // at 3–5 Hz, 2.5 mm here).
            curvature_pull_s: 0.1,
            curvature_filter_hz: 2.0,
            dead_reckon_s: 1.5,
            steer_rate_rad_s: 30f64.to_radians(),
            approach_max_rad: 8f64.to_radians(),
            // Measured on the bench AGV 0.1 m / 5° away from the tape at
            // 1.5 m/s (tried 0.05–0.3 s): the rear sensor's last readings
            // before it swings off, placed from its 3 Hz rate, put the front
            // one 0.07 m short, and the blind stretch began from there.
            placement_blend_s: 0.1,
        }
    }
}

impl MagneticGuideConfig {
    /// d, front sensor to rear sensor.
    pub fn sensor_spacing_m(&self) -> f64 {
        self.front_x_m - self.rear_x_m
    }

    /// How far from a sensor's centre the tape is still read: its outermost
    /// probe's centre (the tape's own width adds a little, unknown here).
    pub fn sensor_reach_m(&self) -> f64 {
        (f64::from(PROBES) - 1.0) / 2.0 * self.probe_pitch_m.abs()
    }

    /// The largest approach angle that keeps both sensors on the tape with
    /// the sensors' midpoint at `lateral_m`: |y| + (d/2)·sin α within the
    /// reach. Further out than the reach one sensor is off anyway; the
    /// approach is then the angle at which both can read the tape with the
    /// midpoint on it, so that the vehicle arrives at the tape able to keep
    /// it.
    pub fn approach_limit_rad(&self, lateral_m: f64) -> f64 {
        let half_spacing_m = (self.sensor_spacing_m().abs() / 2.0).max(f64::EPSILON);
        let reach_m = self.sensor_reach_m();
        let centred = (reach_m / half_spacing_m).min(1.0);
        let here = (reach_m - lateral_m.abs()) / half_spacing_m;
        // Near the reach `here` goes to 0 and would stall the approach: no
        // less than half the centred angle.
        here.clamp(APPROACH_FLOOR * centred, centred).asin()
    }

    /// The approach angle the P term steers to at `lateral_m`: the sensors'
    /// reach, or with dead reckoning `approach_max_rad` if larger.
    pub fn approach_max_rad(&self, lateral_m: f64) -> f64 {
        let reach_rad = self.approach_limit_rad(lateral_m);
        if self.dead_reckon_s > 0.0 {
            reach_rad.max(self.approach_max_rad.abs())
        } else {
            reach_rad
        }
    }

    /// The largest correction whose yaw rate sweeps the outer sensor across
    /// the tape no faster than the approach limit does: tan δ·|x|max/L ≤
    /// sin α_max.
    pub fn correction_limit_rad(&self) -> f64 {
        let outer_x_m = self.front_x_m.abs().max(self.rear_x_m.abs()).max(f64::EPSILON);
        let sin_alpha = self.approach_limit_rad(0.0).sin();
        (self.wheelbase_m.abs() * sin_alpha / outer_x_m).atan()
    }

    /// The correction limit: the configured one, within the geometric one
    /// unless the guide dead-reckons.
    pub fn correction_max_rad(&self) -> f64 {
        let configured_rad = self.steer_correction_max_rad.abs();
        if self.dead_reckon_s > 0.0 {
            configured_rad
        } else {
            configured_rad.min(self.correction_limit_rad())
        }
    }

    /// The speed of a start with no sensor on the tape (seed 002 §4.3:
    /// straight on until a sensor triggers, then correct): the fastest, up
    /// to the cruise speed and no slower than `lost_speed_mps`, at which the
    /// vehicle meeting the tape at the approach angle (`approach_max_rad`,
    /// or the sensors' reach's if larger) can turn along it, the largest
    /// correction about `curve_rad` at the steering's slew rate, before the
    /// sensor that found it at one edge has crossed to the other
    /// ([`search_speed_mps`]). Without a known slew rate, `lost_speed_mps`.
    pub fn off_tape_speed_mps(&self, curve_rad: f64) -> f64 {
        let floor_mps = self.lost_speed_mps.max(0.0);
        let model = TurnBackModel {
            speed_mps: self.cruise_speed_mps,
            wheelbase_m: self.wheelbase_m.abs(),
            steer_rate_rad_s: self.steer_rate_rad_s,
            curve_rad: if curve_rad.is_finite() { curve_rad } else { 0.0 },
            correction_rad: self.correction_max_rad(),
            steer_max_rad: self.steer_max_rad.abs(),
            mid_x_m: 0.5 * (self.front_x_m + self.rear_x_m),
        };
        if !model.usable() || self.cruise_speed_mps <= floor_mps {
            return floor_mps;
        }
        let approach_rad = self.approach_max_rad(0.0);
        search_speed_mps(
            &model,
            approach_rad,
            self.sensor_reach_m(),
            floor_mps,
            self.cruise_speed_mps,
        )
    }

    /// Tuned for seed 002's figure (back on a curve within 2 s, correction
    /// within ±10°) on the same vehicle: the seed's PD (K_I = 0) with the
    /// correction limited to ±10° about the steering it took over. Without
    /// an integral, a curve needing more than 10° beyond that steering (on
    /// the bench vehicle: tighter than 16.4 m, entered from a straight) is
    /// beyond it, and any curve is held with a standing offset of
    /// steering/kp. The geometric correction limit applies as well.
    pub fn seed_figure() -> Self {
        Self {
            steer: IncrementalPidGains {
                kp: 9.0,
                ki: 0.0,
                kd: 6.0,
                d_filter_hz: 0.0,
            },
            steer_correction_max_rad: 10f64.to_radians(),
            curvature_pull_s: 0.0,
            placement_blend_s: 0.0,
            ..Self::default()
        }
    }
}

/// One control step's inputs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MagneticInput {
    /// Probe masks, bit i−1 = probe i, probe 1 rightmost.
    pub front_mask: u16,
    pub rear_mask: u16,
    /// Measured (or, lacking that, commanded) forward speed and yaw rate
    /// (positive = clockwise): the kinematic rate and a lost sensor's
    /// placement need them.
    pub speed_mps: f64,
    pub yaw_rate_rad_s: f64,
}

/// What the guide saw and decided in one update.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MagneticStatus {
    /// Seed §4.2 `num` of each sensor (`None` off the tape).
    pub front_num: Option<f64>,
    pub rear_num: Option<f64>,
    /// e1, e2 as read (positive = tape to the right).
    pub front_m: Option<f64>,
    pub rear_m: Option<f64>,
    /// e1, e2 as used: a lost sensor's is placed from the other's.
    pub front_used_m: f64,
    pub rear_used_m: f64,
    /// Midpoint's lateral deviation, its rate as used by the D term, and the
    /// angle deviation (all 0 when lost).
    pub lateral_m: f64,
    pub lateral_rate_mps: f64,
    pub angle_rad: f64,
    /// Neither sensor sees the tape.
    pub lost: bool,
    /// Both sensors see the tape.
    pub acquired: bool,
    pub steer: IncrementalTerms,
    pub speed: IncrementalTerms,
    /// The demands: centre (bicycle) steering angle, positive = right, and
    /// vehicle speed.
    pub steer_rad: f64,
    pub speed_mps: f64,
}

/// A sensor's history since the tape was last fully lost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct SensorTrack {
    /// The last reading, while it is on the tape.
    current_m: Option<f64>,
    /// Its filtered rate while on the tape.
    rate_mps: f64,
    /// How long it has been on the tape without a break.
    on_tape_s: f64,
    /// A line through its readings since it found the tape: its rate before
    /// the low-pass one has settled.
    slope: ReadingSlope,
    /// It found the tape after being off it, and has read it since without
    /// a reading inside the trusted range: an edge reading then is the tape
    /// coming in, where it reads, not "this far or further" (see
    /// [`pushed_out`]). Once a reading is trusted an edge reading is the
    /// tape going out again, and is pushed out.
    came_in: bool,
    /// While it is off the tape: the side the tape is on (±1), once known.
    /// It cannot change without the sensor seeing the tape on the way
    /// across, so it is kept until then.
    side: Option<f64>,
}

impl SensorTrack {
    /// Its rate: the low-pass one once settled, before that the line
    /// through its readings once there are enough; `None` until then.
    fn known_rate_mps(&self, config: &MagneticGuideConfig) -> Option<f64> {
        if self.on_tape_s >= rate_settle_s(config) {
            Some(self.rate_mps)
        } else {
            self.slope.rate_mps()
        }
    }

    fn update(&mut self, reading_m: Option<f64>, trust_m: f64, cutoff_hz: f64, dt_s: f64) {
        self.rate_mps = match (self.current_m, reading_m) {
            (Some(last), Some(now)) if dt_s > 0.0 => low_pass(self.rate_mps, (now - last) / dt_s, cutoff_hz, dt_s),
            _ => 0.0,
        };
        self.on_tape_s = match (self.current_m, reading_m) {
            (Some(_), Some(_)) => self.on_tape_s + dt_s.max(0.0),
            _ => 0.0,
        };
        self.slope.update(reading_m, dt_s);
        self.came_in = match (self.current_m, reading_m) {
            (None, Some(_)) => true,
            (Some(_), Some(now)) => self.came_in && now.abs() > trust_m,
            _ => false,
        };
        self.current_m = reading_m;
        if let Some(now) = reading_m.filter(|r| *r != 0.0) {
            self.side = Some(now.signum());
        }
    }
}

/// The guide's state between updates.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MagneticGuide {
    steer: IncrementalPid,
    speed: IncrementalPid,
    front: SensorTrack,
    rear: SensorTrack,
    /// How long both sensors have been off the tape.
    lost_s: f64,
    /// The last demands made with the tape in sight.
    last_steer_rad: f64,
    last_speed_mps: f64,
    /// The last angle deviation with the tape in sight.
    last_angle_rad: f64,
    /// Whether either sensor has seen the tape since the guide started.
    seen_tape: bool,
    /// The search after losing the tape, once the hold is over.
    search: Option<Search>,
    curvature: CurvatureEstimate,
    /// The deviation as last measured, carried forward since.
    estimate: Option<TapeEstimate>,
    /// The speed of a start off the tape, once worked out.
    off_tape_speed_mps: Option<f64>,
}

/// The tape's curvature from the angle deviation and the yaw rate: along
/// the tape the angle deviation changes at v·k − ω.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct CurvatureEstimate {
    /// The last angle deviation read by both sensors, while it goes on.
    last_angle_rad: Option<f64>,
    /// Filtered, positive = curving right (1/m).
    per_m: f64,
    /// How long the filter has run without a break.
    settled_s: f64,
}

impl CurvatureEstimate {
    /// Advances with `angle_rad` (None: no trustworthy reading, restart).
    fn update(&mut self, angle_rad: Option<f64>, speed_mps: f64, yaw_rate_rad_s: f64, cutoff_hz: f64, dt_s: f64) {
        let moving = speed_mps.abs() > MIN_RATE_SPEED_MPS && dt_s > 0.0 && cutoff_hz > 0.0;
        match (self.last_angle_rad, angle_rad) {
            (Some(last), Some(now)) if moving => {
                let raw = ((now - last) / dt_s + yaw_rate_rad_s) / speed_mps;
                self.per_m = if self.settled_s > 0.0 {
                    low_pass(self.per_m, raw, cutoff_hz, dt_s)
                } else {
                    yaw_rate_rad_s / speed_mps
                };
                self.settled_s += dt_s;
            }
            _ => self.settled_s = 0.0,
        }
        self.last_angle_rad = angle_rad.filter(|_| moving);
    }

    /// The curvature once the filter has settled.
    fn settled_per_m(&self, cutoff_hz: f64) -> Option<f64> {
        let needed_s = RATE_SETTLE_TIME_CONSTANTS / (std::f64::consts::TAU * cutoff_hz);
        (self.settled_s >= needed_s).then_some(self.per_m)
    }
}

/// One of the two sensors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Sensor {
    Front,
    Rear,
}

/// Turning back towards where the tape was lost.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Search {
    /// +1 the tape is to the right, −1 left; 0 unknown (straight on).
    side: f64,
    /// How much more to turn towards it before going on with the steering
    /// the integral learnt.
    turn_left_rad: f64,
}

/// The approach limit never goes below this fraction of the centred one.
const APPROACH_FLOOR: f64 = 0.5;

/// A sensor's rate, and the side of the other sensor it implies, is trusted
/// after this many time constants of its filter.
const RATE_SETTLE_TIME_CONSTANTS: f64 = 3.0;
/// A reading this many pitches inside the outermost probe or closer to the
/// centre is taken as it is; further out it sticks at the outer probes.
/// Sticking starts once the tape's far edge passes the outermost probe:
/// half a 30 mm tape plus the probes' reach beyond it, 1.75 pitches of
/// 10 mm (found in the bench: at 1.5 the last "trusted" readings of a
/// sensor leaving the tape moved at half the rate, which placed the other
/// sensor short).
const TRUST_MARGIN_PITCHES: f64 = 1.75;
/// Below this speed a sensor's rate says nothing about the tape's direction.
const MIN_RATE_SPEED_MPS: f64 = 0.05;

/// How long a sensor's rate filter takes to settle.
fn rate_settle_s(config: &MagneticGuideConfig) -> f64 {
    RATE_SETTLE_TIME_CONSTANTS / (std::f64::consts::TAU * config.sensor_rate_filter_hz)
}

/// How far from a sensor's centre a reading is taken as it is (see
/// `TRUST_MARGIN_PITCHES`).
fn trusted_reach_m(config: &MagneticGuideConfig) -> f64 {
    config.sensor_reach_m() - TRUST_MARGIN_PITCHES * config.probe_pitch_m.abs()
}

/// An edge reading (beyond `trust_m`) only says "this far or further": it
/// is pushed out to the prediction when that is further on the same side.
fn pushed_out(read_m: Option<f64>, predicted_m: Option<f64>, trust_m: f64) -> Option<f64> {
    match (read_m, predicted_m) {
        (Some(e), Some(p)) if e.abs() > trust_m && p.signum() == e.signum() && p.abs() > e.abs() => Some(p),
        _ => read_m,
    }
}

impl MagneticGuide {
    /// A guide taking over a vehicle that already steers `steer_rad` (the
    /// mode engaging while driving): the steering PID's integral starts
    /// there, so the incremental form carries the steering a curve needs
    /// instead of asking the lateral error to hold it.
    pub fn engaged_at(steer_rad: f64) -> Self {
        MagneticGuide {
            steer: IncrementalPid::starting_at(steer_rad),
            last_steer_rad: if steer_rad.is_finite() { steer_rad } else { 0.0 },
            ..MagneticGuide::default()
        }
    }

    pub fn reset(&mut self) {
        *self = MagneticGuide::default();
    }

    /// One control step, `dt_s` after the last.
    pub fn update(&mut self, config: &MagneticGuideConfig, input: &MagneticInput, dt_s: f64) -> MagneticStatus {
        let pitch_m = config.probe_pitch_m;
        let front_m = sensor_deviation_m(input.front_mask, pitch_m);
        let rear_m = sensor_deviation_m(input.rear_mask, pitch_m);
        let mut status = MagneticStatus {
            front_num: probe_num(input.front_mask),
            rear_num: probe_num(input.rear_mask),
            front_m,
            rear_m,
            lost: front_m.is_none() && rear_m.is_none(),
            acquired: front_m.is_some() && rear_m.is_some(),
            ..MagneticStatus::default()
        };
        if front_m.is_some() || rear_m.is_some() {
            self.lost_s = 0.0;
            self.seen_tape = true;
            self.search = None;
        }
        let cutoff_hz = config.sensor_rate_filter_hz;
        let trust_m = trusted_reach_m(config);
        self.front.update(front_m, trust_m, cutoff_hz, dt_s);
        self.rear.update(rear_m, trust_m, cutoff_hz, dt_s);
        let spacing_m = config.sensor_spacing_m();
        let speed_mps = input.speed_mps;
        let Some((e1, e2)) = self.used_deviations(config, front_m, rear_m, input, dt_s) else {
            (status.steer_rad, status.speed_mps) = self.lost_demand(config, input, dt_s);
            return status;
        };
        let (lateral_m, angle_rad) = lateral_and_angle(e1, e2, spacing_m);
        if let Some(estimate) = self.estimate.as_mut() {
            // What the readings and the estimate made of it, its age kept.
            *estimate = TapeEstimate {
                lateral_m,
                angle_rad,
                ..*estimate
            };
        }
        self.pull_towards_curve(config, status.acquired.then_some((e1, e2, angle_rad)), input, dt_s);
        // The integral is for the steering a curve needs, learnt while
        // tracking; integrating the large errors of a recovery winds it up
        // and overshoots, so only with both sensors on the tape and the
        // body within half the approach limit.
        let tracking = status.acquired && angle_rad.abs() <= 0.5 * config.approach_limit_rad(0.0);
        let steer_gains = IncrementalPidGains {
            ki: if tracking { config.steer.ki } else { 0.0 },
            ..config.steer
        };
        let (steer, lateral_rate_mps) = self.steer_terms(config, &steer_gains, lateral_m, angle_rad, input, dt_s);
        let max_cut_mps = (config.cruise_speed_mps - config.min_speed_mps).max(0.0);
        let speed = self.speed.update(
            &config.speed,
            angle_rad.abs() - config.angle_deadband_rad,
            dt_s,
            0.0,
            max_cut_mps,
        );
        let steer_rad = self.limited_steer_rad(config, &steer, lateral_m, speed_mps);
        self.last_angle_rad = angle_rad;
        self.last_steer_rad = steer_rad;
        self.last_speed_mps = config.cruise_speed_mps - speed.output;
        MagneticStatus {
            front_used_m: e1,
            rear_used_m: e2,
            lateral_m,
            lateral_rate_mps,
            angle_rad,
            steer,
            speed,
            steer_rad,
            speed_mps: config.cruise_speed_mps - speed.output,
            ..status
        }
    }

    /// The steering PID's terms on the lateral offset, with the lateral rate
    /// it used (m/s): differenced from the readings, or the kinematic rate
    /// from the speed, the tape angle and the yaw rate.
    fn steer_terms(
        &mut self,
        config: &MagneticGuideConfig,
        steer_gains: &IncrementalPidGains,
        lateral_m: f64,
        angle_rad: f64,
        input: &MagneticInput,
        dt_s: f64,
    ) -> (IncrementalTerms, f64) {
        let steer_max_rad = config.steer_max_rad.abs();
        match config.lateral_rate {
            LateralRate::Difference => {
                let terms = self
                    .steer
                    .update(steer_gains, lateral_m, dt_s, -steer_max_rad, steer_max_rad);
                (
                    terms,
                    if config.steer.kd != 0.0 {
                        terms.d / config.steer.kd
                    } else {
                        0.0
                    },
                )
            }
            LateralRate::Kinematic => {
                let mid_x_m = (config.front_x_m + config.rear_x_m) / 2.0;
                let (lead_lateral_m, lead_angle_rad) = self.after_unwinding(config, lateral_m, angle_rad, input);
                let rate_mps = input.speed_mps * lead_angle_rad.tan() - input.yaw_rate_rad_s * mid_x_m;
                let terms = self.steer.update_with_rate(
                    steer_gains,
                    lead_lateral_m,
                    rate_mps,
                    dt_s,
                    -steer_max_rad,
                    steer_max_rad,
                );
                (terms, rate_mps)
            }
        }
    }

    /// The steering angle from the PID's terms: the integral plus the
    /// limited PD correction, within the lock.
    fn limited_steer_rad(
        &self,
        config: &MagneticGuideConfig,
        steer: &IncrementalTerms,
        lateral_m: f64,
        speed_mps: f64,
    ) -> f64 {
        let steer_max_rad = config.steer_max_rad.abs();
        // The seed's "correction angle": the PD part, about the integral
        // (which holds what the path's curvature needs), with the P part
        // limited to the approach angle the sensors can keep.
        let p_max = config.steer.kd.abs() * speed_mps.abs() * config.approach_max_rad(lateral_m).sin();
        let p = if config.steer.kd > 0.0 {
            steer.p.clamp(-p_max, p_max)
        } else {
            steer.p
        };
        let correction_max_rad = config.correction_max_rad();
        (steer.i + (p + steer.d).clamp(-correction_max_rad, correction_max_rad)).clamp(-steer_max_rad, steer_max_rad)
    }

    /// The front and rear deviations the control law uses (see the module
    /// documentation): as read; an edge reading, which only says "this far
    /// or further", pushed out to where the carried-forward estimate puts
    /// the tape; a sensor off the tape placed beyond its edge; both off, the
    /// estimate's for `dead_reckon_s`. `None`: nothing to steer on. Keeps
    /// the estimate: reset by a trustworthy reading, else carried forward.
    fn used_deviations(
        &mut self,
        config: &MagneticGuideConfig,
        front_m: Option<f64>,
        rear_m: Option<f64>,
        input: &MagneticInput,
        dt_s: f64,
    ) -> Option<(f64, f64)> {
        let predicted = self.predicted_estimate(config, input, dt_s);
        let (pf, pr) = match predicted {
            Some(p) => {
                let (f, r) = p.sensor_deviations_m(config.sensor_spacing_m());
                (Some(f), Some(r))
            }
            None => (None, None),
        };
        let trust_m = trusted_reach_m(config);
        let trusted = |e: f64| e.abs() <= trust_m;
        // A sensor the tape has just come into reads where the tape is.
        let front_used = if self.front.came_in {
            front_m
        } else {
            pushed_out(front_m, pf, trust_m)
        };
        let rear_used = if self.rear.came_in {
            rear_m
        } else {
            pushed_out(rear_m, pr, trust_m)
        };
        let (e1, e2, fresh) = match (front_used, rear_used) {
            (Some(f), Some(r)) => (
                f,
                r,
                predicted.is_none() || (front_m.is_some_and(trusted) && rear_m.is_some_and(trusted)),
            ),
            (Some(f), None) => {
                let (r, settled) = self.place_other(config, Sensor::Front, f, pr, input, dt_s);
                (f, r, predicted.is_some() || settled)
            }
            (None, Some(r)) => {
                let (f, settled) = self.place_other(config, Sensor::Rear, r, pf, input, dt_s);
                (f, r, predicted.is_some() || settled)
            }
            (None, None) => return self.dead_reckoned(config, predicted, dt_s),
        };
        self.estimate = if fresh {
            Some(TapeEstimate::measured(0.0, 0.0))
        } else {
            predicted
        };
        Some((e1, e2))
    }

    /// The estimate carried forward by `dt_s`, while it is young enough to
    /// steer on; the tape's curvature taken as what the integral steers.
    fn predicted_estimate(
        &self,
        config: &MagneticGuideConfig,
        input: &MagneticInput,
        dt_s: f64,
    ) -> Option<TapeEstimate> {
        let curvature_per_m = self.integral_curvature_per_m(config);
        let mid_x_m = 0.5 * (config.front_x_m + config.rear_x_m);
        self.estimate
            .filter(|e| e.age_s < config.dead_reckon_s)
            .map(|e| e.predicted(input.speed_mps, input.yaw_rate_rad_s, curvature_per_m, mid_x_m, dt_s))
    }

    /// The curvature the steering integral drives (what the guide has
    /// learnt of the tape's curve).
    fn integral_curvature_per_m(&self, config: &MagneticGuideConfig) -> f64 {
        if config.wheelbase_m.abs() > f64::EPSILON {
            self.steer.integral().tan() / config.wheelbase_m.abs()
        } else {
            0.0
        }
    }

    /// Only `seen` reads the tape (`seen_m`): the other sensor's placement,
    /// from the seen one's rate once that has settled away from the edge
    /// (where the reading sticks), else from the estimate (`predicted_other_m`)
    /// while there is one; and whether the rate had settled.
    fn place_other(
        &mut self,
        config: &MagneticGuideConfig,
        seen: Sensor,
        seen_m: f64,
        predicted_other_m: Option<f64>,
        input: &MagneticInput,
        dt_s: f64,
    ) -> (f64, bool) {
        let (seen_track, x_m, towards) = match seen {
            Sensor::Front => (self.front, config.front_x_m, -1.0),
            Sensor::Rear => (self.rear, config.rear_x_m, 1.0),
        };
        let low_pass_settled = seen_track.on_tape_s >= rate_settle_s(config) && seen_m.abs() <= trusted_reach_m(config);
        // With nothing carried forward, a line through the seen sensor's
        // first readings is the best there is (see `ReadingSlope`).
        let fitted = predicted_other_m.is_none() && seen_track.slope.rate_mps().is_some();
        let settled = low_pass_settled || fitted;
        let from_rate_m = self.other_sensor_m(config, &seen_track, x_m, seen_m, towards, input);
        let estimate_m = match predicted_other_m {
            // The rate-placed sensor jitters by d·Δrate/v (the reading's
            // steps): blended into the carried-forward estimate, not reset
            // to it, so that the estimate a blind stretch starts from is not
            // one unlucky step.
            Some(p) if settled && config.placement_blend_s > 0.0 => {
                p + (dt_s.max(0.0) / config.placement_blend_s).min(1.0) * (from_rate_m - p)
            }
            _ => predicted_other_m.filter(|_| !settled).unwrap_or(from_rate_m),
        };
        // The side is decided once the rate has settled and the seen sensor
        // has read inside its trusted range since the tape came in (edge
        // readings stick: their rate says nothing), or the line puts the
        // blind sensor clearly on one side; until then it is a guess, kept
        // open. Found in the bench:
        // 0.05 m / 8° away the rear sensor starts at its edge, its stuck
        // readings said "parallel", and the front's side locked on that put
        // the tape on the wrong side: the guide drove off the tape.
        let decided = (seen_track.on_tape_s >= rate_settle_s(config) && !seen_track.came_in)
            || (fitted && estimate_m.abs() >= 0.5 * config.sensor_reach_m());
        let lost = match seen {
            Sensor::Front => &mut self.rear,
            Sensor::Rear => &mut self.front,
        };
        // The side from the rate itself once settled: the blend starts
        // from a placement kept beyond the edge, so it alone would never
        // cross to the other side.
        let side_m = if settled { from_rate_m } else { estimate_m };
        (Self::place_lost(lost, decided, estimate_m, side_m, config), settled)
    }

    /// The other sensor's deviation from this one (`track`, at `x_m`,
    /// reading `e_m`), `towards` it (+1 forwards): along this sensor's local
    /// tape direction (a sensor moving along the tape sees it drift across
    /// at v·tan α − ω·x), the tape bending by k·d²/2 on the way (y'' = k
    /// either way). While the rate settles its filter leans on 0, which
    /// says "the vehicle follows the tape": k is then the vehicle's own
    /// curvature ω/v, which keeps that prior whole (with the sensors
    /// symmetric about the rear axle, the other sensor reads the same);
    /// once settled, the tape's (the integral's). Found in SITL: with the
    /// unsettled rate and no bend, on a 10 m arc the other sensor was
    /// placed 0.2 m off on the wrong side and the vehicle steered away from
    /// the tape.
    fn other_sensor_m(
        &self,
        config: &MagneticGuideConfig,
        track: &SensorTrack,
        x_m: f64,
        e_m: f64,
        towards: f64,
        input: &MagneticInput,
    ) -> f64 {
        let (speed_mps, yaw_rate) = (input.speed_mps, input.yaw_rate_rad_s);
        let moving = speed_mps.abs() > MIN_RATE_SPEED_MPS;
        let rate_mps = track.known_rate_mps(config).unwrap_or(track.rate_mps);
        let tan_alpha = if moving {
            (rate_mps + yaw_rate * x_m) / speed_mps
        } else {
            0.0
        };
        let k = if track.on_tape_s >= rate_settle_s(config) {
            self.integral_curvature_per_m(config)
        } else if moving {
            yaw_rate / speed_mps
        } else {
            0.0
        };
        let spacing_m = config.sensor_spacing_m();
        e_m + towards * spacing_m * tan_alpha + 0.5 * k * spacing_m.powi(2)
    }

    /// Both sensors off the tape: the estimate, if there is one and the tape
    /// has been seen, each sensor kept beyond its edge on the side it last
    /// saw the tape (reading nothing, an estimate that puts the tape under
    /// it is pushed out that far).
    fn dead_reckoned(
        &mut self,
        config: &MagneticGuideConfig,
        predicted: Option<TapeEstimate>,
        dt_s: f64,
    ) -> Option<(f64, f64)> {
        let p = predicted.filter(|_| self.seen_tape)?;
        self.lost_s += dt_s.max(0.0);
        let edge_m = LOST_EDGE_PITCHES * config.probe_pitch_m.abs();
        let beyond = |e: f64, side: Option<f64>| match side {
            Some(side) if side * e < edge_m => side * edge_m,
            _ => e,
        };
        let spacing_m = config.sensor_spacing_m();
        let (f, r) = p.sensor_deviations_m(spacing_m);
        let (f, r) = (beyond(f, self.front.side), beyond(r, self.rear.side));
        let (lateral_m, angle_rad) = lateral_and_angle(f, r, spacing_m);
        self.estimate = Some(TapeEstimate {
            lateral_m,
            angle_rad,
            ..p
        });
        Some((f, r))
    }

    /// Measures the tape's curvature while both sensors read it away from
    /// their edges (there the reading sticks at the outer probes), and pulls
    /// the steering integral towards what that curvature needs: the
    /// integral alone learns it from the lateral error, too slowly to hold
    /// an arc that needs more than the correction limit beyond it.
    fn pull_towards_curve(
        &mut self,
        config: &MagneticGuideConfig,
        reading: Option<(f64, f64, f64)>,
        input: &MagneticInput,
        dt_s: f64,
    ) {
        let trust_m = trusted_reach_m(config);
        let angle_rad = reading
            .filter(|(e1, e2, _)| e1.abs() <= trust_m && e2.abs() <= trust_m)
            .map(|(_, _, angle_rad)| angle_rad);
        let cutoff_hz = config.curvature_filter_hz;
        self.curvature
            .update(angle_rad, input.speed_mps, input.yaw_rate_rad_s, cutoff_hz, dt_s);
        let Some(curvature_per_m) = self.curvature.settled_per_m(cutoff_hz) else {
            return;
        };
        if config.curvature_pull_s <= 0.0 || angle_rad.is_none() {
            return;
        }
        let steer_max_rad = config.steer_max_rad.abs();
        let curve_rad = (config.wheelbase_m.abs() * curvature_per_m)
            .atan()
            .clamp(-steer_max_rad, steer_max_rad);
        let pull = (dt_s / config.curvature_pull_s).min(1.0);
        self.steer.shift_integral((curve_rad - self.steer.integral()) * pull);
    }

    /// The lateral and angle deviation once the steering has unwound to
    /// the curve's (the integral) at `steer_rate_rad_s`: the yaw rate beyond
    /// the curve's, ω − v·k, falls to 0 over t = |δ − δ_I|/rate, turning the
    /// angle by (ω − v·k)·t/2 more and moving the lateral deviation by
    /// v·α·t − v·(ω − v·k)·t²/3. Steering on these rather than on the
    /// present ones stops the correction in time: found in SITL, a PD on
    /// the present ones keeps turning while the steering unwinds at the
    /// rate limit, and overshoots into a limit cycle on any larger error.
    fn after_unwinding(
        &self,
        config: &MagneticGuideConfig,
        lateral_m: f64,
        angle_rad: f64,
        input: &MagneticInput,
    ) -> (f64, f64) {
        let (speed_mps, yaw_rate) = (input.speed_mps, input.yaw_rate_rad_s);
        let wheelbase_m = config.wheelbase_m.abs();
        if config.steer_rate_rad_s <= 0.0 || speed_mps.abs() <= MIN_RATE_SPEED_MPS || wheelbase_m <= f64::EPSILON {
            return (lateral_m, angle_rad);
        }
        let curve_rad = self.steer.integral();
        let steer_now_rad = (yaw_rate * wheelbase_m / speed_mps).atan();
        let unwind_s = (steer_now_rad - curve_rad).abs() / config.steer_rate_rad_s;
        let excess_rate = yaw_rate - speed_mps * curve_rad.tan() / wheelbase_m;
        let lead_angle_rad = angle_rad - excess_rate * unwind_s / 2.0;
        let lead_lateral_m =
            lateral_m + speed_mps * angle_rad.tan() * unwind_s - speed_mps * excess_rate * unwind_s.powi(2) / 3.0;
        (lead_lateral_m, lead_angle_rad)
    }

    /// The demands with both sensors off the tape: the hold, then the
    /// search (see the module documentation).
    fn lost_demand(&mut self, config: &MagneticGuideConfig, input: &MagneticInput, dt_s: f64) -> (f64, f64) {
        self.lost_s += dt_s.max(0.0);
        if !self.seen_tape {
            // Seed §4.3: a start off the tape drives straight until a sensor
            // finds it; "straight" along the curve the guide took over
            // (its integral, 0 from rest). Found in SITL: knocked off the
            // outside of an arc it was following and driving truly
            // straight, the robot never met the tape again.
            let speed_mps = *self
                .off_tape_speed_mps
                .get_or_insert_with(|| config.off_tape_speed_mps(self.steer.integral()));
            return (self.steer.integral(), speed_mps);
        }
        if self.lost_s <= config.lost_hold_s {
            // A gap between the sensors' ranges, or an edge probe
            // flickering: carry on as commanded.
            return (self.last_steer_rad, self.last_speed_mps);
        }
        let search = match self.search {
            Some(search) => search,
            None => self.start_search(config),
        };
        // Turning towards the tape is progress; the curve's steering (the
        // integral) turns the body too, which counts.
        let turned_rad = search.side * input.yaw_rate_rad_s * dt_s.max(0.0);
        let turn_left_rad = search.turn_left_rad - turned_rad.max(0.0);
        self.search = Some(Search {
            turn_left_rad,
            ..search
        });
        let turn_rad = if search.side != 0.0 && turn_left_rad > 0.0 {
            search.side * config.correction_max_rad()
        } else {
            0.0
        };
        let steer_max_rad = config.steer_max_rad.abs();
        let steer_rad = (self.steer.integral() + turn_rad).clamp(-steer_max_rad, steer_max_rad);
        (steer_rad, config.lost_speed_mps)
    }

    /// The search starts: which side the tape went, and how far to turn
    /// back. What the sensors read is stale by now, their sides are not;
    /// the steering integral (what the path's curvature needs) neither, so
    /// the guide starts from it when the tape is back.
    fn start_search(&mut self, config: &MagneticGuideConfig) -> Search {
        let side = self.front.side.or(self.rear.side).unwrap_or(0.0);
        let search = Search {
            side,
            turn_left_rad: self.last_angle_rad.abs() + config.approach_limit_rad(0.0),
        };
        let fresh = MagneticGuide {
            steer: IncrementalPid::starting_at(self.steer.integral()),
            front: SensorTrack {
                side: self.front.side,
                ..SensorTrack::default()
            },
            rear: SensorTrack {
                side: self.rear.side,
                ..SensorTrack::default()
            },
            lost_s: self.lost_s,
            seen_tape: true,
            search: Some(search),
            ..MagneticGuide::default()
        };
        *self = fresh;
        search
    }

    /// Where a sensor that is off the tape probably has it: at least just
    /// past its outermost probe, on the side it last saw it (the tape left
    /// through that edge) or, never having seen it, on the side the other
    /// sensor's reading and rate put it (`side_m`'s sign; decided once that
    /// rate has settled with a reading inside the trusted range, or a line
    /// through its first readings puts it clearly on one side); further out
    /// if `estimate_m` says so.
    fn place_lost(
        lost: &mut SensorTrack,
        decided: bool,
        estimate_m: f64,
        side_m: f64,
        config: &MagneticGuideConfig,
    ) -> f64 {
        let edge_m = LOST_EDGE_PITCHES * config.probe_pitch_m;
        let side = match lost.side {
            Some(side) => side,
            None if side_m == 0.0 => return 0.0,
            None => {
                if decided {
                    lost.side = Some(side_m.signum());
                }
                side_m.signum()
            }
        };
        if estimate_m.signum() == side {
            estimate_m.abs().max(edge_m) * side
        } else {
            edge_m * side
        }
    }
}
