use std::time::Duration;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;

/// A minute of random demands at random step sizes, recorded.
fn demand_script(seed: u64) -> Vec<(Duration, ActuatorDemand)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut script = Vec::new();
    let mut total = Duration::ZERO;
    while total < Duration::from_secs(60) {
        let dt = Duration::from_micros(rng.random_range(1_000..60_000));
        let demand = ackermann(rng.random_range(-1.2..1.2), rng.random_range(-1.0..1.0));
        // Hold each demand for a while so the vehicle actually goes somewhere.
        for _ in 0..rng.random_range(1..40) {
            script.push((dt, demand));
            total += dt;
        }
    }
    script
}

fn play(seed: u64, script: &[(Duration, ActuatorDemand)]) -> (World, Vec<u8>) {
    let mut world = World::new(WorldConfig::default(), seed);
    let mut bytes = Vec::new();
    for (dt, demand) in script {
        world.step(*dt, demand);
        world.take_gnss_bytes(&mut bytes);
    }
    (world, bytes)
}

#[test]
fn same_seed_same_world_to_the_bit() {
    let script = demand_script(99);
    let (a, a_bytes) = play(42, &script);
    let (b, b_bytes) = play(42, &script);
    assert_eq!(a.time(), b.time());
    let bits = |w: &World| {
        let t = w.truth();
        [
            t.north_m,
            t.east_m,
            t.yaw_rad,
            t.speed_mps,
            t.yaw_rate_rad_s,
            t.steer_rad,
            t.left_mps,
            t.right_mps,
        ]
        .map(f64::to_bits)
    };
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(a.battery(), b.battery());
    assert!(a_bytes.len() > 100_000);
    assert!(a_bytes == b_bytes, "GNSS bytes differ");
    // The vehicle went somewhere, so the comparison means something.
    assert!(a.truth().north_m.hypot(a.truth().east_m) > 1.0);

    let (c, c_bytes) = play(43, &script);
    assert_eq!(bits(&a), bits(&c), "the seed drives noise only, not physics");
    assert_eq!(a_bytes.len() / 1000, c_bytes.len() / 1000);
    assert!(a_bytes != c_bytes);
}

/// Position errors (north, east), altitude errors and heading errors (deg)
/// over `epochs` epochs while circling slowly.
struct Errors {
    north_m: Vec<f64>,
    east_m: Vec<f64>,
    alt_m: Vec<f64>,
    heading_deg: Vec<f64>,
    reported_sigma_m: f64,
}

fn collect_errors(gnss: GnssSimConfig, epochs: usize, seed: u64) -> Errors {
    let config = WorldConfig {
        gnss,
        ..WorldConfig::default()
    };
    let mut world = World::new(config, seed);
    let mut reader = NmeaReader::new();
    let demand = ackermann(0.5, 0.25);
    world.step(Duration::ZERO, &demand);
    read_gnss(&mut world, &mut reader);
    let mut errors = Errors {
        north_m: Vec::new(),
        east_m: Vec::new(),
        alt_m: Vec::new(),
        heading_deg: Vec::new(),
        reported_sigma_m: f64::NAN,
    };
    for _ in 0..epochs {
        world.step(Duration::from_millis(100), &demand);
        let (true_n, true_e) = antenna_truth(&world);
        for sample in read_gnss(&mut world, &mut reader) {
            match sample {
                GnssSample::Fix(fix) => {
                    let p = GeoPoint {
                        lat_deg: fix.lat_deg,
                        lon_deg: fix.lon_deg,
                        alt_m: fix.alt_msl_m,
                    };
                    let (n, e) = world.geodetic_to_local(&p);
                    errors.north_m.push(n - true_n);
                    errors.east_m.push(e - true_e);
                    errors
                        .alt_m
                        .push(fix.alt_msl_m - world.local_to_geodetic(true_n, true_e).alt_m);
                }
                GnssSample::Heading(h) => {
                    let gap = h.heading_deg - world.truth().yaw_rad.to_degrees();
                    errors.heading_deg.push((gap + 180.0).rem_euclid(360.0) - 180.0);
                }
                GnssSample::Accuracy(acc) => errors.reported_sigma_m = acc.sigma_north_m,
                _ => {}
            }
        }
    }
    assert_eq!(errors.north_m.len(), epochs);
    errors
}

