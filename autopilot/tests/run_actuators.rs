//! The vehicle's PWM outputs (`furrow run`) on a fake sysfs tree: pulses
//! follow the core, and the watchdog puts them at trim when the core stops
//! feeding them; dropping the outputs (process exit) leaves them at trim.

use std::fs;
use std::path::Path;
use std::time::{Duration, Instant};

use autopilot::run::actuators::PwmActuators;
use autopilot::run::config::{PwmOutputSetting, PwmSettings};

/// A PWM class directory with one two-channel chip, removed on drop.
fn fake_tree() -> tempfile::TempDir {
    let root = tempfile::Builder::new().prefix("furrow-pwm-").tempdir().unwrap();
    let chip = root.path().join("pwmchip0");
    fs::create_dir_all(&chip).unwrap();
    fs::write(chip.join("npwm"), "2\n").unwrap();
    fs::write(chip.join("export"), "").unwrap();
    for ch in 0..2 {
        let dir = chip.join(format!("pwm{ch}"));
        fs::create_dir_all(&dir).unwrap();
        fs::write(dir.join("period"), "0\n").unwrap();
        fs::write(dir.join("duty_cycle"), "0\n").unwrap();
        fs::write(dir.join("enable"), "0\n").unwrap();
        fs::write(dir.join("polarity"), "normal\n").unwrap();
    }
    root
}

/// The duty cycle file's number. A plain file is truncated then written
/// (sysfs attributes change atomically): an empty read is a write under
/// way, read again.
fn duty_ns(root: &Path, ch: u32) -> u64 {
    let path = root.join(format!("pwmchip0/pwm{ch}/duty_cycle"));
    for _ in 0..1000 {
        if let Ok(n) = fs::read_to_string(&path).unwrap().trim().parse() {
            return n;
        }
        std::thread::yield_now();
    }
    panic!("{} never held a number", path.display());
}

fn settings(root: &Path) -> PwmSettings {
    PwmSettings {
        root: root.to_path_buf(),
        period_us: 20_000,
        outputs: vec![
            PwmOutputSetting {
                servo: 1,
                chip: 0,
                channel: 0,
            },
            PwmOutputSetting {
                servo: 3,
                chip: 0,
                channel: 1,
            },
        ],
    }
}

fn wait_for(mut ok: impl FnMut() -> bool, within: Duration) -> bool {
    let deadline = Instant::now() + within;
    while Instant::now() < deadline {
        if ok() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    ok()
}

#[test]
fn pulses_follow_the_core_and_a_silent_core_is_trimmed() {
    let tree = fake_tree();
    let root = tree.path();
    let mut trims = [1500u16; 16];
    trims[2] = 1480;
    let deadline = Duration::from_millis(60);
    let outputs = PwmActuators::start(&settings(root), &trims, deadline);
    assert_eq!(
        (duty_ns(root, 0), duty_ns(root, 1)),
        (1_500_000, 1_480_000),
        "trim at start"
    );

    let mut pulses = [0u16; 16];
    pulses[0] = 1300;
    pulses[2] = 1800;
    // Fed every 20 ms (a 50 Hz core): the pulses stay.
    for _ in 0..10 {
        std::thread::sleep(Duration::from_millis(20));
        outputs.apply(&pulses);
    }
    let stalled = Instant::now();
    assert_eq!((duty_ns(root, 0), duty_ns(root, 1)), (1_300_000, 1_800_000));
    assert_eq!(outputs.watchdog_trips(), 0);

    // The core stalls: within a few deadlines every output is at trim.
    assert!(
        wait_for(|| duty_ns(root, 1) == 1_480_000, deadline * 4),
        "throttle still at {} ns",
        duty_ns(root, 1)
    );
    assert!(stalled.elapsed() >= deadline, "trimmed before the deadline");
    assert_eq!(duty_ns(root, 0), 1_500_000);
    assert_eq!(outputs.watchdog_trips(), 1);

    // The core is back: pulses again; then the process ends: trim.
    outputs.apply(&pulses);
    assert_eq!(duty_ns(root, 1), 1_800_000);
    drop(outputs);
    assert_eq!((duty_ns(root, 0), duty_ns(root, 1)), (1_500_000, 1_480_000));
}

#[test]
fn a_missing_pwm_chip_is_retried_not_fatal() {
    let tree = fake_tree();
    let root = tree.path();
    let mut config = settings(root);
    config.root = root.join("not-there");
    let outputs = PwmActuators::start(&config, &[1500; 16], Duration::from_millis(100));
    let status = outputs.status().expect("outputs configured");
    assert!(!status.connected && status.errors >= 1, "{status:?}");
    assert!(status.last_error.is_some_and(|e| e.contains("not-there")));
    outputs.apply(&[1600; 16]);
    drop(outputs);
}
