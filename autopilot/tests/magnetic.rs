//! Double magnetic guide (seed 002 §2, §4): sign conventions against the
//! simulated sensors, the incremental PID against the positional one, the
//! lost-tape behaviour, and the re-acquisition scenario's figures.
//!
//! Sources: docs/references.md §Seed 002.

use autopilot::control::pid::{PidGains, PidState};
use autopilot::guidance::magnetic::{
    IncrementalPid, IncrementalPidGains, LateralRate, MagneticGuide, MagneticGuideConfig, MagneticInput,
    lateral_and_angle, probe_num, sensor_deviation_m,
};
use autopilot::sitl::magnetic_scenario::{MagneticProfile, MagneticScenario, run};
use sim::{MagneticSensor, MagneticSensorConfig, MagneticTape, VehicleTruth};

const PITCH_M: f64 = 0.010;
/// Half a probe pitch: the reading's quantisation either way.
const QUANTUM_M: f64 = 0.0025 + 1e-9;

fn probes(list: &[u32]) -> u16 {
    list.iter().fold(0, |m, p| m | 1 << (p - 1))
}

#[test]
fn num_and_deviation_follow_the_seed() {
    // Centred: probes 7–10 (or 8–9) give num = 17 and no deviation.
    assert_eq!(probe_num(probes(&[7, 8, 9, 10])), Some(17.0));
    assert_eq!(sensor_deviation_m(probes(&[8, 9]), PITCH_M), Some(0.0));
    // Probe 1 is the rightmost: tape to the right, num < 17, positive.
    assert_eq!(probe_num(probes(&[1, 2, 3])), Some(4.0));
    assert_eq!(sensor_deviation_m(probes(&[1, 2, 3]), PITCH_M), Some(0.065));
    assert_eq!(sensor_deviation_m(probes(&[16]), PITCH_M), Some(-0.075));
    assert_eq!(probe_num(0), None);
    assert_eq!(sensor_deviation_m(0, PITCH_M), None);
}

fn truth(north_m: f64, east_m: f64, yaw_deg: f64) -> VehicleTruth {
    VehicleTruth {
        north_m,
        east_m,
        yaw_rad: yaw_deg.to_radians(),
        ..VehicleTruth::default()
    }
}

/// (e1, e2, lateral, angle) as the guide computes them from the simulated
/// sensors on a straight north-going tape along east = 0.
fn sense(t: &VehicleTruth) -> (f64, f64, f64, f64) {
    let cfg = MagneticSensorConfig::default();
    let tape = MagneticTape::polyline(&[(-20.0, 0.0), (20.0, 0.0)], MagneticTape::DEFAULT_WIDTH_M);
    let e1 = sensor_deviation_m(cfg.read(&tape, t, MagneticSensor::Front), PITCH_M).unwrap();
    let e2 = sensor_deviation_m(cfg.read(&tape, t, MagneticSensor::Rear), PITCH_M).unwrap();
    let (lateral, angle) = lateral_and_angle(e1, e2, cfg.front_x_m - cfg.rear_x_m);
    (e1, e2, lateral, angle)
}

#[test]
fn deviations_are_positive_when_the_tape_is_to_the_right() {
    // Vehicle 30 mm left of the tape (west of it), parallel: tape to the
    // right of both sensors, steer right.
    let (e1, e2, lateral, angle) = sense(&truth(0.0, -0.03, 0.0));
    assert!(
        (e1 - 0.03).abs() <= QUANTUM_M && (e2 - 0.03).abs() <= QUANTUM_M,
        "{e1} {e2}"
    );
    assert!((lateral - 0.03).abs() <= QUANTUM_M && angle.abs() < 0.003);
    // And to the right of the tape: all negative.
    let (e1, e2, lateral, _) = sense(&truth(0.0, 0.03, 0.0));
    assert!(e1 < 0.0 && e2 < 0.0 && (lateral + 0.03).abs() <= QUANTUM_M);
    // Heading south, the vehicle's right is west: the same offset reads the
    // other way.
    let (e1, _, _, _) = sense(&truth(0.0, -0.03, 180.0));
    assert!((e1 + 0.03).abs() <= QUANTUM_M);
}

