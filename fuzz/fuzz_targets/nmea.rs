//! NMEA 0183 from a GNSS receiver (`drivers::gnss::NmeaReader`): line
//! framing, checksums, the `nmea` crate's sentences and the hand-parsed THS,
//! HDM and HDG, and an IMU's VectorNav `$VNIMU`/`$VNYMR` lines.
//!
//! Input: byte 0 is a chunk size, the rest the stream. Properties: the
//! samples and counters do not depend on chunking; every sample holds
//! numbers the estimator can use (finite, in range; NaN only where the type
//! documents it); the line buffer stays bounded.
#![no_main]

use std::time::Duration;

use drivers::gnss::{FixQuality, GnssSample, MAX_SENTENCE_LEN, NmeaReader, NmeaStats};
use libfuzzer_sys::fuzz_target;

fn read(stream: &[u8], chunk: usize) -> (Vec<GnssSample>, NmeaStats) {
    let mut reader = NmeaReader::new();
    let mut samples = Vec::new();
    for (i, part) in stream.chunks(chunk.max(1)).enumerate() {
        // Stamps differ per chunk; compare them out below.
        reader.push(Duration::from_millis(i as u64), part, &mut samples);
        assert!(reader.pending_len() <= MAX_SENTENCE_LEN);
    }
    (samples, reader.stats())
}

fn unstamped(sample: &GnssSample) -> GnssSample {
    let mut s = *sample;
    match &mut s {
        GnssSample::Fix(f) => f.t = Duration::ZERO,
        GnssSample::Velocity(v) => v.t = Duration::ZERO,
        GnssSample::Accuracy(a) => a.t = Duration::ZERO,
        GnssSample::Heading(h) => h.t = Duration::ZERO,
        GnssSample::Time(t) => t.t = Duration::ZERO,
        GnssSample::Imu(i) => i.t = Duration::ZERO,
    }
    s
}

fn check(sample: &GnssSample) {
    match sample {
        GnssSample::Fix(f) => {
            if f.quality != FixQuality::NoFix {
                assert!(f.lat_deg.is_finite() && f.lat_deg.abs() <= 90.0, "{f:?}");
                assert!(f.lon_deg.is_finite() && f.lon_deg.abs() <= 180.0, "{f:?}");
            } else {
                assert!(f.lat_deg.is_nan() && f.lon_deg.is_nan(), "{f:?}");
            }
            assert!(!f.alt_msl_m.is_infinite(), "{f:?}");
            assert!(f.hdop.is_nan() || (f.hdop.is_finite() && f.hdop >= 0.0), "{f:?}");
            if let Some(s) = f.utc_time_of_day_s {
                assert!((0.0..86_401.0).contains(&s), "{f:?}");
            }
        }
        GnssSample::Velocity(v) => {
            assert!(v.speed_mps.is_finite() && v.speed_mps >= 0.0, "{v:?}");
            if let Some(c) = v.course_deg {
                assert!((0.0..360.0).contains(&c), "{v:?}");
            }
        }
        GnssSample::Accuracy(a) => {
            assert!(a.sigma_north_m.is_finite() && a.sigma_north_m >= 0.0, "{a:?}");
            assert!(a.sigma_east_m.is_finite() && a.sigma_east_m >= 0.0, "{a:?}");
            if let Some(up) = a.sigma_up_m {
                assert!(up.is_finite() && up >= 0.0, "{a:?}");
            }
        }
        GnssSample::Heading(h) => assert!(h.heading_deg.is_finite(), "{h:?}"),
        GnssSample::Time(_) => {}
        GnssSample::Imu(i) => {
            let values = i.gyro_rad_s.iter().chain(&i.accel_mps2).chain(&i.mag_gauss);
            assert!(values.into_iter().all(|v| v.is_finite()), "{i:?}");
        }
    }
}

/// NaN fields compare unequal: compare samples by their debug text.
fn texts(samples: &[GnssSample]) -> Vec<String> {
    samples.iter().map(|s| format!("{:?}", unstamped(s))).collect()
}

fuzz_target!(|data: &[u8]| {
    let Some((&chunk, stream)) = data.split_first() else {
        return;
    };
    let (whole, whole_stats) = read(stream, stream.len());
    let (chunked, chunked_stats) = read(stream, usize::from(chunk));
    assert_eq!(whole_stats, chunked_stats, "counters depend on chunking");
    assert_eq!(texts(&whole), texts(&chunked), "samples depend on chunking");
    for sample in &whole {
        check(sample);
    }
});
