use std::time::Duration;

use proptest::prelude::*;

use super::*;
use crate::nmea_out::{EpochReport, write_epoch};
use drivers::gnss::{FixQuality, GnssFix};

const EPOCH: Duration = Duration::from_millis(100);

fn world_at(home: GeoPoint, gnss: GnssSimConfig) -> World {
    World::new(
        WorldConfig {
            home,
            home_heading_deg: 200.0,
            gnss,
            ..WorldConfig::default()
        },
        7,
    )
}

fn angle_gap_deg(a: f64, b: f64) -> f64 {
    (a - b + 180.0).rem_euclid(360.0) - 180.0
}

/// Expected antenna speed and course (v + ω × r).
fn antenna_velocity(world: &World) -> (f64, f64) {
    let t = world.truth();
    let (ax, ay) = world.config().gnss.antenna_body_m;
    let (vx, vy) = (t.speed_mps - t.yaw_rate_rad_s * ay, t.yaw_rate_rad_s * ax);
    (vx.hypot(vy), (t.yaw_rad + vy.atan2(vx)).to_degrees())
}

#[test]
fn reader_recovers_what_the_receiver_sent() {
    let homes = [
        GeoPoint {
            lat_deg: 29.1330,
            lon_deg: 119.6400,
            alt_m: 50.0,
        },
        GeoPoint {
            lat_deg: -33.8568,
            lon_deg: 151.2153,
            alt_m: 5.0,
        },
        GeoPoint {
            lat_deg: 40.0150,
            lon_deg: -105.2705,
            alt_m: 1655.0,
        },
        GeoPoint {
            lat_deg: -0.0001,
            lon_deg: -0.0001,
            alt_m: -20.0,
        },
    ];
    let gnss = GnssSimConfig {
        antenna_body_m: (0.5, -0.2),
        ..noiseless_gnss()
    };
    for home in homes {
        let mut world = world_at(home, gnss.clone());
        let mut reader = NmeaReader::new();
        let script = [(0.0, 0.0, 1.0), (0.6, 0.5, 6.0), (-1.0, 0.75, 6.0), (0.4, -0.3, 8.0)];
        let mut epochs = 0;
        for (steering, throttle, seconds) in script {
            for _ in 0..(seconds / EPOCH.as_secs_f64()).round() as usize {
                world.step(EPOCH, &ackermann(steering, throttle));
                let samples = read_gnss(&mut world, &mut reader);
                check_epoch(&world, &samples);
                epochs += 1;
            }
        }
        let stats = reader.stats();
        // Epoch 0 plus one per step, four sentences each, all parsed.
        assert_eq!(stats.sentences, 4 * (epochs + 1));
        assert_eq!(stats.total(), stats.sentences);
    }
}

fn check_epoch(world: &World, samples: &[GnssSample]) {
    let [.., fix, vel, time, acc, hdg] = samples else {
        panic!("{samples:?}");
    };
    let (GnssSample::Fix(fix), GnssSample::Velocity(vel), GnssSample::Time(time)) = (fix, vel, time) else {
        panic!("{samples:?}");
    };
    let (GnssSample::Accuracy(acc), GnssSample::Heading(hdg)) = (acc, hdg) else {
        panic!("{samples:?}");
    };
    assert_eq!(fix.quality, FixQuality::RtkFixed);
    let (north_m, east_m) = world.geodetic_to_local(&GeoPoint {
        lat_deg: fix.lat_deg,
        lon_deg: fix.lon_deg,
        alt_m: fix.alt_msl_m,
    });
    let (true_n, true_e) = antenna_truth(world);
    let error_m = (north_m - true_n).hypot(east_m - true_e);
    assert!(error_m < 0.2e-3, "position off by {error_m} m");
    let true_alt = world.local_to_geodetic(true_n, true_e).alt_m;
    assert!((fix.alt_msl_m - true_alt).abs() < 0.6e-3);

    let (speed_mps, course_deg) = antenna_velocity(world);
    assert!(
        (vel.speed_mps - speed_mps).abs() < 3e-4,
        "{} vs {speed_mps}",
        vel.speed_mps
    );
    match vel.course_deg {
        Some(course) => assert!(angle_gap_deg(course, course_deg).abs() < 1e-3),
        None => assert!(speed_mps < 0.05),
    }
    let heading_gap = angle_gap_deg(hdg.heading_deg, world.truth().yaw_rad.to_degrees());
    assert!(heading_gap.abs() < 6e-4, "{heading_gap}");
    assert!(world.truth().speed_mps >= 0.0 || angle_gap_deg(course_deg, hdg.heading_deg).abs() > 90.0);

    assert_eq!(
        (acc.sigma_north_m, acc.sigma_east_m, acc.sigma_up_m),
        (0.0, 0.0, Some(0.0))
    );
    let utc_start = world.config().utc_start_unix_us;
    let elapsed_us = i64::try_from(world.time().as_micros()).unwrap();
    assert_eq!(time.utc_unix_us, utc_start + elapsed_us);
    let of_day_s = (time.utc_unix_us.rem_euclid(86_400_000_000)) as f64 * 1e-6;
    assert!((fix.utc_time_of_day_s.unwrap() - of_day_s).abs() < 1e-6);
}

