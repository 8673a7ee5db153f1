//! The best re-acquire time a vehicle's steering allows, for
//! `furrow-bench magnetic` to print next to what the guide measured: a
//! guide that knew exactly where the tape is, steering the largest
//! correction one way, then the other, then straight, at the steering's
//! slew rate, at a constant speed.
//!
//! The model is the kinematic bicycle on a straight tape (on an arc, in the
//! curve's frame, the correction about the curve's steering does the same to
//! first order), with the steering slewing at its rate and no lag (which
//! only makes the bound lower). Re-acquired means both sensors' centres
//! within the tolerance from then on: the schedule's end plus a second of
//! driving straight. The best is searched over the two phases' lengths (for
//! each first-phase length, the second one that ends aligned, by bisection),
//! in both orders: a search over one family of manoeuvres, not a proof that
//! nothing faster exists, but no guide that reads the tape can beat a
//! manoeuvre planned with the truth by much.

/// Integration step.
const STEP_S: f64 = 0.005;
/// The first phase is tried in steps this long, up to `LONGEST_PHASE_S`.
const PHASE_STEP_S: f64 = 0.01;
const LONGEST_PHASE_S: f64 = 4.0;
/// Driven straight after the schedule: the sensors must stay within the
/// tolerance for this long.
const HOLD_S: f64 = 1.0;
const BISECTIONS: usize = 16;

/// The vehicle, its sensors and the start, all the bound needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundCase {
    pub wheelbase_m: f64,
    /// Largest steering either way about the curve's, and its slew rate.
    pub correction_rad: f64,
    pub steer_rate_rad_s: f64,
    /// Sensor centres forward of the rear axle.
    pub front_x_m: f64,
    pub rear_x_m: f64,
    pub speed_mps: f64,
    /// The sensors' midpoint this far from the tape…
    pub offset_m: f64,
    /// …heading this far away from it (negative: towards it).
    pub away_rad: f64,
    pub tolerance_m: f64,
}

/// The best manoeuvre: the correction limit towards the tape (or away,
/// if not `towards_first`) for `first_s`, the other way for `second_s`,
/// then straight; back within the tolerance after `time_s`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Manoeuvre {
    pub time_s: f64,
    pub towards_first: bool,
    pub first_s: f64,
    pub second_s: f64,
}

/// The pose relative to the tape (the x axis): rear axle lateral `y_m` on
/// the start's side, heading `psi_rad` away from the tape, steering
/// `steer_rad` (positive turns away).
#[derive(Clone, Copy, Debug)]
struct State {
    y_m: f64,
    psi_rad: f64,
    steer_rad: f64,
}

impl BoundCase {
    /// The best time found, seconds; `None` if no manoeuvre of the family
    /// gets back within the tolerance.
    pub fn best_time_s(&self) -> Option<f64> {
        self.best_manoeuvre().map(|m| m.time_s)
    }

    /// The fastest manoeuvre of the family, `None` if none gets back within
    /// the tolerance.
    pub fn best_manoeuvre(&self) -> Option<Manoeuvre> {
        let mut best: Option<Manoeuvre> = None;
        for towards_first in [true, false] {
            let phases = (LONGEST_PHASE_S / PHASE_STEP_S).round() as usize;
            for i in 0..=phases {
                let first_s = i as f64 * PHASE_STEP_S;
                let Some(second_s) = self.aligning_second_phase_s(towards_first, first_s) else {
                    continue;
                };
                if let Some(time_s) = self.reacquire_time_s(towards_first, first_s, second_s)
                    && best.is_none_or(|b| time_s < b.time_s)
                {
                    best = Some(Manoeuvre {
                        time_s,
                        towards_first,
                        first_s,
                        second_s,
                    });
                }
            }
        }
        best
    }

    /// The yaw rate at the correction limit, rad/s: how fast the heading
    /// can turn at all.
    pub fn yaw_rate_at_limit_rad_s(&self) -> f64 {
        self.speed_mps * self.correction_rad.tan() / self.wheelbase_m
    }

    /// The time to slew the steering from straight to the limit, s.
    pub fn slew_to_limit_s(&self) -> f64 {
        if self.steer_rate_rad_s > 0.0 {
            self.correction_rad / self.steer_rate_rad_s
        } else {
            f64::INFINITY
        }
    }

    fn start(&self) -> State {
        let mid_x_m = 0.5 * (self.front_x_m + self.rear_x_m);
        State {
            y_m: self.offset_m - mid_x_m * self.away_rad.sin(),
            psi_rad: self.away_rad,
            steer_rad: 0.0,
        }
    }

    /// The steering commanded at `t_s`: the correction towards the tape (or
    /// away, if not `towards_first`) for `first_s`, the other way for
    /// `second_s`, then none.
    fn command_rad(&self, towards_first: bool, first_s: f64, second_s: f64, t_s: f64) -> f64 {
        let first = if towards_first { -1.0 } else { 1.0 } * self.correction_rad;
        if t_s < first_s {
            first
        } else if t_s < first_s + second_s {
            -first
        } else {
            0.0
        }
    }