#[test]
fn angle_deviation_has_the_sign_of_the_turn_needed() {
    // Centred but yawed 3° right: the front sensor is 52 mm right of the tape
    // (tape to its left), the rear one 52 mm left. The tape heads 3° left
    // of the vehicle: turn left.
    let (e1, e2, lateral, angle) = sense(&truth(0.0, 0.0, 3.0));
    let expected_m = 3f64.to_radians().tan();
    assert!(
        (e1 + expected_m).abs() <= QUANTUM_M && (e2 - expected_m).abs() <= QUANTUM_M,
        "{e1} {e2}"
    );
    assert!((angle + 3f64.to_radians()).abs() < 0.003, "{}", angle.to_degrees());
    assert!(lateral.abs() <= QUANTUM_M);
    // Yawed 1° left and 40 mm left of the tape: both sensors see it on the
    // right (57 and 23 mm), so seed eq. 2's |e1| + |e2| gives more than
    // twice the angle (and would give the same for 1° right); e1 − e2 gives
    // +1°.
    let (e1, e2, lateral, angle) = sense(&truth(0.0, -0.04, -1.0));
    assert!(e1 > 0.0 && e2 > 0.0);
    assert!((angle - 1f64.to_radians()).abs() < 0.003, "{}", angle.to_degrees());
    let seed_eq2 = ((e1.abs() + e2.abs()) / 2.0).atan();
    assert!(seed_eq2 > 2.0 * angle);
    assert!((lateral - 0.04).abs() <= QUANTUM_M);
}

