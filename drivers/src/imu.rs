//! Inertial samples and the VectorNav ASCII output that carries them.
//!
//! VectorNav's VN-100/VN-200/VN-300 (and units that copy their protocol)
//! stream "asynchronous ASCII outputs": NMEA-0183-style lines of `$`, an
//! address, comma-separated fields, `*`, a checksum and CR LF. Two of them
//! carry the rates and accelerations Furrow reads (VN-100 user manual,
//! registers 27 and 54; `$VNYMR` at 40 Hz is the factory default output):
//!
//! | sentence | fields after the address                                        |
//! |----------|-----------------------------------------------------------------|
//! | `$VNIMU` | magX, magY, magZ (gauss), accelX..Z (m/s²), gyroX..Z (rad/s), temperature (°C), pressure (kPa) |
//! | `$VNYMR` | yaw, pitch, roll (°), magX..Z (gauss), accelX..Z (m/s²), gyroX..Z (rad/s) |
//!
//! Axes are the sensor's body frame: x forward, y right, z down (mount the
//! unit so, or set its reference frame rotation, register 26). At rest and
//! level the accelerometer reads about −9.8 m/s² on z (specific force). The
//! checksum is the 8-bit XOR of the bytes between `$` and `*`, two hex
//! digits: the unit's default. Its optional 16-bit CRC (four digits) is
//! refused as malformed: configure the 8-bit checksum (register 30).
//!
//! The lines go through [`crate::gnss::NmeaReader`] like any NMEA sentence,
//! so an IMU port is a [`crate::gnss::port::GnssPort`] of its own and its
//! samples arrive as [`crate::gnss::GnssSample::Imu`]. `$VNYMR`'s attitude
//! is the unit's own filter (magnetic, pitch and roll from gravity) and is
//! not used: the core estimates heading itself.

use crate::fixed_decimal::FixedDecimal;
use std::io::Write;
use std::time::Duration;

/// One inertial measurement, body frame (x forward, y right, z down).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample {
    pub t: Duration,
    /// Angular rate about x, y, z: z positive turns right (clockwise seen
    /// from above).
    pub gyro_rad_s: [f64; 3],
    /// Specific force: about (0, 0, −9.8) at rest and level.
    pub accel_mps2: [f64; 3],
    /// Magnetic field, gauss.
    pub mag_gauss: [f64; 3],
}

/// Standard gravity.
pub const GRAVITY_MPS2: f64 = 9.80665;

/// Why a VectorNav body was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BadImuSentence;

/// Whether `address` (`VNIMU`, `VNYMR`) is an IMU output this module reads.
pub fn is_imu_address(address: &str) -> bool {
    matches!(address, "VNIMU" | "VNYMR")
}

/// Parses the body of a line (between `$` and `*`, checksum already
/// checked) stamped `t`. Every field must be a finite number: an empty or
/// NaN field (a sensor fault) refuses the whole sample.
pub fn parse_vectornav_body(body: &str, t: Duration) -> Result<ImuSample, BadImuSentence> {
    let mut fields = body.split(',');
    let address = fields.next().ok_or(BadImuSentence)?;
    let (skip, count) = match address {
        "VNIMU" => (0, 11),
        "VNYMR" => (3, 12),
        _ => return Err(BadImuSentence),
    };
    let mut values = [0.0; 12];
    let mut n = 0;
    for field in fields {
        let slot = values.get_mut(n).ok_or(BadImuSentence)?;
        *slot = number(field)?;
        n += 1;
    }
    if n != count {
        return Err(BadImuSentence);
    }
    let v = &values[skip..];
    let triple = |i: usize| [v[i], v[i + 1], v[i + 2]];
    Ok(ImuSample {
        t,
        mag_gauss: triple(0),
        accel_mps2: triple(3),
        gyro_rad_s: triple(6),
    })
}

