//! Actuator dynamics: a first-order lag whose rate is clipped, solved exactly
//! over a step (a linear slew while the lag would exceed the limit, then the
//! exponential tail), so results do not depend on the physics rate.

/// `x` after `h_s` seconds of ẋ = clamp((target − x)/tau, ±limit).
/// `tau_s` ≤ 0 is a pure slew at `limit`; `limit` may be infinite.
pub(crate) fn lag_limited(x: f64, target: f64, tau_s: f64, limit: f64, h_s: f64) -> f64 {
    let err = target - x;
    if err == 0.0 || h_s <= 0.0 {
        return x;
    }
    let dir = err.signum();
    let mut gap = err.abs();
    let mut h_s = h_s;
    if tau_s <= 0.0 {
        let travel = limit * h_s;
        return if travel >= gap { target } else { x + dir * travel };
    }
    let band = limit * tau_s;
    if gap > band {
        let slew_s = (gap - band) / limit;
        if h_s <= slew_s {
            return x + dir * limit * h_s;
        }
        gap = band;
        h_s -= slew_s;
    }
    target - dir * gap * (-h_s / tau_s).exp()
}

/// Time for [`lag_limited`] to move `x` to `boundary`, which lies strictly
/// between `x` and `target` (so it is reached in finite time if `limit` > 0).
fn time_to_reach(x: f64, target: f64, boundary: f64, tau_s: f64, limit: f64) -> f64 {
    let gap = (target - x).abs();
    let gap_at_boundary = (target - boundary).abs();
    if tau_s <= 0.0 {
        return (gap - gap_at_boundary) / limit;
    }
    let band = limit * tau_s;
    if gap_at_boundary >= band {
        return (gap - gap_at_boundary) / limit;
    }
    let slew_s = (gap - band).max(0.0) / limit;
    slew_s + tau_s * (gap.min(band) / gap_at_boundary).ln()
}

/// A drive: lagged speed whose acceleration is limited by `accel_max` while
/// |v| grows and by `brake_max` while it shrinks.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Drive {
    pub tau_s: f64,
    pub accel_max_mps2: f64,
    pub brake_max_mps2: f64,
}

impl Drive {
    /// Speed after `h_s` seconds chasing `target_mps`. Going through zero
    /// brakes down to zero, then accelerates the other way.
    pub(crate) fn advance(&self, v_mps: f64, target_mps: f64, h_s: f64) -> f64 {
        let shrinking = v_mps != 0.0 && (target_mps - v_mps).signum() != v_mps.signum();
        if !shrinking {
            return lag_limited(v_mps, target_mps, self.tau_s, self.accel_max_mps2, h_s);
        }
        let reverses = target_mps != 0.0 && target_mps.signum() != v_mps.signum();
        if !reverses {
            return lag_limited(v_mps, target_mps, self.tau_s, self.brake_max_mps2, h_s);
        }
        let to_zero_s = time_to_reach(v_mps, target_mps, 0.0, self.tau_s, self.brake_max_mps2);
        if to_zero_s >= h_s {
            return lag_limited(v_mps, target_mps, self.tau_s, self.brake_max_mps2, h_s);
        }
        lag_limited(0.0, target_mps, self.tau_s, self.accel_max_mps2, h_s - to_zero_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slews_then_decays() {
        // Gap 1, band 0.5·0.1 = 0.05: slews 0.95/0.5 = 1.9 s, then decays.
        assert!((lag_limited(0.0, 1.0, 0.1, 0.5, 1.0) - 0.5).abs() < 1e-12);
        let after_slew = lag_limited(0.0, 1.0, 0.1, 0.5, 1.9);
        assert!((after_slew - 0.95).abs() < 1e-12);
        let tail = lag_limited(0.0, 1.0, 0.1, 0.5, 2.0);
        assert!((tail - (1.0 - 0.05 * (-1.0f64).exp())).abs() < 1e-12);
    }

    #[test]
    fn splitting_a_step_changes_nothing() {
        let whole = lag_limited(0.2, -0.4, 0.1, 0.5, 0.37);
        let mut x = 0.2;
        for _ in 0..37 {
            x = lag_limited(x, -0.4, 0.1, 0.5, 0.01);
        }
        assert!((whole - x).abs() < 1e-12);
    }

    #[test]
    fn pure_slew_and_pure_lag() {
        assert_eq!(lag_limited(0.0, 1.0, 0.0, 2.0, 0.25), 0.5);
        assert_eq!(lag_limited(0.0, 1.0, 0.0, 2.0, 1.0), 1.0);
        let lag = lag_limited(0.0, 1.0, 0.5, f64::INFINITY, 0.5);
        assert!((lag - (1.0 - (-1.0f64).exp())).abs() < 1e-12);
    }

    #[test]
    fn reversal_brakes_to_zero_then_accelerates() {
        let drive = Drive {
            tau_s: 0.0,
            accel_max_mps2: 1.0,
            brake_max_mps2: 2.0,
        };
        // 2 m/s → −1 m/s: 1 s of braking at 2 m/s², then 0.5 s at 1 m/s².
        assert!((drive.advance(2.0, -1.0, 1.0) - 0.0).abs() < 1e-12);
        assert!((drive.advance(2.0, -1.0, 1.5) + 0.5).abs() < 1e-12);
        assert!((drive.advance(2.0, -1.0, 3.0) + 1.0).abs() < 1e-12);
        assert!((drive.advance(-2.0, 0.0, 0.5) + 1.0).abs() < 1e-12);
    }

    #[test]
    fn time_to_reach_agrees_with_lag() {
        let (tau, limit) = (0.3, 2.0);
        let t = time_to_reach(1.0, -0.1, 0.0, tau, limit);
        assert!(lag_limited(1.0, -0.1, tau, limit, t).abs() < 1e-12);
    }
}
