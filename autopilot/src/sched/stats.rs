//! Per-task timing statistics with a fixed-size histogram, so recording is
//! allocation-free on the tick and the median/p99 can be read at any time.

/// Counts durations in 1 µs buckets up to 1 ms, then in 100 µs buckets up
/// to 100 ms; anything longer lands in the last bucket.
#[derive(Clone, Debug)]
pub struct DurationHistogram {
    fine: [u64; 1000],
    coarse: [u64; 1000],
    count: u64,
    max_us: u64,
}

impl Default for DurationHistogram {
    fn default() -> Self {
        DurationHistogram {
            fine: [0; 1000],
            coarse: [0; 1000],
            count: 0,
            max_us: 0,
        }
    }
}

impl DurationHistogram {
    pub fn record(&mut self, us: u64) {
        if us < 1000 {
            self.fine[us as usize] += 1;
        } else {
            let bucket = ((us - 1000) / 100).min(999);
            self.coarse[bucket as usize] += 1;
        }
        self.count += 1;
        self.max_us = self.max_us.max(us);
    }

    pub fn count(&self) -> u64 {
        self.count
    }

    pub fn max_us(&self) -> u64 {
        self.max_us
    }

    /// The smallest bucket value below which a fraction `q` of the samples
    /// lie (bucket lower edge; exact to 1 µs under 1 ms).
    pub fn quantile_us(&self, q: f64) -> u64 {
        if self.count == 0 {
            return 0;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.count as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (us, n) in self.fine.iter().enumerate() {
            seen += n;
            if seen >= rank {
                return us as u64;
            }
        }
        for (bucket, n) in self.coarse.iter().enumerate() {
            seen += n;
            if seen >= rank {
                return 1000 + bucket as u64 * 100;
            }
        }
        self.max_us
    }
}

/// Runs, overruns and timing of one task.
#[derive(Clone, Debug)]
pub struct TaskStats {
    pub budget_us: u32,
    pub runs: u64,
    pub overruns: u64,
    pub histogram: Box<DurationHistogram>,
}

impl TaskStats {
    pub fn new(budget_us: u32) -> Self {
        TaskStats {
            budget_us,
            runs: 0,
            overruns: 0,
            histogram: Box::default(),
        }
    }

    pub fn record(&mut self, us: u64) {
        self.runs += 1;
        if self.budget_us > 0 && us > u64::from(self.budget_us) {
            self.overruns += 1;
        }
        self.histogram.record(us);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_of_a_known_distribution() {
        let mut h = DurationHistogram::default();
        for us in 1..=100 {
            h.record(us);
        }
        assert_eq!(h.quantile_us(0.5), 50);
        assert_eq!(h.quantile_us(0.99), 99);
        assert_eq!(h.max_us(), 100);
        h.record(5_000);
        assert_eq!(h.quantile_us(1.0), 5_000);
    }
}
