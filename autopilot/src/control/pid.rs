//! A PID controller as a pure state update: the caller passes the error and
//! the time step, gains are explicit.

/// Gains and limits.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PidGains {
    pub kp: f64,
    pub ki: f64,
    pub kd: f64,
    /// The integrator's contribution is clamped to ±imax.
    pub imax: f64,
}

/// Integrator and last error.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PidState {
    integral: f64,
    last_error: Option<f64>,
}

/// The three terms of one update, for telemetry and tuning.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PidTerms {
    pub p: f64,
    pub i: f64,
    pub d: f64,
}

impl PidTerms {
    pub fn output(&self) -> f64 {
        self.p + self.i + self.d
    }
}

impl PidState {
    /// Advances by `dt_s` with `error`; a non-finite error or step leaves the
    /// state unchanged and outputs zero.
    pub fn update(&mut self, gains: &PidGains, error: f64, dt_s: f64) -> PidTerms {
        if !error.is_finite() || !dt_s.is_finite() || dt_s <= 0.0 {
            return PidTerms::default();
        }
        if gains.ki != 0.0 {
            let limit = gains.imax.abs() / gains.ki.abs();
            self.integral = (self.integral + error * dt_s).clamp(-limit, limit);
        } else {
            self.integral = 0.0;
        }
        let derivative = self.last_error.map_or(0.0, |e| (error - e) / dt_s);
        self.last_error = Some(error);
        PidTerms {
            p: gains.kp * error,
            i: gains.ki * self.integral,
            d: gains.kd * derivative,
        }
    }

    pub fn reset(&mut self) {
        *self = PidState::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proportional_integral_derivative() {
        let g = PidGains {
            kp: 2.0,
            ki: 1.0,
            kd: 0.5,
            imax: 10.0,
        };
        let mut s = PidState::default();
        let t = s.update(&g, 1.0, 0.1);
        assert_eq!(t.p, 2.0);
        assert!((t.i - 0.1).abs() < 1e-12);
        assert_eq!(t.d, 0.0, "no derivative kick on the first sample");
        let t = s.update(&g, 2.0, 0.1);
        assert!((t.d - 5.0).abs() < 1e-12);
    }

    #[test]
    fn integrator_is_limited() {
        let g = PidGains {
            kp: 0.0,
            ki: 1.0,
            kd: 0.0,
            imax: 0.5,
        };
        let mut s = PidState::default();
        for _ in 0..1000 {
            s.update(&g, 1.0, 0.1);
        }
        assert!((s.update(&g, 1.0, 0.1).i - 0.5).abs() < 1e-12);
    }

    #[test]
    fn nan_is_ignored() {
        let g = PidGains {
            kp: 1.0,
            ki: 1.0,
            kd: 1.0,
            imax: 1.0,
        };
        let mut s = PidState::default();
        assert_eq!(s.update(&g, f64::NAN, 0.1).output(), 0.0);
        assert_eq!(s, PidState::default());
    }
}
