//! What turning along the tape takes: from a deviation, the largest
//! correction towards aligning, held just long enough, then unwound to the
//! curve's steering at the steering's slew rate, and where that leaves the
//! tape. MAGNETIC mode's start off the tape uses it to choose its search
//! speed: once a sensor finds the tape at its edge, the vehicle must turn
//! along it before the sensor has crossed it.
//!
//! The model is the one the guide's estimate is carried with
//! ([`TapeEstimate::predicted`]): the vehicle's yaw rate from the bicycle
//! model at the simulated steering, the tape's curvature from the steering
//! the guide has learnt the curve needs.

use super::magnetic_estimate::TapeEstimate;

/// Plan integration step.
const PLAN_STEP_S: f64 = 0.01;
/// The longest turn the plan considers.
const LONGEST_TURN_S: f64 = 4.0;
const BISECTIONS: usize = 14;

/// What the plan needs of the vehicle, its steering and the tape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TurnBackModel {
    pub speed_mps: f64,
    pub wheelbase_m: f64,
    pub steer_rate_rad_s: f64,
    /// The steering the tape's curve needs (the guide's integral).
    pub curve_rad: f64,
    /// The largest correction about it, and the lock.
    pub correction_rad: f64,
    pub steer_max_rad: f64,
    /// The sensors' midpoint ahead of the rear axle.
    pub mid_x_m: f64,
}

/// Turning `direction` (+1 right, −1 left, 0 not at all) with the largest
/// correction for `turn_s`, then unwinding to the curve's steering, ends
/// aligned with the tape, `final_lateral_m` from it (guide signs: positive
/// = the tape to the right).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Alignment {
    pub direction: f64,
    pub turn_s: f64,
    pub final_lateral_m: f64,
}

impl TurnBackModel {
    /// Whether the plan can say anything: moving, with a steering that turns.
    pub fn usable(&self) -> bool {
        let finite = [
            self.speed_mps,
            self.wheelbase_m,
            self.steer_rate_rad_s,
            self.curve_rad,
            self.correction_rad,
            self.steer_max_rad,
            self.mid_x_m,
        ]
        .iter()
        .all(|v| v.is_finite());
        finite
            && self.speed_mps > 0.05
            && self.wheelbase_m > f64::EPSILON
            && self.steer_rate_rad_s > 0.0
            && self.correction_rad > 0.0
    }

    /// The steering commanded for a turn `direction`: the curve's plus the
    /// correction, within the lock.
    pub fn command_rad(&self, direction: f64) -> f64 {
        let max_rad = self.steer_max_rad.abs();
        (self.curve_rad + direction * self.correction_rad.abs()).clamp(-max_rad, max_rad)
    }

    /// Where the tape is once the steering, now `steer_rad`, has turned
    /// `direction` for `turn_s` and then unwound to the curve's.
    fn after(&self, start: TapeEstimate, steer_rad: f64, direction: f64, turn_s: f64) -> TapeEstimate {
        let curvature_per_m = self.curve_rad.tan() / self.wheelbase_m;
        let slew_rad = self.steer_rate_rad_s * PLAN_STEP_S;
        let turn_cmd_rad = self.command_rad(direction);
        let max_steps =
            ((turn_s + 2.0 * self.steer_max_rad.abs() / self.steer_rate_rad_s) / PLAN_STEP_S).ceil() as usize + 1;
        let (mut estimate, mut steer_rad) = (start, steer_rad);
        for step in 0..max_steps {
            let t_s = step as f64 * PLAN_STEP_S;
            let command_rad = if t_s < turn_s { turn_cmd_rad } else { self.curve_rad };
            if t_s >= turn_s && (steer_rad - self.curve_rad).abs() < 1e-9 {
                break;
            }
            let next_rad = steer_rad + (command_rad - steer_rad).clamp(-slew_rad, slew_rad);
            let mean_rad = 0.5 * (steer_rad + next_rad);
            let yaw_rate = self.speed_mps * mean_rad.tan() / self.wheelbase_m;
            estimate = estimate.predicted(self.speed_mps, yaw_rate, curvature_per_m, self.mid_x_m, PLAN_STEP_S);
            steer_rad = next_rad;
        }
        estimate
    }

    /// The turn that ends aligned from `estimate` with the steering at
    /// `steer_rad`: unwinding at once leaves an angle; the turn towards it,
    /// as long as needed (by bisection: longer turns turn further), cancels it.
    pub fn alignment(&self, estimate: TapeEstimate, steer_rad: f64) -> Alignment {
        let unwound = self.after(estimate, steer_rad, 0.0, 0.0);
        let direction = if unwound.angle_rad > 0.0 {
            1.0
        } else if unwound.angle_rad < 0.0 {
            -1.0
        } else {
            0.0
        };
        if direction == 0.0 {
            return Alignment {
                direction,
                turn_s: 0.0,
                final_lateral_m: unwound.lateral_m,
            };
        }
        let (mut short_s, mut long_s) = (0.0, LONGEST_TURN_S);
        for _ in 0..BISECTIONS {
            let mid_s = 0.5 * (short_s + long_s);
            if self.after(estimate, steer_rad, direction, mid_s).angle_rad * direction > 0.0 {
                short_s = mid_s;
            } else {
                long_s = mid_s;
            }
        }
        let turn_s = 0.5 * (short_s + long_s);
        Alignment {
            direction,
            turn_s,
            final_lateral_m: self.after(estimate, steer_rad, direction, turn_s).lateral_m,
        }
    }
}