/// A fixed pseudo-random error sequence.
fn errors(n: usize, seed: u64) -> Vec<f64> {
    let mut x = seed;
    (0..n)
        .map(|_| {
            x = x
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((x >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.2
        })
        .collect()
}

#[test]
fn incremental_pid_equals_the_positional_one() {
    let gains = IncrementalPidGains {
        kp: 3.0,
        ki: 1.5,
        kd: 0.4,
        d_filter_hz: 0.0,
    };
    let positional_gains = PidGains {
        kp: gains.kp,
        ki: gains.ki,
        kd: gains.kd,
        imax: 1e9,
    };
    let dt_s = 0.02;
    let mut incremental = IncrementalPid::default();
    let mut positional = PidState::default();
    let e = errors(500, 7);
    let mut last_output = 0.0;
    for (k, &error) in e.iter().enumerate() {
        let inc = incremental.update(&gains, error, dt_s, -1e9, 1e9);
        let pos = positional.update(&positional_gains, error, dt_s);
        assert!(
            (inc.output - pos.output()).abs() < 1e-9,
            "sample {k}: {} vs {}",
            inc.output,
            pos.output()
        );
        assert!((inc.p - pos.p).abs() < 1e-12 && (inc.d - pos.d).abs() < 1e-9 && (inc.i - pos.i).abs() < 1e-9);
        // Seed eq. 15, third line: Kp(1 + T/Ti + Td/T)e_k − Kp(1 + 2Td/T)e_{k−1}
        // + Kp(Td/T)e_{k−2}, with Ti = Kp/Ki and Td = Kd/Kp.
        if k >= 2 {
            let (ti, td) = (gains.kp / gains.ki, gains.kd / gains.kp);
            let eq15 = gains.kp * (1.0 + dt_s / ti + td / dt_s) * error - gains.kp * (1.0 + 2.0 * td / dt_s) * e[k - 1]
                + gains.kp * td / dt_s * e[k - 2];
            assert!((inc.delta - eq15).abs() < 1e-9, "sample {k}");
            assert!((inc.output - last_output - eq15).abs() < 1e-9);
        }
        last_output = inc.output;
    }
}

#[test]
fn saturation_is_not_remembered() {
    let pd = IncrementalPidGains {
        kp: 2.0,
        ..IncrementalPidGains::default()
    };
    let mut pid = IncrementalPid::default();
    assert_eq!(pid.update(&pd, 0.0, 0.02, -0.5, 0.5).output, 0.0);
    assert_eq!(pid.update(&pd, 1.0, 0.02, -0.5, 0.5).output, 0.5);
    // Eq. 15 clamped as written would now give 0.5 − 2 = −1.5 → −0.5.
    assert_eq!(pid.update(&pd, 0.0, 0.02, -0.5, 0.5).output, 0.0);
    // The integral stops where P + I reaches the limit, and comes off it at
    // once when the error turns.
    let pi = IncrementalPidGains {
        kp: 1.0,
        ki: 10.0,
        ..IncrementalPidGains::default()
    };
    let mut pid = IncrementalPid::default();
    for _ in 0..500 {
        assert!(pid.update(&pi, 0.5, 0.02, -1.0, 1.0).output <= 1.0);
    }
    assert!((pid.integral() - 0.5).abs() < 1e-9, "{}", pid.integral());
    assert!(pid.update(&pi, -0.5, 0.02, -1.0, 1.0).output < 0.0);
}

/// The guide on its readings alone: no dead reckoning, no steering-rate
/// lead (each tested on its own below).
fn guide_config(hold_s: f64) -> MagneticGuideConfig {
    MagneticGuideConfig {
        lost_hold_s: hold_s,
        dead_reckon_s: 0.0,
        steer_rate_rad_s: 0.0,
        ..MagneticGuideConfig::default()
    }
}

fn input(front_mask: u16, rear_mask: u16) -> MagneticInput {
    MagneticInput {
        front_mask,
        rear_mask,
        speed_mps: 1.5,
        yaw_rate_rad_s: 0.0,
    }
}

#[test]
fn steering_follows_the_tape_side() {
    let cfg = guide_config(0.0);
    // Tape right of both sensors: steer right; left: steer left.
    let right = probes(&[3, 4, 5]);
    let left = probes(&[12, 13, 14]);
    let s = MagneticGuide::default().update(&cfg, &input(right, right), 0.02);
    assert!(s.acquired && !s.lost && s.lateral_m > 0.0 && s.steer_rad > 0.0);
    let s = MagneticGuide::default().update(&cfg, &input(left, left), 0.02);
    assert!(s.lateral_m < 0.0 && s.steer_rad < 0.0);
    // Tape crossing from rear-left to front-right (vehicle yawed left): angle
    // positive, and the speed PID slows down beyond its dead band.
    let cfg = MagneticGuideConfig {
        angle_deadband_rad: 1f64.to_radians(),
        ..cfg
    };
    let mut guide = MagneticGuide::default();
    let s = guide.update(&cfg, &input(probes(&[1, 2, 3]), probes(&[14, 15, 16])), 0.02);
    assert!(s.angle_rad > cfg.angle_deadband_rad && s.speed_mps < cfg.cruise_speed_mps);
    // The correction is limited about the integral.
    assert!(s.steer_rad.abs() <= cfg.steer_correction_max_rad + 1e-12);
}

#[test]
fn both_sensors_lost_searches_back_towards_the_side_last_seen() {
    let tape_right = probes(&[4, 5, 6]);
    let tape_left = probes(&[11, 12, 13]);
    for (tape, side) in [(tape_right, 1.0), (tape_left, -1.0)] {
        // No hold: the search starts at once, at the search speed, towards
        // the side the sensors last read the tape on, at the correction
        // limit (about the integral, which is 0 here).
        let cfg = MagneticGuideConfig {
            steer: IncrementalPidGains {
                ki: 0.0,
                ..MagneticGuideConfig::default().steer
            },
            ..guide_config(0.0)
        };
        let limit_rad = cfg.correction_limit_rad();
        let mut guide = MagneticGuide::default();
        assert_eq!(guide.update(&cfg, &input(tape, tape), 0.02).steer_rad.signum(), side);
        let s = guide.update(&cfg, &input(0, 0), 0.02);
        assert!(s.lost && !s.acquired);
        assert_eq!(s.speed_mps, cfg.lost_speed_mps);
        assert!(
            (s.steer_rad - side * limit_rad).abs() < 1e-12,
            "{} vs {side}·{limit_rad}",
            s.steer_rad
        );
        // Bounded: once the body has turned the last angle deviation (0
        // here) plus the approach limit towards the tape, straight on.
        let bound_rad = cfg.approach_limit_rad(0.0);
        let turning = MagneticInput {
            yaw_rate_rad_s: side * 0.1,
            ..input(0, 0)
        };
        let steps = (bound_rad / (0.1 * 0.02)).ceil() as usize;
        for _ in 0..steps - 1 {
            assert_eq!(guide.update(&cfg, &turning, 0.02).steer_rad.signum(), side);
        }
        let s = guide.update(&cfg, &turning, 0.02);
        assert_eq!((s.steer_rad, s.speed_mps), (0.0, cfg.lost_speed_mps));
        assert!(s.lost);
    }
    // With a hold: the last demands for lost_hold_s, then the search.
    let cfg = MagneticGuideConfig {
        steer: IncrementalPidGains {
            ki: 0.0,
            ..MagneticGuideConfig::default().steer
        },
        ..guide_config(0.1)
    };
    let mut guide = MagneticGuide::default();
    let on_tape = guide.update(&cfg, &input(tape_right, tape_right), 0.02);
    let mut steer = Vec::new();
    for _ in 0..10 {
        let s = guide.update(&cfg, &input(0, 0), 0.02);
        assert!(s.lost);
        steer.push(s.steer_rad);
    }
    assert!(steer[..5].iter().all(|s| *s == on_tape.steer_rad), "{steer:?}");
    assert!(steer[5..].iter().all(|s| *s == cfg.correction_limit_rad()), "{steer:?}");
    // Found again: no derivative kick (difference form: D starts at 0).
    let cfg = MagneticGuideConfig {
        lateral_rate: LateralRate::Difference,
        ..cfg
    };
    let s = guide.update(&cfg, &input(tape_right, tape_right), 0.02);
    assert!(!s.lost && s.steer.d == 0.0 && s.steer_rad > 0.0);
}

/// Seed §4.3 (Fig. 4c): a start with no sensor on the tape drives straight
/// at the search speed until one triggers, then corrects. "Straight" is
/// along the curve it took over: engaged from rest, straight; engaged
/// while following an arc (knocked off it), on along the arc, which a
/// truly straight drive off its outside would never meet again.
#[test]
fn a_start_off_the_tape_goes_straight_until_a_sensor_triggers() {
    let cfg = guide_config(0.3);
    let mut from_rest = MagneticGuide::default();
    let s = from_rest.update(&cfg, &input(0, 0), 0.02);
    assert!(s.lost);
    assert_eq!((s.steer_rad, s.speed_mps), (0.0, cfg.lost_speed_mps));
    let mut guide = MagneticGuide::engaged_at(0.2);
    for _ in 0..100 {
        let s = guide.update(&cfg, &input(0, 0), 0.02);
        assert!(s.lost);
        assert_eq!((s.steer_rad, s.speed_mps), (0.2, cfg.lost_speed_mps));
    }
    // The front sensor finds the tape on its right: steer right.
    let s = guide.update(&cfg, &input(probes(&[2, 3, 4]), 0), 0.02);
    assert!(!s.lost && s.steer_rad > 0.0, "{s:?}");
}

/// Both sensors keep the tape only while |y| + (d/2)·sin α is within the
/// outermost probe: the P term is limited so the PD law steers to no more
/// than that approach angle, and the correction's yaw rate to what sweeps
/// the outer sensor no faster.
#[test]
fn approach_and_correction_are_limited_to_the_sensors_reach() {
    let cfg = MagneticGuideConfig {
        steer_correction_max_rad: 1.0,
        steer: IncrementalPidGains {
            ki: 0.0,
            ..MagneticGuideConfig::default().steer
        },
        ..guide_config(0.3)
    };
    // 16 probes at 10 mm: the outermost is 75 mm from the centre; ±1 m.
    assert!((cfg.sensor_reach_m() - 0.075).abs() < 1e-12);
    assert!((cfg.approach_limit_rad(0.0) - 0.075f64.asin()).abs() < 1e-12);
    assert!((cfg.approach_limit_rad(0.02) - 0.055f64.asin()).abs() < 1e-12);
    // Near or past the reach: no less than half the centred angle.
    assert!((cfg.approach_limit_rad(0.05) - 0.0375f64.asin()).abs() < 1e-12);
    assert!((cfg.approach_limit_rad(-0.2) - 0.0375f64.asin()).abs() < 1e-12);
    assert!((cfg.correction_limit_rad() - (2.9 * 0.075f64).atan()).abs() < 1e-12);
    // Both sensors 65 mm left of the tape (probes 1–3 right of centre),
    // aligned, at 0.5 m/s: kp·y alone would be 0.585 rad; limited to
    // kd·v·sin α_max.
    let tape = probes(&[1, 2, 3]);
    let slow = MagneticInput {
        speed_mps: 0.5,
        ..input(tape, tape)
    };
    let s = MagneticGuide::default().update(&cfg, &slow, 0.02);
    let lateral_m = 0.065;
    assert!((s.lateral_m - lateral_m).abs() < 1e-12, "{}", s.lateral_m);
    let expected = cfg.steer.kd * 0.5 * cfg.approach_limit_rad(lateral_m).sin();
    assert!(expected < cfg.correction_limit_rad() && expected < cfg.steer.kp * lateral_m);
    assert!((s.steer_rad - expected).abs() < 1e-9, "{} vs {expected}", s.steer_rad);
    // At 1.5 m/s that would be more than the correction limit, which holds.
    let s = MagneticGuide::default().update(&cfg, &input(tape, tape), 0.02);
    assert!(
        (s.steer_rad - cfg.correction_limit_rad()).abs() < 1e-12,
        "{}",
        s.steer_rad
    );
    // With dead reckoning the sensors may leave the tape: the approach is
    // `approach_max_rad` and the correction only the configured one.
    let cfg = MagneticGuideConfig {
        dead_reckon_s: 1.5,
        approach_max_rad: 8f64.to_radians(),
        ..cfg
    };
    let s = MagneticGuide::default().update(&cfg, &slow, 0.02);
    let expected = cfg.steer.kd * 0.5 * 8f64.to_radians().sin();
    assert!((s.steer_rad - expected).abs() < 1e-9, "{} vs {expected}", s.steer_rad);
}

/// Both sensors off the tape after reading it with an angle: the guide
/// steers on the deviation carried forward with the vehicle's motion, at
/// the speed PID's speed, for `dead_reckon_s`; then the hold and the search.
#[test]
fn both_sensors_lost_dead_reckons_then_searches() {
    let cfg = MagneticGuideConfig {
        dead_reckon_s: 0.5,
        steer_rate_rad_s: 0.0,
        angle_deadband_rad: 0.5,
        ..guide_config(0.0)
    };
    let mut guide = MagneticGuide::default();
    // Tape 50 mm right of the front sensor, 50 mm left of the rear: the
    // body heads 2.9° left of it, the midpoint on it.
    let s = guide.update(&cfg, &input(probes(&[3, 4]), probes(&[13, 14])), 0.02);
    assert!(s.acquired && s.angle_rad > 0.0 && s.lateral_m.abs() < 1e-12);
    let mut last_lateral_m = s.lateral_m;
    for step in 0..24 {
        let s = guide.update(&cfg, &input(0, 0), 0.02);
        assert!(s.lost, "{step}");
        // Carried forward: the tape drifts right at v·tan α (no yaw rate),
        // and each sensor, reading nothing, is beyond its edge on the side
        // it last saw the tape.
        assert!(s.lateral_m >= last_lateral_m, "{step}: {s:?}");
        assert!(s.front_used_m >= 0.08 && s.rear_used_m <= -0.08, "{step}: {s:?}");
        assert!(
            s.steer_rad > 0.0 && s.speed_mps == cfg.cruise_speed_mps,
            "{step}: {s:?}"
        );
        last_lateral_m = s.lateral_m;
    }
    // Past dead_reckon_s (from the last reading): the search.
    let s = guide.update(&cfg, &input(0, 0), 0.02);
    let s = if s.speed_mps == cfg.cruise_speed_mps {
        guide.update(&cfg, &input(0, 0), 0.02)
    } else {
        s
    };
    assert!(s.lost && s.speed_mps == cfg.lost_speed_mps, "{s:?}");
}

/// With the steering's rate known, the law acts on the deviation the
/// vehicle will have once its steering has unwound: turning towards the
/// tape at a yaw rate that will close the angle, it eases off sooner.
#[test]
fn steering_leads_by_the_time_to_unwind() {
    let tape = probes(&[3, 4, 5]);
    let turning = MagneticInput {
        yaw_rate_rad_s: 0.15,
        ..input(tape, tape)
    };
    let plain = guide_config(0.3);
    let lead = MagneticGuideConfig {
        steer_rate_rad_s: 30f64.to_radians(),
        ..plain
    };
    let without = MagneticGuide::default().update(&plain, &turning, 0.02);
    let with = MagneticGuide::default().update(&lead, &turning, 0.02);
    assert!(
        with.steer_rad < without.steer_rad,
        "{} vs {}",
        with.steer_rad,
        without.steer_rad
    );
    // Not turning, nothing to unwind: the same.
    let still = input(tape, tape);
    let a = MagneticGuide::default().update(&plain, &still, 0.02);
    let b = MagneticGuide::default().update(&lead, &still, 0.02);
    assert!((a.steer_rad - b.steer_rad).abs() < 1e-12);
}

#[test]
fn a_sensor_off_the_tape_is_placed_on_the_side_the_tape_left_it() {
    let cfg = guide_config(0.3);
    let mut guide = MagneticGuide::default();
    let centred = probes(&[8, 9]);
    // The rear sensor's tape drifts right and off its edge.
    guide.update(&cfg, &input(centred, probes(&[2, 3, 4])), 0.02);
    let s = guide.update(&cfg, &input(centred, 0), 0.02);
    assert!(s.rear_m.is_none() && s.rear_used_m >= 0.08 && !s.lost && !s.acquired);
    assert!(s.angle_rad < 0.0, "tape from rear-right to front-centre heads left");
    // The front one's drifts left and off.
    let mut guide = MagneticGuide::default();
    guide.update(&cfg, &input(probes(&[14, 15, 16]), centred), 0.02);
    let s = guide.update(&cfg, &input(0, centred), 0.02);
    assert!(s.front_used_m <= -0.08 && s.angle_rad < 0.0 && s.lateral_m < 0.0);
}

/// One sensor on the tape from the start, the other never having seen it:
/// which side the blind one is on follows from how the seen one's reading
/// moves, within five readings (0.1 s; the low-pass rate needs 0.16 s).
/// The rear's tape moving out to the left (the body turning away from a
/// tape on its left) puts the front one further left; moving in, the front
/// one has crossed it. Those readings also start the dead reckoning: the
/// rear then leaving the tape too, the guide still knows where it is and
/// steers back (it used to wait 0.16 s for the low-pass rate, and a sensor
/// leaving sooner left it with nothing to carry forward).
#[test]
fn the_blind_sensors_side_follows_the_seen_ones_motion() {
    let cfg = MagneticGuideConfig::default();
    // Three probes centred on probe i read (17 − 2i)·5 mm: 11 → −25 mm, 15 → −65 mm.
    let rear = |i: u32| probes(&[i - 1, i, i + 1]);
    for (centres, side) in [([11, 12, 13, 14, 15], -1.0), ([15, 14, 13, 12, 11], 1.0)] {
        let mut guide = MagneticGuide::default();
        let mut s = guide.update(&cfg, &input(0, rear(centres[0])), 0.02);
        for i in &centres[1..] {
            s = guide.update(&cfg, &input(0, rear(*i)), 0.02);
        }
        assert!(side * s.front_used_m >= 0.08, "{side}: {s:?}");
        assert!(side * s.angle_rad > 0.0, "{side}: {s:?}");
        if side < 0.0 {
            let s = guide.update(&cfg, &input(0, 0), 0.02);
            assert!(s.lost && s.lateral_m < -0.05 && s.steer_rad < 0.0, "{s:?}");
        }
    }
}

#[test]
fn engaging_carries_the_current_steering() {
    let cfg = guide_config(0.3);
    let centred = probes(&[8, 9]);
    let mut guide = MagneticGuide::engaged_at(0.2);
    let s = guide.update(&cfg, &input(centred, centred), 0.02);
    assert!((s.steer_rad - 0.2).abs() < 1e-12 && (s.steer.i - 0.2).abs() < 1e-12);
}

/// The double-guide paper's figure on its own robot: back on a curved tape
/// within 2 s at 1.5 m/s with the correction within ±10°, from 0.1 m and 5°
/// off towards the tape, either side of it, curving either way, several
/// noise seeds.
#[test]
fn scenario_reacquires_a_curve_within_two_seconds() {
    let robot = MagneticProfile::double_guide_robot().scenario(1.5);
    for (offset_m, heading_deg) in [(0.1, -5.0f64), (-0.1, 5.0)] {
        for curves_right in [true, false] {
            for seed in 1..=3 {
                let scenario = MagneticScenario {
                    start_offset_m: offset_m,
                    start_heading_rad: heading_deg.to_radians(),
                    tape_curves_right: curves_right,
                    seed,
                    ..robot
                };
                let r = run(&scenario);
                let what = format!("offset {offset_m} m, heading {heading_deg}°, right {curves_right}, seed {seed}");
                let t = r.reacquire_time_s.unwrap_or_else(|| panic!("{what}: not re-acquired"));
                assert!(t <= 2.0, "{what}: {t} s");
                assert!(r.max_correction_rad <= 10f64.to_radians() + 1e-9, "{what}");
                assert!(
                    r.max_steer_cmd_rad <= r.curve_steer_rad.abs() + 10f64.to_radians() + 1e-9,
                    "{what}"
                );
                assert!(r.max_offset_after_m < 0.010 && r.final_offset_m < 0.005, "{what}");
                assert_eq!(r.lost_steps, 0, "{what}");
                assert!(r.min_speed_mps > 1.0, "{what}");
            }
        }
    }
}

#[test]
fn scenario_starts_where_it_says_and_is_deterministic() {
    let scenario = MagneticScenario::default();
    let a = run(&scenario);
    assert_eq!(a, run(&scenario));
    // Both sensors ±1 m about the midpoint: offsets 0.1 ± 1·tan(−5°) from the
    // centred pose (the arc's sagitta over ±1 m is the same at both ends, so
    // it cancels against the centred pose's).
    let first = a.samples[0];
    let tan = (-5f64).to_radians().tan();
    assert!(
        (first.front_offset_m - (0.1 + tan)).abs() < 0.002,
        "{}",
        first.front_offset_m
    );
    assert!(
        (first.rear_offset_m - (0.1 - tan)).abs() < 0.002,
        "{}",
        first.rear_offset_m
    );
    assert!((a.curve_steer_rad - (2.9 / (15f64 * 15.0 - 1.0).sqrt()).atan()).abs() < 1e-12);
    assert!(a.samples.windows(2).all(|w| w[1].time_s > w[0].time_s));
    assert!((a.samples.len() as f64 - scenario.duration_s * scenario.control_rate_hz).abs() < 1.0);
}

/// The general-purpose defaults (an integral): a tape running straight into
/// a 15 m arc 2 m ahead is caught and held.
#[test]
fn default_config_takes_a_curve_from_a_straight() {
    let seed_figure = MagneticScenario::default();
    for (offset_m, heading_deg) in [(0.03, -2.5f64), (-0.03, 2.5), (0.0, 0.0)] {
        for curves_right in [true, false] {
            let scenario = MagneticScenario {
                guide: MagneticGuideConfig {
                    front_x_m: seed_figure.guide.front_x_m,
                    rear_x_m: seed_figure.guide.rear_x_m,
                    ..MagneticGuideConfig::default()
                },
                start_offset_m: offset_m,
                start_heading_rad: heading_deg.to_radians(),
                tape_curves_right: curves_right,
                run_up_on_curve: false,
                lead_in_m: 2.0,
                duration_s: 15.0,
                ..seed_figure
            };
            let r = run(&scenario);
            let what = format!("offset {offset_m} m, heading {heading_deg}°, right {curves_right}");
            let t = r.reacquire_time_s.unwrap_or_else(|| panic!("{what}: not re-acquired"));
            assert!(t < 6.5, "{what}: {t} s");
            assert_eq!(r.lost_steps, 0, "{what}");
        }
    }
}
