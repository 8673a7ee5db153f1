//! Per-task timing statistics with a fixed-size histogram, so recording is
//! allocation-free on the tick and the median/p99 can be read at any time.

/// Counts durations in buckets 1/64 of their octave wide (log-linear, as
/// HdrHistogram does): exact below 64 ns, within 1.6 % above (64 ns wide at
/// 5 µs, 512 ns at 50 µs), up to 2^40 ns (18 min); anything longer lands in
/// the last bucket (its true maximum is kept separately). The same relative
/// precision at every scale in 9 kB.
#[derive(Clone, Debug)]
pub struct DurationHistogram {
    counts: [u32; BUCKETS],
    count: u64,
    max_ns: u64,
}

/// Sub-buckets per octave: 2^SUB_BITS.
const SUB_BITS: u32 = 6;
const SUB: u64 = 1 << SUB_BITS;
/// Octaves above the exact range: up to 2^MAX_BITS ns.
const MAX_BITS: u32 = 40;
const BUCKETS: usize = (SUB as usize) * (1 + (MAX_BITS - SUB_BITS) as usize);

impl Default for DurationHistogram {
    fn default() -> Self {
        DurationHistogram {
            counts: [0; BUCKETS],
            count: 0,
            max_ns: 0,
        }
    }
}

/// The bucket of a duration.
fn bucket_of(ns: u64) -> usize {
    if ns < SUB {
        return ns as usize;
    }
    // ns in [2^msb, 2^(msb+1)), split into SUB buckets of 2^octave ns.
    let msb = 63 - ns.leading_zeros();
    let octave = msb - SUB_BITS;
    let index = SUB * (1 + u64::from(octave)) + ((ns >> octave) - SUB);
    (index as usize).min(BUCKETS - 1)
}

/// The lower edge of a bucket, ns.
fn bucket_floor_ns(index: usize) -> u64 {
    let index = index as u64;
    if index < SUB {
        return index;
    }
    let octave = index / SUB - 1;
    (SUB + index % SUB) << octave
}

impl DurationHistogram {
    pub fn record(&mut self, ns: u64) {
        let bucket = &mut self.counts[bucket_of(ns)];
        *bucket = bucket.saturating_add(1);
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
    /// (exact below 64 ns, within 1.6 % above).
    pub fn quantile_ns(&self, q: f64) -> u64 {
        if self.count == 0 {
            return 0;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.count as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (i, n) in self.counts.iter().enumerate() {
            seen += u64::from(*n);
            if seen >= rank {
                return bucket_floor_ns(i);
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
        // 2500 ns lies in a 32 ns bucket from 2496, 4950 in a 64 ns one from 4928.
        assert_eq!(h.quantile_ns(0.5), 2496);
        assert_eq!(h.quantile_ns(0.99), 4928);
        assert_eq!(h.max_ns(), 5000);
        h.record(5_000_000);
        assert_eq!(h.quantile_ns(1.0), 4_980_736);
        assert_eq!(h.max_ns(), 5_000_000);
    }

    #[test]
    fn every_duration_lands_in_the_bucket_whose_edges_hold_it() {
        for ns in (0..100_000u64)
            .chain((0..64).map(|b| 1u64 << (b % 40)))
            .chain([u64::MAX / 3])
        {
            let i = bucket_of(ns);
            let floor = bucket_floor_ns(i);
            assert!(floor <= ns, "{ns} below its bucket's floor {floor}");
            if i + 1 < BUCKETS {
                assert!(ns < bucket_floor_ns(i + 1), "{ns} at or past the next bucket's floor");
                // Relative width within 1/64 (exact below 64 ns).
                assert!(
                    bucket_floor_ns(i + 1) - floor <= (floor / SUB).max(1),
                    "bucket {i} too wide"
                );
            }
        }
    }
}