fn report(lat_deg: f64, lon_deg: f64, alt_m: f64, speed_mps: f64) -> EpochReport {
    EpochReport {
        utc_unix_us: 1_735_689_600_000_000 + 86_399_990_000,
        quality: FixQuality::RtkFixed,
        position: GeoPoint {
            lat_deg,
            lon_deg,
            alt_m,
        },
        satellites: 35,
        hdop: 0.6,
        speed_mps,
        course_deg: Some(359.9999),
        sigma_horizontal_m: 0.0112,
        sigma_alt_m: 0.02,
        heading_deg: Some(-0.0001),
    }
}

fn parse_fix(bytes: &[u8]) -> GnssFix {
    let mut samples = Vec::new();
    NmeaReader::new().push(Duration::ZERO, bytes, &mut samples);
    match samples.first() {
        Some(GnssSample::Fix(fix)) => *fix,
        other => panic!("{other:?}"),
    }
}

proptest! {
    #[test]
    fn coordinates_survive_to_a_fifth_of_a_millimetre(
        lat_deg in -89.9f64..89.9,
        lon_deg in -179.99f64..179.99,
        alt_m in -400.0f64..9000.0,
    ) {
        let mut bytes = Vec::new();
        write_epoch("GN", &report(lat_deg, lon_deg, alt_m, 1.0), &mut bytes);
        let fix = parse_fix(&bytes);
        // Metres per degree, generously (the meridian radius is below 6.4e6 m).
        let m_per_deg = 6.4e6_f64.to_radians();
        let north_m = (fix.lat_deg - lat_deg) * m_per_deg;
        let east_m = (fix.lon_deg - lon_deg) * m_per_deg * lat_deg.to_radians().cos();
        prop_assert!(north_m.hypot(east_m) < 0.2e-3);
        prop_assert!((fix.alt_msl_m - alt_m).abs() < 1e-3);
    }
}

#[test]
fn sentences_stay_within_82_characters() {
    let mut bytes = Vec::new();
    write_epoch("GN", &report(-89.99, -179.99, -1234.5678, 40.0), &mut bytes);
    write_epoch("GN", &report(89.99, 179.99, 99_999.999, 0.0), &mut bytes);
    let text = String::from_utf8(bytes).unwrap();
    let lines: Vec<&str> = text.split_inclusive("\r\n").collect();
    assert_eq!(lines.len(), 8);
    for line in lines {
        assert!(line.len() <= 82, "{} chars: {line}", line.len());
    }
    // The last centisecond of the day, and angles that round to 360.
    assert!(text.contains("GNGGA,235959.99,"));
    assert!(text.contains(",0.000,010125,,,R*"), "{text}");
    assert!(text.contains("GNHDT,0.000,T*"));
}