fn assert_within_20_pct(measured: f64, configured: f64, what: &str) {
    let ratio = measured / configured;
    assert!(
        (0.8..1.2).contains(&ratio),
        "{what}: σ {measured} vs {configured} (×{ratio:.3})"
    );
}

#[test]
fn white_noise_has_the_configured_sigma() {
    let gnss = GnssSimConfig {
        pos_walk_sigma_m: 0.0,
        ..GnssSimConfig::default()
    };
    let errors = collect_errors(gnss.clone(), 3000, 5);
    assert_within_20_pct(rms(&errors.north_m), gnss.pos_sigma_m, "north");
    assert_within_20_pct(rms(&errors.east_m), gnss.pos_sigma_m, "east");
    assert_within_20_pct(rms(&errors.alt_m), gnss.alt_sigma_m, "alt");
    assert_within_20_pct(rms(&errors.heading_deg), gnss.heading_sigma_deg, "heading");
    assert!((errors.reported_sigma_m - gnss.pos_sigma_m).abs() < 1e-6);
}

#[test]
fn bench_receiver_noise_has_the_reported_sigma() {
    // 2000 s: some 30 correlation times of the walk.
    let gnss = GnssSimConfig::default();
    let errors = collect_errors(gnss.clone(), 20_000, 11);
    let sigma = gnss.horizontal_sigma_m();
    assert!((sigma - 0.01118).abs() < 1e-5);
    assert!((errors.reported_sigma_m - sigma).abs() < 1e-4, "GST carries 4 decimals");
    assert_within_20_pct(rms(&errors.north_m), sigma, "north");
    assert_within_20_pct(rms(&errors.east_m), sigma, "east");
}

#[test]
fn walk_is_a_gauss_markov_process() {
    let gnss = GnssSimConfig {
        pos_sigma_m: 0.0,
        pos_walk_sigma_m: 0.005,
        pos_walk_tau_s: 1.0,
        ..GnssSimConfig::default()
    };
    let errors = collect_errors(gnss.clone(), 5000, 3);
    for (axis, e) in [("north", &errors.north_m), ("east", &errors.east_m)] {
        assert_within_20_pct(rms(e), gnss.pos_walk_sigma_m, axis);
        let lag1 = e.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / e.iter().map(|x| x * x).sum::<f64>();
        let expected = (-0.1f64).exp();
        assert!(
            (lag1 - expected).abs() < 0.03,
            "{axis}: lag-1 correlation {lag1} vs {expected}"
        );
    }
}

/// The north error of the fix a receiver sends one epoch after its walk σ
/// changed from `from_m` to `to_m` (white noise off), for one seed.
fn walk_after_change(from_m: f64, to_m: f64, seed: u64) -> f64 {
    let gnss = |walk_m: f64| GnssSimConfig {
        pos_sigma_m: 0.0,
        pos_walk_sigma_m: walk_m,
        ..GnssSimConfig::default()
    };
    let config = WorldConfig {
        gnss: gnss(from_m),
        ..WorldConfig::default()
    };
    let mut world = World::new(config, seed);
    let mut reader = NmeaReader::new();
    world.step(Duration::ZERO, &ActuatorDemand::STOP);
    read_gnss(&mut world, &mut reader);
    world.set_gnss_config(gnss(to_m));
    world.step(Duration::from_millis(100), &ActuatorDemand::STOP);
    let (true_n, _) = antenna_truth(&world);
    let fix = read_gnss(&mut world, &mut reader)
        .into_iter()
        .find_map(|s| match s {
            GnssSample::Fix(fix) => Some(fix),
            _ => None,
        })
        .expect("an epoch at 0.1 s");
    let p = GeoPoint {
        lat_deg: fix.lat_deg,
        lon_deg: fix.lon_deg,
        alt_m: fix.alt_msl_m,
    };
    world.geodetic_to_local(&p).0 - true_n
}

#[test]
fn a_new_walk_sigma_describes_the_receiver_at_once() {
    // Left at the old σ the walk would fade over a minute: a receiver set to
    // 1 mm would still wander by 5 mm, and a filter told 1 mm would trust it.
    for (from_m, to_m) in [(0.005, 0.001), (0.0, 0.001), (0.001, 0.005)] {
        let errors: Vec<f64> = (1..=400).map(|seed| walk_after_change(from_m, to_m, seed)).collect();
        assert_within_20_pct(rms(&errors), to_m, &format!("walk {from_m} m → {to_m} m"));
    }
}
