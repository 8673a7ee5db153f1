//! How fast a sensor's reading moves, from its first samples on the tape: a
//! least-squares line through the readings since the sensor found the tape,
//! older ones fading. The guide's low-pass rate leans on 0 for its first
//! three time constants (0.16 s at 3 Hz), and a sensor that has just found
//! the tape, or is about to leave it, may read it for less than that: found
//! in SITL, the paper's robot 0.1 m / 5° heading away from the tape reads it
//! with its rear sensor for 0.15 s, so the guide never learnt the angle and
//! had nothing to carry through the blind stretch that follows. A line
//! through a few 2.5 mm steps already says which way the tape moves.

/// Readings older than this weigh 1/e.
const FADE_S: f64 = 0.2;
/// A fit needs at least this many readings…
const MIN_SAMPLES: f64 = 4.0;
/// …spanning at least this long.
const MIN_SPAN_S: f64 = 0.05;

/// Weighted sums of (t, reading), t measured back from the latest sample
/// (so that they stay small however long the sensor tracks).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReadingSlope {
    count: f64,
    weight: f64,
    sum_t: f64,
    sum_tt: f64,
    sum_e: f64,
    sum_te: f64,
    /// Time from the oldest reading to the latest.
    span_s: f64,
}

impl ReadingSlope {
    /// Adds `reading_m` `dt_s` after the last one; `None` (the sensor off
    /// the tape) starts over.
    pub fn update(&mut self, reading_m: Option<f64>, dt_s: f64) {
        let Some(e) = reading_m.filter(|e| e.is_finite()) else {
            *self = ReadingSlope::default();
            return;
        };
        let dt_s = if dt_s.is_finite() { dt_s.max(0.0) } else { 0.0 };
        if self.count > 0.0 {
            // Every earlier sample is now dt further back, and fades.
            let fade = (-dt_s / FADE_S).exp();
            self.sum_tt = fade * (self.sum_tt - 2.0 * dt_s * self.sum_t + dt_s * dt_s * self.weight);
            self.sum_t = fade * (self.sum_t - dt_s * self.weight);
            self.sum_te = fade * (self.sum_te - dt_s * self.sum_e);
            self.sum_e *= fade;
            self.weight *= fade;
            self.span_s += dt_s;
        }
        self.count += 1.0;
        self.weight += 1.0;
        self.sum_e += e;
    }

    /// The reading's rate (m/s), once there are enough readings over a
    /// long enough time to fit a line.
    pub fn rate_mps(&self) -> Option<f64> {
        if self.count < MIN_SAMPLES || self.span_s < MIN_SPAN_S {
            return None;
        }
        let denominator = self.weight * self.sum_tt - self.sum_t * self.sum_t;
        (denominator > f64::EPSILON).then(|| (self.weight * self.sum_te - self.sum_t * self.sum_e) / denominator)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reading moving at 0.13 m/s (5° at 1.5 m/s), quantised to 2.5 mm
    /// steps: four readings over 60 ms give the rate within 30 %; fewer
    /// give none; losing the tape starts over.
    #[test]
    fn a_few_quantised_readings_give_the_rate() {
        let mut slope = ReadingSlope::default();
        let reading = |i: usize| (-0.056 - 0.13 * 0.02 * i as f64) / 0.0025;
        for i in 0..3 {
            slope.update(Some(reading(i).round() * 0.0025), 0.02);
            assert_eq!(slope.rate_mps(), None);
        }
        slope.update(Some(reading(3).round() * 0.0025), 0.02);
        let rate = slope.rate_mps().expect("four readings over 60 ms");
        assert!((rate + 0.13).abs() < 0.039, "{rate}");
        for i in 4..200 {
            slope.update(Some(reading(i).round() * 0.0025), 0.02);
        }
        let rate = slope.rate_mps().expect("still tracking");
        assert!((rate + 0.13).abs() < 0.005, "{rate}");
        slope.update(None, 0.02);
        assert_eq!(slope.rate_mps(), None);
    }
}