#[test]
fn epochs_sample_the_instant_whatever_the_step_size() {
    let mut aligned = world_at(WorldConfig::default().home, noiseless_gnss());
    let mut ragged = aligned.clone();
    let demand = ackermann(0.7, 0.5);
    let mut aligned_fixes = Vec::new();
    let mut ragged_fixes = Vec::new();
    let (mut r1, mut r2) = (NmeaReader::new(), NmeaReader::new());
    while aligned.time() < Duration::from_secs(6) {
        aligned.step(EPOCH, &demand);
        aligned_fixes.extend(read_gnss(&mut aligned, &mut r1));
    }
    // 7 ms steps: epochs fall inside steps and inside physics sub-steps.
    while ragged.time() < Duration::from_secs(6) {
        ragged.step(
            Duration::from_millis(7).min(Duration::from_secs(6) - ragged.time()),
            &demand,
        );
        ragged_fixes.extend(read_gnss(&mut ragged, &mut r2));
    }
    let fixes = |samples: &[GnssSample]| -> Vec<GnssFix> {
        samples
            .iter()
            .filter_map(|s| match s {
                GnssSample::Fix(fix) => Some(*fix),
                _ => None,
            })
            .collect()
    };
    let (a, r) = (fixes(&aligned_fixes), fixes(&ragged_fixes));
    assert_eq!(a.len(), 61, "epochs at 0.0, 0.1, … 6.0 s");
    assert_eq!(a.len(), r.len());
    for (k, (a, r)) in a.iter().zip(&r).enumerate() {
        assert_eq!(a.utc_time_of_day_s, r.utc_time_of_day_s);
        let gap_m = (a.lat_deg - r.lat_deg).hypot(a.lon_deg - r.lon_deg) * 111_000.0;
        assert!(gap_m < 0.3e-3, "epoch {k}: {gap_m} m");
    }
}

#[test]
fn receiver_settings_apply_at_the_next_epoch() {
    let mut world = world_at(WorldConfig::default().home, GnssSimConfig::default());
    let mut reader = NmeaReader::new();
    world.step(Duration::from_millis(250), &ActuatorDemand::STOP);
    let count = |samples: &[GnssSample]| samples.iter().filter(|s| matches!(s, GnssSample::Fix(_))).count();
    assert_eq!(count(&read_gnss(&mut world, &mut reader)), 3);

    world.set_gnss_config(GnssSimConfig {
        rate_hz: 5.0,
        talker: "GP".to_owned(),
        heading_enabled: false,
        quality: FixQuality::RtkFloat,
        ..GnssSimConfig::default()
    });
    world.step(Duration::from_millis(750), &ActuatorDemand::STOP);
    let mut bytes = Vec::new();
    world.take_gnss_bytes(&mut bytes);
    let text = String::from_utf8(bytes).unwrap();
    // 5 Hz grid from 0.25 s: 0.4, 0.6, 0.8, 1.0.
    assert_eq!(text.matches("$GPGGA").count(), 4);
    assert!(text.contains("$GPGGA,000000.40,"));
    assert!(!text.contains("HDT") && !text.contains("$GN"));
    assert!(text.contains(",5,20,0.6,") && text.contains(",,,F*"));

    world.set_gnss_config(GnssSimConfig {
        quality: FixQuality::NoFix,
        ..GnssSimConfig::default()
    });
    world.step(Duration::from_millis(100), &ActuatorDemand::STOP);
    let samples = read_gnss(&mut world, &mut reader);
    let [GnssSample::Fix(fix)] = samples[..] else {
        panic!("{samples:?}")
    };
    assert_eq!(fix.quality, FixQuality::NoFix);
    assert!(fix.lat_deg.is_nan() && fix.lon_deg.is_nan());

    world.set_gnss_config(GnssSimConfig {
        enabled: false,
        ..GnssSimConfig::default()
    });
    world.step(Duration::from_secs(1), &ActuatorDemand::STOP);
    let mut bytes = Vec::new();
    world.take_gnss_bytes(&mut bytes);
    assert!(bytes.is_empty());
    assert_eq!(reader.stats().total(), reader.stats().sentences);
}