/// The fastest speed, within `min_mps..=max_mps`, at which a vehicle
/// driving straight onto the tape at `approach_rad` can, once a sensor
/// finds the tape at its edge, turn along it before that sensor has
/// crossed its whole width (`2·reach_m`): the lateral travel of the
/// aligning turn grows with the speed, so bisection finds it. `model`'s
/// speed is replaced.
pub fn search_speed_mps(model: &TurnBackModel, approach_rad: f64, reach_m: f64, min_mps: f64, max_mps: f64) -> f64 {
    let travel_m = |speed_mps: f64| {
        let model = TurnBackModel { speed_mps, ..*model };
        if !model.usable() {
            return f64::INFINITY;
        }
        let start = TapeEstimate::measured(0.0, approach_rad.abs());
        let plan = model.alignment(start, model.curve_rad);
        if plan.turn_s >= 0.999 * LONGEST_TURN_S {
            // Not aligned within the longest turn the plan considers.
            return f64::INFINITY;
        }
        plan.final_lateral_m.abs()
    };
    let (low, high) = (min_mps.max(0.0), max_mps.max(min_mps));
    if travel_m(high) <= 2.0 * reach_m {
        return high;
    }
    let (mut low, mut high) = (low, high);
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (low + high);
        if travel_m(mid) <= 2.0 * reach_m {
            low = mid;
        } else {
            high = mid;
        }
    }
    low
}

#[cfg(test)]
mod tests {
    use super::*;

    fn robot(speed_mps: f64) -> TurnBackModel {
        TurnBackModel {
            speed_mps,
            wheelbase_m: 0.87,
            steer_rate_rad_s: 30f64.to_radians(),
            curve_rad: 0.0,
            correction_rad: 10f64.to_radians(),
            steer_max_rad: 30f64.to_radians(),
            mid_x_m: 0.0,
        }
    }

    /// Already aligned: no turn, and the tape stays where it is.
    #[test]
    fn aligned_needs_no_turn() {
        let plan = robot(1.5).alignment(TapeEstimate::measured(0.05, 0.0), 0.0);
        assert_eq!(plan.direction, 0.0);
        assert!((plan.final_lateral_m - 0.05).abs() < 1e-12, "{plan:?}");
    }

    /// Heading 5° towards a tape 0.1 m to the right (the tape heads left of
    /// the body: angle −5°): aligning turns left, and ends nearer the tape
    /// than it started, but not past it.
    #[test]
    fn aligning_turns_against_the_angle() {
        let plan = robot(1.5).alignment(TapeEstimate::measured(0.1, -5f64.to_radians()), 0.0);
        assert_eq!(plan.direction, -1.0);
        assert!(plan.turn_s > 0.0 && plan.final_lateral_m < 0.1, "{plan:?}");
        let end = robot(1.5).after(TapeEstimate::measured(0.1, -5f64.to_radians()), 0.0, -1.0, plan.turn_s);
        assert!(end.angle_rad.abs() < 1e-3, "{end:?}");
    }

    /// The search speed: at 8° the paper's robot (±10° about 0.87 m)
    /// turns within the sensors' width even at 1.5 m/s; the bench AGV
    /// (30° about 2.9 m, the same 30°/s) at 10° only slower, at a speed
    /// whose turn does fit; and 2° of correction on the robot turns too
    /// wide at any speed (the travel is L·α²/(2·tan δ) plus the slewing),
    /// so the floor.
    #[test]
    fn search_speed_turns_within_the_sensors_width() {
        let reach_m = 0.075;
        assert_eq!(search_speed_mps(&robot(1.0), 8f64.to_radians(), reach_m, 0.5, 1.5), 1.5);
        let agv = TurnBackModel {
            wheelbase_m: 2.9,
            correction_rad: 30f64.to_radians(),
            ..robot(1.0)
        };
        let approach_rad = 10f64.to_radians();
        let speed_mps = search_speed_mps(&agv, approach_rad, reach_m, 0.5, 1.5);
        assert!(speed_mps > 0.5 && speed_mps < 1.5, "{speed_mps}");
        let at = TurnBackModel { speed_mps, ..agv };
        let travel_m = at
            .alignment(TapeEstimate::measured(0.0, approach_rad), 0.0)
            .final_lateral_m
            .abs();
        assert!((travel_m - 2.0 * reach_m).abs() < 0.002, "{travel_m}");
        let weak = TurnBackModel {
            correction_rad: 2f64.to_radians(),
            ..robot(1.0)
        };
        assert_eq!(search_speed_mps(&weak, 8f64.to_radians(), reach_m, 0.2, 1.5), 0.2);
    }
}
