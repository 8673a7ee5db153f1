//! Per-task timing statistics with a fixed-size histogram, so recording is
//! allocation-free on the tick and the median/p99 can be read at any time.

/// Counts durations in 10 ns buckets up to 10 µs, then in 10 µs buckets up
/// to 10 ms; anything longer lands in the last bucket (its true maximum is
/// kept separately).
#[derive(Clone, Debug)]
pub struct DurationHistogram {
    fine: [u64; 1000],
    coarse: [u64; 1000],
    count: u64,
    max_ns: u64,
}

const FINE_NS: u64 = 10;
const COARSE_NS: u64 = 10_000;
const FINE_END_NS: u64 = FINE_NS * 1000;

impl Default for DurationHistogram {
    fn default() -> Self {
        DurationHistogram {
            fine: [0; 1000],
            coarse: [0; 1000],
            count: 0,
            max_ns: 0,
        }
    }
}

impl DurationHistogram {
    pub fn record(&mut self, ns: u64) {
        if ns < FINE_END_NS {
            self.fine[(ns / FINE_NS) as usize] += 1;
        } else {
            let bucket = ((ns - FINE_END_NS) / COARSE_NS).min(999);
            self.coarse[bucket as usize] += 1;
        }
        self.count += 1;
        self.max_ns = self.max_ns.max(ns);
    }

    pub fn count(&self) -> u64 {
        self.count
    }

    pub fn max_ns(&self) -> u64 {
        self.max_ns
    }

    /// The bucket's lower edge below which a fraction `q` of the samples lie
    /// (to 10 ns under 10 µs, to 10 µs above).
    pub fn quantile_ns(&self, q: f64) -> u64 {
        if self.count == 0 {
            return 0;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.count as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (i, n) in self.fine.iter().enumerate() {
            seen += n;
            if seen >= rank {
                return i as u64 * FINE_NS;
            }
        }
        for (i, n) in self.coarse.iter().enumerate() {
            seen += n;
            if seen >= rank {
                return FINE_END_NS + i as u64 * COARSE_NS;
            }
        }
        self.max_ns
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

    pub fn record(&mut self, ns: u64) {
        self.runs += 1;
        if self.budget_us > 0 && ns > u64::from(self.budget_us) * 1000 {
            self.overruns += 1;
        }
        self.histogram.record(ns);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_of_a_known_distribution() {
        let mut h = DurationHistogram::default();
        for k in 1..=100 {
            h.record(k * 50);
        }
        assert_eq!(h.quantile_ns(0.5), 2500);
        assert_eq!(h.quantile_ns(0.99), 4950);
        assert_eq!(h.max_ns(), 5000);
        h.record(5_000_000);
        assert_eq!(h.quantile_ns(1.0), 5_000_000);
    }
}