    fn step(&self, state: &mut State, command_rad: f64) {
        let slew_rad = self.steer_rate_rad_s * STEP_S;
        let steer_rad = state.steer_rad + (command_rad - state.steer_rad).clamp(-slew_rad, slew_rad);
        let yaw_rate = |steer: f64| self.speed_mps * steer.tan() / self.wheelbase_m;
        let psi_rad = state.psi_rad + 0.5 * (yaw_rate(state.steer_rad) + yaw_rate(steer_rad)) * STEP_S;
        state.y_m += self.speed_mps * (0.5 * (state.psi_rad + psi_rad)).sin() * STEP_S;
        state.psi_rad = psi_rad;
        state.steer_rad = steer_rad;
    }

    /// The farther sensor's distance from the tape.
    fn error_m(&self, state: &State) -> f64 {
        let sin = state.psi_rad.sin();
        (state.y_m + self.front_x_m * sin)
            .abs()
            .max((state.y_m + self.rear_x_m * sin).abs())
    }

    /// Time until the steering is back at 0 after the schedule.
    fn schedule_end_s(&self, first_s: f64, second_s: f64) -> f64 {
        let unwind_s = if self.steer_rate_rad_s > 0.0 {
            self.correction_rad / self.steer_rate_rad_s
        } else {
            0.0
        };
        first_s + second_s + unwind_s + STEP_S
    }

    /// The heading once the schedule is over.
    fn final_heading_rad(&self, towards_first: bool, first_s: f64, second_s: f64) -> f64 {
        let mut state = self.start();
        let end_s = self.schedule_end_s(first_s, second_s);
        let mut t_s = 0.0;
        while t_s < end_s {
            self.step(&mut state, self.command_rad(towards_first, first_s, second_s, t_s));
            t_s += STEP_S;
        }
        state.psi_rad
    }

    /// The second phase's length that ends with the heading along the tape.
    fn aligning_second_phase_s(&self, towards_first: bool, first_s: f64) -> Option<f64> {
        // Longer second phases turn further back: the heading left is
        // monotonic in it.
        let sign = if towards_first { 1.0 } else { -1.0 };
        let residual = |second_s: f64| sign * self.final_heading_rad(towards_first, first_s, second_s);
        let (mut low_s, mut high_s) = (0.0, LONGEST_PHASE_S);
        if residual(low_s) > 0.0 || residual(high_s) < 0.0 {
            return None;
        }
        for _ in 0..BISECTIONS {
            let mid_s = 0.5 * (low_s + high_s);
            if residual(mid_s) < 0.0 {
                low_s = mid_s;
            } else {
                high_s = mid_s;
            }
        }
        Some(0.5 * (low_s + high_s))
    }

    /// The first instant from which both sensors stay within the tolerance
    /// to the schedule's end plus `HOLD_S`.
    fn reacquire_time_s(&self, towards_first: bool, first_s: f64, second_s: f64) -> Option<f64> {
        let mut state = self.start();
        let end_s = self.schedule_end_s(first_s, second_s) + HOLD_S;
        let (mut t_s, mut since) = (0.0, Some(0.0));
        while t_s < end_s {
            if self.error_m(&state) >= self.tolerance_m {
                since = None;
            } else if since.is_none() {
                since = Some(t_s);
            }
            self.step(&mut state, self.command_rad(towards_first, first_s, second_s, t_s));
            t_s += STEP_S;
        }
        since
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn robot(offset_m: f64, away_deg: f64) -> BoundCase {
        BoundCase {
            wheelbase_m: 0.87,
            correction_rad: 10f64.to_radians(),
            steer_rate_rad_s: 30f64.to_radians(),
            front_x_m: 0.5,
            rear_x_m: -0.5,
            speed_mps: 1.5,
            offset_m,
            away_rad: away_deg.to_radians(),
            tolerance_m: 0.010,
        }
    }

    #[test]
    fn on_the_tape_it_is_there_at_once() {
        assert_eq!(robot(0.0, 0.0).best_time_s(), Some(0.0));
    }

    /// Further off or turned further away takes longer, and never less than
    /// turning back the heading alone at the largest yaw rate.
    #[test]
    fn harder_starts_take_longer() {
        let near = robot(0.05, 2.0).best_time_s().expect("near");
        let far = robot(0.15, 2.0).best_time_s().expect("far");
        let away = robot(0.15, 8.0).best_time_s().expect("away");
        assert!(near < far && far < away, "{near} {far} {away}");
        let yaw_rate = 1.5 * 10f64.to_radians().tan() / 0.87;
        assert!(away > 8f64.to_radians() / yaw_rate, "{away}");
    }
}