/// A field as VectorNav writes it (`+00.002066`, `-09.758`): digits, one
/// optional sign and point. Rust's float parser alone would also take
/// `inf`, `NaN` and exponents.
fn number(field: &str) -> Result<f64, BadImuSentence> {
    let digits = field.strip_prefix(['+', '-']).unwrap_or(field);
    let plain = !digits.is_empty()
        && digits.bytes().all(|b| b.is_ascii_digit() || b == b'.')
        && digits.bytes().filter(|&b| b == b'.').count() <= 1
        && digits.bytes().any(|b| b.is_ascii_digit());
    if !plain {
        return Err(BadImuSentence);
    }
    field.parse().map_err(|_| BadImuSentence)
}

/// Appends the `$VNIMU` line (with CR LF) a VectorNav unit sends for
/// `sample`, in its fixed-width format: what the simulator emits, and a
/// reference for adapters. Temperature in °C, pressure in kPa.
pub fn write_vnimu(out: &mut Vec<u8>, sample: &ImuSample, temperature_c: f64, pressure_kpa: f64) {
    let [mx, my, mz] = sample.mag_gauss;
    let [ax, ay, az] = sample.accel_mps2;
    let [gx, gy, gz] = sample.gyro_rad_s;
    out.push(b'$');
    let body_start = out.len();
    // Writing to a Vec cannot fail; once it has grown, nothing allocates.
    // `{:+0w$.d$}` each, through the fixed-decimal fast path.
    let field = |value, decimals, width| FixedDecimal {
        value,
        decimals,
        width,
        plus: true,
    };
    let _ = write!(
        out,
        "VNIMU,{},{},{},{},{},{},{},{},{},{},{}",
        field(mx, 4, 8),
        field(my, 4, 8),
        field(mz, 4, 8),
        field(ax, 3, 7),
        field(ay, 3, 7),
        field(az, 3, 7),
        field(gx, 6, 10),
        field(gy, 6, 10),
        field(gz, 6, 10),
        field(temperature_c, 1, 5),
        field(pressure_kpa, 3, 8),
    );
    let checksum = crate::gnss::nmea_checksum(&out[body_start..]);
    let _ = write!(out, "*{checksum:02X}\r\n");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gnss::{GnssSample, NmeaReader};
    use proptest::prelude::*;

    const T: Duration = Duration::from_millis(250);

    /// A line as a VN-200 sent it (its checksum is the unit's).
    const RECORDED: &str = "$VNIMU,-00.0350,+00.4222,-00.6643,-00.015,+00.019,+09.948,+00.002066,-00.008442,-00.044656,+20.7,+084.322*66\r\n";

    fn read(bytes: &[u8]) -> (Vec<GnssSample>, NmeaReader) {
        let mut reader = NmeaReader::new();
        let mut out = Vec::new();
        reader.push(T, bytes, &mut out);
        (out, reader)
    }

    #[test]
    fn a_recorded_vnimu_line_gives_its_fields() {
        let (out, reader) = read(RECORDED.as_bytes());
        assert_eq!(reader.stats().sentences, 1, "{:?}", reader.stats());
        let [GnssSample::Imu(s)] = out[..] else {
            panic!("{out:?}");
        };
        assert_eq!(s.t, T);
        assert_eq!(s.mag_gauss, [-0.035, 0.4222, -0.6643]);
        assert_eq!(s.accel_mps2, [-0.015, 0.019, 9.948]);
        assert_eq!(s.gyro_rad_s, [0.002066, -0.008442, -0.044656]);
    }

    #[test]
    fn vnymr_skips_the_units_attitude() {
        let body = "VNYMR,+006.380,+000.023,-001.953,+1.0640,-0.2531,+3.0614,+00.005,+00.344,-09.758,-0.001222,-0.000450,-0.001218";
        let line = format!("${body}*{:02X}\r\n", crate::gnss::nmea_checksum(body.as_bytes()));
        let (out, _) = read(line.as_bytes());
        let [GnssSample::Imu(s)] = out[..] else {
            panic!("{out:?}");
        };
        assert_eq!(s.mag_gauss, [1.064, -0.2531, 3.0614]);
        assert_eq!(s.accel_mps2, [0.005, 0.344, -9.758]);
        assert_eq!(s.gyro_rad_s, [-0.001222, -0.00045, -0.001218]);
    }

    #[test]
    fn bad_lines_are_counted_not_read() {
        let mut bad_checksum = RECORDED.to_string();
        bad_checksum.replace_range(RECORDED.len() - 4..RECORDED.len() - 2, "67");
        let (out, reader) = read(bad_checksum.as_bytes());
        assert!(out.is_empty());
        assert_eq!(reader.stats().checksum_errors, 1);
        for body in [
            // a field short, one too many, empty, NaN, exponent, two points
            "VNIMU,1,2,3,4,5,6,7,8,9,10",
            "VNIMU,1,2,3,4,5,6,7,8,9,10,11,12",
            "VNIMU,1,2,3,4,5,6,7,8,,10,11",
            "VNIMU,1,2,3,4,5,6,7,8,NaN,10,11",
            "VNIMU,1,2,3,4,5,6,7,8,1e3,10,11",
            "VNIMU,1,2,3,4,5,6,7,8,1.2.3,10,11",
            "VNYMR,1,2,3,4,5,6,7,8,9,10,11",
        ] {
            let line = format!("${body}*{:02X}\r\n", crate::gnss::nmea_checksum(body.as_bytes()));
            let (out, reader) = read(line.as_bytes());
            assert!(out.is_empty(), "{body}: {out:?}");
            assert_eq!(reader.stats().malformed, 1, "{body}");
        }
        // The 16-bit CRC form is not read.
        let (out, reader) = read(b"$VNIMU,1,2,3,4,5,6,7,8,9,10,11*1A2B\r\n");
        assert!(out.is_empty());
        assert_eq!(reader.stats().malformed, 1);
    }

    #[test]
    fn the_writer_round_trips_through_the_reader() {
        let sample = ImuSample {
            t: T,
            gyro_rad_s: [0.001234, -0.5, 1.25],
            accel_mps2: [0.5, -3.25, -GRAVITY_MPS2],
            mag_gauss: [0.2, -0.05, 0.45],
        };
        let mut bytes = Vec::new();
        write_vnimu(&mut bytes, &sample, 25.0, 101.325);
        let (out, reader) = read(&bytes);
        assert_eq!(reader.stats().sentences, 1, "{}", String::from_utf8_lossy(&bytes));
        let [GnssSample::Imu(s)] = out[..] else {
            panic!("{out:?}");
        };
        for i in 0..3 {
            assert!((s.gyro_rad_s[i] - sample.gyro_rad_s[i]).abs() <= 5e-7);
            assert!((s.accel_mps2[i] - sample.accel_mps2[i]).abs() <= 5e-4);
            assert!((s.mag_gauss[i] - sample.mag_gauss[i]).abs() <= 5e-5);
        }
    }

    proptest! {
        /// Bytes of any kind around and inside IMU lines: the reader never
        /// panics, never yields a non-finite value, and a good line after
        /// the garbage is still read.
        #[test]
        fn garbage_never_yields_a_bad_sample(
            noise in proptest::collection::vec(any::<u8>(), 0..400),
            cut in 0usize..120,
        ) {
            let mut bytes = noise.clone();
            bytes.extend_from_slice(&RECORDED.as_bytes()[..cut.min(RECORDED.len())]);
            bytes.extend_from_slice(&noise);
            bytes.extend_from_slice(b"\r\n");
            bytes.extend_from_slice(RECORDED.as_bytes());
            let (out, _) = read(&bytes);
            let imu: Vec<_> = out.iter().filter_map(|s| match s { GnssSample::Imu(s) => Some(*s), _ => None }).collect();
            for s in &imu {
                prop_assert!(s.gyro_rad_s.iter().chain(&s.accel_mps2).chain(&s.mag_gauss).all(|v| v.is_finite()));
            }
            prop_assert!(imu.last().is_some_and(|s| s.gyro_rad_s == [0.002066, -0.008442, -0.044656]));
        }
    }
}
